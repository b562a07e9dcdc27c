// CPU rasteriser: coverage masks (strokes, polygons, circles, rects, stripes),
// compositing onto an RGBA8 canvas, stb_easy_font text, and pixel-space
// polyline helpers. Conventions in raster.h.
#include "scene/raster.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-compare"
#include <stb/stb_easy_font.h>
#pragma GCC diagnostic pop

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <stdexcept>

namespace icube::scene {

namespace {

bool finite2(glm::dvec2 p) { return std::isfinite(p.x) && std::isfinite(p.y); }

double clamp01(double v) { return v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v); }

// floor / ceil of a finite coordinate, clamped to [lo, hi] before the int
// conversion (shapes far outside the image must not overflow an int).
int floor_px(double v, int lo, int hi) {
  return static_cast<int>(std::clamp(std::floor(v), static_cast<double>(lo), static_cast<double>(hi)));
}
int ceil_px(double v, int lo, int hi) {
  return static_cast<int>(std::clamp(std::ceil(v), static_cast<double>(lo), static_cast<double>(hi)));
}

// Axis-aligned quads of stb_easy_font for `text` at (0, 0), in font units.
struct TextRect {
  double x0, y0, x1, y1;
};

// The text as stb_easy_font can index it: newlines kept, anything outside
// printable ASCII replaced by '?', NUL-terminated.
std::vector<char> font_chars(const std::string& text) {
  std::vector<char> chars;
  chars.reserve(text.size() + 1);
  for (char c : text) chars.push_back(c == '\n' || (c >= 32 && c <= 126) ? c : '?');
  chars.push_back('\0');
  return chars;
}

std::vector<TextRect> text_rects(const std::string& text) {
  std::vector<char> chars = font_chars(text);
  // Each vertex is 16 bytes (x, y, z floats + RGBA); a glyph has at most ~10 quads.
  std::vector<char> buffer(text.size() * 16 * 4 * 16 + 1024);
  unsigned char colour[4] = {255, 255, 255, 255};
  const int quads = stb_easy_font_print(0.0f, 0.0f, chars.data(), colour, buffer.data(), static_cast<int>(buffer.size()));
  std::vector<TextRect> rects;
  rects.reserve(static_cast<size_t>(quads));
  for (int q = 0; q < quads; ++q) {
    float v0[2], v2[2];
    std::memcpy(v0, buffer.data() + static_cast<size_t>(q) * 64, sizeof v0);
    std::memcpy(v2, buffer.data() + static_cast<size_t>(q) * 64 + 32, sizeof v2);
    const double x0 = static_cast<double>(v0[0]), y0 = static_cast<double>(v0[1]);
    const double x1 = static_cast<double>(v2[0]), y1 = static_cast<double>(v2[1]);
    rects.push_back({std::min(x0, x1), std::min(y0, y1), std::max(x0, x1), std::max(y0, y1)});
  }
  return rects;
}

}  // namespace

Rgba with_opacity(Rgba c, double opacity) {
  c.a = static_cast<uint8_t>(std::lround(c.a * clamp01(opacity)));
  return c;
}

// ---- CoverageMask ---------------------------------------------------------------------

CoverageMask::CoverageMask(int width, int height) : width_(width), height_(height) {
  if (width <= 0 || height <= 0 || width > 65536 || height > 65536)
    throw std::invalid_argument("raster: image size " + std::to_string(width) + " x " + std::to_string(height) +
                                " is out of range (1 to 65536)");
  cov_.assign(static_cast<size_t>(width) * static_cast<size_t>(height), 0.0f);
  x0_ = width_, y0_ = height_, x1_ = 0, y1_ = 0;
}

double CoverageMask::total() const {
  double sum = 0.0;
  for (float c : cov_) sum += static_cast<double>(c);
  return sum;
}

void CoverageMask::clear() {
  for (int y = y0_; y < y1_; ++y)
    std::fill_n(cov_.begin() + static_cast<long>(y) * width_ + x0_, x1_ - x0_, 0.0f);
  x0_ = width_, y0_ = height_, x1_ = 0, y1_ = 0;
}

void CoverageMask::touch(int x0, int y0, int x1, int y1) {
  x0_ = std::min(x0_, x0), y0_ = std::min(y0_, y0);
  x1_ = std::max(x1_, x1), y1_ = std::max(y1_, y1);
}

void CoverageMask::put(int x, int y, float c) {
  float& dst = cov_[static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x)];
  if (c > dst) dst = c;
}

