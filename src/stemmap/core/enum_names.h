#pragma once

// An enum's names in option files and on the command line. Read strictly: a name not in the
// table is an InputError naming the choices (NLOHMANN_JSON_SERIALIZE_ENUM would read it as the
// table's first value, silently).
#include <fmt/format.h>

#include <array>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>

#include "stemmap/core/error.h"

namespace stemmap {

template <typename E, size_t N>
using EnumNames = std::array<std::pair<E, std::string_view>, N>;

template <typename E, size_t N>
std::string_view EnumName(const EnumNames<E, N>& names, E value) {
  for (const auto& [e, name] : names) {
    if (e == value) return name;
  }
  return "?";
}

// "a, b or c".
template <typename E, size_t N>
std::string EnumChoices(const EnumNames<E, N>& names) {
  std::string out;
  for (size_t i = 0; i < N; ++i) {
    if (i > 0) out += i + 1 == N ? " or " : ", ";
    out += names[i].second;
  }
  return out;
}

// The value named `name`; InputError "<what> '<name>' is not a, b or c" otherwise.
template <typename E, size_t N>
E EnumFromName(const EnumNames<E, N>& names, std::string_view name, std::string_view what) {
  for (const auto& [e, n] : names) {
    if (n == name) return e;
  }
  throw InputError(fmt::format("{} '{}' is not {}", what, name, EnumChoices(names)));
}

// A JSON string read as the value it names (InputError for another string or a non-string).
template <typename E, size_t N>
E EnumFromJson(const EnumNames<E, N>& names, const nlohmann::json& j, std::string_view what) {
  if (!j.is_string()) {
    throw InputError(
        fmt::format("{} must be one of {}, not {}", what, EnumChoices(names), j.dump()));
  }
  return EnumFromName(names, j.get<std::string>(), what);
}

}  // namespace stemmap

// Defines to_json (the value's name) and from_json (EnumFromJson; `what` names the option in
// errors) for enum E with names table NAMES, in E's namespace.
#define STEMMAP_ENUM_JSON(E, NAMES, WHAT)                    \
  inline void to_json(nlohmann::json& j, E value) {          \
    j = std::string(::stemmap::EnumName(NAMES, value));      \
  }                                                          \
  inline void from_json(const nlohmann::json& j, E& value) { \
    value = ::stemmap::EnumFromJson(NAMES, j, WHAT);         \
  }
