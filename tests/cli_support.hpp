// Runs the perifx command line from a test (the binary's path is the build's PERIFX_CLI macro) and
// captures its exit code and combined stdout/stderr.
#pragma once
#include <doctest/doctest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace perifx::test {

struct CliResult {
  int code;            // exit status, −1 when the process did not exit normally
  std::string output;  // stdout and stderr, interleaved
};

inline CliResult run_cli(const std::string& args) {
  const std::string cmd = std::string(PERIFX_CLI) + " " + args + " 2>&1";
  FILE* pipe = ::popen(cmd.c_str(), "r");
  REQUIRE(pipe != nullptr);
  std::string out;
  std::array<char, 4096> buf;
  while (std::size_t n = std::fread(buf.data(), 1, buf.size(), pipe)) out.append(buf.data(), n);
  const int status = ::pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

}  // namespace perifx::test
