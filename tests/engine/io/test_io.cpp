// Tests for engine/io: atomic writes, and VTU / PLY / PVD files parsed back byte by byte here (not
// just "the file exists"), plus, when ParaView's pvpython is installed, a check that ParaView itself
// opens them.
#include <doctest/doctest.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/io.hpp"

namespace fs = std::filesystem;
using perifx::FieldLocation;
using perifx::FieldType;
using perifx::FieldView;
using perifx::Vec3;
using perifx::io::IoError;

namespace {

// A fresh directory per test, removed afterwards, so tests neither collide with each other nor
// with a concurrent run of the suite.
class TempDir {
 public:
  TempDir() {
    static int counter = 0;
    path_ = fs::temp_directory_path() /
            ("perifx_io_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }
  fs::path operator/(const std::string& name) const { return path_ / name; }

 private:
  fs::path path_;
};

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  REQUIRE(in.good());
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write_plain(const fs::path& p, const std::string& s) {
  std::ofstream out(p, std::ios::binary);
  out << s;
}

// Any leftover "<name>.tmp-<pid>" in the directory means write_atomic leaked its temporary.
bool has_temp_files(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".tmp-") != std::string::npos) return true;
  return false;
}

template <class T>
T load(const std::string& bytes, std::size_t at) {
  REQUIRE(at + sizeof(T) <= bytes.size());
  T v;
  std::memcpy(&v, bytes.data() + at, sizeof(T));
  return v;
}

template <class T>
bool same_bits(T a, T b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

// Value of attribute `name` in the start tag `tag`, or "" when absent.
std::string attr(const std::string& tag, const std::string& name) {
  const std::string key = " " + name + "=\"";
  const auto pos = tag.find(key);
  if (pos == std::string::npos) return "";
  const auto begin = pos + key.size();
  const auto end = tag.find('"', begin);
  REQUIRE(end != std::string::npos);
  return tag.substr(begin, end - begin);
}

// All start tags `<element ...>` in `xml`.
std::vector<std::string> tags(const std::string& xml, const std::string& element) {
  std::vector<std::string> out;
  const std::string open = "<" + element + " ";
  for (auto pos = xml.find(open); pos != std::string::npos; pos = xml.find(open, pos + 1)) {
    const auto end = xml.find('>', pos);
    REQUIRE(end != std::string::npos);
    out.push_back(xml.substr(pos, end - pos + 1));
  }
  return out;
}

// Minimal well-formedness check: tags nest and close properly. Feeds markup through a shared stack
// so the part before and after the binary block can be checked as one document.
void check_tags(const std::string& markup, std::vector<std::string>& stack) {
  for (auto pos = markup.find('<'); pos != std::string::npos; pos = markup.find('<', pos + 1)) {
    const auto end = markup.find('>', pos);
    REQUIRE(end != std::string::npos);
    const std::string tag = markup.substr(pos + 1, end - pos - 1);
    if (tag.starts_with("?") || tag.starts_with("!")) continue;
    if (tag.starts_with("/")) {
      REQUIRE_FALSE(stack.empty());
      CHECK(stack.back() == tag.substr(1));
      stack.pop_back();
      continue;
    }
    const std::string name = tag.substr(0, tag.find_first_of(" /"));
    if (!tag.ends_with("/")) stack.push_back(name);
  }
}

struct VtuArray {
  std::string name, type;
  int components = 1;
  std::string payload;  // the raw bytes after the UInt64 count
};

struct Vtu {
  std::size_t points = 0, cells = 0;
  std::map<std::string, VtuArray> point_data;
  VtuArray coordinates, connectivity, offsets, types;
};

// Parses what write_vtu_points writes: the XML header, then the appended raw block, where each
// DataArray's offset (relative to the byte after '_') points at a UInt64 byte count and the data.
Vtu parse_vtu(const std::string& file) {
  Vtu vtu;
  CHECK(file.starts_with("<?xml version=\"1.0\"?>\n"));
  const auto appended = file.find("<AppendedData encoding=\"raw\">");
  REQUIRE(appended != std::string::npos);
  const auto underscore = file.find('_', appended);
  REQUIRE(underscore != std::string::npos);
  const std::size_t base = underscore + 1;
  const std::string header = file.substr(0, appended);

  const auto roots = tags(header, "VTKFile");
  REQUIRE(roots.size() == 1);
  CHECK(attr(roots[0], "type") == "UnstructuredGrid");
  CHECK(attr(roots[0], "version") == "1.0");
  CHECK(attr(roots[0], "byte_order") == "LittleEndian");
  CHECK(attr(roots[0], "header_type") == "UInt64");
  const auto pieces = tags(header, "Piece");
  REQUIRE(pieces.size() == 1);
  vtu.points = std::stoull(attr(pieces[0], "NumberOfPoints"));
  vtu.cells = std::stoull(attr(pieces[0], "NumberOfCells"));

  const auto point_data_begin = header.find("<PointData>");
  const auto point_data_end = header.find("</PointData>");
  const auto points_begin = header.find("<Points>");
  const auto cells_begin = header.find("<Cells>");
  REQUIRE(point_data_begin != std::string::npos);
  REQUIRE(point_data_end != std::string::npos);
  REQUIRE(points_begin != std::string::npos);
  REQUIRE(cells_begin != std::string::npos);

  std::size_t end_of_blocks = base;
  for (auto pos = header.find("<DataArray "); pos != std::string::npos; pos = header.find("<DataArray ", pos + 1)) {
    const std::string tag = header.substr(pos, header.find('>', pos) - pos + 1);
    CHECK(tag.ends_with("/>"));
    CHECK(attr(tag, "format") == "appended");
    VtuArray a;
    a.name = attr(tag, "Name");
    a.type = attr(tag, "type");
    const std::string comps = attr(tag, "NumberOfComponents");
    a.components = comps.empty() ? 1 : std::stoi(comps);
    const std::size_t at = base + std::stoull(attr(tag, "offset"));
    const auto bytes = load<std::uint64_t>(file, at);
    REQUIRE(at + 8 + bytes <= file.size());
    a.payload = file.substr(at + 8, bytes);
    end_of_blocks = std::max<std::size_t>(end_of_blocks, at + 8 + bytes);

    if (pos > point_data_begin && pos < point_data_end) {
      vtu.point_data[a.name] = a;
    } else if (pos > points_begin && pos < cells_begin) {
      vtu.coordinates = a;
    } else if (a.name == "connectivity") {
      vtu.connectivity = a;
    } else if (a.name == "offsets") {
      vtu.offsets = a;
    } else if (a.name == "types") {
      vtu.types = a;
    } else {
      FAIL("unexpected DataArray " << tag);
    }
  }

  // The raw block must end exactly where the closing markup starts: no gaps, no overlap with it.
  const std::string tail = file.substr(end_of_blocks);
  CHECK(tail == "\n  </AppendedData>\n</VTKFile>\n");
  std::vector<std::string> stack;
  check_tags(file.substr(0, base - 1), stack);
  check_tags(tail, stack);
  CHECK(stack.empty());
  return vtu;
}

struct Ply {
  std::size_t vertices = 0;
  std::vector<std::pair<std::string, std::string>> properties;  // (type, name)
  std::string body;
};

Ply parse_ply(const std::string& file) {
  Ply ply;
  const std::string end = "end_header\n";
  const auto header_end = file.find(end);
  REQUIRE(header_end != std::string::npos);
  std::istringstream header(file.substr(0, header_end));
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(header, line)) lines.push_back(line);
  REQUIRE(lines.size() >= 4);
  CHECK(lines[0] == "ply");
  CHECK(lines[1] == "format binary_little_endian 1.0");
  CHECK(lines[2] == "comment perifx");
  REQUIRE(lines[3].starts_with("element vertex "));
  ply.vertices = std::stoull(lines[3].substr(std::strlen("element vertex ")));
  for (std::size_t i = 4; i < lines.size(); ++i) {
    std::istringstream words(lines[i]);
    std::string keyword, type, name, extra;
    words >> keyword >> type >> name;
    CHECK(keyword == "property");
    CHECK_FALSE(static_cast<bool>(words >> extra));
    ply.properties.emplace_back(type, name);
  }
  ply.body = file.substr(header_end + end.size());
  return ply;
}

// Values chosen to catch any lossy conversion: non-representable decimals, extremes, a subnormal,
// a negative zero.
const std::vector<Vec3> kPoints = {
    Vec3(0.1, -2.5, 1e-300),
    Vec3(std::numbers::pi, 6.02214076e23, -0.0),
    Vec3(4.9406564584124654e-324, -1.0 / 3.0, 123456.789),
};

FieldView view(std::string name, FieldType type, int components, const void* data, std::size_t count) {
  FieldView f;
  f.name = std::move(name);
  f.type = type;
  f.components = components;
  f.data = data;
  f.count = count;
  return f;
}

bool pvpython_available() { return std::system("command -v pvpython >/dev/null 2>&1") == 0; }

// Runs a pvpython script and returns its standard output (stderr is left to the console).
std::string run_pvpython(const fs::path& script) {
  const std::string cmd = "pvpython '" + script.string() + "'";
  FILE* pipe = ::popen(cmd.c_str(), "r");
  REQUIRE(pipe != nullptr);
  std::string out;
  std::array<char, 4096> buf{};
  while (const std::size_t got = std::fread(buf.data(), 1, buf.size(), pipe)) out.append(buf.data(), got);
  const int status = ::pclose(pipe);
  CHECK(status == 0);
  return out;
}

}  // namespace

