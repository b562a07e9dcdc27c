// The .safetensors reader (engine/nn/safetensors.h): round trips of F32, F16
// and BF16 tensors (empty and scalar shapes too), exact half/bfloat16
// conversions over every 16-bit pattern, non-finite scans, every validation
// rule with its one-line error naming the file and the tensor, and the real
// reference weights of unet_small (../shared/data/models/unet_small).
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "gpu_test_context.h"
#include "nn/safetensors.h"
#include "nn/weights.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <utility>
#include <vector>

using namespace icube;
using nn::DType;

namespace {

// A hand-written file: header text as given, then `data`.
std::string raw_file(const std::string& header, const std::string& data) {
  std::string out(8, '\0');
  const uint64_t n = header.size();
  for (int i = 0; i < 8; ++i) out[static_cast<size_t>(i)] = static_cast<char>((n >> (8 * i)) & 0xFF);
  return out + header + data;
}

std::string error_of(const std::string& bytes) {
  try {
    (void)nn::SafetensorsFile::from_bytes(bytes, "w.safetensors");
  } catch (const scene::InputError& e) {
    const std::string what = e.what();
    CHECK(what.find('\n') == std::string::npos);
    CHECK(what.rfind("w.safetensors: ", 0) == 0);
    return what;
  }
  return "no error";
}

// Independent reference for binary16 -> float: sign * 2^(e-15) * (1 + m/1024), subnormals m * 2^-24.
double half_reference(uint16_t h) {
  const int s = h >> 15, e = (h >> 10) & 31, m = h & 1023;
  double v;
  if (e == 31) v = m ? std::numeric_limits<double>::quiet_NaN() : std::numeric_limits<double>::infinity();
  else if (e == 0) v = std::ldexp(m, -24);
  else v = std::ldexp(1.0 + m / 1024.0, e - 15);
  return s ? -v : v;
}

nn::TensorToWrite tensor16(const char* name, DType dtype, std::vector<int64_t> shape, std::vector<uint8_t> bytes) {
  nn::TensorToWrite t;
  t.name = name;
  t.dtype = dtype;
  t.shape = std::move(shape);
  t.bytes = std::move(bytes);
  return t;
}

}  // namespace

TEST_CASE("safetensors: F32, F16 and BF16 tensors round trip, with metadata, empty and scalar shapes") {
  std::vector<nn::TensorToWrite> ts;
  ts.push_back(nn::f32_tensor("input_blocks.0.0.weight", {2, 1, 3}, {1.f, -2.f, 3.5f, 0.f, 1e30f, -1e-30f}));
  // 16-bit tensors from floats, little-endian.
  auto encode16 = [](DType dtype, std::initializer_list<float> values) {
    std::vector<uint8_t> bytes;
    for (const float f : values) {
      const uint16_t v = dtype == DType::F16 ? nn::float_to_half(f) : nn::float_to_bf16(f);
      bytes.push_back(static_cast<uint8_t>(v & 0xFF));
      bytes.push_back(static_cast<uint8_t>(v >> 8));
    }
    return bytes;
  };
  ts.push_back(tensor16("h", DType::F16, {3}, encode16(DType::F16, {1.0f, -0.5f, 65504.0f})));
  ts.push_back(tensor16("b", DType::BF16, {3}, encode16(DType::BF16, {1.0f, -3.0f, 1e38f})));
  ts.push_back(nn::f32_tensor("empty", {0, 4}, {}));
  ts.push_back(nn::f32_tensor("scalar", {}, {2.5f}));
  test::TempDir tmp("safetensors");
  const std::string path = (tmp.path / "w.safetensors").string();
  nn::write_safetensors(path, ts, {{"format", "pt"}});
  const nn::SafetensorsFile f(path);
  CHECK(f.metadata().at("format") == "pt");
  REQUIRE(f.tensors().size() == 5);
  CHECK(f.tensors()[0].name == "b");  // sorted by name
  CHECK(f.header_bytes() % 8 == 0);
  const nn::TensorInfo* w = f.find("input_blocks.0.0.weight");
  REQUIRE(w != nullptr);
  CHECK(w->shape_text() == "[2, 1, 3]");
  CHECK(f.to_f32(*w) == std::vector<float>{1.f, -2.f, 3.5f, 0.f, 1e30f, -1e-30f});
  CHECK(f.to_f32(*f.find("h")) == std::vector<float>{1.0f, -0.5f, 65504.0f});
  const std::vector<float> bv = f.to_f32(*f.find("b"));
  CHECK(bv[0] == 1.0f);
  CHECK(bv[1] == -3.0f);
  CHECK(bv[2] == doctest::Approx(1e38).epsilon(1e-2));
  CHECK(f.find("empty")->numel() == 0);
  CHECK(f.to_f32(*f.find("empty")).empty());
  CHECK(f.find("scalar")->numel() == 1);
  CHECK(f.to_f32(*f.find("scalar")) == std::vector<float>{2.5f});
  CHECK(f.find("nope") == nullptr);
  CHECK(f.first_non_finite(*w) == -1);
  // Moving keeps the views valid (mapped and owned copies).
  nn::SafetensorsFile moved = nn::SafetensorsFile::from_bytes(scene::read_file(path), "copy");
  nn::SafetensorsFile again = std::move(moved);
  CHECK(again.to_f32(*again.find("scalar")) == std::vector<float>{2.5f});
}

