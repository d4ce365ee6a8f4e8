// Reader: per-thread trilinear sampling of a level set.
#include "impl.h"

namespace dentsim::vdb {

Reader::Reader(std::unique_ptr<Impl> i) : impl(std::move(i)) {}
Reader::~Reader() = default;

std::unique_ptr<Reader> new_reader(const LevelSet& grid) {
  return std::make_unique<Reader>(std::make_unique<Reader::Impl>(grid.impl->grid));
}

std::array<float, 4> Reader::value_gradient(double x, double y, double z) {
  const auto ijk = impl->xform->worldToIndex(openvdb::Vec3d(x, y, z));
  return trilinear(impl->acc, ijk, impl->xform->voxelSize()[0]);
}

float Reader::value(double x, double y, double z) { return value_gradient(x, y, z)[0]; }

void Reader::values(rust::Slice<const float> xyz, rust::Slice<float> out) {
  const size_t n = std::min(xyz.size() / 3, out.size());
  for (size_t i = 0; i < n; ++i) out[i] = value(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
}

}  // namespace dentsim::vdb
