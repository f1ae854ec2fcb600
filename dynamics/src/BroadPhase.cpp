#include "lsdem/dynamics/BroadPhase.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

namespace lsdem::dynamics {
namespace {

constexpr std::uint64_t kEmptySlot = ~std::uint64_t(0);  // hash table slot holding no row
constexpr std::size_t kChunk = 256;                       // cells per unit of parallel work
constexpr std::ptrdiff_t kParallelBodies = 4096;          // fewer bodies run on one thread
constexpr double kBoxSlack = 1e-12;                       // relative widening of search boxes against round-off

// Integer cell coordinate of x for cells of size 1/invH, clamped far outside any
// real domain so the conversion is defined for every finite x.
inline std::int64_t cellCoord(double x, double invH) {
  constexpr double kLimit = 4.0e18;
  const double c = std::clamp(x * invH, -kLimit, kLimit);
  // floor without a library call: truncate, then step down for negative fractions.
  const std::int64_t i = std::int64_t(c);
  return i - std::int64_t(c < double(i));
}

// A 64-bit finaliser (murmur3 fmix64): spreads neighbouring keys over the table.
inline std::uint64_t mix(std::uint64_t x) {
  x ^= x >> 33;
  x *= 0xff51afd7ed558ccdULL;
  x ^= x >> 33;
  x *= 0xc4ceb9fe1a85ec53ULL;
  x ^= x >> 33;
  return x;
}

// Hash of a row of cells (level and the K coordinates after x).
template <std::size_t K>
inline std::uint64_t rowHash(int level, const std::array<std::int64_t, K>& c) {
  std::uint64_t h = mix(std::uint64_t(level) * 0x9E3779B97F4A7C15ULL);
  for (std::size_t a = 0; a < K; ++a) h = mix(h ^ std::uint64_t(c[a]));
  return h;
}

// True when the row offset o (in y[, z]) points "forward": its last non-zero
// component is positive. Of two cells in different rows exactly one sees the
// other forward; within a row, the one with the larger x is forward.
template <std::size_t K>
inline int rowDirection(const std::array<std::int64_t, K>& o) {
  for (std::size_t a = K; a-- > 0;) {
    if (o[a] != 0) return o[a] > 0 ? 1 : -1;
  }
  return 0;
}

// Advances c through the box [lo, hi], first coordinate fastest; false after the last.
template <std::size_t K>
inline bool nextInBox(std::array<std::int64_t, K>& c, const std::array<std::int64_t, K>& lo,
                      const std::array<std::int64_t, K>& hi) {
  for (std::size_t a = 0; a < K; ++a) {
    if (c[a] < hi[a]) {
      ++c[a];
      return true;
    }
    c[a] = lo[a];
  }
  return false;
}

// Sorts a run in place: insertion sort for short or nearly sorted runs (linear
// when already sorted), std::sort for long ones.
template <class T>
inline void sortRun(T* first, T* last) {
  if (last - first > 64) {
    std::sort(first, last);
    return;
  }
  for (T* i = first + 1; i < last; ++i) {
    const T v = *i;
    T* j = i;
    for (; j > first && *(j - 1) > v; --j) *j = *(j - 1);
    *j = v;
  }
}

}  // namespace

template <int D>
BroadPhase<D>::BroadPhase(const BroadPhaseDef<D>& def) : def_(def) {
  if (!(def.skin >= 0.0) || !std::isfinite(def.skin)) {
    throw std::invalid_argument("broad phase skin must be >= 0, got " + std::to_string(def.skin));
  }
}

template <int D>
bool BroadPhase<D>::update(const std::vector<Vec<D>>& positions, const std::vector<double>& radii,
                           const std::vector<std::uint64_t>& ids) {
  validate(positions, radii, ids);
  // Keep the list while it is known to be valid.
  if (valid_ && positions.size() == builtId_.size() && !isStale(positions, radii, ids)) return false;
  rebuild(positions, radii, ids);
  return true;
}

template <int D>
void BroadPhase<D>::validate(const std::vector<Vec<D>>& positions, const std::vector<double>& radii,
                             const std::vector<std::uint64_t>& ids) const {
  // Sizes must agree and indices must fit 32 bits.
  if (positions.size() != radii.size() || positions.size() != ids.size()) {
    throw std::invalid_argument("broad phase: positions, radii and ids differ in size (" +
                                std::to_string(positions.size()) + ", " + std::to_string(radii.size()) + ", " +
                                std::to_string(ids.size()) + ")");
  }
  if (positions.size() >= std::numeric_limits<std::uint32_t>::max()) {
    throw std::invalid_argument("broad phase: too many bodies, " + std::to_string(positions.size()));
  }
  // One pass flags bad values; a second, sequential pass names the first one.
  const std::ptrdiff_t n = std::ptrdiff_t(positions.size());
  bool bad = false;
#pragma omp parallel for schedule(static) reduction(|| : bad) if (n > kParallelBodies)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    if (!positions[i].allFinite() || !(radii[i] >= 0.0) || !std::isfinite(radii[i])) bad = true;
  }
  if (!bad) return;
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    if (!positions[i].allFinite()) {
      throw std::invalid_argument("broad phase: position of body " + std::to_string(i) + " is not finite");
    }
    if (!(radii[i] >= 0.0) || !std::isfinite(radii[i])) {
      throw std::invalid_argument("broad phase: radius of body " + std::to_string(i) + " must be >= 0, got " +
                                  std::to_string(radii[i]));
    }
  }
}

