// Benchmark peers: the same jobs done the plain OpenVDB way, for `dentsim bench` to compare with.
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/MeshToVolume.h>
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

// Any tool shape: its level set built from its triangle mesh at the stroke's pose
// (`meshToLevelSet`, in this grid's frame and band), then subtracted.
void LevelSet::peer_mesh_cut(rust::Slice<const float> points, rust::Slice<const uint32_t> triangles) {
  auto& grid = *impl->grid;
  if (points.size() % 3 != 0 || triangles.size() % 3 != 0)
    throw std::invalid_argument("peer mesh arrays must hold whole xyz points and whole triangles");
  const size_t n = points.size() / 3;
  std::vector<openvdb::Vec3s> pts(n);
  for (size_t i = 0; i < n; ++i) pts[i] = openvdb::Vec3s(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
  std::vector<openvdb::Vec3I> tris(triangles.size() / 3);
  for (size_t i = 0; i < tris.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      if (triangles[3 * i + a] >= n) throw std::out_of_range("peer mesh triangle names a missing point");
      tris[i][a] = triangles[3 * i + a];
    }
  }
  const float half_width = grid.background() / float(voxel_size());
  auto tool = openvdb::tools::meshToLevelSet<FloatGrid>(grid.transform(), pts, tris, half_width);
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
