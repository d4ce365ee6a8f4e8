// Conversions between level sets and surfaces or dense volumes.
//
// to_mesh: volumeToMesh at iso 0, quads split to triangles wound counter-clockwise seen from
// outside (VTK's convention; OpenVDB's own winding is the opposite), normals from the trilinear
// gradient. Cost: one pass over the active voxels.
#include <openvdb/tools/Dense.h>
#include <openvdb/tools/LevelSetRebuild.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <stdexcept>

#include "impl.h"

namespace dentsim::vdb {

MeshBuffers LevelSet::to_mesh() const {
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> tris;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*impl->grid, points, tris, quads, 0.0, 0.0);

  MeshBuffers out;
  out.points.reserve(points.size() * 3);
  out.normals.reserve(points.size() * 3);
  openvdb::tree::ValueAccessor<const FloatTree, false> acc(impl->grid->tree());
  const auto& xform = impl->grid->transform();
  const double h = voxel_size();
  for (const auto& p : points) {
    const auto g = trilinear(acc, xform.worldToIndex(openvdb::Vec3d(p)), h);
    double len = std::sqrt(double(g[1]) * g[1] + double(g[2]) * g[2] + double(g[3]) * g[3]);
    if (!(len > 0.0)) len = 1.0;
    for (int a = 0; a < 3; ++a) {
      out.points.push_back(p[a]);
      out.normals.push_back(float(g[1 + a] / len));
    }
  }
  out.triangles.reserve(tris.size() * 3 + quads.size() * 6);
  for (const auto& t : tris) {
    out.triangles.push_back(t[2]);
    out.triangles.push_back(t[1]);
    out.triangles.push_back(t[0]);
  }
  for (const auto& q : quads) {
    const uint32_t r[4] = {q[3], q[2], q[1], q[0]};
    for (uint32_t v : {r[0], r[1], r[2], r[0], r[2], r[3]}) out.triangles.push_back(v);
  }
  return out;
}

std::unique_ptr<LevelSet> level_set_from_mesh(rust::Slice<const float> points,
                                              rust::Slice<const uint32_t> triangles,
                                              double voxel_size, double half_width) {
  auto grid = new_grid(voxel_size, half_width);
  if (points.size() % 3 != 0 || triangles.size() % 3 != 0)
    throw std::invalid_argument("mesh arrays must hold whole xyz points and whole triangles");
  const size_t n_points = points.size() / 3;
  std::vector<openvdb::Vec3s> pts(n_points);
  for (size_t i = 0; i < n_points; ++i)
    pts[i] = openvdb::Vec3s(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
  std::vector<openvdb::Vec3I> tris(triangles.size() / 3);
  for (size_t i = 0; i < tris.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      const uint32_t v = triangles[3 * i + a];
      if (v >= n_points)
        throw std::out_of_range("triangle " + std::to_string(i) + " names point " +
                                std::to_string(v) + " of " + std::to_string(n_points));
      tris[i][a] = v;
    }
  }
  auto out = openvdb::tools::meshToLevelSet<FloatGrid>(grid->transform(), pts, tris,
                                                       float(half_width));
  out->setGridClass(openvdb::GRID_LEVEL_SET);
  return wrap(out);
}

std::unique_ptr<LevelSet> level_set_from_dense(std::array<uint32_t, 3> dims,
                                               std::array<double, 16> index_to_world,
                                               rust::Slice<const float> values, float iso,
                                               bool inside_above, double voxel_size,
                                               double half_width) {
  auto target = new_grid(voxel_size, half_width);
  const size_t expected = size_t(dims[0]) * dims[1] * dims[2];
  if (expected == 0 || values.size() != expected)
    throw std::invalid_argument("dense volume holds " + std::to_string(values.size()) +
                                " values, its dimensions need " + std::to_string(expected));
  // Row-major 4x4 with the translation in the last column; OpenVDB wants it transposed.
  openvdb::Mat4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[c][r] = index_to_world[4 * r + c];
  auto source = FloatGrid::create(std::numeric_limits<float>::max());
  source->setTransform(openvdb::math::Transform::createLinearTransform(m));
  {
    const openvdb::CoordBBox box(Coord(0), Coord(int(dims[0]) - 1, int(dims[1]) - 1,
                                                 int(dims[2]) - 1));
    std::vector<float> shifted(expected);
    for (size_t i = 0; i < expected; ++i) {
      const float v = values[i];
      if (!std::isfinite(v)) throw std::invalid_argument("dense volume value " + std::to_string(i) + " is not finite");
      shifted[i] = inside_above ? iso - v : v - iso;
    }
    openvdb::tools::Dense<float, openvdb::tools::LayoutXYZ> dense(box, shifted.data());
    openvdb::tools::copyFromDense(dense, *source, 0.f);
  }
  auto out = openvdb::tools::levelSetRebuild(*source, 0.f, float(half_width), float(half_width),
                                             &target->transform());
  out->setGridClass(openvdb::GRID_LEVEL_SET);
  return wrap(out);
}

}  // namespace dentsim::vdb
