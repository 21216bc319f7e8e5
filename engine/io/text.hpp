// Internal to engine/io: the line/token reader the text format readers share (TetGen, Gmsh, OBJ,
// OFF, ASCII PLY and STL). Errors are ReadError "file:line: message".
#pragma once
#include <charconv>
#include <cmath>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "io/atomic.hpp"

namespace perifx::io::detail {

// Walks a file's text line by line, yielding the whitespace-separated tokens of each non-empty line.
// `comment` (when not '\0') starts a comment that runs to the end of the line.
class TokenLines {
 public:
  TokenLines(const std::filesystem::path& path, const std::string& kind, char comment = '#')
      : name_(path.string()), text_(read_file(path, kind)), comment_(comment) {}
  // Over text already in memory, starting at byte `offset`, which is just after line `lines_before`.
  TokenLines(std::string name, std::string text, std::size_t offset, std::size_t lines_before, char comment)
      : name_(std::move(name)), text_(std::move(text)), pos_(offset), line_(lines_before), comment_(comment) {}

  // Next line that has at least one token; false at end of file.
  bool next(std::vector<std::string_view>& tokens) {
    while (pos_ < text_.size()) {
      std::size_t end = text_.find('\n', pos_);
      if (end == std::string::npos) end = text_.size();
      std::string_view line(text_.data() + pos_, end - pos_);
      pos_ = end + 1;
      ++line_;
      if (comment_ != '\0') {
        if (const auto c = line.find(comment_); c != std::string_view::npos) line = line.substr(0, c);
      }
      tokens.clear();
      std::size_t i = 0;
      while (i < line.size()) {
        while (i < line.size() && is_space(line[i])) ++i;
        std::size_t j = i;
        while (j < line.size() && !is_space(line[j])) ++j;
        if (j > i) tokens.push_back(line.substr(i, j - i));
        i = j;
      }
      if (!tokens.empty()) return true;
    }
    return false;
  }

  // "file:line: message" for the line last returned by next().
  [[noreturn]] void fail(const std::string& message) const {
    throw ReadError(name_ + ":" + std::to_string(line_) + ": " + message);
  }
  [[noreturn]] void fail_truncated(const std::string& what) const {
    throw ReadError(name_ + ":" + std::to_string(line_) + ": file is truncated: " + what);
  }

  long long integer(std::string_view token, const char* what) const {
    long long value = 0;
    const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (ec != std::errc() || ptr != token.data() + token.size()) {
      fail("bad " + std::string(what) + " '" + std::string(token) + "' (expected an integer)");
    }
    return value;
  }

  double real(std::string_view token, const char* what) const {
    // from_chars does not accept a leading '+', which some writers emit.
    std::string_view t = token;
    if (!t.empty() && t.front() == '+') t.remove_prefix(1);
    double value = 0.0;
    const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
    if (ec != std::errc() || ptr != t.data() + t.size() || !std::isfinite(value)) {
      fail("bad " + std::string(what) + " '" + std::string(token) + "' (expected a finite number)");
    }
    return value;
  }

  // A count read from a header, before anything of that size is allocated: `count` items of at least
  // `min_bytes` each must fit in the rest of the file, else "file:line: <what> N is more than the
  // file can hold".
  void check_fits(long long count, std::size_t min_bytes, const char* what) const {
    const std::size_t rest = pos_ < text_.size() ? text_.size() - pos_ : 0;
    if (count > 0 && double(count) * double(min_bytes) > double(rest) + 1.0)
      fail(std::string(what) + " " + std::to_string(count) + " is more than the file can hold (got " +
           std::to_string(rest) + " bytes after this line; expected at least " + std::to_string(min_bytes) +
           " per item)");
  }

  std::size_t line() const { return line_; }
  std::size_t offset() const { return pos_; }  // start of the line after the last one returned
  const std::string& name() const { return name_; }
  const std::string& text() const { return text_; }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

  std::string name_;
  std::string text_;
  std::size_t pos_ = 0;
  std::size_t line_ = 0;
  char comment_ = '#';
};

}  // namespace perifx::io::detail
