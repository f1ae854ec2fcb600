#pragma once
/// @file State.h
/// @brief A byte archive for the state of a world between steps (checkpoints).
///
/// The world, its contact solver and its effects write their state into a
/// StateWriter and read it back from a StateReader in the same order. Values
/// are copied byte for byte (native little-endian doubles), so a restored world
/// continues bit for bit like the one that was saved. The archive is memory
/// only: io/ writes it to disk (DESIGN: only io reads or writes files).
///
/// Only plain values go through put()/get(): arithmetic types, enums and
/// fixed-size Eigen vectors, matrices and quaternions (arrays of doubles), and
/// structs made of those without implicit padding (a struct that would have
/// some declares zeroed bytes in its place, as NodeContact does, and asserts
/// its size): padding would carry whatever memory held, and two saves of one
/// state would differ. Apart from the wall-clock values (putWallClock), two
/// worlds in the same state write the same bytes.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::dynamics {

class StateWriter {
 public:
  /// @brief Appends the bytes of one plain value.
  template <class T>
  void put(const T& value) {
    const auto* p = reinterpret_cast<const char*>(&value);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  /// @brief Appends a count and the elements of a vector of plain values.
  template <class T, class A>
  void putVector(const std::vector<T, A>& values) {
    put(std::uint64_t(values.size()));
    const auto* p = reinterpret_cast<const char*>(values.data());
    bytes_.insert(bytes_.end(), p, p + values.size() * sizeof(T));
  }
  void putString(const std::string& s) {
    put(std::uint64_t(s.size()));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
  }
  /// @brief Writes a tag that the reader checks, so a misaligned archive fails loudly.
  void putTag(const char* tag) { putString(tag); }
  /// @brief Appends a wall-clock value (World's stage times): the only bytes
  /// of a state that differ between two runs that reach the same state. With
  /// setWallClock(false) they are written as zeros, so two such states compare
  /// byte for byte (the reader reads them as usual).
  template <class T>
  void putWallClock(const T& value) {
    if (wallClock_) {
      put(value);
    } else {
      bytes_.insert(bytes_.end(), sizeof(T), '\0');
    }
  }
  template <class T>
  void putWallClockVector(const std::vector<T>& values) {
    if (wallClock_) {
      putVector(values);
    } else {
      put(std::uint64_t(values.size()));
      bytes_.insert(bytes_.end(), values.size() * sizeof(T), '\0');
    }
  }
  void setWallClock(bool on) { wallClock_ = on; }

  const std::vector<char>& bytes() const { return bytes_; }

 private:
  std::vector<char> bytes_;
  bool wallClock_ = true;
};

class StateReader {
 public:
  StateReader(const char* data, std::size_t size) : data_(data), size_(size) {}

  template <class T>
  T get() {
    T value;
    std::memcpy(reinterpret_cast<char*>(&value), take(sizeof(T)), sizeof(T));
    return value;
  }
  template <class T, class A>
  void getVector(std::vector<T, A>& values) {
    const std::uint64_t n = get<std::uint64_t>();
    if (n > (size_ - pos_) / (sizeof(T) ? sizeof(T) : 1)) fail("vector of " + std::to_string(n) + " elements");
    values.resize(std::size_t(n));
    std::memcpy(reinterpret_cast<char*>(values.data()), take(std::size_t(n) * sizeof(T)), std::size_t(n) * sizeof(T));
  }
  std::string getString() {
    const std::uint64_t n = get<std::uint64_t>();
    if (n > size_ - pos_) fail("string of " + std::to_string(n) + " bytes");
    const char* p = take(std::size_t(n));
    return std::string(p, p + n);
  }
  /// @brief Reads a tag and checks it (throws std::runtime_error when it differs).
  void expectTag(const char* tag) {
    const std::string got = getString();
    if (got != tag) fail(std::string("section '") + tag + "', found '" + got + "'");
  }
  /// @brief Reads a tag that must be one of `tags` and returns its index
  /// (throws std::runtime_error when it is none of them): a section read in
  /// its current version and the earlier ones.
  std::size_t expectTag(std::initializer_list<const char*> tags) {
    const std::string got = getString();
    std::size_t k = 0;
    std::string names;
    for (const char* tag : tags) {
      if (got == tag) return k;
      names += (k++ == 0 ? "'" : " or '") + std::string(tag) + "'";
    }
    fail("section " + names + ", found '" + got + "'");
  }
  bool atEnd() const { return pos_ == size_; }

 private:
  const char* take(std::size_t n) {
    if (n > size_ - pos_) fail(std::to_string(n) + " more bytes");
    const char* p = data_ + pos_;
    pos_ += n;
    return p;
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("checkpoint state is truncated or corrupt: expected " + what + " at byte " +
                             std::to_string(pos_));
  }

  const char* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace lsdem::dynamics
