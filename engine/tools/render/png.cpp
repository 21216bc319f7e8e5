// PNG encoding through libpng's simplified API (png_image), which does the filtering and deflate;
// the file goes to disk through io::write_atomic like every other perifx output.
#include "tools/render/png.hpp"

#include <png.h>

#include <stdexcept>

#include "io/atomic.hpp"

namespace perifx::render {

std::string encode_png(int width, int height, const std::vector<std::uint8_t>& rgb) {
  if (width <= 0 || height <= 0 || rgb.size() != std::size_t(width) * std::size_t(height) * 3)
    throw std::runtime_error("encode_png: " + std::to_string(rgb.size()) + " bytes do not make a " +
                             std::to_string(width) + "x" + std::to_string(height) + " RGB image");
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGB;
  const png_int_32 stride = 3 * width;
  // First call asks for the size, second one writes; the bound from the size query is exact.
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, rgb.data(), stride, nullptr))
    throw std::runtime_error(std::string("libpng: ") + image.message);
  std::string out(size, '\0');
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, rgb.data(), stride, nullptr))
    throw std::runtime_error(std::string("libpng: ") + image.message);
  out.resize(size);
  png_image_free(&image);
  return out;
}

void write_png(const std::filesystem::path& target, int width, int height, const std::vector<std::uint8_t>& rgb) {
  const std::string bytes = encode_png(width, height, rgb);
  io::write_atomic(target, [&](std::ostream& os) { os.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); });
}

}  // namespace perifx::render
