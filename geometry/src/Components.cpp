#include "lsdem/geometry/Components.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::geometry {

namespace {

/// Linear offset between neighbours along each axis (x fastest).
template <int D>
std::array<std::size_t, D> strides(const Index<D>& dims) {
  std::array<std::size_t, D> s{};
  s[0] = 1;
  for (int a = 1; a < D; ++a) s[a] = s[a - 1] * std::size_t(dims[a - 1]);
  return s;
}

/// Scratch of the 1D squared distance transform on a line of n samples.
struct LineScratch {
  std::vector<double> f, d, z;
  std::vector<int> v;
  void resize(std::size_t n) {
    f.resize(n);
    d.resize(n);
    z.resize(n + 1);
    v.resize(n);
  }
};

/// Exact 1D squared distance transform (lower envelope of parabolas,
/// Felzenszwalb & Huttenlocher): d[q] = min_p (q - p)^2 + f[p], in cells^2.
void distanceTransform1D(int n, LineScratch& s) {
  const double inf = std::numeric_limits<double>::infinity();
  // Intersection abscissa of the parabolas rooted at q and p.
  auto cross = [&s](int q, int p) {
    return ((s.f[std::size_t(q)] + double(q) * q) - (s.f[std::size_t(p)] + double(p) * p)) / (2.0 * (q - p));
  };
  // Lower envelope: v holds the roots of its parabolas, z the boundaries between them.
  std::size_t k = 0;
  s.v[0] = 0;
  s.z[0] = -inf;
  s.z[1] = inf;
  for (int q = 1; q < n; ++q) {
    double x = cross(q, s.v[k]);
    while (x <= s.z[k]) {
      --k;
      x = cross(q, s.v[k]);
    }
    ++k;
    s.v[k] = q;
    s.z[k] = x;
    s.z[k + 1] = inf;
  }
  // Read the envelope at every sample.
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (s.z[k + 1] < q) ++k;
    const int p = s.v[k];
    s.d[std::size_t(q)] = double(q - p) * double(q - p) + s.f[std::size_t(p)];
  }
}

/// Squared Euclidean distance (cells^2) from every node to the nearest node
/// where `dist2` is 0 on entry (the others hold a large value), in place;
/// separable: one 1D transform per axis.
template <int D>
void squaredDistanceTransform(const Index<D>& dims, std::vector<double>& dist2) {
  const std::array<std::size_t, D> stride = strides<D>(dims);
  for (int a = 0; a < D; ++a) {
    const int n = dims[a];
    const std::int64_t lines = std::int64_t(dist2.size() / std::size_t(n));
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel
#endif
    {
      LineScratch scratch;
      scratch.resize(std::size_t(n));
#ifdef LSDEM_HAVE_OPENMP
#pragma omp for schedule(static)
#endif
      for (std::int64_t l = 0; l < lines; ++l) {
        // First node of line l: l split into the index below axis a and the one above it.
        const std::size_t inner = std::size_t(l) % stride[a];
        const std::size_t outer = std::size_t(l) / stride[a];
        const std::size_t base = outer * stride[a] * std::size_t(n) + inner;
        for (int q = 0; q < n; ++q) scratch.f[std::size_t(q)] = dist2[base + std::size_t(q) * stride[a]];
        distanceTransform1D(n, scratch);
        for (int q = 0; q < n; ++q) dist2[base + std::size_t(q) * stride[a]] = scratch.d[std::size_t(q)];
      }
    }
  }
}

}  // namespace

