// .vdb files holding several named grids with their metadata.
#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <istream>
#include <mutex>
#include <stdexcept>
#include <streambuf>

#include "impl.h"

#if defined(__SANITIZE_ADDRESS__)
#define DENTSIM_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define DENTSIM_ASAN 1
#endif
#endif
#ifndef DENTSIM_ASAN
#define DENTSIM_ASAN 0
#endif

// Set by a sanitizer runtime (libFuzzer writes its crash file from it); weak so plain builds link.
extern "C" void __sanitizer_set_death_callback(void (*callback)(void)) __attribute__((weak));

namespace dentsim::vdb {

// OpenVDB's file I/O takes its type registries' locks. A fork copies only the forking thread, so
// a lock another thread held at that moment would stay locked in the child forever: every file
// read and write here, and every fork, holds this one mutex.
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

// An istream over borrowed bytes (no copy), seekable as OpenVDB's reader may ask.
namespace {
struct BytesBuf : std::streambuf {
  BytesBuf(const uint8_t* data, size_t size) {
    char* p = const_cast<char*>(reinterpret_cast<const char*>(data));
    setg(p, p, p + size);
  }
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override {
    off_type base = dir == std::ios_base::beg ? 0 : dir == std::ios_base::cur ? gptr() - eback() : egptr() - eback();
    return seekpos(pos_type(base + off), std::ios_base::in);
  }
  pos_type seekpos(pos_type pos, std::ios_base::openmode) override {
    if (off_type(pos) < 0 || off_type(pos) > egptr() - eback()) return pos_type(off_type(-1));
    setg(eback(), eback() + off_type(pos), egptr());
    return pos;
  }
};
}  // namespace

static std::unique_ptr<GridList> read_bytes_locked(rust::Slice<const uint8_t> bytes);

// Every grid of a .vdb file's bytes, loaded whole (no delayed loading: a corrupt leaf must fail
// here, not in a later cut). Throws on any error the reader detects.
std::unique_ptr<GridList> read_bytes(rust::Slice<const uint8_t> bytes) {
  std::lock_guard<std::mutex> lock(io_mutex);
  return read_bytes_locked(bytes);
}

static std::unique_ptr<GridList> read_bytes_locked(rust::Slice<const uint8_t> bytes) {
  auto list = new_grid_list();
  BytesBuf buf(bytes.data(), bytes.size());
  std::istream is(&buf);
  is.exceptions(std::ios_base::badbit);
  openvdb::io::Stream stream(is, /*delayLoad=*/false);
  if (auto grids = stream.getGrids()) list->impl->grids = *grids;
  return list;
}

// OpenVDB's reader trusts its input: some corrupt compressed data crashes it (SIGSEGV, double
// free), overflows a heap buffer without crashing (bloscFromStream reads a chunk's stated size
// before checking it), or asks for absurd memory. So only a forked child parses the file's bytes,
// its address space capped at its current size + max_bytes, with a deadline; it writes the grids
// it read back out with OpenVDB's writer (uncompressed) into `clean`, which is all this process
// then parses. Returns "" when the child succeeded, else why not.
rust::String probe_read(rust::Slice<const uint8_t> bytes, uint64_t max_bytes, uint32_t timeout_ms,
                        std::vector<uint8_t>& clean) {
  ensure_initialized();
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  const int out_fd = memfd_create("dentsim-vdb-read", MFD_CLOEXEC);
  if (out_fd < 0) {
    close(fds[0]);
    close(fds[1]);
    throw std::runtime_error(std::string("memfd_create: ") + std::strerror(errno));
  }
  std::unique_lock<std::mutex> lock(io_mutex);
  const pid_t pid = fork();
  if (pid != 0) {
    // Closed before another thread may fork: a later probe's child would inherit this write
    // end, and this read's end of file would wait for that child too.
    close(fds[1]);
    lock.unlock();  // the child leaves it: it never takes it again
  }
  if (pid < 0) {
    close(fds[0]);
    close(out_fd);
    throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  }
  if (pid == 0) {
    close(fds[0]);
    // A crash must end the child: not the host's handlers (ParaView's, a fuzzer's) inherited.
    for (int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL}) signal(sig, SIG_DFL);
    if (__sanitizer_set_death_callback) __sanitizer_set_death_callback(nullptr);
    // No core dumps, and no glibc/OpenVDB noise on the user's terminal.
    struct rlimit no_core {0, 0};
    setrlimit(RLIMIT_CORE, &no_core);
    int devnull = open("/dev/null", O_WRONLY);
    if (devnull >= 0) dup2(devnull, STDERR_FILENO);
#if !DENTSIM_ASAN
    // ASan reserves terabytes of shadow address space; a cap would break it.
    long pages = 0;
    if (FILE* f = std::fopen("/proc/self/statm", "r")) {
      if (std::fscanf(f, "%ld", &pages) != 1) pages = 0;
      std::fclose(f);
    }
    const uint64_t now = uint64_t(pages) * uint64_t(sysconf(_SC_PAGESIZE));
    struct rlimit cap {rlim_t(now + max_bytes), rlim_t(now + max_bytes)};
    if (pages > 0) setrlimit(RLIMIT_AS, &cap);
#endif
    std::string msg;
    try {
      auto list = read_bytes_locked(bytes);
      std::ofstream out("/proc/self/fd/" + std::to_string(out_fd), std::ios::binary | std::ios::trunc);
      openvdb::io::Stream stream(out);
      stream.setCompression(openvdb::io::COMPRESS_NONE);
      stream.setGridStatsMetadataEnabled(false);  // its statistics would run TBB in the child
      stream.write(list->impl->grids);
      out.close();
      if (!out) throw std::runtime_error("could not hand the grids back (out of memory?)");
      // Never destroy a tree here: ~Tree runs a TBB parallel_for, and TBB's state copied from a
      // threaded parent can wait forever. _exit frees everything.
      list.release();
    } catch (const std::bad_alloc&) {
      msg = "reading it asks for more than " + std::to_string(max_bytes >> 20) + " MiB of memory (corrupt sizes, or over the memory limit)";
    } catch (const std::exception& e) {
      msg = e.what();
      if (msg.empty()) msg = "OpenVDB could not read it";
    } catch (...) {
      msg = "OpenVDB could not read it";
    }
    if (msg.size() > 4096) msg.resize(4096);
    size_t done = 0;
    while (done < msg.size()) {
      ssize_t n = write(fds[1], msg.data() + done, msg.size() - done);
      if (n <= 0) break;
      done += size_t(n);
    }
    _exit(msg.empty() ? 0 : 1);
  }
  std::string msg;
  bool timed_out = false;
  int status = 0;
  bool reaped = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  // Ends at the pipe's end of file or at the child's exit, whichever comes first: a process
  // forked elsewhere (not under io_mutex) may hold a copy of the write end until it execs.
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) {
      timed_out = true;
      break;
    }
    struct pollfd p {fds[0], POLLIN, 0};
    const int r = poll(&p, 1, int(std::min<long long>(left, 20)));
    if (r < 0 && errno == EINTR) continue;
    if (r == 0) {
      if (waitpid(pid, &status, WNOHANG) == pid) {
        reaped = true;
        // What the child wrote before it exited is in the pipe already.
        char chunk[1024];
        while (poll(&p, 1, 0) > 0) {
          const ssize_t n = read(fds[0], chunk, sizeof chunk);
          if (n <= 0) break;
          if (msg.size() < 4096) msg.append(chunk, size_t(n));
        }
        break;
      }
      continue;
    }
    if (r < 0) continue;
    char chunk[1024];
    const ssize_t n = read(fds[0], chunk, sizeof chunk);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // EOF: the child has exited (or closed the pipe)
    if (msg.size() < 4096) msg.append(chunk, size_t(n));
  }
  close(fds[0]);
  if (timed_out) kill(pid, SIGKILL);
  while (!reaped && waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timed_out || WIFSIGNALED(status)) close(out_fd);
  if (timed_out)
    return rust::String("OpenVDB's reader did not finish within " + std::to_string(timeout_ms / 1000) +
                        " s (corrupt file?)");
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    if (sig == SIGKILL)  // the kernel's OOM killer, or the cap hit outside an allocation
      return rust::String("reading it asks for more than " + std::to_string(max_bytes >> 20) + " MiB of memory (corrupt sizes, or over the memory limit)");
    return rust::String(std::string("OpenVDB's reader crashed on it (signal ") + std::to_string(sig) + ", " +
                        strsignal(sig) + "): the file is corrupt");
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
    struct stat st {};
    if (fstat(out_fd, &st) != 0 || st.st_size <= 0) {
      close(out_fd);
      return rust::String("OpenVDB's reader handed nothing back");
    }
    clean.resize(size_t(st.st_size));
    off_t at = 0;
    while (at < st.st_size) {
      const ssize_t n = pread(out_fd, clean.data() + at, size_t(st.st_size - at), at);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      at += n;
    }
    close(out_fd);
    if (at != st.st_size) return rust::String("could not read back the grids OpenVDB's reader handed back");
    return rust::String();
  }
  close(out_fd);
  if (msg.empty()) msg = "OpenVDB's reader failed (exit status " + std::to_string(WEXITSTATUS(status)) + ")";
  return rust::String(msg);
}

}  // namespace dentsim::vdb
