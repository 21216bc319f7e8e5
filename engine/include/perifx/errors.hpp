// perifx public API: every error a host can catch. All derive from perifx::Error (a
// std::runtime_error) whose what() is one line naming the file, the JSON pointer or line, the value
// and what was expected, so a host can show it unchanged. The CLI maps them to exit codes
// (README: 2 invalid scene or mesh, 3 output not writable, 7 unstable simulation, 8 not enough memory).
#pragma once
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>

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

// The simulation blew up: World::step found a particle whose position or velocity is not finite, or
// whose speed is beyond the world's bound (StepSettings::max_speed: 10 × the fastest material wave
// speed plus every prescribed, initial, collider, projectile and gravity speed). Thrown after the
// step that produced it, before any frame of that state is written. what() is one line:
//   "<scene file>: /bodies/<k>: <problem> (got <value>; expected <what>); hint: <advice>"
class InstabilityError : public Error {
 public:
  InstabilityError(std::string message, std::uint64_t step, std::size_t particle)
      : Error(std::move(message)), step_(step), particle_(particle) {}
  std::uint64_t step() const { return step_; }          // the step that produced the bad state
  std::size_t particle() const { return particle_; }    // the lowest-index bad particle

 private:
  std::uint64_t step_ = 0;
  std::size_t particle_ = 0;
};

}  // namespace perifx
