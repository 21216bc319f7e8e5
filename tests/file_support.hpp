// Files for tests: a fresh scratch folder per test group and name, and a whole file read as bytes.
#pragma once
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace perifx::test {

// <system temp>/perifx_<group>_<pid>/<name>, emptied; created unless `create` is false (for commands
// that must create their output folder themselves). The pid keeps parallel test processes apart.
inline std::filesystem::path temp_dir(const std::string& group, const std::string& name, bool create = true) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("perifx_" + group + "_" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  if (create) fs::create_directories(dir);
  else fs::create_directories(dir.parent_path());
  return dir;
}

// The file's bytes ("" when it cannot be opened).
inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace perifx::test
