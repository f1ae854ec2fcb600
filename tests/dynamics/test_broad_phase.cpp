#include "lsdem/dynamics/BroadPhase.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

using IdPair = std::pair<std::uint64_t, std::uint64_t>;

// Bodies as the broad phase sees them: centroids (m), bounding radii (m), global ids.
template <int D>
struct Cloud {
  std::vector<Vec<D>> positions;
  std::vector<double> radii;
  std::vector<std::uint64_t> ids;

  void add(const Vec<D>& x, double r) {
    positions.push_back(x);
    radii.push_back(r);
    // An odd multiplier is a bijection of 64-bit integers: unique ids spread over
    // all 64 bits, in no particular order.
    ids.push_back(std::uint64_t(ids.size() + 1) * 0x9E3779B97F4A7C15ULL);
  }
  std::size_t size() const { return positions.size(); }
};

template <int D>
Vec<D> uniformIn(std::mt19937_64& rng, double lo, double hi) {
  std::uniform_real_distribution<double> u(lo, hi);
  Vec<D> x;
  for (int a = 0; a < D; ++a) x[a] = u(rng);
  return x;
}

template <int D>
Vec<D> gaussian(std::mt19937_64& rng, double sigma) {
  std::normal_distribution<double> g(0.0, sigma);
  Vec<D> x;
  for (int a = 0; a < D; ++a) x[a] = g(rng);
  return x;
}

