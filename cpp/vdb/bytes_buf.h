// An istream buffer over borrowed bytes: the library's parse of the reader's output and the
// reader process's parse of a file both hand OpenVDB bytes already in memory.
#pragma once

#include <cstddef>
#include <ios>
#include <streambuf>

namespace dentsim::vdb {

// No copy; seekable as OpenVDB's reader may ask.
struct BytesBuf : std::streambuf {
  BytesBuf(const void* data, size_t size) {
    char* p = const_cast<char*>(static_cast<const char*>(data));
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

}  // namespace dentsim::vdb
