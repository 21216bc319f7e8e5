#include "io/pc2.hpp"

#include <bit>
#include <cstdint>
#include <string>

#include "io/atomic.hpp"
#include "io/write_checks.hpp"

namespace perifx::io {

static_assert(std::endian::native == std::endian::little, "the PC2 writer writes this machine's bytes");

void write_pc2(const std::filesystem::path& file, const std::vector<std::vector<float>>& frames, float start_frame) {
  const std::size_t values = frames.empty() ? 0 : frames.front().size();
  for (std::size_t k = 0; k < frames.size(); ++k)
    if (frames[k].size() != values || values % 3 != 0)
      throw IoError("cannot write '" + file.string() + "': frame " + std::to_string(k) + " has " +
                    std::to_string(frames[k].size()) + " coordinates, expected " + std::to_string(values) +
                    " (3 per vertex, the same every frame)");
  for (std::size_t k = 0; k < frames.size(); ++k)
    detail::check_finite(file, frames[k].data(), frames[k].size(), "frame " + std::to_string(k) + ": vertex");
  write_atomic(file, [&](std::ostream& os) {
    const char signature[12] = {'P', 'O', 'I', 'N', 'T', 'C', 'A', 'C', 'H', 'E', '2', '\0'};
    os.write(signature, sizeof signature);
    const std::int32_t version = 1, vertices = static_cast<std::int32_t>(values / 3),
                       samples = static_cast<std::int32_t>(frames.size());
    const float rate = 1.0f;
    os.write(reinterpret_cast<const char*>(&version), 4);
    os.write(reinterpret_cast<const char*>(&vertices), 4);
    os.write(reinterpret_cast<const char*>(&start_frame), 4);
    os.write(reinterpret_cast<const char*>(&rate), 4);
    os.write(reinterpret_cast<const char*>(&samples), 4);
    for (const auto& f : frames) os.write(reinterpret_cast<const char*>(f.data()), static_cast<std::streamsize>(f.size() * 4));
  });
}

}  // namespace perifx::io