TEST_CASE("io: write_atomic writes exact content and leaves no temporary") {
  TempDir dir;
  const fs::path target = dir / "out.bin";
  const std::string content("abc\0\xff\n\r\n end", 13);
  perifx::io::write_atomic(target, [&](std::ostream& os) { os.write(content.data(), content.size()); });
  CHECK(read_file(target) == content);
  CHECK_FALSE(has_temp_files(dir.path()));
}

TEST_CASE("io: write_atomic creates missing parent directories") {
  TempDir dir;
  const fs::path target = dir.path() / "a" / "b" / "c" / "out.txt";
  perifx::io::write_atomic(target, [](std::ostream& os) { os << "hello"; });
  CHECK(read_file(target) == "hello");
  CHECK_FALSE(has_temp_files(target.parent_path()));
}

TEST_CASE("io: write_atomic replaces an existing file") {
  TempDir dir;
  const fs::path target = dir / "out.txt";
  write_plain(target, "old content that is longer than the new one");
  perifx::io::write_atomic(target, [](std::ostream& os) { os << "new"; });
  CHECK(read_file(target) == "new");
  CHECK_FALSE(has_temp_files(dir.path()));
}

TEST_CASE("io: write_atomic keeps the old file when fill throws") {
  TempDir dir;
  const fs::path target = dir / "out.txt";
  write_plain(target, "precious");
  CHECK_THROWS_WITH_AS(perifx::io::write_atomic(target,
                                                [](std::ostream& os) {
                                                  os << "half a fra";  // a partial write, then failure
                                                  throw std::runtime_error("simulated failure");
                                                }),
                       "simulated failure", std::runtime_error);
  CHECK(read_file(target) == "precious");
  CHECK_FALSE(has_temp_files(dir.path()));
}