template <int D>
bool BroadPhase<D>::isStale(const std::vector<Vec<D>>& positions, const std::vector<double>& radii,
                            const std::vector<std::uint64_t>& ids) const {
  // Stale when a body was replaced, or moved (plus grew) more than skin/2.
  const double halfSkin = 0.5 * skin_;
  const std::ptrdiff_t n = std::ptrdiff_t(positions.size());
  bool stale = false;
#pragma omp parallel for schedule(static) reduction(|| : stale) if (n > kParallelBodies)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    const double drift = (positions[i] - builtPosition_[i]).norm() + std::max(0.0, radii[i] - builtRadius_[i]);
    if (ids[i] != builtId_[i] || drift > halfSkin) stale = true;
  }
  return stale;
}

template <int D>
void BroadPhase<D>::rebuild(const std::vector<Vec<D>>& positions, const std::vector<double>& radii,
                            const std::vector<std::uint64_t>& ids) {
  valid_ = false;
  const std::size_t n = positions.size();

  // Resolve the skin: the user's, or 0.1 x the smallest radius.
  skin_ = def_.skin;
  if (skin_ == 0.0 && n > 0) skin_ = 0.1 * *std::min_element(radii.begin(), radii.end());

  // Bucket the bodies by cell, search the neighbourhoods, order the pairs.
  orderByIds(ids);
  assignLevels(radii);
  bucketByCell(positions, radii);
  findPairs();
  sortPairs();

  // Remember the bodies as built.
  builtPosition_.assign(positions.begin(), positions.end());
  builtRadius_.assign(radii.begin(), radii.end());
  builtId_.assign(ids.begin(), ids.end());
  valid_ = true;
  ++rebuilds_;
}

template <int D>
void BroadPhase<D>::orderByIds(const std::vector<std::uint64_t>& ids) {
  const std::size_t n = ids.size();
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), std::uint32_t(0));

  // Strictly increasing ids (no removals yet) need no sort.
  bool increasing = true;
  for (std::size_t k = 1; k < n && increasing; ++k) increasing = ids[k] > ids[k - 1];
  if (!increasing) {
    // LSD radix sort on 11-bit digits; a digit equal for all bodies is skipped.
    constexpr int kBits = 11, kPasses = 6;
    constexpr std::uint32_t kBuckets = 1u << kBits;
    histogram_.assign(std::size_t(kPasses) * kBuckets, 0);
    for (std::size_t i = 0; i < n; ++i) {
      for (int p = 0; p < kPasses; ++p) ++histogram_[p * kBuckets + ((ids[i] >> (p * kBits)) & (kBuckets - 1))];
    }
    radixTmp_.resize(n);
    for (int p = 0; p < kPasses; ++p) {
      std::uint32_t* h = histogram_.data() + std::size_t(p) * kBuckets;
      if (h[(ids[0] >> (p * kBits)) & (kBuckets - 1)] == n) continue;
      std::uint32_t sum = 0;
      for (std::uint32_t b = 0; b < kBuckets; ++b) sum += std::exchange(h[b], sum);
      for (std::size_t k = 0; k < n; ++k) {
        const std::uint32_t i = order_[k];
        radixTmp_[h[(ids[i] >> (p * kBits)) & (kBuckets - 1)]++] = i;
      }
      order_.swap(radixTmp_);
    }
    // Ids must be unique: the canonical order depends on it.
    for (std::size_t k = 1; k < n; ++k) {
      if (ids[order_[k]] == ids[order_[k - 1]]) {
        throw std::invalid_argument("broad phase: duplicate id " + std::to_string(ids[order_[k]]));
      }
    }
  }

  // Rank of each body in id order.
  rank_.resize(n);
  for (std::size_t k = 0; k < n; ++k) rank_[order_[k]] = std::uint32_t(k);
}

