/// @file test_narrow_phase.cpp
/// @brief The narrow phase (eq. 3-4): contact geometry against exact spheres,
/// order independence of the two-sided test, planes and tools, Newton's third
/// law and the balance of moments, shear history keyed by global ids, input
/// checks, and bitwise-identical results for 1 and 2 threads.

#include "support/Shapes.h"
#include "lsdem/dynamics/Integrator.h"
#include "lsdem/dynamics/NarrowPhase.h"
#include "lsdem/geometry/ShapeDef.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <random>

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

using PairList = std::vector<std::array<std::uint32_t, 2>>;
using ShapePtr2 = std::shared_ptr<const geometry::Shape<2>>;

template <int D>
std::shared_ptr<const geometry::Shape<D>> grain(std::uint64_t seed) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::RandomGrain;
  def.grain.equivalentDiameter = 1.0;
  def.grain.elongation = 1.3;
  def.grain.roughness = 0.15;
  def.grain.seed = seed;
  def.cellsAcross = 10;
  def.options.nodesPerCell = 1.0;
  return geometry::buildShape(def);
}

template <int D>
Orientation<D> randomOrientation(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  if constexpr (D == 2) {
    return std::numbers::pi * u(rng);
  } else {
    Eigen::Quaterniond q(u(rng), u(rng), u(rng), u(rng));
    return q.normalized();
  }
}

template <int D>
Spin<D> randomSpin(std::mt19937_64& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  if constexpr (D == 2) {
    return u(rng);
  } else {
    return Vec<3>(u(rng), u(rng), u(rng));
  }
}

template <int D>
Vec<D> randomVector(std::mt19937_64& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  Vec<D> v;
  for (int a = 0; a < D; ++a) v[a] = u(rng);
  return v;
}

// Every pair of particles whose bounding spheres overlap, in canonical order.
template <int D>
PairList allPairs(const Particles<D>& p) {
  PairList pairs;
  for (std::uint32_t i = 0; i < p.size(); ++i) {
    for (std::uint32_t j = i + 1; j < p.size(); ++j) {
      const double reach = p.shape[i]->boundingRadius() + p.shape[j]->boundingRadius();
      if ((p.position[i] - p.position[j]).squaredNorm() < reach * reach) {
        pairs.push_back(p.id[i] < p.id[j] ? std::array<std::uint32_t, 2>{i, j} : std::array<std::uint32_t, 2>{j, i});
      }
    }
  }
  return pairs;
}

// Every pair of particles, in canonical order (ids ascend with the index).
template <int D>
PairList everyPair(const Particles<D>& p) {
  PairList pairs;
  for (std::uint32_t i = 0; i < p.size(); ++i) {
    for (std::uint32_t j = i + 1; j < p.size(); ++j) pairs.push_back({i, j});
  }
  return pairs;
}

// Eight grains of three shapes on a ring of `radius` about the origin (in
// the x-y plane), orientations drawn from `seed`.
template <int D>
Particles<D> ringOfGrains(double radius, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const auto shapes = std::array{grain<D>(1), grain<D>(2), grain<D>(3)};
  Particles<D> p;
  for (int i = 0; i < 8; ++i) {
    ParticleDef<D> def;
    def.shape = shapes[std::size_t(i) % 3];
    const double angle = 2.0 * std::numbers::pi * i / 8.0;
    def.position = Vec<D>::Zero();
    def.position[0] = radius * std::cos(angle);
    def.position[1] = radius * std::sin(angle);
    def.orientation = randomOrientation<D>(rng);
    p.add(def);
  }
  return p;
}

// Two lists of node contacts equal bit for bit: nodes, forces, overlaps.
template <int D>
::testing::AssertionResult sameContacts(std::span<const NodeContact<D>> a, std::span<const NodeContact<D>> b) {
  if (a.size() != b.size()) return ::testing::AssertionFailure() << a.size() << " against " << b.size() << " contacts";
  for (std::size_t k = 0; k < a.size(); ++k) {
    if (a[k].node != b[k].node || std::memcmp(a[k].force.data(), b[k].force.data(), sizeof(Vec<D>)) != 0 ||
        std::memcmp(&a[k].overlap, &b[k].overlap, sizeof(double)) != 0) {
      return ::testing::AssertionFailure() << "node contact " << k << " differs";
    }
  }
  return ::testing::AssertionSuccess();
}

template <int D>
void clearForces(Particles<D>& p) {
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.force[i].setZero();
    p.torque[i] = Rotation<D>::zeroSpin();
  }
}

double spinNorm(double s) { return std::abs(s); }
double spinNorm(const Vec<3>& s) { return s.norm(); }

// eq. 3-4 against exact spheres: every node contact of two overlapping
// spheres lies inside the other sphere by its reported overlap, and its normal
// is the other sphere's radial direction (pointing from b towards a).
template <int D>
void checkSphereGeometry() {
  const auto shape = test::sphereShape<D>(0.5, 20);
  Particles<D> p;
  ParticleDef<D> def;
  def.shape = shape;
  std::mt19937_64 rng(3);
  def.orientation = randomOrientation<D>(rng);
  p.add(def);
  def.orientation = randomOrientation<D>(rng);
  def.position = Vec<D>::Ones().normalized() * 0.97;  // 3 cm overlap
  p.add(def);
  ContactLawDef law;
  law.hasFriction = false;
  law.hasDamping = false;
  ContactSolver<D> solver(law);
  solver.compute(p, {{0, 1}}, {}, {}, 1e-5);
  ASSERT_EQ(solver.pairContacts().size(), 1u);
  std::size_t sides[2] = {0, 0};
  const double h = shape->grid().spacing();
  for (const NodeContact<D>& c : solver.nodeContacts()) {
    const std::size_t other = c.ownerIsB ? 0 : 1;
    const Vec<D> radial = (c.point - p.position[other]).normalized();
    // Depth inside the other sphere (exact surface radius R = 0.5), to the
    // accuracy of multilinear interpolation of its distance: (D-1) h^2 / (8 R).
    EXPECT_NEAR(c.overlap, 0.5 - (c.point - p.position[other]).norm(), 1.1 * (D - 1) * h * h / 4.0);
    // Normal: radial out of the other body, signed to point from b to a, to
    // the accuracy of the interpolated gradient (~ h / (2 R) per axis).
    const Vec<D> expected = c.ownerIsB ? Vec<D>(-radial) : radial;
    EXPECT_GT(c.normal.dot(expected), std::cos(h / 0.5));
    EXPECT_NEAR(c.normal.norm(), 1.0, 1e-12);
    // Linear per-node law with weight 1/2 per direction: F = k delta grad phi,
    // along the normal; |grad phi| of the interpolated distance is 1 to the
    // accuracy of its gradient (~ h / (2 R)).
    const double ratio = c.force.norm() / (0.5 * law.kn * c.overlap);
    EXPECT_NEAR(ratio, 1.0, h / (2 * 0.5));
    EXPECT_TRUE(c.force.isApprox(ratio * 0.5 * law.kn * c.overlap * c.normal, 1e-12));
    ++sides[c.ownerIsB];
  }
  EXPECT_GT(sides[0], 3u);
  EXPECT_GT(sides[1], 3u);
  // The pair force pushes a away from b; the sum of node forces is the pair force.
  const PairContact<D>& pc = solver.pairContacts()[0];
  EXPECT_LT(pc.force.dot(p.position[1] - p.position[0]), 0.0);
  Vec<D> sum = Vec<D>::Zero();
  for (const NodeContact<D>& c : solver.nodeContacts()) sum += c.force;
  EXPECT_TRUE(sum.isApprox(pc.force, 1e-12));
}

