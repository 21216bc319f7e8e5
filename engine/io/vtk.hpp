// VTK XML files: one appended-raw-data writer (VtkAppendedWriter) behind the particle VTU, the
// surface VTP and the tet VTU, the ParaView .pvd collection, and the readers for both (what
// run_dir.cpp uses to read frames back).
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <ostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "components/embedded_mesh.hpp"
#include "perifx/fields.hpp"
#include "components/math.hpp"

namespace perifx::io {

// A VTK XML file whose arrays are raw appended blocks, each a UInt64 byte count and the bytes,
// little endian. Arrays are declared in file order inside sections (<PointData>, <Points>, ...);
// their blocks follow in the same order after the '_' marker.
class VtkAppendedWriter {
 public:
  // dataset: "UnstructuredGrid" or "PolyData"; piece_attributes: the <Piece> attributes, e.g.
  // NumberOfPoints="8" NumberOfCells="8".
  VtkAppendedWriter(std::string dataset, const std::string& piece_attributes);
  void begin_section(std::string_view name);  // e.g. "PointData"
  void end_section();
  // An array whose payload is `bytes` bytes at `data` (kept by pointer until write()). components
  // 0 leaves the NumberOfComponents attribute out (VTK then reads 1).
  void add_array(std::string_view vtk_type, std::string_view name, int components, const void* data, std::size_t bytes);
  // An array whose payload is produced at write time (must write exactly `bytes` bytes).
  void add_array(std::string_view vtk_type, std::string_view name, int components, std::size_t bytes,
                 std::function<void(std::ostream&)> payload);
  // Writes the file atomically (write_atomic).
  void write(const std::filesystem::path& target) const;

 private:
  std::string dataset_;
  std::string xml_;
  std::uint64_t offset_ = 0;
  std::vector<std::pair<std::uint64_t, std::function<void(std::ostream&)>>> blocks_;
  std::string section_;
};

// Particles as a VTK XML UnstructuredGrid (one vertex cell per point), binary appended raw data,
// little endian, readable by ParaView. Fields must have location particle and count == points.size().
void write_vtu_points(const std::filesystem::path& target, const std::vector<Vec3>& points,
                      const std::vector<FieldView>& fields);
// Surface as VTK XML PolyData (.vtp), vertices split along crack rims (io/render_surface.hpp), with
// point data normal, velocity, reference (Float64 ×3) and source (UInt32), cell data crack (UInt8),
// fragment (UInt32, stable piece id) and tet (UInt32): what the
// surface.pvd series lists (ParaView's .pvd reader takes VTK XML files only).
void write_vtp_surface(const std::filesystem::path& target, const SurfaceMesh& surface);
// Tet mesh as VTK XML UnstructuredGrid (VTK_TETRA cells) with per-cell damage (Float64) and
// fragment (UInt32); both arrays have one value per tet.
void write_vtu_tets(const std::filesystem::path& target, const std::vector<Vec3>& vertices,
                    const std::vector<std::array<std::uint32_t, 4>>& tets, const std::vector<double>& damage,
                    const std::vector<std::uint32_t>& fragment);

// A ParaView .pvd collection, rewritten atomically each time a frame is added.
class PvdSeries {
 public:
  explicit PvdSeries(std::filesystem::path target);
  void add(double time, const std::filesystem::path& file);  // file: relative to the .pvd's folder
  // The entries so far, and a series continued from them (a resumed run; nothing is written).
  const std::vector<std::pair<double, std::string>>& entries() const { return entries_; }
  void restore(std::vector<std::pair<double, std::string>> entries) { entries_ = std::move(entries); }
 private:
  std::filesystem::path target_;
  std::vector<std::pair<double, std::string>> entries_;
};

// ---- Reading ----

struct PvdEntry {
  double time = 0.0;
  std::filesystem::path file;  // as written in the collection (relative to the .pvd's folder)
};
// The <DataSet> entries of a .pvd, in file order. Throws ReadError "<pvd>: malformed DataSet entry".
std::vector<PvdEntry> read_pvd(const std::filesystem::path& pvd);

// The arrays of a VTK XML file with raw appended data (UInt64 or UInt32 block headers, little
// endian), converted to double. Arrays inside <Points> are stored under the name "Points".
struct VtkArrays {
  std::size_t points = 0;                            // <Piece NumberOfPoints>
  std::map<std::string, std::vector<double>> arrays;  // by name
};
// Reads only the arrays `wanted` accepts by name (the points always). Throws ReadError
// "cannot read '<file>': <why>".
VtkArrays read_vtk_arrays(const std::filesystem::path& file, const std::function<bool(const std::string&)>& wanted);

}  // namespace perifx::io
