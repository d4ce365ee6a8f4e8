// .vdb files holding several named grids with their metadata.
#include <openvdb/io/File.h>

#include <stdexcept>

#include "impl.h"

namespace dentsim::vdb {

GridList::GridList(std::unique_ptr<Impl> i) : impl(std::move(i)) {}
GridList::~GridList() = default;

std::unique_ptr<GridList> new_grid_list() {
  ensure_initialized();
  return std::make_unique<GridList>(std::make_unique<GridList::Impl>());
}

// Shares the tree: writing does not copy the voxels.
void GridList::push(const LevelSet& grid) { impl->grids.push_back(grid.impl->grid); }
size_t GridList::len() const { return impl->grids.size(); }

static const openvdb::GridBase& at(const GridList::Impl& impl, size_t i) {
  if (i >= impl.grids.size() || !impl.grids[i])
    throw std::out_of_range("no grid at index " + std::to_string(i));
  return *impl.grids[i];
}

rust::String GridList::grid_name(size_t i) const { return rust::String(at(*impl, i).getName()); }
rust::String GridList::grid_type(size_t i) const { return rust::String(at(*impl, i).type()); }
rust::String GridList::grid_class(size_t i) const {
  return rust::String(openvdb::GridBase::gridClassToString(at(*impl, i).getGridClass()));
}

std::unique_ptr<LevelSet> GridList::take(size_t i) {
  const auto& base = at(*impl, i);
  auto grid = openvdb::GridBase::grid<FloatGrid>(impl->grids[i]);
  if (!grid)
    throw std::invalid_argument("grid '" + base.getName() + "' is of type " + base.type() +
                                ", expected a float level set");
  const auto voxel = grid->voxelSize();
  if (!grid->hasUniformVoxels() || !grid->transform().isLinear())
    throw std::invalid_argument("grid '" + base.getName() + "' has non-uniform voxels " +
                                std::to_string(voxel[0]) + " x " + std::to_string(voxel[1]) +
                                " x " + std::to_string(voxel[2]) + ", expected cubic voxels");
  impl->grids[i].reset();
  return wrap(grid);
}

void GridList::write_file(rust::Str path) const {
  openvdb::io::File file{std::string(path)};
  file.write(impl->grids);
  file.close();
}

std::unique_ptr<GridList> read_file(rust::Str path) {
  auto list = new_grid_list();
  openvdb::io::File file{std::string(path)};
  file.open();
  list->impl->grids = *file.getGrids();
  file.close();
  return list;
}

}  // namespace dentsim::vdb
