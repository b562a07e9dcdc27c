// Reading a model's keyword arguments from JSON (unet_config, vae_config):
// typed getters whose failures are scene::InputError naming the file and key.
#pragma once

#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace icube::nn {

struct KwargsReader {
  using json = nlohmann::json;
  const std::string& source;

  [[noreturn]] void fail(const std::string& key, const std::string& what) const { throw scene::InputError(source, key, what); }
  int integer(const std::string& key, const json& v, int lo = -1, int hi = 1'000'000) const {
    if (!v.is_number_integer()) fail(key, "is not an integer");
    const int64_t i = v.get<int64_t>();
    if (i < lo || i > hi) fail(key, std::to_string(i) + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return static_cast<int>(i);
  }
  bool boolean(const std::string& key, const json& v) const {
    if (!v.is_boolean()) fail(key, "is not true or false");
    return v.get<bool>();
  }
  // A non-empty list of positive integers.
  std::vector<int> list(const std::string& key, const json& v) const {
    if (!v.is_array() || v.empty()) fail(key, "is not a non-empty list of integers");
    std::vector<int> out;
    for (const json& e : v) {
      const int i = integer(key, e);
      if (i < 1) fail(key, "entry " + std::to_string(i) + " is not positive");
      out.push_back(i);
    }
    return out;
  }
  // Arguments for features the engine does not implement: only their "off" value.
  void null_only(const std::string& key, const json& v, const std::string& what) const {
    if (!v.is_null()) fail(key, what + " is not implemented (must be null)");
  }
  void must_be(const std::string& key, const json& v, bool expected, const std::string& what) const {
    if (boolean(key, v) != expected) fail(key, what + " is not implemented (must be " + (expected ? "true" : "false") + ")");
  }
};

}  // namespace icube::nn