TEST_CASE("io: write_atomic keeps the old file when fill leaves the stream failed") {
  TempDir dir;
  const fs::path target = dir / "out.txt";
  write_plain(target, "precious");
  CHECK_THROWS_AS(perifx::io::write_atomic(target,
                                           [](std::ostream& os) {
                                             os << "partial";
                                             os.setstate(std::ios::badbit);
                                           }),
                  IoError);
  CHECK(read_file(target) == "precious");
  CHECK_FALSE(has_temp_files(dir.path()));
}

TEST_CASE("io: write_atomic into an unwritable location throws IoError naming the path") {
  TempDir dir;
  // A regular file where a directory should be: fails even as root, unlike permission bits.
  write_plain(dir / "not_a_dir", "x");
  const fs::path target = dir.path() / "not_a_dir" / "sub" / "out.vtu";
  try {
    perifx::io::write_atomic(target, [](std::ostream& os) { os << "data"; });
    FAIL("expected IoError");
  } catch (const IoError& e) {
    const std::string what = e.what();
    INFO(what);
    CHECK(what.find((dir.path() / "not_a_dir").string()) != std::string::npos);
    CHECK(what.find("out.vtu") != std::string::npos);
  }
  CHECK(read_file(dir / "not_a_dir") == "x");
  CHECK_FALSE(has_temp_files(dir.path()));
}

