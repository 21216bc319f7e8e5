// Shared by the geometry tests: the fixture folder and a self-removing temporary directory.
#pragma once
#include <stdlib.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>

namespace perifx::test {

// Fixture directory: from the build's PERIFX_SOURCE_DIR, else from this file's own location.
inline std::filesystem::path geometry_data_dir() {
#ifdef PERIFX_SOURCE_DIR
  return std::filesystem::path(PERIFX_SOURCE_DIR) / "tests" / "engine" / "geometry" / "data";
#else
  return std::filesystem::path(__FILE__).parent_path() / "data";
#endif
}

// A fresh directory under the system temp dir, removed when the test ends.
struct TempDir {
  std::filesystem::path path;
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "perifx_test_XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

}  // namespace perifx::test
