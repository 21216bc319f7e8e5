// Internal to engine/io: the checks the writers apply before touching the disk, so bad input never
// costs a partial file: particle fields (VTU in vtk.cpp, PLY in ply.cpp) and surfaces (OBJ, PLY, VTP).
#pragma once
#include <cmath>
#include <filesystem>
#include <string>
#include <unordered_set>
#include <vector>

#include "components/embedded_mesh.hpp"
#include "perifx/fields.hpp"
#include "io/atomic.hpp"

namespace perifx::io::detail {

[[noreturn]] inline void fail_write(const std::filesystem::path& target, const std::string& why) {
  throw IoError("cannot write '" + target.string() + "': " + why);
}

inline void check_particle_fields(const std::filesystem::path& target, const std::vector<FieldView>& fields,
                                  std::size_t n) {
  std::unordered_set<std::string> names;
  for (const FieldView& f : fields) {
    const std::string label = "field '" + f.name + "'";
    if (f.name.empty()) fail_write(target, "a field has an empty name");
    if (!names.insert(f.name).second) fail_write(target, label + " appears twice");
    if (f.location != FieldLocation::particle) fail_write(target, label + " is not a particle field");
    if (f.count != n)
      fail_write(target, label + " has " + std::to_string(f.count) + " tuples for " + std::to_string(n) + " points");
    if (f.components < 1) fail_write(target, label + " has fewer than one component");
    if (field_type_size(f.type) == 0) fail_write(target, label + " has an unknown type");
    if (n > 0 && f.data == nullptr) fail_write(target, label + " has no data");
  }
}

inline std::size_t field_bytes(const FieldView& f) {
  return f.count * static_cast<std::size_t>(f.components) * field_type_size(f.type);
}

// Derived outputs (vertex positions and velocities, poses) are checked finite before anything is
// written: a NaN there is a bug upstream (a fit or rotation of a degenerate matrix), and a file with
// it breaks the importers (the glTF validator rejects it; Blender and game engines draw nothing).
inline void check_finite(const std::filesystem::path& target, const float* values, std::size_t count, const std::string& what) {
  for (std::size_t k = 0; k < count; ++k)
    if (!std::isfinite(values[k]))
      fail_write(target, what + " " + std::to_string(k / 3) + " is not finite (nothing written)");
}

inline void check_surface(const std::filesystem::path& target, const SurfaceMesh& s) {
  const std::size_t n = s.triangles.size();
  if (s.crack.size() != n || s.fragment.size() != n) fail_write(target, "surface arrays have different lengths");
  for (const auto& t : s.triangles)
    for (auto v : t)
      if (v >= s.vertices.size()) fail_write(target, "triangle vertex " + std::to_string(v) + " out of range");
  for (std::size_t v = 0; v < s.vertices.size(); ++v)
    if (!s.vertices[v].allFinite() || (v < s.velocity.size() && !s.velocity[v].allFinite()))
      fail_write(target, "surface vertex " + std::to_string(v) + " has a non-finite position or velocity (nothing written)");
}

}  // namespace perifx::io::detail
