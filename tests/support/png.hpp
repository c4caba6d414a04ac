#pragma once
// Reading PNG files in tests: structure and checksums, size, text chunks.

#include <cstdint>
#include <map>
#include <string>

namespace lagrange::testing {

struct PngInfo {
  bool valid = false;  // signature, every chunk's CRC, IHDR first, IEND last
  std::string error;
  std::uint32_t width = 0, height = 0;
  std::map<std::string, std::string> text;  // tEXt and uncompressed iTXt chunks, by key
};

PngInfo ReadPng(const std::string& path);

}  // namespace lagrange::testing
