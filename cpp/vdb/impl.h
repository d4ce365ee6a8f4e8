// Private to cpp/vdb: the pimpl bodies and helpers shared by its sources.
#pragma once

#include <openvdb/openvdb.h>

#include <algorithm>
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

// A voxel a local cut changed: its index and box-relative position in the tool patch, old and
// new value.
struct ChangedVoxel {
  uint32_t m;
  uint16_t i, j, k;
  float old, now;
};

struct LevelSet::Impl {
  FloatGrid::Ptr grid;
  // Reused by local cuts (old values over the patch, changed voxels, the patch's leaves and tile
  // values); never shrinks.
  std::vector<float> scratch_old;
  std::vector<float> scratch_weight;  // curvature weight of each voxel's new value (cut.cc)
  std::vector<ChangedVoxel> scratch_changed;
  std::vector<VoxelChange> scratch_log;  // the last logged cut's changes (old values): the first log_count
  size_t log_count = 0;
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

// The volume measure's kernels over t = phi / eps in [-1, 1], tabulated for linear interpolation:
// the smoothed Heaviside H(t) = (1 - t - sin(pi t) / pi) / 2 and the delta kernel
// D(t) = (1 + cos(pi t)) / 2. Interpolation errors are below 1e-6, far under a voxel's share of
// any volume we report; the cut evaluates them per changed voxel at haptic rate, where libm's sin
// and cos were a fifth of a cut.
constexpr int kKernelSteps = 1024;
struct KernelTables {
  float heaviside[kKernelSteps + 2];
  float delta[kKernelSteps + 2];
};
extern const KernelTables kKernels;

// The volume measure at one voxel size h, with eps = 1.5 h:
// - inside_fraction: the smoothed Heaviside of a signed distance, 1 inside, 0 outside;
// - curvature_weight: the smoothed Heaviside overcounts a convex region by m * (integral of mean
//   curvature sum over the surface), m = eps^2 (1/6 - 1/pi^2); the discrete Laplacian of a
//   signed distance is that curvature, so subtracting curvature_weight(phi) * Laplacian per voxel
//   (m * delta_eps(phi)) removes the bias (to second order) for any smooth surface.
// Both read the tables branch-free: beyond +-eps the tables' end values hold (1 or 0, and 0).
struct VolumeKernels {
  double eps;
  float scale, m_over_eps;
  explicit VolumeKernels(double h)
      : eps(1.5 * h),
        scale(float(kKernelSteps / 2 / eps)),
        m_over_eps(float(eps * (1.0 / 6.0 - 1.0 / (M_PI * M_PI)))) {}
  __attribute__((always_inline)) float lookup(const float* table, float phi) const {
    float u = phi * scale + float(kKernelSteps / 2);
    u = u > 0.f ? (u < float(kKernelSteps) ? u : float(kKernelSteps)) : 0.f;  // NaN reads as inside
    const int i = std::min(int(u), kKernelSteps - 1);
    return table[i] + (u - float(i)) * (table[i + 1] - table[i]);
  }
  double inside_fraction(float phi) const { return lookup(kKernels.heaviside, phi); }
  float curvature_weight(float phi) const { return m_over_eps * lookup(kKernels.delta, phi); }
};

CutStats subtract_core(LevelSet::Impl& impl, std::array<int32_t, 3> index_min,
                       std::array<uint32_t, 3> dims, rust::Slice<const float> tool,
                       rust::Slice<const uint32_t> spans, rust::Slice<const uint32_t> runs,
                       rust::Slice<const float> run_values, float offset, bool logged, bool measured);

// Trilinear value and gradient (world units) at an index-space point.
template <typename Accessor>
inline std::array<float, 4> trilinear(Accessor& acc, const openvdb::Vec3d& ijk, double voxel) {
  const openvdb::Vec3d f(std::floor(ijk.x()), std::floor(ijk.y()), std::floor(ijk.z()));
  const Coord c(int(f.x()), int(f.y()), int(f.z()));
  const double u = ijk.x() - f.x(), v = ijk.y() - f.y(), w = ijk.z() - f.z();
  float s[2][2][2];
  // Two times in three the 2x2x2 stencil lies in one leaf block: one probe, then eight reads
  // from its leaf, or one tile value for all eight (no leaf: most burr points are in open air,
  // where each of eight accessor reads used to walk down from the root's children).
  using Leaf = FloatTree::LeafNodeType;
  constexpr int last = int(Leaf::DIM) - 1;
  const bool one_block = (c.x() & last) < last && (c.y() & last) < last && (c.z() & last) < last;
  const Leaf* leaf = one_block ? acc.probeConstLeaf(c) : nullptr;
  if (leaf) {
    const float* v = leaf->buffer().data() + Leaf::coordToOffset(c);
    constexpr int sx = 1 << 2 * Leaf::LOG2DIM, sy = 1 << Leaf::LOG2DIM;
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b)
        for (int d = 0; d < 2; ++d) s[a][b][d] = v[a * sx + b * sy + d];
  } else if (one_block) {
    const float tile = acc.getValue(c);
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b)
        for (int d = 0; d < 2; ++d) s[a][b][d] = tile;
  } else {
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b)
        for (int d = 0; d < 2; ++d) s[a][b][d] = acc.getValue(c.offsetBy(a, b, d));
  }
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
