// Reading the GSM's configuration (config.json: `hparams` under the official
// names, `dav2_config`): the value at a dotted path, typed, or a one-line
// scene::InputError naming the source and the path. Shared by the stages'
// config readers.
#pragma once

#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace icube::nn::gsm_json {

inline const nlohmann::json& at(const nlohmann::json& j, const std::string& path, const std::string& source = "the GSM config") {
  const nlohmann::json* v = &j;
  size_t from = 0;
  while (from <= path.size()) {
    const size_t dot = path.find('.', from);
    const std::string key = path.substr(from, dot == std::string::npos ? std::string::npos : dot - from);
    if (!v->is_object() || !v->contains(key)) throw scene::InputError(source, path, "missing");
    v = &(*v)[key];
    if (dot == std::string::npos) break;
    from = dot + 1;
  }
  return *v;
}

inline bool has(const nlohmann::json& j, const std::string& path) {
  const nlohmann::json* v = &j;
  size_t from = 0;
  while (true) {
    const size_t dot = path.find('.', from);
    const std::string key = path.substr(from, dot == std::string::npos ? std::string::npos : dot - from);
    if (!v->is_object() || !v->contains(key)) return false;
    v = &(*v)[key];
    if (dot == std::string::npos) return true;
    from = dot + 1;
  }
}

inline int integer(const nlohmann::json& j, const std::string& path, const std::string& source = "the GSM config") {
  const nlohmann::json& v = at(j, path, source);
  if (!v.is_number_integer()) throw scene::InputError(source, path, "is not an integer");
  return v.get<int>();
}

inline double number(const nlohmann::json& j, const std::string& path, const std::string& source = "the GSM config") {
  const nlohmann::json& v = at(j, path, source);
  if (!v.is_number()) throw scene::InputError(source, path, "is not a number");
  return v.get<double>();
}

inline bool boolean(const nlohmann::json& j, const std::string& path, const std::string& source = "the GSM config") {
  const nlohmann::json& v = at(j, path, source);
  if (!v.is_boolean()) throw scene::InputError(source, path, "is not true or false");
  return v.get<bool>();
}

inline std::string text(const nlohmann::json& j, const std::string& path, const std::string& source = "the GSM config") {
  const nlohmann::json& v = at(j, path, source);
  if (!v.is_string()) throw scene::InputError(source, path, "is not a string");
  return v.get<std::string>();
}

template <class T>
std::vector<T> list(const nlohmann::json& j, const std::string& path, const std::string& source = "the GSM config") {
  const nlohmann::json& v = at(j, path, source);
  if (!v.is_array()) throw scene::InputError(source, path, "is not a list");
  std::vector<T> out;
  for (const nlohmann::json& e : v) {
    if constexpr (std::is_same_v<T, bool>) {
      if (!e.is_boolean()) throw scene::InputError(source, path, "has an entry that is not true or false");
    } else if constexpr (std::is_integral_v<T>) {
      if (!e.is_number_integer()) throw scene::InputError(source, path, "has an entry that is not an integer");
    } else {
      if (!e.is_number()) throw scene::InputError(source, path, "has an entry that is not a number");
    }
    out.push_back(e.get<T>());
  }
  return out;
}

}  // namespace icube::nn::gsm_json
