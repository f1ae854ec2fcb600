#pragma once
/// @file Grid.h
/// @brief The discrete level set (eq. 1): a dense regular grid of float values
/// with an origin and a uniform spacing, in 2D or 3D.
///
/// Rationale: LS-DEM reads a particle's level set once per surface node of every
/// neighbour per step, so the grid is a flat `std::vector<float>` (x fastest) and
/// the value/gradient look-ups are inline here. Floats halve the memory of a
/// shape against doubles and are accurate to ~1e-7 of the grid size, far below
/// the interpolation error; all arithmetic on them is done in double.
///
/// Frames: node (i, j, k) sits at world position origin + spacing * (i, j, k).
/// "Grid coordinates" are continuous node coordinates in cells.

#include "lsdem/geometry/Types.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#ifdef __SSE2__
#include <emmintrin.h>
#endif

namespace lsdem::geometry {

/// Cells of padding around a shape on every side of a new grid. Four cells keep
/// the border at phi >= 4h, outside the widest smoothed-Heaviside band the mass
/// properties use (3 cells), so no mass is cut off at the border.
inline constexpr int kDefaultPaddingCells = 4;

template <int D>
class Grid {
 public:
  static_assert(D == 2 || D == 3, "lsdem grids are 2D or 3D");

  Grid() = default;
  /// @brief A grid of `dims` nodes per axis, node 0 at `origin` (world units),
  /// `spacing` world units between nodes, every value set to `fill`.
  /// @note dims >= 2 on every axis and spacing > 0; throws std::invalid_argument otherwise.
  Grid(const Index<D>& dims, const Vec<D>& origin, double spacing, float fill = 0.0f);

  /// @brief The smallest grid with spacing `spacing` whose nodes cover `box`
  /// grown by `paddingCells` cells on every side, values set to `fill`.
  static Grid covering(const Box<D>& box, double spacing, int paddingCells, float fill = 0.0f);

  const Index<D>& dims() const { return dims_; }
  const Vec<D>& origin() const { return origin_; }
  double spacing() const { return spacing_; }
  std::size_t size() const { return values_.size(); }
  /// @brief Bytes held by the values.
  std::size_t bytes() const { return values_.size() * sizeof(float); }
  std::vector<float>& values() { return values_; }
  const std::vector<float>& values() const { return values_; }
  bool empty() const { return values_.empty(); }

  /// @brief Linear offset of node `i` (x fastest).
  std::size_t linear(const Index<D>& i) const {
    if constexpr (D == 2) {
      return std::size_t(i[0]) + std::size_t(dims_[0]) * std::size_t(i[1]);
    } else {
      return std::size_t(i[0]) + std::size_t(dims_[0]) * (std::size_t(i[1]) + std::size_t(dims_[1]) * std::size_t(i[2]));
    }
  }
  /// @brief Steps node index `i` to the next node in linear order (x fastest):
  /// unlinear(n + 1) from i = unlinear(n) without divisions.
  void advance(Index<D>& i) const {
    for (int a = 0; a < D; ++a) {
      if (++i[a] < dims_[a]) return;
      i[a] = 0;
    }
  }
  /// @brief Node index of linear offset `n`.
  Index<D> unlinear(std::size_t n) const {
    Index<D> i;
    for (int a = 0; a < D; ++a) {
      i[a] = int(n % std::size_t(dims_[a]));
      n /= std::size_t(dims_[a]);
    }
    return i;
  }
  bool inBounds(const Index<D>& i) const { return (i >= 0).all() && (i < dims_).all(); }

  float& at(const Index<D>& i) { return values_[linear(i)]; }
  float at(const Index<D>& i) const { return values_[linear(i)]; }
  float& operator[](std::size_t n) { return values_[n]; }
  float operator[](std::size_t n) const { return values_[n]; }

