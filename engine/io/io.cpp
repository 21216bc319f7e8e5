// File output: atomic writes, VTU and PLY particle frames, and the ParaView .pvd index.
//
// Everything here is written for two properties: a reader (ParaView following a running simulation,
// a render farm picking up frames) never sees a half-written file, and the bytes of a frame depend
// only on its data, so reruns can be compared with cmp. Hence no timestamps, no locale-dependent
// number formatting, and every file goes through write_atomic.
#include "io/io.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <numeric>
#include <system_error>
#include <unordered_set>
#include <utility>

namespace perifx::io {

namespace fs = std::filesystem;

// The binary blocks are the in-memory bytes of the arrays. Both formats are declared little endian,
// so a big-endian host would need byte swapping; no supported target is big endian, so refuse to
// build rather than silently write wrong files.
static_assert(std::endian::native == std::endian::little, "perifx io writes host-order bytes as little endian");
// Points are written straight from std::vector<Vec3> memory as x0 y0 z0 x1 ..., which needs Vec3 to
// be exactly three packed doubles (true for Eigen::Vector3d: it is not a vectorizable fixed size).
static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");

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

std::string xml_escape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

// Shortest decimal text that parses back to the same double, independent of the global locale
// (a "%g" under a German locale would print a comma and ParaView would misread the time).
std::string double_text(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, res.ptr);
}

const char* vtk_type_name(FieldType t) {
  switch (t) {
    case FieldType::f64: return "Float64";
    case FieldType::f32: return "Float32";
    case FieldType::u32: return "UInt32";
    case FieldType::u16: return "UInt16";
    case FieldType::u8: return "UInt8";
  }
  return nullptr;
}

const char* ply_type_name(FieldType t) {
  switch (t) {
    case FieldType::f64: return "double";
    case FieldType::f32: return "float";
    case FieldType::u32: return "uint";
    case FieldType::u16: return "ushort";
    case FieldType::u8: return "uchar";
  }
  return nullptr;
}

// Validates everything before touching the disk, so a bad field never costs a partially built file.
void check_fields(const fs::path& target, const std::vector<FieldView>& fields, std::size_t n) {
  std::unordered_set<std::string> names;
  for (const FieldView& f : fields) {
    const std::string label = "field '" + f.name + "'";
    if (f.name.empty()) fail("cannot write", target, "a field has an empty name");
    if (!names.insert(f.name).second) fail("cannot write", target, label + " appears twice");
    if (f.location != FieldLocation::particle)
      fail("cannot write", target, label + " is not a particle field");
    if (f.count != n)
      fail("cannot write", target,
           label + " has " + std::to_string(f.count) + " tuples for " + std::to_string(n) + " points");
    if (f.components < 1) fail("cannot write", target, label + " has fewer than one component");
    if (field_type_size(f.type) == 0) fail("cannot write", target, label + " has an unknown type");
    if (n > 0 && f.data == nullptr) fail("cannot write", target, label + " has no data");
  }
}

std::size_t field_bytes(const FieldView& f) {
  return f.count * static_cast<std::size_t>(f.components) * field_type_size(f.type);
}

void write_bytes(std::ostream& os, const void* data, std::size_t bytes) {
  if (bytes > 0) os.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
}

// One appended VTK block: the UInt64 byte count (header_type="UInt64"), then the raw bytes.
void write_vtk_block(std::ostream& os, const void* data, std::size_t bytes) {
  const std::uint64_t header = bytes;
  write_bytes(os, &header, sizeof header);
  write_bytes(os, data, bytes);
}

// PLY property names are whitespace-separated tokens; anything else would corrupt the header.
bool valid_ply_name(const std::string& name) {
  return !name.empty() && std::none_of(name.begin(), name.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return u <= 0x20 || u == 0x7f;
  });
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

