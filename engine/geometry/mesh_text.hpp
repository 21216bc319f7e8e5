// Internal to engine/geometry: the line/token reader shared by the mesh file loaders, and small
// mesh checks they all apply. Errors are GeometryError "file:line: message".
#pragma once
#include <charconv>
#include <cmath>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "geometry/geometry.hpp"

namespace perifx::geometry::detail {

// The whole text of a file (binary-safe). `kind` names the file in messages ("Gmsh mesh").
std::string read_whole_file(const std::filesystem::path& path, const std::string& kind);

// Walks a file's text line by line, yielding the whitespace-separated tokens of each non-empty line.
// `comment` (when not '\0') starts a comment that runs to the end of the line.
class TokenLines {
 public:
  TokenLines(const std::filesystem::path& path, const std::string& kind, char comment = '#')
      : name_(path.string()), text_(read_whole_file(path, kind)), comment_(comment) {}
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
    throw GeometryError(name_ + ":" + std::to_string(line_) + ": " + message);
  }
  [[noreturn]] void fail_truncated(const std::string& what) const {
    throw GeometryError(name_ + ":" + std::to_string(line_) + ": file is truncated: " + what);
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

// Signed volume of the tet (a, b, c, d), > 0 when positively oriented.
double signed_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);
// Orients a tet read from a file: flips negative ones, and returns false for a degenerate one (volume
// ≤ 1e-12 of its mean edge cubed); `volume` and `mean_edge` are set for the caller's message.
bool orient_tet(const std::vector<Vec3>& vertices, std::array<std::uint32_t, 4>& tet, double& volume,
                double& mean_edge);
// Drops vertices no tet uses (keeping the order of the rest) and renumbers the tets.
void compact_vertices(TetMesh& mesh);
// Throws "<source>: mesh has K disconnected pieces ..." when the tets form more than one group
// linked by shared vertices (also rejects non-manifold faces, via face_neighbors).
void require_one_piece(const TetMesh& mesh, const std::string& source);

}  // namespace perifx::geometry::detail
