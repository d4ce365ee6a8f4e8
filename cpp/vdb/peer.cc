// Benchmark peers: the same jobs done the plain OpenVDB way, for `dentsim bench` to compare with.
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/VolumeToMesh.h>

#include "impl.h"

namespace dentsim::vdb {

// Accessor + BoxSampler over a list of world points, all in one C++ loop.
double LevelSet::peer_sample_sum(rust::Slice<const float> xyz) const {
  const auto& grid = *impl->grid;
  FloatGrid::ConstAccessor acc = grid.getConstAccessor();
  openvdb::tools::GridSampler<FloatGrid::ConstAccessor, openvdb::tools::BoxSampler> sampler(
      acc, grid.transform());
  double sum = 0.0;
  for (size_t i = 0; i + 2 < xyz.size(); i += 3)
    sum += sampler.wsSample(openvdb::Vec3d(xyz[i], xyz[i + 1], xyz[i + 2]));
  return sum;
}

// A tool level set built and subtracted per stroke, as level-set sculpting tools do.
void LevelSet::peer_sphere_cut(std::array<double, 3> center, double radius) {
  auto& grid = *impl->grid;
  const float h = float(voxel_size());
  const float half_width = grid.background() / h;
  auto tool = openvdb::tools::createLevelSetSphere<FloatGrid>(
      float(radius), openvdb::Vec3f(center[0], center[1], center[2]), h, half_width);
  openvdb::tools::csgDifference(grid, *tool);
}

uint64_t LevelSet::peer_full_mesh() const {
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> tris;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*impl->grid, points, tris, quads, 0.0, 0.0);
  return quads.size() * 2 + tris.size();
}

}  // namespace dentsim::vdb