TEST_CASE("safetensors: I64, I32, U8 and BOOL tensors (a reference case's indices and masks) read back, and weights refuse them") {
  std::vector<nn::TensorToWrite> ts;
  ts.push_back(nn::i32_tensor("ijk", {2, 3}, {-6, 0, 7, 2147483647, -2147483647 - 1, 1}));
  ts.push_back(nn::u8_tensor("mask", {4}, {0, 1, 255, 1}));
  nn::TensorToWrite l;
  l.name = "count";
  l.dtype = DType::I64;
  l.shape = {1};
  const int64_t big = -(int64_t{1} << 40);
  l.bytes.resize(8);
  std::memcpy(l.bytes.data(), &big, 8);
  ts.push_back(l);
  nn::TensorToWrite b = nn::u8_tensor("flag", {2}, {1, 0});
  b.dtype = DType::BOOL;
  ts.push_back(b);
  test::TempDir tmp("safetensors_int");
  const std::string path = (tmp.path / "i.safetensors").string();
  nn::write_safetensors(path, ts);
  const nn::SafetensorsFile f(path);
  CHECK(f.to_i64(*f.find("ijk")) == std::vector<int64_t>{-6, 0, 7, 2147483647, -2147483648LL, 1});
  CHECK(f.to_i64(*f.find("mask")) == std::vector<int64_t>{0, 1, 255, 1});
  CHECK(f.to_i64(*f.find("count")) == std::vector<int64_t>{big});
  CHECK(f.to_i64(*f.find("flag")) == std::vector<int64_t>{1, 0});
  CHECK(f.find("flag")->dtype == DType::BOOL);
  CHECK(f.to_f32(*f.find("mask")) == std::vector<float>{0.f, 1.f, 255.f, 1.f});
  CHECK(f.first_non_finite(*f.find("ijk")) == -1);
  nn::write_safetensors(path + ".f", {nn::f32_tensor("x", {1}, {1.f})});
  const nn::SafetensorsFile g(path + ".f");
  CHECK_THROWS_AS(g.to_i64(*g.find("x")), std::invalid_argument);
  // A parameter stored as integers is refused with the file and the tensor named.
  nn::write_safetensors(path + ".w", {nn::i32_tensor("conv.weight", {2, 3}, {1, 2, 3, 4, 5, 6})});
  const std::vector<nn::ParamSpec> params{{"conv.weight", {2, 3}}};
  try {
    nn::load_weights_cpu(nn::SafetensorsFile(path + ".w"), params, {});
    FAIL("an I32 parameter was accepted");
  } catch (const scene::InputError& e) {
    CHECK(std::string(e.what()).find("tensor 'conv.weight'") != std::string::npos);
    CHECK(std::string(e.what()).find("dtype I32: a parameter must be F32, F16 or BF16") != std::string::npos);
  }
}

