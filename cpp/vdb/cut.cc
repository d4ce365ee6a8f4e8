// Local CSG difference against a dense patch of tool signed distances.
//
// In: a box of voxels (index_min, dims, x fastest) holding the tool's signed distance at each voxel
// centre. Out: every voxel with tool < background takes max(value, -tool); voxels whose new value
// leaves the band are switched off at +-background. Cost: one cached accessor lookup per voxel
// within the tool's band; voxels farther outside the tool are skipped without touching the tree.
#include "impl.h"

namespace dentsim::vdb {

CutStats LevelSet::subtract_dense(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                                  rust::Slice<const float> tool) {
  const size_t expected = size_t(dims[0]) * dims[1] * dims[2];
  if (tool.size() != expected)
    throw std::invalid_argument("tool patch holds " + std::to_string(tool.size()) +
                                " values, its dimensions need " + std::to_string(expected));
  auto& grid = *impl->grid;
  const float bg = grid.background();
  const double h = voxel_size();
  const double eps = 1.5 * h;
  openvdb::tree::ValueAccessor<FloatTree, false> acc(grid.tree());
  CutStats stats{0, 0.0};
  size_t n = 0;
  for (uint32_t k = 0; k < dims[2]; ++k)
    for (uint32_t j = 0; j < dims[1]; ++j)
      for (uint32_t i = 0; i < dims[0]; ++i, ++n) {
        const float t = tool[n];
        if (!(t < bg)) continue;
        const Coord c(index_min[0] + int32_t(i), index_min[1] + int32_t(j),
                      index_min[2] + int32_t(k));
        const float old = acc.getValue(c);
        const float cut = -t;
        if (!(cut > old)) continue;
        if (cut < bg) {
          acc.setValueOn(c, cut);
        } else {
          acc.setValueOff(c, bg);
        }
        const float now = cut < bg ? cut : bg;
        stats.changed_voxels += 1;
        stats.removed_volume += inside_fraction(old, eps) - inside_fraction(now, eps);
      }
  stats.removed_volume *= h * h * h;
  return stats;
}

}  // namespace dentsim::vdb