void CoverageMask::stroke_segment(glm::dvec2 a, glm::dvec2 b, double width) {
  if (!(width > 0.0) || !std::isfinite(width) || !finite2(a) || !finite2(b)) return;
  // Coverage = clamp(hw + 0.5 - distance, 0, 1) · gain: a unit ramp either
  // side, so the profile across integrates to max(w, 1) · gain = w.
  const double hw = std::max(width, 1.0) * 0.5, gain = std::min(width, 1.0);
  const double reach = hw + 0.5;
  {
    // Clip to the image grown by the reach (Liang-Barsky): far-away endpoints
    // would otherwise cost precision in the distances below.
    const glm::dvec2 d0 = b - a;
    double t0 = 0.0, t1 = 1.0;
    auto keep = [&](double p, double q) {  // the part with p·t <= q
      if (p == 0.0) return q >= 0.0;
      const double r = q / p;
      if (p < 0.0) {
        if (r > t1) return false;
        t0 = std::max(t0, r);
      } else {
        if (r < t0) return false;
        t1 = std::min(t1, r);
      }
      return true;
    };
    const double lo = -reach - 1.0, hx = width_ + reach + 1.0, hy = height_ + reach + 1.0;
    if (!keep(-d0.x, a.x - lo) || !keep(d0.x, hx - a.x) || !keep(-d0.y, a.y - lo) || !keep(d0.y, hy - a.y)) return;
    if (t0 > 0.0 || t1 < 1.0) {
      const glm::dvec2 a0 = a;
      a = a0 + t0 * d0, b = a0 + t1 * d0;
    }
  }
  const int ya = floor_px(std::min(a.y, b.y) - reach, 0, height_);
  const int yb = ceil_px(std::max(a.y, b.y) + reach, 0, height_);
  if (ya >= yb) return;
  const glm::dvec2 d = b - a;
  const double len2 = glm::dot(d, d);
  int tx0 = width_, tx1 = 0;
  for (int y = ya; y < yb; ++y) {
    const double py = y + 0.5;
    double xlo = std::min(a.x, b.x), xhi = std::max(a.x, b.x);
    if (std::abs(d.y) > 1e-12) {
      double t0 = clamp01((py - reach - a.y) / d.y), t1 = clamp01((py + reach - a.y) / d.y);
      xlo = std::min(a.x + t0 * d.x, a.x + t1 * d.x);
      xhi = std::max(a.x + t0 * d.x, a.x + t1 * d.x);
    }
    const int xs = floor_px(xlo - reach, 0, width_);
    const int xe = ceil_px(xhi + reach, 0, width_);
    for (int x = xs; x < xe; ++x) {
      const glm::dvec2 p(x + 0.5, py);
      const double t = len2 > 0.0 ? clamp01(glm::dot(p - a, d) / len2) : 0.0;
      const double dist = glm::length(p - (a + t * d));
      const double c = clamp01(hw + 0.5 - dist) * gain;
      if (c > 0.0) put(x, y, static_cast<float>(c));
    }
    tx0 = std::min(tx0, xs), tx1 = std::max(tx1, xe);
  }
  if (tx0 < tx1) touch(tx0, ya, tx1, yb);
}

void CoverageMask::stroke_polyline(const std::vector<glm::dvec2>& points, double width, bool closed) {
  if (points.size() == 1) stroke_segment(points[0], points[0], width);
  for (size_t i = 1; i < points.size(); ++i) stroke_segment(points[i - 1], points[i], width);
  if (closed && points.size() > 2) stroke_segment(points.back(), points.front(), width);
}

void CoverageMask::fill_polygon(const std::vector<glm::dvec2>& ring) { fill_polygons({ring}); }

