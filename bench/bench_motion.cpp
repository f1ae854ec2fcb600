/// @file bench_motion.cpp
/// @brief Kinematic-body motions (evaluated once per body per step) and the
/// critical-time-step estimate (once per shape: at start-up and for each new
/// fragment shape after breakage).

#include "lsdem/dynamics/Integrator.h"
#include "lsdem/dynamics/Motion.h"
#include "lsdem/dynamics/TimeStep.h"
#include "lsdem/geometry/ShapeDef.h"

#include <benchmark/benchmark.h>

#include <cmath>

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

// One step of the integrator (kickDrift, then kick) of `range(0)` free
// bodies with forces, torques and spins of a flowing bed (spins of order
// 10 rad/s, dt 1e-5 s), one thread: in 3D the free rotation of each body.
template <int D>
void BM_Integrate(benchmark::State& state) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::Sphere;
  def.radius = 0.01;
  def.cellsAcross = 8.0;
  const auto shape = geometry::buildShape(def);
  Particles<D> p;
  const int n = int(state.range(0));
  for (int i = 0; i < n; ++i) {
    ParticleDef<D> pd;
    pd.shape = shape;
    pd.position = Vec<D>::Constant(0.03 * i);
    pd.velocity = Vec<D>::Constant(0.1 * std::sin(i));
    p.add(pd);
    p.force[i] = Vec<D>::Constant(1e-3 * std::cos(i));
    if constexpr (D == 2) {
      p.angularVelocity[i] = 10.0 * std::sin(0.7 * i);
      p.torque[i] = 1e-7 * std::cos(0.3 * i);
    } else {
      p.inertia[i] = p.inertia[i].cwiseProduct(Vec<3>(1.0, 1.3, 1.7));  // an asymmetric top
      p.invInertia[i] = p.inertia[i].cwiseInverse();
      p.angularVelocity[i] = Vec<3>(10.0 * std::sin(0.7 * i), 8.0 * std::cos(0.2 * i), 3.0);
      p.torque[i] = Vec<3>(1e-7, -2e-7, 1e-7 * std::cos(0.3 * i));
    }
  }
  for (auto _ : state) {
    kickDrift(p, 1e-5);
    kick(p, 1e-5);
    benchmark::ClobberMemory();
  }
  state.counters["ns_per_body"] =
      benchmark::Counter(double(n), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_Integrate<2>)->Arg(1000);
BENCHMARK(BM_Integrate<3>)->Arg(1000);

// evaluate() of a jaw crusher (Table 1) through the Motion variant.
void BM_EvaluateJawCrusher(benchmark::State& state) {
  const Motion<2> motion = JawCrusher<2>{};
  double t = 0.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(evaluate(motion, t));
    t += 1.8e-6;
  }
}
BENCHMARK(BM_EvaluateJawCrusher);

// evaluate() of a 3D key-framed path with `range(0)` frames (binary search, slerp).
void BM_EvaluateKeyFramed3D(benchmark::State& state) {
  KeyFramed<3> path;
  for (int k = 0; k < state.range(0); ++k) {
    path.frames.push_back({double(k), Vec<3>(std::sin(k), std::cos(k), 0.1 * k),
                           Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * k, Vec<3>(1, 2, 3).normalized()))});
  }
  const Motion<3> motion = path;
  double t = 0.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(evaluate(motion, t));
    t = std::fmod(t + 0.0137, double(state.range(0)));
  }
}
BENCHMARK(BM_EvaluateKeyFramed3D)->Arg(10)->Arg(1000);

// stiffestContact() of a 3D superellipsoid (exponents 4) of `range(0)` cells
// across at `range(1)` nodes per cell.
void BM_StiffestContact3D(benchmark::State& state) {
  geometry::ShapeDef<3> def;
  def.kind = geometry::ShapeKind::Superellipsoid;
  def.semiAxes = Vec<3>(1.0, 0.6, 0.5);
  def.exponents = {4.0, 4.0};
  def.cellsAcross = double(state.range(0));
  def.options.nodesPerCell = double(state.range(1));
  const auto shape = geometry::buildShape(def);
  for (auto _ : state) benchmark::DoNotOptimize(stiffestContact(*shape, NodeStiffness{}).stiffness);
  state.counters["nodes"] = double(shape->nodes().size());
}
BENCHMARK(BM_StiffestContact3D)->Args({10, 1})->Args({20, 1})->Unit(benchmark::kMillisecond);

}  // namespace