// Swapping the roles of a and b (the other particle gets the lower id) gives
// the same forces and torques on each body to round-off, for random grains in
// random overlapping poses with random velocities (damping and friction on).
template <int D>
void checkOrderIndependence() {
  std::mt19937_64 rng(11);
  const auto shapeX = grain<D>(21), shapeY = grain<D>(22);
  ContactLawDef law;  // the paper's law: linear per node, friction, damping
  int tested = 0;
  for (int trial = 0; trial < 20; ++trial) {
    // Pose of Y around X, close enough for the grains to overlap.
    const Orientation<D> qx = randomOrientation<D>(rng), qy = randomOrientation<D>(rng);
    const Vec<D> xy = randomVector<D>(rng, 1.0).normalized() * 0.8;
    const Vec<D> vx = randomVector<D>(rng, 0.5), vy = randomVector<D>(rng, 0.5);
    const Spin<D> wx = randomSpin<D>(rng, 2.0), wy = randomSpin<D>(rng, 2.0);
    // Two stores: X added first (X = a), or Y added first (Y = a).
    Particles<D> stores[2];
    for (int s = 0; s < 2; ++s) {
      for (int k = 0; k < 2; ++k) {
        const bool isX = (k == 0) == (s == 0);
        ParticleDef<D> def;
        def.shape = isX ? shapeX : shapeY;
        def.orientation = isX ? qx : qy;
        def.position = isX ? Vec<D>(Vec<D>::Zero()) : xy;
        def.velocity = isX ? vx : vy;
        def.angularVelocity = isX ? wx : wy;
        stores[s].add(def);
      }
    }
    // Forces after two steps of history (friction), accumulated into the particles.
    Vec<D> force[2][2];
    Spin<D> torque[2][2];
    std::size_t nodes[2];
    for (int s = 0; s < 2; ++s) {
      ContactSolver<D> solver(law);
      for (int k = 0; k < 2; ++k) {
        clearForces(stores[s]);
        solver.compute(stores[s], {{0, 1}}, {}, {}, 1e-4);
        solver.accumulate(stores[s]);
        stores[s].position[0] += 1e-4 * stores[s].velocity[0];
        stores[s].position[1] += 1e-4 * stores[s].velocity[1];
      }
      nodes[s] = solver.nodeContacts().size();
      // Index of X and Y in this store.
      const std::size_t ix = s == 0 ? 0 : 1, iy = 1 - ix;
      force[s][0] = stores[s].force[ix];
      force[s][1] = stores[s].force[iy];
      torque[s][0] = stores[s].torque[ix];
      torque[s][1] = stores[s].torque[iy];
    }
    if (nodes[0] == 0) continue;
    ++tested;
    EXPECT_EQ(nodes[0], nodes[1]);
    const double scale = force[0][0].norm();
    for (int k = 0; k < 2; ++k) {
      EXPECT_LT((force[0][k] - force[1][k]).norm(), 1e-12 * scale) << "trial " << trial;
      EXPECT_LT(spinNorm(torque[0][k] - torque[1][k]), 1e-12 * scale) << "trial " << trial;
    }
    EXPECT_LT((force[0][0] + force[0][1]).norm(), 1e-12 * scale);
  }
  EXPECT_GE(tested, 15);
}