void CoverageMask::fill_polygons(const std::vector<std::vector<glm::dvec2>>& rings) {
  struct Edge {
    double x0, y0, x1, y1;
    int dir;
  };
  std::vector<Edge> edges;
  double ymin = 1e300, ymax = -1e300, xmin = 1e300, xmax = -1e300;
  for (const auto& ring : rings) {
    for (size_t i = 0; i < ring.size(); ++i) {
      glm::dvec2 p = ring[i], q = ring[(i + 1) % ring.size()];
      if (!finite2(p) || !finite2(q) || p.y == q.y) continue;
      int dir = 1;
      if (p.y > q.y) std::swap(p, q), dir = -1;
      edges.push_back({p.x, p.y, q.x, q.y, dir});
      ymin = std::min(ymin, p.y), ymax = std::max(ymax, q.y);
      xmin = std::min({xmin, p.x, q.x}), xmax = std::max({xmax, p.x, q.x});
    }
  }
  if (edges.empty()) return;
  const int ra = floor_px(ymin, 0, height_);
  const int rb = ceil_px(ymax, 0, height_);
  const int ca = floor_px(xmin, 0, width_);
  const int cb = ceil_px(xmax + 1.0, 0, width_);
  if (ra >= rb || ca >= cb) return;
  std::sort(edges.begin(), edges.end(), [](const Edge& e, const Edge& f) { return e.y0 < f.y0; });

  constexpr int kSub = 4;
  constexpr double kWeight = 1.0 / kSub;
  std::vector<double> acc(static_cast<size_t>(cb - ca));
  std::vector<std::pair<double, int>> crossings;
  std::vector<size_t> active;
  size_t next = 0;
  auto add_span = [&](double xa, double xb) {
    xa = std::max(xa, static_cast<double>(ca)), xb = std::min(xb, static_cast<double>(cb));
    if (xb <= xa) return;
    const int ia = static_cast<int>(std::floor(xa)), ib = static_cast<int>(std::floor(xb));
    if (ia == ib) {
      acc[static_cast<size_t>(ia - ca)] += (xb - xa) * kWeight;
      return;
    }
    acc[static_cast<size_t>(ia - ca)] += (ia + 1 - xa) * kWeight;
    for (int i = ia + 1; i < ib; ++i) acc[static_cast<size_t>(i - ca)] += kWeight;
    if (ib < cb) acc[static_cast<size_t>(ib - ca)] += (xb - ib) * kWeight;
  };
  // Edges that start above the first row are activated by the same loop.
  for (int row = ra; row < rb; ++row) {
    std::fill(acc.begin(), acc.end(), 0.0);
    bool any = false;
    for (int k = 0; k < kSub; ++k) {
      const double ys = row + (k + 0.5) * kWeight;
      while (next < edges.size() && edges[next].y0 <= ys) active.push_back(next++);
      crossings.clear();
      std::erase_if(active, [&](size_t e) { return edges[e].y1 <= ys; });
      for (size_t e : active) {
        const Edge& ed = edges[e];
        crossings.emplace_back(ed.x0 + (ys - ed.y0) * (ed.x1 - ed.x0) / (ed.y1 - ed.y0), ed.dir);
      }
      if (crossings.size() < 2) continue;
      std::sort(crossings.begin(), crossings.end());
      int wind = 0;
      double start = 0.0;
      for (const auto& [x, dir] : crossings) {
        const int before = wind;
        wind += dir;
        if (before == 0 && wind != 0) start = x;
        if (before != 0 && wind == 0) add_span(start, x), any = true;
      }
    }
    if (!any) continue;
    for (int x = ca; x < cb; ++x) {
      const double c = acc[static_cast<size_t>(x - ca)];
      if (c > 0.0) put(x, row, static_cast<float>(std::min(c, 1.0)));
    }
    touch(ca, row, cb, row + 1);
  }
}

void CoverageMask::fill_circle(glm::dvec2 centre, double radius) {
  if (!(radius > 0.0) || !std::isfinite(radius) || !finite2(centre)) return;
  const double reach = radius + 0.5;
  const int ya = floor_px(centre.y - reach, 0, height_);
  const int yb = ceil_px(centre.y + reach, 0, height_);
  const int xa = floor_px(centre.x - reach, 0, width_);
  const int xb = ceil_px(centre.x + reach, 0, width_);
  if (ya >= yb || xa >= xb) return;
  const double gain = std::min(1.0, radius * 2.0);
  for (int y = ya; y < yb; ++y)
    for (int x = xa; x < xb; ++x) {
      const double d = glm::length(glm::dvec2(x + 0.5, y + 0.5) - centre);
      const double c = clamp01(std::max(radius, 0.5) + 0.5 - d) * gain;
      if (c > 0.0) put(x, y, static_cast<float>(c));
    }
  touch(xa, ya, xb, yb);
}

void CoverageMask::fill_rect(double x0, double y0, double x1, double y1) {
  if (!(x1 > x0) || !(y1 > y0)) return;
  const int xa = floor_px(x0, 0, width_), xb = ceil_px(x1, 0, width_);
  const int ya = floor_px(y0, 0, height_), yb = ceil_px(y1, 0, height_);
  if (xa >= xb || ya >= yb) return;
  for (int y = ya; y < yb; ++y) {
    const double cy = std::min<double>(y + 1, y1) - std::max<double>(y, y0);
    for (int x = xa; x < xb; ++x) {
      const double cx = std::min<double>(x + 1, x1) - std::max<double>(x, x0);
      put(x, y, static_cast<float>(clamp01(cx) * clamp01(cy)));
    }
  }
  touch(xa, ya, xb, yb);
}

