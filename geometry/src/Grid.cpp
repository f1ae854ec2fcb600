#include "lsdem/geometry/Grid.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

namespace lsdem::geometry {

template <int D>
Grid<D>::Grid(const Index<D>& dims, const Vec<D>& origin, double spacing, float fill)
    : dims_(dims), origin_(origin), spacing_(spacing) {
  if (!(spacing > 0.0) || !std::isfinite(spacing)) {
    throw std::invalid_argument("grid spacing must be positive and finite, got " + std::to_string(spacing));
  }
  if ((dims < 2).any()) {
    throw std::invalid_argument("a grid needs at least 2 nodes per axis");
  }
  std::size_t n = 1;
  for (int a = 0; a < D; ++a) n *= std::size_t(dims[a]);
  values_.assign(n, fill);
}

template <int D>
Grid<D> Grid<D>::covering(const Box<D>& box, double spacing, int paddingCells, float fill) {
  if (!(spacing > 0.0) || !std::isfinite(spacing)) {
    throw std::invalid_argument("grid spacing must be positive and finite, got " + std::to_string(spacing));
  }
  // Nodes are placed symmetrically about the box centre so a symmetric shape
  // gets a symmetric grid.
  const Vec<D> centre = 0.5 * (box.lower + box.upper);
  Index<D> dims;
  Vec<D> origin;
  double total = 1.0;
  for (int a = 0; a < D; ++a) {
    const double half = 0.5 * (box.upper[a] - box.lower[a]);
    const double cells = std::ceil(half / spacing - 1e-9) + paddingCells;
    total *= 2.0 * cells + 1.0;
    if (!(half >= 0.0) || !std::isfinite(cells) || cells > double(1 << 23) || total > 2147483647.0) {
      throw std::invalid_argument("a grid of spacing " + std::to_string(spacing) + " over a box " +
                                  std::to_string(2.0 * half) + " wide is too large or invalid");
    }
    const int halfCells = int(cells);
    dims[a] = 2 * halfCells + 1;
    origin[a] = centre[a] - halfCells * spacing;
  }
  return Grid<D>(dims.max(2), origin, spacing, fill);
}

template <int D>
double Grid<D>::maxGradientNorm() const {
  for (int a = 0; a < D; ++a) {
    if (dims_[a] < 2) return 0.0;
  }
  std::array<std::size_t, D> stride;
  stride[0] = 1;
  for (int a = 1; a < D; ++a) stride[a] = stride[a - 1] * std::size_t(dims_[a - 1]);
  // A grid node is a corner of the cells on either side of it along each
  // axis, independently per axis; at a corner the squared gradient is the sum
  // over axes of the squared difference along that cell's edge. So the largest
  // over the cells meeting at a node is the sum over axes of the larger
  // squared difference to the lower and to the upper neighbour.
  double largest2 = 0.0;
  Index<D> i = Index<D>::Zero();
  for (std::size_t n = 0; n < values_.size(); ++n, advance(i)) {
    const double v = values_[n];
    double g2 = 0.0;
    for (int a = 0; a < D; ++a) {
      double d2 = 0.0;
      if (i[a] > 0) d2 = std::max(d2, (double(values_[n - stride[a]]) - v) * (double(values_[n - stride[a]]) - v));
      if (i[a] + 1 < dims_[a]) d2 = std::max(d2, (double(values_[n + stride[a]]) - v) * (double(values_[n + stride[a]]) - v));
      g2 += d2;
    }
    largest2 = std::max(largest2, g2);
  }
  return std::sqrt(largest2) / spacing_;
}

template <int D>
std::vector<float> Grid<D>::cubicDeviationBounds() const {
  std::array<std::size_t, D> stride;
  stride[0] = 1;
  for (int a = 1; a < D; ++a) stride[a] = stride[a - 1] * std::size_t(dims_[a - 1]);
  const std::size_t n = values_.size();
  // The value at node q shifted by k along axis b, the index clamped to the
  // grid as the interpolant's stencil is.
  const auto at = [&](const std::vector<double>& m, std::size_t q, const Index<D>& i, int b, int k) {
    const int j = std::clamp(i[b] + k, 0, dims_[b] - 1);
    return m[std::size_t(std::ptrdiff_t(q) + std::ptrdiff_t(j - i[b]) * std::ptrdiff_t(stride[b]))];
  };
  std::vector<double> term(n), scratch(n);
  std::vector<double> total(n, 0.0);
  for (int a = 0; a < D; ++a) {
    // |second difference| along a at every node (border neighbours clamped).
    Index<D> i = Index<D>::Zero();
    for (std::size_t q = 0; q < n; ++q, advance(i)) {
      const double below = i[a] > 0 ? values_[q - stride[a]] : values_[q];
      const double above = i[a] + 1 < dims_[a] ? values_[q + stride[a]] : values_[q];
      term[q] = std::abs(below - 2.0 * double(values_[q]) + above);
    }
    // Axis a's term of the telescoping sum: the linear weights on the axes
    // before a and a's own (the cell's two nodes), the Catmull-Rom weights
    // on the axes after it, whose sums of |weight| over the inner and outer
    // pair are at most 9/8 and 1/8 for every t. One axis at a time.
    for (int b = 0; b < D; ++b) {
      i = Index<D>::Zero();
      for (std::size_t q = 0; q < n; ++q, advance(i)) {
        const double inner = std::max(term[q], at(term, q, i, b, 1));
        scratch[q] = b <= a ? inner : 1.125 * inner + 0.125 * std::max(at(term, q, i, b, -1), at(term, q, i, b, 2));
      }
      term.swap(scratch);
    }
    for (std::size_t q = 0; q < n; ++q) total[q] += term[q] / 8.0;
  }
  // Per cell, rounded up to a float.
  std::vector<float> bound(n, 0.0f);
  Index<D> i = Index<D>::Zero();
  for (std::size_t q = 0; q < n; ++q, advance(i)) {
    if ((i >= dims_ - 1).any()) continue;
    float f = float(total[q]);
    if (double(f) < total[q]) f = std::nextafter(f, std::numeric_limits<float>::infinity());
    bound[q] = f;
  }
  return bound;
}

template class Grid<2>;
template class Grid<3>;

}  // namespace lsdem::geometry