// A dense random cluster of grains in a box of planes with a tool: forces,
// torques and node contacts after a few steps, as raw bytes. The node
// records are read after the last step, or (readEachStep) after every step;
// the last step runs on `lastThreads` threads where > 0.
template <int D>
std::vector<unsigned char> clusterRun(int threads, std::size_t count, const ContactLawDef& law = {},
                                      bool readEachStep = false, int lastThreads = 0) {
#ifdef _OPENMP
  const int before = omp_get_max_threads();
  omp_set_num_threads(threads);
#else
  (void)threads;
#endif
  std::mt19937_64 rng(5);
  const auto shapes = std::array{grain<D>(1), grain<D>(2), grain<D>(3)};
  const auto toolShape = test::sphereShape<D>(1.5, 15);
  Particles<D> p;
  const int perRow = D == 2 ? int(std::ceil(std::sqrt(double(count)))) : int(std::ceil(std::cbrt(double(count))));
  for (std::size_t i = 0; i < count; ++i) {
    ParticleDef<D> def;
    def.shape = shapes[i % 3];
    Vec<D> cell;
    std::size_t r = i;
    for (int a = 0; a < D; ++a) {
      cell[a] = double(r % std::size_t(perRow));
      r /= std::size_t(perRow);
    }
    def.position = 0.85 * cell + randomVector<D>(rng, 0.05);
    def.orientation = randomOrientation<D>(rng);
    def.velocity = randomVector<D>(rng, 0.3);
    def.angularVelocity = randomSpin<D>(rng, 1.0);
    p.add(def);
  }
  const double extent = 0.85 * (perRow - 1);
  std::vector<Plane<D>> planes;
  for (int a = 0; a < D; ++a) {
    planes.push_back(Plane<D>{-0.45 * Vec<D>::Unit(a), Vec<D>::Unit(a), Vec<D>::Zero()});
    planes.push_back(Plane<D>{(extent + 0.45) * Vec<D>::Unit(a), -Vec<D>::Unit(a), Vec<D>::Zero()});
  }
  ToolPose<D> tool;
  tool.shape = toolShape.get();
  tool.position = Vec<D>::Constant(0.5 * extent);
  tool.velocity = Vec<D>::UnitX() * 0.1;
  tool.angularVelocity = randomSpin<D>(rng, 0.5);
  const std::vector<ToolPose<D>> tools{tool};
  ContactSolver<D> solver(law);
  std::vector<unsigned char> bytes;
  const auto append = [&](const void* data, std::size_t size) {
    const auto* b = static_cast<const unsigned char*>(data);
    bytes.insert(bytes.end(), b, b + size);
  };
  const double dt = 2e-5;
  std::size_t readEach = 0;
  for (int s = 0; s < 4; ++s) {
#ifdef _OPENMP
    if (s == 3 && lastThreads > 0) omp_set_num_threads(lastThreads);
#else
    (void)lastThreads;
#endif
    kickDrift(p, dt);
    clearForces(p);
    solver.compute(p, allPairs(p), planes, tools, dt);
    if (readEachStep) readEach += solver.nodeContacts().size() + solver.nodeShear().size();
    const BoundaryLoads<D>& loads = solver.accumulate(p);
    kick(p, dt);
    append(loads.planeForce.data(), loads.planeForce.size() * sizeof(Vec<D>));
    append(loads.toolForce.data(), loads.toolForce.size() * sizeof(Vec<D>));
  }
  EXPECT_GT(solver.particleContacts().size(), count);
  EXPECT_GT(solver.planeContacts().size(), 0u);
  EXPECT_GT(solver.toolContacts().size(), 0u);
  EXPECT_GT(solver.historySize(), 0u);
  if (readEachStep) {
    EXPECT_GT(readEach, 0u);
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    append(&p.force[i], sizeof(Vec<D>));
    append(&p.torque[i], sizeof(Spin<D>));
    append(&p.position[i], sizeof(Vec<D>));
    append(&p.velocity[i], sizeof(Vec<D>));
  }
  // Every particle's shear history, taken before anything else reads the
  // node records (at several threads they are then still in the threads'
  // buffers: particleHistories() copies them first).
  std::vector<std::uint64_t> ids(p.id.begin(), p.id.end());
  std::sort(ids.begin(), ids.end());
  std::size_t historyNodes = 0;
  for (const auto& h : solver.particleHistories(ids)) {
    append(h.pairs.data(), h.pairs.size() * sizeof(h.pairs[0]));
    for (const NodeContact<D>& c : h.nodes) {
      append(c.force.data(), sizeof(Vec<D>));
      append(&c.node, sizeof(c.node));
    }
    append(h.shear.data(), h.shear.size() * sizeof(Vec<D>));
    historyNodes += h.nodes.size();
  }
  EXPECT_GT(historyNodes, 0u);
  for (const NodeContact<D>& c : solver.nodeContacts()) {
    append(c.force.data(), sizeof(Vec<D>));
    append(&c.node, sizeof(c.node));
  }
  // The pair records (whole: no padding) and their node ranges, which
  // follow one another from the first node contact to the last.
  std::size_t next = 0;
  for (const PairContact<D>& pc : solver.pairContacts()) {
    EXPECT_EQ(pc.firstNode, next);
    next += pc.nodeCount;
    append(&pc, sizeof(pc));
  }
  EXPECT_EQ(next, solver.nodeContacts().size());
  for (const Vec<D>& shear : solver.nodeShear()) append(shear.data(), sizeof(Vec<D>));
  const double energy[2] = {solver.elasticEnergy(), solver.dissipatedPower()};
  append(energy, sizeof(energy));
#ifdef _OPENMP
  omp_set_num_threads(before);
#endif
  return bytes;
}

// Newton's third law and the balance of moments over a cluster's particle
// pairs: the forces sum to zero and so do the moments about the origin
// (x_i x F_i + T_i), to round-off.
template <int D>
void checkBalance() {
  std::mt19937_64 rng(8);
  Particles<D> p;
  for (int i = 0; i < 12; ++i) {
    ParticleDef<D> def;
    def.shape = grain<D>(std::uint64_t(i % 3 + 1));
    def.position = randomVector<D>(rng, 0.9);
    def.orientation = randomOrientation<D>(rng);
    def.velocity = randomVector<D>(rng, 0.3);
    def.angularVelocity = randomSpin<D>(rng, 1.0);
    p.add(def);
  }
  ContactSolver<D> solver(ContactLawDef{});
  clearForces(p);
  const PairList pairs = allPairs(p);
  solver.compute(p, pairs, {}, {}, 1e-4);
  solver.accumulate(p);
  ASSERT_GT(solver.particleContacts().size(), 5u);
  Vec<D> total = Vec<D>::Zero();
  Spin<D> moment = Rotation<D>::zeroSpin();
  double scale = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    total += p.force[i];
    moment += Rotation<D>::moment(p.position[i], p.force[i]) + p.torque[i];
    scale = std::max(scale, p.force[i].norm());
  }
  EXPECT_LT(total.norm(), 1e-12 * scale * double(p.size()));
  EXPECT_LT(spinNorm(moment), 1e-12 * scale * double(p.size()));
  // Bulk rejection: the node trees keep fewer nodes than both directions of
  // every pair hold, and what they drop touches nothing. Brute force: every
  // node of every pair whose bounding spheres overlap, in the other body's
  // bounding sphere, against its level set.
  std::uint64_t all = 0;
  std::vector<std::vector<std::uint32_t>> touching;
  for (const auto& [a, b] : pairs) {
    const double reach = p.shape[a]->boundingRadius() + p.shape[b]->boundingRadius();
    if ((p.position[a] - p.position[b]).squaredNorm() > reach * reach) continue;
    all += p.shape[a]->nodes().size() + p.shape[b]->nodes().size();
    for (const auto& [owner, other] : {std::pair{a, b}, std::pair{b, a}}) {
      std::vector<std::uint32_t> inside;
      const auto& nodes = p.shape[owner]->nodes().positions;
      for (std::uint32_t i = 0; i < nodes.size(); ++i) {
        const Vec<D> world = p.rotation(owner) * nodes[i] + p.position[owner];
        const Vec<D> body = p.rotation(other).transpose() * (world - p.position[other]);
        if (body.norm() <= p.shape[other]->boundingRadius() && p.shape[other]->value(body) < 0.0) inside.push_back(i);
      }
      if (!inside.empty()) touching.push_back(inside);
    }
  }
  EXPECT_GT(solver.cellChecks(), 0u);
  EXPECT_LT(solver.nodeChecks(), all / 2);  // measured: 37 % (2D), 14 % (3D)
  std::vector<std::vector<std::uint32_t>> found;
  for (const PairContact<D>& pc : solver.particleContacts()) {
    std::vector<std::uint32_t> side[2];
    for (std::uint32_t k = pc.firstNode; k < pc.firstNode + pc.nodeCount; ++k) {
      const NodeContact<D>& c = solver.nodeContacts()[k];
      side[c.ownerIsB].push_back(c.node);
    }
    for (const auto& s : side) {
      EXPECT_TRUE(std::is_sorted(s.begin(), s.end()));  // node order within a direction
      if (!s.empty()) found.push_back(s);
    }
  }
  EXPECT_EQ(found, touching);
}

}  // namespace

