// perifx public API: every error a host can catch. All derive from perifx::Error (a
// std::runtime_error) whose what() is one line naming the file, the JSON pointer or line, the value
// and what was expected, so a host can show it unchanged. The CLI maps them to exit codes
// (README: 2 invalid scene or mesh, 3 output not writable).
#pragma once
#include <stdexcept>
#include <string>

namespace perifx {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace scene {
// A scene that cannot be used. what() is the full one-line message:
//   "<file>: <json pointer>: <problem> (got <value>; expected <what>)"
class SceneError : public Error {
 public:
  SceneError(std::string file, std::string pointer, std::string message)
      : Error(file + ": " + (pointer.empty() ? "" : pointer + ": ") + message),
        file_(std::move(file)),
        pointer_(std::move(pointer)),
        message_(std::move(message)) {}
  const std::string& file() const { return file_; }
  const std::string& pointer() const { return pointer_; }
  const std::string& message() const { return message_; }

 private:
  std::string file_, pointer_, message_;
};
}  // namespace scene

namespace geometry {
// A mesh that cannot be used; what() names the file and line when there is one.
class GeometryError : public Error {
 public:
  using Error::Error;
};
}  // namespace geometry

namespace io {
// An output file that could not be written (or an input file that could not be read); what() names
// the path and the operating system's reason.
class IoError : public Error {
 public:
  using Error::Error;
};
}  // namespace io

}  // namespace perifx
