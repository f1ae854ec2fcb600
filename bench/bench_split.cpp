// Level-set splitting (eq. 14-15) of one grain by a flat cut, node placement
// and the fragments' shapes included: a 2D grain on a 128^2 grid and a 3D
// grain on a 64^3 grid. Targets: < 1 ms (2D) and < 20 ms (3D).
//
// The kernels need lsdem::breakage; they are compiled only when the benchmark
// target sees its headers (bench/CMakeLists.txt linking lsdem::breakage).
#if __has_include("lsdem/breakage/Split.h")

#include "lsdem/breakage/Split.h"
#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/Shape.h"

#include <benchmark/benchmark.h>

namespace {

using lsdem::geometry::Shape;
using lsdem::geometry::Vec;

// A round grain (unit sphere / circle) whose grid has `cells` nodes per axis,
// padding included, cut by an oblique plane at `offset` from its centre.
// Arguments: surface matched to the mass (SplitOptions::matchEnclosedVolume)
// 0/1, and re-gridding 0/1 (regridCells = 10 with the plane at 0.7 radii, so
// the cap, 0.3 radii thick, is re-gridded; at 0.1 without).
template <int D>
void splitGrain(benchmark::State& state, int cells) {
  const double h = 2.0 / double(cells - 2 * lsdem::geometry::kDefaultPaddingCells - 1);
  const auto parent = Shape<D>::fromGrid(lsdem::geometry::sphereGrid<D>(1.0, h));
  lsdem::breakage::SplitOptions options;
  options.matchEnclosedVolume = state.range(0) != 0;
  const bool regrid = state.range(1) != 0;
  options.regridCells = regrid ? 10.0 : 0.0;
  lsdem::breakage::FractureSurface<D> cut;
  Vec<D> normal = Vec<D>::Ones();
  normal[0] = 2.0;
  cut.plane = lsdem::geometry::HalfSpace<D>{normal.normalized(), regrid ? 0.7 : 0.1};
  std::size_t fragments = 0, regridded = 0;
  double shift = 0.0;
  for (auto _ : state) {
    const lsdem::breakage::SplitResult<D> split = lsdem::breakage::splitShape<D>(*parent, cut, options);
    fragments = split.fragments.size();
    regridded = 0;
    for (const auto& f : split.fragments) regridded += f.regridded;
    shift = split.largestSurfaceShift;
    benchmark::DoNotOptimize(split.fragments.data());
  }
  state.counters["grid_nodes"] = double(parent->grid().size());
  state.counters["fragments"] = double(fragments);
  state.counters["regridded"] = double(regridded);
  state.counters["shift_cells"] = shift;
}

void BM_Split2D_128(benchmark::State& state) { splitGrain<2>(state, 128); }
void BM_Split3D_64(benchmark::State& state) { splitGrain<3>(state, 64); }

BENCHMARK(BM_Split2D_128)->ArgNames({"match", "regrid"})->Args({0, 0})->Args({1, 0})->Args({0, 1})->Args({1, 1})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Split3D_64)->ArgNames({"match", "regrid"})->Args({0, 0})->Args({1, 0})->Args({0, 1})->Args({1, 1})
    ->Unit(benchmark::kMillisecond);

}  // namespace

#endif
