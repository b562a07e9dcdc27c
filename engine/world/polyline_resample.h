// InfiniCube's polyline resampling rule (conventions §6).
//
// Each segment a -> b of length d gets n = max(ceil(d / step), 2) points at
// t = linspace(0, 1, n)[:-1], i.e. a + (b - a) * k / (n - 1) for k < n - 1,
// and the polyline's final vertex is appended once at the end. A zero-length
// segment (repeated vertex) therefore still emits its start point once, as
// upstream does. step = 0.25 m for road edges and lines (kMapResampleStep);
// lane centre lines used as road-surface points here are resampled at 0.4 m.
// Everything stays in double (world coordinates can be ~1e5 m).
#pragma once

#include <glm/glm.hpp>

#include <vector>

namespace icube::world {

inline constexpr double kMapResampleStep = 0.25;
inline constexpr double kSurfaceResampleStep = 0.4;

// Resamples one polyline. Empty input -> empty output; one vertex -> that
// vertex. Throws std::invalid_argument for step <= 0 or a non-finite step.
std::vector<glm::dvec3> resample_polyline(const std::vector<glm::dvec3>& points, double step = kMapResampleStep);

// Appends resample_polyline(points, step) to `out`.
void append_resampled(std::vector<glm::dvec3>& out, const std::vector<glm::dvec3>& points,
                      double step = kMapResampleStep);

}  // namespace icube::world
