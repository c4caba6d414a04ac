#include "tests/support/mini_json.hpp"

#include <charconv>
#include <stdexcept>

namespace lagrange::testing {
namespace {

class Parser {
 public:
  explicit Parser(std::string_view s) : s_(s) {}

  Json Document() {
    Json v = Value();
    Space();
    if (pos_ != s_.size()) Fail("trailing text");
    return v;
  }

 private:
  [[noreturn]] void Fail(const char* what) const {
    throw std::runtime_error(std::string("json: ") + what + " at offset " + std::to_string(pos_));
  }
  void Space() {
    while (pos_ < s_.size() && (s_[pos_] == ' ' || s_[pos_] == '\n' || s_[pos_] == '\t' || s_[pos_] == '\r')) ++pos_;
  }
  bool Eat(char c) {
    Space();
    if (pos_ < s_.size() && s_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }
  void Expect(char c) {
    if (!Eat(c)) Fail("unexpected character");
  }
  bool Word(std::string_view w) {
    if (s_.substr(pos_, w.size()) != w) return false;
    pos_ += w.size();
    return true;
  }
  std::string String() {
    Expect('"');
    std::string out;
    while (pos_ < s_.size() && s_[pos_] != '"') {
      if (s_[pos_] == '\\') ++pos_;
      out += s_[pos_++];
    }
    if (pos_ >= s_.size()) Fail("unterminated string");
    ++pos_;
    return out;
  }
  Json Value() {
    Space();
    if (pos_ >= s_.size()) Fail("unexpected end");
    Json v;
    const char c = s_[pos_];
    if (c == '{') {
      ++pos_;
      v.kind = Json::Kind::kObject;
      if (Eat('}')) return v;
      do {
        Space();
        std::string key = String();
        Expect(':');
        v.object[key] = Value();
      } while (Eat(','));
      Expect('}');
    } else if (c == '[') {
      ++pos_;
      v.kind = Json::Kind::kArray;
      if (Eat(']')) return v;
      do v.array.push_back(Value());
      while (Eat(','));
      Expect(']');
    } else if (c == '"') {
      v.kind = Json::Kind::kString;
      v.string = String();
    } else if (Word("true") || Word("false")) {
      v.kind = Json::Kind::kBool;
      v.boolean = s_[pos_ - 1] == 'e' && s_.substr(pos_ - 4, 4) == "true";
    } else if (Word("null")) {
      v.kind = Json::Kind::kNull;
    } else {
      v.kind = Json::Kind::kNumber;
      const auto [end, ec] = std::from_chars(s_.data() + pos_, s_.data() + s_.size(), v.number);
      if (ec != std::errc()) Fail("bad number");
      pos_ = static_cast<std::size_t>(end - s_.data());
    }
    return v;
  }

  std::string_view s_;
  std::size_t pos_ = 0;
};

}  // namespace

const Json& Json::operator[](const std::string& key) const {
  auto it = object.find(key);
  if (kind != Kind::kObject || it == object.end()) throw std::runtime_error("json: no key " + key);
  return it->second;
}

const Json& Json::operator[](std::size_t i) const {
  if (kind != Kind::kArray || i >= array.size()) throw std::runtime_error("json: no index");
  return array[i];
}

std::vector<double> Json::Numbers() const {
  std::vector<double> out;
  for (std::size_t i = 0; i < array.size(); ++i) {
    if (array[i].kind != Kind::kNumber) throw std::runtime_error("json: not a number");
    out.push_back(array[i].number);
  }
  return out;
}

std::vector<std::vector<double>> Json::NumberRows() const {
  std::vector<std::vector<double>> out;
  for (const Json& row : array) out.push_back(row.Numbers());
  return out;
}

Json ParseJson(std::string_view text) { return Parser(text).Document(); }

}  // namespace lagrange::testing