TEST_CASE("io: write_atomic onto a directory throws IoError and removes the temporary") {
  TempDir dir;
  // The temporary can be written but the rename over a non-empty directory fails.
  const fs::path target = dir / "occupied";
  fs::create_directories(target / "child");
  try {
    perifx::io::write_atomic(target, [](std::ostream& os) { os << "data"; });
    FAIL("expected IoError");
  } catch (const IoError& e) {
    const std::string what = e.what();
    INFO(what);
    CHECK(what.find(target.string()) != std::string::npos);
  }
  CHECK(fs::is_directory(target / "child"));
  CHECK_FALSE(has_temp_files(dir.path()));
}

TEST_CASE("io: VTU round-trips points, scalar, vector and u8 fields bit-exactly") {
  TempDir dir;
  const fs::path target = dir / "frame.vtu";
  const std::vector<double> damage = {0.0, 0.3333333333333333, std::numeric_limits<double>::max()};
  const std::vector<double> velocity = {1.5, -2.25, 1e-310, 0.1, 0.2, 0.30000000000000004, -7.0, 8e100, -0.0};
  const std::vector<std::uint8_t> material = {0, 7, 255};
  const std::vector<FieldView> fields = {
      view("damage", FieldType::f64, 1, damage.data(), 3),
      view("velocity", FieldType::f64, 3, velocity.data(), 3),
      view("material", FieldType::u8, 1, material.data(), 3),
  };
  perifx::io::write_vtu_points(target, kPoints, fields);
  CHECK_FALSE(has_temp_files(dir.path()));

  const Vtu vtu = parse_vtu(read_file(target));
  CHECK(vtu.points == 3);
  CHECK(vtu.cells == 3);

  REQUIRE(vtu.coordinates.payload.size() == 3 * 3 * sizeof(double));
  CHECK(vtu.coordinates.type == "Float64");
  CHECK(vtu.coordinates.components == 3);
  for (std::size_t i = 0; i < 3; ++i)
    for (int c = 0; c < 3; ++c)
      CHECK(same_bits(load<double>(vtu.coordinates.payload, (i * 3 + c) * 8), kPoints[i][c]));

  REQUIRE(vtu.point_data.size() == 3);
  const VtuArray& d = vtu.point_data.at("damage");
  CHECK(d.type == "Float64");
  CHECK(d.components == 1);
  REQUIRE(d.payload.size() == 3 * 8);
  for (std::size_t i = 0; i < 3; ++i) CHECK(same_bits(load<double>(d.payload, i * 8), damage[i]));

  const VtuArray& v = vtu.point_data.at("velocity");
  CHECK(v.type == "Float64");
  CHECK(v.components == 3);
  REQUIRE(v.payload.size() == 9 * 8);
  for (std::size_t i = 0; i < 9; ++i) CHECK(same_bits(load<double>(v.payload, i * 8), velocity[i]));

  const VtuArray& m = vtu.point_data.at("material");
  CHECK(m.type == "UInt8");
  CHECK(m.components == 1);
  REQUIRE(m.payload.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) CHECK(static_cast<std::uint8_t>(m.payload[i]) == material[i]);

  CHECK(vtu.connectivity.type == "Int64");
  CHECK(vtu.offsets.type == "Int64");
  CHECK(vtu.types.type == "UInt8");
  REQUIRE(vtu.connectivity.payload.size() == 3 * 8);
  REQUIRE(vtu.offsets.payload.size() == 3 * 8);
  REQUIRE(vtu.types.payload.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) {
    CHECK(load<std::int64_t>(vtu.connectivity.payload, i * 8) == static_cast<std::int64_t>(i));
    CHECK(load<std::int64_t>(vtu.offsets.payload, i * 8) == static_cast<std::int64_t>(i + 1));
    CHECK(vtu.types.payload[i] == 1);  // VTK_VERTEX
  }
}

