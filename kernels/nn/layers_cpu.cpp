// Plain-loop CPU references of the network layers; see layers_cpu.h.
#include "nn/layers_cpu.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace icube::nn::cpu {

namespace {

double D(float v) { return static_cast<double>(v); }

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}

int64_t spatial_of(const CpuTensor& x) {
  int64_t n = 1;
  for (size_t i = 2; i < x.rank(); ++i) n *= x.shape[i];
  return n;
}

// 1x1 convolution over any spatial rank: w [Co, Ci, 1...].
CpuTensor pointwise(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias) {
  const int64_t B = x.dim(0), Ci = x.dim(1), Co = w.dim(0), S = spatial_of(x);
  require(w.dim(1) == Ci, "conv: weight " + w.shape_text() + " does not take " + std::to_string(Ci) + " channels");
  std::vector<int64_t> shape = x.shape;
  shape[1] = Co;
  CpuTensor y(shape);
  std::vector<double> acc(static_cast<size_t>(S));
  for (int64_t b = 0; b < B; ++b)
    for (int64_t co = 0; co < Co; ++co) {
      std::fill(acc.begin(), acc.end(), bias ? D(bias->data[static_cast<size_t>(co)]) : 0.0);
      for (int64_t ci = 0; ci < Ci; ++ci) {
        const double wv = D(w.data[static_cast<size_t>(co * Ci + ci)]);
        const float* xp = &x.data[static_cast<size_t>((b * Ci + ci) * S)];
        for (int64_t s = 0; s < S; ++s) acc[static_cast<size_t>(s)] += wv * D(xp[s]);
      }
      float* yp = &y.data[static_cast<size_t>((b * Co + co) * S)];
      for (int64_t s = 0; s < S; ++s) yp[s] = static_cast<float>(acc[static_cast<size_t>(s)]);
    }
  return y;
}

}  // namespace

CpuTensor conv3d(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias, int stride, int padding) {
  require(x.rank() >= 3, "conv3d: input " + x.shape_text() + " has no spatial axes");
  if (w.rank() != 5 || (w.dim(2) == 1 && w.dim(3) == 1 && w.dim(4) == 1 && stride == 1)) {
    require(w.rank() == 2 || w.rank() == 3 || w.rank() == 5, "conv: weight " + w.shape_text() + " is not a conv weight");
    return pointwise(x, w, bias);
  }
  require(x.rank() == 5, "conv3d: input " + x.shape_text() + " is not [B, C, X, Y, Z]");
  const int64_t B = x.dim(0), Ci = x.dim(1), X = x.dim(2), Y = x.dim(3), Z = x.dim(4);
  const int64_t Co = w.dim(0), K = w.dim(2);
  require(w.dim(1) == Ci && w.dim(3) == K && w.dim(4) == K,
          "conv3d: weight " + w.shape_text() + " does not fit input " + x.shape_text());
  const int64_t OX = (X + 2 * padding - K) / stride + 1, OY = (Y + 2 * padding - K) / stride + 1,
                OZ = (Z + 2 * padding - K) / stride + 1;
  require(OX > 0 && OY > 0 && OZ > 0, "conv3d: input " + x.shape_text() + " is smaller than the kernel");
  CpuTensor y({B, Co, OX, OY, OZ});
  std::vector<double> acc(static_cast<size_t>(OX * OY * OZ));
  for (int64_t b = 0; b < B; ++b)
    for (int64_t co = 0; co < Co; ++co) {
      std::fill(acc.begin(), acc.end(), bias ? D(bias->data[static_cast<size_t>(co)]) : 0.0);
      for (int64_t ci = 0; ci < Ci; ++ci) {
        const float* xp = &x.data[static_cast<size_t>(((b * Ci + ci) * X) * Y * Z)];
        for (int64_t kx = 0; kx < K; ++kx)
          for (int64_t ky = 0; ky < K; ++ky)
            for (int64_t kz = 0; kz < K; ++kz) {
              const double wv = D(w.data[static_cast<size_t>((((co * Ci + ci) * K + kx) * K + ky) * K + kz)]);
              for (int64_t ox = 0; ox < OX; ++ox) {
                const int64_t ix = ox * stride - padding + kx;
                if (ix < 0 || ix >= X) continue;
                for (int64_t oy = 0; oy < OY; ++oy) {
                  const int64_t iy = oy * stride - padding + ky;
                  if (iy < 0 || iy >= Y) continue;
                  double* ap = &acc[static_cast<size_t>((ox * OY + oy) * OZ)];
                  const float* row = xp + (ix * Y + iy) * Z;
                  for (int64_t oz = 0; oz < OZ; ++oz) {
                    const int64_t iz = oz * stride - padding + kz;
                    if (iz >= 0 && iz < Z) ap[oz] += wv * D(row[iz]);
                  }
                }
              }
            }
      }
      float* yp = &y.data[static_cast<size_t>((b * Co + co) * OX * OY * OZ)];
      for (size_t i = 0; i < acc.size(); ++i) yp[i] = static_cast<float>(acc[i]);
    }
  return y;
}

