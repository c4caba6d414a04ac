#pragma once
// An enum's names, written once: a constexpr table of {value, name} pairs per
// enum, and ToString / Parse / the "a|b|c" and "a, b or c" lists all read
// that table.
//
//   constexpr EnumName<Method> kMethodNames[] = {{Method::kClosedForm, "closed-form"}, ...};
//   std::string_view ToString(Method m) { return NameOf(kMethodNames, m); }

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace lagrange {

template <class E>
struct EnumName {
  E value;
  std::string_view name;
};

// The name of `value`, or "?" for a value not in the table.
template <class E, std::size_t N>
constexpr std::string_view NameOf(const EnumName<E> (&table)[N], E value) {
  for (const EnumName<E>& e : table) {
    if (e.value == value) return e.name;
  }
  return "?";
}

// The value named `name` exactly, or nullopt.
template <class E, std::size_t N>
constexpr std::optional<E> ValueOf(const EnumName<E> (&table)[N], std::string_view name) {
  for (const EnumName<E>& e : table) {
    if (e.name == name) return e.value;
  }
  return std::nullopt;
}

// Every name in table order, joined by '|': "a|b|c".
template <class E, std::size_t N>
std::string JoinedNames(const EnumName<E> (&table)[N]) {
  std::string names;
  for (const EnumName<E>& e : table) {
    if (!names.empty()) names += '|';
    names += e.name;
  }
  return names;
}

// Every name in table order as alternatives in words: "a, b or c".
template <class E, std::size_t N>
std::string NamesInWords(const EnumName<E> (&table)[N]) {
  std::string names;
  for (std::size_t i = 0; i < N; ++i) {
    if (i > 0) names += i + 1 == N ? " or " : ", ";
    names += table[i].name;
  }
  return names;
}

}  // namespace lagrange
