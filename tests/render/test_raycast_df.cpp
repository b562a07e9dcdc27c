// The double-float primitives of shaders/common/df.glsl, on which the ray
// caster's float-only exact pass (shaders/raycast/exact_df.comp) rests, run on
// the device through the test kernel shaders/raycast/df_check.comp
// (render::df_check_gpu) and checked against long double on the CPU: TwoSum,
// TwoProduct and Veltkamp's split exact (the device neither fuses nor
// reassociates them), df add / mul / div / sqrt within their error bounds and
// normalised; the ray caster's df chord (raycast/chord_df.glsl) against the
// double formula of the CPU reference within the error its header derives;
// plus the host's double -> pair conversion (render::camera_df).
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "render/camera.h"
#include "render/raycast_gpu.h"
#include "shared/raycast_df_params.h"

#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <utility>
#include <vector>

using namespace icube;

namespace {

constexpr long double kU2 = 0x1p-48L;  // u^2, u = 2^-24

// A df pair (hi, lo) of x: hi = float(x), lo = float(x - hi).
glm::vec2 pair_of(long double x) {
  const float hi = static_cast<float>(x);
  return {hi, static_cast<float>(x - static_cast<long double>(hi))};
}

long double value(const glm::vec2& p) { return static_cast<long double>(p.x) + static_cast<long double>(p.y); }

// |lo| <= ulp(hi) / 2, i.e. hi == float(hi + lo).
bool normalised(const glm::vec2& p) { return static_cast<float>(value(p)) == p.x; }

// Random doubles with random signs and magnitudes 2^[-e, e].
struct Gen {
  std::mt19937_64 rng{12345};
  long double operator()(int e) {
    std::uniform_real_distribution<double> m(1.0, 2.0), x(-e, e);
    const long double v = std::ldexp(static_cast<long double>(m(rng)), static_cast<int>(std::lround(x(rng))));
    return (rng() & 1) ? -v : v;
  }
  // A double-precision random value (53 bits) with random magnitude.
  long double full(int e) {
    std::uniform_real_distribution<double> m(1.0, 2.0);
    const long double v = (*this)(e);
    return v * static_cast<long double>(m(rng)) / 1.5L;
  }
};

shader::RaycastDfCheckParams op_params(uint32_t op) {
  shader::RaycastDfCheckParams p{};
  p.op = op;
  return p;
}

int floatBitsToInt(float f) {
  int32_t i = 0;
  std::memcpy(&i, &f, 4);
  return i;
}

struct Stat {
  long double max_rel = 0.0L;
  size_t bad = 0, not_normal = 0;
};

}  // namespace