  /// @brief World position of node `i`.
  Vec<D> nodePosition(const Index<D>& i) const { return origin_ + spacing_ * i.template cast<double>().matrix(); }
  /// @brief Continuous grid coordinates (cells) of world point x.
  Vec<D> toGrid(const Vec<D>& x) const { return (x - origin_) / spacing_; }
  /// @brief World point of continuous grid coordinates g (cells).
  Vec<D> toWorld(const Vec<D>& g) const { return origin_ + spacing_ * g; }
  /// @brief World box spanned by the nodes.
  Box<D> bounds() const { return {origin_, origin_ + spacing_ * (dims_ - 1).template cast<double>().matrix()}; }
  /// @brief True when x lies inside the box spanned by the nodes (where look-ups interpolate).
  bool contains(const Vec<D>& x) const { return bounds().contains(x); }

  /// @brief Multilinear value at world point x (world units).
  /// Outside the node box the answer is phi(c) + |x - c|, with c the closest
  /// point of the box: continuous, positive far away when the grid's border is
  /// outside the shape, and growing like a distance.
  double value(const Vec<D>& x) const;

  /// @brief Multilinear value at world point x and its analytic gradient
  /// (world units per world unit) written to `grad`. Inside the box the gradient
  /// is the exact derivative of the interpolant (piecewise per cell); outside it
  /// is the derivative of the extension described at value().
  double valueAndGradient(const Vec<D>& x, Vec<D>& grad) const;

  /// @brief The interpolant at grid coordinates g (cells from the first
  /// node), which must lie in the node box [0, dims - 1]^D: value() without
  /// the conversion from world units and the outside extension, for callers
  /// that fold the conversion into their own transform (the narrow phase).
  /// The same arithmetic as value() from there on.
  [[gnu::always_inline]] double valueAtCells(const Vec<D>& g) const {
    return interpolate<GradientMode::None>(g, nullptr, 0.0);
  }
  /// @brief valueAtCells() at the n points g[0, n), into out[0, n): the
  /// same values bit for bit, two points at a time where the target has
  /// SSE2 (every x86-64 does): one register holds both points' operands and
  /// each instruction makes the same operation, in the same order, on both.
  /// About 1.4x the points per second of one-at-a-time look-ups
  /// (BM_BatchedLookup). The narrow phase's batched walks make their
  /// look-ups through it. (A build that lets the compiler fuse multiplies
  /// and adds, e.g. -march=native with FMA, may fuse the two versions
  /// differently: the test Grid.BatchedLookupsAgreeBitForBit* checks a build.)
  void valuesAtCells(const Vec<D>* g, std::size_t n, double* out) const;
  /// @brief valueAndGradientAtCells() at the n points g[0, n): values into
  /// values[0, n), gradients per cell length into grads[0, n); the same bit
  /// for bit, two points at a time as valuesAtCells(). For callers whose
  /// points mostly lie inside, which need the gradient of most of them:
  /// one pass over the corners instead of a value and then a second
  /// look-up for the gradient (the narrow phase's retests of nodes near
  /// contact). `grads` may be `g` itself: each point is read before its
  /// gradient is written.
  void valuesAndGradientsAtCells(const Vec<D>* g, std::size_t n, double* values, Vec<D>* grads) const;
  /// @brief valueAtCells() and the gradient per cell length (divide by
  /// spacing() for world units); the same value bit for bit.
  [[gnu::always_inline]] double valueAndGradientAtCells(const Vec<D>& g, Vec<D>& gradCells) const {
    return interpolate<GradientMode::Always>(g, &gradCells, 0.0);
  }
  /// @brief valueAtCells(), and where the value is below `threshold` also
  /// the gradient of valueAndGradientAtCells(), from the same corner values:
  /// one look-up where a caller that needs the gradient only for points
  /// inside would otherwise make two. `gradCells` is left as it was where
  /// the value is not below `threshold`.
  [[gnu::always_inline]] double valueAtCellsGradientBelow(const Vec<D>& g, double threshold, Vec<D>& gradCells) const {
    return interpolate<GradientMode::Below>(g, &gradCells, threshold);
  }

