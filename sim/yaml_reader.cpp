#include "sim/yaml_reader.hpp"

#include "base/bounded_file.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "plant/plant_factory.hpp"

namespace lagrange {
namespace {

std::string Describe(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "nothing";
  if (node.IsMap()) return "a map";
  if (node.IsSequence()) return "a list of " + std::to_string(node.size());
  return "'" + node.Scalar() + "'";
}

std::string JoinPath(const std::string& parent, std::string_view key) {
  return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}

std::string FormatConfigError(const std::string& file, int line, int column, const std::string& key,
                              const std::string& message) {
  std::string s = file;
  if (line > 0) {
    s.append(":").append(std::to_string(line)).append(":").append(std::to_string(column));
  }
  s.append(": ");
  if (!key.empty()) s.append(key).append(": ");
  return s.append(message);
}

}  // namespace

ConfigError::ConfigError(std::string file, int line, int column, std::string key, std::string message)
    : std::runtime_error(FormatConfigError(file, line, column, key, message)), file_(std::move(file)) {}

YamlReader::YamlReader(YAML::Node node, std::string path, std::shared_ptr<const std::string> file)
    : node_(std::move(node)), path_(std::move(path)), file_(std::move(file)) {}

YamlReader& YamlReader::operator=(const YamlReader& other) {
  node_.reset(other.node_);
  path_ = other.path_;
  file_ = other.file_;
  return *this;
}

YamlReader YamlReader::Parse(const std::string& text, const std::string& file) {
  auto name = std::make_shared<const std::string>(file);
  try {
    YAML::Node root = YAML::Load(text);
    if (!root.IsDefined() || root.IsNull()) throw ConfigError(file, 0, 0, "", "the file is empty");
    return YamlReader(root, "", name);
  } catch (const YAML::Exception& e) {
    throw ConfigError(file, e.mark.line + 1, e.mark.column + 1, "", "invalid YAML: " + e.msg);
  }
}

YamlReader YamlReader::Load(const std::string& path) {
  try {
    return Parse(ReadBoundedFile(path, kMaxSceneBytes), path);
  } catch (const FileReadError& e) {
    throw ConfigError(path, 0, 0, "", e.what());
  }
}

void YamlReader::Fail(const std::string& message) const {
  const YAML::Mark mark = node_.Mark();
  const int line = mark.is_null() ? 0 : mark.line + 1;
  const int column = mark.is_null() ? 0 : mark.column + 1;
  throw ConfigError(*file_, line, column, path_, message);
}

void YamlReader::Fail(std::string_view subkey, const std::string& message) const {
  YamlReader(node_, JoinPath(path_, subkey), file_).Fail(message);
}

void YamlReader::ExpectKind(bool ok, const char* expected) const {
  if (!ok) Fail(std::string("expected ") + expected + ", got " + Describe(node_));
}

bool YamlReader::Has(std::string_view key) const { return node_.IsMap() && node_[std::string(key)].IsDefined(); }

YamlReader YamlReader::Required(std::string_view key) const {
  ExpectKind(node_.IsMap(), "a map");
  YAML::Node child = node_[std::string(key)];
  if (!child.IsDefined()) Fail("missing key '" + std::string(key) + "'");
  return YamlReader(child, JoinPath(path_, key), file_);
}

std::optional<YamlReader> YamlReader::Optional(std::string_view key) const {
  ExpectKind(node_.IsMap(), "a map");
  YAML::Node child = node_[std::string(key)];
  if (!child.IsDefined()) return std::nullopt;
  return YamlReader(child, JoinPath(path_, key), file_);
}

void YamlReader::ExpectKeys(std::initializer_list<std::string_view> allowed) const {
  ExpectKind(node_.IsMap(), "a map");
  for (const auto& entry : node_) {
    const std::string key = entry.first.Scalar();
    bool known = false;
    for (std::string_view a : allowed) known = known || a == key;
    if (known) continue;
    std::string list;
    for (std::string_view a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
    YamlReader(entry.first, JoinPath(path_, key), file_).Fail("unknown key (expected one of: " + list + ")");
  }
}

std::vector<std::pair<std::string, YamlReader>> YamlReader::Entries() const {
  ExpectKind(node_.IsMap(), "a map");
  std::vector<std::pair<std::string, YamlReader>> out;
  for (const auto& entry : node_) {
    const std::string key = entry.first.Scalar();
    out.emplace_back(key, YamlReader(entry.second, JoinPath(path_, key), file_));
  }
  return out;
}

std::size_t YamlReader::Size() const {
  ExpectKind(node_.IsSequence(), "a list");
  return node_.size();
}

YamlReader YamlReader::At(std::size_t i) const {
  ExpectKind(node_.IsSequence(), "a list");
  return YamlReader(node_[i], path_ + "[" + std::to_string(i) + "]", file_);
}

std::string YamlReader::Text() const {
  ExpectKind(node_.IsScalar(), "a single value");
  return node_.Scalar();
}

double YamlReader::ParseNumber(bool allow_infinity) const {
  ExpectKind(node_.IsScalar(), allow_infinity ? "a number or .inf" : "a finite number");
  const std::string& s = node_.Scalar();
  if (allow_infinity) {
    if (s == ".inf" || s == ".Inf" || s == "+.inf") return std::numeric_limits<double>::infinity();
    if (s == "-.inf" || s == "-.Inf") return -std::numeric_limits<double>::infinity();
  }
  const std::optional<double> v = ParseFiniteNumber(s);
  if (!v)
    Fail(std::string("expected ") + (allow_infinity ? "a number or .inf" : "a finite number") + ", got '" + s + "'");
  return *v;
}

double YamlReader::Number() const { return ParseNumber(false); }
double YamlReader::NumberOrInfinity() const { return ParseNumber(true); }

double YamlReader::PositiveNumber() const {
  const double v = Number();
  if (!(v > 0.0)) Fail("expected a positive number, got " + node_.Scalar());
  return v;
}

double YamlReader::NonNegativeNumber() const {
  const double v = Number();
  if (!(v >= 0.0)) Fail("expected a number >= 0, got " + node_.Scalar());
  return v;
}

int YamlReader::Integer(int min, int max) const {
  const double v = Number();
  if (v != std::floor(v) || v < min || v > max) {
    Fail("expected a whole number from " + std::to_string(min) + " to " + std::to_string(max) + ", got " +
         node_.Scalar());
  }
  return static_cast<int>(v);
}

bool YamlReader::Bool() const {
  ExpectKind(node_.IsScalar(), "true or false");
  const std::string& s = node_.Scalar();
  if (s == "true" || s == "on" || s == "yes") return true;
  if (s == "false" || s == "off" || s == "no") return false;
  Fail("expected true or false, got '" + s + "'");
}

VectorXd YamlReader::Vector(int n) const {
  ExpectKind(node_.IsSequence(),
             n >= 0 ? ("a list of " + std::to_string(n) + " numbers").c_str() : "a list of numbers");
  if (n >= 0 && static_cast<int>(node_.size()) != n) {
    Fail("expected " + std::to_string(n) + " values (one per joint), got " + std::to_string(node_.size()));
  }
  VectorXd v(static_cast<int>(node_.size()));
  for (std::size_t i = 0; i < node_.size(); ++i) v[static_cast<int>(i)] = At(i).Number();
  return v;
}

VectorXd YamlReader::VectorOrInfinity(int n) const {
  ExpectKind(node_.IsSequence(), ("a list of " + std::to_string(n) + " numbers").c_str());
  if (static_cast<int>(node_.size()) != n) {
    Fail("expected " + std::to_string(n) + " values (one per joint), got " + std::to_string(node_.size()));
  }
  VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = At(static_cast<std::size_t>(i)).NumberOrInfinity();
  return v;
}

VectorXd YamlReader::NumberOrVector(int n) const {
  if (node_.IsScalar()) return VectorXd::Constant(n, Number());
  return Vector(n);
}

}  // namespace lagrange