void CoverageMask::modulate_stripes(glm::dvec2 origin, glm::dvec2 direction, double period, double duty) {
  if (!(period > 0.0) || x0_ >= x1_) return;
  const double on = period * clamp01(duty);
  for (int y = y0_; y < y1_; ++y)
    for (int x = x0_; x < x1_; ++x) {
      float& c = cov_[static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x)];
      if (c <= 0.0f) continue;
      const double u = glm::dot(glm::dvec2(x + 0.5, y + 0.5) - origin, direction);
      const double t = u - std::floor(u / period) * period;  // [0, period)
      const double inside = t < on ? std::min(t, on - t) : -std::min(t - on, period - t);
      c = static_cast<float>(static_cast<double>(c) * clamp01(inside + 0.5));
    }
}

// ---- Canvas ---------------------------------------------------------------------------

Canvas::Canvas(int width, int height, Rgba background) : width_(width), height_(height), scratch_(width, height) {
  pixels_.resize(static_cast<size_t>(width) * static_cast<size_t>(height) * 4);
  fill(background);
}

Rgba Canvas::pixel(int x, int y) const {
  if (x < 0 || y < 0 || x >= width_ || y >= height_) return {0, 0, 0, 0};
  const uint8_t* p = &pixels_[(static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x)) * 4];
  return {p[0], p[1], p[2], p[3]};
}

void Canvas::fill(Rgba c) {
  for (size_t i = 0; i < pixels_.size(); i += 4) {
    pixels_[i] = c.r, pixels_[i + 1] = c.g, pixels_[i + 2] = c.b, pixels_[i + 3] = c.a;
  }
}

void Canvas::blend(int x, int y, Rgba c, double coverage) {
  if (x < 0 || y < 0 || x >= width_ || y >= height_) return;
  const double a = c.a / 255.0 * clamp01(coverage);
  if (a <= 0.0) return;
  uint8_t* p = &pixels_[(static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x)) * 4];
  const double da = p[3] / 255.0;
  const double oa = a + da * (1.0 - a);
  const uint8_t src[3] = {c.r, c.g, c.b};
  for (int ch = 0; ch < 3; ++ch)
    p[ch] = static_cast<uint8_t>(std::lround((src[ch] * a + p[ch] * da * (1.0 - a)) / oa));
  p[3] = static_cast<uint8_t>(std::lround(oa * 255.0));
}

void Canvas::composite(CoverageMask& mask, Rgba c) {
  if (mask.width() != width_ || mask.height() != height_)
    throw std::invalid_argument("raster: mask size differs from the canvas");
  for (int y = mask.dirty_y0(); y < mask.dirty_y1(); ++y)
    for (int x = mask.dirty_x0(); x < mask.dirty_x1(); ++x) {
      const float m = mask.at(x, y);
      if (m > 0.0f) blend(x, y, c, static_cast<double>(m));
    }
  mask.clear();
}

void Canvas::stroke_polyline(const std::vector<glm::dvec2>& points, double width, Rgba c, bool closed) {
  scratch_.stroke_polyline(points, width, closed);
  composite(scratch_, c);
}

void Canvas::stroke_dashed(const std::vector<glm::dvec2>& points, double width, double dash, double gap, Rgba c) {
  for (const auto& piece : dash_polyline(points, dash, gap)) scratch_.stroke_polyline(piece, width);
  composite(scratch_, c);
}

void Canvas::fill_polygon(const std::vector<glm::dvec2>& ring, Rgba c) {
  scratch_.fill_polygon(ring);
  composite(scratch_, c);
}

void Canvas::fill_circle(glm::dvec2 centre, double radius, Rgba c) {
  scratch_.fill_circle(centre, radius);
  composite(scratch_, c);
}

void Canvas::stroke_circle(glm::dvec2 centre, double radius, double width, Rgba c) {
  const int n = std::clamp(static_cast<int>(radius * 2.0), 16, 256);
  std::vector<glm::dvec2> ring;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * std::numbers::pi * i / n;
    ring.push_back(centre + radius * glm::dvec2(std::cos(a), std::sin(a)));
  }
  stroke_polyline(ring, width, c, true);
}