template <int D>
void BroadPhase<D>::assignLevels(const std::vector<double>& radii) {
  const std::size_t n = radii.size();

  // Levels halve from the largest grown diameter: level k holds diameters in
  // (maxD / 2^(k+1), maxD / 2^k]; the last level also takes everything smaller.
  double maxDiameter = 0.0;
  for (std::size_t i = 0; i < n; ++i) maxDiameter = std::max(maxDiameter, 2.0 * (radii[i] + skin_));
  std::array<double, kMaxLevels> lowerBound;  // a diameter above this fits level k
  for (int k = 0; k < kMaxLevels; ++k) {
    lowerBound[k] = k + 1 < kMaxLevels ? std::ldexp(maxDiameter, -(k + 1)) : -1.0;
    levelMaxRadius_[k] = -1.0;
  }
  level_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double R = radii[i] + skin_;
    int k = 0;
    while (!(2.0 * R > lowerBound[k])) ++k;
    level_[i] = std::uint8_t(k);
    levelMaxRadius_[k] = std::max(levelMaxRadius_[k], R);
  }

  // Cell size of a level: its largest grown diameter, so cells are as small as
  // the level allows (a positive size even for bodies of zero size).
  occupiedLevels_.clear();
  for (int k = 0; k < kMaxLevels; ++k) {
    if (levelMaxRadius_[k] < 0.0) continue;
    occupiedLevels_.push_back(k);
    double h = 2.0 * levelMaxRadius_[k];
    if (!(h > 0.0)) h = maxDiameter > 0.0 ? std::ldexp(maxDiameter, -kMaxLevels) : 1.0;
    h = std::max(h, 4.0 * std::numeric_limits<double>::min());  // 1/h stays finite
    cellSize_[k] = h;
    invCellSize_[k] = 1.0 / h;
  }
}

template <int D>
std::int64_t BroadPhase<D>::findRow(int level, const RowCoord& coord) const {
  const std::uint64_t h = rowHash(level, coord);
  const std::uint64_t tag = h >> 32;
  const std::size_t mask = rowTable_.size() - 1;
  for (std::size_t slot = h & mask;; slot = (slot + 1) & mask) {
    const std::uint64_t entry = rowTable_[slot];
    if (entry == kEmptySlot) return -1;
    if (entry >> 32 != tag) continue;
    const Row& row = rows_[std::uint32_t(entry)];
    if (row.level == level && row.coord == coord) return std::uint32_t(entry);
  }
}

template <int D>
std::uint32_t BroadPhase<D>::insertRow(int level, const RowCoord& coord) {
  // Find the row, or claim the empty slot that ends the probe.
  const std::uint64_t h = rowHash(level, coord);
  const std::uint64_t tag = h >> 32;
  std::size_t mask = rowTable_.size() - 1;
  std::size_t slot = h & mask;
  for (;; slot = (slot + 1) & mask) {
    const std::uint64_t entry = rowTable_[slot];
    if (entry == kEmptySlot) break;
    if (entry >> 32 == tag && rows_[std::uint32_t(entry)].level == level && rows_[std::uint32_t(entry)].coord == coord) {
      return std::uint32_t(entry);
    }
  }
  const std::uint32_t row = std::uint32_t(rows_.size());
  rows_.push_back({coord, level, 0});
  rowTable_[slot] = tag << 32 | row;

  // Keep the load at most 1/2: double the table and re-insert every row.
  if (2 * rows_.size() > rowTable_.size()) {
    rowTable_.assign(2 * rowTable_.size(), kEmptySlot);
    mask = rowTable_.size() - 1;
    for (std::uint32_t r = 0; r < rows_.size(); ++r) {
      const std::uint64_t hr = rowHash(rows_[r].level, rows_[r].coord);
      std::size_t s = hr & mask;
      while (rowTable_[s] != kEmptySlot) s = (s + 1) & mask;
      rowTable_[s] = (hr >> 32) << 32 | r;
    }
  }
  return row;
}

