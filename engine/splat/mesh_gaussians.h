// Surface Gaussians of a triangle mesh: flat discs that tile every triangle,
// coloured by a simple paint scheme with the lighting baked in. The viewer
// draws its own car with them in the Gaussian view (the package's Gaussians
// hold the scene's cars, never the one the user drives).
//
// Tiling: a triangle whose longest edge is L is cut into m² similar
// sub-triangles (m = ceil(L / spacing)), one Gaussian at each one's centroid,
// oriented with its z axis along the triangle's normal, σ = 0.5·(L / m) in
// the plane (neighbouring discs overlap, so the surface reads as closed) and
// `normal_sigma` across it. Triangles of zero area give nothing.
// Colour (SH degree 0): `glass` for triangles whose centroid lies above
// `belt_height` and which slope more than 25° from horizontal (|n.z| < 0.9:
// side windows, windshield, rear window; the roof stays body), `tire` for
// triangles below `tire_height` (wheels, sills, underbody), `body` for the
// rest; each multiplied by ambient + (1 − ambient)·max(0, n·sun), in the mesh
// frame (the light turns with the car).
// Heights are measured from the mesh's lowest point.
// Tests: tests/splat/test_mesh_gaussians.cpp.
#pragma once

#include "splat/gaussians.h"
#include "world/triangle_mesh.h"

#include <glm/glm.hpp>

namespace icube::splat {

struct MeshPaint {
  glm::vec3 body{0.55f, 0.07f, 0.06f};   // linear-ish RGB in [0, 1]: a deep red
  glm::vec3 glass{0.06f, 0.08f, 0.10f};
  glm::vec3 tire{0.05f, 0.05f, 0.05f};
  double belt_height = 1.1;   // m above the mesh's lowest point (the built-in car in a 1.6 m box:
                              // hood and trunk tops end at ~1.06 m, the cabin rises to 1.6 m)
  double tire_height = 0.30;
  glm::dvec3 sun{0.3, 0.2, 0.93};  // towards the light (normalised inside)
  float ambient = 0.45f;
  float opacity = 0.99f;
};

struct MeshGaussianOptions {
  double spacing = 0.05;        // m: the longest sub-triangle edge
  double normal_sigma = 0.004;  // m
  size_t max_gaussians = 2'000'000;  // std::invalid_argument past it (spacing too fine for the mesh)
};

GaussianCloud mesh_surface_gaussians(const world::TriangleMesh& mesh, const MeshPaint& paint = {},
                                     const MeshGaussianOptions& options = {});

}  // namespace icube::splat
