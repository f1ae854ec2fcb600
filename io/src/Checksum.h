#pragma once
/// @file Checksum.h
/// @brief CRC-32 (zlib) of byte ranges of any length, as checkpoints and
/// binary grain files close with (internal to io).

#include <zlib.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>

namespace lsdem::io {

/// A running CRC-32: add() bytes in any pieces, value() of all added so far.
class Crc32 {
 public:
  void add(const char* data, std::size_t size) {
    while (size > 0) {  // zlib takes a uInt length
      const std::size_t n = std::min<std::size_t>(size, std::size_t(1) << 30);
      crc_ = crc32(crc_, reinterpret_cast<const Bytef*>(data), uInt(n));
      data += n;
      size -= n;
    }
  }
  std::uint32_t value() const { return std::uint32_t(crc_); }

 private:
  uLong crc_ = crc32(0L, Z_NULL, 0);
};

/// The CRC-32 of one byte range.
inline std::uint32_t crc32Of(const char* data, std::size_t size) {
  Crc32 c;
  c.add(data, size);
  return c.value();
}

}  // namespace lsdem::io