CpuTensor group_norm(const CpuTensor& x, int groups, const CpuTensor& weight, const CpuTensor& bias, double eps) {
  const int64_t B = x.dim(0), C = x.dim(1), S = spatial_of(x);
  require(groups > 0 && C % groups == 0, "group_norm: " + std::to_string(C) + " channels in " +
                                             std::to_string(groups) + " groups");
  require(weight.numel() == C && bias.numel() == C, "group_norm: affine parameters do not have " + std::to_string(C) +
                                                        " entries");
  const int64_t cg = C / groups;
  CpuTensor y(x.shape);
  for (int64_t b = 0; b < B; ++b)
    for (int64_t g = 0; g < groups; ++g) {
      const size_t base = static_cast<size_t>((b * C + g * cg) * S), n = static_cast<size_t>(cg * S);
      double mean = 0.0;
      for (size_t i = 0; i < n; ++i) mean += D(x.data[base + i]);
      mean /= static_cast<double>(n);
      double var = 0.0;
      for (size_t i = 0; i < n; ++i) var += (D(x.data[base + i]) - mean) * (D(x.data[base + i]) - mean);
      var /= static_cast<double>(n);
      const double inv = 1.0 / std::sqrt(var + eps);
      for (int64_t c = 0; c < cg; ++c) {
        const double wv = D(weight.data[static_cast<size_t>(g * cg + c)]), bv = D(bias.data[static_cast<size_t>(g * cg + c)]);
        for (int64_t s = 0; s < S; ++s) {
          const size_t i = base + static_cast<size_t>(c * S + s);
          y.data[i] = static_cast<float>((D(x.data[i]) - mean) * inv * wv + bv);
        }
      }
    }
  return y;
}

CpuTensor layer_norm(const CpuTensor& x, const CpuTensor& weight, const CpuTensor& bias, double eps) {
  const int64_t D_ = x.shape.back(), rows = x.numel() / D_;
  require(weight.numel() == D_ && bias.numel() == D_, "layer_norm: parameters do not have " + std::to_string(D_) + " entries");
  CpuTensor y(x.shape);
  for (int64_t r = 0; r < rows; ++r) {
    const float* p = &x.data[static_cast<size_t>(r * D_)];
    double mean = 0.0, var = 0.0;
    for (int64_t i = 0; i < D_; ++i) mean += D(p[i]);
    mean /= static_cast<double>(D_);
    for (int64_t i = 0; i < D_; ++i) var += (D(p[i]) - mean) * (D(p[i]) - mean);
    var /= static_cast<double>(D_);
    const double inv = 1.0 / std::sqrt(var + eps);
    for (int64_t i = 0; i < D_; ++i)
      y.data[static_cast<size_t>(r * D_ + i)] =
          static_cast<float>((D(p[i]) - mean) * inv * D(weight.data[static_cast<size_t>(i)]) + D(bias.data[static_cast<size_t>(i)]));
  }
  return y;
}

CpuTensor linear(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias) {
  require(w.rank() == 2 && w.dim(1) == x.shape.back(),
          "linear: weight " + w.shape_text() + " does not take input " + x.shape_text());
  const int64_t In = w.dim(1), Out = w.dim(0), rows = x.numel() / In;
  std::vector<int64_t> shape = x.shape;
  shape.back() = Out;
  CpuTensor y(shape);
  for (int64_t r = 0; r < rows; ++r)
    for (int64_t o = 0; o < Out; ++o) {
      double acc = bias ? D(bias->data[static_cast<size_t>(o)]) : 0.0;
      const float* xp = &x.data[static_cast<size_t>(r * In)];
      const float* wp = &w.data[static_cast<size_t>(o * In)];
      for (int64_t i = 0; i < In; ++i) acc += D(xp[i]) * D(wp[i]);
      y.data[static_cast<size_t>(r * Out + o)] = static_cast<float>(acc);
    }
  return y;
}