void write_vtu_points(const fs::path& target, const std::vector<Vec3>& points,
                      const std::vector<FieldView>& fields) {
  const std::size_t n = points.size();
  check_fields(target, fields, n);

  // Offsets are relative to the first byte after the '_' marker and advance by each block's
  // 8-byte count header plus its payload, in the order the blocks are written below.
  std::uint64_t offset = 0;
  auto next_offset = [&offset](std::size_t payload) {
    const std::uint64_t here = offset;
    offset += sizeof(std::uint64_t) + payload;
    return std::to_string(here);
  };

  const std::string ns = std::to_string(n);
  std::string xml;
  xml.reserve(1024 + 160 * fields.size());
  xml += "<?xml version=\"1.0\"?>\n";
  xml += "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n";
  xml += "  <UnstructuredGrid>\n";
  xml += "    <Piece NumberOfPoints=\"" + ns + "\" NumberOfCells=\"" + ns + "\">\n";
  xml += "      <PointData>\n";
  for (const FieldView& f : fields) {
    xml += "        <DataArray type=\"";
    xml += vtk_type_name(f.type);
    xml += "\" Name=\"" + xml_escape(f.name) + "\" NumberOfComponents=\"" + std::to_string(f.components) +
           "\" format=\"appended\" offset=\"" + next_offset(field_bytes(f)) + "\"/>\n";
  }
  xml += "      </PointData>\n";
  xml += "      <Points>\n";
  xml += "        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\" offset=\"" +
         next_offset(n * 3 * sizeof(double)) + "\"/>\n";
  xml += "      </Points>\n";
  xml += "      <Cells>\n";
  // Int64 so connectivity never overflows, whatever the particle count.
  xml += "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"" +
         next_offset(n * sizeof(std::int64_t)) + "\"/>\n";
  xml += "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"" +
         next_offset(n * sizeof(std::int64_t)) + "\"/>\n";
  xml += "        <DataArray type=\"UInt8\" Name=\"types\" format=\"appended\" offset=\"" +
         next_offset(n * sizeof(std::uint8_t)) + "\"/>\n";
  xml += "      </Cells>\n";
  xml += "    </Piece>\n";
  xml += "  </UnstructuredGrid>\n";
  xml += "  <AppendedData encoding=\"raw\">\n   _";

  static constexpr std::string_view kTail = "\n  </AppendedData>\n</VTKFile>\n";

  write_atomic(target, [&](std::ostream& os) {
    os.write(xml.data(), static_cast<std::streamsize>(xml.size()));
    for (const FieldView& f : fields) write_vtk_block(os, f.data, field_bytes(f));
    write_vtk_block(os, points.data(), n * 3 * sizeof(double));

    // connectivity is 0..n-1 and offsets 1..n: one buffer, filled twice, one bulk write each.
    std::vector<std::int64_t> ints(n);
    std::iota(ints.begin(), ints.end(), std::int64_t{0});
    write_vtk_block(os, ints.data(), n * sizeof(std::int64_t));
    std::iota(ints.begin(), ints.end(), std::int64_t{1});
    write_vtk_block(os, ints.data(), n * sizeof(std::int64_t));
    ints = {};

    constexpr std::uint8_t kVtkVertex = 1;
    const std::vector<std::uint8_t> types(n, kVtkVertex);
    write_vtk_block(os, types.data(), n);

    os.write(kTail.data(), static_cast<std::streamsize>(kTail.size()));
  });
}

