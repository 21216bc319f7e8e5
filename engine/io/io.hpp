// File output. Every file is written to "<name>.tmp-<pid>" in the same directory, flushed, then
// renamed over the target, so readers never see a half-written file, even after a crash or kill.
#pragma once
#include <filesystem>
#include <functional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "components/field_registry.hpp"
#include "components/math.hpp"

namespace perifx::io {

class IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Writes through `fill` into a temporary file, then renames it to `target`. Throws IoError naming
// the path and the OS error on failure (and removes the temporary).
void write_atomic(const std::filesystem::path& target, const std::function<void(std::ostream&)>& fill);

// Particles as a VTK XML UnstructuredGrid (one vertex cell per point), binary appended raw data,
// little endian, readable by ParaView. Fields must have location particle and count == points.size().
void write_vtu_points(const std::filesystem::path& target, const std::vector<Vec3>& points,
                      const std::vector<FieldView>& fields);

// Particles as binary little-endian PLY points: x y z as float, then each field as properties
// (vectors become name_x name_y name_z). Houdini and Blender import these.
void write_ply_points(const std::filesystem::path& target, const std::vector<Vec3>& points,
                      const std::vector<FieldView>& fields);

// A ParaView .pvd collection, rewritten atomically each time a frame is added.
class PvdSeries {
 public:
  explicit PvdSeries(std::filesystem::path target);
  void add(double time, const std::filesystem::path& file);  // file: relative to the .pvd's folder
 private:
  std::filesystem::path target_;
  std::vector<std::pair<double, std::string>> entries_;
};

}  // namespace perifx::io
