#include "io/gltf.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>

#include <nlohmann/json.hpp>

#include "io/atomic.hpp"
#include "io/write_checks.hpp"

namespace perifx::io {

static_assert(std::endian::native == std::endian::little, "the GLB writer writes this machine's bytes");

namespace {

using Json = nlohmann::ordered_json;

constexpr int kFloat = 5126, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// The binary chunk and the JSON arrays that describe it.
struct Builder {
  std::string bin;
  Json views = Json::array(), accessors = Json::array();

  // Appends `bytes` (4-byte aligned) as a buffer view; returns its index.
  int view(const void* data, std::size_t bytes, int target) {
    while (bin.size() % 4) bin.push_back('\0');
    Json v = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}};
    if (target) v["target"] = target;
    bin.append(static_cast<const char*>(data), bytes);
    views.push_back(v);
    return static_cast<int>(views.size()) - 1;
  }
  // Float accessor of `components` per element; min/max when asked (POSITION, animation input).
  int floats(const std::vector<float>& values, int components, const char* type, int target, bool bounds) {
    const std::size_t count = values.size() / components;
    Json a = {{"bufferView", view(values.data(), values.size() * 4, target)},
              {"componentType", kFloat},
              {"count", count},
              {"type", type}};
    if (bounds) {
      std::vector<float> lo(components, std::numeric_limits<float>::infinity()), hi(components, -std::numeric_limits<float>::infinity());
      for (std::size_t k = 0; k < count; ++k)
        for (int d = 0; d < components; ++d)
          lo[d] = std::min(lo[d], values[k * components + d]), hi[d] = std::max(hi[d], values[k * components + d]);
      a["min"] = lo;
      a["max"] = hi;
    }
    accessors.push_back(a);
    return static_cast<int>(accessors.size()) - 1;
  }
  int indices(const std::vector<std::uint32_t>& values) {
    accessors.push_back({{"bufferView", view(values.data(), values.size() * 4, kElementArrayBuffer)},
                         {"componentType", kUnsignedInt},
                         {"count", values.size()},
                         {"type", "SCALAR"}});
    return static_cast<int>(accessors.size()) - 1;
  }
};

// One primitive: the triangles `faces` of `s` with their own vertices.
Json primitive(Builder& b, const SurfaceMesh& s, const std::vector<std::size_t>& faces,
               const std::vector<std::array<std::array<double, 2>, 3>>* uv, int material) {
  std::map<std::uint32_t, std::uint32_t> local;  // surface vertex → primitive vertex
  std::vector<std::uint32_t> used, index;
  std::vector<float> texcoord;
  if (uv) {
    // UVs are per face corner: every corner gets its own vertex.
    for (std::size_t f : faces)
      for (int k = 0; k < 3; ++k) {
        index.push_back(static_cast<std::uint32_t>(used.size()));
        used.push_back(s.triangles[f][k]);
        texcoord.push_back(static_cast<float>((*uv)[f][k][0]));
        texcoord.push_back(static_cast<float>(1.0 - (*uv)[f][k][1]));  // glTF v runs down the image
      }
  } else {
    for (std::size_t f : faces)
      for (int k = 0; k < 3; ++k) {
        const auto [it, fresh] = local.emplace(s.triangles[f][k], static_cast<std::uint32_t>(used.size()));
        if (fresh) used.push_back(s.triangles[f][k]);
        index.push_back(it->second);
      }
  }
  // Area-weighted normals over this primitive's triangles (by surface vertex, so corner copies of one
  // crack vertex share a smooth normal).
  std::map<std::uint32_t, Vec3> sum;
  for (std::size_t f : faces) {
    const auto& t = s.triangles[f];
    const Vec3 n = (s.vertices[t[1]] - s.vertices[t[0]]).cross(s.vertices[t[2]] - s.vertices[t[0]]);
    for (int k = 0; k < 3; ++k) {
      auto [it, fresh] = sum.emplace(t[k], n);
      if (!fresh) it->second += n;
    }
  }
  std::vector<float> position, normal;
  for (std::uint32_t v : used) {
    Vec3 n = sum[v];
    const double len = n.norm();
    n = len > 0 && std::isfinite(len) ? Vec3(n / len) : Vec3(0, 1, 0);
    Eigen::Vector3f nf = n.cast<float>();
    nf.normalize();
    for (int d = 0; d < 3; ++d) position.push_back(static_cast<float>(s.vertices[v][d])), normal.push_back(nf[d]);
  }
  Json attributes = {{"POSITION", b.floats(position, 3, "VEC3", kArrayBuffer, true)},
                     {"NORMAL", b.floats(normal, 3, "VEC3", kArrayBuffer, false)}};
  if (uv) attributes["TEXCOORD_0"] = b.floats(texcoord, 2, "VEC2", kArrayBuffer, false);
  return {{"attributes", attributes}, {"indices", b.indices(index)}, {"material", material}, {"mode", 4}};
}

}  // namespace

