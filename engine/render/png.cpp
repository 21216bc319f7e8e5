// PNG encoding: see png.hpp. Formats: PNG (ISO/IEC 15948), zlib (RFC 1950), deflate (RFC 1951).
#include "render/png.hpp"

#include <array>
#include <cstdlib>
#include <stdexcept>

#include "io/io.hpp"

namespace perifx::render {
namespace {

// Deflate writes bits least-significant first; Huffman codes go most-significant bit first.
class BitWriter {
 public:
  explicit BitWriter(std::string& out) : out_(out) {}
  void bits(std::uint32_t value, int count) {  // value's low `count` bits, LSB first
    acc_ |= std::uint64_t(value) << fill_;
    fill_ += count;
    while (fill_ >= 8) {
      out_.push_back(static_cast<char>(acc_ & 0xffu));
      acc_ >>= 8;
      fill_ -= 8;
    }
  }
  void code(std::uint32_t code, int length) {  // a Huffman code, MSB first
    std::uint32_t rev = 0;
    for (int i = 0; i < length; ++i) rev |= ((code >> i) & 1u) << (length - 1 - i);
    bits(rev, length);
  }
  void flush() {
    if (fill_ > 0) out_.push_back(static_cast<char>(acc_ & 0xffu));
    acc_ = 0;
    fill_ = 0;
  }

 private:
  std::string& out_;
  std::uint64_t acc_ = 0;
  int fill_ = 0;
};

constexpr std::array<int, 29> kLengthBase = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                             31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
constexpr std::array<int, 29> kLengthExtra = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                              2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
constexpr std::array<int, 30> kDistBase = {1,    2,    3,    4,    5,    7,     9,     13,    17,  25,
                                           33,   49,   65,   97,   129,  193,   257,   385,   513, 769,
                                           1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
constexpr std::array<int, 30> kDistExtra = {0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6,
                                            6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};

// Fixed literal/length code (RFC 1951 3.2.6).
void put_symbol(BitWriter& w, int sym) {
  if (sym < 144) w.code(0x30u + unsigned(sym), 8);
  else if (sym < 256) w.code(0x190u + unsigned(sym - 144), 9);
  else if (sym < 280) w.code(unsigned(sym - 256), 7);
  else w.code(0xC0u + unsigned(sym - 280), 8);
}

void put_match(BitWriter& w, int length, int distance) {
  int li = 28;
  while (kLengthBase[li] > length) --li;
  put_symbol(w, 257 + li);
  if (kLengthExtra[li]) w.bits(unsigned(length - kLengthBase[li]), kLengthExtra[li]);
  int di = 29;
  while (kDistBase[di] > distance) --di;
  w.code(unsigned(di), 5);
  if (kDistExtra[di]) w.bits(unsigned(distance - kDistBase[di]), kDistExtra[di]);
}

std::uint32_t adler32(const std::uint8_t* data, std::size_t size) {
  std::uint32_t a = 1, b = 0;
  for (std::size_t i = 0; i < size; ++i) {
    a = (a + data[i]) % 65521u;
    b = (b + a) % 65521u;
  }
  return (b << 16) | a;
}

void put_be32(std::string& out, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<char>((v >> s) & 0xffu));
}

void put_chunk(std::string& out, const char type[4], const std::string& data) {
  put_be32(out, static_cast<std::uint32_t>(data.size()));
  std::string body(type, 4);
  body += data;
  out += body;
  put_be32(out, crc32(reinterpret_cast<const std::uint8_t*>(body.data()), body.size()));
}

int paeth(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

}  // namespace

std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t n = 0; n < 256; ++n) {
      std::uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = table[(crc ^ data[i]) & 0xffu] ^ (crc >> 8);
  return ~crc;
}

std::string zlib_compress(const std::uint8_t* data, std::size_t size) {
  std::string out;
  out.reserve(size / 4 + 64);
  out.push_back(static_cast<char>(0x78));  // deflate, 32 KiB window
  out.push_back(static_cast<char>(0x01));  // fastest-compression hint; 0x7801 % 31 == 0
  BitWriter w(out);
  w.bits(1, 1);  // BFINAL: one block
  w.bits(1, 2);  // BTYPE 01: fixed Huffman

  constexpr int kWindow = 1 << 15, kHashBits = 15, kMaxChain = 48, kMaxLen = 258;
  std::vector<std::int32_t> head(std::size_t(1) << kHashBits, -1), prev(kWindow, -1);
  auto hash = [&](std::size_t i) {
    const std::uint32_t v = std::uint32_t(data[i]) | std::uint32_t(data[i + 1]) << 8 | std::uint32_t(data[i + 2]) << 16;
    return (v * 2654435761u) >> (32 - kHashBits);
  };
  auto insert = [&](std::size_t i) {
    if (i + 2 >= size) return;
    const auto h = hash(i);
    prev[i & (kWindow - 1)] = head[h];
    head[h] = static_cast<std::int32_t>(i);
  };

  std::size_t i = 0;
  while (i < size) {
    int best_len = 0, best_dist = 0;
    if (i + 2 < size) {
      const int max_len = static_cast<int>(std::min<std::size_t>(kMaxLen, size - i));
      std::int32_t cand = head[hash(i)];
      for (int chain = 0; cand >= 0 && chain < kMaxChain; ++chain) {
        const std::size_t c = static_cast<std::size_t>(cand);
        if (i - c > std::size_t(kWindow - 1)) break;
        int len = 0;
        while (len < max_len && data[c + std::size_t(len)] == data[i + std::size_t(len)]) ++len;
        if (len > best_len) {
          best_len = len;
          best_dist = static_cast<int>(i - c);
          if (len == max_len) break;
        }
        const std::int32_t next = prev[c & (kWindow - 1)];
        if (next >= cand) break;  // the slot was overwritten by a newer position
        cand = next;
      }
    }
    if (best_len >= 3) {
      put_match(w, best_len, best_dist);
      for (int k = 0; k < best_len; ++k) insert(i + std::size_t(k));
      i += std::size_t(best_len);
    } else {
      put_symbol(w, data[i]);
      insert(i);
      ++i;
    }
  }
  put_symbol(w, 256);
  w.flush();
  put_be32(out, adler32(data, size));
  return out;
}

std::string encode_png(int width, int height, const std::vector<std::uint8_t>& rgb) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("PNG size must be positive");
  const std::size_t stride = std::size_t(width) * 3;
  if (rgb.size() != stride * std::size_t(height)) throw std::invalid_argument("PNG pixel buffer has the wrong size");

