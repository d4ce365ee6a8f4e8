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
  const float* tp = tool.data();  // rust::Slice indexing calls out of line per element
  const float bg = grid.background();
  const double h = grid.voxelSize()[0];
  const double eps = 1.5 * h;
  const float reach = bg + float(h) * 1.01f;
  auto& before = impl.scratch_old;
  if (before.size() < expected) {  // grows once to the largest patch, then reused
    before.resize(expected);
  }
  openvdb::tree::ValueAccessor<FloatTree, false> acc(grid.tree());
  CutStats stats{0, 0.0};
  const Box box{index_min, dims};
  using Leaf = FloatTree::LeafNodeType;
  constexpr int L = int(Leaf::DIM);
  auto floor_to_leaf = [](int v) { return v & ~(L - 1); };
  const int hi[3] = {index_min[0] + int(dims[0]) - 1, index_min[1] + int(dims[1]) - 1,
                     index_min[2] + int(dims[2]) - 1};
  // Pass 1, leaf block by leaf block: blocks in an outside tile cannot change and are skipped
  // after one probe (their voxels are left unread: pass 2 never needs them, see below); voxels in
  // a leaf are read directly from it.
  auto& changed = impl.scratch_changed;
  changed.clear();
  auto& blocks = impl.scratch_blocks;  // 1 = the block was read, per leaf block of the box
  const int nb_x = (hi[0] - floor_to_leaf(index_min[0])) / L + 1;
  const int nb_y = (hi[1] - floor_to_leaf(index_min[1])) / L + 1;
  const int nb_z = (hi[2] - floor_to_leaf(index_min[2])) / L + 1;
  if (blocks.size() < size_t(nb_x) * nb_y * nb_z) blocks.resize(size_t(nb_x) * nb_y * nb_z);
  const int fx = floor_to_leaf(index_min[0]), fy = floor_to_leaf(index_min[1]),
            fz = floor_to_leaf(index_min[2]);
  auto block_of = [&](int x, int y, int z) {  // x, y, z >= the floored box origin
    return size_t(unsigned(x - fx) / L) +
           size_t(nb_x) * (size_t(unsigned(y - fy) / L) + size_t(nb_y) * size_t(unsigned(z - fz) / L));
  };
  for (int bx = floor_to_leaf(index_min[0]); bx <= hi[0]; bx += L)
    for (int by = floor_to_leaf(index_min[1]); by <= hi[1]; by += L)
      for (int bz = floor_to_leaf(index_min[2]); bz <= hi[2]; bz += L) {
        const Coord origin(bx, by, bz);
        Leaf* leaf = acc.probeLeaf(origin);
        const float tile = leaf ? 0.f : acc.getValue(origin);
        const bool skip = !leaf && !(tile < bg);
        blocks[block_of(bx, by, bz)] = skip ? 0 : 1;
        if (skip) continue;
        const int x0 = std::max(bx, index_min[0]), x1 = std::min(bx + L - 1, hi[0]);
        const int y0 = std::max(by, index_min[1]), y1 = std::min(by + L - 1, hi[1]);
        const int z0 = std::max(bz, index_min[2]), z1 = std::min(bz + L - 1, hi[2]);
        for (int z = z0; z <= z1; ++z)
          for (int y = y0; y <= y1; ++y) {
            size_t n = box.index(x0 - index_min[0], y - index_min[1], z - index_min[2]);
            for (int x = x0; x <= x1; ++x, ++n) {
              const float t = tp[n] + offset;
              if (!(t < reach)) continue;  // unread; pass 2 knows it from the tool
              const Coord c(x, y, z);
              const float old = leaf ? leaf->getValue(c) : tile;
              before[n] = old;
              if (!(t < bg)) continue;
              const float cut = -t;
              const float now = cut < bg ? cut : bg;
              if (!(now > old)) continue;
              if (!leaf) leaf = acc.touchLeaf(origin);  // an inside tile becomes a leaf
              if (cut < bg) {
                leaf->setValueOn(c, cut);
              } else {
                leaf->setValueOff(c, bg);
              }
              changed.push_back(uint32_t(n));
              stats.removed_volume += inside_fraction(old, eps) - inside_fraction(now, eps);
              if (log) log->push_back(VoxelChange{c.x(), c.y(), c.z(), old});
            }
          }
      }
  stats.changed_voxels = changed.size();
  if (changed.empty()) return stats;
  // Pass 2: the curvature term changes only at changed voxels and their six neighbours. Unread
  // voxels (skipped outside blocks, or beyond the tool's reach) are unchanged; their value comes
  // from the tree. The tool's cut-off margin keeps every changed voxel's neighbours in the box.
  // Old and new value of a box voxel (box-relative i, j, k). A voxel was read in pass 1 iff its
  // block was read and the tool reached it; its new value follows from the tool again.
  auto value = [&](int i, int j, int k, float& o, float& w) {
    if (box.contains(i, j, k) &&
        blocks[block_of(index_min[0] + i, index_min[1] + j, index_min[2] + k)]) {
      const size_t m = box.index(i, j, k);
      const float t = tp[m] + offset;
      if (t < reach) {
        o = before[m];
        const float now = -t < bg ? -t : bg;
        w = t < bg && now > o ? now : o;
        return;
      }
    }
    o = w = acc.getValue(Coord(index_min[0] + i, index_min[1] + j, index_min[2] + k));
  };
  static const int nb[7][3] = {{0, 0, 0}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0},
                               {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  auto& mark = impl.scratch_mark;  // all zero between calls
  if (mark.size() < expected) mark.resize(expected, 0);
  auto& visited = impl.scratch_visited;
  visited.clear();
  double correction = 0.0;
  const int nx = int(dims[0]), nxy = int(dims[0] * dims[1]);
  for (uint32_t c : changed) {
    const int ci = int(c) % nx, cj = (int(c) / nx) % int(dims[1]), ck = int(c) / nxy;
    for (const auto& d : nb) {
      const int i = ci + d[0], j = cj + d[1], k = ck + d[2];
      if (!box.contains(i, j, k)) continue;
      const size_t m = box.index(i, j, k);
      if (mark[m]) continue;
      mark[m] = 1;
      visited.push_back(uint32_t(m));
      float o, w;
      value(i, j, k, o, w);
      if (std::fabs(o) >= eps && std::fabs(w) >= eps) continue;
      float so = 0.f, sw = 0.f;
      for (int q = 1; q < 7; ++q) {
        float a, b;
        value(i + nb[q][0], j + nb[q][1], k + nb[q][2], a, b);
        so += a;
        sw += b;
      }
      correction += curvature_term(o, (so - 6.f * o) / (h * h), eps) -
                    curvature_term(w, (sw - 6.f * w) / (h * h), eps);
    }
  }
  for (uint32_t m : visited) mark[m] = 0;
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
  const float* tp = tool.data();
  const float* op = offsets.data();
  const size_t n_off = offsets.size();
  double* rp = removed.data();
  openvdb::tree::ValueAccessor<const FloatTree, false> acc(grid.tree());
  size_t n = 0;
  for (uint32_t k = 0; k < dims[2]; ++k)
    for (uint32_t j = 0; j < dims[1]; ++j)
      for (uint32_t i = 0; i < dims[0]; ++i, ++n) {
        if (!(tp[n] + smallest < bg)) continue;
        const float old = acc.getValue(Coord(index_min[0] + int32_t(i), index_min[1] + int32_t(j),
                                             index_min[2] + int32_t(k)));
        const double before = inside_fraction(old, eps);
        if (before == 0.0) continue;
        for (size_t m = 0; m < n_off; ++m) {
          const float cut = -(tp[n] + op[m]);
          if (cut > old) rp[m] += before - inside_fraction(std::min(cut, bg), eps);
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
