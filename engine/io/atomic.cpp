// Atomic writes (see atomic.hpp) and the whole-file reader the format readers share.
#include "io/atomic.hpp"

#include <fcntl.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <fstream>
#include <iterator>
#include <system_error>
#include <utility>

namespace perifx::io {

namespace fs = std::filesystem;

namespace {

std::string errno_text(int err) {
  // errno can be 0 when a stream fails without a system call failing (e.g. a fill that set
  // failbit itself); say so instead of printing "Success".
  return err != 0 ? std::string(std::strerror(err)) : std::string("stream error");
}

[[noreturn]] void fail(const std::string& what, const fs::path& path, const std::string& why) {
  throw IoError(what + " '" + path.string() + "': " + why);
}

// Removes the temporary file unless the write completed; covers exceptions thrown by `fill` too.
class TempFileGuard {
 public:
  explicit TempFileGuard(fs::path p) : path_(std::move(p)) {}
  TempFileGuard(const TempFileGuard&) = delete;
  TempFileGuard& operator=(const TempFileGuard&) = delete;
  ~TempFileGuard() {
    if (armed_) {
      std::error_code ec;  // best effort: we are already reporting a more useful error
      fs::remove(path_, ec);
    }
  }
  void release() { armed_ = false; }

 private:
  fs::path path_;
  bool armed_ = true;
};

// std::ofstream cannot give us its descriptor, so sync by reopening the file: on Linux (and POSIX
// in practice) fsync flushes the inode's dirty pages whichever descriptor they were written through.
// O_WRONLY rather than O_RDONLY because some systems reject fsync on read-only descriptors.
void fsync_file(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) fail("cannot reopen for fsync", path, errno_text(errno));
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    fail("fsync failed for", path, errno_text(err));
  }
  if (::close(fd) != 0) fail("close failed for", path, errno_text(errno));
}

// Makes the rename itself durable. Best effort: the target is already complete and in place, and
// some filesystems do not support syncing directories, so a failure here is not worth an error.
void fsync_directory_best_effort(const fs::path& dir) {
  const fs::path d = dir.empty() ? fs::path(".") : dir;
  const int fd = ::open(d.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  (void)::fsync(fd);
  ::close(fd);
}

}  // namespace

void write_atomic(const fs::path& target, const std::function<void(std::ostream&)>& fill) {
  if (target.empty() || !target.has_filename()) fail("cannot write", target, "not a file path");

  const fs::path dir = target.parent_path();
  if (!dir.empty()) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) fail("cannot create directory", dir, ec.message() + " (writing '" + target.string() + "')");
  }

  // Same directory as the target so the rename stays on one filesystem and is atomic. The pid keeps
  // two processes writing the same target (e.g. a rerun racing a stale one) off each other's temp.
  fs::path tmp = target;
  tmp += ".tmp-" + std::to_string(::getpid());
  TempFileGuard guard(tmp);

  {
    std::ofstream os;
    errno = 0;
    os.open(tmp, std::ios::binary | std::ios::out | std::ios::trunc);
    if (!os.is_open()) fail("cannot create", tmp, errno_text(errno));

    // Exceptions from `fill` propagate unchanged (the caller's error is more telling than ours);
    // the guard removes the temporary and the target is untouched.
    errno = 0;
    fill(os);
    if (!os) fail("write failed for", tmp, errno_text(errno));
    errno = 0;
    os.flush();
    if (!os) fail("flush failed for", tmp, errno_text(errno));
    errno = 0;
    os.close();
    if (os.fail()) fail("close failed for", tmp, errno_text(errno));
  }

  fsync_file(tmp);

  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) fail("cannot rename '" + tmp.string() + "' to", target, ec.message());
  guard.release();

  fsync_directory_best_effort(dir);
}

std::string read_file(const fs::path& path, const std::string& kind) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw ReadError(kind + " file '" + path.string() + "' does not exist");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ReadError("cannot open " + kind + " file '" + path.string() + "'");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw ReadError("error reading '" + path.string() + "'");
  return text;
}

}  // namespace perifx::io

namespace perifx::io {

std::size_t remove_stale_temporaries(const std::filesystem::path& dir) {
  std::size_t removed = 0;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const auto at = name.rfind(".tmp-");
    if (at == std::string::npos || at + 5 == name.size()) continue;
    const std::string digits = name.substr(at + 5);
    if (digits.size() > 9 || !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
      continue;
    const auto pid = static_cast<pid_t>(std::stol(digits));
    if (pid > 0 && (::kill(pid, 0) == 0 || errno == EPERM)) continue;  // its writer is still running
    std::error_code remove_ec;
    if (it->is_regular_file(remove_ec) && fs::remove(it->path(), remove_ec)) ++removed;
  }
  return removed;
}

}  // namespace perifx::io