  // Each row gets the filter whose output has the smallest sum of |signed bytes| (the usual heuristic).
  std::vector<std::uint8_t> raw((stride + 1) * std::size_t(height));
  std::vector<std::uint8_t> trial(stride), best(stride);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* row = rgb.data() + std::size_t(y) * stride;
    const std::uint8_t* up = y > 0 ? row - stride : nullptr;
    long best_cost = -1;
    int best_filter = 0;
    for (int f = 0; f < 5; ++f) {
      long cost = 0;
      for (std::size_t x = 0; x < stride; ++x) {
        const int a = x >= 3 ? row[x - 3] : 0, b = up ? up[x] : 0, c = (up && x >= 3) ? up[x - 3] : 0;
        int pred = 0;
        switch (f) {
          case 1: pred = a; break;
          case 2: pred = b; break;
          case 3: pred = (a + b) / 2; break;
          case 4: pred = paeth(a, b, c); break;
          default: break;
        }
        trial[x] = static_cast<std::uint8_t>(row[x] - pred);
        cost += std::abs(static_cast<int>(static_cast<std::int8_t>(trial[x])));
      }
      if (best_cost < 0 || cost < best_cost) best_cost = cost, best_filter = f, best.swap(trial);
    }
    std::uint8_t* dst = raw.data() + std::size_t(y) * (stride + 1);
    dst[0] = static_cast<std::uint8_t>(best_filter);
    std::copy(best.begin(), best.end(), dst + 1);
  }

  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  put_be32(ihdr, static_cast<std::uint32_t>(width));
  put_be32(ihdr, static_cast<std::uint32_t>(height));
  ihdr += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bit, truecolour, deflate, adaptive filter, no interlace
  put_chunk(png, "IHDR", ihdr);
  put_chunk(png, "IDAT", zlib_compress(raw.data(), raw.size()));
  put_chunk(png, "IEND", std::string());
  return png;
}

void write_png(const std::filesystem::path& target, int width, int height, const std::vector<std::uint8_t>& rgb) {
  const std::string png = encode_png(width, height, rgb);
  io::write_atomic(target, [&](std::ostream& os) { os.write(png.data(), static_cast<std::streamsize>(png.size())); });
}

}  // namespace perifx::render