TEST(NarrowPhase, SphereContactGeometry2D) { checkSphereGeometry<2>(); }
TEST(NarrowPhase, SphereContactGeometry3D) { checkSphereGeometry<3>(); }
TEST(NarrowPhase, SwappingThePairGivesEqualAndOppositeForces2D) { checkOrderIndependence<2>(); }
TEST(NarrowPhase, SwappingThePairGivesEqualAndOppositeForces3D) { checkOrderIndependence<3>(); }
TEST(NarrowPhase, ForcesAndMomentsBalance2D) { checkBalance<2>(); }
TEST(NarrowPhase, ForcesAndMomentsBalance3D) { checkBalance<3>(); }

// Separation certificates are exact: eight grains on a ring drawn towards
// its centre by 0.5 % a pass while turning (about a tenth of a cell a pass),
// from apart to pressed together, then pressed on by a hundredth of that a
// pass, around a tool (a grain held at the centre, turning) that they close
// onto. The node contacts with certificates equal those without, bit for
// bit, at every pass; the certificates spare walks (a wrong clearance would
// miss the contacts that appear as the ring closes) and, for the pairs in
// contact, the tree walks (only the leaves a certificate kept are tested).
template <int D>
void checkCertificatesExact(const ContactLawDef& law = {}) {
  Particles<D> p = ringOfGrains<D>(2.0, 21);
  ContactSolver<D> with(law), without(law);
  without.setSeparationCertificates(false);
  const auto hub = grain<D>(4);
  ToolPose<D> tool;
  tool.shape = hub.get();
  std::vector<ToolPose<D>> tools{tool};
  std::uint64_t spared = 0;
  std::size_t passesTouching = 0;
  const auto pairs = allPairs(p);
  std::uint64_t leafOnly = 0, frontier = 0;
  for (int pass = 0; pass < 200; ++pass) {
    const double step = pass < 150 ? 1.0 : 0.01;
    for (std::size_t i = 0; i < p.size(); ++i) {
      p.position[i] *= 1.0 - 0.005 * step;
      if constexpr (D == 2) {
        p.orientation[i] += 0.01 * step;
      } else {
        p.orientation[i] =
            (p.orientation[i] * Eigen::Quaterniond(Eigen::AngleAxisd(0.01 * step, Vec<3>::UnitZ()))).normalized();
      }
    }
    if constexpr (D == 2) {
      tools[0].orientation -= 0.003 * step;
    } else {
      tools[0].orientation =
          (tools[0].orientation * Eigen::Quaterniond(Eigen::AngleAxisd(-0.003 * step, Vec<3>::UnitX()))).normalized();
    }
    with.compute(p, pairs, {}, tools, 1e-6);
    without.compute(p, pairs, {}, tools, 1e-6);
    spared += with.certifiedWalks();
    leafOnly += with.leafWalks();
    frontier += with.frontierWalks();
    EXPECT_EQ(without.leafWalks(), 0u);
    EXPECT_EQ(without.frontierWalks(), 0u);
    EXPECT_EQ(without.certifiedWalks(), 0u);
    ASSERT_TRUE(sameContacts(with.nodeContacts(), without.nodeContacts())) << "pass " << pass;
    passesTouching += !with.nodeContacts().empty();
  }
  EXPECT_GT(spared, 100u);
  EXPECT_GT(leafOnly, 100u);
  EXPECT_GT(frontier, 1000u);  // moves beyond the frontier's least margin: only part of the tree walked again
  EXPECT_GT(passesTouching, 60u);
  EXPECT_GT(with.toolContacts().size(), 0u);  // the ring closed onto the tool
  EXPECT_LT(passesTouching, 190u);  // apart at first: the contacts appear while certificates are in use
  ::testing::Test::RecordProperty("spared_walks", std::to_string(spared));
  ::testing::Test::RecordProperty("leaf_walks", std::to_string(leafOnly));
  ::testing::Test::RecordProperty("frontier_walks", std::to_string(frontier));
}

TEST(NarrowPhase, SeparationCertificatesAreExact2D) { checkCertificatesExact<2>(); }
TEST(NarrowPhase, SeparationCertificatesAreExact3D) { checkCertificatesExact<3>(); }
// The same with the tricubic look-up: its certificates are the multilinear
// ones with the margin Shape::cubicMargin taken off.
TEST(NarrowPhase, SeparationCertificatesAreExactTricubic3D) {
  ContactLawDef law;
  law.interpolation = LevelSetInterpolation::Tricubic;
  checkCertificatesExact<3>(law);
}

// Frontier walks over a long path: a grain rolled around another, touching
// it nearly all the way (in 3D on a spiral from pole to pole), so the
// contact moves over both surfaces and the walks refine their frontiers and
// kept leaves where it passed, until (3D) the growth guard walks the trees
// whole again. The contacts equal those of a solver without certificates,
// bit for bit, at every pass.
template <int D>
void checkFrontierWalksAroundAGrain() {
  Particles<D> p;
  ParticleDef<D> def;
  def.shape = grain<D>(5);
  p.add(def);
  def.shape = grain<D>(6);
  p.add(def);
  ContactSolver<D> with(ContactLawDef{}), without(ContactLawDef{});
  without.setSeparationCertificates(false);
  const PairList pairs{{0, 1}};
  std::uint64_t walks = 0, frontier = 0, others = 0;
  std::size_t touching = 0;
  constexpr int kPasses = 600;
  for (int pass = 0; pass < kPasses; ++pass) {
    const double t = double(pass) / kPasses;
    const double angle = 6.0 * std::numbers::pi * t;  // three turns
    Vec<D> direction = Vec<D>::Zero();
    if constexpr (D == 2) {
      direction << std::cos(angle), std::sin(angle);
      p.orientation[1] = 2.0 * angle;
    } else {
      const double polar = std::numbers::pi * (0.1 + 0.8 * t);
      direction << std::sin(polar) * std::cos(angle), std::sin(polar) * std::sin(angle), std::cos(polar);
      p.orientation[1] = Eigen::Quaterniond(Eigen::AngleAxisd(2.0 * angle, Vec<3>(0.3, 0.2, 1.0).normalized()));
    }
    // In and out by up to 0.6 cells, so contacts come and go along the way.
    p.position[1] = (0.86 + 0.06 * std::sin(40.0 * angle)) * direction;
    with.compute(p, pairs, {}, {}, 1e-6);
    without.compute(p, pairs, {}, {}, 1e-6);
    ASSERT_TRUE(sameContacts(with.nodeContacts(), without.nodeContacts())) << "pass " << pass;
    touching += !with.nodeContacts().empty();
    if (pass > 0) {
      walks += 2;
      frontier += with.frontierWalks();
      others += with.certifiedWalks() + with.leafWalks() + with.frontierWalks();
    }
  }
  EXPECT_GT(touching, std::size_t(kPasses * 3 / 4));
  EXPECT_GT(frontier, walks / 2);  // most walks after the first start from the frontier
  if constexpr (D == 3) {
    EXPECT_GT(walks - others, 0u);  // and the growth guard walked some whole again
  }
}