  /// @brief The Catmull-Rom tricubic (bicubic in 2D) interpolant at grid
  /// coordinates g (cells), which must lie in the node box: per axis the
  /// cubic through the four nodes about g's cell, with the slopes at the
  /// cell's ends the central differences (v[i+1] - v[i-1]) / 2; a stencil
  /// index past the border takes the border node. It reproduces quadratics,
  /// so on a smooth signed distance its error is O(h^3) where the
  /// multilinear interpolant's is h^2 / (8 R) (R the radius of curvature).
  /// C1 across cells. The narrow phase's look-up when a scene chooses
  /// `interpolation = "tricubic"` (ContactLaw.h, LevelSetInterpolation).
  [[gnu::always_inline]] double cubicValueAtCells(const Vec<D>& g) const {
    return interpolateCubic<GradientMode::None>(g, nullptr, 0.0);
  }
  /// @brief cubicValueAtCells() and its exact gradient per cell length; the
  /// same value bit for bit.
  [[gnu::always_inline]] double cubicValueAndGradientAtCells(const Vec<D>& g, Vec<D>& gradCells) const {
    return interpolateCubic<GradientMode::Always>(g, &gradCells, 0.0);
  }
  /// @brief cubicValueAtCells(), and where it is below `threshold` also its
  /// gradient per cell length (as valueAtCellsGradientBelow).
  [[gnu::always_inline]] double cubicValueAtCellsGradientBelow(const Vec<D>& g, double threshold,
                                                             Vec<D>& gradCells) const {
    return interpolateCubic<GradientMode::Below>(g, &gradCells, threshold);
  }

  /// @brief The cell holding grid coordinates g inside the node box, as the
  /// look-ups choose it (the upper border in the last cell): the linear
  /// offset of its lowest corner.
  std::size_t cellAtCells(const Vec<D>& g) const {
    Index<D> c;
    for (int a = 0; a < D; ++a) c[a] = std::clamp(int(g[a]), 0, dims_[a] - 2);
    return linear(c);
  }

  /// @brief Per cell, a bound on |cubic - multilinear| over the cell (world
  /// units), stored at the cell's lowest corner (entries at the last node of
  /// an axis are 0). The tensor product is written as a telescoping sum,
  /// C_x C_y C_z - L_x L_y L_z = (C_x - L_x) C_y C_z + L_x (C_y - L_y) C_z +
  /// L_x L_y (C_z - L_z). Per axis, Catmull-Rom minus linear on a cell is
  /// alpha(t) D2[i] + beta(t) D2[i+1] with |alpha| + |beta| = t(1-t)/2 <= 1/8
  /// (D2 the second differences at the cell's two nodes); the Catmull-Rom
  /// weights of the inner two nodes sum to at most 9/8, the outer two's
  /// absolute values to at most 1/8, the linear weights to 1. Each term is
  /// bounded by filtering |D2| with those weights axis by axis. Rounded up
  /// to float.
  std::vector<float> cubicDeviationBounds() const;

  /// @brief The largest |grad phi| of the multilinear interpolant inside the
  /// node box (world units per world unit): exact. In a cell each component of
  /// the gradient is multilinear in the other coordinates and does not depend
  /// on its own, so |grad|^2 is convex along every axis and its maximum over
  /// the cell is at a corner, where the gradient is the cell's edge
  /// differences from that corner over the spacing.
  double maxGradientNorm() const;

 private:
  enum class GradientMode { None, Always, Below };
  template <GradientMode Mode>
  [[gnu::always_inline]] inline double interpolate(const Vec<D>& g, Vec<D>* gradCells, double threshold) const;
  template <GradientMode Mode>
  [[gnu::always_inline]] inline double interpolateCubic(const Vec<D>& g, Vec<D>* gradCells, double threshold) const;
  /// Grid coordinates g clamped into the node box.
  Vec<D> clampToBox(const Vec<D>& g) const;
  template <bool Gradients>
  inline void interpolateBatch(const Vec<D>* g, std::size_t n, double* values, Vec<D>* grads) const;