TEST_CASE("raycast df: TwoSum, TwoProduct and the Veltkamp split are exact on the device") {
  gpu::Context& ctx = test::gpu_context();
  Gen g;
  std::vector<glm::vec4> in;
  // Random floats within 2^±15 of 1 (the exact sum and product fit in long double's 64 bits),
  // plus cancellations and halfway cases.
  for (int i = 0; i < 20000; ++i) {
    const float a = static_cast<float>(g(15)), b = static_cast<float>(g(15));
    in.emplace_back(a, 0.0f, b, 0.0f);
  }
  for (float a : {1.0f, -3.0f, 0.1f, 16777215.0f, 1.0e-6f}) {
    in.emplace_back(a, 0.0f, -a, 0.0f);
    in.emplace_back(a, 0.0f, std::nextafter(-a, 0.0f), 0.0f);
    in.emplace_back(a, 0.0f, a * 0x1p-24f, 0.0f);  // a tie of the rounded sum
    in.emplace_back(a, 0.0f, a * 0x1p-25f, 0.0f);
    in.emplace_back(a, 0.0f, 0.0f, 0.0f);
  }
  const auto sum = render::df_check_gpu(ctx, op_params(RAYCAST_DF_TWO_SUM), in);
  const auto prod = render::df_check_gpu(ctx, op_params(RAYCAST_DF_TWO_PROD), in);
  const auto split = render::df_check_gpu(ctx, op_params(RAYCAST_DF_SPLIT), in);
  REQUIRE(sum.size() == in.size());
  size_t bad_sum = 0, bad_prod = 0, bad_split = 0;
  for (size_t i = 0; i < in.size(); ++i) {
    const float a = in[i].x, b = in[i].z;
    const long double exact_sum = static_cast<long double>(a) + b, exact_prod = static_cast<long double>(a) * b;
    // s is the rounded sum and s + e the exact one; the same for the product.
    const bool ok_sum = sum[i].x == static_cast<float>(exact_sum) && value(sum[i]) == exact_sum;
    const bool ok_prod = prod[i].x == static_cast<float>(exact_prod) && value(prod[i]) == exact_prod;
    // hi has at most 12 significant bits (its 12 low stored mantissa bits are 0), hi + lo == a.
    uint32_t bits = 0;
    std::memcpy(&bits, &split[i].x, 4);
    const bool ok_split = value(split[i]) == static_cast<long double>(a) && (bits & 0xfffu) == 0;
    auto d = [](float x) { return static_cast<double>(x); };
    if (!ok_sum && bad_sum++ < 5) std::printf("  two_sum(%a, %a) = (%a, %a)\n", d(a), d(b), d(sum[i].x), d(sum[i].y));
    if (!ok_prod && bad_prod++ < 5)
      std::printf("  two_prod(%a, %a) = (%a, %a)\n", d(a), d(b), d(prod[i].x), d(prod[i].y));
    if (!ok_split && bad_split++ < 5) std::printf("  split(%a) = (%a, %a)\n", d(a), d(split[i].x), d(split[i].y));
  }
  CHECK(bad_sum == 0);
  CHECK(bad_prod == 0);
  CHECK(bad_split == 0);
}

TEST_CASE("raycast df: add, mul, div and sqrt within their error bounds against long double") {
  gpu::Context& ctx = test::gpu_context();
  Gen g;
  std::vector<glm::vec4> in;
  std::vector<long double> A, B;
  auto push = [&](long double a, long double b) {
    const glm::vec2 pa = pair_of(a), pb = pair_of(b);
    in.emplace_back(pa.x, pa.y, pb.x, pb.y);
    A.push_back(value(pa));  // the operands as the device sees them
    B.push_back(value(pb));
  };
  for (int i = 0; i < 20000; ++i) push(g.full(30), g.full(30));
  for (int i = 0; i < 5000; ++i) {  // near cancellations: b = -a (1 + small)
    const long double a = g.full(10);
    push(a, -a * (1.0L + g.full(30) * 0x1p-20L));
  }
  for (long double a : {1.0L, 0.2L, 0.01L, 100.0L / 3.0L, 1.0e6L + 1.0L / 7.0L}) push(a, a);
  struct Op {
    uint32_t op;
    const char* name;
    long double bound;  // relative error, in u^2
  };
  for (const Op& op : {Op{RAYCAST_DF_ADD, "add", 3.0L}, Op{RAYCAST_DF_MUL, "mul", 7.0L}, Op{RAYCAST_DF_DIV, "div", 10.0L},
                       Op{RAYCAST_DF_SQRT, "sqrt", 10.0L}}) {
    CAPTURE(op.name);
    std::vector<glm::vec4> args = in;
    if (op.op == RAYCAST_DF_SQRT)
      for (glm::vec4& v : args) v = glm::vec4(std::fabs(v.x), v.x < 0.0f ? -v.y : v.y, 0.0f, 0.0f);
    const auto r = render::df_check_gpu(ctx, op_params(op.op), args);
    REQUIRE(r.size() == args.size());
    Stat st;
    for (size_t i = 0; i < args.size(); ++i) {
      const long double a = op.op == RAYCAST_DF_SQRT ? std::fabs(A[i]) : A[i], b = B[i];
      const long double want = op.op == RAYCAST_DF_ADD   ? a + b
                               : op.op == RAYCAST_DF_MUL ? a * b
                               : op.op == RAYCAST_DF_DIV ? a / b
                                                         : std::sqrt(a);
      const long double got = value(r[i]);
      const long double rel = want == 0.0L ? std::fabs(got) : std::fabs(got - want) / std::fabs(want);
      st.max_rel = std::max(st.max_rel, rel);
      if (rel > op.bound * kU2 && st.bad++ < 5)
        std::printf("  df_%s(%.21Lg, %.21Lg) = %.21Lg, want %.21Lg (%.3Lg u^2)\n", op.name, a, b, got, want, rel / kU2);
      st.not_normal += !normalised(r[i]);
    }
    std::printf("df_%s: %zu values, max relative error %.3Lg u^2 (bound %.0Lf)\n", op.name, args.size(),
                st.max_rel / kU2, op.bound);
    CHECK(st.bad == 0);
    CHECK(st.not_normal == 0);
  }
}