TEST(NarrowPhase, FrontierWalksAroundAGrain2D) { checkFrontierWalksAroundAGrain<2>(); }
TEST(NarrowPhase, FrontierWalksAroundAGrain3D) { checkFrontierWalksAroundAGrain<3>(); }

// Certificates under random motion: twelve grains about a turning tool,
// each step in one of five regimes (at rest, jitter of 1e-4, 3e-3, 0.02 or
// 0.1 grain diameters with turns to match, so moves go back and forth and
// from far below to far above the margins), pulled back towards a ring that
// breathes in and out; the pair list is sometimes every pair, sometimes
// shuffled (certificates found by ids, not slots), the tool's pairs
// sometimes limited, and each step runs on 1 to 3 threads (lists made on
// one thread read on another). Three planes: one under the ring, moving
// up and down and tilting, one at its side that breathes with it, one
// out of reach of every grain. Contacts equal those without certificates,
// bit for bit, at every step.
template <int D>
void checkCertificatesUnderRandomMotion(std::uint64_t seed, int steps) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), u01(0.0, 1.0);
  const auto shapes = std::array{grain<D>(1), grain<D>(2), grain<D>(3)};
  const auto hub = grain<D>(4);
  Particles<D> p;
  std::vector<Vec<D>> ring;
  for (int i = 0; i < 12; ++i) {
    ParticleDef<D> def;
    def.shape = shapes[std::size_t(i) % 3];
    def.position = Vec<D>::Zero();
    def.position[0] = 1.6 * std::cos(2.0 * std::numbers::pi * i / 12.0);
    def.position[1] = 1.6 * std::sin(2.0 * std::numbers::pi * i / 12.0);
    def.orientation = randomOrientation<D>(rng);
    ring.push_back(def.position);
    p.add(def);
  }
  std::vector<ToolPose<D>> tools(1);
  tools[0].shape = hub.get();
  std::vector<Plane<D>> planes(3);
  planes[2].point[1] = 10.0;  // out of reach
  ContactSolver<D> with(ContactLawDef{}), without(ContactLawDef{});
  without.setSeparationCertificates(false);
  std::vector<std::array<std::uint64_t, 2>> limit;
  std::uint64_t contacts = 0, planeContacts = 0, frontier = 0, leaf = 0, spared = 0;
#ifdef _OPENMP
  const int threadsBefore = omp_get_max_threads();
#endif
  for (int step = 0; step < steps; ++step) {
    const double r = u01(rng);
    const double amplitude = r < 0.2 ? 0.0 : r < 0.5 ? 1e-4 : r < 0.8 ? 3e-3 : r < 0.95 ? 0.02 : 0.1;
    const double breathing = 0.75 + 0.2 * std::sin(0.02 * step);
    for (std::size_t i = 0; i < p.size(); ++i) {
      p.position[i] += randomVector<D>(rng, amplitude);
      p.position[i] += 0.05 * (breathing * ring[i] - p.position[i]);
      if constexpr (D == 2) {
        p.orientation[i] += 3.0 * amplitude * u(rng);
      } else {
        const Vec<3> axis = Vec<3>(u(rng), u(rng), u(rng)).normalized();
        p.orientation[i] = (p.orientation[i] * Eigen::Quaterniond(Eigen::AngleAxisd(3.0 * amplitude * u(rng), axis)))
                               .normalized();
      }
    }
    if constexpr (D == 2) {
      tools[0].orientation += 2.0 * amplitude * u(rng);
    } else {
      tools[0].orientation =
          (tools[0].orientation * Eigen::Quaterniond(Eigen::AngleAxisd(2.0 * amplitude * u(rng), Vec<3>::UnitX())))
              .normalized();
    }
    planes[0].normal = Vec<D>::UnitY();
    planes[0].normal[0] = 0.1 * std::sin(0.03 * step) + amplitude * u(rng);
    planes[0].normal.normalize();
    planes[0].point = Vec<D>::Zero();
    planes[0].point[1] = -1.6 * breathing - 0.2 + 0.05 * std::sin(0.1 * step) + amplitude * u(rng);
    planes[1].normal = -Vec<D>::UnitX();
    planes[1].point = Vec<D>::Zero();
    planes[1].point[0] = 1.6 * breathing + 0.3;
    // The broad phase's list, or every pair (certificates of pairs apart).
    PairList pairs = u01(rng) < 0.5 ? allPairs(p) : everyPair(p);
    if (u01(rng) < 0.3) std::shuffle(pairs.begin(), pairs.end(), rng);
    if (u01(rng) < 0.3) {
      limit.clear();
      for (std::size_t i = 0; i < p.size(); ++i) {
        if (u01(rng) < 0.5) limit.push_back({p.id[i], 0});
      }
      with.limitToolPairs(std::span<const std::array<std::uint64_t, 2>>(limit));
      without.limitToolPairs(std::span<const std::array<std::uint64_t, 2>>(limit));
    } else {
      with.limitToolPairs(std::nullopt);
      without.limitToolPairs(std::nullopt);
    }
    const int threads = 1 + int(rng() % 3);
#ifdef _OPENMP
    omp_set_num_threads(threads);
#endif
    (void)threads;
    with.compute(p, pairs, planes, tools, 1e-6);
    without.compute(p, pairs, planes, tools, 1e-6);
    ASSERT_TRUE(sameContacts(with.nodeContacts(), without.nodeContacts())) << "step " << step;
    contacts += without.nodeContacts().size();
    planeContacts += without.planeContacts().size();
    frontier += with.frontierWalks();
    leaf += with.leafWalks();
    spared += with.certifiedWalks();
  }
