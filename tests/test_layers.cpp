// The layers (README.md "How it is built"), checked on the sources: components/ is plain data and
// includes only components/ and the public vocabulary (perifx/); systems/ includes only components/,
// systems/ and perifx/; the public headers include only each other. (That the public headers also
// compile alone is checked by the perifx_public_api_check build target.)
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

// Quoted includes of every .hpp/.cpp directly in `folder`.
std::vector<std::pair<std::string, std::string>> quoted_includes(const fs::path& folder) {
  std::vector<std::pair<std::string, std::string>> out;
  const std::regex include_line(R"(^\s*#\s*include\s*"([^"]+)\")");
  for (const auto& entry : fs::directory_iterator(folder)) {
    const auto ext = entry.path().extension();
    if (ext != ".hpp" && ext != ".cpp") continue;
    std::ifstream in(entry.path());
    std::string line;
    std::smatch m;
    while (std::getline(in, line))
      if (std::regex_search(line, m, include_line)) out.emplace_back(entry.path().filename().string(), m[1]);
  }
  return out;
}

bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

}  // namespace

TEST_CASE("layers: components, systems and public headers include nothing from above them") {
  const fs::path root = PERIFX_SOURCE_DIR;
  const auto components = quoted_includes(root / "components");
  const auto systems = quoted_includes(root / "systems");
  const auto public_headers = quoted_includes(root / "engine/include/perifx");
  REQUIRE(!components.empty());
  REQUIRE(!systems.empty());
  for (const auto& [file, target] : components) {
    CAPTURE(file);
    CAPTURE(target);
    CHECK((starts_with(target, "components/") || starts_with(target, "perifx/")));
  }
  for (const auto& [file, target] : systems) {
    CAPTURE(file);
    CAPTURE(target);
    const bool local = target.find('/') == std::string::npos;  // a header of systems/ itself
    CHECK((local || starts_with(target, "systems/") || starts_with(target, "components/") ||
           starts_with(target, "perifx/")));
  }
  for (const auto& [file, target] : public_headers) {
    CAPTURE(file);
    CAPTURE(target);
    CHECK(starts_with(target, "perifx/"));
  }
}
