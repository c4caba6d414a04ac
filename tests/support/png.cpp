#include "tests/support/png.hpp"

#include <array>
#include <fstream>
#include <iterator>
#include <vector>

namespace lagrange::testing {
namespace {

std::uint32_t Crc32(const std::uint8_t* data, std::size_t n) {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) c = table[(c ^ data[i]) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

std::uint32_t Be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

}  // namespace

PngInfo ReadPng(const std::string& path) {
  PngInfo info;
  std::ifstream in(path, std::ios::binary);
  const std::vector<std::uint8_t> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  static const std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (b.size() < 8 || !std::equal(kSignature, kSignature + 8, b.begin())) {
    info.error = "no PNG signature";
    return info;
  }
  std::size_t at = 8;
  std::string last;
  bool first = true;
  while (at + 12 <= b.size()) {
    const std::uint32_t len = Be32(&b[at]);
    if (at + 12 + len > b.size()) {
      info.error = "truncated chunk";
      return info;
    }
    const std::string type(b.begin() + static_cast<long>(at) + 4, b.begin() + static_cast<long>(at) + 8);
    const std::uint8_t* data = &b[at + 8];
    if (Crc32(&b[at + 4], len + 4) != Be32(&b[at + 8 + len])) {
      info.error = "bad CRC in " + type;
      return info;
    }
    if (first && type != "IHDR") {
      info.error = "IHDR is not first";
      return info;
    }
    if (type == "IHDR" && len >= 8) {
      info.width = Be32(data);
      info.height = Be32(data + 4);
    }
    if (type == "tEXt" || type == "iTXt") {
      const std::string chunk(data, data + len);
      const std::size_t nul = chunk.find('\0');
      std::string value = chunk.substr(nul + 1);
      if (type == "iTXt") {  // compression flag, method, language\0, translated keyword\0, text
        if (value.size() >= 2 && value[0] == 0) {
          const std::size_t lang = value.find('\0', 2);
          const std::size_t trans = value.find('\0', lang + 1);
          value = value.substr(trans + 1);
        } else {
          value.clear();
        }
      }
      info.text[chunk.substr(0, nul)] = value;
    }
    last = type;
    first = false;
    at += 12 + len;
  }
  info.valid = last == "IEND" && at == b.size() && info.width > 0 && info.height > 0;
  if (!info.valid && info.error.empty()) info.error = "no IEND at the end";
  return info;
}

}  // namespace lagrange::testing