TEST_CASE("raycast df: the camera's doubles as float pairs") {
  shader::RaycastCameraF64 c{};
  c.r00 = 0.1;
  c.fx = 1234.5678901234;
  c.off_x = 0.7071067811865476;
  c.voxel_size = 0.2;
  c.eps_sem = 0.01;
  c.t_max = std::numeric_limits<double>::infinity();
  const shader::RaycastCameraDf d = render::camera_df(c);
  for (const auto& [x, p] : {std::pair{c.r00, d.r00}, std::pair{c.fx, d.fx}, std::pair{c.off_x, d.off_x},
                             std::pair{c.voxel_size, d.voxel_size}, std::pair{c.eps_sem, d.eps_sem}}) {
    CAPTURE(x);
    CHECK(p.hi == static_cast<float>(x));
    CHECK(std::fabs(static_cast<double>(p.hi) + static_cast<double>(p.lo) - x) <= 0x1p-48 * std::fabs(x));
  }
  CHECK(d.t_max.hi == FLT_MAX);
  CHECK(d.t_max.lo == 0.0f);
  CHECK(d.r01.hi == 0.0f);
}

namespace {

// The CPU reference's semantic chord of relative voxel v on pixel (u, w)'s ray (engine/render/camera.cpp
// camera_ray, the formulas of raycast_chord_f64 in raycast/traverse.glsl), with the unit direction
// components of the axes whose planes give the entry and the exit (0 where the entry is t = 0).
struct RefChord {
  double chord = 0.0, t_in = 0.0, d_in = 0.0, d_out = 0.0;
};

RefChord ref_chord(const render::Camera& cam, const glm::dvec3& o, double vs, const glm::ivec3& v, uint32_t u, uint32_t w,
                   int bound) {
  const glm::dvec3 d = render::camera_ray(cam, u, w, render::PixelConvention::Integer).dir;
  const glm::dvec3 dd = d / vs;
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity(), te = 0.0, tx = 1.0e300;
  double d0 = 0.0, d1 = 0.0, de = 0.0, dx = 0.0;
  for (int a = 0; a < 3; ++a) {
    if (dd[a] == 0.0) continue;
    const double ta = (-bound - o[a]) / dd[a], tb = (bound - o[a]) / dd[a];
    if (std::min(ta, tb) > t0) { t0 = std::min(ta, tb); d0 = d[a]; }
    if (std::max(ta, tb) < t1) { t1 = std::max(ta, tb); d1 = d[a]; }
    const int st = dd[a] > 0.0 ? 1 : -1;
    const double tin = ((st > 0 ? v[a] : v[a] + 1) - o[a]) / dd[a], tout = ((st > 0 ? v[a] + 1 : v[a]) - o[a]) / dd[a];
    if (tin > te) { te = tin; de = d[a]; }
    if (tout < tx) { tx = tout; dx = d[a]; }
  }
  RefChord r;
  r.t_in = std::max(te, t0);
  r.d_in = te >= t0 ? de : d0;
  r.d_out = tx <= t1 ? dx : d1;
  r.chord = std::max(std::min(tx, t1) - r.t_in, 0.0);
  return r;
}

}  // namespace

