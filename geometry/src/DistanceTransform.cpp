#include "lsdem/geometry/DistanceTransform.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace lsdem::geometry {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Scratch of one line's transform, reused across lines.
struct LineScratch {
  std::vector<double> f;                          // the line's input values
  std::vector<int> vertex;                        // envelope parabolas: their sample index
  std::vector<double> bound;                      // envelope: parabola k is lowest on [bound[k], bound[k+1]]
  std::vector<double> out;                        // the transformed line
  std::vector<std::int32_t> feature, featureOut;  // nearest source per sample (when tracked)
  void resize(int n) {
    f.resize(std::size_t(n));
    out.resize(std::size_t(n));
    feature.resize(std::size_t(n));
    featureOut.resize(std::size_t(n));
    vertex.resize(std::size_t(n));
    bound.resize(std::size_t(n) + 1);
  }
};

// One line: d[q] = min over p of f[p] + ((q - p) h)^2, in place on s.f
// (Felzenszwalb & Huttenlocher, Algorithm 1, with sample positions q h and
// infinite samples left out of the envelope). With `track`, s.feature
// follows: each sample takes the feature of the sample whose parabola wins.
void transformLine(LineScratch& s, int n, double h, bool track) {
  double* f = s.f.data();
  int* v = s.vertex.data();
  double* z = s.bound.data();
  // Lower envelope of the parabolas rooted at finite samples.
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (f[q] == kInf) continue;
    const double xq = q * h;
    const double fq = f[q] + xq * xq;
    double cross = -kInf;
    while (k >= 0) {
      const double xv = v[k] * h;
      // Where parabola q overtakes parabola v[k] (positions in world units).
      cross = (fq - (f[v[k]] + xv * xv)) / (2.0 * (xq - xv));
      if (cross > z[k]) break;
      --k;  // parabola v[k] is nowhere lowest any more
    }
    if (k < 0) cross = -kInf;
    ++k;
    v[k] = q;
    z[k] = cross;
    z[k + 1] = kInf;
  }
  if (k < 0) return;  // no finite sample: the line stays infinite
  // Read the envelope at every sample (values first, so f is not overwritten
  // before the envelope's roots are read).
  double* out = s.out.data();
  int j = 0;
  for (int q = 0; q < n; ++q) {
    const double x = q * h;
    while (z[j + 1] < x) ++j;
    const double dx = x - v[j] * h;
    out[q] = f[v[j]] + dx * dx;
    if (track) s.featureOut[std::size_t(q)] = s.feature[std::size_t(v[j])];
  }
  std::copy(out, out + n, f);
  if (track) std::copy(s.featureOut.begin(), s.featureOut.begin() + n, s.feature.begin());
}

// The transform along axis `a` of every line of `d` (dims n), in place, and
// of the nearest-source indices `nearest` when not null.
void transformAxis(std::vector<double>& d, std::vector<std::int32_t>* nearest, const Index<3>& n, int a, double h) {
  const std::size_t stride[3] = {1, std::size_t(n[0]), std::size_t(n[0]) * std::size_t(n[1])};
  // The two other axes index the lines.
  const int b = (a + 1) % 3, c = (a + 2) % 3;
  const long long lines = (long long)n[b] * n[c];
  const int len = n[a];
#pragma omp parallel
  {
    LineScratch s;
    s.resize(len);
#pragma omp for schedule(static)
    for (long long line = 0; line < lines; ++line) {
      const std::size_t ib = std::size_t(line % n[b]), ic = std::size_t(line / n[b]);
      const std::size_t start = ib * stride[b] + ic * stride[c];
      for (int q = 0; q < len; ++q) s.f[std::size_t(q)] = d[start + std::size_t(q) * stride[a]];
      if (nearest) {
        for (int q = 0; q < len; ++q) s.feature[std::size_t(q)] = (*nearest)[start + std::size_t(q) * stride[a]];
      }
      transformLine(s, len, h, nearest != nullptr);
      for (int q = 0; q < len; ++q) d[start + std::size_t(q) * stride[a]] = s.f[std::size_t(q)];
      if (nearest) {
        for (int q = 0; q < len; ++q) (*nearest)[start + std::size_t(q) * stride[a]] = s.feature[std::size_t(q)];
      }
    }
  }
}

}  // namespace

std::vector<double> squaredDistanceTransform(const std::vector<std::uint8_t>& source, const Index<3>& dims,
                                             const Vec<3>& spacing, std::vector<std::int32_t>* nearest) {
  if ((dims < 1).any()) throw std::invalid_argument("distance transform: dims must be >= 1");
  if (!(spacing.array() > 0.0).all() || !spacing.allFinite()) {
    throw std::invalid_argument("distance transform: spacing must be positive");
  }
  const std::size_t count = std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]);
  if (source.size() != count) throw std::invalid_argument("distance transform: mask size does not match dims");
  if (nearest && count > std::size_t(std::numeric_limits<std::int32_t>::max())) {
    throw std::invalid_argument("distance transform: too many voxels to index the nearest source");
  }
  // 0 at the sources, infinite elsewhere (each source its own nearest); then one pass per axis.
  std::vector<double> d(count);
  for (std::size_t i = 0; i < count; ++i) d[i] = source[i] ? 0.0 : kInf;
  if (nearest) {
    nearest->assign(count, -1);
    for (std::size_t i = 0; i < count; ++i) {
      if (source[i]) (*nearest)[i] = std::int32_t(i);
    }
  }
  for (int a = 0; a < 3; ++a) transformAxis(d, nearest, dims, a, spacing[a]);
  return d;
}

std::vector<float> maskSignedDistance(const std::vector<std::uint8_t>& mask, const Index<3>& dims,
                                      const Vec<3>& spacing) {
  // The nearest inside voxel of every voxel, and the nearest outside one.
  std::vector<std::uint8_t> outside(mask.size());
  for (std::size_t i = 0; i < mask.size(); ++i) outside[i] = mask[i] ? 0 : 1;
  std::vector<std::int32_t> nearestInside, nearestOutside;
  squaredDistanceTransform(mask, dims, spacing, &nearestInside);
  squaredDistanceTransform(outside, dims, spacing, &nearestOutside);
  outside = {};
  if (mask.empty() || nearestInside[0] < 0 || nearestOutside[0] < 0) {
    throw std::invalid_argument("signed distance of a mask: the mask needs both inside and outside voxels");
  }
  // The distance from each voxel centre to the box of its nearest voxel of
  // the other phase: per axis max(|offset| - s/2, 0).
  const std::size_t nx = std::size_t(dims[0]), nxy = nx * std::size_t(dims[1]);
  const Vec<3> half = 0.5 * spacing;
  std::vector<float> phi(mask.size());
  for (std::size_t i = 0; i < mask.size(); ++i) {
    const std::size_t j = std::size_t(mask[i] ? nearestOutside[i] : nearestInside[i]);
    const Vec<3> offset(double(long(i % nx) - long(j % nx)),
                        double(long(i / nx % std::size_t(dims[1])) - long(j / nx % std::size_t(dims[1]))),
                        double(long(i / nxy) - long(j / nxy)));
    const Vec<3> gap = (offset.cwiseAbs().cwiseProduct(spacing) - half).cwiseMax(0.0);
    phi[i] = mask[i] ? -float(gap.norm()) : float(gap.norm());
  }
  return phi;
}

}  // namespace lsdem::geometry
