// dentsim-vdb-reader: parses one .vdb file's bytes with OpenVDB in a process of its own, so that a
// corrupt file can crash it, overflow a buffer in it or ask it for gigabytes without harm to the
// caller (crates/vdb/src/reader_process.rs starts it; DESIGN.md "Reading a .vdb someone else
// wrote"). A fresh process, not a fork: a fork of a threaded caller copies locks and TBB state
// mid-use and could wait forever.
//
//   dentsim-vdb-reader MAX_BYTES   stdin: the file's bytes (a seekable file, read from byte 0)
//                                  stdout: a seekable file the grids are written to, uncompressed
//                                  stderr: why it failed (one message), nothing else
// Exit 0: the grids are in stdout. Exit 1: stderr says why. A crash dies of its signal; the
// address-space cap (its size once the bytes are in + MAX_BYTES) ends a wild allocation.
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <istream>
#include <new>
#include <stdexcept>
#include <streambuf>
#include <string>
#include <vector>

#include "bytes_buf.h"

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

namespace {

using dentsim::vdb::BytesBuf;

int message_fd = -1;

[[noreturn]] void fail(std::string msg) {
  if (msg.empty()) msg = "OpenVDB could not read it";
  if (msg.size() > 4096) msg.resize(4096);
  size_t done = 0;
  while (done < msg.size()) {
    const ssize_t n = write(message_fd, msg.data() + done, msg.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    done += size_t(n);
  }
  _exit(1);
}

std::vector<char> read_input() {
  struct stat st {};
  if (fstat(STDIN_FILENO, &st) != 0 || st.st_size <= 0) fail("OpenVDB's reader got no bytes to read");
  std::vector<char> bytes(size_t(st.st_size));
  off_t at = 0;
  while (at < st.st_size) {
    const ssize_t n = pread(STDIN_FILENO, bytes.data() + at, size_t(st.st_size - at), at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail(std::string("OpenVDB's reader could not read its input: ") + std::strerror(errno));
    at += n;
  }
  return bytes;
}

}  // namespace

int main(int argc, char** argv) {
  // A crash must end this process (the caller turns the signal into an error), and never with a
  // core dump; signals the caller ignored stay ignored across exec otherwise.
  for (int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL, SIGPIPE}) signal(sig, SIG_DFL);
  struct rlimit no_core {0, 0};
  setrlimit(RLIMIT_CORE, &no_core);
  // The message goes to the caller's pipe; glibc's and OpenVDB's noise goes nowhere.
  message_fd = fcntl(STDERR_FILENO, F_DUPFD_CLOEXEC, 3);
  const int devnull = open("/dev/null", O_WRONLY | O_CLOEXEC);
  if (devnull >= 0) dup2(devnull, STDERR_FILENO);
  char* end = nullptr;
  const unsigned long long max_bytes = argc == 2 ? std::strtoull(argv[1], &end, 10) : 0;
  if (argc != 2 || !end || *end != '\0' || max_bytes == 0) fail("usage: dentsim-vdb-reader MAX_BYTES");

  std::vector<char> bytes = read_input();
  openvdb::initialize();
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
  try {
    // No delayed loading: a corrupt leaf must fail here, not in a later cut.
    BytesBuf buf(bytes.data(), bytes.size());
    std::istream is(&buf);
    is.exceptions(std::ios_base::badbit);
    openvdb::io::Stream in(is, /*delayLoad=*/false);
    openvdb::GridPtrVecPtr grids = in.getGrids();
    if (!grids) grids = std::make_shared<openvdb::GridPtrVec>();
    std::ofstream out("/proc/self/fd/1", std::ios::binary | std::ios::trunc);
    openvdb::io::Stream stream(out);
    stream.setCompression(openvdb::io::COMPRESS_NONE);
    stream.setGridStatsMetadataEnabled(false);  // the caller does not need them: time saved
    stream.write(*grids);
    out.close();
    if (!out) throw std::runtime_error("could not hand the grids back (out of memory?)");
  } catch (const std::bad_alloc&) {
    fail("reading it asks for more than " + std::to_string(max_bytes >> 20) +
         " MiB of memory (corrupt sizes, or over the memory limit)");
  } catch (const std::exception& e) {
    fail(e.what());
  } catch (...) {
    fail("OpenVDB could not read it");
  }
  // The trees are freed with the process: destroying them first would only cost time.
  _exit(0);
}