TEST_CASE("raycast df: the float-only exact pass's chord (raycast/chord_df.glsl) against the double formula") {
  gpu::Context& ctx = test::gpu_context();
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> unit(0.0, 1.0), tdist(0.3, 120.0);
  std::normal_distribution<double> n;
  const double vs = 0.2;
  const int bound = 1 << 20;
  double max_norm_err = 0.0, max_err = 0.0;
  size_t samples = 0, bad = 0;
  for (int c = 0; c < 8; ++c) {
    render::Camera cam;
    cam.K = {1050.0 + 100.0 * unit(rng), 1049.0 + 100.0 * unit(rng), 416.0 + unit(rng), 240.0 - unit(rng), 832, 480};
    const glm::dmat3 R = glm::mat3_cast(glm::normalize(glm::dquat(n(rng), n(rng), n(rng), n(rng))));
    cam.c2w = glm::dmat4(R);
    cam.c2w[3] = glm::dvec4(unit(rng) * vs, unit(rng) * vs, unit(rng) * vs, 1.0);  // in voxel 0 of a grid at 0
    const shader::RaycastCameraF64 c64 = render::camera_f64(cam, glm::dvec3(0.0), vs, {});
    const glm::dvec3 o(c64.off_x, c64.off_y, c64.off_z);  // camera position - reference voxel corner
    REQUIRE(glm::all(glm::lessThan(o, glm::dvec3(1.0))));
    std::vector<glm::vec4> in;
    std::vector<RefChord> want;
    for (int k = 0; k < 5000; ++k) {
      const uint32_t u = static_cast<uint32_t>(unit(rng) * 832.0), w = static_cast<uint32_t>(unit(rng) * 480.0);
      const glm::dvec3 d = render::camera_ray(cam, u, w, render::PixelConvention::Integer).dir;
      const glm::ivec3 v(glm::floor(o + tdist(rng) * d / vs));  // a voxel the ray passes through
      uint32_t bits[4] = {static_cast<uint32_t>(v.x), static_cast<uint32_t>(v.y), static_cast<uint32_t>(v.z), u | (w << 16)};
      glm::vec4 x;
      std::memcpy(&x, bits, sizeof x);
      in.push_back(x);
      want.push_back(ref_chord(cam, o, vs, v, u, w, bound));
    }
    shader::RaycastDfCheckParams p{};
    p.op = RAYCAST_DF_CHORD;
    p.lo_x = p.lo_y = p.lo_z = -bound;
    p.hi_x = p.hi_y = p.hi_z = bound;
    const auto got = render::df_check_gpu(ctx, p, in, render::camera_df(c64));
    REQUIRE(got.size() == in.size());
    for (size_t i = 0; i < in.size(); ++i) {
      const RefChord& rc = want[i];
      const double err = std::fabs(static_cast<double>(value(got[i]) - static_cast<long double>(rc.chord)));
      // The header's estimate: ~1e-13 t (1 / |d_in| + 1 / |d_out|) metres.
      const double scale = rc.t_in * ((rc.d_in != 0.0 ? 1.0 / std::fabs(rc.d_in) : 0.0) + 1.0 / std::fabs(rc.d_out)) + 1e-3;
      max_err = std::max(max_err, err);
      max_norm_err = std::max(max_norm_err, err / scale);
      if (err > 1e-13 * scale && bad++ < 5)
        std::printf("  chord of voxel (%d %d %d): df %.17Lg, double %.17g, t %.3f\n", floatBitsToInt(in[i].x),
                    floatBitsToInt(in[i].y), floatBitsToInt(in[i].z), value(got[i]), rc.chord, rc.t_in);
      ++samples;
    }
  }
  std::printf("df chord: %zu voxels on random camera rays (t 0.3-120 m), max |df - double| %.3g m, max / (t (1/|d_in| + "
              "1/|d_out|)) %.3g\n",
              samples, max_err, max_norm_err);
  CHECK(bad == 0);
  CHECK(max_err < 1e-9);
}