template <int D>
int labelComponents(const Grid<D>& grid, std::vector<int>& labels) {
  labels.assign(grid.size(), -1);
  const Index<D>& dims = grid.dims();
  const std::array<std::size_t, D> stride = strides<D>(dims);
  std::vector<std::size_t> stack;
  int count = 0;
  // Scan in linear order; each unlabelled interior node seeds a flood fill, so
  // components are numbered by their lowest linear index.
  for (std::size_t seed = 0; seed < grid.size(); ++seed) {
    if (!(grid[seed] < 0.0f) || labels[seed] >= 0) continue;
    const int label = count++;
    labels[seed] = label;
    stack.push_back(seed);
    while (!stack.empty()) {
      const std::size_t n = stack.back();
      stack.pop_back();
      const Index<D> i = grid.unlinear(n);
      // Visit the face neighbours (2 per axis) that are interior and unlabelled.
      for (int a = 0; a < D; ++a) {
        if (i[a] > 0) {
          const std::size_t m = n - stride[a];
          if (grid[m] < 0.0f && labels[m] < 0) {
            labels[m] = label;
            stack.push_back(m);
          }
        }
        if (i[a] + 1 < dims[a]) {
          const std::size_t m = n + stride[a];
          if (grid[m] < 0.0f && labels[m] < 0) {
            labels[m] = label;
            stack.push_back(m);
          }
        }
      }
    }
  }
  return count;
}

template <int D>
std::vector<Grid<D>> connectedComponents(const Grid<D>& grid, int paddingCells) {
  if (paddingCells < 0) {
    throw std::invalid_argument("connectedComponents: paddingCells must be >= 0, got " + std::to_string(paddingCells));
  }
  std::vector<int> labels;
  const int count = labelComponents(grid, labels);
  std::vector<Grid<D>> out;
  if (count == 0) return out;
  out.reserve(std::size_t(count));

  // Node bounding box of every component.
  std::vector<Index<D>> lower(std::size_t(count), grid.dims()), upper(std::size_t(count), Index<D>::Constant(-1));
  for (std::size_t n = 0; n < grid.size(); ++n) {
    if (labels[n] < 0) continue;
    const Index<D> i = grid.unlinear(n);
    lower[std::size_t(labels[n])] = lower[std::size_t(labels[n])].min(i);
    upper[std::size_t(labels[n])] = upper[std::size_t(labels[n])].max(i);
  }

  const double h = grid.spacing();
  const double far = 1e20;  // "no component node yet", cells^2
  std::vector<double> dist2;
  for (int k = 0; k < count; ++k) {
    // The crop: the bounding box plus padding, at least 2 nodes per axis.
    const Index<D> cropLo = lower[std::size_t(k)] - paddingCells;
    Index<D> cropHi = upper[std::size_t(k)] + paddingCells;
    cropHi = cropHi.max(cropLo + 1);
    const Index<D> dims = cropHi - cropLo + 1;
    Grid<D> piece(dims, grid.nodePosition(cropLo), h);
    const std::int64_t nodes = std::int64_t(piece.size());

    // Seeds of the distance transform: the component's own nodes.
    dist2.assign(piece.size(), far);
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (std::int64_t m = 0; m < nodes; ++m) {
      const Index<D> gi = cropLo + piece.unlinear(std::size_t(m));
      if (grid.inBounds(gi) && labels[grid.linear(gi)] == k) dist2[std::size_t(m)] = 0.0;
    }
    squaredDistanceTransform<D>(dims, dist2);

    // Values: phi on k, the distance bound elsewhere (see the header).
    const double diagonal = std::sqrt(double(D));
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (std::int64_t m = 0; m < nodes; ++m) {
      const std::size_t node = std::size_t(m);
      const Index<D> gi = cropLo + piece.unlinear(node);
      const bool inInput = grid.inBounds(gi);
      const std::size_t n = inInput ? grid.linear(gi) : 0;
      if (inInput && labels[n] == k) {
        piece[node] = grid[n];
        continue;
      }
      const double phi = inInput ? double(grid[n]) : grid.value(piece.nodePosition(piece.unlinear(node)));
      const double d = std::sqrt(dist2[node]);
      // Interior of another piece (at least one cell from k): pushed out to d - h >= 0.
      // Exterior: raised only where it is farther than a cell diagonal from k.
      piece[node] = (phi < 0.0) ? float(h * (d - 1.0)) : float(std::max(phi, h * (d - diagonal)));
    }
    out.push_back(std::move(piece));
  }
  return out;
}

template int labelComponents<2>(const Grid<2>&, std::vector<int>&);
template int labelComponents<3>(const Grid<3>&, std::vector<int>&);
template std::vector<Grid<2>> connectedComponents<2>(const Grid<2>&, int);
template std::vector<Grid<3>> connectedComponents<3>(const Grid<3>&, int);

}  // namespace lsdem::geometry
