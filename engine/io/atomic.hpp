// Atomic file writes and whole-file reads, the two primitives every format in engine/io builds on.
// Every file is written to "<name>.tmp-<pid>" in the same directory, flushed, fsynced, then renamed
// over the target, so readers never see a half-written file, even after a crash or kill.
#pragma once
#include <filesystem>
#include <functional>
#include <ostream>
#include <stdexcept>
#include <string>

#include "perifx/errors.hpp"

namespace perifx::io {

// IoError (a file could not be written; exit code 3 in the CLI) is public: perifx/errors.hpp.

// A file could not be read or parsed; what() names the file (and the line, for text formats).
// Engine code that reads input (geometry) rethrows it as its own error type.
class ReadError : public Error {
 public:
  using Error::Error;
};

// Writes through `fill` into a temporary file, then renames it to `target`. Throws IoError naming
// the path and the OS error on failure (and removes the temporary).
void write_atomic(const std::filesystem::path& target, const std::function<void(std::ostream&)>& fill);

// Removes "<name>.tmp-<pid>" files in `dir` left by killed runs: those whose pid is not a running
// process (a live writer's temporaries are kept). Returns how many were removed; a missing
// directory is not an error.
std::size_t remove_stale_temporaries(const std::filesystem::path& dir);

// The whole content of a file (binary-safe). `kind` names the file in messages ("Gmsh mesh"):
// "<kind> file '<path>' does not exist", "cannot open <kind> file '<path>'".
std::string read_file(const std::filesystem::path& path, const std::string& kind);

// Runs `read` and turns a `From` error into a `To` error with the same message (each layer reports
// reading failures with its own error type; the message, which names the file, stays as it is).
template <class From, class To, class Read>
auto rethrow_as(Read&& read) {
  try {
    return read();
  } catch (const From& e) {
    throw To(e.what());
  }
}

}  // namespace perifx::io
