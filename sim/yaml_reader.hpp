#pragma once
// Typed, strict reading of a YAML document: every value is checked as it is
// read, every map is checked for unknown keys, and every error names the
// file, the line and column, the key path (instances[0].plant.params.m1) and
// what was expected.

#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <initializer_list>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "plant/types.hpp"

namespace lagrange {

// "FILE:LINE:COLUMN: KEY: MESSAGE"
class ConfigError : public std::runtime_error {
 public:
  ConfigError(std::string file, int line, int column, std::string key, std::string message);
  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

class YamlReader {
 public:
  // Parses `text`; a syntax error is a ConfigError at its position.
  static YamlReader Parse(const std::string& text, const std::string& file);
  // Reads and parses a file; a file that cannot be read, is not a regular
  // file (a FIFO, a device: read without blocking and refused) or is larger
  // than kMaxSceneBytes is a ConfigError naming it.
  static YamlReader Load(const std::string& path);
  static constexpr std::size_t kMaxSceneBytes = 1u << 20;  // a scene is a few KiB

  // YAML::Node's own assignment writes through to the document; these rebind.
  YamlReader(const YamlReader&) = default;
  YamlReader& operator=(const YamlReader& other);

  const std::string& file() const { return *file_; }

  bool IsSequence() const { return node_.IsSequence(); }
  bool IsScalar() const { return node_.IsScalar(); }
  bool IsMap() const { return node_.IsMap(); }

  // Map access. Required() fails with "missing key" when absent.
  bool Has(std::string_view key) const;
  YamlReader Required(std::string_view key) const;
  std::optional<YamlReader> Optional(std::string_view key) const;
  // Fails on the first key not in `allowed`, listing the allowed ones.
  void ExpectKeys(std::initializer_list<std::string_view> allowed) const;
  // Map entries in document order: (key, value).
  std::vector<std::pair<std::string, YamlReader>> Entries() const;

  // Sequence access.
  std::size_t Size() const;
  YamlReader At(std::size_t i) const;

  // Scalars.
  std::string Text() const;          // any scalar, as written
  double Number() const;             // finite
  double PositiveNumber() const;     // finite, > 0
  double NonNegativeNumber() const;  // finite, >= 0
  double NumberOrInfinity() const;   // finite, .inf or -.inf
  int Integer(int min, int max) const;
  bool Bool() const;
  // A sequence of n finite numbers (n < 0: any length).
  VectorXd Vector(int n) const;
  // A sequence of n numbers each finite or ±.inf.
  VectorXd VectorOrInfinity(int n) const;
  // One number for every joint (broadcast) or a sequence of n.
  VectorXd NumberOrVector(int n) const;

  [[noreturn]] void Fail(const std::string& message) const;
  // Fails at a key below this node (checked by a later, whole-struct validation).
  [[noreturn]] void Fail(std::string_view subkey, const std::string& message) const;

 private:
  YamlReader(YAML::Node node, std::string path, std::shared_ptr<const std::string> file);
  void ExpectKind(bool ok, const char* expected) const;
  double ParseNumber(bool allow_infinity) const;

  YAML::Node node_;
  std::string path_;
  std::shared_ptr<const std::string> file_;
};

}  // namespace lagrange
