#include "support/Sampling.h"
#include "lsdem/geometry/Csg.h"
#include "lsdem/geometry/MassProperties.h"
#include "lsdem/geometry/Primitives.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

using namespace lsdem::geometry;
using lsdem::test::sampled;
using lsdem::test::boxAround;

namespace {

constexpr double kPi = std::numbers::pi;


// A plane (eq. 19) through `point` with normal `normal`: signed distance, negative on the -normal side.
template <int D>
SignedDistance<D> plane(const Vec<D>& normal, const Vec<D>& point) {
  const Vec<D> n = normal.normalized();
  return [n, point](const Vec<D>& x) { return n.dot(x - point); };
}

// Splits `phi` by `psi` (eq. 14, 15), recombines (eq. 16) and checks the
// identity min(max(phi, -psi), max(phi, psi)) = max(phi, -|psi|) node by node:
// the same inside set as phi everywhere, phi itself wherever phi >= -|psi|.
// Returns the two halves' volumes.
template <int D>
std::pair<double, double> splitAndRecombine(const Grid<D>& phi, const SignedDistance<D>& psi) {
  const Grid<D> minus = csgDifference(phi, psi);
  const Grid<D> inter = csgIntersection(phi, psi);
  const Grid<D> joined = csgUnion(minus, inter);
  std::size_t unchanged = 0;
  for (std::size_t n = 0; n < phi.size(); ++n) {
    const double p = psi(phi.nodePosition(phi.unlinear(n)));
    EXPECT_NE(p, 0.0);  // the identity's inside set needs psi != 0 at the nodes
    EXPECT_EQ(joined[n] < 0.0f, phi[n] < 0.0f) << "node " << n;
    EXPECT_EQ(joined[n], float(std::max(double(phi[n]), -std::abs(p)))) << "node " << n;
    if (phi[n] >= -std::abs(p)) {
      EXPECT_EQ(joined[n], phi[n]) << "node " << n;
      ++unchanged;
    }
    // Each half is inside only on its own side of the cut.
    if (minus[n] < 0.0f) {
      EXPECT_GT(p, 0.0);
    }
    if (inter[n] < 0.0f) {
      EXPECT_LT(p, 0.0);
    }
  }
  EXPECT_GT(unchanged, phi.size() / 2);
  return {massProperties(minus).volume, massProperties(inter).volume};
}

// Circular segment area cut from a disc of radius R by a chord at distance d from the centre.
double segmentArea(double R, double d) { return R * R * std::acos(d / R) - d * std::sqrt(R * R - d * d); }
// Spherical cap volume cut from a ball of radius R by a plane at distance d from the centre.
double capVolume(double R, double d) {
  const double hc = R - d;
  return kPi * hc * hc * (3 * R - hc) / 3.0;
}

}  // namespace

// A disc split by a line (eq. 18) into a segment and the rest: identity of
// eq. 16, and areas matching the analytic segment.
TEST(Csg, SplitCircleByLine) {
  const double R = 0.5;
  const Vec<2> c(0.011, -0.007);
  const Grid<2> phi = sampled<2>(boxAround<2>(c, R), 0.02, [&](const Vec<2>& x) { return (x - c).norm() - R; });
  const Vec<2> n = Vec<2>(0.6, 0.8);
  const double d = 0.2037;
  const auto [rest, segment] = splitAndRecombine<2>(phi, plane<2>(-n, c + d * n));
  // plane(-n, c + d n) is negative on the far side of the chord: the segment.
  EXPECT_NEAR(segment, segmentArea(R, d), 0.005 * segmentArea(R, d));
  EXPECT_NEAR(rest, kPi * R * R - segmentArea(R, d), 0.005 * (kPi * R * R - segmentArea(R, d)));
  EXPECT_NEAR(rest + segment, massProperties(phi).volume, 0.002 * kPi * R * R);
  std::printf("circle split: segment area error %.3e, rest %.3e\n", segment / segmentArea(R, d) - 1.0,
              rest / (kPi * R * R - segmentArea(R, d)) - 1.0);
}

