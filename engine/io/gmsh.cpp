// Gmsh .msh input, ASCII formats 2.2 and 4.1 (see gmsh.hpp). Only tetrahedra matter to the model;
// every other element type, and every section other than the format, nodes and elements, is skipped.
#include <cstdint>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "io/gmsh.hpp"
#include "io/text.hpp"

namespace perifx::io {

namespace {

using detail::TokenLines;

constexpr long long kTet4 = 4;    // 4-node tetrahedron
constexpr long long kTet10 = 11;  // 10-node tetrahedron: corners first

struct PendingTet {
  std::array<long long, 4> tags;  // node tags, resolved once all nodes are known
  std::size_t line;
  long long element;
};

class GmshReader {
 public:
  explicit GmshReader(const std::filesystem::path& file) : in_(file, "Gmsh mesh", '\0') {}

  TetFile read() {
    while (in_.next(tok_)) {
      const std::string_view head = tok_[0];
      if (head == "$MeshFormat") {
        format();
      } else if (head == "$Nodes") {
        require_format();
        if (major_ == 2) nodes_v2(); else nodes_v4();
        end_section("$EndNodes");
      } else if (head == "$Elements") {
        require_format();
        if (major_ == 2) elements_v2(); else elements_v4();
        end_section("$EndElements");
      } else if (head.size() > 1 && head[0] == '$' && head.substr(0, 4) != "$End") {
        skip_section(head);
      } else {
        in_.fail("unexpected '" + std::string(head) + "' outside a section (expected a line like $Nodes)");
      }
    }
    if (major_ == 0) in_.fail("no $MeshFormat section: not a Gmsh .msh file");
    return build();
  }

 private:
  void format() {
    if (!in_.next(tok_)) in_.fail_truncated("$MeshFormat has no version line");
    const std::string version(tok_[0]);
    if (version == "2" || version == "2.0" || version == "2.1" || version == "2.2") {
      major_ = 2;
    } else if (version == "4.1") {
      major_ = 4;
    } else {
      in_.fail("Gmsh format version " + version + " is not supported (expected 2.2 or 4.1; "
               "re-export with gmsh -format msh41 or msh22)");
    }
    if (tok_.size() >= 2 && tok_[1] != "0") {
      in_.fail("binary .msh files are not supported; save as ASCII (gmsh option -bin 0)");
    }
    end_section("$EndMeshFormat");
  }

  void require_format() const {
    if (major_ == 0) in_.fail("'" + std::string(tok_[0]) + "' before $MeshFormat");
  }

  void end_section(const char* end) {
    if (!in_.next(tok_)) in_.fail_truncated(std::string("missing ") + end);
    if (tok_[0] != end) in_.fail("expected " + std::string(end) + ", found '" + std::string(tok_[0]) + "'");
  }

  void skip_section(std::string_view head) {
    const std::string end = "$End" + std::string(head.substr(1));
    const std::size_t start = in_.line();
    while (in_.next(tok_)) {
      if (tok_[0] == end) return;
    }
    in_.fail_truncated("section " + std::string(head) + " opened on line " + std::to_string(start) +
                       " has no " + end);
  }

  long long count(std::string_view token, const char* what) const {
    const long long n = in_.integer(token, what);
    if (n < 0 || n > static_cast<long long>(UINT32_MAX / 4)) in_.fail(std::string(what) + " " + std::to_string(n) + " is out of range");
    in_.check_fits(n, 2, what);  // every node, element or block takes a line
    return n;
  }

  void add_node(long long tag, std::string_view x, std::string_view y, std::string_view z) {
    const Vec3 p(in_.real(x, "x coordinate"), in_.real(y, "y coordinate"), in_.real(z, "z coordinate"));
    if (!index_.emplace(tag, static_cast<std::uint32_t>(vertices_.size())).second) {
      in_.fail("node tag " + std::to_string(tag) + " appears twice");
    }
    vertices_.push_back(p);
  }

  void need_line(const std::string& what) {
    if (!in_.next(tok_)) in_.fail_truncated(what);
    if (tok_[0].size() > 0 && tok_[0][0] == '$') in_.fail("section ends early: expected " + what + ", found '" + std::string(tok_[0]) + "'");
  }

  // 2.2: "<count>", then "<tag> x y z" lines.
  void nodes_v2() {
    need_line("the node count");
    const long long n = count(tok_[0], "node count");
    for (long long k = 0; k < n; ++k) {
      need_line("node " + std::to_string(k + 1) + " of " + std::to_string(n));
      if (tok_.size() < 4) in_.fail("a node line needs '<tag> x y z', found " + std::to_string(tok_.size()) + " fields");
      add_node(in_.integer(tok_[0], "node tag"), tok_[1], tok_[2], tok_[3]);
    }
  }

