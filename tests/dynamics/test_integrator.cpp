#include "support/Shapes.h"
#include "support/Threads.h"
#include "lsdem/dynamics/Integrator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

template <int D>
std::shared_ptr<const geometry::Shape<D>> smallSphere() {
  return test::sphereShape<D>(0.5, 8);
}

// One free 3D body with principal moments (1, 2, 3) spinning at w (world frame).
Particles<3> asymmetricTop(const Vec<3>& w) {
  Particles<3> p;
  ParticleDef<3> def;
  def.shape = smallSphere<3>();
  p.add(def);
  p.inertia[0] = Vec<3>(1.0, 2.0, 3.0);
  p.invInertia[0] = p.inertia[0].cwiseInverse();
  p.angularVelocity[0] = w;
  return p;
}

// Kinetic energy and world angular momentum of a torque-free 3D body.
double rotationalEnergy(const Particles<3>& p) {
  const Vec<3> wb = p.orientation[0].conjugate() * p.angularVelocity[0];
  return 0.5 * (p.inertia[0].array() * wb.array().square()).sum();
}
Vec<3> angularMomentum(const Particles<3>& p) {
  const Vec<3> wb = p.orientation[0].conjugate() * p.angularVelocity[0];
  return p.orientation[0] * Vec<3>(p.inertia[0].cwiseProduct(wb));
}

}  // namespace

// Velocity Verlet is exact for a constant force: x = x0 + v0 t + a t^2 / 2.
TEST(Integrator, ConstantForceIsExact) {
  Particles<2> p;
  ParticleDef<2> def;
  def.shape = smallSphere<2>();
  def.velocity = Vec<2>(1.0, 2.0);
  p.add(def);
  const Vec<2> F(0.3, -9.81 * p.mass[0]);
  const double dt = 1e-3;
  for (int s = 0; s < 1000; ++s) {
    p.force[0] = F;
    kickDrift(p, dt);
    kick(p, dt);
  }
  const Vec<2> a = F / p.mass[0];
  EXPECT_LT((p.position[0] - (Vec<2>(1.0, 2.0) + 0.5 * a)).norm(), 1e-12);
  EXPECT_LT((p.velocity[0] - (Vec<2>(1.0, 2.0) + a)).norm(), 1e-12);
}

// A free asymmetric top (I = 1, 2, 3) spinning near its unstable middle axis
// tumbles; energy and |L| stay constant to 1e-4 relative, and L keeps its
// direction in the world frame.
TEST(Integrator, FreeAsymmetricTopConservesEnergyAndAngularMomentum) {
  Particles<3> p = asymmetricTop(Vec<3>(0.05, 2.0, 0.05));
  const double E0 = rotationalEnergy(p);
  const Vec<3> L0 = angularMomentum(p);
  const double dt = 1e-3;
  double worstE = 0.0, worstL = 0.0;
  Vec<3> wBodyFirst = p.orientation[0].conjugate() * p.angularVelocity[0];
  bool flipped = false;
  for (int s = 0; s < 100000; ++s) {
    kickDrift(p, dt);
    kick(p, dt);
    worstE = std::max(worstE, std::abs(rotationalEnergy(p) - E0) / E0);
    worstL = std::max(worstL, (angularMomentum(p) - L0).norm() / L0.norm());
    const Vec<3> wb = p.orientation[0].conjugate() * p.angularVelocity[0];
    if (wb[1] * wBodyFirst[1] < 0.0) flipped = true;
  }
  EXPECT_TRUE(flipped) << "the top should tumble about its middle axis";
  EXPECT_LT(worstE, 1e-4);
  EXPECT_LT(worstL, 1e-4);
  RecordProperty("max_relative_energy_error", std::to_string(worstE));
  RecordProperty("max_relative_momentum_error", std::to_string(worstL));
}

// Second order: halving dt quarters the error of a spinning, precessing top.
TEST(Integrator, RotationIsSecondOrder) {
  auto run = [](double dt) {
    Particles<3> p = asymmetricTop(Vec<3>(0.3, 1.0, 0.7));
    const int steps = int(std::lround(2.0 / dt));
    for (int s = 0; s < steps; ++s) {
      kickDrift(p, dt);
      kick(p, dt);
    }
    return p.orientation[0];
  };
  const Eigen::Quaterniond ref = run(1e-4);
  const double e1 = ref.angularDistance(run(4e-3));
  const double e2 = ref.angularDistance(run(2e-3));
  const double order = std::log2(e1 / e2);
  EXPECT_GT(order, 1.8);
  EXPECT_LT(order, 2.3);
}

TEST(Particles, IdsGrowAndRemovalKeepsOthers) {
  Particles<2> p;
  ParticleDef<2> def;
  def.shape = smallSphere<2>();
  for (int i = 0; i < 4; ++i) {
    def.position = Vec<2>(double(i), 0.0);
    p.add(def);
  }
  p.remove(1);
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p.id[1], 3u);  // the last particle moved into the hole
  EXPECT_DOUBLE_EQ(p.position[1][0], 3.0);
  EXPECT_EQ(p.add(def), 3u);
  EXPECT_EQ(p.id[3], 4u);  // ids are never reused
  const double pi = 3.14159265358979323846;
  EXPECT_NEAR(p.mass[0], 2650.0 * pi * 0.25, 0.01 * 2650.0 * pi * 0.25);
  def.density = -1.0;
  EXPECT_THROW(p.add(def), std::invalid_argument);
}