TEST_CASE("io: VTU maps every field type and is byte-deterministic") {
  TempDir dir;
  const std::vector<float> f32 = {1.5f, -0.0f, 3.4e38f, 1e-45f, 2.0f, 3.0f};
  const std::vector<std::uint32_t> u32 = {0, 4000000000u};
  const std::vector<std::uint16_t> u16 = {65535, 1};
  const std::vector<Vec3> points = {Vec3(0, 0, 0), Vec3(1, 2, 3)};
  const std::vector<FieldView> fields = {
      view("f", FieldType::f32, 3, f32.data(), 2),
      view("id", FieldType::u32, 1, u32.data(), 2),
      view("a<b & \"c\"", FieldType::u16, 1, u16.data(), 2),  // needs XML escaping
  };
  perifx::io::write_vtu_points(dir / "a.vtu", points, fields);
  perifx::io::write_vtu_points(dir / "b.vtu", points, fields);
  const std::string bytes = read_file(dir / "a.vtu");
  CHECK(bytes == read_file(dir / "b.vtu"));

  const Vtu vtu = parse_vtu(bytes);
  REQUIRE(vtu.point_data.size() == 3);
  const VtuArray& f = vtu.point_data.at("f");
  CHECK(f.type == "Float32");
  CHECK(f.components == 3);
  REQUIRE(f.payload.size() == 6 * 4);
  for (std::size_t i = 0; i < 6; ++i) CHECK(same_bits(load<float>(f.payload, i * 4), f32[i]));
  const VtuArray& id = vtu.point_data.at("id");
  CHECK(id.type == "UInt32");
  REQUIRE(id.payload.size() == 2 * 4);
  CHECK(load<std::uint32_t>(id.payload, 4) == 4000000000u);
  const VtuArray& e = vtu.point_data.at("a&lt;b &amp; &quot;c&quot;");
  CHECK(e.type == "UInt16");
  REQUIRE(e.payload.size() == 2 * 2);
  CHECK(load<std::uint16_t>(e.payload, 0) == 65535);
  CHECK(load<std::uint16_t>(e.payload, 2) == 1);
}

TEST_CASE("io: VTU with no points is still a valid file") {
  TempDir dir;
  perifx::io::write_vtu_points(dir / "empty.vtu", {}, {view("damage", FieldType::f64, 1, nullptr, 0)});
  const Vtu vtu = parse_vtu(read_file(dir / "empty.vtu"));
  CHECK(vtu.points == 0);
  CHECK(vtu.point_data.at("damage").payload.empty());
  CHECK(vtu.coordinates.payload.empty());
}

TEST_CASE("io: writers reject fields that do not match the points, without writing") {
  TempDir dir;
  const std::vector<double> two = {1.0, 2.0};
  const std::vector<double> three = {1.0, 2.0, 3.0};
  FieldView short_field = view("short", FieldType::f64, 1, two.data(), 2);
  FieldView bond_field = view("bond_stretch", FieldType::f64, 1, three.data(), 3);
  bond_field.location = FieldLocation::bond;

  for (const FieldView& bad : {short_field, bond_field}) {
    CAPTURE(bad.name);
    CHECK_THROWS_AS(perifx::io::write_vtu_points(dir / "bad.vtu", kPoints, {bad}), IoError);
    CHECK_THROWS_AS(perifx::io::write_ply_points(dir / "bad.ply", kPoints, {bad}), IoError);
  }
  const FieldView good = view("good", FieldType::f64, 1, three.data(), 3);
  CHECK_THROWS_AS(perifx::io::write_vtu_points(dir / "bad.vtu", kPoints, {good, good}), IoError);
  CHECK_THROWS_AS(perifx::io::write_ply_points(dir / "bad.ply", kPoints, {view("x", FieldType::f64, 1, three.data(), 3)}),
                  IoError);
  CHECK_THROWS_AS(perifx::io::write_ply_points(dir / "bad.ply", kPoints, {view("two words", FieldType::f64, 1, three.data(), 3)}),
                  IoError);
  CHECK(fs::is_empty(dir.path()));
}