  // 4.1: "<blocks> <nodes> <min tag> <max tag>", then per block "<dim> <entity> <parametric> <n>",
  // n tag lines, n coordinate lines "x y z [u v w]".
  void nodes_v4() {
    need_line("the $Nodes header");
    if (tok_.size() < 4) in_.fail("$Nodes header needs '<blocks> <nodes> <min tag> <max tag>'");
    const long long blocks = count(tok_[0], "block count");
    for (long long b = 0; b < blocks; ++b) {
      need_line("node block " + std::to_string(b + 1) + " of " + std::to_string(blocks));
      if (tok_.size() < 4) in_.fail("a node block header needs '<dim> <entity> <parametric> <count>'");
      const long long n = count(tok_[3], "node count");
      std::vector<long long> tags;
      tags.reserve(static_cast<std::size_t>(n));
      while (static_cast<long long>(tags.size()) < n) {
        need_line("node tags of block " + std::to_string(b + 1));
        for (std::string_view t : tok_) tags.push_back(in_.integer(t, "node tag"));
      }
      if (static_cast<long long>(tags.size()) != n) in_.fail("more node tags than the block's count " + std::to_string(n));
      for (long long k = 0; k < n; ++k) {
        need_line("coordinates of node " + std::to_string(tags[static_cast<std::size_t>(k)]));
        if (tok_.size() < 3) in_.fail("a coordinate line needs 'x y z', found " + std::to_string(tok_.size()) + " fields");
        add_node(tags[static_cast<std::size_t>(k)], tok_[0], tok_[1], tok_[2]);
      }
    }
  }

  void add_tet(long long element, std::size_t first_node) {
    PendingTet t{};
    for (std::size_t i = 0; i < 4; ++i) t.tags[i] = in_.integer(tok_[first_node + i], "node tag");
    t.line = in_.line();
    t.element = element;
    tets_.push_back(t);
  }

  // 2.2: "<count>", then "<tag> <type> <ntags> <tags...> <nodes...>".
  void elements_v2() {
    need_line("the element count");
    const long long n = count(tok_[0], "element count");
    for (long long k = 0; k < n; ++k) {
      need_line("element " + std::to_string(k + 1) + " of " + std::to_string(n));
      if (tok_.size() < 3) in_.fail("an element line needs '<tag> <type> <ntags> ...'");
      const long long tag = in_.integer(tok_[0], "element tag");
      const long long type = in_.integer(tok_[1], "element type");
      if (type != kTet4 && type != kTet10) continue;
      const long long ntags = in_.integer(tok_[2], "tag count");
      const long long nodes = type == kTet4 ? 4 : 10;
      if (ntags < 0 || static_cast<long long>(tok_.size()) < 3 + ntags + nodes) {
        in_.fail("tetrahedron " + std::to_string(tag) + " needs " + std::to_string(ntags) + " tags and " +
                 std::to_string(nodes) + " nodes, found " + std::to_string(tok_.size()) + " fields");
      }
      add_tet(tag, static_cast<std::size_t>(3 + ntags));
    }
  }

  // 4.1: "<blocks> <elements> <min tag> <max tag>", then per block "<dim> <entity> <type> <n>" and
  // n lines "<tag> <nodes...>".
  void elements_v4() {
    need_line("the $Elements header");
    if (tok_.size() < 4) in_.fail("$Elements header needs '<blocks> <elements> <min tag> <max tag>'");
    const long long blocks = count(tok_[0], "block count");
    for (long long b = 0; b < blocks; ++b) {
      need_line("element block " + std::to_string(b + 1) + " of " + std::to_string(blocks));
      if (tok_.size() < 4) in_.fail("an element block header needs '<dim> <entity> <type> <count>'");
      const long long type = in_.integer(tok_[2], "element type");
      const long long n = count(tok_[3], "element count");
      const bool tet = type == kTet4 || type == kTet10;
      const std::size_t nodes = type == kTet4 ? 4 : 10;
      for (long long k = 0; k < n; ++k) {
        need_line("element " + std::to_string(k + 1) + " of block " + std::to_string(b + 1));
        if (!tet) continue;
        if (tok_.size() < 1 + nodes) {
          in_.fail("a tetrahedron line needs '<tag>' and " + std::to_string(nodes) + " node tags, found " +
                   std::to_string(tok_.size()) + " fields");
        }
        add_tet(in_.integer(tok_[0], "element tag"), 1);
      }
    }
  }

  [[noreturn]] void fail_at(std::size_t line, const std::string& message) const {
    throw ReadError(in_.name() + ":" + std::to_string(line) + ": " + message);
  }

  TetFile build() {
    if (tets_.empty()) {
      throw ReadError(in_.name() + ": no tetrahedra (element type 4) in the file; mesh the volume "
                          "(Gmsh: Mesh > 3D, or gmsh -3) before saving");
    }
    TetFile mesh;
    mesh.vertices = std::move(vertices_);
    mesh.tet_word = "tetrahedron";
    mesh.tet_source = in_.name();
    mesh.tets.reserve(tets_.size());
    for (const PendingTet& p : tets_) {
      std::array<std::uint32_t, 4> tet{};
      for (std::size_t i = 0; i < 4; ++i) {
        const auto it = index_.find(p.tags[i]);
        if (it == index_.end()) {
          fail_at(p.line, "tetrahedron " + std::to_string(p.element) + " uses node " + std::to_string(p.tags[i]) +
                              ", which is not in $Nodes");
        }
        tet[i] = it->second;
      }
      mesh.tets.push_back(tet);
      mesh.tet_line.push_back(p.line);
      mesh.tet_id.push_back(p.element);
    }
    return mesh;
  }

  TokenLines in_;
  std::vector<std::string_view> tok_;
  int major_ = 0;
  std::vector<Vec3> vertices_;
  std::unordered_map<long long, std::uint32_t> index_;
  std::vector<PendingTet> tets_;
};

}  // namespace

TetFile read_gmsh(const std::filesystem::path& file) { return GmshReader(file).read(); }

}  // namespace perifx::io