#ifdef _OPENMP
  omp_set_num_threads(threadsBefore);
#endif
  EXPECT_GT(contacts, std::uint64_t(steps) * 20);  // the grains touch each other and the tool
  EXPECT_GT(planeContacts, std::uint64_t(steps));  // and the two planes in reach
  EXPECT_GT(frontier, std::uint64_t(steps));
  EXPECT_GT(leaf, std::uint64_t(steps));
  EXPECT_GT(spared, std::uint64_t(steps));
}

TEST(NarrowPhase, CertificatesStayExactUnderRandomMotion2D) { checkCertificatesUnderRandomMotion<2>(1, 300); }
TEST(NarrowPhase, CertificatesStayExactUnderRandomMotion3D) { checkCertificatesUnderRandomMotion<3>(2, 120); }

// The tricubic look-up's contacts are exactly those of testing every node
// of every pair against the other body's Catmull-Rom interpolant: the
// bulk rejection (multilinear, lowered by Shape::cubicMargin) and the cubic
// bounding radius lose none. The overlaps are the interpolant's values.
template <int D>
void checkTricubicAgainstBruteForce() {
  const Particles<D> p = ringOfGrains<D>(1.2, 5);
  const PairList pairs = everyPair(p);
  ContactLawDef law;
  law.interpolation = LevelSetInterpolation::Tricubic;
  ContactSolver<D> solver(law);
  solver.setSeparationCertificates(false);
  solver.compute(p, pairs, {}, {}, 1e-6);
  std::size_t expected = 0;
  double expectedOverlap = 0.0;
  for (const auto& [a, b] : pairs) {
    for (const auto& [owner, other] : {std::pair{a, b}, std::pair{b, a}}) {
      const geometry::Shape<D>& so = *p.shape[owner];
      const geometry::Shape<D>& st = *p.shape[other];
      const geometry::Grid<D>& grid = st.grid();
      for (const Vec<D>& x : so.nodes().positions) {
        const Vec<D> world = p.position[owner] + p.rotation(owner) * x;
        const Vec<D> body = p.rotation(other).transpose() * (world - p.position[other]);
        const Vec<D> g = grid.toGrid(st.bodyToGrid().apply(body));
        if (!grid.contains(grid.toWorld(g))) continue;
        const double phi = grid.cubicValueAtCells(g);
        if (phi < 0.0) {
          ++expected;
          expectedOverlap -= phi;
        }
      }
    }
  }
  double overlap = 0.0;
  for (const NodeContact<D>& c : solver.nodeContacts()) overlap += c.overlap;
  EXPECT_GT(expected, 20u);
  EXPECT_EQ(solver.nodeContacts().size(), expected);
  EXPECT_NEAR(overlap, expectedOverlap, 1e-9 * expectedOverlap);
}

TEST(NarrowPhase, TricubicContactsMatchBruteForce2D) { checkTricubicAgainstBruteForce<2>(); }
TEST(NarrowPhase, TricubicContactsMatchBruteForce3D) { checkTricubicAgainstBruteForce<3>(); }

// Node margins: a pressed ring computed twice at the same state. The second
// step is a leaf walk for every touching direction, and a node of a kept
// leaf is tested only when its margin from the first step does not clear
// it (those inside, which the force needs, and none that are clear by more
// than the slack), and no leaf cell is tested again: so the nodes tested
// equal the node contacts, against
// more than twice as many in the first step, and the contacts and forces
// are those of a solver without certificates, bit for bit.
template <int D>
void checkNodeMargins() {
  const Particles<D> p = ringOfGrains<D>(1.2, 5);
  const auto pairs = allPairs(p);
  ContactSolver<D> with(ContactLawDef{}), without(ContactLawDef{});
  without.setSeparationCertificates(false);
  with.compute(p, pairs, {}, {}, 1e-6);
  const std::uint64_t firstChecks = with.nodeChecks();
  with.compute(p, pairs, {}, {}, 1e-6);
  without.compute(p, pairs, {}, {}, 1e-6);
  const std::size_t contacts = with.nodeContacts().size();
  ASSERT_GE(with.particleContacts().size(), 4u);
  EXPECT_GE(with.leafWalks(), with.particleContacts().size());
  EXPECT_EQ(with.nodeChecks(), contacts);
  EXPECT_GT(firstChecks, 2 * contacts);
  // Every kept leaf's cell test holds its outcome (rejected or passed) by
  // its margin: none is made again.
  EXPECT_EQ(with.cellChecks(), 0u);
  EXPECT_TRUE(sameContacts(with.nodeContacts(), without.nodeContacts()));
}

TEST(NarrowPhase, NodeMarginsSpareClearNodes2D) { checkNodeMargins<2>(); }
TEST(NarrowPhase, NodeMarginsSpareClearNodes3D) { checkNodeMargins<3>(); }

TEST(NarrowPhase, OneAndTwoThreadsAreBitwiseIdentical) {
#ifndef _OPENMP
  GTEST_SKIP() << "built without OpenMP";
#else
  const std::vector<unsigned char> one2 = clusterRun<2>(1, 300), two2 = clusterRun<2>(2, 300);
  ASSERT_EQ(one2.size(), two2.size());
  EXPECT_EQ(std::memcmp(one2.data(), two2.data(), one2.size()), 0);
  const std::vector<unsigned char> one3 = clusterRun<3>(1, 64), two3 = clusterRun<3>(2, 64);
  ASSERT_EQ(one3.size(), two3.size());
  EXPECT_EQ(std::memcmp(one3.data(), two3.data(), one3.size()), 0);
  // Three and four threads: parts shared by two threads, and by a thread
  // alone, threads that help with another part, a first thread whose
  // buffers are not the output (more threads than this machine's cores is
  // fine: only the schedule changes).
  for (const int threads : {3, 4, 5}) {
    EXPECT_EQ(clusterRun<2>(threads, 300), one2) << threads << " threads";
    EXPECT_EQ(clusterRun<3>(threads, 64), one3) << threads << " threads";
  }
  // The other threads' node records are copied into the output only when
  // read (ContactSolver::nodeContacts), and the next step reads its history
  // from either place: read after every step, or with the thread count
  // dropping while records are held by a thread that goes away.
  EXPECT_EQ(clusterRun<3>(2, 64, {}, true), one3);
  EXPECT_EQ(clusterRun<3>(3, 64, {}, false, 1), one3);
  EXPECT_EQ(clusterRun<3>(1, 64, {}, false, 3), one3);
  EXPECT_EQ(clusterRun<2>(4, 300, {}, true, 2), one2);
  // The tricubic look-up too.
  ContactLawDef cubic;
  cubic.interpolation = LevelSetInterpolation::Tricubic;
  const std::vector<unsigned char> oneC = clusterRun<3>(1, 64, cubic), twoC = clusterRun<3>(2, 64, cubic);
  ASSERT_EQ(oneC.size(), twoC.size());
  EXPECT_EQ(std::memcmp(oneC.data(), twoC.data(), oneC.size()), 0);
  EXPECT_NE(oneC, one3);  // a different look-up, different forces
#endif
}

