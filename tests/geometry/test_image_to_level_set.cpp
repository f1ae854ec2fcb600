// Grains from a labelled image: spheres and ellipsoids voxelised in the test
// (a voxel belongs to a grain when its centre is inside) come back as level
// sets whose volume and centroid are the analytic ones, and the per-label
// statistics (counts, boxes, border contact) are exact.

#include "lsdem/geometry/ImageToLevelSet.h"
#include "lsdem/geometry/LabelVolume.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/SurfaceNodes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>
#include <vector>

using namespace lsdem::geometry;

namespace {

// A volume of `n` voxels of `h` (world units) with one ellipsoid, label 1,
// of semi-axes `axes` centred at `centre` (world units).
LabelVolume ellipsoidVolume(const Index<3>& n, const Vec<3>& h, const Vec<3>& centre, const Vec<3>& axes) {
  LabelVolume v;
  v.dims = n;
  v.spacing = h;
  v.origin = Vec<3>(0.3, -0.2, 0.1);
  v.labels.assign(v.voxelCount(), 0);
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        const Vec<3> p = (v.voxelCentre(Index<3>(i, j, k)) - centre).cwiseQuotient(axes);
        if (p.squaredNorm() < 1.0) v.labels[v.linear(i, j, k)] = 1;
      }
  return v;
}

struct Recovered {
  double volume;       // of the level set
  double voxelVolume;  // voxel count x voxel volume
  Vec<3> centroid;
};

Recovered recover(const LabelVolume& v, double cellsAcross = 20.0) {
  const std::vector<LabelStats> stats = labelStatistics(v);
  EXPECT_EQ(stats.size(), 1u);
  LabelGridOptions o;
  o.cellsAcross = cellsAcross;
  const auto shape = Shape<3>::fromGrid(labelLevelSet(v, stats.at(0), o));
  return {shape->volume(), double(stats[0].voxels) * v.spacing.prod(), shape->bodyToGrid().translation};
}

}  // namespace

// A sphere 20 voxels across (radius 10 voxels), its centre off the voxel
// lattice: volume within 1 % of 4/3 pi r^3 (measured +0.37 %, of which
// +0.32 % is the voxelisation's: the voxel count's own error), and within
// 0.2 % of the voxel count (measured +0.06 %); centroid within a fiftieth of
// a voxel (measured 0.011: the voxelisation's own offset).
TEST(ImageToLevelSet, SphereTwentyVoxelsAcrossKeepsItsVolume) {
  const double h = 1e-4, r = 10.0 * h;
  const Vec<3> centre = Vec<3>(0.3, -0.2, 0.1) + h * Vec<3>(15.3, 14.8, 15.55);
  const LabelVolume v = ellipsoidVolume(Index<3>(31, 30, 32), Vec<3>::Constant(h), centre, Vec<3>::Constant(r));
  const Recovered got = recover(v);
  const double exact = 4.0 / 3.0 * M_PI * r * r * r;
  const double error = got.volume / exact - 1.0;
  std::printf("sphere 20 voxels across: volume error %+.3f %%, centroid off by %.4f voxels\n", 100.0 * error,
              (got.centroid - centre).norm() / h);
  EXPECT_LT(std::abs(error), 0.01);
  EXPECT_LT(std::abs(got.volume / got.voxelVolume - 1.0), 0.002);
  EXPECT_LT((got.centroid - centre).norm(), 0.02 * h);
}

// An ellipsoid of semi-axes 16, 12 and 10 voxels (20 across its thinnest
// axis): within 1 % (measured +0.12 %).
TEST(ImageToLevelSet, EllipsoidKeepsItsVolume) {
  const double h = 2e-4;
  const Vec<3> axes = h * Vec<3>(16.0, 12.0, 10.0);
  const Vec<3> centre = Vec<3>(0.3, -0.2, 0.1) + h * Vec<3>(20.4, 15.1, 13.7);
  const LabelVolume v = ellipsoidVolume(Index<3>(41, 31, 28), Vec<3>::Constant(h), centre, axes);
  const Recovered got = recover(v);
  const double exact = 4.0 / 3.0 * M_PI * axes.prod();
  const double error = got.volume / exact - 1.0;
  std::printf("ellipsoid 32 x 24 x 20 voxels: volume error %+.3f %%, against the voxel count %+.3f %%\n", 100.0 * error,
              100.0 * (got.volume / got.voxelVolume - 1.0));
  EXPECT_LT(std::abs(error), 0.01);
  EXPECT_LT(std::abs(got.volume / got.voxelVolume - 1.0), 0.002);
  EXPECT_LT((got.centroid - centre).norm(), 0.02 * h);
}