  Index<D> dims_ = Index<D>::Zero();
  Vec<D> origin_ = Vec<D>::Zero();
  double spacing_ = 1.0;
  std::vector<float> values_;
};

// ---- inline look-ups (the narrow phase calls these once per node per step) ----

// The interpolant at grid coordinates g inside the box; with Mode Always
// (Below: where the value is below `threshold`), also its derivative per cell
// length in *gradCells. Every look-up shares this arithmetic, so their
// values agree bit for bit.
template <int D>
template <typename Grid<D>::GradientMode Mode>
inline double Grid<D>::interpolate(const Vec<D>& g, Vec<D>* gradCells, double threshold) const {
  // Cell containing g (clamped so the upper border uses the last cell) and the
  // fractional position t in [0, 1]^D inside it. g >= 0 (every caller
  // clamps it into the box or tests it is inside), so truncation is the floor
  // (std::floor is a library call on baseline x86-64, without SSE4.1).
  Index<D> c;
  Vec<D> t;
  for (int a = 0; a < D; ++a) {
    const int ci = std::clamp(int(g[a]), 0, dims_[a] - 2);
    c[a] = ci;
    t[a] = g[a] - double(ci);
  }
  const std::size_t n0 = linear(c);
  if constexpr (D == 2) {
    const std::size_t sy = std::size_t(dims_[0]);
    const double v00 = values_[n0], v10 = values_[n0 + 1];
    const double v01 = values_[n0 + sy], v11 = values_[n0 + sy + 1];
    const double a0 = v00 + t[0] * (v10 - v00);  // along x at y = 0
    const double a1 = v01 + t[0] * (v11 - v01);  // along x at y = 1
    const double value = a0 + t[1] * (a1 - a0);
    if (Mode == GradientMode::Always || (Mode == GradientMode::Below && value < threshold)) {
      (*gradCells)[0] = (v10 - v00) + t[1] * ((v11 - v01) - (v10 - v00));
      (*gradCells)[1] = a1 - a0;
    }
    return value;
  } else {
    const std::size_t sy = std::size_t(dims_[0]);
    const std::size_t sz = sy * std::size_t(dims_[1]);
    const double v000 = values_[n0], v100 = values_[n0 + 1];
    const double v010 = values_[n0 + sy], v110 = values_[n0 + sy + 1];
    const double v001 = values_[n0 + sz], v101 = values_[n0 + sz + 1];
    const double v011 = values_[n0 + sz + sy], v111 = values_[n0 + sz + sy + 1];
    // Interpolate along x on the four x-edges, then along y, then z.
    const double x00 = v000 + t[0] * (v100 - v000), x10 = v010 + t[0] * (v110 - v010);
    const double x01 = v001 + t[0] * (v101 - v001), x11 = v011 + t[0] * (v111 - v011);
    const double y0 = x00 + t[1] * (x10 - x00), y1 = x01 + t[1] * (x11 - x01);
    const double value = y0 + t[2] * (y1 - y0);
    if (Mode == GradientMode::Always || (Mode == GradientMode::Below && value < threshold)) {
      // d/dx: differences along x bilinearly interpolated in (y, z).
      const double d00 = v100 - v000, d10 = v110 - v010, d01 = v101 - v001, d11 = v111 - v011;
      const double dy0 = d00 + t[1] * (d10 - d00), dy1 = d01 + t[1] * (d11 - d01);
      (*gradCells)[0] = dy0 + t[2] * (dy1 - dy0);
      (*gradCells)[1] = (x10 - x00) + t[2] * ((x11 - x01) - (x10 - x00));
      (*gradCells)[2] = y1 - y0;
    }
    return value;
  }
}

template <int D>
inline void Grid<D>::valuesAtCells(const Vec<D>* g, std::size_t n, double* out) const {
  interpolateBatch<false>(g, n, out, nullptr);
}

template <int D>
inline void Grid<D>::valuesAndGradientsAtCells(const Vec<D>* g, std::size_t n, double* values, Vec<D>* grads) const {
  interpolateBatch<true>(g, n, values, grads);
}

// The batched look-ups: interpolate() at the points g[0, n), two at a time
// where the target has SSE2 (every x86-64 does), each instruction making
// interpolate()'s operation on both points (lane 0 point j, lane 1 point
// j + 1) in its order, so the values and gradients are the same bit for
// bit; the last point of an odd count alone. With Gradients also the
// gradients per cell length, into grads (which may be g: a pair's points
// are read before their gradients are written).
template <int D>
template <bool Gradients>
inline void Grid<D>::interpolateBatch(const Vec<D>* g, std::size_t n, double* values, Vec<D>* grads) const {
  std::size_t j = 0;
#ifdef __SSE2__
  const float* const v = values_.data();
  const std::size_t sy = std::size_t(dims_[0]);
  [[maybe_unused]] const std::size_t sz = sy * std::size_t(dims_[1]);
  const __m128d zero = _mm_setzero_pd();
  __m128d lastCell[D];
  for (int a = 0; a < D; ++a) lastCell[a] = _mm_set1_pd(double(dims_[a] - 2));
  // x + s (y - x): interpolate()'s step.
  const auto lerp = [](__m128d x, __m128d y, __m128d s) { return _mm_add_pd(x, _mm_mul_pd(s, _mm_sub_pd(y, x))); };
  for (; j + 2 <= n; j += 2) {
    // Per axis, both points: the cell clamp(int(g), 0, dims - 2) of
    // interpolate(), taken as int(max(min(g, dims - 2), 0)), the same cell
    // for every g (truncation is the floor for g >= 0), and t = g - cell.
    __m128d t[D];
    int c0[D], c1[D];
    for (int a = 0; a < D; ++a) {
      const __m128d ga = _mm_set_pd(g[j + 1][a], g[j][a]);
      const __m128i ca = _mm_cvttpd_epi32(_mm_max_pd(_mm_min_pd(ga, lastCell[a]), zero));
      t[a] = _mm_sub_pd(ga, _mm_cvtepi32_pd(ca));
      c0[a] = _mm_cvtsi128_si32(ca);
      c1[a] = _mm_cvtsi128_si32(_mm_shuffle_epi32(ca, 1));
    }
    Index<D> i0, i1;
    for (int a = 0; a < D; ++a) i0[a] = c0[a], i1[a] = c1[a];
    const float* const p0 = v + linear(i0);
    const float* const p1 = v + linear(i1);
    // Corner `offset` of both cells, widened to double.
    const auto corner = [p0, p1](std::size_t offset) {
      return _mm_cvtps_pd(_mm_unpacklo_ps(_mm_load_ss(p0 + offset), _mm_load_ss(p1 + offset)));
    };
    // Gradient component a: lane 0 to point j, lane 1 to point j + 1.
    [[maybe_unused]] const auto put = [grads, j](int a, __m128d x) {
      _mm_storel_pd(&grads[j][a], x);
      _mm_storeh_pd(&grads[j + 1][a], x);
    };
    if constexpr (D == 2) {
      const __m128d v00 = corner(0), v10 = corner(1), v01 = corner(sy), v11 = corner(sy + 1);
      const __m128d a0 = lerp(v00, v10, t[0]), a1 = lerp(v01, v11, t[0]);
      _mm_storeu_pd(values + j, lerp(a0, a1, t[1]));
      if constexpr (Gradients) {
        put(0, lerp(_mm_sub_pd(v10, v00), _mm_sub_pd(v11, v01), t[1]));
        put(1, _mm_sub_pd(a1, a0));
      }
    } else {
      const __m128d v000 = corner(0), v100 = corner(1), v010 = corner(sy), v110 = corner(sy + 1);
      const __m128d v001 = corner(sz), v101 = corner(sz + 1), v011 = corner(sz + sy), v111 = corner(sz + sy + 1);
      const __m128d x00 = lerp(v000, v100, t[0]), x10 = lerp(v010, v110, t[0]);
      const __m128d x01 = lerp(v001, v101, t[0]), x11 = lerp(v011, v111, t[0]);
      const __m128d y0 = lerp(x00, x10, t[1]), y1 = lerp(x01, x11, t[1]);
      _mm_storeu_pd(values + j, lerp(y0, y1, t[2]));
      if constexpr (Gradients) {
        const __m128d d00 = _mm_sub_pd(v100, v000), d10 = _mm_sub_pd(v110, v010);
        const __m128d d01 = _mm_sub_pd(v101, v001), d11 = _mm_sub_pd(v111, v011);
        put(0, lerp(lerp(d00, d10, t[1]), lerp(d01, d11, t[1]), t[2]));
        put(1, lerp(_mm_sub_pd(x10, x00), _mm_sub_pd(x11, x01), t[2]));
        put(2, _mm_sub_pd(y1, y0));
      }
    }
  }
#endif
  for (; j < n; ++j) {
    if constexpr (Gradients) {
      values[j] = valueAndGradientAtCells(g[j], grads[j]);
    } else {
      values[j] = valueAtCells(g[j]);
    }
  }
}

namespace detail {
/// Catmull-Rom weights of the nodes i-1, i, i+1, i+2 at t in [0, 1] of cell i.
[[gnu::always_inline]] inline void catmullRomWeights(double t, double w[4]) {
  const double t2 = t * t, t3 = t2 * t;
  w[0] = 0.5 * (-t3 + 2.0 * t2 - t);
  w[1] = 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0);
  w[2] = 0.5 * (-3.0 * t3 + 4.0 * t2 + t);
  w[3] = 0.5 * (t3 - t2);
}
/// Their derivatives with respect to t.
[[gnu::always_inline]] inline void catmullRomDerivatives(double t, double w[4]) {
  const double t2 = t * t;
  w[0] = 0.5 * (-3.0 * t2 + 4.0 * t - 1.0);
  w[1] = 0.5 * (9.0 * t2 - 10.0 * t);
  w[2] = 0.5 * (-9.0 * t2 + 8.0 * t + 1.0);
  w[3] = 0.5 * (3.0 * t2 - 2.0 * t);
}
}  // namespace detail