CpuTensor attention(const CpuTensor& q, const CpuTensor& k, const CpuTensor& v) {
  require(q.rank() == 4 && k.shape == q.shape && v.shape == q.shape, "attention: q, k, v must share one [B, H, N, D] shape");
  const int64_t BH = q.dim(0) * q.dim(1), N = q.dim(2), Dh = q.dim(3);
  const double scale = 1.0 / std::sqrt(static_cast<double>(Dh));
  CpuTensor out(q.shape);
  std::vector<double> logits(static_cast<size_t>(N));
  for (int64_t h = 0; h < BH; ++h) {
    const size_t base = static_cast<size_t>(h * N * Dh);
    for (int64_t i = 0; i < N; ++i) {
      double mx = -std::numeric_limits<double>::infinity();
      for (int64_t j = 0; j < N; ++j) {
        double dot = 0.0;
        for (int64_t d = 0; d < Dh; ++d)
          dot += D(q.data[base + static_cast<size_t>(i * Dh + d)]) * D(k.data[base + static_cast<size_t>(j * Dh + d)]);
        logits[static_cast<size_t>(j)] = dot * scale;
        mx = std::max(mx, logits[static_cast<size_t>(j)]);
      }
      double sum = 0.0;
      for (double& l : logits) sum += (l = std::exp(l - mx));
      for (int64_t d = 0; d < Dh; ++d) {
        double acc = 0.0;
        for (int64_t j = 0; j < N; ++j) acc += logits[static_cast<size_t>(j)] * D(v.data[base + static_cast<size_t>(j * Dh + d)]);
        out.data[base + static_cast<size_t>(i * Dh + d)] = static_cast<float>(acc / sum);
      }
    }
  }
  return out;
}

CpuTensor silu(CpuTensor x) {
  for (float& v : x.data) v = static_cast<float>(D(v) / (1.0 + std::exp(-D(v))));
  return x;
}

CpuTensor gelu(CpuTensor x) {
  for (float& v : x.data) v = static_cast<float>(0.5 * D(v) * (1.0 + std::erf(D(v) / std::sqrt(2.0))));
  return x;
}

CpuTensor add(CpuTensor a, const CpuTensor& b) {
  require(a.shape == b.shape, "add: shapes " + a.shape_text() + " and " + b.shape_text() + " differ");
  for (size_t i = 0; i < a.data.size(); ++i) a.data[i] += b.data[i];
  return a;
}

CpuTensor scale_shift(CpuTensor h, const CpuTensor& ss) {
  const int64_t B = h.dim(0), C = h.dim(1), S = spatial_of(h);
  require(ss.rank() == 2 && ss.dim(0) == B && ss.dim(1) == 2 * C, "scale_shift: modulation " + ss.shape_text() +
                                                                       " does not fit " + h.shape_text());
  for (int64_t b = 0; b < B; ++b)
    for (int64_t c = 0; c < C; ++c) {
      const float scale = ss.data[static_cast<size_t>(b * 2 * C + c)], shift = ss.data[static_cast<size_t>(b * 2 * C + C + c)];
      float* p = &h.data[static_cast<size_t>((b * C + c) * S)];
      for (int64_t s = 0; s < S; ++s) p[s] = p[s] * (1.0f + scale) + shift;
    }
  return h;
}

CpuTensor add_channel_bias(CpuTensor h, const CpuTensor& e) {
  const int64_t B = h.dim(0), C = h.dim(1), S = spatial_of(h);
  require(e.rank() == 2 && e.dim(0) == B && e.dim(1) == C, "add_channel_bias: " + e.shape_text() + " does not fit " +
                                                               h.shape_text());
  for (int64_t b = 0; b < B; ++b)
    for (int64_t c = 0; c < C; ++c) {
      float* p = &h.data[static_cast<size_t>((b * C + c) * S)];
      for (int64_t s = 0; s < S; ++s) p[s] += e.data[static_cast<size_t>(b * C + c)];
    }
  return h;
}

