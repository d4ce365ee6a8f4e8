// LevelSet basics: construction from leaves, measures, CSG and metadata.
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tree/LeafManager.h>
#include <tbb/parallel_for.h>

#include <array>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "impl.h"

namespace dentsim::vdb {

void ensure_initialized() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

LevelSet::LevelSet(std::unique_ptr<Impl> i) : impl(std::move(i)) {}
LevelSet::~LevelSet() = default;

std::unique_ptr<LevelSet> wrap(FloatGrid::Ptr grid) {
  auto impl = std::make_unique<LevelSet::Impl>();
  impl->grid = std::move(grid);
  return std::make_unique<LevelSet>(std::move(impl));
}

FloatGrid::Ptr new_grid(double voxel_size, double half_width) {
  ensure_initialized();
  if (!(voxel_size > 0.0) || !std::isfinite(voxel_size))
    throw std::invalid_argument("voxel size must be a positive number of mm, got " +
                                std::to_string(voxel_size));
  if (!(half_width >= 1.0) || !std::isfinite(half_width))
    throw std::invalid_argument("narrow-band half width must be at least 1 voxel, got " +
                                std::to_string(half_width));
  auto grid = FloatGrid::create(float(voxel_size * half_width));
  grid->setTransform(openvdb::math::Transform::createLinearTransform(voxel_size));
  grid->setGridClass(openvdb::GRID_LEVEL_SET);
  return grid;
}

std::unique_ptr<LevelSet> new_level_set(double voxel_size, double half_width) {
  return wrap(new_grid(voxel_size, half_width));
}

std::unique_ptr<LevelSet> level_set_sphere(std::array<double, 3> center, double radius,
                                           double voxel_size, double half_width) {
  new_grid(voxel_size, half_width);  // validates the arguments
  if (!(radius > voxel_size)) throw std::invalid_argument("sphere radius must exceed one voxel");
  return wrap(openvdb::tools::createLevelSetSphere<FloatGrid>(
      float(radius), openvdb::Vec3f(center[0], center[1], center[2]), float(voxel_size),
      float(half_width)));
}

double LevelSet::voxel_size() const { return impl->grid->voxelSize()[0]; }
float LevelSet::background() const { return impl->grid->background(); }
rust::String LevelSet::name() const { return rust::String(impl->grid->getName()); }
void LevelSet::set_name(rust::Str name) { impl->grid->setName(std::string(name)); }
uint64_t LevelSet::active_voxel_count() const { return impl->grid->activeVoxelCount(); }
uint64_t LevelSet::leaf_count() const { return impl->grid->tree().leafCount(); }
uint64_t LevelSet::mem_bytes() const { return impl->grid->memUsage(); }

std::array<int32_t, 6> LevelSet::index_bbox() const {
  const auto box = impl->grid->evalActiveVoxelBoundingBox();
  return {box.min().x(), box.min().y(), box.min().z(), box.max().x(), box.max().y(), box.max().z()};
}

std::unique_ptr<LevelSet> LevelSet::deep_copy() const { return wrap(impl->grid->deepCopy()); }

void LevelSet::set_leaf(std::array<int32_t, 3> origin, rust::Slice<const float> values) {
  using Leaf = FloatTree::LeafNodeType;
  if (values.size() != Leaf::SIZE)
    throw std::invalid_argument("a leaf holds 512 values, got " + std::to_string(values.size()));
  const float bg = impl->grid->background();
  Leaf* leaf = impl->grid->tree().touchLeaf(Coord(origin[0], origin[1], origin[2]));
  for (openvdb::Index n = 0; n < Leaf::SIZE; ++n) {
    const float v = values[n];
    if (std::fabs(v) < bg) {
      leaf->setValueOn(n, v);
    } else {
      leaf->setValueOff(n, v < 0.f ? -bg : bg);
    }
  }
}

const KernelTables kKernels = [] {
  KernelTables k{};
  for (int i = 0; i <= kKernelSteps + 1; ++i) {
    const double t = std::min(-1.0 + 2.0 * i / kKernelSteps, 1.0);
    k.heaviside[i] = float(0.5 * (1.0 - t - std::sin(M_PI * t) / M_PI));
    k.delta[i] = float(0.5 * (1.0 + std::cos(M_PI * t)));
  }
  return k;
}();

void LevelSet::finish_build() {
  openvdb::tools::signedFloodFill(impl->grid->tree());
  openvdb::tools::pruneLevelSet(impl->grid->tree());
}

// 2^21 leaves hold 4 GiB of values: far beyond a tooth (~15 k leaves at 0.05 mm).
constexpr uint64_t kMaxVoxelizedLeaves = 1u << 21;

void LevelSet::voxelize_inside() {
  auto& tree = impl->grid->tree();
  constexpr int L = int(FloatTree::LeafNodeType::DIM);
  std::vector<Coord> origins;  // the tree cannot change under its iterator
  auto it = tree.cbeginValueOff();
  it.setMaxDepth(FloatTree::ValueOffCIter::LEAF_DEPTH - 1);  // tiles only, not leaf voxels
  for (; it; ++it) {
    if (!(*it < 0.f)) continue;
    openvdb::CoordBBox box;
    it.getBoundingBox(box);
    if (origins.size() + box.volume() / (L * L * L) > kMaxVoxelizedLeaves)
      throw std::invalid_argument("the inside of grid '" + impl->grid->getName() +
                                  "' is too large to turn into leaves (over " +
                                  std::to_string(kMaxVoxelizedLeaves) + " leaves)");
    for (int x = box.min().x(); x <= box.max().x(); x += L)
      for (int y = box.min().y(); y <= box.max().y(); y += L)
        for (int z = box.min().z(); z <= box.max().z(); z += L) origins.emplace_back(x, y, z);
  }
  openvdb::tree::ValueAccessor<FloatTree, false> acc(tree);
  for (const Coord& o : origins) acc.touchLeaf(o);
}

void LevelSet::prune() { openvdb::tools::pruneLevelSet(impl->grid->tree()); }

double LevelSet::volume() const {
  const double h = voxel_size();
  const VolumeKernels kernels(h);
  const FloatTree& tree = impl->grid->tree();
  // Voxels wholly inside are counted (an integer, the same in any order), the surface's
  // fractions summed: then the volume is the same on any number of threads, and the same whether
  // the inside is tiles or leaves (voxelize_inside). The tiles above the leaves first, then each
  // leaf side by side, their sums added in leaf order.
  uint64_t whole = 0;
  double fractions = 0.0;
  const auto add = [&kernels](float value, uint64_t count, uint64_t& whole, double& fractions) {
    const double f = kernels.inside_fraction(value);
    if (f == 1.0)
      whole += count;
    else if (f > 0.0)
      fractions += f * double(count);
  };
  auto it = tree.cbeginValueAll();
  it.setMaxDepth(FloatTree::ValueAllCIter::LEAF_DEPTH - 1);
  for (; it; ++it) add(*it, it.getVoxelCount(), whole, fractions);
  // Per leaf: its voxels, and the curvature correction over its active voxels near the surface
  // (see VolumeKernels in impl.h).
  struct Part {
    uint64_t whole = 0;
    double fractions = 0.0, correction = 0.0;
  };
  openvdb::tree::LeafManager<const FloatTree> leaves(tree);
  std::vector<Part> parts(leaves.leafCount());
  tbb::parallel_for(leaves.leafRange(), [&](const openvdb::tree::LeafManager<const FloatTree>::LeafRange& range) {
    openvdb::tree::ValueAccessor<const FloatTree, false> acc(tree);
    for (auto leaf = range.begin(); leaf; ++leaf) {
      Part& part = parts[leaf.pos()];
      const float* values = leaf->buffer().data();
      for (openvdb::Index n = 0; n < FloatTree::LeafNodeType::SIZE; ++n)
        add(values[n], 1, part.whole, part.fractions);
      for (auto v = leaf->cbeginValueOn(); v; ++v) {
        const float phi = *v;
        if (!(std::fabs(phi) < kernels.eps)) continue;
        const Coord c = v.getCoord();
        const float s = acc.getValue(c.offsetBy(1, 0, 0)) + acc.getValue(c.offsetBy(-1, 0, 0)) +
                        acc.getValue(c.offsetBy(0, 1, 0)) + acc.getValue(c.offsetBy(0, -1, 0)) +
                        acc.getValue(c.offsetBy(0, 0, 1)) + acc.getValue(c.offsetBy(0, 0, -1));
        part.correction += kernels.curvature_weight(phi) * (s - 6.f * phi) / (h * h);
      }
    }
  });
  double correction = 0.0;
  for (const Part& part : parts) {
    whole += part.whole;
    fractions += part.fractions;
    correction += part.correction;
  }
  return (double(whole) + fractions - correction) * h * h * h;
}

static void require_same_transform(const FloatGrid& a, const FloatGrid& b, const char* op) {
  if (a.transform() != b.transform())
    throw std::invalid_argument(std::string(op) + ": grids '" + a.getName() + "' and '" +
                                b.getName() + "' have different transforms (voxel size or origin)");
}

void LevelSet::csg_difference(const LevelSet& other) {
  require_same_transform(*impl->grid, *other.impl->grid, "CSG difference");
  auto tool = other.impl->grid->deepCopy();  // csgDifference empties its second argument
  openvdb::tools::csgDifference(*impl->grid, *tool);
}

void LevelSet::csg_union(const LevelSet& other) {
  require_same_transform(*impl->grid, *other.impl->grid, "CSG union");
  auto tool = other.impl->grid->deepCopy();
  openvdb::tools::csgUnion(*impl->grid, *tool);
}

void LevelSet::csg_intersection(const LevelSet& other) {
  require_same_transform(*impl->grid, *other.impl->grid, "CSG intersection");
  auto tool = other.impl->grid->deepCopy();
  openvdb::tools::csgIntersection(*impl->grid, *tool);
}

// insertMeta throws TypeError when the key exists with another type (a file's string
// "stiffness_n_per_mm" overwritten by a number): replace, do not merge.
void LevelSet::set_meta_string(rust::Str key, rust::Str value) {
  impl->grid->removeMeta(std::string(key));
  impl->grid->insertMeta(std::string(key), openvdb::StringMetadata(std::string(value)));
}
void LevelSet::set_meta_f64(rust::Str key, double value) {
  impl->grid->removeMeta(std::string(key));
  impl->grid->insertMeta(std::string(key), openvdb::DoubleMetadata(value));
}
void LevelSet::set_meta_i64(rust::Str key, int64_t value) {
  impl->grid->removeMeta(std::string(key));
  impl->grid->insertMeta(std::string(key), openvdb::Int64Metadata(value));
}
void LevelSet::set_meta_vec3(rust::Str key, std::array<float, 3> v) {
  impl->grid->removeMeta(std::string(key));
  impl->grid->insertMeta(std::string(key), openvdb::Vec3SMetadata(openvdb::Vec3s(v[0], v[1], v[2])));
}

rust::Vec<rust::String> LevelSet::meta_keys() const {
  rust::Vec<rust::String> keys;
  for (auto it = impl->grid->beginMeta(); it != impl->grid->endMeta(); ++it)
    keys.push_back(rust::String(it->first));
  return keys;
}

static openvdb::Metadata::ConstPtr find_meta(const FloatGrid& g, rust::Str key) {
  auto m = g[std::string(key)];
  if (!m)
    throw std::out_of_range("grid '" + g.getName() + "' has no metadata '" + std::string(key) + "'");
  return m;
}

rust::String LevelSet::meta_type(rust::Str key) const {
  return rust::String(find_meta(*impl->grid, key)->typeName());
}

rust::String LevelSet::meta_string(rust::Str key) const {
  return rust::String(find_meta(*impl->grid, key)->str());
}

double LevelSet::meta_f64(rust::Str key) const {
  auto m = find_meta(*impl->grid, key);
  if (auto d = openvdb::DynamicPtrCast<const openvdb::DoubleMetadata>(m)) return d->value();
  if (auto f = openvdb::DynamicPtrCast<const openvdb::FloatMetadata>(m)) return f->value();
  if (auto i = openvdb::DynamicPtrCast<const openvdb::Int64Metadata>(m)) return double(i->value());
  if (auto i = openvdb::DynamicPtrCast<const openvdb::Int32Metadata>(m)) return double(i->value());
  throw std::invalid_argument("metadata '" + std::string(key) + "' of grid '" +
                              impl->grid->getName() + "' is " + m->typeName() +
                              ", expected a number");
}

std::array<float, 3> LevelSet::meta_vec3(rust::Str key) const {
  auto m = find_meta(*impl->grid, key);
  if (auto v = openvdb::DynamicPtrCast<const openvdb::Vec3SMetadata>(m))
    return {v->value().x(), v->value().y(), v->value().z()};
  if (auto v = openvdb::DynamicPtrCast<const openvdb::Vec3DMetadata>(m))
    return {float(v->value().x()), float(v->value().y()), float(v->value().z())};
  throw std::invalid_argument("metadata '" + std::string(key) + "' of grid '" +
                              impl->grid->getName() + "' is " + m->typeName() +
                              ", expected vec3s");
}

}  // namespace dentsim::vdb
