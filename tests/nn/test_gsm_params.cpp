// The GSM's state dict from its configuration (engine/nn/gsm/gsm_params.h), the
// released preset (gsm_preset.h), the checked loader (gsm_weights.h) and random
// weights (gsm_random_weights.h): the preset gives the official manifest
// gsm.tsv exactly and gsm_small's config its weight file; the preset's file is
// the built-in text and holds the released run-time settings; a missing,
// misshapen, unexpected, integer or non-finite tensor is refused with the file
// and the tensor named; random weights of gsm_small's structure load and run
// through the whole forward with finite, well-formed Gaussians, reading no
// tensor the specs mark as carried only.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "gsm_case.h"
#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_preset.h"
#include "nn/gsm/gsm_random_weights.h"
#include "nn/safetensors.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

using namespace icube;

namespace {

// "[16, 3, 3, 3]" as both the manifest and shape_text write it.
std::string shape_of(const std::vector<int64_t>& s) { return nn::shape_text(s); }

struct ManifestRow {
  std::string name, shape, dtype, note;
};

std::vector<ManifestRow> read_manifest(const std::string& path) {
  std::vector<ManifestRow> rows;
  std::istringstream in(scene::read_file(path));
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#' || line.rfind("name\t", 0) == 0) continue;
    std::vector<std::string> f;
    std::istringstream cols(line);
    for (std::string c; std::getline(cols, c, '\t');) f.push_back(c);
    REQUIRE(f.size() == 4);
    rows.push_back({f[0], f[1], f[2], f[3]});
  }
  return rows;
}

// A safetensors header's tensors in the file's own order (the JSON object's order).
std::vector<std::pair<std::string, nlohmann::ordered_json>> header_in_order(const std::string& path) {
  const std::string bytes = scene::read_file(path);
  uint64_t n = 0;
  std::memcpy(&n, bytes.data(), 8);
  const nlohmann::ordered_json h = nlohmann::ordered_json::parse(bytes.substr(8, n));
  std::vector<std::pair<std::string, nlohmann::ordered_json>> out;
  for (auto it = h.begin(); it != h.end(); ++it)
    if (it.key() != "__metadata__") out.emplace_back(it.key(), it.value());
  return out;
}

// The message of the InputError `f` throws (fails the test when none).
std::string input_error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const scene::InputError& e) {
    return e.what();
  }
  FAIL("no scene::InputError");
  return {};
}

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

bool same_tensors(const nn::GsmWeights& a, const nn::GsmWeights& b) {
  if (a.tensors.size() != b.tensors.size()) return false;
  for (const auto& [name, t] : a.tensors)
    if (!b.has(name) || b.at(name).shape != t.shape || b.at(name).data != t.data) return false;
  return true;
}

}  // namespace

TEST_CASE("gsm params: the infinicube-gsm preset's state dict is the official manifest gsm.tsv") {
  const nn::GsmModelConfig m = nn::load_gsm_model_config("infinicube-gsm");
  const std::vector<nn::GsmParamSpec> specs = nn::gsm_param_specs(m);
  CHECK(specs.size() == 887);
  CHECK(nn::gsm_parameter_count(specs) == 360'738'506);
  CHECK(nn::gsm_buffer_count(specs) == 1417);
  const std::string tsv = std::string(ICUBE_SOURCE_DIR) + "/../shared/reference/models/gsm.tsv";
  if (!std::filesystem::exists(tsv)) return;
  const std::vector<ManifestRow> rows = read_manifest(tsv);
  REQUIRE(rows.size() == specs.size());
  size_t differ = 0;
  for (size_t i = 0; i < rows.size(); ++i) {
    const nn::GsmParamSpec& s = specs[i];
    const bool same = s.name == rows[i].name && shape_of(s.shape) == rows[i].shape &&
                      (s.integer() ? "int64" : "float32") == rows[i].dtype && s.buffer() == has(rows[i].note, "buffer");
    if (!same && ++differ <= 5)
      FAIL_CHECK("row " << i << ": ours " << s.name << " " << shape_of(s.shape) << (s.buffer() ? " buffer" : "")
                        << ", manifest " << rows[i].name << " " << rows[i].shape << " " << rows[i].dtype << " " << rows[i].note);
  }
  CHECK(differ == 0);
  // What the forward does not read: the depth head, the structure heads, the mask token, the batch counts and
  // the coarsest fusion layer's unused residual unit.
  size_t carried = 0;
  for (const nn::GsmParamSpec& s : specs)
    if (!s.run) {
      ++carried;
      const bool expected = has(s.name, ".dav2.model.head.") || has(s.name, ".struct_convs.") || has(s.name, "mask_token") ||
                            has(s.name, "num_batches_tracked") || has(s.name, "fusion_stage.layers.0.residual_layer1.");
      CHECK_MESSAGE(expected, s.name);
    }
  CHECK(carried == 6 + 15 + 1 + 9 + 4);
}

