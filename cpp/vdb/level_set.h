// The C++ side of crates/vdb: narrow-band level sets over OpenVDB 10.
//
// Every type is pimpl so that OpenVDB, TBB and Boost headers stay inside cpp/vdb/*.cc and out of
// the cxx-generated code. Coordinates are world millimetres unless a name says "index".
#pragma once

#include <array>
#include <cstdint>
#include <memory>

#include "rust/cxx.h"

namespace dentsim::vdb {

struct MeshBuffers;
struct CutStats;
struct VoxelChange;

class LevelSet {
public:
  struct Impl;
  explicit LevelSet(std::unique_ptr<Impl> impl);
  ~LevelSet();

  double voxel_size() const;
  float background() const;
  rust::String name() const;
  void set_name(rust::Str name);
  uint64_t active_voxel_count() const;
  uint64_t leaf_count() const;
  uint64_t mem_bytes() const;
  std::array<int32_t, 6> index_bbox() const;
  std::unique_ptr<LevelSet> deep_copy() const;

  // Building from leaves: values of one 8^3 leaf, x slowest (OpenVDB's leaf order).
  void set_leaf(std::array<int32_t, 3> origin, rust::Slice<const float> values);
  void finish_build();

  // Volume enclosed (mm^3): smoothed Heaviside over every voxel and tile.
  double volume() const;
  // Inside tiles become leaves (inactive, -background), so cuts never allocate; prune undoes it.
  void voxelize_inside();
  void prune();

  // Local cutting: v = max(v, -tool) over a dense patch of tool distances (x fastest), read
  // only within each row's span (see DensePatch::spans).
  CutStats subtract_dense(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                          rust::Slice<const float> tool, rust::Slice<const uint32_t> spans);

  void csg_difference(const LevelSet& other);
  void csg_union(const LevelSet& other);
  void csg_intersection(const LevelSet& other);
  // Moves the surface along its normals by `distance` mm, outward when positive (offset.cc).
  void offset(double distance);
  void narrow_band(double half_width_voxels);

  MeshBuffers to_mesh() const;

  void set_meta_string(rust::Str key, rust::Str value);
  void set_meta_f64(rust::Str key, double value);
  void set_meta_i64(rust::Str key, int64_t value);
  void set_meta_vec3(rust::Str key, std::array<float, 3> value);
  rust::Vec<rust::String> meta_keys() const;
  rust::String meta_type(rust::Str key) const;
  rust::String meta_string(rust::Str key) const;
  double meta_f64(rust::Str key) const;
  std::array<float, 3> meta_vec3(rust::Str key) const;

  // Benchmark peers: what plain OpenVDB code would do for the same job (peer.cc, compiled only
  // with the Rust feature `peer`).
  double peer_sample_sum(rust::Slice<const float> xyz) const;
  void peer_sphere_cut(std::array<double, 3> center, double radius);
  void peer_mesh_cut(rust::Slice<const float> points, rust::Slice<const uint32_t> triangles);
  uint64_t peer_full_mesh() const;

  // Haptic sampling without a Reader (sample.cc): values, or value + gradient per point.
  void sample_values(rust::Slice<const float> xyz, rust::Slice<float> out) const;
  void sample_value_gradients(rust::Slice<const float> xyz, rust::Slice<float> out) const;
  uint64_t content_hash() const;

  // Cutting with an undo log, rate limiting, journal replay, region reads (added for issue 4).
  CutStats subtract_logged(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                           rust::Slice<const float> tool, rust::Slice<const uint32_t> spans,
                           rust::Slice<const uint32_t> runs, rust::Slice<const float> run_values,
                           float offset, bool measured);
  // The voxels the last subtract_logged changed, with their old values (valid until the next cut).
  rust::Slice<const VoxelChange> last_changes() const;
  // Sets each entry's value to the new value of the voxel the last logged cut changed at the
  // same position in last_changes (the first out.size() of them).
  void last_new_values(rust::Slice<VoxelChange> out) const;
  // Grows the cut's working buffers for patches up to dims, so those cuts allocate nothing.
  void reserve_cut(std::array<uint32_t, 3> dims);
  // Sets out[b] = 1 for each leaf-aligned 8^3 block b overlapping the box (x fastest, from the
  // block holding index_min) that holds a leaf or an inside tile: material a cut could change.
  void mark_material_blocks(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                            rust::Slice<uint8_t> out) const;
  void removal_by_offset(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                         rust::Slice<const float> tool, rust::Slice<const float> offsets,
                         rust::Slice<double> removed) const;
  void write_voxels(rust::Slice<const VoxelChange> changes);
  void read_voxels(rust::Slice<VoxelChange> changes) const;
  void read_dense(std::array<int32_t, 3> index_min, std::array<uint32_t, 3> dims,
                  rust::Slice<float> out) const;
  rust::Vec<int32_t> leaf_origins() const;

  std::unique_ptr<Impl> impl;
};

// A cached, unregistered accessor for one thread; trilinear value and gradient.
class Reader {
public:
  struct Impl;
  explicit Reader(std::unique_ptr<Impl> impl);
  ~Reader();
  float value(double x, double y, double z);
  std::array<float, 4> value_gradient(double x, double y, double z);
  void values(rust::Slice<const float> xyz, rust::Slice<float> out);
  std::unique_ptr<Impl> impl;
};

// Named grids on their way to or from a .vdb file.
class GridList {
public:
  struct Impl;
  explicit GridList(std::unique_ptr<Impl> impl);
  ~GridList();
  void push(const LevelSet& grid);
  size_t len() const;
  rust::String grid_name(size_t i) const;
  rust::String grid_type(size_t i) const;
  rust::String grid_class(size_t i) const;
  std::unique_ptr<LevelSet> take(size_t i);
  void write_file(rust::Str path) const;
  std::unique_ptr<Impl> impl;
};

std::unique_ptr<LevelSet> new_level_set(double voxel_size, double half_width);
std::unique_ptr<LevelSet> level_set_sphere(std::array<double, 3> center, double radius,
                                           double voxel_size, double half_width);
std::unique_ptr<LevelSet> level_set_from_mesh(rust::Slice<const float> points,
                                              rust::Slice<const uint32_t> triangles,
                                              double voxel_size, double half_width);
std::unique_ptr<LevelSet> level_set_from_dense(std::array<uint32_t, 3> dims,
                                               std::array<double, 16> index_to_world,
                                               rust::Slice<const float> values, float iso,
                                               bool inside_above, double voxel_size,
                                               double half_width);
std::unique_ptr<Reader> new_reader(const LevelSet& grid);
std::unique_ptr<GridList> new_grid_list();
std::unique_ptr<GridList> read_bytes(rust::Slice<const uint8_t> bytes);

}  // namespace dentsim::vdb