template <int D>
void BroadPhase<D>::bucketByCell(const std::vector<Vec<D>>& positions, const std::vector<double>& radii) {
  const std::size_t n = positions.size();

  // Rows by hashing (level, y[, z]); count the bodies of each row.
  std::size_t capacity = 64;  // reuse the last size, up to 2 slots per body
  while (capacity < rowTable_.size() && capacity < 2 * n) capacity *= 2;
  rowTable_.assign(capacity, kEmptySlot);
  rows_.clear();
  rowStart_.assign(1, 0);
  rowOf_.resize(n);
  cellX_.resize(n);
  int lastLevel = -1;
  RowCoord lastRow{};
  std::uint32_t lastRowNumber = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const int L = level_[i];
    RowCoord rc;
    for (int a = 1; a < D; ++a) rc[a - 1] = cellCoord(positions[i][a], invCellSize_[L]);
    cellX_[i] = cellCoord(positions[i][0], invCellSize_[L]);
    // Bodies stored next to each other often share a row: skip the hash then.
    if (L != lastLevel || rc != lastRow) {
      lastRowNumber = insertRow(L, rc);
      lastLevel = L;
      lastRow = rc;
    }
    rowOf_[i] = lastRowNumber;
    if (rowStart_.size() < rows_.size() + 1) rowStart_.push_back(0);  // a new row
    ++rowStart_[rowOf_[i] + 1];
  }
  const std::size_t nRows = rows_.size();
  rowStart_.resize(nRows + 1);
  rowStart_[0] = 0;
  for (std::size_t r = 0; r < nRows; ++r) rowStart_[r + 1] += rowStart_[r];

  // Group the bodies by row (counting sort), then sort each row by x (ties in
  // storage order: (x, index) pairs are unique).
  rowOrder_.resize(n);
  rowFill_.assign(rowStart_.begin(), rowStart_.end() - 1);
  for (std::size_t i = 0; i < n; ++i) rowOrder_[rowFill_[rowOf_[i]]++] = {cellX_[i], std::uint32_t(i)};
  const std::ptrdiff_t nRowsSigned = std::ptrdiff_t(nRows);
#pragma omp parallel for schedule(dynamic, 64) if (std::ptrdiff_t(n) > kParallelBodies)
  for (std::ptrdiff_t r = 0; r < nRowsSigned; ++r) {
    sortRun(rowOrder_.data() + rowStart_[r], rowOrder_.data() + rowStart_[r + 1]);
  }

  // Cells: runs of equal x within a row.
  cells_.clear();
  for (std::size_t r = 0; r < nRows; ++r) {
    rows_[r].cellBegin = std::uint32_t(cells_.size());
    for (std::uint32_t k = rowStart_[r]; k < rowStart_[r + 1]; ++k) {
      if (k == rowStart_[r] || rowOrder_[k].first != rowOrder_[k - 1].first) {
        cells_.push_back({rowOrder_[k].first, std::uint32_t(r), k});
      }
    }
  }
  rows_.push_back({RowCoord{}, -1, std::uint32_t(cells_.size())});
  cells_.push_back({0, std::uint32_t(nRows), std::uint32_t(n)});

  // Body data in cell order.
  sortedPosition_.resize(n);
  sortedRadius_.resize(n);
  sortedRank_.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t i = rowOrder_[k].second;
    sortedPosition_[k] = positions[i];
    sortedRadius_[k] = radii[i] + skin_;
    sortedRank_[k] = rank_[i];
  }
}