// Anisotropic voxels (twice as long in z): the sphere is 20 voxels across in
// x and y but only 10 in z (measured -0.47 %, -0.41 % against the voxel count).
TEST(ImageToLevelSet, AnisotropicVoxels) {
  const Vec<3> h(1e-4, 1e-4, 2e-4);
  const double r = 1e-3;
  const Vec<3> centre = Vec<3>(0.3, -0.2, 0.1) + Vec<3>(15.2e-4, 15.6e-4, 16.3e-4);
  const LabelVolume v = ellipsoidVolume(Index<3>(31, 31, 16), h, centre, Vec<3>::Constant(r));
  const Recovered got = recover(v);
  const double exact = 4.0 / 3.0 * M_PI * r * r * r;
  const double error = got.volume / exact - 1.0;
  std::printf("sphere in 1 x 1 x 2 voxels: volume error %+.3f %%, against the voxel count %+.3f %%\n", 100.0 * error,
              100.0 * (got.volume / got.voxelVolume - 1.0));
  EXPECT_LT(std::abs(error), 0.01);
  EXPECT_LT(std::abs(got.volume / got.voxelVolume - 1.0), 0.005);
}

// At 10, 20 and 40 voxels across a sphere (the grid 20 cells across each
// time) the volume is the voxel count's to 0.1 % (measured +0.07 %, +0.05 %,
// +0.02 %): what is left of the error is the voxelisation's (measured
// against 4/3 pi r^3: -0.05 %, -0.12 %, -0.02 %).
TEST(ImageToLevelSet, VolumeFollowsTheVoxelCount) {
  for (const double across : {10.0, 20.0, 40.0}) {
    const double h = 1.0 / across, r = 0.5;
    const int count = int(across) + 8;
    const Vec<3> centre = Vec<3>(0.3, -0.2, 0.1) + h * Vec<3>(0.5 * count + 0.3, 0.5 * count - 0.2, 0.5 * count + 0.05);
    const LabelVolume v =
        ellipsoidVolume(Index<3>(count, count, count), Vec<3>::Constant(h), centre, Vec<3>::Constant(r));
    const Recovered got = recover(v);
    const double error = got.volume / (4.0 / 3.0 * M_PI * r * r * r) - 1.0;
    const double againstCount = got.volume / got.voxelVolume - 1.0;
    std::printf("sphere %2.0f voxels across: volume error %+.3f %%, against the voxel count %+.3f %%\n", across,
                100.0 * error, 100.0 * againstCount);
    EXPECT_LT(std::abs(againstCount), 0.001) << across;
    EXPECT_LT(std::abs(error), across >= 20.0 ? 0.01 : 0.02) << across;
  }
}

TEST(LabelVolume, StatisticsCountBoxesAndBorder) {
  LabelVolume v;
  v.dims = Index<3>(6, 5, 4);
  v.spacing = Vec<3>(1.0, 2.0, 3.0);
  v.origin = Vec<3>(10.0, 0.0, 0.0);
  v.labels.assign(v.voxelCount(), 0);
  v.labels[v.linear(2, 2, 1)] = 7;
  v.labels[v.linear(3, 2, 2)] = 7;
  v.labels[v.linear(0, 1, 1)] = 3;  // on the x = 0 face
  v.labels[v.linear(4, 3, 2)] = 9;
  const std::vector<LabelStats> s = labelStatistics(v);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].label, 3u);
  EXPECT_TRUE(s[0].touchesBorder);
  EXPECT_EQ(s[1].label, 7u);
  EXPECT_EQ(s[1].voxels, 2u);
  EXPECT_FALSE(s[1].touchesBorder);
  EXPECT_EQ(s[1].lower.matrix(), Index<3>(2, 2, 1).matrix());
  EXPECT_EQ(s[1].upper.matrix(), Index<3>(3, 2, 2).matrix());
  EXPECT_DOUBLE_EQ(s[1].voxelCentroid[0], 12.5);
  EXPECT_DOUBLE_EQ(s[1].voxelCentroid[1], 4.0);
  EXPECT_DOUBLE_EQ(s[1].voxelCentroid[2], 4.5);
  EXPECT_FALSE(s[2].touchesBorder);
  // Background 7: labels 0, 3 and 9 are counted instead.
  EXPECT_EQ(labelStatistics(v, 7).size(), 3u);
  EXPECT_EQ(labelStatistics(v, 7)[0].voxels, v.voxelCount() - 4);
}

