// Checkpoints (engine/io/checkpoint.cpp, World::save_checkpoint / load_checkpoint): a world restored
// from a checkpoint holds every array of for_each_array with the same bytes as the world that wrote
// it and steps on bit for bit, on another thread count; truncated and foreign files are refused.
#include <doctest/doctest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "components/world_state.hpp"
#include "perifx/world.hpp"
#include "setup/world_setup.hpp"

namespace fs = std::filesystem;
using namespace perifx;

namespace {

const fs::path kWall = fs::path(PERIFX_SOURCE_DIR) / "tests/engine/data/resume_wall.json";

// Every array's bytes by name (lists of the same name concatenated), without what a checkpoint does not
// keep: thread-dependent scratch and the projectiles' per-block lists (each step refills them).
std::map<std::string, std::string> array_bytes(const WorldState& w) {
  std::map<std::string, std::string> out;
  for_each_array(w, [&](ArrayKind, const char* name, const auto& array) {
    if (std::string(name) == "contact.pairs.bonded_stamp" || std::string(name) == "projectiles.block_contacts") return;
    out[name].append(reinterpret_cast<const char*>(array.data()), array.size() * sizeof(array[0]));
  });
  return out;
}

}  // namespace

TEST_CASE("checkpoint: a restored world has every array's bytes and steps on bit for bit") {
  auto sc = scene::load_scene_file(kWall);
  sc.threads = 2;
  World a(sc);
  a.step(80);  // the ball is through (pieces from step 70): broken bonds, split mesh, contact pairs
  const fs::path file = fs::temp_directory_path() / ("perifx_checkpoint_" + std::to_string(::getpid()) + ".bin");
  a.save_checkpoint(file, "note");
  sc.threads = 1;
  World b(sc);
  CHECK(b.load_checkpoint(file) == "note");
  CHECK(b.step_count() == 80);
  CHECK(b.time() == a.time());
  const auto bytes_a = array_bytes(a.state()), bytes_b = array_bytes(b.state());
  for (const auto& [name, bytes] : bytes_a) {
    INFO("array " << name);
    CHECK(bytes == bytes_b.at(name));
  }
  CHECK(a.contact_counters().list_builds == b.contact_counters().list_builds);
  CHECK(a.fragment_count() == b.fragment_count());
  CHECK(a.fragment_count() > 1);
  a.step(40);
  b.step(40);
  CHECK(std::memcmp(a.positions().data(), b.positions().data(), a.positions().size_bytes()) == 0);
  CHECK(array_bytes(a.state()) == array_bytes(b.state()));

  SUBCASE("a truncated file is refused") {
    fs::resize_file(file, fs::file_size(file) / 2);
    World c(sc);
    CHECK_THROWS_WITH_AS(c.load_checkpoint(file), doctest::Contains("the file is truncated"), io::IoError);
  }
  SUBCASE("a damaged array length is refused as a truncated file, before anything is allocated") {
    // The first array's element count (after the magic, the version, the header text, the array's name
    // and its element size) set to 2^62: read in place, the reader checks it against what is left.
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    std::uint64_t at = 8 + 4, n = 0;
    f.seekg(std::streamoff(at));
    f.read(reinterpret_cast<char*>(&n), sizeof n);
    at += 8 + n;  // the header text
    f.seekg(std::streamoff(at));
    f.read(reinterpret_cast<char*>(&n), sizeof n);
    at += 8 + n + 4;  // the first array's name and element size
    const std::uint64_t huge = std::uint64_t{1} << 62;
    f.seekp(std::streamoff(at));
    f.write(reinterpret_cast<const char*>(&huge), sizeof huge);
    f.close();
    World c(sc);
    CHECK_THROWS_WITH_AS(c.load_checkpoint(file), doctest::Contains("the file is truncated"), io::IoError);
  }
  SUBCASE("a file that is not a checkpoint is refused") {
    std::ofstream(file) << "{\"this\": \"is JSON, not a checkpoint\"}";
    World c(sc);
    CHECK_THROWS_WITH_AS(c.load_checkpoint(file), doctest::Contains("not a perifx checkpoint"), io::IoError);
  }
  SUBCASE("another scene's checkpoint is refused") {
    auto other = sc;
    other.text = sc.text.substr(0, sc.text.find("\"gravity\"")) + "\"gravity\": [0, -1, 0]," +
                 sc.text.substr(sc.text.find("\"time\"") - 2);
    other.gravity = Vec3(0, -1, 0);
    World c(other);
    CHECK_THROWS_WITH_AS(c.load_checkpoint(file), doctest::Contains("top-level keys: gravity"), scene::SceneError);
  }
  fs::remove(file);
}

TEST_CASE("checkpoint: a whole world written without its contact buffers resumes in one process bit for bit") {
  // A distributed run's rank 0 releases its whole world's contact grids and pair list
  // (setup::release_contact_buffers) and writes checkpoints from that world. One process resuming such a
  // checkpoint allocates the buffers again and builds the list on its next step: the same forces, so the
  // same bits as resuming a checkpoint that kept them.
  auto sc = scene::load_scene_file(kWall);
  sc.threads = 2;
  World a(sc);
  a.step(80);  // broken bonds, pieces (from step 70) and a built pair list
  REQUIRE(a.state().contact.enabled);
  REQUIRE(a.state().contact.pairs.valid);
  const std::string stem = "perifx_checkpoint_released_" + std::to_string(::getpid());
  const fs::path kept = fs::temp_directory_path() / (stem + "_kept.bin");
  const fs::path released = fs::temp_directory_path() / (stem + "_released.bin");
  a.save_checkpoint(kept, "");
  const std::size_t contact_before = a.memory().contact_bytes;
  setup::release_contact_buffers(a.state_mutable());
  CHECK(a.memory().contact_bytes == a.state().contact.size.capacity() * sizeof(double));  // only the sizes
  CHECK(a.memory().contact_bytes < contact_before / 10);
  a.save_checkpoint(released, "");
  CHECK(fs::file_size(released) < fs::file_size(kept));
  World b(sc), c(sc);
  b.load_checkpoint(kept);
  c.load_checkpoint(released);
  CHECK_FALSE(c.state().contact.pairs.valid);
  CHECK(c.state().contact.grid.start.size() == b.state().contact.grid.start.size());  // allocated again
  b.step(40);
  c.step(40);
  CHECK(std::memcmp(b.positions().data(), c.positions().data(), b.positions().size_bytes()) == 0);
  CHECK(std::memcmp(b.velocities().data(), c.velocities().data(), b.velocities().size_bytes()) == 0);
  CHECK(b.alive_bond_count() == c.alive_bond_count());
  fs::remove(kept);
  fs::remove(released);
}
