#pragma once
/// @file FuzzInput.h
/// @brief Turns a fuzzer's byte string into bounded numbers for the fuzz
/// targets: each draw consumes bytes from the front and yields 0 when they run out.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace lsdem::fuzz {

class FuzzInput {
 public:
  FuzzInput(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  /// @brief The next byte (0 when exhausted).
  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  /// @brief An integer in [lo, hi].
  int integer(int lo, int hi) { return lo + int(word() % std::uint32_t(hi - lo + 1)); }
  /// @brief A number in [lo, hi] on a grid of 2^16 steps (lo included, hi included).
  double uniform(double lo, double hi) { return lo + (hi - lo) * double(word() & 0xffff) / 65535.0; }
  /// @brief A raw double from 8 bytes (any value, NaN and Inf included).
  double raw() {
    std::uint8_t b[8] = {};
    for (std::uint8_t& x : b) x = byte();
    double v = 0.0;
    std::memcpy(&v, b, sizeof v);
    return v;
  }
  /// @brief True with probability about k / 256.
  bool chance(int k) { return byte() < k; }
  /// @brief Bytes left.
  std::size_t remaining() const { return size_ - pos_; }

 private:
  std::uint32_t word() {
    std::uint32_t w = 0;
    for (int i = 0; i < 4; ++i) w = (w << 8) | byte();
    return w;
  }

  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace lsdem::fuzz
