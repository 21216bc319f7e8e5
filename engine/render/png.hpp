// A minimal PNG encoder (8-bit RGB, no dependencies): per-row adaptive filter, then a zlib stream of
// fixed-Huffman deflate blocks with a small hash-chain LZ77 matcher. Good enough for rendered frames
// (flat backgrounds compress 20-50x); not a general-purpose compressor.
#pragma once
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace perifx::render {

// rgb: width*height*3 bytes, rows top to bottom. Returns the whole PNG file.
std::string encode_png(int width, int height, const std::vector<std::uint8_t>& rgb);

// encode_png written through io::write_atomic (throws io::IoError).
void write_png(const std::filesystem::path& target, int width, int height, const std::vector<std::uint8_t>& rgb);

// zlib (RFC 1950) stream around fixed-Huffman deflate (RFC 1951) blocks. Exposed for the tests.
std::string zlib_compress(const std::uint8_t* data, std::size_t size);

std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc = 0);

}  // namespace perifx::render
