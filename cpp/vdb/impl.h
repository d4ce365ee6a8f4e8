// Private to cpp/vdb: the pimpl bodies and helpers shared by its sources.
#pragma once

#include <openvdb/openvdb.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "dentsim-vdb/src/sys.rs.h"
#include "vdb/level_set.h"

namespace dentsim::vdb {

using openvdb::Coord;
using openvdb::FloatGrid;
using openvdb::FloatTree;

// OpenVDB must register its grid and metadata types once per process before file I/O.
void ensure_initialized();

struct LevelSet::Impl {
  FloatGrid::Ptr grid;
  // Reused by local cuts (old values over the patch, changed and visited voxels, the patch's
  // leaves and tile values); never shrinks.
  std::vector<float> scratch_old;
  std::vector<uint32_t> scratch_changed, scratch_visited;
  std::vector<uint8_t> scratch_mark;
  std::vector<FloatTree::LeafNodeType*> scratch_leaves;
  std::vector<float> scratch_tiles;
};

// Unregistered accessor: no allocation or locking on creation; valid while the grid is not
// modified, which the Rust side guarantees by borrowing the grid for the reader's lifetime.
struct Reader::Impl {
  FloatGrid::ConstPtr grid;
  openvdb::tree::ValueAccessor<const FloatTree, false> acc;
  openvdb::math::Transform::ConstPtr xform;
  explicit Impl(FloatGrid::ConstPtr g) : grid(g), acc(g->tree()), xform(g->transformPtr()) {}
};

struct GridList::Impl {
  openvdb::GridPtrVec grids;
};

std::unique_ptr<LevelSet> wrap(FloatGrid::Ptr grid);
FloatGrid::Ptr new_grid(double voxel_size, double half_width);

// sin(pi x) for x in [-1, 1]: folded to [-1/2, 1/2] and a Taylor polynomial to x^13 (error
// < 1e-7). The volume measure calls it per changed voxel at haptic rate, where libm's sin and
// cos were a fifth of a cut.
inline double sin_pi(double x) {
  if (x > 0.5) x = 1.0 - x;
  if (x < -0.5) x = -1.0 - x;
  const double y = M_PI * x, y2 = y * y;
  return y * (1.0 + y2 * (-1.0 / 6 + y2 * (1.0 / 120 + y2 * (-1.0 / 5040 + y2 * (1.0 / 362880 +
         y2 * (-1.0 / 39916800 + y2 * (1.0 / 6227020800.0)))))));
}

// cos(pi x) for x in [-1, 1].
inline double cos_pi(double x) { return sin_pi(0.5 - std::fabs(x)); }

// Smoothed Heaviside of a signed distance: 1 inside, 0 outside, over +-1.5 voxels.
inline double inside_fraction(float phi, double eps) {
  if (phi <= -eps) return 1.0;
  if (phi >= eps) return 0.0;
  const double t = phi / eps;
  return 0.5 * (1.0 - t - sin_pi(t) / M_PI);
}

// Curvature term of the volume measure: the smoothed Heaviside overcounts a convex region by
// m * (integral of mean curvature sum over the surface), m = eps^2 (1/6 - 1/pi^2); the discrete
// Laplacian of a signed distance is that curvature, so subtracting m * delta_eps(phi) * Laplacian
// per voxel removes the bias (to second order) for spheres, cylinders and any smooth surface.
inline double curvature_term(float phi, double laplacian, double eps) {
  if (!(std::fabs(phi) < eps)) return 0.0;
  const double m = eps * eps * (1.0 / 6.0 - 1.0 / (M_PI * M_PI));
  const double delta = 0.5 * (1.0 + cos_pi(phi / eps)) / eps;
  return m * delta * laplacian;
}

CutStats subtract_core(LevelSet::Impl& impl, std::array<int32_t, 3> index_min,
                       std::array<uint32_t, 3> dims, rust::Slice<const float> tool,
                       rust::Slice<const uint32_t> spans, float offset,
                       rust::Vec<VoxelChange>* log);

// Trilinear value and gradient (world units) at an index-space point.
template <typename Accessor>
inline std::array<float, 4> trilinear(Accessor& acc, const openvdb::Vec3d& ijk, double voxel) {
  const openvdb::Vec3d f(std::floor(ijk.x()), std::floor(ijk.y()), std::floor(ijk.z()));
  const Coord c(int(f.x()), int(f.y()), int(f.z()));
  const double u = ijk.x() - f.x(), v = ijk.y() - f.y(), w = ijk.z() - f.z();
  float s[2][2][2];
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int d = 0; d < 2; ++d) s[a][b][d] = acc.getValue(c.offsetBy(a, b, d));
  auto lerp = [](double p, double q, double t) { return p + (q - p) * t; };
  const double x00 = lerp(s[0][0][0], s[1][0][0], u), x10 = lerp(s[0][1][0], s[1][1][0], u);
  const double x01 = lerp(s[0][0][1], s[1][0][1], u), x11 = lerp(s[0][1][1], s[1][1][1], u);
  const double y0 = lerp(x00, x10, v), y1 = lerp(x01, x11, v);
  const double value = lerp(y0, y1, w);
  const double gx = lerp(lerp(s[1][0][0] - s[0][0][0], s[1][1][0] - s[0][1][0], v),
                         lerp(s[1][0][1] - s[0][0][1], s[1][1][1] - s[0][1][1], v), w);
  const double gy = lerp(x10 - x00, x11 - x01, w);
  const double gz = y1 - y0;
  return {float(value), float(gx / voxel), float(gy / voxel), float(gz / voxel)};
}

}  // namespace dentsim::vdb