// Rows looked up for the previous cell of a chunk, per level: consecutive cells
// of a row search the same rows, so each row is hashed about once per row, and
// the cells to start from are found by stepping from the previous ones instead
// of bisecting again.
template <int D>
struct BroadPhase<D>::RowCache {
  static constexpr int kSize = D == 2 ? 4 : 16;  // rows in a box of up to 4 cells per axis
  static constexpr std::int64_t kNotLookedUp = -2;
  struct Entry {
    bool valid = false;
    RowCoord lo{}, hi{};
    std::array<std::int64_t, kSize> row{};      // row number, -1 (none) or kNotLookedUp
    std::array<std::uint32_t, kSize> cursor{};  // first cell searched last time
  };
  std::array<Entry, kMaxLevels> level;
};

template <int D>
void BroadPhase<D>::findPairs() {
  const std::size_t nCells = cells_.size() - 1;
  const std::size_t chunks = (nCells + kChunk - 1) / kChunk;
  if (chunkPairs_.size() < chunks) chunkPairs_.resize(chunks);

  // Each chunk of cells searches its neighbourhoods into its own buffer.
  const std::ptrdiff_t nChunks = std::ptrdiff_t(chunks);
  [[maybe_unused]] const bool parallel = nChunks > 1 && std::ptrdiff_t(sortedPosition_.size()) > kParallelBodies;
#pragma omp parallel for schedule(dynamic, 1) if (parallel)
  for (std::ptrdiff_t chunk = 0; chunk < nChunks; ++chunk) {
    std::vector<std::uint64_t>& out = chunkPairs_[chunk];
    out.clear();
    RowCache cache;
    const std::size_t end = std::min(nCells, std::size_t(chunk + 1) * kChunk);
    for (std::size_t cell = std::size_t(chunk) * kChunk; cell < end; ++cell) searchCell(cell, cache, out);
  }
}

template <int D>
void BroadPhase<D>::searchCell(std::size_t cell, RowCache& cache, std::vector<std::uint64_t>& out) const {
  const Cell* cells = cells_.data();
  const Vec<D>* position = sortedPosition_.data();
  const double* radius = sortedRadius_.data();
  const std::uint32_t* rank = sortedRank_.data();
  const Cell& A = cells[cell];
  const Row& rowA = rows_[A.row];
  const std::uint32_t a0 = A.bodyBegin, a1 = cells[cell + 1].bodyBegin;
  const int own = rowA.level;

  // Sphere test of every body s of this cell against bodies [t0, t1) (only t > s
  // for this cell itself); hits are stored by rank. The test:
  // |x_t - x_s|^2 < (R_s + R_t)^2, R grown by the skin.
  auto testRange = [&](std::uint32_t t0, std::uint32_t t1, bool ownCell) {
    for (std::uint32_t s = a0; s < a1; ++s) {
      const Vec<D> xs = position[s];
      const double Rs = radius[s];
      const std::uint64_t rs = rank[s];
      for (std::uint32_t t = ownCell ? s + 1 : t0; t < t1; ++t) {
        const double sumR = Rs + radius[t];
        if ((position[t] - xs).squaredNorm() < sumR * sumR) {
          const std::uint64_t rt = rank[t];
          out.push_back(rs < rt ? rs << 32 | rt : rt << 32 | rs);
        }
      }
    }
  };

  // Pairs inside the cell.
  testRange(a0, a1, true);

  // Searches level L: the union of the bodies' boxes, each reaching R + Rmax_L
  // (partners' centroids lie within), row by row. In the own level only cells
  // forward of this one are searched, so each pair of cells is met once.
  auto searchLevel = [&](int L) {
    const double invH = invCellSize_[L], Rmax = levelMaxRadius_[L];
    std::int64_t xLo = std::numeric_limits<std::int64_t>::max(), xHi = std::numeric_limits<std::int64_t>::min();
    RowCoord lo, hi;
    lo.fill(std::numeric_limits<std::int64_t>::max());
    hi.fill(std::numeric_limits<std::int64_t>::min());
    for (std::uint32_t s = a0; s < a1; ++s) {
      const Vec<D>& x = position[s];
      const double reach = (radius[s] + Rmax) * (1.0 + kBoxSlack);
      xLo = std::min(xLo, cellCoord(x[0] - reach, invH));
      xHi = std::max(xHi, cellCoord(x[0] + reach, invH));
      for (int a = 1; a < D; ++a) {
        lo[a - 1] = std::min(lo[a - 1], cellCoord(x[a] - reach, invH));
        hi[a - 1] = std::max(hi[a - 1], cellCoord(x[a] + reach, invH));
      }
    }

    // The rows of the box; the cache holds them when the previous cell had the same box.
    typename RowCache::Entry& entry = cache.level[L];
    std::size_t boxRows = 1;
    for (int a = 0; a + 1 < D; ++a) boxRows *= std::size_t(hi[a] - lo[a]) + 1;
    const bool cacheable = boxRows <= std::size_t(RowCache::kSize);
    const bool cached = cacheable && entry.valid && entry.lo == lo && entry.hi == hi;
    if (cacheable && !cached) {
      entry.valid = true;
      entry.lo = lo;
      entry.hi = hi;
      entry.row.fill(RowCache::kNotLookedUp);
    }
    RowCoord rc = lo;
    std::size_t k = 0;
    do {
      const std::size_t slot = k++;
      // Which cells of this row to search: x in [from, xHi].
      std::int64_t from = xLo;
      if (L == own) {
        RowCoord offset;
        for (int a = 0; a + 1 < D; ++a) offset[a] = rc[a] - rowA.coord[a];
        const int direction = rowDirection(offset);
        if (direction < 0) continue;
        if (direction == 0) from = std::max(xLo, A.x + 1);
      }
      // The row, and the first cell with x >= from: stepped from the cached
      // cursor, or by bisection.
      const bool hit = cacheable && entry.row[slot] != RowCache::kNotLookedUp;
      const std::int64_t r = hit ? entry.row[slot] : findRow(L, rc);
      if (cacheable) entry.row[slot] = r;
      if (r < 0) continue;
      const std::uint32_t rowBegin = rows_[r].cellBegin, rowEnd = rows_[r + 1].cellBegin;
      std::uint32_t b;
      if (hit) {
        b = entry.cursor[slot];
        while (b > rowBegin && cells[b - 1].x >= from) --b;
        while (b < rowEnd && cells[b].x < from) ++b;
      } else {
        b = std::uint32_t(std::lower_bound(cells + rowBegin, cells + rowEnd, from,
                                           [](const Cell& c, std::int64_t x) { return c.x < x; }) -
                          cells);
      }
      if (cacheable) entry.cursor[slot] = b;
      // Test the bodies of those cells (they are contiguous).
      std::uint32_t bEnd = b;
      while (bEnd < rowEnd && cells[bEnd].x <= xHi) ++bEnd;
      if (bEnd > b) testRange(cells[b].bodyBegin, cells[bEnd].bodyBegin, false);
    } while (nextInBox(rc, lo, hi));
  };

  // Own level, then the coarser levels (pairs across levels are met only from
  // the smaller body's side).
  searchLevel(own);
  for (const int L : occupiedLevels_) {
    if (L >= own) break;
    searchLevel(L);
  }
}