// The Catmull-Rom interpolant at grid coordinates g inside the box (see
// cubicValueAtCells); with Mode Always (Below: where the value is below
// `threshold`) also its derivative per cell length. Separable: the sums
// along x first (per y[, z] row of the 4^D stencil), then y, then z. With a
// gradient mode the rows' x-derivative sums are formed in the same pass as
// their values (the stencil is gathered once); the arithmetic of each sum is
// that of the value-only look-up, so the results agree bit for bit.
template <int D>
template <typename Grid<D>::GradientMode Mode>
inline double Grid<D>::interpolateCubic(const Vec<D>& g, Vec<D>* gradCells, double threshold) const {
  // Cell, fraction, weights and the stencil's offsets per axis (clamped at the border).
  constexpr bool withGradient = Mode != GradientMode::None;
  double w[D][4];
  std::size_t offset[D][4];
  std::size_t stride = 1;
  double t[D];
  for (int a = 0; a < D; ++a) {
    const int ci = std::clamp(int(g[a]), 0, dims_[a] - 2);
    t[a] = g[a] - double(ci);
    detail::catmullRomWeights(t[a], w[a]);
    for (int k = 0; k < 4; ++k) offset[a][k] = stride * std::size_t(std::clamp(ci + k - 1, 0, dims_[a] - 1));
    stride *= std::size_t(dims_[a]);
  }
  double dx[4] = {0.0, 0.0, 0.0, 0.0};
  if constexpr (withGradient) detail::catmullRomDerivatives(t[0], dx);
  const float* v = values_.data();
  // One row of the stencil along x: its value sum and (with a gradient
  // mode) its x-derivative sum.
  const auto rowSums = [&](const float* r, double& value, double& derivative) {
    const double r0 = r[offset[0][0]], r1 = r[offset[0][1]], r2 = r[offset[0][2]], r3 = r[offset[0][3]];
    value = w[0][0] * r0 + w[0][1] * r1 + w[0][2] * r2 + w[0][3] * r3;
    if constexpr (withGradient) derivative = dx[0] * r0 + dx[1] * r1 + dx[2] * r2 + dx[3] * r3;
  };
  if constexpr (D == 2) {
    double row[4], rowDx[4];  // the x sums of the four rows
    for (int j = 0; j < 4; ++j) rowSums(v + offset[1][j], row[j], rowDx[j]);
    const double value = w[1][0] * row[0] + w[1][1] * row[1] + w[1][2] * row[2] + w[1][3] * row[3];
    if (Mode == GradientMode::Always || (Mode == GradientMode::Below && value < threshold)) {
      double dy[4];
      detail::catmullRomDerivatives(t[1], dy);
      double gx = 0.0;
      for (int j = 0; j < 4; ++j) gx += w[1][j] * rowDx[j];
      (*gradCells)[0] = gx;
      (*gradCells)[1] = dy[0] * row[0] + dy[1] * row[1] + dy[2] * row[2] + dy[3] * row[3];
    }
    return value;
  } else {
    double row[4][4], rowDx[4][4];  // the x sums of the 16 rows, [z][y]
    double plane[4];                // the y sums of the four planes
    for (int k = 0; k < 4; ++k) {
      for (int j = 0; j < 4; ++j) rowSums(v + offset[2][k] + offset[1][j], row[k][j], rowDx[k][j]);
      plane[k] = w[1][0] * row[k][0] + w[1][1] * row[k][1] + w[1][2] * row[k][2] + w[1][3] * row[k][3];
    }
    const double value = w[2][0] * plane[0] + w[2][1] * plane[1] + w[2][2] * plane[2] + w[2][3] * plane[3];
    if (Mode == GradientMode::Always || (Mode == GradientMode::Below && value < threshold)) {
      double dy[4], dz[4];
      detail::catmullRomDerivatives(t[1], dy);
      detail::catmullRomDerivatives(t[2], dz);
      double gx = 0.0, gy = 0.0;
      for (int k = 0; k < 4; ++k) {
        double px = 0.0;  // the y sum of the rows' x derivatives
        for (int j = 0; j < 4; ++j) px += w[1][j] * rowDx[k][j];
        gx += w[2][k] * px;
        gy += w[2][k] * (dy[0] * row[k][0] + dy[1] * row[k][1] + dy[2] * row[k][2] + dy[3] * row[k][3]);
      }
      (*gradCells)[0] = gx;
      (*gradCells)[1] = gy;
      (*gradCells)[2] = dz[0] * plane[0] + dz[1] * plane[1] + dz[2] * plane[2] + dz[3] * plane[3];
    }
    return value;
  }
}