TEST_CASE("io: PLY header and interleaved binary records round-trip") {
  TempDir dir;
  const fs::path target = dir / "frame.ply";
  const std::vector<double> damage = {0.0, 0.3333333333333333, 1e300};
  const std::vector<double> velocity = {1.5, -2.25, 1e-310, 0.1, 0.2, 0.3, -7.0, 8e100, -0.0};
  const std::vector<std::uint8_t> material = {0, 7, 255};
  const std::vector<float> temperature = {300.5f, -1.0f, 1e-40f};
  const std::vector<std::uint32_t> id = {1, 2, 4000000000u};
  const std::vector<std::uint16_t> group = {9, 65535, 0};
  const std::vector<FieldView> fields = {
      view("damage", FieldType::f64, 1, damage.data(), 3),
      view("velocity", FieldType::f64, 3, velocity.data(), 3),
      view("material", FieldType::u8, 1, material.data(), 3),
      view("temperature", FieldType::f32, 1, temperature.data(), 3),
      view("id", FieldType::u32, 1, id.data(), 3),
      view("group", FieldType::u16, 1, group.data(), 3),
  };
  perifx::io::write_ply_points(target, kPoints, fields);
  CHECK_FALSE(has_temp_files(dir.path()));

  const Ply ply = parse_ply(read_file(target));
  CHECK(ply.vertices == 3);
  const std::vector<std::pair<std::string, std::string>> expected = {
      {"float", "x"},          {"float", "y"},          {"float", "z"},          {"double", "damage"},
      {"double", "velocity_x"}, {"double", "velocity_y"}, {"double", "velocity_z"}, {"uchar", "material"},
      {"float", "temperature"}, {"uint", "id"},          {"ushort", "group"},
  };
  CHECK(ply.properties == expected);

  const std::size_t record = 3 * 4 + 8 + 3 * 8 + 1 + 4 + 4 + 2;
  REQUIRE(ply.body.size() == 3 * record);
  for (std::size_t i = 0; i < 3; ++i) {
    CAPTURE(i);
    std::size_t at = i * record;
    for (int c = 0; c < 3; ++c, at += 4)
      CHECK(same_bits(load<float>(ply.body, at), static_cast<float>(kPoints[i][c])));
    CHECK(same_bits(load<double>(ply.body, at), damage[i]));
    at += 8;
    for (std::size_t c = 0; c < 3; ++c, at += 8) CHECK(same_bits(load<double>(ply.body, at), velocity[i * 3 + c]));
    CHECK(load<std::uint8_t>(ply.body, at) == material[i]);
    at += 1;
    CHECK(same_bits(load<float>(ply.body, at), temperature[i]));
    at += 4;
    CHECK(load<std::uint32_t>(ply.body, at) == id[i]);
    at += 4;
    CHECK(load<std::uint16_t>(ply.body, at) == group[i]);
  }
}

TEST_CASE("io: PLY records stay correct across write chunks") {
  // More points than one internal chunk, so a chunk-boundary offset error would show.
  TempDir dir;
  const std::size_t n = 100003;
  std::vector<Vec3> points(n);
  std::vector<std::uint32_t> id(n);
  for (std::size_t i = 0; i < n; ++i) {
    points[i] = Vec3(static_cast<double>(i), -static_cast<double>(i), 0.5);
    id[i] = static_cast<std::uint32_t>(i * 7);
  }
  perifx::io::write_ply_points(dir / "big.ply", points, {view("id", FieldType::u32, 1, id.data(), n)});
  const Ply ply = parse_ply(read_file(dir / "big.ply"));
  REQUIRE(ply.body.size() == n * 16);
  // Plain memcpy here: a doctest assertion per value would make this loop dominate the suite.
  struct Record {
    float x, y, z;
    std::uint32_t id;
  };
  static_assert(sizeof(Record) == 16);
  std::size_t first_bad = n;
  for (std::size_t i = 0; i < n && first_bad == n; ++i) {
    Record r;
    std::memcpy(&r, ply.body.data() + i * sizeof(Record), sizeof(Record));
    if (r.x != static_cast<float>(i) || r.y != -static_cast<float>(i) || r.z != 0.5f || r.id != i * 7) first_bad = i;
  }
  CHECK(first_bad == n);
}