// The reference: every pair tested, with the same sphere test as the broad phase
// (|x_j - x_i|^2 < ((r_i + skin) + (r_j + skin))^2), as id pairs in canonical order.
template <int D>
std::vector<IdPair> bruteForce(const Cloud<D>& c, double skin) {
  std::vector<IdPair> out;
  for (std::size_t i = 0; i < c.size(); ++i) {
    for (std::size_t j = i + 1; j < c.size(); ++j) {
      const double sumR = (c.radii[i] + skin) + (c.radii[j] + skin);
      if ((c.positions[j] - c.positions[i]).squaredNorm() < sumR * sumR) {
        out.emplace_back(std::min(c.ids[i], c.ids[j]), std::max(c.ids[i], c.ids[j]));
      }
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The broad phase's pairs as id pairs, in its own order (not re-sorted).
template <int D>
std::vector<IdPair> idPairs(const BroadPhase<D>& bp, const Cloud<D>& c) {
  std::vector<IdPair> out;
  for (const auto& p : bp.pairs()) out.emplace_back(c.ids[p[0]], c.ids[p[1]]);
  return out;
}

// Equal spheres (r = 0.5) at random in a box: about 3 neighbours each.
template <int D>
Cloud<D> uniformCloud(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const double side = std::pow(double(n) * (D == 2 ? 1.2 : 1.0), 1.0 / D);
  Cloud<D> c;
  for (std::size_t i = 0; i < n; ++i) c.add(uniformIn<D>(rng, 0.0, side), 0.5);
  return c;
}

// Bimodal 100:1: big grains (r = 1) and tiny fragments (r = 0.01), the fragments
// in small clumps near the grains' surfaces, so big-big, big-tiny and tiny-tiny
// pairs all occur.
template <int D>
Cloud<D> bimodalCloud(std::size_t nBig, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const double side = 2.2 * std::pow(double(nBig), 1.0 / D);
  Cloud<D> c;
  for (std::size_t i = 0; i < nBig; ++i) c.add(uniformIn<D>(rng, 0.0, side), 1.0);
  for (std::size_t i = 0; i < nBig; ++i) {
    const Vec<D> dir = gaussian<D>(rng, 1.0).normalized();
    const Vec<D> centre = c.positions[i] + 1.0 * dir;
    for (int k = 0; k < 10; ++k) c.add(centre + gaussian<D>(rng, 0.03), 0.01);
  }
  return c;
}

// Gaussian clusters of bodies with radii uniform in [0.2, 1].
template <int D>
Cloud<D> clusteredCloud(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> r(0.2, 1.0);
  std::vector<Vec<D>> centres;
  for (int k = 0; k < 12; ++k) centres.push_back(uniformIn<D>(rng, -40.0, 40.0));
  Cloud<D> c;
  for (std::size_t i = 0; i < n; ++i) c.add(centres[i % centres.size()] + gaussian<D>(rng, D == 2 ? 4.0 : 2.0), r(rng));
  return c;
}

// A few huge bodies (r = 10) among many tiny ones (r = 0.1).
template <int D>
Cloud<D> hugeAmongTinyCloud(std::size_t nTiny, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const double side = (D == 2 ? 0.35 : 0.25) * std::pow(double(nTiny), 1.0 / D);
  Cloud<D> c;
  for (std::size_t i = 0; i < nTiny; ++i) c.add(uniformIn<D>(rng, -side, side), 0.1);
  for (int k = 0; k < 3; ++k) c.add(uniformIn<D>(rng, -side, side), 10.0);
  return c;
}

// Radii log-uniform in [0.01, 1]: a continuous 100:1 size range.
template <int D>
Cloud<D> continuousSizesCloud(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> e(std::log(0.01), std::log(1.0));
  const double side = 0.6 * std::pow(double(n), 1.0 / D);
  Cloud<D> c;
  for (std::size_t i = 0; i < n; ++i) c.add(uniformIn<D>(rng, 0.0, side), std::exp(e(rng)));
  return c;
}

// Number of pairs whose two radii are (big, big), (big, small), (small, small) about `split`.
template <int D>
std::array<int, 3> pairKinds(const BroadPhase<D>& bp, const Cloud<D>& c, double split) {
  std::array<int, 3> k{0, 0, 0};
  for (const auto& p : bp.pairs()) ++k[int(c.radii[p[0]] < split) + int(c.radii[p[1]] < split)];
  return k;
}

template <class Dim>
class BroadPhaseTest : public ::testing::Test {};
using Dims = ::testing::Types<std::integral_constant<int, 2>, std::integral_constant<int, 3>>;
TYPED_TEST_SUITE(BroadPhaseTest, Dims);

}  // namespace

// Three spheres on a line, r = 1, skin 0.1 (grown radius 1.1): centres 2.1 apart
// are candidates (2.1 < 2.2), 2.4 apart are not.
TYPED_TEST(BroadPhaseTest, HandCheckedLine) {
  constexpr int D = TypeParam::value;
  Cloud<D> c;
  c.add(Vec<D>::Zero(), 1.0);
  c.add(Vec<D>::Unit(0) * 2.1, 1.0);
  c.add(Vec<D>::Unit(0) * 4.5, 1.0);
  BroadPhase<D> bp({.skin = 0.1});
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
  ASSERT_EQ(bp.pairs().size(), 1u);
  const std::array<std::uint32_t, 2> p = bp.pairs()[0];
  EXPECT_EQ(std::min(p[0], p[1]), 0u);
  EXPECT_EQ(std::max(p[0], p[1]), 1u);
  EXPECT_LT(c.ids[p[0]], c.ids[p[1]]);
  EXPECT_EQ(bp.skin(), 0.1);
}

// Equal sizes: exactly the brute-force pair set, explicit and default skin.
TYPED_TEST(BroadPhaseTest, UniformSizesMatchBruteForce) {
  constexpr int D = TypeParam::value;
  const Cloud<D> c = uniformCloud<D>(3000, 1);
  for (const double skin : {0.0, 0.2}) {
    BroadPhase<D> bp({.skin = skin});
    bp.update(c.positions, c.radii, c.ids);
    const double used = skin == 0.0 ? 0.05 : skin;
    EXPECT_EQ(bp.skin(), used);
    const std::vector<IdPair> ref = bruteForce(c, used);
    EXPECT_GT(ref.size(), c.size());
    EXPECT_EQ(idPairs(bp, c), ref);
    EXPECT_EQ(bp.levels(), 1);
  }
}

// Bimodal 100:1 sizes: exact pair set, with pairs of all three kinds present.
TYPED_TEST(BroadPhaseTest, Bimodal100To1MatchesBruteForce) {
  constexpr int D = TypeParam::value;
  const Cloud<D> c = bimodalCloud<D>(300, 2);
  BroadPhase<D> bp;  // default skin: 0.1 x 0.01
  bp.update(c.positions, c.radii, c.ids);
  EXPECT_DOUBLE_EQ(bp.skin(), 0.001);
  EXPECT_EQ(idPairs(bp, c), bruteForce(c, bp.skin()));
  EXPECT_EQ(bp.levels(), 2);
  const auto kinds = pairKinds(bp, c, 0.5);
  EXPECT_GT(kinds[0], 10);   // big-big
  EXPECT_GT(kinds[1], 100);  // big-tiny
  EXPECT_GT(kinds[2], 100);  // tiny-tiny
}

// Clusters with radii in [0.2, 1]: exact pair set.
TYPED_TEST(BroadPhaseTest, ClusteredMatchesBruteForce) {
  constexpr int D = TypeParam::value;
  const Cloud<D> c = clusteredCloud<D>(3000, 3);
  BroadPhase<D> bp({.skin = 0.05});
  bp.update(c.positions, c.radii, c.ids);
  const std::vector<IdPair> ref = bruteForce(c, 0.05);
  EXPECT_GT(ref.size(), c.size());
  EXPECT_EQ(idPairs(bp, c), ref);
}

// A few huge bodies among many tiny ones (100:1): each huge body has hundreds of
// candidates, all found.
TYPED_TEST(BroadPhaseTest, HugeAmongTinyMatchesBruteForce) {
  constexpr int D = TypeParam::value;
  const Cloud<D> c = hugeAmongTinyCloud<D>(3000, 4);
  BroadPhase<D> bp({.skin = 0.01});
  bp.update(c.positions, c.radii, c.ids);
  EXPECT_EQ(idPairs(bp, c), bruteForce(c, 0.01));
  const auto kinds = pairKinds(bp, c, 1.0);
  EXPECT_GT(kinds[1], 200);  // huge-tiny
  EXPECT_GT(kinds[2], 200);  // tiny-tiny
}

// Continuous sizes over 100:1: grown diameters 0.022..2.002 m fill the levels
// (2.002 / 2^k, 2.002 / 2^(k+1)] for k = 0..6; exact pair set.
TYPED_TEST(BroadPhaseTest, ContinuousSizesMatchBruteForce) {
  constexpr int D = TypeParam::value;
  const Cloud<D> c = continuousSizesCloud<D>(3000, 5);
  BroadPhase<D> bp;
  bp.update(c.positions, c.radii, c.ids);
  EXPECT_EQ(bp.levels(), 7);
  const std::vector<IdPair> ref = bruteForce(c, bp.skin());
  EXPECT_GT(ref.size(), 500u);
  EXPECT_EQ(idPairs(bp, c), ref);
}

// Output order: ids[i] < ids[j] in every pair, pairs strictly increasing in (id, id).
TYPED_TEST(BroadPhaseTest, CanonicalIdOrder) {
  constexpr int D = TypeParam::value;
  const Cloud<D> c = clusteredCloud<D>(2000, 6);
  BroadPhase<D> bp({.skin = 0.1});
  bp.update(c.positions, c.radii, c.ids);
  const std::vector<IdPair> got = idPairs(bp, c);
  ASSERT_FALSE(got.empty());
  for (std::size_t k = 0; k < got.size(); ++k) {
    EXPECT_LT(got[k].first, got[k].second);
    if (k > 0) {
      EXPECT_LT(got[k - 1], got[k]);
    }
  }
}

// Storing the bodies in another order gives the same list of id pairs.
TYPED_TEST(BroadPhaseTest, StorageOrderDoesNotMatter) {
  constexpr int D = TypeParam::value;
  const Cloud<D> c = bimodalCloud<D>(200, 7);
  std::vector<std::size_t> perm(c.size());
  std::iota(perm.begin(), perm.end(), std::size_t(0));
  std::mt19937_64 rng(70);
  std::shuffle(perm.begin(), perm.end(), rng);
  Cloud<D> shuffled;
  for (const std::size_t i : perm) {
    shuffled.positions.push_back(c.positions[i]);
    shuffled.radii.push_back(c.radii[i]);
    shuffled.ids.push_back(c.ids[i]);
  }
  BroadPhase<D> a({.skin = 0.002}), b({.skin = 0.002});
  a.update(c.positions, c.radii, c.ids);
  b.update(shuffled.positions, shuffled.radii, shuffled.ids);
  ASSERT_GT(a.pairs().size(), 100u);
  EXPECT_EQ(idPairs(a, c), idPairs(b, shuffled));
}

// Moves below skin/2 keep the list, and it still holds every pair that truly
// overlaps (and every pair closer than one skin); one move beyond skin/2 rebuilds.
TYPED_TEST(BroadPhaseTest, SkinKeepsListValidAndTriggersRebuild) {
  constexpr int D = TypeParam::value;
  Cloud<D> c = clusteredCloud<D>(2000, 8);
  const double skin = 0.1;
  BroadPhase<D> bp({.skin = skin});
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
  EXPECT_EQ(bp.rebuilds(), 1u);
  const std::vector<IdPair> before = bruteForce(c, 0.0);
  const std::vector<Vec<D>> built = c.positions;

  // Small random moves, each shorter than skin/2.
  std::mt19937_64 rng(80);
  std::uniform_real_distribution<double> len(0.0, 0.499 * skin);
  for (Vec<D>& x : c.positions) x += len(rng) * gaussian<D>(rng, 1.0).normalized();
  EXPECT_FALSE(bp.update(c.positions, c.radii, c.ids));
  EXPECT_EQ(bp.rebuilds(), 1u);
  const std::vector<IdPair> list = idPairs(bp, c);
  std::vector<IdPair> sortedList = list;
  std::sort(sortedList.begin(), sortedList.end());
  const std::vector<IdPair> touching = bruteForce(c, 0.0);
  const std::vector<IdPair> withinSkin = bruteForce(c, 0.5 * skin);
  EXPECT_NE(touching, before);  // the moves changed which pairs touch
  EXPECT_TRUE(std::includes(sortedList.begin(), sortedList.end(), touching.begin(), touching.end()));
  EXPECT_TRUE(std::includes(sortedList.begin(), sortedList.end(), withinSkin.begin(), withinSkin.end()));

  // One body 0.51 skin away from where it was at the build: rebuild, and the
  // list is exact again.
  c.positions[17] = built[17] + Vec<D>::Unit(0) * (0.51 * skin);
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
  EXPECT_EQ(bp.rebuilds(), 2u);
  EXPECT_EQ(idPairs(bp, c), bruteForce(c, skin));
  EXPECT_FALSE(bp.update(c.positions, c.radii, c.ids));
}

// What else rebuilds: invalidate(), a changed count, a replaced body (id), a
// radius that grew past the skin budget. A radius that shrank does not.
TYPED_TEST(BroadPhaseTest, RebuildTriggers) {
  constexpr int D = TypeParam::value;
  Cloud<D> c = uniformCloud<D>(500, 9);
  BroadPhase<D> bp({.skin = 0.1});
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
  EXPECT_FALSE(bp.update(c.positions, c.radii, c.ids));
  bp.invalidate();
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
  c.add(Vec<D>::Zero(), 0.5);
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
  c.ids[3] = 12345;
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
  c.radii[5] -= 0.2;
  EXPECT_FALSE(bp.update(c.positions, c.radii, c.ids));
  c.radii[5] += 0.26;
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
  EXPECT_EQ(bp.rebuilds(), 5u);
  EXPECT_EQ(idPairs(bp, c), bruteForce(c, 0.1));
}

// No bodies and one body: no pairs; a second identical call does not rebuild.
TYPED_TEST(BroadPhaseTest, EmptyAndSingle) {
  constexpr int D = TypeParam::value;
  Cloud<D> c;
  BroadPhase<D> bp;
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
  EXPECT_TRUE(bp.pairs().empty());
  EXPECT_FALSE(bp.update(c.positions, c.radii, c.ids));
  c.add(Vec<D>::Ones(), 0.3);
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
  EXPECT_TRUE(bp.pairs().empty());
  EXPECT_DOUBLE_EQ(bp.skin(), 0.03);
  EXPECT_FALSE(bp.update(c.positions, c.radii, c.ids));
  EXPECT_EQ(bp.rebuilds(), 2u);
}

// Unbounded domain: negative coordinates, copies of a cloud 2^20 (3D) or 2^30
// (2D) cells away (where any scheme packing wrapped coordinates into one key
// would merge cells), far outliers (1e200 m, -3e15 m), two coincident bodies.
TYPED_TEST(BroadPhaseTest, UnboundedDomainFarApartCopies) {
  constexpr int D = TypeParam::value;
  Cloud<D> base = uniformCloud<D>(400, 10);
  // Radius 0.5, skin 0.5: the base cell is exactly 2 m.
  const double wrap = 2.0 * std::ldexp(1.0, D == 2 ? 30 : 20);
  Cloud<D> c;
  for (std::size_t i = 0; i < base.size(); ++i) {
    c.add(base.positions[i] - Vec<D>::Constant(7.0), 0.5);
    c.add(base.positions[i] - Vec<D>::Constant(7.0) + Vec<D>::Unit(0) * wrap, 0.5);
    c.add(base.positions[i] + Vec<D>::Constant(-wrap), 0.5);
  }
  c.add(Vec<D>::Constant(1e200), 0.5);
  c.add(Vec<D>::Constant(1e200), 0.5);
  c.add(Vec<D>::Constant(-3e15), 0.5);
  BroadPhase<D> bp({.skin = 0.5});
  bp.update(c.positions, c.radii, c.ids);
  const std::vector<IdPair> ref = bruteForce(c, 0.5);
  EXPECT_GT(ref.size(), 3 * base.size());
  EXPECT_EQ(idPairs(bp, c), ref);
}

// Size ratio 10^6:1, beyond the 15 levels: the tiniest bodies share the last
// level with the larger small ones; still the exact pair set.
TYPED_TEST(BroadPhaseTest, ExtremeSizeRatio) {
  constexpr int D = TypeParam::value;
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Cloud<D> c;
  for (int i = 0; i < 200; ++i) c.add(uniformIn<D>(rng, 0.0, 12.0), 1.0);
  for (int i = 0; i < 200; ++i) {
    const Vec<D> centre = c.positions[i] + gaussian<D>(rng, 1.0).normalized();
    for (int k = 0; k < 5; ++k) c.add(centre + gaussian<D>(rng, 2e-6), 1e-6);
    for (int k = 0; k < 5; ++k) c.add(centre + gaussian<D>(rng, 2e-4), 1e-4 * (1.0 + 0.5 * u(rng)));
  }
  BroadPhase<D> bp;  // skin 1e-7
  bp.update(c.positions, c.radii, c.ids);
  // Occupied levels: 0 (r = 1), 12 and 13 (r ~ 1e-4), and the last, 14
  // (diameters <= 2 / 2^14), shared by the smallest 1e-4 bodies and the 1e-6 ones.
  EXPECT_EQ(bp.levels(), 4);
  const std::vector<IdPair> ref = bruteForce(c, bp.skin());
  EXPECT_EQ(idPairs(bp, c), ref);
  const auto kinds = pairKinds(bp, c, 1e-5);
  EXPECT_GT(kinds[2], 100);  // pairs of the 1e-6 bodies
}

// Zero radii and zero skin: no pairs at all, not even two coincident bodies,
// since the test is strict (|x_i - x_j|^2 < 0 never holds); any motion rebuilds.
TYPED_TEST(BroadPhaseTest, ZeroRadiiAndZeroSkin) {
  constexpr int D = TypeParam::value;
  Cloud<D> c = uniformCloud<D>(100, 14);
  std::fill(c.radii.begin(), c.radii.end(), 0.0);
  c.positions[1] = c.positions[0];
  BroadPhase<D> bp;
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
  EXPECT_EQ(bp.skin(), 0.0);
  EXPECT_TRUE(bp.pairs().empty());
  EXPECT_FALSE(bp.update(c.positions, c.radii, c.ids));
  c.positions[5][0] += 1e-12;
  EXPECT_TRUE(bp.update(c.positions, c.radii, c.ids));
}

// Bad input names the parameter and throws.
TYPED_TEST(BroadPhaseTest, RejectsBadInput) {
  constexpr int D = TypeParam::value;
  EXPECT_THROW(BroadPhase<D>({.skin = -1.0}), std::invalid_argument);
  EXPECT_THROW(BroadPhase<D>({.skin = std::numeric_limits<double>::quiet_NaN()}), std::invalid_argument);
  const Cloud<D> good = uniformCloud<D>(10, 11);
  BroadPhase<D> bp;
  {
    Cloud<D> c = good;
    c.radii.pop_back();
    EXPECT_THROW(bp.update(c.positions, c.radii, c.ids), std::invalid_argument);
  }
  {
    Cloud<D> c = good;
    c.positions[4][0] = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(bp.update(c.positions, c.radii, c.ids), std::invalid_argument);
  }
  {
    Cloud<D> c = good;
    c.radii[2] = -0.1;
    EXPECT_THROW(bp.update(c.positions, c.radii, c.ids), std::invalid_argument);
  }
  {
    Cloud<D> c = good;
    c.radii[2] = std::numeric_limits<double>::infinity();
    EXPECT_THROW(bp.update(c.positions, c.radii, c.ids), std::invalid_argument);
  }
  {
    Cloud<D> c = good;
    c.ids[7] = c.ids[1];
    EXPECT_THROW(bp.update(c.positions, c.radii, c.ids), std::invalid_argument);
  }
  // A failed update leaves the broad phase usable.
  EXPECT_TRUE(bp.update(good.positions, good.radii, good.ids));
  EXPECT_EQ(idPairs(bp, good), bruteForce(good, bp.skin()));
}

// The same pairs for 1 and 2 threads, on enough bodies to run the parallel paths.
TYPED_TEST(BroadPhaseTest, SameResultForOneAndTwoThreads) {
  constexpr int D = TypeParam::value;
  const Cloud<D> c = continuousSizesCloud<D>(20000, 12);
  std::vector<std::array<std::uint32_t, 2>> one, two;
#ifdef _OPENMP
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
#endif
  {
    BroadPhase<D> bp;
    bp.update(c.positions, c.radii, c.ids);
    one = bp.pairs();
  }
#ifdef _OPENMP
  omp_set_num_threads(2);
#endif
  {
    BroadPhase<D> bp;
    bp.update(c.positions, c.radii, c.ids);
    two = bp.pairs();
  }
#ifdef _OPENMP
  omp_set_num_threads(saved);
#endif
  EXPECT_GT(one.size(), 5000u);
  EXPECT_EQ(one, two);
}
