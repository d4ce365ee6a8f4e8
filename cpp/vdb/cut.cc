// Local CSG difference against a dense patch of tool signed distances.
//
// In: a box of voxels (index_min, dims, x fastest) holding the tool's signed distance at each voxel
// centre, and an offset added to it (a positive offset shrinks the tool: partial-depth cuts).
// Out: every voxel with tool + offset < background takes max(value, -(tool + offset)); voxels
// whose new value leaves the band are switched off at +background. A logged cut keeps each changed
// voxel's old value for last_changes (undo and dirty tracking; the buffer is reused, no
// allocation once grown). Removed volume is measured exactly as LevelSet::volume measures: the smoothed
// Heaviside with its curvature correction, evaluated before and after on every voxel whose value or
// Laplacian changed. Cost: one accessor probe per leaf block the row spans reach and one buffer
// read per voxel within the tool's band (plus one voxel when measured); voxels farther outside
// the tool are not read.
#include <limits>
#include <type_traits>

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

// subtract_core, compiled twice: for unmeasured cuts, whose voxel loop then carries none of the
// measure's stores and branches (the haptic tick's enamel -13 %), and for the rest with
// `measured` and `logged` left to run time (fixing both as well made measured cuts 4 % slower).
template <bool unmeasured>
CutStats subtract_as(LevelSet::Impl& impl, std::array<int32_t, 3> index_min,
                     std::array<uint32_t, 3> dims, rust::Slice<const float> tool,
                     rust::Slice<const uint32_t> spans, rust::Slice<const uint32_t> runs,
                     rust::Slice<const float> run_values, float offset, bool logged, bool measure) {
  const bool measured = !unmeasured && measure;
  const size_t expected = size_t(dims[0]) * dims[1] * dims[2];
  if (tool.size() != expected)
    throw std::invalid_argument("tool patch holds " + std::to_string(tool.size()) +
                                " values, its dimensions need " + std::to_string(expected));
  if (dims[0] > 0xffff || dims[1] > 0xffff || dims[2] > 0xffff)
    throw std::invalid_argument("tool patch is over 65535 voxels along an axis");
  const size_t rows = size_t(dims[1]) * dims[2];
  if (!spans.empty() && spans.size() != 2 * rows)
    throw std::invalid_argument("tool patch has " + std::to_string(spans.size() / 2) +
                                " row spans for " + std::to_string(rows) + " rows");
  const uint32_t* sp = spans.empty() ? nullptr : spans.data();
  // Given column runs, the spans are not read: checking each row's cost a twelfth of the subtract.
  for (size_t r = 0; sp && runs.empty() && r < rows; ++r)
    if (sp[2 * r] > sp[2 * r + 1] || sp[2 * r + 1] > dims[0])
      throw std::invalid_argument("tool patch row span " + std::to_string(r) + " is not within its row");
  const size_t columns = size_t(dims[0]) * dims[1];
  if (runs.size() % 4 != 0)
    throw std::invalid_argument("tool patch column runs are not (column, start, end, value) quadruples");
  const uint32_t* rp = runs.empty() ? nullptr : runs.data();
  for (size_t r = 0; r < runs.size(); r += 4)
    if (rp[r] >= columns || rp[r + 1] > rp[r + 2] || rp[r + 2] > dims[2] ||
        size_t(rp[r + 3]) + (rp[r + 2] - rp[r + 1]) > run_values.size())
      throw std::invalid_argument("tool patch column run " + std::to_string(r / 4) +
                                  " is not within its column or the runs' values");
  if (!std::isfinite(offset)) throw std::invalid_argument("tool offset is not finite");
  auto& grid = *impl.grid;
  const float* tp = tool.data();  // rust::Slice indexing calls out of line per element
  const float bg = grid.background();
  const double h = grid.voxelSize()[0];
  const VolumeKernels kernels(h);
  const float reach = bg + float(h) * 1.01f;
  // Only pass 2 (the measure) reads voxels past the band: an unmeasured cut reads none of them.
  const float read_limit = measured ? reach : bg;
  auto& before = impl.scratch_old;
  if (before.size() < expected) {  // grows once to the largest patch, then reused
    before.resize(expected);
  }
  float* old_values = before.data();
  auto& after_weight = impl.scratch_weight;
  if (after_weight.size() < expected) after_weight.resize(expected);
  float* weights = after_weight.data();
  openvdb::tree::ValueAccessor<FloatTree, false> acc(grid.tree());
  CutStats stats{0, 0.0};
  const Box box{index_min, dims};
  using Leaf = FloatTree::LeafNodeType;
  constexpr int L = int(Leaf::DIM);
  constexpr int LOG2 = int(Leaf::LOG2DIM);
  auto floor_to_leaf = [](int v) { return v & ~(L - 1); };
  const int hi[3] = {index_min[0] + int(dims[0]) - 1, index_min[1] + int(dims[1]) - 1,
                     index_min[2] + int(dims[2]) - 1};
  // Pass 1, row by row within each row's span (or, given column runs, run by run along z):
  // voxels the tool reaches (within the band plus one voxel) have their old value kept in
  // `before` and are raised where the tool is deeper. Each leaf block is probed once, when a span
  // first reaches it; a row segment is then read through a pointer stepping along x in the leaf's
  // buffer (z is its fastest axis; a column's steps by one), or standing on the tile value of a
  // block without a leaf. An outside tile cannot change: its voxels just
  // take the tile value in `before`, for pass 2 (measured cuts only).
  // At most every voxel changes: the buffers grow once to the largest patch and are written
  // through pointers (push_back built each entry on the stack and stalled reloading it).
  auto& changed_buffer = impl.scratch_changed;
  if (changed_buffer.size() < expected) changed_buffer.resize(expected);
  ChangedVoxel* const changed = changed_buffer.data();
  size_t n_changed = 0;
  impl.log_count = 0;
  if (logged && impl.scratch_log.size() < expected) impl.scratch_log.resize(expected);
  VoxelChange* const log = impl.scratch_log.data();
  const int fx = floor_to_leaf(index_min[0]), fy = floor_to_leaf(index_min[1]),
            fz = floor_to_leaf(index_min[2]);
  const int nb_x = (hi[0] - fx) / L + 1, nb_y = (hi[1] - fy) / L + 1, nb_z = (hi[2] - fz) / L + 1;
  auto& leaves = impl.scratch_leaves;
  auto& tiles = impl.scratch_tiles;
  // Blocks are probed when a row first reaches them (NaN tile: not yet): a head's box holds
  // far more blocks than its spans touch, and a probe costs about what a voxel row does.
  // (Within capacity: the buffers grow to the largest patch, then are reused.)
  leaves.assign(size_t(nb_x) * nb_y * nb_z, nullptr);
  tiles.assign(leaves.size(), std::numeric_limits<float>::quiet_NaN());
  auto probe = [&](size_t b, int x, int y, int z) {
    if (std::isnan(tiles[b])) {
      const Coord origin(x & ~(L - 1), y & ~(L - 1), z & ~(L - 1));
      leaves[b] = acc.probeLeaf(origin);
      tiles[b] = leaves[b] ? 0.f : acc.getValue(origin);
    }
  };
  // One segment of a row (along x) or of a column (along z, `along_z`) from patch voxel
  // (i, j, k), `n` voxels long within leaf block `b`. Rows step along x in the patch (1) and the
  // leaf (L²); columns along z, the leaf's fastest axis (1), and the patch's slowest (nx·ny), so
  // a column reads its tool values from the runs' own copy (`t_run`, z fastest) instead.
  const size_t plane = size_t(dims[0]) * dims[1];
  auto segment = [&](auto along_z, int i, int j, int k, int n, size_t b, const float* t_run) {
    constexpr bool Z = decltype(along_z)::value;
    const int x = index_min[0] + i, y = index_min[1] + j, z = index_min[2] + k;
    probe(b, x, y, z);
    Leaf* leaf = leaves[b];
    const float tile = tiles[b];
    const size_t row = box.index(i, j, k);
    const size_t t_step = Z ? plane : 1;  // the patch's step (old values, weights)
    const float* t_row = Z ? t_run : tp + row;
    float* old_row = old_values + row;
    float* weight_row = weights + row;
    if (!leaf && !(tile < bg)) {
      if (measured)
        for (int s = 0; s < n; ++s) old_row[s * t_step] = tile;
      return;
    }
    const int first = ((x & (L - 1)) << 2 * LOG2) | ((y & (L - 1)) << LOG2) | (z & (L - 1));
    const ptrdiff_t leaf_step = Z ? 1 : L * L;
    const float* src = leaf ? leaf->buffer().data() + first : &tile;
    ptrdiff_t stride = leaf ? leaf_step : 0;
    for (int s = 0; s < n; ++s) {
      const float t = t_row[s] + offset;
      if (!(t < read_limit)) continue;  // unread; pass 2 knows it from the tool
      const float old = src[s * stride];
      if (measured) old_row[s * t_step] = old;
      const float now = -t < bg ? -t : bg;
      const bool cuts = (t < bg) & (now > old);
      if (measured) weight_row[s * t_step] = kernels.curvature_weight(cuts ? now : old);
      if (!cuts) continue;
      if (!leaf) {  // an inside tile becomes a leaf
        leaf = leaves[b] = acc.touchLeaf(Coord(x & ~(L - 1), y & ~(L - 1), z & ~(L - 1)));
        src = leaf->buffer().data() + first;
        stride = leaf_step;
      }
      const openvdb::Index at = openvdb::Index(first + s * leaf_step);
      if (now < bg) {
        leaf->setValueOn(at, now);
      } else {
        leaf->setValueOff(at, bg);
      }
      ChangedVoxel& cv = changed[n_changed++];
      cv.m = uint32_t(row + s * t_step);
      cv.i = uint16_t(Z ? i : i + s);
      cv.j = uint16_t(j);
      cv.k = uint16_t(Z ? k + s : k);
      cv.old = old;
      cv.now = now;
      if (measured) stats.removed_volume += kernels.inside_fraction(old) - kernels.inside_fraction(now);
      if (logged) {
        VoxelChange& lc = log[impl.log_count++];
        lc.i = Z ? x : x + s;
        lc.j = y;
        lc.k = Z ? z + s : z;
        lc.value = old;
      }
    }
  };
  if (runs.empty()) {
    for (int k = 0; k < int(dims[2]); ++k)
      for (int j = 0; j < int(dims[1]); ++j) {
        const size_t r = size_t(j) + size_t(dims[1]) * size_t(k);
        const int s0 = sp ? int(sp[2 * r]) : 0, s1 = sp ? int(sp[2 * r + 1]) : int(dims[0]);
        const int y = index_min[1] + j, z = index_min[2] + k;
        const size_t row_blocks = size_t(nb_x) * (size_t((y - fy) / L) + size_t(nb_y) * size_t((z - fz) / L));
        for (int xs = s0; xs < s1;) {
          const int x = index_min[0] + xs;
          const int xe = std::min(s1, xs + (L - (x & (L - 1))));  // end of this leaf block's part
          segment(std::false_type{}, xs, j, k, xe - xs, row_blocks + size_t((x - fx) / L), nullptr);
          xs = xe;
        }
      }
  } else {
    // Column runs (a head evaluated in columns, see `Sweep::column_runs`): the same voxels
    // below the band, read along the leaves' fastest axis.
    const float* rv = run_values.data();
    for (size_t r = 0; r < runs.size(); r += 4) {
      const int i = int(rp[r] % dims[0]), j = int(rp[r] / dims[0]);
      const int x = index_min[0] + i, y = index_min[1] + j;
      const size_t column_blocks = size_t((x - fx) / L) + size_t(nb_x) * size_t((y - fy) / L);
      const int k0 = int(rp[r + 1]);
      const float* t_run = rv + rp[r + 3];
      for (int ks = k0, k1 = int(rp[r + 2]); ks < k1;) {
        const int z = index_min[2] + ks;
        const int ke = std::min(k1, ks + (L - (z & (L - 1))));
        segment(std::true_type{}, i, j, ks, ke - ks, column_blocks + size_t(nb_x) * nb_y * size_t((z - fz) / L), t_run + (ks - k0));
        ks = ke;
      }
    }
  }
  stats.changed_voxels = n_changed;
  if (n_changed == 0 || !measured) return stats;
  // Pass 2, the curvature term: sum over voxels v of W(old_v) Lap(old)_v - W(new_v) Lap(new)_v,
  // where W is the curvature weight. With d = new - old (non-zero only at changed voxels) and
  // Lap(new) = Lap(old) + Lap(d), regrouping the Lap(d) sum by the changed voxel it comes from
  // gives, per changed voxel c: (W(old_c) - W(new_c)) Lap(old)_c - d_c Lap(W(new))_c. So only the
  // six neighbours of each changed voxel are read. Pass 1 noted the old value and W(new) of every
  // voxel within the tool's reach, which holds most neighbours (a voxel's distance to the tool
  // changes by at most h); the others (past the box, or in the ball the last stroke already cut)
  // are unchanged and read from pass 1's leaf table. Branch-light: this runs per changed voxel.
  auto unchanged = [&](int i, int j, int k) -> float {
    const int x = index_min[0] + i, y = index_min[1] + j, z = index_min[2] + k;
    if (!box.contains(i, j, k)) return acc.getValue(Coord(x, y, z));
    const size_t b = size_t((x - fx) / L) + size_t(nb_x) * (size_t((y - fy) / L) + size_t(nb_y) * size_t((z - fz) / L));
    probe(b, x, y, z);
    const Leaf* leaf = leaves[b];
    return leaf ? leaf->buffer().data()[Leaf::coordToOffset(Coord(x, y, z))] : tiles[b];
  };
  double correction = 0.0;
  const int nx = int(dims[0]), ny = int(dims[1]), nz = int(dims[2]);
  const ptrdiff_t step[6] = {1, -1, nx, -nx, ptrdiff_t(nx) * ny, -ptrdiff_t(nx) * ny};
  static const int nb[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const float inv_h2 = float(1.0 / (h * h));
  for (size_t n = 0; n < n_changed; ++n) {
    const ChangedVoxel& c = changed[n];
    float sum_old = 0.f, sum_weight = 0.f;
    const bool inner = c.i > 0 && c.j > 0 && c.k > 0 && c.i + 1 < nx && c.j + 1 < ny && c.k + 1 < nz;
    for (int q = 0; q < 6; ++q) {
      const size_t m = c.m + step[q];
      if (inner && tp[m] + offset < reach) {
        sum_old += old_values[m];
        sum_weight += weights[m];
      } else {
        const int i = c.i + nb[q][0], j = c.j + nb[q][1], k = c.k + nb[q][2];
        float o;
        if (box.contains(i, j, k) && tp[box.index(i, j, k)] + offset < reach) {
          const size_t n = box.index(i, j, k);
          o = old_values[n];
          sum_weight += weights[n];
        } else {
          o = unchanged(i, j, k);
          sum_weight += kernels.curvature_weight(o);
        }
        sum_old += o;
      }
    }
    const float w_new = weights[c.m];
    const float lap_old = (sum_old - 6.f * c.old) * inv_h2;
    const float lap_weight = (sum_weight - 6.f * w_new) * inv_h2;
    correction += double((kernels.curvature_weight(c.old) - w_new) * lap_old - (c.now - c.old) * lap_weight);
  }
  stats.removed_volume = (stats.removed_volume - correction) * h * h * h;
  return stats;
}

}  // namespace

