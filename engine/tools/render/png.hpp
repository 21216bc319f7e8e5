// PNG output of rendered frames (8-bit RGB), encoded by libpng.
#pragma once
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace perifx::render {

// rgb: width*height*3 bytes, rows top to bottom. Returns the whole PNG file. Throws
// std::runtime_error when libpng refuses (e.g. a size that does not match rgb).
std::string encode_png(int width, int height, const std::vector<std::uint8_t>& rgb);

// encode_png written through io::write_atomic (throws io::IoError).
void write_png(const std::filesystem::path& target, int width, int height, const std::vector<std::uint8_t>& rgb);

}  // namespace perifx::render
