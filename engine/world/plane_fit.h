// Plane fitting for the road surface (conventions §6): a total-least-squares
// plane through 3-D points (the covariance's smallest eigenvector, by cyclic
// Jacobi rotations) and the horizontal fallback through the median z.
#pragma once

#include "world/road_surface.h"

#include <glm/glm.hpp>

#include <array>
#include <vector>

namespace icube::world {

// Eigenvalues (ascending) and unit eigenvectors of a symmetric 3x3 matrix.
void symmetric_eigen(std::array<std::array<double, 3>, 3> a, std::array<double, 3>& values,
                     std::array<glm::dvec3, 3>& vectors);
// The horizontal plane through the median z (numpy's median); z = 0 for no points.
SurfacePlane horizontal_plane(std::vector<glm::dvec3> pts);
// False (out untouched) for fewer than 3 points, collinear points or a plane steeper than ~84 degrees.
bool fit_plane(const std::vector<glm::dvec3>& pts, SurfacePlane& out);

}  // namespace icube::world