CpuTensor avg_pool2(const CpuTensor& x) {
  require(x.rank() == 5, "avg_pool2: input " + x.shape_text() + " is not [B, C, X, Y, Z]");
  const int64_t BC = x.dim(0) * x.dim(1), X = x.dim(2), Y = x.dim(3), Z = x.dim(4);
  const int64_t OX = X / 2, OY = Y / 2, OZ = Z / 2;
  require(OX > 0 && OY > 0 && OZ > 0, "avg_pool2: input " + x.shape_text() + " has an axis shorter than 2");
  CpuTensor y({x.dim(0), x.dim(1), OX, OY, OZ});
  for (int64_t bc = 0; bc < BC; ++bc)
    for (int64_t i = 0; i < OX; ++i)
      for (int64_t j = 0; j < OY; ++j)
        for (int64_t l = 0; l < OZ; ++l) {
          double s = 0.0;
          for (int d = 0; d < 8; ++d)
            s += D(x.data[static_cast<size_t>(((bc * X + 2 * i + (d & 1)) * Y + 2 * j + ((d >> 1) & 1)) * Z + 2 * l + (d >> 2))]);
          y.data[static_cast<size_t>(((bc * OX + i) * OY + j) * OZ + l)] = static_cast<float>(s / 8.0);
        }
  return y;
}

CpuTensor upsample2(const CpuTensor& x) {
  require(x.rank() == 5, "upsample2: input " + x.shape_text() + " is not [B, C, X, Y, Z]");
  const int64_t BC = x.dim(0) * x.dim(1), X = x.dim(2), Y = x.dim(3), Z = x.dim(4);
  CpuTensor y({x.dim(0), x.dim(1), 2 * X, 2 * Y, 2 * Z});
  for (int64_t bc = 0; bc < BC; ++bc)
    for (int64_t i = 0; i < 2 * X; ++i)
      for (int64_t j = 0; j < 2 * Y; ++j)
        for (int64_t l = 0; l < 2 * Z; ++l)
          y.data[static_cast<size_t>(((bc * 2 * X + i) * 2 * Y + j) * 2 * Z + l)] =
              x.data[static_cast<size_t>(((bc * X + i / 2) * Y + j / 2) * Z + l / 2)];
  return y;
}

CpuTensor concat_channels(const CpuTensor& a, const CpuTensor& b) {
  require(a.rank() == b.rank() && a.dim(0) == b.dim(0) && spatial_of(a) == spatial_of(b),
          "concat: " + a.shape_text() + " and " + b.shape_text() + " differ beyond the channels");
  const int64_t B = a.dim(0), Ca = a.dim(1), Cb = b.dim(1), S = spatial_of(a);
  std::vector<int64_t> shape = a.shape;
  shape[1] = Ca + Cb;
  CpuTensor y(shape);
  for (int64_t n = 0; n < B; ++n) {
    std::copy_n(&a.data[static_cast<size_t>(n * Ca * S)], Ca * S, &y.data[static_cast<size_t>(n * (Ca + Cb) * S)]);
    std::copy_n(&b.data[static_cast<size_t>(n * Cb * S)], Cb * S, &y.data[static_cast<size_t>((n * (Ca + Cb) + Ca) * S)]);
  }
  return y;
}

CpuTensor timestep_embedding(const std::vector<int64_t>& t, int dim, double max_period) {
  const int half = dim / 2;
  CpuTensor e({static_cast<int64_t>(t.size()), dim});
  const float c = static_cast<float>(-std::log(max_period));
  for (size_t b = 0; b < t.size(); ++b)
    for (int i = 0; i < half; ++i) {
      const float freq = std::exp(c * static_cast<float>(i) / static_cast<float>(half));
      const float arg = static_cast<float>(t[b]) * freq;
      e.data[b * static_cast<size_t>(dim) + static_cast<size_t>(i)] = std::cos(arg);
      e.data[b * static_cast<size_t>(dim) + static_cast<size_t>(half + i)] = std::sin(arg);
    }
  return e;  // an odd dim keeps its last entry 0, as upstream pads
}

double max_abs_over_std(const std::vector<float>& got, const std::vector<float>& ref) {
  require(got.size() == ref.size() && !ref.empty(), "max_abs_over_std: sizes differ or are empty");
  double mean = 0.0, var = 0.0, mx = 0.0;
  for (float v : ref) mean += D(v);
  mean /= static_cast<double>(ref.size());
  for (float v : ref) var += (D(v) - mean) * (D(v) - mean);
  for (size_t i = 0; i < got.size(); ++i) mx = std::max(mx, std::abs(D(got[i]) - D(ref[i])));
  return mx / std::max(std::sqrt(var / static_cast<double>(ref.size())), 1e-30);
}

}  // namespace icube::nn::cpu