// freeRotation against the same splitting written with Eigen's angle-axis
// rotations, at sub-step angles on both sides of where its sine and cosine
// switch from the series to the library (1/16 rad): the same orientation to
// round-off.
TEST(Integrator, FreeRotationMatchesAngleAxisSplitting) {
  auto reference = [](Eigen::Quaterniond q, const Vec<3>& L, const Vec<3>& inertia, double dt) {
    Vec<3> Lb = q.conjugate() * L;
    const int axes[5] = {0, 1, 2, 1, 0};
    const double times[5] = {0.5 * dt, 0.5 * dt, dt, 0.5 * dt, 0.5 * dt};
    for (int s = 0; s < 5; ++s) {
      const int k = axes[s];
      const Eigen::AngleAxisd turn(times[s] * Lb[k] / inertia[k], Vec<3>::Unit(k));
      q = q * Eigen::Quaterniond(turn);
      Lb = turn.inverse() * Lb;
    }
    return q.normalized();
  };
  const Vec<3> inertia(1.0, 2.5, 4.0);
  double worst = 0.0;
  for (double dt : {1e-6, 1e-3, 0.03, 0.2, 1.0}) {
    for (int c = 0; c < 8; ++c) {
      const Eigen::Quaterniond q0 =
          Eigen::Quaterniond(Eigen::AngleAxisd(0.7 * c + 0.1, Vec<3>(1.0, 0.3 * c - 1.0, 0.5).normalized()));
      const Vec<3> L(0.4 + 0.1 * c, -1.3 + 0.3 * c, 2.0 - 0.2 * c);
      Eigen::Quaterniond q = q0;
      freeRotation(q, L, inertia.cwiseInverse(), dt);
      const Eigen::Quaterniond ref = reference(q0, L, inertia, dt);
      worst = std::max(worst, q.angularDistance(ref));
    }
  }
  EXPECT_LT(worst, 5e-15);
  RecordProperty("max_angle_difference_rad", std::to_string(worst));
}

// kickDrift turns 3D bodies in batches of 8 (their free rotations made
// together): 517 bodies (64 full batches and part of one; above 512 the
// loop is shared among threads), each with its own inertia, spin, torque
// and force, end bit for bit where the same body stepped alone ends, over
// 20 steps, at one thread and at two.
TEST(Integrator, BodiesSteppedTogetherMatchEachAlone) {
  constexpr int n = 517;
  const auto shape = smallSphere<3>();
  const auto setUp = [&shape](Particles<3>& p, int i) {
    ParticleDef<3> def;
    def.shape = shape;
    def.position = Vec<3>(0.1 * i, -0.2 * i, 0.05 * (i % 9));
    def.velocity = Vec<3>(std::sin(i), std::cos(2.0 * i), 0.3);
    def.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.4 * i + 0.1, Vec<3>(1.0, std::sin(0.2 * i), -0.5).normalized()));
    const std::size_t k = p.size();
    p.add(def);
    p.inertia[k] = Vec<3>(1.0 + 0.1 * (i % 7), 2.0 - 0.05 * (i % 11), 3.0 + 0.2 * (i % 5));
    p.invInertia[k] = p.inertia[k].cwiseInverse();
    p.angularVelocity[k] = Vec<3>(3.0 * std::sin(0.7 * i), 2.0 * std::cos(0.3 * i), 1.0 + 0.5 * (i % 4));
    p.torque[k] = Vec<3>(0.2 * std::sin(i), -0.1, 0.05 * (i % 3));
    p.force[k] = Vec<3>(-0.3, 0.1 * std::cos(i), 0.2);
  };
  for (int threads : {1, 2}) {
    const test::ScopedThreads scoped(threads);
    Particles<3> together;
    std::vector<Particles<3>> alone(n);
    for (int i = 0; i < n; ++i) {
      setUp(together, i);
      setUp(alone[std::size_t(i)], i);
    }
    const double dt = 1e-3;
    for (int step = 0; step < 20; ++step) {
      kickDrift(together, dt);
      kick(together, dt);
      for (Particles<3>& one : alone) {
        kickDrift(one, dt);
        kick(one, dt);
      }
    }
    for (int i = 0; i < n; ++i) {
      SCOPED_TRACE("body " + std::to_string(i) + ", threads " + std::to_string(threads));
      const Particles<3>& one = alone[std::size_t(i)];
      EXPECT_EQ(together.position[i], one.position[0]);
      EXPECT_EQ(together.velocity[i], one.velocity[0]);
      EXPECT_EQ(together.orientation[i].coeffs(), one.orientation[0].coeffs());
      EXPECT_EQ(together.angularVelocity[i], one.angularVelocity[0]);
    }
    // Every body turned, by about its spin times the 20 steps' 0.02 s.
    for (int i = 0; i < n; ++i) {
      Particles<3> start;
      setUp(start, i);
      EXPECT_GT(together.orientation[i].angularDistance(start.orientation[0]), 0.01) << "body " << i;
    }
  }
}