// The shared task cursor (run()): threads taking chunks from both ends of
// a list take every task exactly once, each thread's ranges in the order
// of its end (ascending from the front, descending from the back).
TEST(NarrowPhase, TaskCursorHandsOutEveryTaskOnce) {
  constexpr std::uint32_t kTasks = 20000;
  for (const std::uint32_t chunk : {1u, 3u, 8u}) {
    detail::TaskCursor cursor;
    cursor.reset(7, kTasks);
    std::vector<int> taker(kTasks, -1);
    std::vector<int> ordered(4, 1);
#pragma omp parallel num_threads(4)
    {
      int thread = 0;
#ifdef _OPENMP
      thread = omp_get_thread_num();
#endif
      const bool fromBack = thread % 2 == 1;
      std::uint32_t last = fromBack ? kTasks + 1 : 0;
      for (;;) {
        const auto [first, end] = cursor.take(chunk, fromBack);
        if (first == end) break;
        if (end - first > chunk || (fromBack ? !(end <= last) : !(first >= last))) ordered[std::size_t(thread)] = 0;
        last = fromBack ? first : end;
        for (std::uint32_t k = first; k < end; ++k) {
          if (taker[k] != -1) ordered[std::size_t(thread)] = 0;
          taker[k] = thread;
        }
      }
    }
    for (std::uint32_t k = 0; k < kTasks; ++k) ASSERT_EQ(taker[k] == -1, k < 7) << "task " << k << ", chunk " << chunk;
    for (int t = 0; t < 4; ++t) EXPECT_EQ(ordered[std::size_t(t)], 1) << "thread " << t << ", chunk " << chunk;
    EXPECT_EQ(cursor.take(chunk, false)[1], 0u);  // nothing left
  }
}

// A particle against a flat face of a large box tool: the same force as
// against a plane at the same place (one-sided, weight 1); the tool's load is
// the reaction, with its moment about the tool's position; a tool moving with
// the particle adds no damping.
TEST(NarrowPhase, ToolFaceActsLikeAPlane) {
  geometry::ShapeDef<2> boxDef;
  boxDef.kind = geometry::ShapeKind::Box;
  boxDef.halfExtents = Vec<2>(4.0, 1.0);
  boxDef.spacing = 0.05;
  boxDef.options.nodesPerCell = 1.0;
  const auto box = geometry::buildShape(boxDef);
  // Tool orientation putting its grid-frame +y face up, top face at y = 0.
  const Vec<2> up = box->bodyToGrid().rotation.transpose() * Vec<2>::UnitY();
  ToolPose<2> tool;
  tool.shape = box.get();
  tool.orientation = 0.5 * std::numbers::pi - std::atan2(up[1], up[0]);
  tool.position = Vec<2>(0.3, -1.0);
  tool.velocity = Vec<2>(0.2, -0.1);
  const std::vector<ToolPose<2>> tools{tool};
  const std::vector<Plane<2>> planes{Plane<2>{Vec<2>::Zero(), Vec<2>::UnitY(), tool.velocity}};
  Particles<2> p;
  ParticleDef<2> def;
  def.shape = test::sphereShape<2>(0.5, 10);
  def.position = Vec<2>(0.0, 0.49);
  def.velocity = tool.velocity;  // at rest relative to the tool
  p.add(def);
  ContactLawDef law;
  ContactSolver<2> withTool(law), withPlane(law);
  withTool.compute(p, {}, {}, tools, 1e-5);
  withPlane.compute(p, {}, planes, {}, 1e-5);
  ASSERT_EQ(withTool.toolContacts().size(), 1u);
  ASSERT_EQ(withPlane.planeContacts().size(), 1u);
  const PairContact<2>& t = withTool.toolContacts()[0];
  const PairContact<2>& q = withPlane.planeContacts()[0];
  EXPECT_EQ(t.nodeCount, q.nodeCount);
  EXPECT_NEAR(t.force[1], q.force[1], 1e-3 * q.force[1]);
  EXPECT_NEAR(t.force[0], 0.0, 1e-3 * q.force[1]);
  // Pure elastic force: the sum of kn x overlap (no damping at zero relative speed).
  double elastic = 0.0;
  for (const NodeContact<2>& c : withPlane.nodeContacts()) elastic += law.kn * c.overlap;
  EXPECT_NEAR(q.force[1], elastic, 1e-9 * elastic);
  // Loads: the reaction on the tool, and its moment about the tool's position.
  Particles<2> copy = p;
  clearForces(copy);
  const BoundaryLoads<2>& loads = withTool.accumulate(copy);
  EXPECT_TRUE(loads.toolForce[0].isApprox(-t.force, 1e-15));
  double moment = 0.0;
  for (const NodeContact<2>& c : withTool.nodeContacts()) moment += Rotation<2>::moment(c.point - tool.position, -c.force);
  EXPECT_NEAR(loads.toolTorque[0], moment, 1e-9 * std::abs(moment));
  EXPECT_TRUE(copy.force[0].isApprox(t.force, 1e-15));
  EXPECT_TRUE(loads.planeForce.empty());
}

