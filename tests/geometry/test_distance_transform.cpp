// The exact Euclidean distance transform (Felzenszwalb-Huttenlocher) against
// brute force on random masks with anisotropic voxels, and the signed
// distance of a mask: zero level on the faces between inside and outside
// voxels, exact distances to a flat face.

#include "lsdem/geometry/DistanceTransform.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

using namespace lsdem::geometry;

namespace {

std::size_t lin(const Index<3>& n, int i, int j, int k) {
  return std::size_t(i) + std::size_t(n[0]) * (std::size_t(j) + std::size_t(n[1]) * std::size_t(k));
}

}  // namespace

TEST(DistanceTransform, MatchesBruteForceOnRandomMasks) {
  const Index<3> n(9, 7, 6);
  const Vec<3> h(0.5, 1.0, 1.7);
  std::mt19937 rng(3);
  for (const double density : {0.02, 0.1, 0.5}) {
    std::bernoulli_distribution pick(density);
    std::vector<std::uint8_t> source(std::size_t(n.prod()));
    for (auto& s : source) s = pick(rng) ? 1 : 0;
    source[17] = 1;  // at least one source
    const std::vector<double> d = squaredDistanceTransform(source, n, h);
    double worst = 0.0;
    for (int k = 0; k < n[2]; ++k) {
      for (int j = 0; j < n[1]; ++j) {
        for (int i = 0; i < n[0]; ++i) {
          double best = std::numeric_limits<double>::infinity();
          for (int c = 0; c < n[2]; ++c) {
            for (int b = 0; b < n[1]; ++b) {
              for (int a = 0; a < n[0]; ++a) {
                if (!source[lin(n, a, b, c)]) continue;
                const double dx = (i - a) * h[0], dy = (j - b) * h[1], dz = (k - c) * h[2];
                best = std::min(best, dx * dx + dy * dy + dz * dz);
              }
            }
          }
          worst = std::max(worst, std::abs(d[lin(n, i, j, k)] - best));
        }
      }
    }
    EXPECT_LT(worst, 1e-12) << "density " << density;
  }
}

TEST(DistanceTransform, NoSourceIsInfiniteAndBadInputThrows) {
  const Index<3> n(4, 3, 2);
  const std::vector<double> d = squaredDistanceTransform(std::vector<std::uint8_t>(24, 0), n, Vec<3>::Ones());
  for (const double v : d) EXPECT_EQ(v, std::numeric_limits<double>::infinity());
  EXPECT_THROW(squaredDistanceTransform(std::vector<std::uint8_t>(23, 0), n, Vec<3>::Ones()), std::invalid_argument);
  EXPECT_THROW(squaredDistanceTransform(std::vector<std::uint8_t>(24, 0), n, Vec<3>(1, 0, 1)), std::invalid_argument);
  EXPECT_THROW(maskSignedDistance(std::vector<std::uint8_t>(24, 1), n, Vec<3>::Ones()), std::invalid_argument);
}

// A half-space mask (voxels i < 4 inside): the values are the distances to
// the face x = 3.5 voxels, negative inside, at every voxel centre.
TEST(DistanceTransform, SignedDistanceOfAFlatFaceIsExact) {
  const Index<3> n(10, 5, 4);
  const double h = 0.25;
  std::vector<std::uint8_t> mask(std::size_t(n.prod()));
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) mask[lin(n, i, j, k)] = i < 4 ? 1 : 0;
  const std::vector<float> phi = maskSignedDistance(mask, n, Vec<3>::Constant(h));
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) EXPECT_NEAR(phi[lin(n, i, j, k)], (i - 3.5) * h, 1e-6) << i;
}
