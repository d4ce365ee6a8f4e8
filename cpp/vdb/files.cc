// .vdb files holding several named grids with their metadata.
#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>

#include <istream>
#include <mutex>
#include <stdexcept>
#include <streambuf>

#include "bytes_buf.h"
#include "impl.h"

namespace dentsim::vdb {

// Was there for the forked reader (a fork copies only the forking thread, so no lock could be
// held mid-fork). The reader is now a process of its own; the mutex stays as cheap insurance:
// OpenVDB 10 does not promise that its file I/O (registries, stream state) may run on several
// streams at once, and in-process reads here parse only the reader's clean output, briefly.
static std::mutex io_mutex;

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
  if (!grid->transform().isLinear() || !grid->hasUniformVoxels())
    throw std::invalid_argument("grid '" + base.getName() + "' has non-uniform voxels " +
                                std::to_string(voxel[0]) + " x " + std::to_string(voxel[1]) +
                                " x " + std::to_string(voxel[2]) + ", expected cubic voxels");
  // A signed distance with a NaN or infinite value would poison every cut and volume.
  const float bg = grid->background();
  if (!std::isfinite(bg) || bg <= 0.f)
    throw std::invalid_argument("grid '" + base.getName() + "' has background " +
                                std::to_string(bg) + ", expected a finite half band width > 0");
  for (auto it = grid->tree().cbeginValueAll(); it; ++it)
    if (!std::isfinite(*it))
      throw std::invalid_argument("grid '" + base.getName() + "' holds a non-finite value at voxel " +
                                  std::to_string(it.getCoord().x()) + "," + std::to_string(it.getCoord().y()) +
                                  "," + std::to_string(it.getCoord().z()));
  impl->grids[i].reset();
  return wrap(grid);
}

void GridList::write_file(rust::Str path) const {
  std::lock_guard<std::mutex> lock(io_mutex);
  openvdb::io::File file{std::string(path)};
  file.write(impl->grids);
  file.close();
}


// Every grid of a .vdb file's bytes, loaded whole (no delayed loading: a corrupt leaf must fail
// here, not in a later cut). Throws on any error the reader detects.
std::unique_ptr<GridList> read_bytes(rust::Slice<const uint8_t> bytes) {
  std::lock_guard<std::mutex> lock(io_mutex);
  auto list = new_grid_list();
  BytesBuf buf(bytes.data(), bytes.size());
  std::istream is(&buf);
  is.exceptions(std::ios_base::badbit);
  openvdb::io::Stream stream(is, /*delayLoad=*/false);
  if (auto grids = stream.getGrids()) list->impl->grids = *grids;
  return list;
}

}  // namespace dentsim::vdb