// Shear history is keyed by global ids: removing another particle (which
// moves the last particle into its slot) does not lose it.
TEST(NarrowPhase, HistorySurvivesReindexing) {
  const auto shape = test::sphereShape<2>(0.5, 10);
  Particles<2> p;
  ParticleDef<2> def;
  def.shape = shape;
  def.position = Vec<2>(-5.0, 0.0);
  p.add(def);  // id 0, far away; removed later
  def.position = Vec<2>(0.0, 0.0);
  p.add(def);  // id 1
  def.position = Vec<2>(0.98, 0.0);
  def.velocity = Vec<2>(0.0, 0.01);  // sliding past along y
  p.add(def);  // id 2
  ContactLawDef law;
  law.hasDamping = false;
  ContactSolver<2> solver(law);
  const double dt = 1e-5;
  solver.compute(p, {{1, 2}}, {}, {}, dt);
  ASSERT_GT(solver.nodeContacts().size(), 0u);
  // First step: the shear is the tangential part of (v_a - v_b) dt.
  const Vec<2> n = solver.nodeContacts()[0].normal;
  const Vec<2> vRel(0.0, -0.01);
  const Vec<2> first = solver.nodeShear()[0];
  EXPECT_TRUE(first.isApprox(dt * (vRel - vRel.dot(n) * n), 1e-12));
  // Remove id 0: id 2 moves to index 0, id 1 stays at index 1; pair (id 1, id 2) = indices (1, 0).
  p.remove(0);
  ASSERT_EQ(p.id[0], 2u);
  ASSERT_EQ(p.id[1], 1u);
  solver.compute(p, {{1, 0}}, {}, {}, dt);
  EXPECT_TRUE(solver.nodeShear()[0].isApprox(2.0 * first, 1e-12));
  // The solver insists on canonical order (id of a < id of b) and valid indices.
  EXPECT_THROW(solver.compute(p, {{0, 1}}, {}, {}, dt), std::invalid_argument);
  EXPECT_THROW(solver.compute(p, {{1, 2}}, {}, {}, dt), std::invalid_argument);
  // accumulate() needs the particles compute() saw.
  solver.compute(p, {{1, 0}}, {}, {}, dt);
  p.remove(1);
  EXPECT_THROW(solver.accumulate(p), std::invalid_argument);
}

// Springs born relaxed (ContactSolver::markNewborn): a disc whose nodes are
// marked as new carries no force at the overlap it is found with; pressed
// deeper it carries kn x the extra overlap per node; drawn out, the rest
// overlap follows it (a later press starts from where it was drawn out to);
// a node without a mark, and a compute() after the marked one, are unaffected.
TEST(NarrowPhase, SpringsBornRelaxedActOnTheExtraOverlapOnly) {
  Particles<2> p;
  ParticleDef<2> def;
  def.shape = test::sphereShape<2>(0.5, 10);
  def.position = Vec<2>(0.0, 0.48);  // 0.02 into the floor
  p.add(def);
  const std::vector<Plane<2>> floor{Plane<2>{Vec<2>::Zero(), Vec<2>::UnitY(), Vec<2>::Zero()}};
  ContactLawDef law;
  law.hasDamping = false;
  law.hasFriction = false;
  const double dt = 1e-5;
  // Reference: the same contact without marks.
  ContactSolver<2> plain(law);
  plain.compute(p, {}, floor, {}, dt);
  ASSERT_EQ(plain.planeContacts().size(), 1u);
  const std::uint32_t touching = plain.planeContacts()[0].nodeCount;
  ASSERT_GE(touching, 2u);
  EXPECT_GT(plain.elasticEnergy(), 0.0);
  EXPECT_TRUE(plain.nodePreload().empty());

  ContactSolver<2> solver(law);
  std::vector<std::uint32_t> all(def.shape->nodes().size());
  for (std::uint32_t n = 0; n < all.size(); ++n) all[n] = n;
  solver.markNewborn(p.id[0], all);
  solver.compute(p, {}, floor, {}, dt);
  ASSERT_EQ(solver.planeContacts().size(), 1u);
  EXPECT_EQ(solver.planeContacts()[0].nodeCount, touching);
  EXPECT_EQ(solver.planeContacts()[0].force.norm(), 0.0);
  EXPECT_EQ(solver.elasticEnergy(), 0.0);
  ASSERT_EQ(solver.nodePreload().size(), touching);
  for (std::uint32_t q = 0; q < touching; ++q) EXPECT_EQ(solver.nodePreload()[q], solver.nodeContacts()[q].overlap);
  // What the disc's fragments would take over: its nodes' rest overlaps against the floor.
  const auto rest = solver.restOverlaps(p, 0);
  ASSERT_EQ(rest.size(), touching);
  EXPECT_EQ(rest[0].owner, p.id[0]);
  EXPECT_EQ(rest[0].node, solver.nodeContacts()[0].node);

  // Pressed 0.01 deeper: kn x 0.01 per node that was touching (the marks are gone).
  p.position[0][1] -= 0.01;
  solver.compute(p, {}, floor, {}, dt);
  plain.compute(p, {}, floor, {}, dt);
  double expected = 0.0;
  for (std::size_t q = 0; q < solver.nodeContacts().size(); ++q) {
    const double extra = solver.nodeContacts()[q].overlap - solver.nodePreload()[q];
    EXPECT_GE(extra, 0.0);
    EXPECT_LE(extra, 0.01 + 1e-12);
    expected += law.kn * extra;
  }
  EXPECT_NEAR(solver.planeContacts()[0].force[1], expected, 1e-9 * expected);
  EXPECT_NEAR(expected, law.kn * 0.01 * touching, 0.01 * law.kn * 0.01 * touching);
  EXPECT_LT(solver.planeContacts()[0].force[1], 0.5 * plain.planeContacts()[0].force[1]);

  // Drawn out to 0.005 deep: no force, the rest overlaps follow the nodes.
  p.position[0][1] = 0.495;
  solver.compute(p, {}, floor, {}, dt);
  EXPECT_EQ(solver.planeContacts()[0].force.norm(), 0.0);
  // Pressed back by 0.004: kn x 0.004 per node still touching, not the 0.02 it was born with.
  p.position[0][1] = 0.491;
  solver.compute(p, {}, floor, {}, dt);
  const std::uint32_t now = solver.planeContacts()[0].nodeCount;
  EXPECT_LE(solver.planeContacts()[0].force[1], law.kn * 0.004 * now * (1.0 + 1e-9));

  // A rest overlap taken over by another id (a fragment), against the floor's key only.
  ContactSolver<2> heir(law);
  Particles<2> q = p;
  q.id[0] = 7;
  q.position[0][1] = 0.48;
  for (const auto& r : rest) heir.inheritRestOverlap(7, r.partner, r.node, r.restOverlap);
  heir.compute(q, {}, floor, {}, dt);
  EXPECT_EQ(heir.elasticEnergy(), 0.0);
  ContactSolver<2> stranger(law);  // the floor's key does not match another partner
  for (const auto& r : rest) stranger.inheritRestOverlap(7, r.partner + 1, r.node, r.restOverlap);
  stranger.compute(q, {}, floor, {}, dt);
  EXPECT_GT(stranger.elasticEnergy(), 0.0);
}
