#pragma once
/// @file Mutate.h
/// @brief The project's own mutation driver for the fuzz targets, for builds
/// without libFuzzer (gcc, CI): deterministic mutants of a seed input.
///
/// A mutant applies 1-4 edits drawn from a seeded generator (SplitMix64), so
/// (input, seed) names the mutant exactly and a failure is reproducible
/// without the file. The edits are those that found the defects of text
/// formats (scene and mesh files) before: a flipped bit; a byte replaced by a
/// separator, quote, bracket, NUL or newline; a span deleted or duplicated; a
/// line deleted or repeated; and a number replaced by an extreme one (0, -1,
/// 1e308, -1e308, 1e-308, nan, inf, 2^32, a huge count).

#include <algorithm>
#include <array>
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace lsdem::fuzz {

/// SplitMix64: a small, fast, well-mixed generator whose whole state is one word.
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  /// @brief An integer in [0, n) (n > 0).
  std::size_t below(std::size_t n) { return std::size_t(next() % n); }

 private:
  std::uint64_t state_;
};

/// @brief FNV-1a hash of a string: a stable seed from a file name.
inline std::uint64_t stableHash(std::string_view s) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const char c : s) h = (h ^ std::uint8_t(c)) * 0x100000001b3ull;
  return h;
}

/// @brief The mutant of `input` named by `seed` (see the file comment).
inline std::vector<std::uint8_t> mutate(const std::vector<std::uint8_t>& input, std::uint64_t seed) {
  static constexpr std::array<std::string_view, 14> kNumbers = {
      "0", "-1", "1e308", "-1e308", "1e-308", "nan", "inf", "-inf", "4294967296", "1000000000", "-0.0", "1e-9",
      "3.5", "65536"};
  static constexpr std::array<char, 12> kBytes = {'\0', '\n', '"', '\'', '[', ']', '{', '}', '=', ',', '#', '.'};
  SplitMix64 rng(seed);
  std::vector<std::uint8_t> out = input;
  const std::size_t edits = 1 + rng.below(4);
  for (std::size_t e = 0; e < edits; ++e) {
    if (out.empty()) {
      out.push_back(std::uint8_t(rng.next()));
      continue;
    }
    const std::size_t at = rng.below(out.size());
    switch (rng.below(6)) {
      case 0:  // a flipped bit
        out[at] ^= std::uint8_t(1u << rng.below(8));
        break;
      case 1:  // a byte that means something to a parser
        out[at] = std::uint8_t(kBytes[rng.below(kBytes.size())]);
        break;
      case 2: {  // a span deleted
        const std::size_t n = std::min(out.size() - at, 1 + rng.below(16));
        out.erase(out.begin() + std::ptrdiff_t(at), out.begin() + std::ptrdiff_t(at + n));
        break;
      }
      case 3: {  // a span duplicated in place
        const std::size_t n = std::min(out.size() - at, 1 + rng.below(32));
        const std::vector<std::uint8_t> span(out.begin() + std::ptrdiff_t(at), out.begin() + std::ptrdiff_t(at + n));
        out.insert(out.begin() + std::ptrdiff_t(at), span.begin(), span.end());
        break;
      }
      case 4: {  // a whole line deleted or repeated
        std::size_t begin = at;
        while (begin > 0 && out[begin - 1] != '\n') --begin;
        std::size_t end = at;
        while (end < out.size() && out[end] != '\n') ++end;
        if (end < out.size()) ++end;
        if (rng.below(2) == 0) {
          out.erase(out.begin() + std::ptrdiff_t(begin), out.begin() + std::ptrdiff_t(end));
        } else {
          const std::vector<std::uint8_t> line(out.begin() + std::ptrdiff_t(begin), out.begin() + std::ptrdiff_t(end));
          out.insert(out.begin() + std::ptrdiff_t(end), line.begin(), line.end());
        }
        break;
      }
      default: {  // the next number replaced by an extreme one
        std::size_t begin = at;
        while (begin < out.size() && !std::isdigit(out[begin])) ++begin;
        if (begin == out.size()) break;
        while (begin > 0 && (std::isdigit(out[begin - 1]) || out[begin - 1] == '.' || out[begin - 1] == '-')) --begin;
        std::size_t end = begin;
        while (end < out.size() && (std::isalnum(out[end]) || out[end] == '.' || out[end] == '-' || out[end] == '+')) {
          ++end;
        }
        const std::string_view number = kNumbers[rng.below(kNumbers.size())];
        out.erase(out.begin() + std::ptrdiff_t(begin), out.begin() + std::ptrdiff_t(end));
        out.insert(out.begin() + std::ptrdiff_t(begin), number.begin(), number.end());
        break;
      }
    }
  }
  return out;
}

}  // namespace lsdem::fuzz
