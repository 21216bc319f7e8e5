// Farm use of `perifx run`: checkpoints and --resume give frames byte-identical to an uninterrupted
// run (fracture, plasticity, contact and a projectile; stopped after N frames, stopped by SIGTERM,
// and SIGKILLed at a random moment; resumed on the same and on another thread count); a changed
// scene is refused; a folder holding another run is refused unless --overwrite or --resume;
// --quiet prints nothing; --progress json prints one object per frame.
#include <doctest/doctest.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "file_support.hpp"

namespace fs = std::filesystem;

namespace {

using perifx::test::slurp;

using perifx::test::run_cli;

const fs::path kScene = fs::path(PERIFX_SOURCE_DIR) / "tests/engine/data/resume_wall.json";

fs::path fresh_dir(const std::string& name) { return perifx::test::temp_dir("resume", name, false); }

// Every file of `a` except summary.json and the checkpoint is in `b` with the same bytes.
int compare_runs(const fs::path& a, const fs::path& b) {
  int files = 0;
  for (const auto& e : fs::directory_iterator(a)) {
    const std::string name = e.path().filename().string();
    if (name == "summary.json" || name == "checkpoint.bin") continue;
    INFO("file " << name);
    REQUIRE(fs::exists(b / name));
    CHECK(slurp(e.path()) == slurp(b / name));
    ++files;
  }
  std::size_t in_b = 0;
  for (const auto& e : fs::directory_iterator(b)) {
    const std::string name = e.path().filename().string();
    in_b += name != "summary.json" && name != "checkpoint.bin";
  }
  CHECK(in_b == std::size_t(files));
  return files;
}

std::string run_args(const fs::path& out, const std::string& extra) {
  return "run " + kScene.string() + " --out " + out.string() + " --quiet " + extra;
}

// Starts the CLI, waits until it has written a checkpoint, then a random 0–1.5 s more, and sends
// `sig`. Returns the exit status as waitpid reports it.
int start_and_signal(const fs::path& out, const std::string& threads, int sig, unsigned seed) {
  const std::string scene = kScene.string(), dir = out.string();
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1), ::dup2(null, 2);
    ::execl(PERIFX_CLI, PERIFX_CLI, "run", scene.c_str(), "--out", dir.c_str(), "--threads", threads.c_str(),
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  for (int k = 0; k < 600 && !fs::exists(out / "checkpoint.bin"); ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  std::mt19937 rng(seed);
  std::this_thread::sleep_for(std::chrono::milliseconds(std::uniform_int_distribution<int>(0, 1500)(rng)));
  ::kill(pid, sig);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return status;
}

}  // namespace

TEST_CASE("run --resume continues byte-identically after a stop, SIGTERM or SIGKILL, on any thread count") {
  const fs::path full = fresh_dir("full");
  REQUIRE(run_cli(run_args(full, "--threads 2")).code == 0);
  const auto summary = nlohmann::json::parse(slurp(full / "summary.json"));
  MESSAGE("uninterrupted: " << summary["frames"] << " frames, " << summary["fragments"] << " pieces, "
                            << summary["alive_bonds"] << " of " << summary["bonds"] << " bonds alive");
  CHECK(summary["fragments"].get<int>() > 1);  // it does break

  SUBCASE("stopped after 6 frames, resumed on 1 thread") {
    const fs::path part = fresh_dir("part");
    REQUIRE(run_cli(run_args(part, "--threads 2 --frames 6")).code == 0);
    const auto r = run_cli(run_args(part, "--threads 1 --resume"));
    REQUIRE(r.code == 0);
    CHECK(r.output.empty());
    CHECK(nlohmann::json::parse(slurp(part / "summary.json"))["first_frame"] == 6);
    MESSAGE("stop at frame 6, resume on 1 thread: " << compare_runs(full, part) << " files byte-identical");
    fs::remove_all(part);
  }
  SUBCASE("SIGTERM finishes the frame, writes a checkpoint and exits 6") {
    const fs::path term = fresh_dir("term");
    const int status = start_and_signal(term, "2", SIGTERM, 7);
    REQUIRE(WIFEXITED(status));
    const int code = WEXITSTATUS(status);
    CHECK((code == 6 || code == 0));  // 0: the run was already past its last frame
    const auto s = nlohmann::json::parse(slurp(term / "summary.json"));
    CHECK(s["interrupted"] == (code == 6));
    REQUIRE(run_cli(run_args(term, "--threads 1 --resume")).code == 0);
    MESSAGE("SIGTERM after frame " << s["last_frame"] << " (exit " << code << "), resumed on 1 thread: "
                                   << compare_runs(full, term) << " files byte-identical");
    fs::remove_all(term);
  }
  SUBCASE("SIGKILL at random moments, resumed on the same and on another thread count") {
    for (unsigned seed : {1u, 2u, 3u}) {
      const fs::path kill = fresh_dir("kill" + std::to_string(seed));
      const int status = start_and_signal(kill, "2", SIGKILL, seed);
      const bool killed = WIFSIGNALED(status);
      const std::string threads = seed % 2 ? "1" : "2";
      const auto r = run_cli(run_args(kill, "--threads " + threads + " --resume"));
      REQUIRE(r.code == 0);
      const auto s = nlohmann::json::parse(slurp(kill / "summary.json"));
      MESSAGE("SIGKILL " << (killed ? "during the run" : "after it ended") << ", resumed after frame "
                         << s["first_frame"] << " on " << threads << " thread(s): " << compare_runs(full, kill)
                         << " files byte-identical");
      fs::remove_all(kill);
    }
  }
  fs::remove_all(full);
}

TEST_CASE("run --resume refuses a changed scene and says which keys changed") {
  const fs::path out = fresh_dir("changed");
  REQUIRE(run_cli(run_args(out, "--frames 4")).code == 0);
  auto scene = nlohmann::json::parse(slurp(kScene));
  scene["gravity"] = {0, -1, 0};
  scene["materials"]["ductile"]["critical_stretch"] = 0.05;
  const fs::path changed = out.parent_path() / ("perifx_resume_changed_" + std::to_string(::getpid()) + ".json");
  std::ofstream(changed) << scene.dump(2);
  const auto r = run_cli("run " + changed.string() + " --out " + out.string() + " --resume --quiet");
  CHECK(r.code == 2);
  CHECK(r.output.find("cannot resume from checkpoint") != std::string::npos);
  CHECK(r.output.find("gravity, materials") != std::string::npos);
  MESSAGE(r.output);
  const auto dt = run_cli(run_args(out, "--resume --dt 5e-5"));
  CHECK(dt.code == 2);
  CHECK(dt.output.find("time step") != std::string::npos);
  // The contact time scale can be overridden on the command line, so it is compared apart from the text.
  const auto tau = run_cli(run_args(out, "--resume --contact-time-scale 1e-4"));
  CHECK(tau.code == 2);
  CHECK(tau.output.find("contact time scale 0.0001 s, checkpoint has") != std::string::npos);
  fs::remove_all(out);
  fs::remove(changed);
}

TEST_CASE("a run into another run's folder is refused unless --overwrite or --resume") {
  const fs::path out = fresh_dir("mixed");
  REQUIRE(run_cli(run_args(out, "--frames 3")).code == 0);
  const auto again = run_cli(run_args(out, "--frames 2"));
  CHECK(again.code == 3);
  CHECK(again.output.find("holds another run's output") != std::string::npos);
  CHECK(again.output.find("--overwrite") != std::string::npos);
  MESSAGE(again.output);
  CHECK(run_cli(run_args(out, "--frames 2 --overwrite --resume")).code == 1);
  REQUIRE(run_cli(run_args(out, "--frames 2 --overwrite")).code == 0);
  CHECK_FALSE(fs::exists(out / "particles.0003.vtu"));  // the older run's later frame is gone
  CHECK(fs::exists(out / "particles.0002.vtu"));
  CHECK(slurp(out / "particles.pvd").find("particles.0003") == std::string::npos);
  fs::remove_all(out);
}

TEST_CASE("run --quiet prints nothing; --progress json prints one object per frame") {
  const fs::path out = fresh_dir("progress");
  const auto quiet = run_cli(run_args(out, "--frames 2"));
  CHECK(quiet.code == 0);
  CHECK(quiet.output.empty());
  const auto json = run_cli("run " + kScene.string() + " --out " + out.string() + " --frames 3 --overwrite --progress json");
  REQUIRE(json.code == 0);
  std::istringstream lines(json.output);
  int count = 0;
  for (std::string line; std::getline(lines, line); ++count) {
    const auto j = nlohmann::json::parse(line);
    CHECK(j["frame"] == count + 1);
    for (const char* key : {"step", "time", "steps_per_second", "eta_seconds", "broken_bonds", "pieces", "memory_bytes"})
      CHECK(j.contains(key));
  }
  CHECK(count == 3);
  CHECK(nlohmann::json::parse(slurp(out / "summary.json"))["version"] == PERIFX_VERSION);
  fs::remove_all(out);
}