template <int D>
inline Vec<D> Grid<D>::clampToBox(const Vec<D>& g) const {
  return g.cwiseMax(Vec<D>::Zero()).cwiseMin((dims_ - 1).template cast<double>().matrix());
}

template <int D>
inline double Grid<D>::value(const Vec<D>& x) const {
  const Vec<D> g = toGrid(x);
  const Vec<D> gc = clampToBox(g);
  const double inside = interpolate<GradientMode::None>(gc, nullptr, 0.0);
  if (gc == g) return inside;
  return inside + (spacing_ * (g - gc)).norm();
}

template <int D>
inline double Grid<D>::valueAndGradient(const Vec<D>& x, Vec<D>& grad) const {
  const Vec<D> g = toGrid(x);
  const Vec<D> gc = clampToBox(g);
  Vec<D> gradCells;
  const double inside = interpolate<GradientMode::Always>(gc, &gradCells, 0.0);
  grad = gradCells;  // per cell of distance -> per world unit, since values are in world units
  // Fast path: x inside the node box.
  if (gc == g) {
    grad /= spacing_;
    return inside;
  }
  // Outside: value = phi(c) + |x - c|; on clamped axes the interpolant does not
  // change with x, the distance term does.
  const Vec<D> offset = spacing_ * (g - gc);
  const double dist = offset.norm();
  for (int a = 0; a < D; ++a) {
    grad[a] = (g[a] != gc[a]) ? offset[a] / dist : grad[a] / spacing_;
  }
  return inside + dist;
}

extern template class Grid<2>;
extern template class Grid<3>;

}  // namespace lsdem::geometry
