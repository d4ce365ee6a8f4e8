// LevelSet::offset: moves the zero iso-surface along its normals by a distance in mm (outward
// when positive). Where the band keeps 2.5 voxels or more each side after it (within half a
// voxel of a 3-voxel band, farther in a wider one), the active values are shifted: they stay
// distances to the moved surface. Beyond, OpenVDB's LevelSetFilter::offset shifts in steps of at
// most half a voxel and re-tracks the narrow band after each (~0.3 s a step for a pulp's 270k
// voxels at 0.05 mm). LevelSet::narrow_band trims a wide band back once the surface is placed.
// Cost: one pass over the active voxels, plus re-tracking per half voxel beyond the band.
#include <openvdb/tools/ChangeBackground.h>
#include <openvdb/tools/Count.h>
#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/ValueTransformer.h>
#include <openvdb/tree/LeafManager.h>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "impl.h"

namespace dentsim::vdb {

void LevelSet::offset(double distance) {
  if (!std::isfinite(distance))
    throw std::invalid_argument("level set offset must be a finite number of mm, got " +
                                std::to_string(distance));
  if (distance == 0.0) return;
  FloatGrid& grid = *impl->grid;
  const double h = grid.voxelSize()[0], kept = 2.5 * h;
  // (The band's extent is read only when the move is past half a voxel.)
  const auto wide_enough = [&] {
    const auto band = openvdb::tools::minMax(grid.tree());
    return band.max() - distance >= kept && band.min() - distance <= -kept;
  };
  if (std::fabs(distance) <= 0.5 * h || wide_enough()) {
    const float d = float(distance), w = grid.background();
    openvdb::tools::foreach(grid.beginValueOn(), [d, w](const FloatGrid::ValueOnIter& it) {
      it.setValue(std::clamp(*it - d, -w, w));
    });
    return;
  }
  openvdb::tools::LevelSetFilter<FloatGrid> filter(grid);
  // The filter adds to the signed distance (negative inside), so growing means subtracting.
  filter.offset(float(-distance));
}

void LevelSet::narrow_band(double half_width_voxels) {
  if (!(std::isfinite(half_width_voxels) && half_width_voxels >= 1.0))
    throw std::invalid_argument("narrow band half width must be at least one voxel, got " +
                                std::to_string(half_width_voxels));
  FloatGrid& grid = *impl->grid;
  const float w = float(half_width_voxels * grid.voxelSize()[0]);
  if (w >= grid.background()) return;
  // Active voxels beyond the new band become its inactive outside or inside.
  openvdb::tree::LeafManager<FloatTree> leaves(grid.tree());
  leaves.foreach([w](FloatTree::LeafNodeType& leaf, size_t) {
    for (auto it = leaf.beginValueOn(); it; ++it) {
      const float v = *it;
      if (v >= w || v <= -w) leaf.setValueOff(it.pos(), v > 0.f ? w : -w);
    }
  });
  openvdb::tools::changeLevelSetBackground(grid.tree(), w);
  openvdb::tools::pruneLevelSet(grid.tree());
}

}  // namespace dentsim::vdb
