/// @file fuzz_contact.cpp
/// @brief libFuzzer target: random contact sets thrown at the contact law and
/// the narrow phase (ContactSolver): two to four particles of the fuzz shape
/// library (resolution-limit spheres, needles, discs, boxes, a concave comb,
/// split fragments) at random overlapping poses and velocities, a plane and a
/// kinematic tool, under a random valid contact law (linear or Hertz, per node
/// or area weighted, with or without friction and damping), for a few steps
/// of shear history.
///
/// Invariants (a violation aborts):
///   - every force, torque, overlap, normal and energy is finite; normals are
///     unit vectors, overlaps >= 0, elastic energy >= 0, dissipated power >= 0;
///   - forces are equal and opposite: the particles' total force plus the
///     loads on the plane and the tool is zero, and each particle pair's
///     moments balance (x_a x F + T_a - x_b x F + T_b = 0), to 1e-9 of the
///     largest force (times the lever) involved.

#include "FuzzInput.h"
#include "FuzzShapes.h"

#include "lsdem/dynamics/ContactLaw.h"
#include "lsdem/dynamics/NarrowPhase.h"
#include "lsdem/dynamics/Particles.h"
#include "lsdem/dynamics/Wall.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace {

using namespace lsdem;
using dynamics::Rotation;
using geometry::Vec;

[[noreturn]] void violation(const char* what, double value = 0.0) {
  std::fprintf(stderr, "fuzz_contact: invariant violated: %s (%.17g)\n", what, value);
  std::abort();
}

template <int D>
dynamics::Orientation<D> orientationFrom(fuzz::FuzzInput& in) {
  if constexpr (D == 2) {
    return in.uniform(-4.0, 4.0);
  } else {
    Eigen::Quaterniond q(in.uniform(-1, 1), in.uniform(-1, 1), in.uniform(-1, 1), in.uniform(-1, 1));
    if (q.norm() < 1e-3) return Eigen::Quaterniond::Identity();
    q.normalize();
    return q;
  }
}

template <int D>
dynamics::Spin<D> spinFrom(fuzz::FuzzInput& in, double scale) {
  if constexpr (D == 2) {
    return in.uniform(-scale, scale);
  } else {
    return Vec<3>(in.uniform(-scale, scale), in.uniform(-scale, scale), in.uniform(-scale, scale));
  }
}

double spinNorm(double w) { return std::abs(w); }
double spinNorm(const Vec<3>& w) { return w.norm(); }

