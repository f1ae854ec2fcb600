/// @file bench_geometry.cpp
/// @brief Kernels of the geometry layer: grid look-ups (the narrow phase's inner
/// operation), mass properties, marching cubes, surface nodes, shape building.
/// Sizes are in cells across the shape, the knob users turn.

#include "lsdem/geometry/Contours.h"
#include "lsdem/geometry/MassProperties.h"
#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/RandomGrain.h"
#include "lsdem/geometry/Reinitialize.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/SurfaceNodes.h"

#include <benchmark/benchmark.h>

#include <random>
#include <vector>

using namespace lsdem::geometry;

namespace {

// A sphere of radius 0.5 with `cells` cells across its diameter.
template <int D>
Grid<D> sphere(int cells) {
  return sphereGrid<D>(0.5, 1.0 / cells, kDefaultPaddingCells);
}

// Random query points near the surface, where contacts are looked up.
template <int D>
std::vector<Vec<D>> shellPoints(std::size_t n) {
  std::mt19937_64 rng(42);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> r(0.45, 0.55);
  std::vector<Vec<D>> pts(n);
  for (auto& p : pts) {
    for (int a = 0; a < D; ++a) p[a] = g(rng);
    p = p.normalized() * r(rng);
  }
  return pts;
}

template <int D>
void BM_GridValueAndGradient(benchmark::State& state) {
  const Grid<D> grid = sphere<D>(int(state.range(0)));
  const std::vector<Vec<D>> pts = shellPoints<D>(4096);
  double sink = 0.0;
  for (auto _ : state) {
    for (const Vec<D>& p : pts) {
      Vec<D> grad;
      sink += grid.valueAndGradient(p, grad) + grad[0];
    }
    benchmark::DoNotOptimize(sink);
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(pts.size()));
  state.SetLabel("look-ups");
}
BENCHMARK(BM_GridValueAndGradient<2>)->Arg(20)->Arg(100);
BENCHMARK(BM_GridValueAndGradient<3>)->Arg(20)->Arg(64);

// The value alone (the narrow phase's bulk-rejection and per-node test; the
// gradient only for nodes inside): the machine's raw look-up rate, to set the
// narrow phase's checks per second against.
template <int D>
void BM_GridValue(benchmark::State& state) {
  const Grid<D> grid = sphere<D>(int(state.range(0)));
  const std::vector<Vec<D>> pts = shellPoints<D>(4096);
  double sink = 0.0;
  for (auto _ : state) {
    for (const Vec<D>& p : pts) sink += grid.value(p);
    benchmark::DoNotOptimize(sink);
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(pts.size()));
  state.SetLabel("look-ups");
}
BENCHMARK(BM_GridValue<3>)->Arg(20)->Arg(64);

template <int D>
void BM_MassProperties(benchmark::State& state) {
  const Grid<D> grid = sphere<D>(int(state.range(0)));
  const MassMethod method = state.range(1) ? MassMethod::Extrapolated : MassMethod::Paper;
  for (auto _ : state) {
    benchmark::DoNotOptimize(massProperties(grid, method));
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(grid.size()));
  state.SetLabel(state.range(1) ? "extrapolated, grid values" : "paper, grid values");
}
BENCHMARK(BM_MassProperties<2>)->Args({128, 0})->Args({128, 1});
BENCHMARK(BM_MassProperties<3>)->Args({20, 0})->Args({20, 1})->Args({64, 0})->Args({64, 1})->Unit(benchmark::kMillisecond);

void BM_MarchingCubes(benchmark::State& state) {
  const Grid<3> grid = sphere<3>(int(state.range(0)));
  std::size_t faces = 0;
  for (auto _ : state) {
    const TriangleMesh mesh = marchingCubes(grid);
    faces = mesh.faces.size();
    benchmark::DoNotOptimize(faces);
  }
  state.counters["faces"] = double(faces);
}
BENCHMARK(BM_MarchingCubes)->Arg(20)->Arg(64)->Unit(benchmark::kMillisecond);

void BM_MarchingSquares(benchmark::State& state) {
  const Grid<2> grid = sphere<2>(int(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(marchingSquares(grid));
}
BENCHMARK(BM_MarchingSquares)->Arg(20)->Arg(128)->Unit(benchmark::kMicrosecond);

template <int D>
void BM_SurfaceNodes(benchmark::State& state) {
  const Grid<D> grid = sphere<D>(int(state.range(0)));
  const double density = double(state.range(1));
  std::size_t nodes = 0;
  for (auto _ : state) {
    const NodeSet<D> set = surfaceNodes(grid, density);
    nodes = set.size();
    benchmark::DoNotOptimize(nodes);
  }
  state.counters["nodes"] = double(nodes);
}
BENCHMARK(BM_SurfaceNodes<2>)->Args({20, 2})->Args({128, 2})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SurfaceNodes<3>)->Args({20, 1})->Args({20, 2})->Unit(benchmark::kMillisecond);

void BM_ReinitializeFastSweeping(benchmark::State& state) {
  const Grid<3> grid = sphere<3>(int(state.range(0)));
  for (auto _ : state) {
    Grid<3> g = grid;
    reinitializeFastSweeping(g);
    benchmark::DoNotOptimize(g.values().data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(grid.size()));
}
BENCHMARK(BM_ReinitializeFastSweeping)->Arg(20)->Arg(48)->Unit(benchmark::kMillisecond);

// A whole 3D random grain shape: grid, mass properties, nodes, descriptors.
void BM_RandomGrainShape3D(benchmark::State& state) {
  RandomGrainDef def;
  def.equivalentDiameter = 1.0;
  def.elongation = 1.3;
  def.roughness = 0.1;
  def.seed = 5;
  const double h = 1.0 / double(state.range(0));
  std::size_t nodes = 0;
  for (auto _ : state) {
    auto shape = Shape<3>::fromGrid(randomGrainGrid<3>(def, h), ShapeOptions{1.0, MassMethod::Extrapolated});
    nodes = shape->nodes().size();
  }
  state.counters["nodes"] = double(nodes);
}
BENCHMARK(BM_RandomGrainShape3D)->Arg(20)->Unit(benchmark::kMillisecond);

}  // namespace