TEST(ImageToLevelSet, RefusesBadOptions) {
  const LabelVolume v =
      ellipsoidVolume(Index<3>(12, 12, 12), Vec<3>::Ones(), Vec<3>(6.3, 5.8, 6.1), Vec<3>::Constant(3.0));
  const LabelStats s = labelStatistics(v).at(0);
  LabelGridOptions o;
  o.cellsAcross = 0.0;
  EXPECT_THROW(labelLevelSet(v, s, o), std::invalid_argument);
  o.cellsAcross = 10.0;
  o.spacing = -1.0;
  EXPECT_THROW(labelLevelSet(v, s, o), std::invalid_argument);
  // A label estimate grows with the resolution.
  LabelGridOptions coarse, fine;
  fine.cellsAcross = 40.0;
  EXPECT_GT(labelLevelSetBytes(v, s, fine), labelLevelSetBytes(v, s, coarse));
}

// Nodes of a scanned sphere on the sub-voxel surface: the grid's nodes lie
// on the multilinear zero set of the resampled distance, ~h^2 / (8 R) per
// curved direction inside the surface the grid samples; moved on to the
// zero set of its Catmull-Rom interpolant the mean offset goes, but the
// voxels' roughness stays and is larger: the nodes scatter about the sphere
// of the voxel count's volume by more than the offset, and no nearer to it.
// Measured (grid 10 cells across, h = 0.1 m, R = 0.5 m), mean r - r_count
// and mean |r - r_count|: 10 voxels -3.2e-3, 1.09e-2 -> +1.1e-4, 1.21e-2;
// 16 voxels -2.6e-3, 8.2e-3 -> +7.4e-4, 9.3e-3; 20 voxels -3.0e-3, 5.0e-3
// -> +3.2e-4, 5.1e-3. So lsdem ct2ls keeps the grid's nodes (the contact
// at small overlaps gets no better either: test_convergence.cpp).
TEST(ImageToLevelSet, NodesOnTheTricubicSurfaceOfAScannedSphere) {
  for (const double across : {10.0, 16.0, 20.0}) {
    const double h = 1.0 / across, r = 0.5;
    const int count = int(across) + 8;
    const Vec<3> centre = Vec<3>(0.3, -0.2, 0.1) + h * Vec<3>(0.5 * count + 0.3, 0.5 * count - 0.2, 0.5 * count + 0.05);
    const LabelVolume v =
        ellipsoidVolume(Index<3>(count, count, count), Vec<3>::Constant(h), centre, Vec<3>::Constant(r));
    const std::vector<LabelStats> stats = labelStatistics(v);
    LabelGridOptions o;
    o.cellsAcross = 10.0;
    const Grid<3> grid = labelLevelSet(v, stats.at(0), o);
    const double rCount = std::cbrt(3.0 * double(stats[0].voxels) * h * h * h / (4.0 * M_PI));
    const NodeSet<3> onGrid = surfaceNodes(grid, 1.0);
    const NodeSet<3> onCubic = surfaceNodes(grid, 1.0, nullptr, [&grid](const Vec<3>& x) {
      return projectOntoLevel(grid, x, 0.0, GridInterpolant::CatmullRom);
    });
    const auto gap = [&](const NodeSet<3>& nodes, double radius) {
      double mean = 0.0, meanAbs = 0.0;
      for (const Vec<3>& x : nodes.positions) {
        const double d = (x - centre).norm() - radius;
        mean += d / double(nodes.size());
        meanAbs += std::abs(d) / double(nodes.size());
      }
      return std::pair{mean, meanAbs};
    };
    const auto [gridMean, gridAbs] = gap(onGrid, rCount);
    const auto [cubicMean, cubicAbs] = gap(onCubic, rCount);
    const auto [gridTrue, gridTrueAbs] = gap(onGrid, r);
    const auto [cubicTrue, cubicTrueAbs] = gap(onCubic, r);
    std::printf("scanned sphere %2.0f voxels across, grid 10 cells (h = %.3f): node r - r_count mean %+.3e |.| %.3e "
                "(grid) -> %+.3e |.| %.3e (tricubic); against r: %+.3e |.| %.3e -> %+.3e |.| %.3e\n",
                across, grid.spacing(), gridMean, gridAbs, cubicMean, cubicAbs, gridTrue, gridTrueAbs, cubicTrue,
                cubicTrueAbs);
    const double inset = grid.spacing() * grid.spacing() / (8.0 * r);
    EXPECT_LT(gridMean, -0.5 * inset) << across;            // the interpolant's inset
    EXPECT_LT(std::abs(cubicMean), 0.5 * inset) << across;  // gone on the tricubic surface
    EXPECT_GT(gridAbs, 1.5 * inset) << across;              // the voxels' roughness, larger
    EXPECT_GT(cubicAbs, gridAbs) << across;                 // and no smaller there
  }
}