template <int D>
void run(fuzz::FuzzInput& in) {
  const auto& library = fuzz::shapeLibrary<D>();
  const double size = 0.01;

  // A random valid law.
  dynamics::ContactLawDef law;
  law.normal = in.chance(64) ? dynamics::NormalModel::Hertz : dynamics::NormalModel::Linear;
  law.formulation = in.chance(100) ? dynamics::ForceFormulation::AreaWeighted : dynamics::ForceFormulation::PerNode;
  law.kn = std::pow(10.0, in.uniform(0.0, 10.0));
  law.ks = law.kn * in.uniform(0.0, 2.0);
  law.friction = in.uniform(0.0, 2.0);
  law.dampingRatio = in.uniform(0.0, 0.99);
  law.youngsModulus = std::pow(10.0, in.uniform(3.0, 12.0));
  law.poissonRatio = in.uniform(0.0, 0.49);
  law.hasFriction = in.chance(180);
  law.hasDamping = in.chance(180);
  dynamics::ContactSolver<D> solver(law);

  // Particles near the origin, overlapping each other.
  dynamics::Particles<D> particles;
  const int count = in.integer(2, 4);
  for (int k = 0; k < count; ++k) {
    dynamics::ParticleDef<D> p;
    p.shape = library[std::size_t(in.integer(0, int(library.size()) - 1))];
    p.density = std::pow(10.0, in.uniform(1.0, 8.0));
    for (int a = 0; a < D; ++a) p.position[a] = in.uniform(-1.0, 1.0) * size;
    p.orientation = orientationFrom<D>(in);
    for (int a = 0; a < D; ++a) p.velocity[a] = in.uniform(-100.0, 100.0);
    p.angularVelocity = spinFrom<D>(in, 1000.0);
    particles.add(p);
  }
  std::vector<typename dynamics::ContactSolver<D>::Pair> pairs;
  for (int a = 0; a < count; ++a) {
    for (int b = a + 1; b < count; ++b) pairs.push_back({std::uint32_t(a), std::uint32_t(b)});
  }

  // A plane through the cloud, and a tool (a library shape) among the particles.
  std::vector<dynamics::Plane<D>> planes;
  if (in.chance(160)) {
    dynamics::Plane<D> plane;
    Vec<D> n;
    for (int a = 0; a < D; ++a) n[a] = in.uniform(-1.0, 1.0);
    if (n.norm() > 1e-3) {
      plane.normal = n.normalized();
      plane.point = plane.normal * in.uniform(-1.5, 0.5) * size;
      for (int a = 0; a < D; ++a) plane.velocity[a] = in.uniform(-5.0, 5.0);
      planes.push_back(plane);
    }
  }
  std::vector<dynamics::ToolPose<D>> tools;
  if (in.chance(100)) {
    dynamics::ToolPose<D> tool;
    tool.shape = library[std::size_t(in.integer(0, int(library.size()) - 1))].get();
    for (int a = 0; a < D; ++a) tool.position[a] = in.uniform(-1.0, 1.0) * size;
    tool.orientation = orientationFrom<D>(in);
    for (int a = 0; a < D; ++a) tool.velocity[a] = in.uniform(-10.0, 10.0);
    tool.angularVelocity = spinFrom<D>(in, 100.0);
    tools.push_back(tool);
  }

  // A few steps: compute, accumulate, check, drift.
  const double dt = std::pow(10.0, in.uniform(-9.0, -4.0));
  const int steps = in.integer(1, 4);
  for (int s = 0; s < steps; ++s) {
    solver.compute(particles, pairs, planes, tools, dt);
    for (std::size_t i = 0; i < particles.size(); ++i) {
      particles.force[i].setZero();
      particles.torque[i] = Rotation<D>::zeroSpin();
    }
    const dynamics::BoundaryLoads<D>& loads = solver.accumulate(particles);

    // Finite values, unit normals, non-negative overlaps and energies.
    double largest = 0.0;
    for (const auto& nc : solver.nodeContacts()) {
      if (!nc.point.allFinite() || !nc.force.allFinite() || !std::isfinite(nc.overlap)) violation("node contact");
      if (!(nc.overlap >= 0.0)) violation("negative overlap", nc.overlap);
      if (std::abs(nc.normal.norm() - 1.0) > 1e-6) {
        std::fprintf(stderr, "node %u ownerIsB %d overlap %g point %g %g\n", nc.node, int(nc.ownerIsB), nc.overlap, nc.point[0], nc.point[1]);
        violation("normal not unit", nc.normal.norm());
      }
      largest = std::max(largest, nc.force.norm());
    }
    if (!std::isfinite(solver.elasticEnergy()) || solver.elasticEnergy() < 0.0) {
      violation("elastic energy", solver.elasticEnergy());
    }
    if (!std::isfinite(solver.dissipatedPower()) || solver.dissipatedPower() < 0.0) {
      violation("dissipated power", solver.dissipatedPower());
    }

    // Equal and opposite: total force of particles and boundaries vanishes.
    Vec<D> total = Vec<D>::Zero();
    for (std::size_t i = 0; i < particles.size(); ++i) {
      if (!particles.force[i].allFinite()) violation("particle force");
      total += particles.force[i];
    }
    for (const auto& f : loads.planeForce) total += f;
    for (const auto& f : loads.toolForce) total += f;
    if (!(total.norm() <= 1e-9 * (largest * double(solver.nodeContacts().size()) + 1e-300))) {
      violation("forces not equal and opposite", total.norm() / (largest + 1e-300));
    }
    // Moments of each particle pair balance.
    for (const auto& pc : solver.particleContacts()) {
      if (pc.nodeCount == 0) continue;
      const Vec<D>& xa = particles.position[pc.a];
      const Vec<D>& xb = particles.position[pc.b];
      const auto m = Rotation<D>::moment(xa - xb, pc.force);
      const double residual = spinNorm(m + pc.torqueA + pc.torqueB);
      const double scale = pc.force.norm() * 4.0 * size + spinNorm(pc.torqueA) + spinNorm(pc.torqueB);
      if (!(residual <= 1e-9 * scale + 1e-300)) violation("pair moments do not balance", residual / scale);
    }

    // Drift a little so the next step sees shear history.
    for (std::size_t i = 0; i < particles.size(); ++i) particles.position[i] += dt * particles.velocity[i];
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::FuzzInput in(data, size);
  try {
    if (in.byte() & 1) {
      run<3>(in);
    } else {
      run<2>(in);
    }
  } catch (const std::exception& e) {
    // Every input above is valid: nothing may throw.
    std::fprintf(stderr, "fuzz_contact: threw on a valid input: %s\n", e.what());
    std::abort();
  }
  return 0;
}
