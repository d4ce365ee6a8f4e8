// Allocation-free batched sampling for the haptic tick, and a content hash for bit-exact checks.
//
// The accessor lives on the stack of each call (unregistered: no allocation, no lock), so the
// haptic thread can sample a grid it owns between cuts without keeping a Reader alive.
// Cost: one accessor walk per corner, cached across the batch (~25-50 ns a point nearby).
#include "impl.h"

namespace dentsim::vdb {

void LevelSet::sample_values(rust::Slice<const float> xyz, rust::Slice<float> out) const {
  openvdb::tree::ValueAccessor<const FloatTree, false> acc(impl->grid->tree());
  const auto& xform = impl->grid->transform();
  const double h = voxel_size();
  const size_t n = std::min(xyz.size() / 3, out.size());
  const float* p = xyz.data();  // rust::Slice indexing calls out of line per element
  float* o = out.data();
  for (size_t i = 0; i < n; ++i) {
    const auto ijk = xform.worldToIndex(openvdb::Vec3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]));
    o[i] = trilinear(acc, ijk, h)[0];
  }
}

void LevelSet::sample_value_gradients(rust::Slice<const float> xyz, rust::Slice<float> out) const {
  openvdb::tree::ValueAccessor<const FloatTree, false> acc(impl->grid->tree());
  const auto& xform = impl->grid->transform();
  const double h = voxel_size();
  const size_t n = std::min(xyz.size() / 3, out.size() / 4);
  const float* p = xyz.data();
  float* o = out.data();
  for (size_t i = 0; i < n; ++i) {
    const auto ijk = xform.worldToIndex(openvdb::Vec3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]));
    const auto g = trilinear(acc, ijk, h);
    for (int k = 0; k < 4; ++k) o[4 * i + k] = g[k];
  }
}

// FNV-1a over every value of the tree (voxels and tiles, active or not) with its coordinate,
// level and active state, in OpenVDB's deterministic iteration order.
uint64_t LevelSet::content_hash() const {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* p, size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) {
      h ^= b[i];
      h *= 1099511628211ull;
    }
  };
  for (auto it = impl->grid->tree().cbeginValueAll(); it; ++it) {
    const Coord c = it.getCoord();
    const int32_t xyz[3] = {c.x(), c.y(), c.z()};
    const float v = *it;
    const int32_t level_on[2] = {int32_t(it.getLevel()), it.isValueOn() ? 1 : 0};
    mix(xyz, sizeof xyz);
    mix(&v, sizeof v);
    mix(level_on, sizeof level_on);
  }
  return h;
}

}  // namespace dentsim::vdb