namespace {

std::vector<std::pair<double, std::string>> parse_pvd(const std::string& xml) {
  CHECK(xml.starts_with("<?xml version=\"1.0\"?>\n"));
  const auto roots = tags(xml, "VTKFile");
  REQUIRE(roots.size() == 1);
  CHECK(attr(roots[0], "type") == "Collection");
  CHECK(attr(roots[0], "version") == "0.1");
  CHECK(attr(roots[0], "byte_order") == "LittleEndian");
  std::vector<std::string> stack;
  check_tags(xml, stack);
  CHECK(stack.empty());
  std::vector<std::pair<double, std::string>> out;
  for (const std::string& tag : tags(xml, "DataSet")) {
    CHECK(tag.ends_with("/>"));
    CHECK(attr(tag, "group").empty());
    CHECK(attr(tag, "part") == "0");
    out.emplace_back(std::strtod(attr(tag, "timestep").c_str(), nullptr), attr(tag, "file"));
  }
  return out;
}

}  // namespace

TEST_CASE("io: PVD lists every frame with round-tripping times, and a re-added time replaces") {
  TempDir dir;
  const fs::path target = dir / "series" / "run.pvd";
  perifx::io::PvdSeries series(target);
  // 0.1 * 3 is 0.30000000000000004: printing with too few digits would lose it.
  const double t0 = 0.0, t1 = 0.1, t2 = 0.1 * 3;
  series.add(t0, "frames/frame_000000.vtu");
  series.add(t1, "frames/frame_000001.vtu");
  series.add(t2, "frames/frame_000002.vtu");
  CHECK_FALSE(has_temp_files(target.parent_path()));

  auto entries = parse_pvd(read_file(target));
  REQUIRE(entries.size() == 3);
  CHECK(same_bits(entries[0].first, t0));
  CHECK(same_bits(entries[1].first, t1));
  CHECK(same_bits(entries[2].first, t2));
  CHECK(entries[0].second == "frames/frame_000000.vtu");
  CHECK(entries[1].second == "frames/frame_000001.vtu");
  CHECK(entries[2].second == "frames/frame_000002.vtu");

  series.add(t1, "frames/frame_000001_restart.vtu");
  entries = parse_pvd(read_file(target));
  REQUIRE(entries.size() == 3);
  CHECK(same_bits(entries[1].first, t1));
  CHECK(entries[1].second == "frames/frame_000001_restart.vtu");
  CHECK(entries[2].second == "frames/frame_000002.vtu");

  CHECK_THROWS_AS(series.add(std::numeric_limits<double>::quiet_NaN(), "nan.vtu"), IoError);
  CHECK(parse_pvd(read_file(target)).size() == 3);
}

TEST_CASE("io: writing 5e5 particles takes well under a second per format") {
  const std::size_t n = 500000;
  std::vector<Vec3> points(n);
  std::vector<double> damage(n), velocity(3 * n);
  std::vector<std::uint8_t> material(n);
  for (std::size_t i = 0; i < n; ++i) {
    points[i] = Vec3(i * 1e-3, i * 2e-3, i * 3e-3);
    damage[i] = static_cast<double>(i % 100) / 100.0;
    velocity[3 * i] = velocity[3 * i + 1] = velocity[3 * i + 2] = static_cast<double>(i);
    material[i] = static_cast<std::uint8_t>(i % 3);
  }
  const std::vector<FieldView> fields = {
      view("damage", FieldType::f64, 1, damage.data(), n),
      view("velocity", FieldType::f64, 3, velocity.data(), n),
      view("material", FieldType::u8, 1, material.data(), n),
  };
  TempDir dir;
  using clock = std::chrono::steady_clock;
  auto start = clock::now();
  perifx::io::write_vtu_points(dir / "big.vtu", points, fields);
  const double vtu_s = std::chrono::duration<double>(clock::now() - start).count();
  start = clock::now();
  perifx::io::write_ply_points(dir / "big.ply", points, fields);
  const double ply_s = std::chrono::duration<double>(clock::now() - start).count();
  MESSAGE("5e5 particles: vtu " << vtu_s << " s, ply " << ply_s << " s (including fsync)");
  // Generous bound: fsync time depends on the disk, and CI machines are shared. The point is to
  // catch a per-value writer, which would be an order of magnitude slower.
  CHECK(vtu_s < 3.0);
  CHECK(ply_s < 3.0);
  CHECK(fs::file_size(dir / "big.vtu") > n * (3 * 8 + 8 + 3 * 8 + 1 + 8 + 8 + 1));
}

