// A small CPU rasteriser for diagnostic pictures (map plots): an RGBA8 canvas
// and an anti-aliased coverage mask.
//
// Pixel (x, y) covers [x, x+1) × [y, y+1) with y pointing down; its centre is
// (x + 0.5, y + 0.5). Shapes are first rasterised into a CoverageMask (a float
// per pixel in [0, 1]; overlapping shapes combine by max, so a polyline or a
// whole layer of strokes blends once, with no darker joints), then composited
// onto the canvas with a colour ("source over", straight alpha, sRGB values
// blended as stored).
//
//   strokes: coverage from the distance to the segment (round caps and joins);
//            across a stroke of width w >= 1 the coverage integrates to w
//   polygons: nonzero winding, exact horizontal coverage on 4 sub-scanlines
//   text: stb_easy_font quads at an integer scale (ASCII 32-126)
#pragma once

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace icube::scene {

struct Rgba {
  uint8_t r = 0, g = 0, b = 0, a = 255;
  bool operator==(const Rgba&) const = default;
};

// `c` with its alpha multiplied by `opacity` (clamped to [0, 1]).
Rgba with_opacity(Rgba c, double opacity);

class CoverageMask {
 public:
  CoverageMask(int width, int height);

  int width() const { return width_; }
  int height() const { return height_; }
  float at(int x, int y) const { return cov_[static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x)]; }
  // Sum of all coverage (pixel area covered).
  double total() const;

  // Zeroes the touched rectangle.
  void clear();
  // The rectangle written since the last clear(): [x0, x1) × [y0, y1); empty when x0 >= x1.
  int dirty_x0() const { return x0_; }
  int dirty_y0() const { return y0_; }
  int dirty_x1() const { return x1_; }
  int dirty_y1() const { return y1_; }

  void stroke_segment(glm::dvec2 a, glm::dvec2 b, double width);
  void stroke_polyline(const std::vector<glm::dvec2>& points, double width, bool closed = false);
  // One ring (closed implicitly); nonzero winding.
  void fill_polygon(const std::vector<glm::dvec2>& ring);
  // Several rings filled together (holes by opposite winding).
  void fill_polygons(const std::vector<std::vector<glm::dvec2>>& rings);
  void fill_circle(glm::dvec2 centre, double radius);
  // Axis-aligned rectangle [x0, x1) × [y0, y1) with fractional edges.
  void fill_rect(double x0, double y0, double x1, double y1);
  // Multiplies the coverage by stripes across `direction` (unit): on for
  // `duty` of every `period` pixels measured from `origin` along it.
  void modulate_stripes(glm::dvec2 origin, glm::dvec2 direction, double period, double duty);

 private:
  void put(int x, int y, float c);
  void touch(int x0, int y0, int x1, int y1);

  int width_, height_;
  std::vector<float> cov_;
  int x0_, y0_, x1_, y1_;
};

class Canvas {
 public:
  Canvas(int width, int height, Rgba background);

  int width() const { return width_; }
  int height() const { return height_; }
  // Row-major RGBA8, width*height*4 bytes.
  const std::vector<uint8_t>& rgba() const { return pixels_; }
  Rgba pixel(int x, int y) const;
  void fill(Rgba c);
  // Blends `c` at `coverage` (0..1) over pixel (x, y); outside pixels are ignored.
  void blend(int x, int y, Rgba c, double coverage);

  // Composites `mask` with colour `c`, then clears the mask.
  void composite(CoverageMask& mask, Rgba c);
  // A mask of the canvas size, for callers that build a layer of many shapes.
  CoverageMask& scratch() { return scratch_; }

  // One-shot shapes (each blends once, through the scratch mask).
  void stroke_polyline(const std::vector<glm::dvec2>& points, double width, Rgba c, bool closed = false);
  void stroke_dashed(const std::vector<glm::dvec2>& points, double width, double dash, double gap, Rgba c);
  void fill_polygon(const std::vector<glm::dvec2>& ring, Rgba c);
  void fill_circle(glm::dvec2 centre, double radius, Rgba c);
  void stroke_circle(glm::dvec2 centre, double radius, double width, Rgba c);
  void fill_rect(double x0, double y0, double x1, double y1, Rgba c);

  // Text with its top-left at (x, y), each font unit `scale` pixels. With
  // halo.a > 0 a `scale`-pixel outline in that colour is drawn first.
  void draw_text(int x, int y, const std::string& text, Rgba c, int scale, Rgba halo = {0, 0, 0, 0});

 private:
  int width_, height_;
  std::vector<uint8_t> pixels_;
  CoverageMask scratch_;
};

// Size of draw_text's output in pixels (multi-line text: widest line, all lines).
int text_width(const std::string& text, int scale);
int text_height(const std::string& text, int scale);

// ---- polyline geometry in pixel space ---------------------------------------------

// Cuts a polyline into dashes `dash` long separated by `gap` (both > 0),
// starting with a dash. Returns the dashes as separate polylines.
std::vector<std::vector<glm::dvec2>> dash_polyline(const std::vector<glm::dvec2>& points, double dash, double gap);

// The polyline moved sideways by `distance` along the normal (-dy, dx) of its
// direction (dx, dy): the left side in a y-up frame, the right side on a
// y-down screen. Joins use the averaged normal, with the miter limited to 2×.
std::vector<glm::dvec2> offset_polyline(const std::vector<glm::dvec2>& points, double distance);

// Drops points closer than `min_spacing` to the last kept point (keeps both ends).
std::vector<glm::dvec2> thin_polyline(const std::vector<glm::dvec2>& points, double min_spacing);

}  // namespace icube::scene