void write_ply_points(const fs::path& target, const std::vector<Vec3>& points,
                      const std::vector<FieldView>& fields) {
  const std::size_t n = points.size();
  check_fields(target, fields, n);

  std::string header;
  header += "ply\nformat binary_little_endian 1.0\ncomment perifx\nelement vertex " + std::to_string(n) + "\n";
  // x y z first and as float: Blender's importer looks for exactly these.
  header += "property float x\nproperty float y\nproperty float z\n";

  std::unordered_set<std::string> props{"x", "y", "z"};
  auto add_property = [&](const FieldView& f, const std::string& name) {
    if (!valid_ply_name(name)) fail("cannot write", target, "PLY property name '" + name + "' is not a single token");
    if (!props.insert(name).second) fail("cannot write", target, "PLY property '" + name + "' appears twice");
    header += "property ";
    header += ply_type_name(f.type);
    header += " " + name + "\n";
  };

  // Layout of one interleaved vertex record: 3 floats, then each field's tuple in order.
  std::size_t record = 3 * sizeof(float);
  std::vector<std::size_t> field_offset;
  field_offset.reserve(fields.size());
  for (const FieldView& f : fields) {
    if (f.components == 1) {
      add_property(f, f.name);
    } else if (f.components == 3) {
      for (const char* axis : {"_x", "_y", "_z"}) add_property(f, f.name + axis);
    } else {
      // Not a scalar or a 3-vector (e.g. a tensor): number the components rather than refuse.
      for (int c = 0; c < f.components; ++c) add_property(f, f.name + "_" + std::to_string(c));
    }
    field_offset.push_back(record);
    record += static_cast<std::size_t>(f.components) * field_type_size(f.type);
  }
  header += "end_header\n";

  write_atomic(target, [&](std::ostream& os) {
    os.write(header.data(), static_cast<std::streamsize>(header.size()));

    // Records are assembled in chunks and each chunk written in one call: per-value stream writes
    // are an order of magnitude slower, and a whole-frame buffer would double the frame's memory.
    constexpr std::size_t kChunk = 1 << 15;
    std::vector<char> buf(std::min(n, kChunk) * record);
    for (std::size_t begin = 0; begin < n; begin += kChunk) {
      const std::size_t count = std::min(kChunk, n - begin);
      for (std::size_t i = 0; i < count; ++i) {
        const Vec3& p = points[begin + i];
        const float xyz[3] = {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
        std::memcpy(buf.data() + i * record, xyz, sizeof xyz);
      }
      // Field by field rather than record by record: each source array is then read sequentially.
      for (std::size_t k = 0; k < fields.size(); ++k) {
        const FieldView& f = fields[k];
        const std::size_t tuple = static_cast<std::size_t>(f.components) * field_type_size(f.type);
        const char* src = static_cast<const char*>(f.data) + begin * tuple;
        char* dst = buf.data() + field_offset[k];
        for (std::size_t i = 0; i < count; ++i) std::memcpy(dst + i * record, src + i * tuple, tuple);
      }
      os.write(buf.data(), static_cast<std::streamsize>(count * record));
    }
  });
}

PvdSeries::PvdSeries(fs::path target) : target_(std::move(target)) {}

void PvdSeries::add(double time, const fs::path& file) {
  // A NaN time would never compare equal, so restarts could not replace it, and ParaView cannot
  // order it anyway.
  if (!std::isfinite(time)) fail("cannot add a non-finite time to", target_, "time is " + double_text(time));

  // Work on a copy so a failed write leaves the series as it was on disk and in memory.
  auto entries = entries_;
  // Kept sorted by time; an equal time replaces its entry (a restart rewriting a frame).
  auto it = std::lower_bound(entries.begin(), entries.end(), time,
                             [](const auto& e, double t) { return e.first < t; });
  // generic_string: ParaView wants '/' separators in the collection whatever the host.
  if (it != entries.end() && it->first == time) {
    it->second = file.generic_string();
  } else {
    entries.insert(it, {time, file.generic_string()});
  }

  std::string xml;
  xml += "<?xml version=\"1.0\"?>\n";
  xml += "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n";
  xml += "  <Collection>\n";
  for (const auto& [t, f] : entries) {
    xml += "    <DataSet timestep=\"" + double_text(t) + "\" group=\"\" part=\"0\" file=\"" + xml_escape(f) + "\"/>\n";
  }
  xml += "  </Collection>\n";
  xml += "</VTKFile>\n";

  write_atomic(target_, [&](std::ostream& os) { os.write(xml.data(), static_cast<std::streamsize>(xml.size())); });
  entries_ = std::move(entries);
}

}  // namespace perifx::io