TEST_CASE("io: ParaView (pvpython) opens the VTU, PLY and PVD") {
  if (!pvpython_available()) {
    MESSAGE("pvpython not installed; skipping the ParaView check");
    return;
  }
  TempDir dir;
  const std::vector<double> damage = {0.25, 0.5, 0.75};
  const std::vector<double> velocity = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  const std::vector<std::uint8_t> material = {0, 1, 2};
  const std::vector<FieldView> fields = {
      view("damage", FieldType::f64, 1, damage.data(), 3),
      view("velocity", FieldType::f64, 3, velocity.data(), 3),
      view("material", FieldType::u8, 1, material.data(), 3),
  };
  perifx::io::write_vtu_points(dir / "frames" / "f0.vtu", kPoints, fields);
  perifx::io::write_vtu_points(dir / "frames" / "f1.vtu", kPoints, fields);
  perifx::io::write_ply_points(dir / "f0.ply", kPoints, fields);
  perifx::io::PvdSeries series(dir / "run.pvd");
  series.add(0.0, "frames/f0.vtu");
  series.add(0.5, "frames/f1.vtu");

  // Prints one "key value" line per fact so the C++ side can check them without a JSON parser.
  const fs::path script = dir / "check.py";
  write_plain(script, R"PY(
import sys
from paraview.simple import XMLUnstructuredGridReader, PVDReader, PLYReader
d = sys.argv[0].rsplit('/', 1)[0]
vtu = XMLUnstructuredGridReader(FileName=[d + '/frames/f0.vtu'])
vtu.UpdatePipeline()
info = vtu.GetDataInformation()
print('vtu_points', info.GetNumberOfPoints())
print('vtu_cells', info.GetNumberOfCells())
from paraview import servermanager
grid = servermanager.Fetch(vtu)
print('vtu_point1', ' '.join(repr(c) for c in grid.GetPoint(1)))  # repr: shortest round-trip
print('vtu_cell_type', grid.GetCellType(2))
pd = vtu.PointData
print('vtu_damage_range', '%.17g' % pd['damage'].GetRange()[0], '%.17g' % pd['damage'].GetRange()[1])
print('vtu_velocity_components', pd['velocity'].GetNumberOfComponents())
print('vtu_material_range', int(pd['material'].GetRange()[0]), int(pd['material'].GetRange()[1]))
pvd = PVDReader(FileName=d + '/run.pvd')
pvd.UpdatePipeline(0.5)
print('pvd_times', ' '.join('%g' % t for t in pvd.TimestepValues))
print('pvd_points', pvd.GetDataInformation().GetNumberOfPoints())
ply = PLYReader(FileNames=[d + '/f0.ply'])
ply.UpdatePipeline()
print('ply_points', ply.GetDataInformation().GetNumberOfPoints())
)PY");
  const std::string out = run_pvpython(script);
  INFO(out);
  CHECK(out.find("vtu_points 3\n") != std::string::npos);
  CHECK(out.find("vtu_cells 3\n") != std::string::npos);
  CHECK(out.find("vtu_point1 3.141592653589793 6.02214076e+23 -0.0\n") != std::string::npos);
  CHECK(out.find("vtu_cell_type 1\n") != std::string::npos);  // VTK_VERTEX
  CHECK(out.find("vtu_damage_range 0.25 0.75\n") != std::string::npos);
  CHECK(out.find("vtu_velocity_components 3\n") != std::string::npos);
  CHECK(out.find("vtu_material_range 0 2\n") != std::string::npos);
  CHECK(out.find("pvd_times 0 0.5\n") != std::string::npos);
  CHECK(out.find("pvd_points 3\n") != std::string::npos);
  CHECK(out.find("ply_points 3\n") != std::string::npos);
}