void write_glb(const std::filesystem::path& file, const SurfaceMesh& s,
               const std::vector<std::array<std::array<double, 2>, 3>>& crack_uv, const std::vector<double>& times,
               const std::vector<RigidPieceTrack>& tracks, const std::string& generator) {
  detail::check_surface(file, s);
  if (crack_uv.size() != s.triangles.size()) detail::fail_write(file, "crack UVs are not one per triangle");
  std::map<std::uint32_t, std::array<std::vector<std::size_t>, 2>> pieces;  // id → outside, crack faces
  for (std::size_t f = 0; f < s.triangles.size(); ++f) pieces[s.fragment[f]][s.crack[f] ? 1 : 0].push_back(f);
  const bool animated = times.size() >= 2;
  if (animated) {
    if (tracks.size() != pieces.size()) detail::fail_write(file, std::to_string(tracks.size()) + " tracks for " + std::to_string(pieces.size()) + " pieces");
    for (std::size_t k = 1; k < times.size(); ++k)
      if (!(times[k] > times[k - 1])) detail::fail_write(file, "key times do not increase at key " + std::to_string(k));
    for (const RigidPieceTrack& track : tracks)
      for (std::size_t k = 0; k < track.translation.size() && k < track.rotation.size(); ++k)
        if (!track.translation[k].allFinite() || !track.rotation[k].allFinite())
          detail::fail_write(file, "piece " + std::to_string(track.id) + "'s pose at key " + std::to_string(k) +
                                       " is not finite (nothing written)");
  }

  Builder b;
  Json nodes = Json::array(), meshes = Json::array(), roots = Json::array();
  Json channels = Json::array(), samplers = Json::array();
  int input = -1;
  if (animated) {
    std::vector<float> t(times.begin(), times.end());
    input = b.floats(t, 1, "SCALAR", 0, true);
  }
  std::size_t node = 0;
  for (const auto& [id, faces] : pieces) {
    const std::string name = "piece_" + std::to_string(id);
    Json prims = Json::array();
    if (!faces[0].empty()) prims.push_back(primitive(b, s, faces[0], nullptr, 0));
    if (!faces[1].empty()) prims.push_back(primitive(b, s, faces[1], &crack_uv, 1));
    meshes.push_back({{"name", name}, {"primitives", prims}});
    nodes.push_back({{"name", name}, {"mesh", node}, {"extras", {{"piece", id}}}});
    roots.push_back(node);
    if (animated) {
      const RigidPieceTrack& track = tracks[node];
      if (track.id != id || track.translation.size() != times.size() || track.rotation.size() != times.size())
        detail::fail_write(file, "track " + std::to_string(node) + " does not match piece " + std::to_string(id));
      std::vector<float> tr, rot;
      for (std::size_t k = 0; k < times.size(); ++k) {
        for (int d = 0; d < 3; ++d) tr.push_back(static_cast<float>(track.translation[k][d]));
        Eigen::Vector4f q = track.rotation[k].cast<float>();
        q.normalize();
        for (int d = 0; d < 4; ++d) rot.push_back(q[d]);
      }
      const int sampler_t = static_cast<int>(samplers.size());
      samplers.push_back({{"input", input}, {"interpolation", "LINEAR"}, {"output", b.floats(tr, 3, "VEC3", 0, false)}});
      samplers.push_back({{"input", input}, {"interpolation", "LINEAR"}, {"output", b.floats(rot, 4, "VEC4", 0, false)}});
      channels.push_back({{"sampler", sampler_t}, {"target", {{"node", node}, {"path", "translation"}}}});
      channels.push_back({{"sampler", sampler_t + 1}, {"target", {{"node", node}, {"path", "rotation"}}}});
    }
    ++node;
  }
  while (b.bin.size() % 4) b.bin.push_back('\0');

  Json doc;
  doc["asset"] = {{"version", "2.0"}, {"generator", generator}};
  doc["scene"] = 0;
  doc["scenes"] = Json::array({{{"name", "perifx"}, {"nodes", roots}}});
  doc["nodes"] = nodes;
  doc["meshes"] = meshes;
  doc["materials"] = Json::array(
      {{{"name", "surface"},
        {"pbrMetallicRoughness", {{"baseColorFactor", {0.7, 0.7, 0.72, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.5}}}},
       {{"name", "crack"},
        {"pbrMetallicRoughness", {{"baseColorFactor", {0.9, 0.45, 0.1, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.8}}}}});
  if (animated) doc["animations"] = Json::array({{{"name", "perifx"}, {"channels", channels}, {"samplers", samplers}}});
  doc["buffers"] = Json::array({{{"byteLength", b.bin.size()}}});
  doc["bufferViews"] = b.views;
  doc["accessors"] = b.accessors;
  std::string json = doc.dump();
  while (json.size() % 4) json.push_back(' ');

  auto u32 = [](std::string& out, std::uint32_t v) { out.append(reinterpret_cast<const char*>(&v), 4); };
  const std::size_t total = 12 + 8 + json.size() + 8 + b.bin.size();
  if (total > 0xFFFFFFFFull) detail::fail_write(file, "the GLB would exceed 4 GiB");
  std::string head;
  u32(head, 0x46546C67u);  // "glTF"
  u32(head, 2);
  u32(head, static_cast<std::uint32_t>(total));
  u32(head, static_cast<std::uint32_t>(json.size()));
  u32(head, 0x4E4F534Au);  // "JSON"
  std::string bin_head;
  u32(bin_head, static_cast<std::uint32_t>(b.bin.size()));
  u32(bin_head, 0x004E4942u);  // "BIN\0"
  write_atomic(file, [&](std::ostream& os) {
    os << head << json << bin_head;
    os.write(b.bin.data(), static_cast<std::streamsize>(b.bin.size()));
  });
}

}  // namespace perifx::io