// A ball split by a plane (eq. 19): cap and remainder volumes.
TEST(Csg, SplitSphereByPlane) {
  const double R = 0.5;
  const Vec<3> c(0.013, -0.021, 0.007);
  const Grid<3> phi = sampled<3>(boxAround<3>(c, R), 0.04, [&](const Vec<3>& x) { return (x - c).norm() - R; });
  const Vec<3> n = Vec<3>(1, 2, 2) / 3.0;
  const double d = 0.15;
  const auto [rest, cap] = splitAndRecombine<3>(phi, plane<3>(-n, c + d * n));
  const double V = 4.0 / 3.0 * kPi * R * R * R;
  EXPECT_NEAR(cap, capVolume(R, d), 0.005 * capVolume(R, d));
  EXPECT_NEAR(rest, V - capVolume(R, d), 0.005 * (V - capVolume(R, d)));
  std::printf("sphere split (25 cells across): cap volume error %.3e, rest %.3e\n", cap / capVolume(R, d) - 1.0,
              rest / (V - capVolume(R, d)) - 1.0);
}

// A concave 2D grain (a crescent: disc minus an offset disc) and a torus,
// split through their concavities: eq. 16 still restores them, and the
// halves' volumes add to the whole.
TEST(Csg, SplitConcaveShapes) {
  const Grid<2> disc = sampled<2>(boxAround<2>(Vec<2>::Zero(), 0.5), 0.02, [](const Vec<2>& x) { return x.norm() - 0.5; });
  const Grid<2> crescent = csgDifference<2>(disc, [](const Vec<2>& x) { return (x - Vec<2>(0.3, 0.0)).norm() - 0.4; });
  const auto [a, b] = splitAndRecombine<2>(crescent, plane<2>(Vec<2>(1.0, 0.05), Vec<2>(-0.05, 0.0031)));
  const double whole = massProperties(crescent).volume;
  EXPECT_NEAR(a + b, whole, 0.003 * whole);
  EXPECT_GT(a, 0.1 * whole);
  EXPECT_GT(b, 0.1 * whole);

  const double Rt = 0.4, rt = 0.15;
  const Grid<3> torus = sampled<3>(Box<3>{Vec<3>(-0.55, -0.55, -0.15), Vec<3>(0.55, 0.55, 0.15)}, 0.03, [&](const Vec<3>& x) {
    return std::hypot(std::hypot(x[0], x[1]) - Rt, x[2]) - rt;
  });
  const auto [t1, t2] = splitAndRecombine<3>(torus, plane<3>(Vec<3>(0.1, 1.0, 0.2), Vec<3>(0.0013, 0.0021, 0.0)));
  const double Vt = 2 * kPi * kPi * Rt * rt * rt;
  EXPECT_NEAR(t1 + t2, Vt, 0.005 * Vt);
  EXPECT_NEAR(t1, 0.5 * Vt, 0.01 * Vt);  // a plane through the axis halves the torus
}

// Two overlapping discs: intersection = lens, difference = disc minus lens,
// union = two discs minus lens; b on its own grid with another origin and spacing.
TEST(Csg, LensAreasGridVersusGrid) {
  const double R = 0.5, dist = 0.6;
  const Vec<2> ca(0.0, 0.0), cb(dist, 0.0);
  const Grid<2> a = sampled<2>(boxAround<2>(ca, R), 0.02, [&](const Vec<2>& x) { return (x - ca).norm() - R; });
  const Grid<2> b = sampled<2>(boxAround<2>(cb + Vec<2>(0.0037, -0.0051), R + 0.01), 0.0137,
                               [&](const Vec<2>& x) { return (x - cb).norm() - R; });
  ASSERT_NE(a.spacing(), b.spacing());
  const double lens = 2 * R * R * std::acos(dist / (2 * R)) - 0.5 * dist * std::sqrt(4 * R * R - dist * dist);
  const double disc = kPi * R * R;
  const double inter = massProperties(csgIntersection(a, b)).volume;
  const double diff = massProperties(csgDifference(a, b)).volume;
  EXPECT_NEAR(inter, lens, 0.005 * lens);
  EXPECT_NEAR(diff, disc - lens, 0.005 * (disc - lens));
  // The union on a grid wide enough for both discs.
  const Grid<2> wide = sampled<2>(Box<2>{Vec<2>(-R, -R), Vec<2>(dist + R, R)}, 0.02,
                                  [&](const Vec<2>& x) { return (x - ca).norm() - R; });
  const double uni = massProperties(csgUnion(wide, b)).volume;
  EXPECT_NEAR(uni, 2 * disc - lens, 0.005 * (2 * disc - lens));
  // The lens is symmetric about x = dist/2.
  EXPECT_NEAR(massProperties(csgIntersection(a, b)).centroid[0], 0.5 * dist, 0.005 * R);
  std::printf("lens: intersection error %.3e, difference error %.3e, union error %.3e\n", (inter - lens) / lens,
              (diff - disc + lens) / (disc - lens), (uni - 2 * disc + lens) / (2 * disc - lens));
}