TEST_CASE("safetensors: half and bfloat16 conversions are exact over every 16-bit pattern") {
  size_t bad = 0;
  for (uint32_t u = 0; u < 65536; ++u) {
    const uint16_t h = static_cast<uint16_t>(u);
    const double want = half_reference(h);
    const float got = nn::half_to_float(h);
    if (std::isnan(want) ? !std::isnan(got) : static_cast<double>(got) != want || std::signbit(got) != std::signbit(want)) {
      if (++bad <= 5) MESSAGE("half 0x" << std::hex << u << ": got " << got << ", want " << want);
    }
    // float -> half -> float is the identity on halves (NaN stays NaN).
    if (!std::isnan(want) && nn::float_to_half(got) != h && ++bad <= 5) MESSAGE("half 0x" << std::hex << u << " does not round trip");
    const float bf = nn::bf16_to_float(h);
    uint32_t bits;
    std::memcpy(&bits, &bf, 4);
    if (bits != (u << 16) && ++bad <= 5) MESSAGE("bf16 0x" << std::hex << u);
    if (!std::isnan(bf) && nn::float_to_bf16(bf) != h && ++bad <= 5) MESSAGE("bf16 0x" << std::hex << u << " round trip");
  }
  CHECK(bad == 0);
  // Rounding to nearest even between neighbours, overflow to infinity, subnormals.
  CHECK(nn::float_to_half(1.0f + std::ldexp(1.0f, -11)) == 0x3C00);  // tie: to the even 1.0
  CHECK(nn::float_to_half(1.0f + 3 * std::ldexp(1.0f, -11)) == 0x3C02);  // tie: to the even 1.001953125
  CHECK(nn::float_to_half(65519.0f) == 0x7BFF);
  CHECK(nn::float_to_half(65520.0f) == 0x7C00);
  CHECK(nn::float_to_half(std::ldexp(1.0f, -25)) == 0x0000);  // half the smallest subnormal: tie to 0
  CHECK(nn::float_to_half(std::ldexp(3.0f, -26)) == 0x0001);
  CHECK(nn::float_to_half(-0.0f) == 0x8000);
  CHECK(std::isnan(nn::half_to_float(nn::float_to_half(std::nanf("")))));
  CHECK(nn::float_to_bf16(1.0f + std::ldexp(1.0f, -8)) == 0x3F80);  // tie to even
  CHECK(nn::float_to_bf16(1.0f + 3 * std::ldexp(1.0f, -8)) == 0x3F82);
}

TEST_CASE("safetensors: non-finite values are found in every dtype") {
  const nn::TensorToWrite h = tensor16("h", DType::F16, {3}, {0x00, 0x3C, 0x00, 0x3C, 0x00, 0x7C});  // 1, 1, inf
  const nn::TensorToWrite b = tensor16("b", DType::BF16, {3}, {0xC0, 0x7F, 0x80, 0x3F, 0x80, 0x3F});  // NaN, 1, 1
  const nn::SafetensorsFile f = nn::SafetensorsFile::from_bytes(
      nn::safetensors_bytes({nn::f32_tensor("f", {4}, {0.f, 1.f, std::nanf(""), 2.f}), h, b}), "mem");
  CHECK(f.first_non_finite(*f.find("f")) == 2);
  CHECK(f.first_non_finite(*f.find("h")) == 2);
  CHECK(f.first_non_finite(*f.find("b")) == 0);
}