CutStats subtract_core(LevelSet::Impl& impl, std::array<int32_t, 3> index_min,
                       std::array<uint32_t, 3> dims, rust::Slice<const float> tool,
                       rust::Slice<const uint32_t> spans, rust::Slice<const uint32_t> runs,
                       rust::Slice<const float> run_values, float offset, bool logged, bool measured) {
  return measured ? subtract_as<false>(impl, index_min, dims, tool, spans, runs, run_values, offset, logged, true)
                  : subtract_as<true>(impl, index_min, dims, tool, spans, runs, run_values, offset, logged, false);
}

CutStats LevelSet::subtract_dense(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                                  rust::Slice<const float> tool, rust::Slice<const uint32_t> spans) {
  return subtract_core(*impl, index_min, dims, tool, spans, {}, {}, 0.f, false, true);
}

CutStats LevelSet::subtract_logged(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                                   rust::Slice<const float> tool, rust::Slice<const uint32_t> spans,
                                   rust::Slice<const uint32_t> runs, rust::Slice<const float> run_values,
                                   float offset, bool measured) {
  return subtract_core(*impl, index_min, dims, tool, spans, runs, run_values, offset, true, measured);
}

void LevelSet::reserve_cut(std::array<uint32_t, 3> dims) {
  const size_t voxels = size_t(dims[0]) * dims[1] * dims[2];
  // A box spans at most dims / 8 + 2 leaf blocks along each axis.
  const size_t blocks = size_t(dims[0] / 8 + 2) * (dims[1] / 8 + 2) * (dims[2] / 8 + 2);
  auto grow = [](auto& buffer, size_t n) {
    if (buffer.size() < n) buffer.resize(n);
  };
  grow(impl->scratch_old, voxels);
  grow(impl->scratch_weight, voxels);
  grow(impl->scratch_changed, voxels);
  grow(impl->scratch_log, voxels);
  grow(impl->scratch_leaves, blocks);
  grow(impl->scratch_tiles, blocks);
}