// Two overlapping balls, grid versus grid with different spacings: lens volume.
TEST(Csg, LensVolume3D) {
  const double R = 0.5, dist = 0.5;
  const Vec<3> ca = Vec<3>::Zero(), cb(dist, 0.0, 0.0);
  const Grid<3> a = sampled<3>(boxAround<3>(ca, R), 0.04, [&](const Vec<3>& x) { return (x - ca).norm() - R; });
  const Grid<3> b = sampled<3>(boxAround<3>(cb, R), 0.033, [&](const Vec<3>& x) { return (x - cb).norm() - R; });
  const double lens = kPi * (4 * R + dist) * (2 * R - dist) * (2 * R - dist) / 12.0;
  const double V = 4.0 / 3.0 * kPi * R * R * R;
  EXPECT_NEAR(massProperties(csgIntersection(a, b)).volume, lens, 0.005 * lens);
  EXPECT_NEAR(massProperties(csgDifference(a, b)).volume, V - lens, 0.005 * (V - lens));
}

// Grid operands are read with Grid::value at a's nodes: multilinear inside b's
// box (exact for a linear field), the distance-like extension outside it;
// same-layout grids combine node values exactly.
TEST(Csg, SamplesSecondGridAtFirstGridsNodes) {
  auto linear = [](const Vec<3>& x) { return 0.3 * x[0] - 0.5 * x[1] + 0.2 * x[2] + 0.1; };
  const Grid<3> a(Index<3>(9, 8, 7), Vec<3>(-0.4, -0.35, -0.3), 0.1, -10.0f);
  Grid<3> b(Index<3>(6, 6, 6), Vec<3>(-0.2, -0.19, -0.21), 0.0731);
  for (std::size_t n = 0; n < b.size(); ++n) b[n] = float(linear(b.nodePosition(b.unlinear(n))));
  const Grid<3> inter = csgIntersection(a, b);
  for (std::size_t n = 0; n < a.size(); ++n) {
    const Vec<3> x = a.nodePosition(a.unlinear(n));
    EXPECT_EQ(inter[n], float(std::max(-10.0, b.value(x))));
    if (b.contains(x)) {
      EXPECT_NEAR(inter[n], linear(x), 1e-6);
    }
  }
  // A node outside b's box gets the extension phi(c) + |x - c|.
  const Index<3> corner(0, 0, 0);
  const Vec<3> xc = a.nodePosition(corner);
  ASSERT_FALSE(b.contains(xc));
  const Vec<3> cc = xc.cwiseMax(b.bounds().lower).cwiseMin(b.bounds().upper);
  EXPECT_NEAR(inter.at(corner), b.value(cc) + (xc - cc).norm(), 1e-5);

  // Same layout: exact node-wise max / min.
  Grid<3> c = a;
  for (std::size_t n = 0; n < c.size(); ++n) c[n] = float(std::sin(0.37 * double(n)));
  Grid<3> e(a.dims(), a.origin(), a.spacing());
  for (std::size_t n = 0; n < e.size(); ++n) e[n] = float(std::cos(0.11 * double(n)));
  const Grid<3> u = csgUnion(c, e), m = csgDifference(c, e), i = csgIntersection(c, e);
  for (std::size_t n = 0; n < c.size(); ++n) {
    EXPECT_EQ(u[n], std::min(c[n], e[n]));
    EXPECT_EQ(m[n], std::max(c[n], -e[n]));
    EXPECT_EQ(i[n], std::max(c[n], e[n]));
  }
  EXPECT_EQ(u.origin(), c.origin());
  EXPECT_EQ(u.spacing(), c.spacing());
  EXPECT_TRUE((u.dims() == c.dims()).all());
}

TEST(Csg, RejectsBadInput) {
  const Grid<2> a(Index<2>(4, 4), Vec<2>::Zero(), 0.1, 1.0f);
  EXPECT_THROW(csgDifference(a, Grid<2>()), std::invalid_argument);
  EXPECT_THROW(csgUnion(Grid<2>(), a), std::invalid_argument);
  EXPECT_THROW(csgIntersection(a, SignedDistance<2>()), std::invalid_argument);
  EXPECT_THROW(csgDifference<2>(a, [](const Vec<2>&) { return std::numeric_limits<double>::quiet_NaN(); }),
               std::invalid_argument);
}