TEST_CASE("gsm params: gsm_small's config gives its weight file's tensors, and the checked loader reads them") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmModelConfig m = nn::load_gsm_model_config(dir + "config.json");
  const std::vector<nn::GsmParamSpec> specs = nn::gsm_param_specs(m);
  const auto file = header_in_order(dir + "weights.safetensors");
  REQUIRE(file.size() == 501);
  REQUIRE(specs.size() == file.size());
  uint64_t parameters = 0;
  for (size_t i = 0; i < specs.size(); ++i) {
    const nn::GsmParamSpec& s = specs[i];
    const std::vector<int64_t> shape = file[i].second["shape"].get<std::vector<int64_t>>();
    const std::string dtype = file[i].second["dtype"].get<std::string>();
    CHECK_MESSAGE(s.name == file[i].first, "tensor " << i << ": ours " << s.name << ", the file's " << file[i].first);
    // The case's writer stores the 0-d batch counts as [1].
    CHECK_MESSAGE((shape == s.shape || (s.integer() && shape == std::vector<int64_t>{1})),
                  s.name << ": ours " << shape_of(s.shape) << ", the file's " << shape_of(shape));
    CHECK_MESSAGE(dtype == (s.integer() ? "I64" : "F32"), s.name << " is " << dtype);
    if (!s.buffer()) parameters += static_cast<uint64_t>(nn::CpuTensor::count(s.shape));
  }
  const nlohmann::json config = nlohmann::json::parse(scene::read_file(dir + "config.json"));
  CHECK(parameters == config["weights"]["n_params"].get<uint64_t>());
  CHECK(nn::gsm_parameter_count(specs) == parameters);
  // The checked loader reads the same values as the plain one, under the specs' shapes.
  const nn::GsmWeights plain = nn::load_gsm_weights(dir + "weights.safetensors");
  const nn::GsmWeights checked = nn::load_gsm_weights(dir + "weights.safetensors", m, true);
  REQUIRE(checked.tensors.size() == plain.tensors.size());
  for (const nn::GsmParamSpec& s : specs) {
    CHECK(checked.at(s.name).shape == s.shape);
    CHECK(checked.at(s.name).data == plain.at(s.name).data);
  }
}

TEST_CASE("gsm params: assets/models/infinicube-gsm.json is the built-in preset and holds the released settings") {
  const std::string asset = std::string(ICUBE_SOURCE_DIR) + "/assets/models/infinicube-gsm.json";
  REQUIRE(std::filesystem::exists(asset));
  CHECK_MESSAGE(scene::read_file(asset) == nn::infinicube_gsm_config_text(),
                "assets/models/infinicube-gsm.json differs from the text built into engine/nn/gsm/gsm_preset.cpp");
  const nn::GsmConfigJson j = nn::read_gsm_config_json("infinicube-gsm");
  CHECK(j.source == "preset infinicube-gsm");
  // The file and the name give the same model.
  CHECK(nn::gsm_param_specs(nn::load_gsm_model_config(asset)).size() == 887);
  // Run-time settings of the released yaml (no tensor shape shows them).
  const nn::GsmConfig c = nn::load_gsm_config("infinicube-gsm");
  CHECK(c.dav2.input_height == 280);
  CHECK(c.dav2.input_width == 420);
  CHECK(c.dav2.out_indices == std::vector<int64_t>{5, 12, 18, 24});
  CHECK(c.dav2.layer_norm_eps == doctest::Approx(1e-6));
  CHECK(c.dav2.upsampler.size() == 2);
  CHECK((c.dav2.upsampler[0].up && c.dav2.upsampler[1].up && !c.dav2.upsampler[0].group_norm));
  CHECK(c.conv.filters == std::vector<int>{3, 16, 32, 64});
  CHECK(c.conv.residual == std::vector<bool>{false, true, true});
  CHECK(c.sky.patch_size == 16);
  CHECK(c.sky.heads == 4);
  CHECK(c.sky.model_midground);
  CHECK(c.voxel_heads.gaussians_per_voxel == 4);
  CHECK(c.voxel_heads.occ_upsample == 2);
  CHECK(c.voxel_heads.max_scaling == 1.0);
  CHECK(c.pixel.znear == 0.5);
  CHECK(c.pixel.zfar == 300.0);
  CHECK(c.pixel.max_scale == doctest::Approx(0.1));
  CHECK(c.pixel.depth_patch_size == 16);
  CHECK((c.pixel.masked_voxel_depth_prior && c.pixel.dav2_feature_prior && !c.pixel.voxel_depth_prior));
  CHECK(!c.pixel.inverse_metric_depth);
  CHECK(c.pixel.midground_only);
  // A config path that does not exist is named.
  CHECK(has(input_error_of([] { nn::load_gsm_model_config("no-such-gsm.json"); }), "no-such-gsm.json"));
}

