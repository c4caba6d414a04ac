#pragma once
// A small JSON reader for tests of lagrangectl's output: objects, arrays,
// numbers, strings, true/false/null. Throws std::runtime_error on bad input.

#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace lagrange::testing {

struct Json {
  enum class Kind { kNull, kBool, kNumber, kString, kArray, kObject } kind = Kind::kNull;
  bool boolean = false;
  double number = 0.0;
  std::string string;
  std::vector<Json> array;
  std::map<std::string, Json> object;

  const Json& operator[](const std::string& key) const;
  const Json& operator[](std::size_t i) const;
  std::vector<double> Numbers() const;                   // an array of numbers
  std::vector<std::vector<double>> NumberRows() const;   // an array of arrays of numbers
};

Json ParseJson(std::string_view text);

}  // namespace lagrange::testing
