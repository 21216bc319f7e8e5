// TetGen files (see tetgen.hpp). Errors name the file and line so a user can fix a hand-edited or
// truncated file without a debugger.
#include "io/tetgen.hpp"

#include <iomanip>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "io/atomic.hpp"
#include "io/text.hpp"

namespace perifx::io {

namespace fs = std::filesystem;

namespace {

using detail::TokenLines;

// The .ele beside a .node: "mesh.1.node" -> "mesh.1.ele".
fs::path ele_path_for(const fs::path& node_file) {
  fs::path ele = node_file;
  if (ele.extension() == ".node") {
    ele.replace_extension(".ele");
  } else {
    ele += ".ele";
  }
  return ele;
}

}  // namespace

TetFile read_tetgen(const fs::path& node_file) {
  std::error_code ec;
  if (!fs::is_regular_file(node_file, ec)) {
    throw ReadError("TetGen node file '" + node_file.string() + "' does not exist");
  }
  const fs::path ele_file = ele_path_for(node_file);
  if (!fs::is_regular_file(ele_file, ec)) {
    throw ReadError("TetGen element file '" + ele_file.string() + "' (expected beside '" +
                        node_file.string() + "') does not exist");
  }

  TetFile mesh;
  std::vector<std::string_view> tok;

  // --- .node: header "<#points> <dim> <#attributes> <#boundary markers>" ---
  TokenLines node(node_file, "TetGen node");
  if (!node.next(tok)) node.fail_truncated("missing the header line");
  const long long npoints = node.integer(tok[0], "point count");
  if (npoints < 0 || npoints > static_cast<long long>(UINT32_MAX)) {
    node.fail("point count " + std::to_string(npoints) + " is out of range");
  }
  if (tok.size() >= 2) {
    const long long dim = node.integer(tok[1], "dimension");
    if (dim != 3) node.fail("dimension is " + std::to_string(dim) + "; only 3-D meshes are supported");
  }
  node.check_fits(npoints, 8, "point count");  // "i x y z\n"
  mesh.vertices.resize(static_cast<std::size_t>(npoints));
  long long base = 0;  // 0 or 1, taken from the first point's index
  for (long long k = 0; k < npoints; ++k) {
    if (!node.next(tok)) {
      node.fail_truncated("expected " + std::to_string(npoints) + " points, found " + std::to_string(k));
    }
    if (tok.size() < 4) node.fail("a point line needs '<index> x y z', found " + std::to_string(tok.size()) + " fields");
    const long long index = node.integer(tok[0], "point index");
    if (k == 0) {
      if (index != 0 && index != 1) node.fail("first point index is " + std::to_string(index) + "; expected 0 or 1");
      base = index;
    } else if (index != base + k) {
      // Point indices are positions in the list; a gap or repeat would silently shift every tet.
      node.fail("point index " + std::to_string(index) + " out of sequence (expected " + std::to_string(base + k) + ")");
    }
    mesh.vertices[static_cast<std::size_t>(k)] =
        Vec3(node.real(tok[1], "x coordinate"), node.real(tok[2], "y coordinate"), node.real(tok[3], "z coordinate"));
  }

  // --- .ele: header "<#tets> <nodes per tet> <#attributes>" ---
  TokenLines ele(ele_file, "TetGen element");
  if (!ele.next(tok)) ele.fail_truncated("missing the header line");
  const long long ntets = ele.integer(tok[0], "tet count");
  if (ntets < 0 || ntets > static_cast<long long>(UINT32_MAX / 4)) {
    ele.fail("tet count " + std::to_string(ntets) + " is out of range");
  }
  long long per_tet = 4;
  if (tok.size() >= 2) per_tet = ele.integer(tok[1], "nodes per tet");
  if (per_tet != 4 && per_tet != 10) {
    ele.fail("nodes per tet is " + std::to_string(per_tet) + "; expected 4 or 10");
  }
  ele.check_fits(ntets, 10, "tet count");  // "i a b c d\n"
  mesh.tets.resize(static_cast<std::size_t>(ntets));
  mesh.tet_line.resize(mesh.tets.size());
  mesh.tet_id.resize(mesh.tets.size());
  mesh.tet_word = "tet";
  mesh.tet_source = ele_file.string();
  for (long long k = 0; k < ntets; ++k) {
    if (!ele.next(tok)) {
      ele.fail_truncated("expected " + std::to_string(ntets) + " tets, found " + std::to_string(k));
    }
    if (static_cast<long long>(tok.size()) < 1 + per_tet) {
      ele.fail("a tet line needs '<index>' and " + std::to_string(per_tet) + " point indices, found " +
               std::to_string(tok.size()) + " fields");
    }
    const std::string_view tet_index = tok[0];
    std::array<std::uint32_t, 4> tet{};
    // Only the corners: the 6 mid-edge nodes of a quadratic tet are not used by the model.
    for (std::size_t i = 0; i < 4; ++i) {
      const long long v = ele.integer(tok[1 + i], "point index") - base;
      if (v < 0 || v >= npoints) {
        ele.fail("tet " + std::string(tet_index) + ": point index " + std::string(tok[1 + i]) +
                 " is out of range (points are " + std::to_string(base) + ".." + std::to_string(base + npoints - 1) + ")");
      }
      tet[i] = static_cast<std::uint32_t>(v);
    }

    mesh.tet_line[static_cast<std::size_t>(k)] = ele.line();
    mesh.tet_id[static_cast<std::size_t>(k)] = ele.integer(tet_index, "tet index");
    mesh.tets[static_cast<std::size_t>(k)] = tet;
  }
  // A .face/.edge/.neigh beside the .node (TetGen writes them) is not needed and is ignored.
  return mesh;
}

void write_tetgen_smesh(const fs::path& target, const std::vector<Vec3>& vertices,
                        const std::vector<std::array<std::uint32_t, 3>>& triangles) {
  std::ostringstream out;
  out << std::setprecision(17);
  out << vertices.size() << " 3 0 0\n";
  for (std::size_t v = 0; v < vertices.size(); ++v)
    out << v + 1 << ' ' << vertices[v].x() << ' ' << vertices[v].y() << ' ' << vertices[v].z() << '\n';
  out << triangles.size() << " 0\n";
  for (const auto& t : triangles) out << "3 " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
  out << "0\n0\n";  // no holes, no regions
  const std::string text = out.str();
  write_atomic(target, [&](std::ostream& os) { os.write(text.data(), static_cast<std::streamsize>(text.size())); });
}

}  // namespace perifx::io
