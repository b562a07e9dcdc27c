// Total-least-squares plane fit and the median-z fallback (plane_fit.h).
#include "world/plane_fit.h"

#include <algorithm>
#include <cmath>

namespace icube::world {

namespace {
// A fitted plane whose unit normal has |z| below this (steeper than ~84°) is
// not a road: the block gets the horizontal fallback plane instead.
constexpr double kMinNormalZ = 0.1;
// Collinearity test: middle eigenvalue <= this times the largest.
constexpr double kCollinearRatio = 1e-12;
}  // namespace

// Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations.
// Returns the eigenvalues (ascending) and the matching unit eigenvectors.
void symmetric_eigen(std::array<std::array<double, 3>, 3> a, std::array<double, 3>& values,
                     std::array<glm::dvec3, 3>& vectors) {
  std::array<std::array<double, 3>, 3> v{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  for (int sweep = 0; sweep < 64; ++sweep) {
    const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    const double diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
    if (off <= 1e-36 * diag || off == 0.0) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        if (a[p][q] == 0.0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        const double t = (theta >= 0.0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (int k = 0; k < 3; ++k) {  // a = J^T a J
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
  }
  std::array<int, 3> order{0, 1, 2};
  std::sort(order.begin(), order.end(), [&](int i, int j) { return a[i][i] < a[j][j]; });
  for (int k = 0; k < 3; ++k) {
    values[k] = a[order[k]][order[k]];
    vectors[k] = glm::dvec3(v[0][order[k]], v[1][order[k]], v[2][order[k]]);
  }
}

SurfacePlane horizontal_plane(std::vector<glm::dvec3> pts) {
  SurfacePlane p;
  if (pts.empty()) return p;
  std::vector<double> z;
  for (const glm::dvec3& q : pts) z.push_back(q.z);
  const size_t mid = z.size() / 2;
  std::nth_element(z.begin(), z.begin() + static_cast<std::ptrdiff_t>(mid), z.end());
  double median = z[mid];
  if (z.size() % 2 == 0) median = 0.5 * (median + *std::max_element(z.begin(), z.begin() + static_cast<std::ptrdiff_t>(mid)));
  p.d = -median;
  return p;
}

// Total least squares: the normal is the covariance's smallest eigenvector.
bool fit_plane(const std::vector<glm::dvec3>& pts, SurfacePlane& out) {
  if (pts.size() < 3) return false;
  glm::dvec3 mean(0.0);
  for (const glm::dvec3& p : pts) mean += p;
  mean /= static_cast<double>(pts.size());
  std::array<std::array<double, 3>, 3> cov{};
  for (const glm::dvec3& p : pts) {
    const glm::dvec3 d = p - mean;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) cov[i][j] += d[i] * d[j];
  }
  std::array<double, 3> values;
  std::array<glm::dvec3, 3> vectors;
  symmetric_eigen(cov, values, vectors);
  if (!(values[2] > 0.0) || values[1] <= kCollinearRatio * values[2]) return false;
  glm::dvec3 n = glm::normalize(vectors[0]);
  if (n.z < 0.0) n = -n;
  if (!(n.z >= kMinNormalZ)) return false;
  out = {n.x, n.y, n.z, -glm::dot(n, mean)};
  return true;
}

}  // namespace icube::world