template <int D>
void BroadPhase<D>::sortPairs() {
  const std::size_t n = order_.size();
  const std::size_t chunks = (cells_.size() - 1 + kChunk - 1) / kChunk;

  // Counting sort of the pairs by the rank of their lower id.
  pairStart_.assign(n + 1, 0);
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
    for (const std::uint64_t p : chunkPairs_[chunk]) ++pairStart_[(p >> 32) + 1];
  }
  for (std::size_t r = 0; r < n; ++r) pairStart_[r + 1] += pairStart_[r];
  const std::size_t m = pairStart_[n];
  pairFill_.assign(pairStart_.begin(), pairStart_.end() - 1);
  partner_.resize(m);
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
    for (const std::uint64_t p : chunkPairs_[chunk]) partner_[pairFill_[p >> 32]++] = std::uint32_t(p);
  }

  // Partners of each body in rank order, then ranks back to body indices.
  pairs_.resize(m);
  const std::ptrdiff_t nBodies = std::ptrdiff_t(n);
#pragma omp parallel for schedule(static) if (nBodies > kParallelBodies)
  for (std::ptrdiff_t r = 0; r < nBodies; ++r) {
    const std::size_t first = pairStart_[r], last = pairStart_[r + 1];
    sortRun(partner_.data() + first, partner_.data() + last);
    for (std::size_t k = first; k < last; ++k) pairs_[k] = {order_[r], order_[partner_[k]]};
  }
}

template class BroadPhase<2>;
template class BroadPhase<3>;

}  // namespace lsdem::dynamics
