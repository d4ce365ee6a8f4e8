// Local CSG difference against a dense patch of tool signed distances.
//
// In: a box of voxels (index_min, dims, x fastest) holding the tool's signed distance at each voxel
// centre, and an offset added to it (a positive offset shrinks the tool: partial-depth cuts).
// Out: every voxel with tool + offset < background takes max(value, -(tool + offset)); voxels
// whose new value leaves the band are switched off at +background. Each changed voxel's old value
// is appended to `log` when one is given (for undo and dirty tracking; reusing its capacity, no
// allocation). Removed volume is measured exactly as LevelSet::volume measures: the smoothed
// Heaviside with its curvature correction, evaluated before and after on every voxel whose value or
// Laplacian changed. Cost: one cached accessor lookup per voxel within the tool's band plus one
// voxel; voxels farther outside the tool are skipped without touching the tree.
#include <limits>

#include "impl.h"

namespace dentsim::vdb {

namespace {

struct Box {
  std::array<int32_t, 3> lo;
  std::array<uint32_t, 3> dims;
  bool contains(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && uint32_t(i) < dims[0] && uint32_t(j) < dims[1] &&
           uint32_t(k) < dims[2];
  }
  size_t index(int i, int j, int k) const { return size_t(i) + dims[0] * (size_t(j) + dims[1] * size_t(k)); }
};

}  // namespace

CutStats subtract_core(LevelSet::Impl& impl, std::array<int32_t, 3> index_min,
                       std::array<uint32_t, 3> dims, rust::Slice<const float> tool, float offset,
                       rust::Vec<VoxelChange>* log) {
  const size_t expected = size_t(dims[0]) * dims[1] * dims[2];
  if (tool.size() != expected)
    throw std::invalid_argument("tool patch holds " + std::to_string(tool.size()) +
                                " values, its dimensions need " + std::to_string(expected));
  if (!std::isfinite(offset)) throw std::invalid_argument("tool offset is not finite");
  auto& grid = *impl.grid;
  const float bg = grid.background();
  const double h = grid.voxelSize()[0];
  const double eps = 1.5 * h;
  const float reach = bg + float(h) * 1.01f;
  const float unknown = std::numeric_limits<float>::quiet_NaN();
  auto& before = impl.scratch_old;
  auto& after = impl.scratch_new;
  if (before.size() < expected) {  // grows once to the largest patch, then reused
    before.resize(expected);
    after.resize(expected);
  }
  openvdb::tree::ValueAccessor<FloatTree, false> acc(grid.tree());
  CutStats stats{0, 0.0};
  const Box box{index_min, dims};
  // Pass 1: old values of every voxel that may change or neighbours one that does; apply the cut.
  size_t n = 0;
  for (uint32_t k = 0; k < dims[2]; ++k)
    for (uint32_t j = 0; j < dims[1]; ++j)
      for (uint32_t i = 0; i < dims[0]; ++i, ++n) {
        const float t = tool[n] + offset;
        if (!(t < reach)) {
          before[n] = after[n] = unknown;
          continue;
        }
        const Coord c(index_min[0] + int32_t(i), index_min[1] + int32_t(j), index_min[2] + int32_t(k));
        const float old = acc.getValue(c);
        before[n] = after[n] = old;
        if (!(t < bg)) continue;
        const float cut = -t;
        if (!(cut > old)) continue;
        const float now = cut < bg ? cut : bg;
        if (cut < bg) {
          acc.setValueOn(c, cut);
        } else {
          acc.setValueOff(c, bg);
        }
        after[n] = now;
        stats.changed_voxels += 1;
        stats.removed_volume += inside_fraction(old, eps) - inside_fraction(now, eps);
        if (log) log->push_back(VoxelChange{c.x(), c.y(), c.z(), old});
      }
  if (stats.changed_voxels == 0) return stats;
  // Pass 2: the curvature term changes wherever a voxel or one of its six neighbours changed.
  auto value = [&](const std::vector<float>& arr, int i, int j, int k) -> float {
    if (box.contains(i, j, k)) {
      const float v = arr[box.index(i, j, k)];
      if (v == v) return v;
    }
    return acc.getValue(Coord(index_min[0] + i, index_min[1] + j, index_min[2] + k));
  };
  static const int nb[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  double correction = 0.0;
  n = 0;
  for (int k = 0; k < int(dims[2]); ++k)
    for (int j = 0; j < int(dims[1]); ++j)
      for (int i = 0; i < int(dims[0]); ++i, ++n) {
        const float o = before[n], w = after[n];
        if (!(o == o)) continue;
        if (std::fabs(o) >= eps && std::fabs(w) >= eps) continue;
        bool touched = o != w;
        float so = 0.f, sw = 0.f;
        for (const auto& d : nb) {
          const float a = value(before, i + d[0], j + d[1], k + d[2]);
          const float b = value(after, i + d[0], j + d[1], k + d[2]);
          touched |= a != b;
          so += a;
          sw += b;
        }
        if (!touched) continue;
        correction += curvature_term(o, (so - 6.f * o) / (h * h), eps) -
                      curvature_term(w, (sw - 6.f * w) / (h * h), eps);
      }
  stats.removed_volume = (stats.removed_volume - correction) * h * h * h;
  return stats;
}

CutStats LevelSet::subtract_dense(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                                  rust::Slice<const float> tool) {
  return subtract_core(*impl, index_min, dims, tool, 0.f, nullptr);
}

CutStats LevelSet::subtract_logged(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                                   rust::Slice<const float> tool, float offset,
                                   rust::Vec<VoxelChange>& log) {
  return subtract_core(*impl, index_min, dims, tool, offset, &log);
}

// Dry run for rate-limited cutting: the volume each offset would remove (smoothed Heaviside only;
// the curvature term is a boundary correction too small to matter for a per-tick budget).
void LevelSet::removal_by_offset(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                                 rust::Slice<const float> tool, rust::Slice<const float> offsets,
                                 rust::Slice<double> removed) const {
  const size_t expected = size_t(dims[0]) * dims[1] * dims[2];
  if (tool.size() != expected || removed.size() != offsets.size())
    throw std::invalid_argument("removal_by_offset: patch or output sizes do not match");
  const auto& grid = *impl->grid;
  const float bg = grid.background();
  const double h = grid.voxelSize()[0];
  const double eps = 1.5 * h;
  float smallest = std::numeric_limits<float>::infinity();
  for (float o : offsets) smallest = std::min(smallest, o);
  for (auto& r : removed) r = 0.0;
  openvdb::tree::ValueAccessor<const FloatTree, false> acc(grid.tree());
  size_t n = 0;
  for (uint32_t k = 0; k < dims[2]; ++k)
    for (uint32_t j = 0; j < dims[1]; ++j)
      for (uint32_t i = 0; i < dims[0]; ++i, ++n) {
        if (!(tool[n] + smallest < bg)) continue;
        const float old = acc.getValue(Coord(index_min[0] + int32_t(i), index_min[1] + int32_t(j),
                                             index_min[2] + int32_t(k)));
        const double before = inside_fraction(old, eps);
        if (before == 0.0) continue;
        for (size_t m = 0; m < offsets.size(); ++m) {
          const float cut = -(tool[n] + offsets[m]);
          if (cut > old) removed[m] += before - inside_fraction(std::min(cut, bg), eps);
        }
      }
  for (auto& r : removed) r *= h * h * h;
}

// Undo / redo: put voxel values back (on inside the band, off at +-background outside it).
void LevelSet::write_voxels(rust::Slice<const VoxelChange> changes) {
  auto& grid = *impl->grid;
  const float bg = grid.background();
  openvdb::tree::ValueAccessor<FloatTree, false> acc(grid.tree());
  for (const auto& c : changes) {
    const Coord ijk(c.i, c.j, c.k);
    if (std::fabs(c.value) < bg) {
      acc.setValueOn(ijk, c.value);
    } else {
      acc.setValueOff(ijk, c.value < 0.f ? -bg : bg);
    }
  }
}

void LevelSet::read_voxels(rust::Slice<VoxelChange> changes) const {
  openvdb::tree::ValueAccessor<const FloatTree, false> acc(impl->grid->tree());
  for (auto& c : changes) c.value = acc.getValue(Coord(c.i, c.j, c.k));
}

// Values of a box of voxels, x fastest (for meshing regions and tests).
void LevelSet::read_dense(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                          rust::Slice<float> out) const {
  const size_t expected = size_t(dims[0]) * dims[1] * dims[2];
  if (out.size() != expected) throw std::invalid_argument("read_dense: output size does not match");
  openvdb::tree::ValueAccessor<const FloatTree, false> acc(impl->grid->tree());
  size_t n = 0;
  for (uint32_t k = 0; k < dims[2]; ++k)
    for (uint32_t j = 0; j < dims[1]; ++j)
      for (uint32_t i = 0; i < dims[0]; ++i, ++n)
        out[n] = acc.getValue(Coord(index_min[0] + int32_t(i), index_min[1] + int32_t(j),
                                    index_min[2] + int32_t(k)));
}

rust::Vec<int32_t> LevelSet::leaf_origins() const {
  rust::Vec<int32_t> out;
  for (auto it = impl->grid->tree().cbeginLeaf(); it; ++it) {
    const Coord o = it->origin();
    out.push_back(o.x());
    out.push_back(o.y());
    out.push_back(o.z());
  }
  return out;
}

}  // namespace dentsim::vdb
