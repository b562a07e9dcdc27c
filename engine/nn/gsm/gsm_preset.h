// The GSM's configuration by name: the preset "infinicube-gsm" is the released
// model (nv-tlabs/InfiniCube gsm_vs02_res512_view1_dual_branch_sky_mlp_modulator.yaml
// merged with its includes as the official exp.parse_config_yaml does, and the
// Depth-Anything-V2-Large architecture as dav2_config), in the form of
// ../shared/data/models/gsm_small/config.json. Its text is assets/models/
// infinicube-gsm.json, built into the engine (tests/nn/test_gsm_params.cpp
// checks the two are the same); any other name is a config file.
#pragma once

#include "nn/gsm/gsm_reference.h"

#include <nlohmann/json.hpp>

#include <string>

namespace icube::nn {

inline constexpr const char* kInfinicubeGsmPreset = "infinicube-gsm";

// The released configuration's JSON text.
const std::string& infinicube_gsm_config_text();

struct GsmConfigJson {
  nlohmann::json json;
  std::string source;  // the file, or "preset infinicube-gsm", for messages
};

// The JSON object of the preset or of a config file; scene::InputError naming the file when it cannot be read or parsed.
GsmConfigJson read_gsm_config_json(const std::string& name_or_path);
// gsm_config_from_json of the preset or of a config file.
GsmConfig load_gsm_config(const std::string& name_or_path);

}  // namespace icube::nn
