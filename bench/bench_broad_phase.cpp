/// @file bench_broad_phase.cpp
/// @brief Broad phase: a full rebuild of the candidate list (invalidate + update)
/// and the per-step staleness check, for N = 1k, 10k, 100k bodies in 2D and 3D.
/// Items are bodies, so "items per second" reads as bodies per second and the
/// time per body should stay flat as N grows (linear cost).
///
/// Packings: "dense" is a jittered lattice of spacing 1 m with radii uniform in
/// [0.45, 0.55] m and centres moved by up to +-0.05 m per axis, so every body
/// touches or nearly touches its lattice neighbours (1.9 / 2.7 candidate pairs
/// per body in 2D / 3D with the default skin). "bimodal" adds one fragment of
/// radius 0.005 m (100:1) at a random point of every lattice cell, so half the
/// bodies are fragments. The counters report pairs per body and occupied levels.

#include "lsdem/dynamics/BroadPhase.h"

#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

using namespace lsdem::dynamics;

namespace {

template <int D>
struct Bodies {
  std::vector<Vec<D>> positions;  // m
  std::vector<double> radii;      // m
  std::vector<std::uint64_t> ids;
};

// About n bodies on a jittered lattice (see the file comment); with `fines`,
// half of them are 100x smaller fragments scattered through the cells.
template <int D>
Bodies<D> packing(std::size_t n, bool fines) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> jitter(-0.05, 0.05), radius(0.45, 0.55), unit(0.0, 1.0);
  const std::size_t cells = fines ? n / 2 : n;
  const int side = int(std::ceil(std::pow(double(cells), 1.0 / D)));
  Bodies<D> b;
  for (std::size_t k = 0; k < cells; ++k) {
    Vec<D> corner;
    std::size_t rest = k;
    for (int a = 0; a < D; ++a) {
      corner[a] = double(rest % std::size_t(side));
      rest /= std::size_t(side);
    }
    Vec<D> x = corner;
    for (int a = 0; a < D; ++a) x[a] += jitter(rng);
    b.positions.push_back(x);
    b.radii.push_back(radius(rng));
    if (fines) {
      Vec<D> y = corner;
      for (int a = 0; a < D; ++a) y[a] += unit(rng) - 0.5;
      b.positions.push_back(y);
      b.radii.push_back(0.005);
    }
  }
  for (std::size_t i = 0; i < b.positions.size(); ++i) b.ids.push_back(i);
  return b;
}

template <int D>
void rebuild(benchmark::State& state, bool fines) {
  const Bodies<D> b = packing<D>(std::size_t(state.range(0)), fines);
  BroadPhase<D> bp;
  bp.update(b.positions, b.radii, b.ids);  // warm the buffers
  for (auto _ : state) {
    bp.invalidate();
    bp.update(b.positions, b.radii, b.ids);
    benchmark::DoNotOptimize(bp.pairs().data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(b.positions.size()));
  state.counters["pairs/body"] = double(bp.pairs().size()) / double(b.positions.size());
  state.counters["levels"] = bp.levels();
}

template <int D>
void BM_BroadPhaseRebuild(benchmark::State& state) {
  rebuild<D>(state, false);
}
template <int D>
void BM_BroadPhaseRebuildBimodal(benchmark::State& state) {
  rebuild<D>(state, true);
}

// The per-step cost when nothing moved far enough: one O(N) pass.
template <int D>
void BM_BroadPhaseCheck(benchmark::State& state) {
  const Bodies<D> b = packing<D>(std::size_t(state.range(0)), false);
  BroadPhase<D> bp;
  bp.update(b.positions, b.radii, b.ids);
  for (auto _ : state) benchmark::DoNotOptimize(bp.update(b.positions, b.radii, b.ids));
  state.SetItemsProcessed(state.iterations() * std::int64_t(b.positions.size()));
}

}  // namespace

BENCHMARK(BM_BroadPhaseRebuild<2>)->Arg(1000)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_BroadPhaseRebuild<3>)->Arg(1000)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_BroadPhaseRebuildBimodal<2>)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_BroadPhaseRebuildBimodal<3>)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_BroadPhaseCheck<2>)->Arg(100000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_BroadPhaseCheck<3>)->Arg(100000)->Unit(benchmark::kMicrosecond);