void Canvas::fill_rect(double x0, double y0, double x1, double y1, Rgba c) {
  scratch_.fill_rect(x0, y0, x1, y1);
  composite(scratch_, c);
}

void Canvas::draw_text(int x, int y, const std::string& text, Rgba c, int scale, Rgba halo) {
  if (text.empty() || scale <= 0) return;
  const std::vector<TextRect> rects = text_rects(text);
  const double s = scale;
  if (halo.a > 0) {
    for (const TextRect& r : rects)
      scratch_.fill_rect(x + r.x0 * s - s, y + r.y0 * s - s, x + r.x1 * s + s, y + r.y1 * s + s);
    composite(scratch_, halo);
  }
  for (const TextRect& r : rects) scratch_.fill_rect(x + r.x0 * s, y + r.y0 * s, x + r.x1 * s, y + r.y1 * s);
  composite(scratch_, c);
}

int text_width(const std::string& text, int scale) {
  std::vector<char> chars = font_chars(text);
  return stb_easy_font_width(chars.data()) * scale;
}

int text_height(const std::string& text, int scale) {
  std::vector<char> chars = font_chars(text);
  return stb_easy_font_height(chars.data()) * scale;
}

// ---- polyline geometry -------------------------------------------------------------------

std::vector<std::vector<glm::dvec2>> dash_polyline(const std::vector<glm::dvec2>& points, double dash, double gap) {
  std::vector<std::vector<glm::dvec2>> out;
  if (points.size() < 2 || !(dash > 0.0) || !(gap > 0.0)) return out;
  bool on = true;
  double left = dash;  // length remaining in the current dash or gap
  std::vector<glm::dvec2> cur{points[0]};
  for (size_t i = 1; i < points.size(); ++i) {
    glm::dvec2 a = points[i - 1];
    const glm::dvec2 b = points[i];
    double seg = glm::length(b - a);
    while (seg > 0.0 && seg >= left) {
      const glm::dvec2 p = a + (b - a) * (left / seg);
      if (on) {
        cur.push_back(p);
        out.push_back(std::move(cur));
        cur.clear();
      } else {
        cur = {p};
      }
      seg -= left;
      a = p;
      on = !on;
      left = on ? dash : gap;
    }
    left -= seg;
    if (on) cur.push_back(b);
  }
  if (on && cur.size() >= 2) out.push_back(std::move(cur));
  return out;
}

std::vector<glm::dvec2> offset_polyline(const std::vector<glm::dvec2>& points, double distance) {
  const size_t n = points.size();
  std::vector<glm::dvec2> out(points);
  if (n < 2) return out;
  // Unit normal of each segment; zero-length segments borrow their neighbour's.
  std::vector<glm::dvec2> seg_normal(n - 1, glm::dvec2(0.0));
  for (size_t i = 0; i + 1 < n; ++i) {
    const glm::dvec2 d = points[i + 1] - points[i];
    const double len = glm::length(d);
    if (len > 1e-12) seg_normal[i] = glm::dvec2(-d.y, d.x) / len;
  }
  for (size_t i = 1; i < seg_normal.size(); ++i)
    if (seg_normal[i] == glm::dvec2(0.0)) seg_normal[i] = seg_normal[i - 1];
  for (size_t i = seg_normal.size() - 1; i-- > 0;)
    if (seg_normal[i] == glm::dvec2(0.0)) seg_normal[i] = seg_normal[i + 1];
  for (size_t i = 0; i < n; ++i) {
    const glm::dvec2 a = seg_normal[i == 0 ? 0 : i - 1], b = seg_normal[i == n - 1 ? n - 2 : i];
    glm::dvec2 m = a + b;
    const double len = glm::length(m);
    if (len < 1e-9) {
      out[i] = points[i] + a * distance;  // a full reversal: keep the incoming side
      continue;
    }
    m /= len;
    const double cos_half = std::max(glm::dot(m, a), 0.5);  // miter length ≤ 2 × distance
    out[i] = points[i] + m * (distance / cos_half);
  }
  return out;
}

std::vector<glm::dvec2> thin_polyline(const std::vector<glm::dvec2>& points, double min_spacing) {
  if (points.size() <= 2) return points;
  std::vector<glm::dvec2> out{points.front()};
  const double min2 = min_spacing * min_spacing;
  for (size_t i = 1; i + 1 < points.size(); ++i) {
    const glm::dvec2 d = points[i] - out.back();
    if (glm::dot(d, d) >= min2) out.push_back(points[i]);
  }
  out.push_back(points.back());
  return out;
}

}  // namespace icube::scene
