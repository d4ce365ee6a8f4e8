// LevelSet::offset: moves the zero iso-surface along its normals by a distance in mm (outward
// when positive) with OpenVDB's LevelSetFilter::offset, which shifts the values in steps of at
// most half a voxel and re-tracks the narrow band after each. Cost: one pass over the active
// voxels per half voxel of distance.
#include <openvdb/tools/LevelSetFilter.h>

#include <stdexcept>
#include <string>

#include "impl.h"

namespace dentsim::vdb {

void LevelSet::offset(double distance) {
  if (!std::isfinite(distance))
    throw std::invalid_argument("level set offset must be a finite number of mm, got " +
                                std::to_string(distance));
  if (distance == 0.0) return;
  openvdb::tools::LevelSetFilter<FloatGrid> filter(*impl->grid);
  // The filter adds to the signed distance (negative inside), so growing means subtracting.
  filter.offset(float(-distance));
}

}  // namespace dentsim::vdb