TEST_CASE("gsm params: load_gsm_weights refuses a missing, misshapen, unexpected, integer or non-finite tensor by name") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmModelConfig m = nn::load_gsm_model_config(dir + "config.json");
  const std::vector<nn::GsmParamSpec> specs = nn::gsm_param_specs(m);
  const std::vector<nn::TensorToWrite> good = nn::gsm_weight_file_tensors(nn::gsm_random_weights(specs, 11), specs);
  test::TempDir tmp("gsm-params");
  int files = 0;
  // Writes `tensors` to a new file and returns its path.
  auto write = [&](const std::vector<nn::TensorToWrite>& tensors) {
    std::string name = "w";  // not "w" + std::to_string(...): GCC 12's -Wrestrict false positive on a short literal
    name += std::to_string(files++) + ".safetensors";
    const std::string path = (tmp.path / name).string();
    nn::write_safetensors(path, tensors);
    return path;
  };
  auto edited = [&](const std::string& name, const std::function<void(std::vector<nn::TensorToWrite>&, size_t)>& edit) {
    std::vector<nn::TensorToWrite> t = good;
    for (size_t i = 0; i < t.size(); ++i)
      if (t[i].name == name) {
        edit(t, i);
        return write(t);
      }
    FAIL("no tensor " << name);
    return std::string();
  };
  // The good file loads, with and without the finite check.
  const std::string ok = write(good);
  CHECK(nn::load_gsm_weights(ok, m, true).tensors.size() == specs.size());
  const std::string conv = "img_encoder.encoders.conv.project_head.1.in_layers.2.weight";  // [16, 8, 3, 3]

  const std::string missing = edited(conv, [](auto& t, size_t i) { t.erase(t.begin() + static_cast<long>(i)); });
  std::string e = input_error_of([&] { nn::load_gsm_weights(missing, m, false); });
  CHECK_MESSAGE(has(e, missing + ": tensor '" + conv + "': missing (the GSM needs [16, 8, 3, 3])"), e);

  const std::string misshapen = edited(conv, [&](auto& t, size_t i) {
    t[i] = nn::f32_tensor(conv, {16, 8, 1, 1}, std::vector<float>(128, 0.1f));
  });
  e = input_error_of([&] { nn::load_gsm_weights(misshapen, m, false); });
  CHECK_MESSAGE(has(e, misshapen + ": tensor '" + conv + "': shape [16, 8, 1, 1], the GSM needs [16, 8, 3, 3]"), e);

  const std::string extra = edited(conv, [](auto& t, size_t) {
    t.push_back(nn::f32_tensor("skybox.skybox_net.0.weight", {2}, {1.0f, 2.0f}));
  });
  e = input_error_of([&] { nn::load_gsm_weights(extra, m, false); });
  CHECK_MESSAGE(has(e, extra + ": tensor 'skybox.skybox_net.0.weight': unexpected"), e);

  const std::string integer = edited(conv, [&](auto& t, size_t i) {
    t[i] = nn::i32_tensor(conv, {16, 8, 3, 3}, std::vector<int32_t>(16 * 8 * 9, 1));
  });
  e = input_error_of([&] { nn::load_gsm_weights(integer, m, false); });
  CHECK_MESSAGE(has(e, integer + ": tensor '" + conv + "': dtype I32: a parameter must be F32, F16 or BF16"), e);

  const std::string nan = edited(conv, [](auto& t, size_t i) {
    const float v = std::nanf("");
    std::memcpy(t[i].bytes.data() + 5 * sizeof(float), &v, sizeof v);
  });
  e = input_error_of([&] { nn::load_gsm_weights(nan, m, true); });
  CHECK_MESSAGE(has(e, nan + ": tensor '" + conv + "': element 5 is not finite"), e);
  CHECK(std::isnan(nn::load_gsm_weights(nan, m, false).at(conv).data[5]));  // read as is without the check

  // A batch count may be [] or [1], I64 or float; a float parameter stored as int64 is not a batch count.
  const std::string count = "img_encoder.encoders.conv.project_head.0.1.num_batches_tracked";
  const std::string count_1 = edited(count, [&](auto& t, size_t i) { t[i] = nn::f32_tensor(count, {1}, {3.0f}); });
  CHECK(nn::load_gsm_weights(count_1, m, true).at(count).data == std::vector<float>{3.0f});
  const std::string count_2 = edited(count, [&](auto& t, size_t i) { t[i] = nn::f32_tensor(count, {2}, {3.0f, 4.0f}); });
  e = input_error_of([&] { nn::load_gsm_weights(count_2, m, false); });
  CHECK_MESSAGE(has(e, "tensor '" + count + "': shape [2], the GSM needs []"), e);
  // The released config against the small file: the first tensor's width is named.
  e = input_error_of([&] { nn::load_gsm_weights(ok, nn::load_gsm_model_config("infinicube-gsm"), false); });
  CHECK_MESSAGE(has(e, "tensor 'img_encoder.encoders.conv.project_head.0.0.weight': shape [8, 3, 3, 3], the GSM needs [16, 3, 3, 3]"), e);
}