TEST_CASE("safetensors: every malformed header is a one-line error naming the file and the tensor") {
  const std::string eight(8, '\0');
  CHECK(error_of("abc").find("3 bytes, shorter than the 8-byte header length") != std::string::npos);
  CHECK(error_of(raw_file("{}", "").substr(0, 9)).find("header length 2 runs past the end") != std::string::npos);
  std::string huge(8, '\0');
  huge[5] = 0x10;  // 2^44
  CHECK(error_of(huge).find("over the 100 MB limit") != std::string::npos);
  CHECK(error_of(raw_file("[1, 2]", "")).find("does not start with '{'") != std::string::npos);
  CHECK(error_of(raw_file("{\"a\": ", "")).find("header: not valid JSON") != std::string::npos);
  CHECK(error_of(raw_file("{} x", "")).find("not valid JSON") != std::string::npos);
  const std::string f4(4, '\0');
  auto one = [&](const std::string& entry, const std::string& data) {
    return error_of(raw_file("{\"w\": " + entry + "}", data));
  };
  CHECK(one("3", f4).find("tensor 'w': entry is not an object") != std::string::npos);
  CHECK(one(R"({"dtype": "F64", "shape": [1], "data_offsets": [0, 8]})", eight)
            .find("tensor 'w': dtype 'F64' is not F32, F16, BF16, I64, I32, U8 or BOOL") != std::string::npos);
  CHECK(one(R"({"shape": [1], "data_offsets": [0, 4]})", f4).find("no \"dtype\" string") != std::string::npos);
  CHECK(one(R"({"dtype": "F32", "data_offsets": [0, 4]})", f4).find("no \"shape\" array") != std::string::npos);
  CHECK(one(R"({"dtype": "F32", "shape": [-1], "data_offsets": [0, 4]})", f4)
            .find("shape entry -1 is not a non-negative integer") != std::string::npos);
  CHECK(one(R"({"dtype": "F32", "shape": [1.5], "data_offsets": [0, 4]})", f4).find("shape entry 1.5") !=
        std::string::npos);
  CHECK(one(R"({"dtype": "F32", "shape": [4294967296, 4294967296], "data_offsets": [0, 4]})", f4)
            .find("is too large") != std::string::npos);
  CHECK(one(R"({"dtype": "F32", "shape": [1], "data_offsets": [0]})", f4).find("\"data_offsets\" is not two") !=
        std::string::npos);
  CHECK(one(R"({"dtype": "F32", "shape": [1], "data_offsets": [4, 0]})", f4).find("end before they begin") !=
        std::string::npos);
  CHECK(one(R"({"dtype": "F32", "shape": [2], "data_offsets": [0, 4]})", f4)
            .find("tensor 'w': shape [2] of F32 needs 8 bytes, data_offsets give 4") != std::string::npos);
  CHECK(one(R"({"dtype": "F32", "shape": [2], "data_offsets": [0, 8]})", f4)
            .find("data_offsets end at 8, past the 4-byte data section") != std::string::npos);
  CHECK(one(R"({"dtype": "F32", "shape": [1], "data_offsets": [0, 4], "extra": 1})", f4)
            .find("unknown field 'extra'") != std::string::npos);
  // Two tensors: overlap, gap, trailing bytes, duplicate names.
  const std::string two = R"({"a": {"dtype": "F32", "shape": [1], "data_offsets": [0, 4]}, )";
  CHECK(error_of(raw_file(two + R"("b": {"dtype": "F32", "shape": [1], "data_offsets": [0, 4]}})", f4))
            .find("tensor 'b': bytes [0, 4) overlap another tensor") != std::string::npos);
  CHECK(error_of(raw_file(two + R"("b": {"dtype": "F32", "shape": [1], "data_offsets": [8, 12]}})", f4 + eight))
            .find("tensor 'b': a gap of 4 unclaimed bytes") != std::string::npos);
  CHECK(error_of(raw_file(two + R"("b": {"dtype": "F16", "shape": [1], "data_offsets": [4, 6]}})", f4 + f4))
            .find("2 bytes after the last tensor belong to no tensor") != std::string::npos);
  CHECK(error_of(raw_file(two + R"("a": {"dtype": "F32", "shape": [1], "data_offsets": [4, 8]}})", eight))
            .find("key 'a' appears twice") != std::string::npos);
  CHECK(error_of(raw_file(R"({"__metadata__": {"k": 1}})", "")).find("value of 'k' is not a string") !=
        std::string::npos);
  // A name with a newline stays one line.
  CHECK(error_of(raw_file("{\"a\\nb\": 3}", "")).find("tensor 'a?b'") != std::string::npos);
  // Files: missing, a directory.
  CHECK_THROWS_WITH_AS(nn::SafetensorsFile("/no/such/w.safetensors"),
                       doctest::Contains("/no/such/w.safetensors: cannot open"), scene::InputError);
  CHECK_THROWS_WITH_AS(nn::SafetensorsFile("/tmp"), doctest::Contains("/tmp: not a regular file"), scene::InputError);
  // A header that is valid but empty describes an empty data section.
  CHECK(nn::SafetensorsFile::from_bytes(raw_file("{}", ""), "empty").tensors().empty());
}

TEST_CASE("safetensors: the unet_small reference weights and intermediates load with the official names") {
  const std::string path = test::test_data_file("models/unet_small/weights.safetensors");
  if (path.empty()) return;
  const nn::SafetensorsFile f(path);
  CHECK(f.tensors().size() == 395);
  const nn::TensorInfo* conv = f.find("input_blocks.0.0.weight");
  REQUIRE(conv != nullptr);
  CHECK(conv->dtype == DType::F32);
  CHECK(conv->shape == std::vector<int64_t>{32, 16, 3, 3, 3});
  size_t params = 0;
  for (const nn::TensorInfo& t : f.tensors()) {
    params += t.numel();
    CHECK(f.first_non_finite(t) == -1);
  }
  CHECK(params * 4 == f.data_bytes());
  const std::string inter = test::test_data_file("models/unet_small/case_1.intermediates.safetensors");
  if (inter.empty()) return;
  const nn::SafetensorsFile g(inter);
  CHECK(!g.tensors().empty());
  for (const nn::TensorInfo& t : g.tensors()) CHECK(g.first_non_finite(t) == -1);
}