rust::Slice<const VoxelChange> LevelSet::last_changes() const {
  return {impl->scratch_log.data(), impl->log_count};
}

void LevelSet::mark_material_blocks(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                                    rust::Slice<uint8_t> out) const {
  constexpr int L = int(FloatTree::LeafNodeType::DIM);
  auto floor_to_leaf = [](int v) { return v & ~(L - 1); };
  int first[3], count[3];
  for (int a = 0; a < 3; ++a) {
    first[a] = floor_to_leaf(index_min[a]);
    count[a] = (index_min[a] + int(dims[a]) - 1 - first[a]) / L + 1;
  }
  if (out.size() < size_t(count[0]) * count[1] * count[2])
    throw std::invalid_argument("material block mask is smaller than the box's blocks");
  const float bg = impl->grid->background();
  openvdb::tree::ValueAccessor<const FloatTree, false> acc(impl->grid->tree());
  size_t b = 0;
  for (int bz = 0; bz < count[2]; ++bz)
    for (int by = 0; by < count[1]; ++by)
      for (int bx = 0; bx < count[0]; ++bx, ++b) {
        if (out[b] == 2) continue;  // another grid's material: nothing to add
        const Coord origin(first[0] + bx * L, first[1] + by * L, first[2] + bz * L);
        // A cut's new values are at most the background: a block whose every voxel is there
        // already (an outside tile, or a leaf a cut left all outside: 1) cannot change; one with
        // a voxel below it (an inside tile, a leaf with an active voxel or an inside one) is 2.
        // An empty leaf is read (an inside one stops at its first voxel).
        uint8_t mark = 0;
        if (const auto* leaf = acc.probeConstLeaf(origin)) {
          bool below = !leaf->isEmpty();
          const float* v = leaf->buffer().data();
          // 64 at a time without a branch (vectorised); a cut-clear leaf is read whole.
          for (openvdb::Index i = 0; !below && i < FloatTree::LeafNodeType::SIZE; i += 64) {
            int any = 0;
            for (openvdb::Index j = 0; j < 64; ++j) any |= int(v[i + j] < bg);
            below = any != 0;
          }
          mark = below ? 2 : 1;
        } else if (acc.getValue(origin) < bg) {
          mark = 2;
        }
        out[b] = std::max(out[b], mark);
      }
}

void LevelSet::last_new_values(rust::Slice<VoxelChange> out) const {
  // Pass 1 keeps each changed voxel's new value beside its log entry, in the same order.
  const size_t n = std::min(out.size(), impl->log_count);
  for (size_t i = 0; i < n; ++i) out[i].value = impl->scratch_changed[i].now;
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
  const VolumeKernels kernels(h);
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
        const double before = kernels.inside_fraction(old);
        if (before == 0.0) continue;
        for (size_t m = 0; m < n_off; ++m) {
          const float cut = -(tp[n] + op[m]);
          if (cut > old) rp[m] += before - kernels.inside_fraction(std::min(cut, bg));
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