TEST_CASE("gsm params: random weights of gsm_small's structure run the whole forward to finite, well-formed Gaussians") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmModelConfig m = nn::load_gsm_model_config(dir + "config.json");
  const std::vector<nn::GsmParamSpec> specs = nn::gsm_param_specs(m);
  nn::GsmWeights w = nn::gsm_random_weights(specs, 5);
  // Deterministic by seed.
  CHECK(same_tensors(nn::gsm_random_weights(specs, 5), w));
  CHECK(!same_tensors(nn::gsm_random_weights(specs, 6), w));
  // The draws keep the model well conditioned.
  size_t bad_var = 0, bad_voxel_bias = 0, bad_pixel_bias = 0, voxel_biases = 0, pixel_biases = 0;
  for (const nn::GsmParamSpec& s : specs) {
    const std::vector<float>& v = w.at(s.name).data;
    if (s.role == nn::GsmTensorRole::RunningVar)
      for (const float x : v) bad_var += !(x >= 0.5f && x <= 1.5f);
    if (s.role == nn::GsmTensorRole::VoxelGaussianBias)
      for (size_t g = 0; g < v.size(); g += 14, ++voxel_biases)  // quaternion (1, 0, 0, 0), opacity logit(0.1)
        bad_voxel_bias += !(v[g + 6] == 1.0f && v[g + 7] == 0.0f && std::fabs(v[g + 10] - std::log(0.1f / 0.9f)) < 1e-6f);
    if (s.role == nn::GsmTensorRole::PixelGaussianBias)
      for (size_t g = 0; g < v.size(); g += 12, ++pixel_biases) bad_pixel_bias += !(v[g + 4] > 0.5f);  // 1 + U(+-1/sqrt(fan_in))
  }
  CHECK(bad_var == 0);
  CHECK(voxel_biases == 2 * 4);  // two heads, gsplat_upsample 4
  CHECK(bad_voxel_bias == 0);
  CHECK(pixel_biases == 2);
  CHECK(bad_pixel_bias == 0);
  // Through a file, checked.
  test::TempDir tmp("gsm-random");
  const std::string path = (tmp.path / "random.safetensors").string();
  nn::write_safetensors(path, nn::gsm_weight_file_tensors(nn::GsmWeights(w), specs));
  nn::GsmWeights loaded = nn::load_gsm_weights(path, m, true);
  CHECK(same_tensors(loaded, w));
  // The forward reads no tensor the specs mark as carried only.
  for (const nn::GsmParamSpec& s : specs)
    if (!s.run) loaded.tensors.erase(s.name);
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  const nn::GsmOutputs out = nn::gsm_forward_reference(m.config, loaded, in, nullptr);
  REQUIRE(out.elements.size() == 1);
  const nn::VoxelGaussians& v = out.elements[0].voxel;
  const nn::PixelGaussians& p = out.elements[0].pixel;
  CHECK(v.count() > 0);
  CHECK(p.count() > 0);
  for (const nn::TensorToWrite& t : nn::gsm_output_tensors(out)) {
    if (t.dtype != nn::DType::F32) continue;
    const nn::SafetensorsFile one = nn::SafetensorsFile::from_bytes(nn::safetensors_bytes({t}), t.name);
    CHECK_MESSAGE(one.first_non_finite(one.tensors().front()) < 0, t.name << " is not finite");
  }
  size_t not_unit = 0, bad_opacity = 0;
  for (const nn::CpuTensor* q : {&v.rotations, &p.rotations})
    for (int64_t i = 0; i < q->dim(0); ++i) {
      double n = 0.0;
      for (int k = 0; k < 4; ++k) n += std::pow(static_cast<double>(q->data[static_cast<size_t>(i * 4 + k)]), 2);
      not_unit += std::fabs(std::sqrt(n) - 1.0) > 1e-5;
    }
  for (const nn::CpuTensor* o : {&v.opacities, &p.opacities})
    for (const float x : o->data) bad_opacity += !(x > 0.0f && x < 1.0f);
  CHECK(not_unit == 0);
  CHECK(bad_opacity == 0);
}
