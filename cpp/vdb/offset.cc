// LevelSet::offset: moves the zero iso-surface along its normals by a distance in mm (outward
// when positive). Within half a voxel the active values are shifted (still distances to the moved
// surface, the band keeps 2.5 voxels or more each side); beyond, OpenVDB's LevelSetFilter::offset
// shifts in steps of at most half a voxel and re-tracks the narrow band after each.
// Cost: one pass over the active voxels, plus re-tracking per half voxel beyond the first.
#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/ValueTransformer.h>

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
  if (std::fabs(distance) <= 0.5 * grid.voxelSize()[0]) {
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

}  // namespace dentsim::vdb
