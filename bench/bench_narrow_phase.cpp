/// @file bench_narrow_phase.cpp
/// @brief The narrow phase and contact forces (ContactSolver::compute) on a
/// dense random cluster: node checks per second (nodes tested against a
/// neighbour's level set, both directions of every candidate pair), wall-clock
/// with all OpenMP threads.

#include "lsdem/dynamics/NarrowPhase.h"
#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/ShapeDef.h"

#include <benchmark/benchmark.h>
#ifdef _OPENMP
#include <omp.h>
#endif
#ifdef __linux__
#include <sched.h>
#endif

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <vector>

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

template <int D>
struct Cluster {
  Particles<D> particles;
  std::vector<std::array<std::uint32_t, 2>> pairs;
};

// Four superellipsoids (superellipses) about 1 m across, `cells` cells across
// their smallest dimension, 1 node per cell, on a jittered lattice of spacing
// `lattice` m (benchmark argument 3, in cm) with random orientations: at
// 0.9 m most neighbours touch, a few percent of their nodes deep.
// Candidate pairs: bounding spheres overlapping (what the broad phase gives
// without skin).
template <int D>
Cluster<D> makeCluster(int perSide, double cells, double lattice) {
  std::vector<std::shared_ptr<const geometry::Shape<D>>> shapes;
  for (int k = 0; k < 4; ++k) {
    geometry::ShapeDef<D> def;
    def.kind = geometry::ShapeKind::Superellipsoid;
    def.semiAxes = Vec<D>::LinSpaced(0.5, 0.5 - 0.04 * (k + 1));
    def.exponents = D == 2 ? std::vector<double>{2.2 + 0.3 * k} : std::vector<double>{2.2 + 0.3 * k, 2.5};
    def.cellsAcross = cells;
    def.options.nodesPerCell = 1.0;
    shapes.push_back(geometry::buildShape(def));
  }
  Cluster<D> c;
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int count = 1;
  for (int a = 0; a < D; ++a) count *= perSide;
  for (int i = 0; i < count; ++i) {
    ParticleDef<D> def;
    def.shape = shapes[std::size_t(i) % shapes.size()];
    int r = i;
    for (int a = 0; a < D; ++a) {
      def.position[a] = lattice * (r % perSide) + 0.03 * u(rng);
      r /= perSide;
    }
    if constexpr (D == 2) {
      def.orientation = std::numbers::pi * u(rng);
      def.angularVelocity = u(rng);
    } else {
      def.orientation = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
      def.angularVelocity = Vec<3>(u(rng), u(rng), u(rng));
    }
    def.velocity = 0.1 * Vec<D>::NullaryExpr([&] { return u(rng); });
    c.particles.add(def);
  }
  const Particles<D>& p = c.particles;
  for (std::uint32_t i = 0; i < p.size(); ++i) {
    for (std::uint32_t j = i + 1; j < p.size(); ++j) {
      const double reach = p.shape[i]->boundingRadius() + p.shape[j]->boundingRadius();
      if ((p.position[i] - p.position[j]).squaredNorm() < reach * reach) c.pairs.push_back({i, j});
    }
  }
  return c;
}

// 2^16 points spread over the grid's box, or only those within one cell of
// its zero level set (fixed seed).
template <int D>
std::vector<Vec<D>> lookupPoints(const geometry::Grid<D>& grid, bool nearSurface) {
  const geometry::Box<D> box = grid.bounds();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec<D>> points;
  while (points.size() < (std::size_t(1) << 16)) {
    Vec<D> x;
    for (int a = 0; a < D; ++a) x[a] = box.lower[a] + u(rng) * (box.upper[a] - box.lower[a]);
    if (nearSurface && std::abs(grid.value(x)) > grid.spacing()) continue;
    points.push_back(x);
  }
  return points;
}
// The near-surface points of lookupPoints in grid coordinates (cells from
// the first node), where the narrow phase's look-ups take them.
template <int D>
std::vector<Vec<D>> surfacePointsAtCells(const geometry::Grid<D>& grid) {
  std::vector<Vec<D>> points = lookupPoints(grid, true);
  for (Vec<D>& x : points) x = grid.toGrid(x);
  return points;
}

// compute() with the paper's law (linear per node, Coulomb friction with
// history, damping); items = node checks. Argument 4: separation
// certificates on (1) or off (0: every pass walks every pair's trees whole,
// as a flowing bed does where the motion outruns the certificates).
// (BM_NarrowPhaseSpringOnly: the same with friction and damping left out of
// the law, a linear spring per node contact, the law at its cheapest: what
// the pass costs besides them.)
template <int D>
void narrowPhase(benchmark::State& state, const ContactLawDef& law) {
  const Cluster<D> c = makeCluster<D>(int(state.range(0)), double(state.range(1)), 0.01 * double(state.range(2)));
  ContactSolver<D> solver(law);
  solver.setSeparationCertificates(state.range(3) != 0);
  // Two steps before timing: the solver's double-buffered outputs have then
  // both grown to the problem's size (a run's steady state).
  for (int warm = 0; warm < 2; ++warm) solver.compute(c.particles, c.pairs, {}, {}, 1e-6);
  for (auto _ : state) {
    solver.compute(c.particles, c.pairs, {}, {}, 1e-6);
    benchmark::DoNotOptimize(solver.pairContacts().data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(solver.nodeChecks()));
  // Share of the node checks that pass the bounding-sphere test (then a grid look-up).
  const Particles<D>& p = c.particles;
  double nearby = 0.0;
  for (const auto& [a, b] : c.pairs) {
    for (const auto& [owner, other] : {std::pair{a, b}, std::pair{b, a}}) {
      const double r = p.shape[other]->boundingRadius();
      for (const Vec<D>& xb : p.shape[owner]->nodes().positions) {
        if ((p.position[owner] + p.rotation(owner) * xb - p.position[other]).norm() <= r) nearby += 1.0;
      }
    }
  }
  state.counters["in sphere"] = nearby / double(solver.nodeChecks());
  state.counters["particles"] = double(c.particles.size());
  state.counters["nodes/particle"] = double(solver.nodeChecks()) / double(2 * c.pairs.size());
  state.counters["pairs"] = double(c.pairs.size());
  state.counters["touching"] = double(solver.particleContacts().size());
  state.counters["node contacts"] = double(solver.nodeContacts().size());
  // Node checks plus tree-cell checks per second (all threads): each is at
  // most one grid look-up (value at the point) after the sphere and box
  // tests; compare with the raw look-up rates below, taken on as many
  // threads.
  state.counters["checks/s"] = benchmark::Counter(double(solver.nodeChecks() + solver.cellChecks()),
                                                  benchmark::Counter::kIsIterationInvariantRate);
  // The machine's raw look-up rate next to it, on this bed's own grid (the
  // first shape's), at 2^16 points within a cell of its surface in grid
  // coordinates, for 50 ms each after the timed passes, on as many threads
  // as the pass (each its own loop over the points; the rate is the sum of
  // theirs): one at a time (Grid::valueAtCells, "raw look-ups/s") and in
  // one batch (Grid::valuesAtCells, two per instruction, as the batched
  // walks make theirs: "raw batched look-ups/s"), and one at a time with
  // the gradient below zero ("raw look-ups with gradient/s"). One line
  // prints them all, with the threads ("threads") and the pass's checks
  // per second and thread ("checks/s per thread").
  {
    const geometry::Grid<D>& grid = p.shape[0]->grid();
    const std::vector<Vec<D>> points = surfacePointsAtCells(grid);
#ifdef _OPENMP
    const int threads = omp_get_max_threads();
#else
    const int threads = 1;
#endif
    // lookUps(values, grad) makes one round of look-ups over `points`,
    // into the calling thread's own `values` and `grad`.
    const auto rate = [&](auto&& lookUps) {
      double total = 0.0;
#ifdef _OPENMP
#pragma omp parallel num_threads(threads) reduction(+ : total)
#endif
      {
        std::vector<double> values(points.size());
        Vec<D> grad = Vec<D>::Zero();
        double seconds = 0.0;
        std::size_t count = 0;
        const auto start = std::chrono::steady_clock::now();
        while (seconds < 0.05) {
          lookUps(values, grad);
          count += points.size();
          seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        }
        total += double(count) / seconds;
      }
      return total;
    };
    state.counters["raw look-ups/s"] = rate([&](std::vector<double>& values, Vec<D>&) {
      double sum = 0.0;
      for (const Vec<D>& g : points) sum += grid.valueAtCells(g);
      values[0] = sum;
      benchmark::DoNotOptimize(values.data());
    });
    // With the gradient where the value is negative (what a contact node
    // takes: Grid::valueAtCellsGradientBelow), about half of these points.
    state.counters["raw look-ups with gradient/s"] = rate([&](std::vector<double>& values, Vec<D>& grad) {
      double sum = 0.0;
      for (const Vec<D>& g : points) sum += grid.valueAtCellsGradientBelow(g, 0.0, grad);
      values[0] = sum;
      benchmark::DoNotOptimize(values.data());
      benchmark::DoNotOptimize(grad);
    });
    state.counters["raw batched look-ups/s"] = rate([&](std::vector<double>& values, Vec<D>&) {
      grid.valuesAtCells(points.data(), points.size(), values.data());
      benchmark::DoNotOptimize(values.data());
      benchmark::ClobberMemory();
    });
    state.counters["threads"] = threads;
    state.counters["checks/s per thread"] = benchmark::Counter(
        double(solver.nodeChecks() + solver.cellChecks()) / threads, benchmark::Counter::kIsIterationInvariantRate);
  }
  state.SetLabel("node checks");
}
template <int D>
void BM_NarrowPhase(benchmark::State& state) {
  narrowPhase<D>(state, ContactLawDef{});
}
template <int D>
void BM_NarrowPhaseSpringOnly(benchmark::State& state) {
  ContactLawDef law;
  law.hasFriction = law.hasDamping = false;
  narrowPhase<D>(state, law);
}

#ifdef _OPENMP
// Thread scaling measured in pairs: each iteration runs one compute() at 1
// thread and one at all threads (two solvers, so each keeps its own
// per-thread caches), back to back, so a slow spell of the machine slows
// both alike. The one-thread pass runs pinned to each of the process's
// cores in turn (Linux), since the cores of a shared machine need not run
// alike: counters give the median one-thread time on each core, the median
// all-thread time (and its gather's: ContactSolver::gatherSeconds), and the
// speed-up against their mean (what one thread takes on a core the system
// picks) and against the fastest core.
template <int D>
void BM_NarrowPhaseThreads(benchmark::State& state) {
  const Cluster<D> c = makeCluster<D>(int(state.range(0)), double(state.range(1)), 0.01 * double(state.range(2)));
  const int threads = omp_get_max_threads();
  ContactSolver<D> one(ContactLawDef{}), all(ContactLawDef{});
  const auto timed = [&](ContactSolver<D>& solver, int n) {
    omp_set_num_threads(n);
    const double start = omp_get_wtime();
    solver.compute(c.particles, c.pairs, {}, {}, 1e-6);
    benchmark::DoNotOptimize(solver.pairContacts().data());
    return omp_get_wtime() - start;
  };
  for (int warm = 0; warm < 2; ++warm) timed(one, 1), timed(all, threads);
  // The cores the process may run on (one entry, -1, where they cannot be pinned).
  std::vector<int> cores{-1};
#ifdef __linux__
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (sched_getaffinity(0, sizeof(allowed), &allowed) == 0 && CPU_COUNT(&allowed) > 1) {
    cores.clear();
    for (int k = 0; k < CPU_SETSIZE; ++k) {
      if (CPU_ISSET(k, &allowed)) cores.push_back(k);
    }
  }
#endif
  const auto pinTo = [&](int core) {
#ifdef __linux__
    if (core < 0) return;
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(core, &set);
    sched_setaffinity(0, sizeof(set), &set);
#else
    (void)core;
#endif
  };
  const auto unpin = [&] {
#ifdef __linux__
    if (cores.front() >= 0) sched_setaffinity(0, sizeof(allowed), &allowed);
#endif
  };
  std::vector<std::vector<double>> oneTimes(cores.size());
  std::vector<double> allTimes, allGathers;
  std::size_t turn = 0;
  for (auto _ : state) {
    const std::size_t k = turn++ % cores.size();
    // The idle OpenMP threads spin for a while after a parallel pass, and
    // one spinning on the core just pinned to would share it: let them
    // sleep first (not timed).
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    pinTo(cores[k]);
    oneTimes[k].push_back(timed(one, 1));
    unpin();
    allTimes.push_back(timed(all, threads));
    allGathers.push_back(all.gatherSeconds());
  }
  omp_set_num_threads(threads);
  const auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double allMedian = median(allTimes);
  double sum = 0.0, fastest = std::numeric_limits<double>::infinity();
  std::size_t timedCores = 0;
  for (std::size_t k = 0; k < cores.size(); ++k) {
    if (oneTimes[k].empty()) continue;
    const double m = median(oneTimes[k]);
    state.counters[cores[k] < 0 ? std::string("1 thread ms") : "1 thread ms, core " + std::to_string(cores[k])] =
        1e3 * m;
    sum += m;
    fastest = std::min(fastest, m);
    ++timedCores;
  }
  state.counters["threads"] = threads;
  state.counters["all ms"] = 1e3 * allMedian;
  // Of which the records' gather (the other threads' records copied into
  // the output, in task order): the part of the pass that does not shrink
  // with the walks.
  state.counters["all ms, gather"] = 1e3 * median(allGathers);
  state.counters["speedup"] = sum / double(timedCores) / allMedian;
  state.counters["speedup, fastest core"] = fastest / allMedian;
}
// The settled and the pressed bed of BM_NarrowPhase.
BENCHMARK(BM_NarrowPhaseThreads<3>)->Args({10, 20, 97})->Args({10, 20, 90})->Unit(benchmark::kMillisecond)->UseRealTime();
#endif

// The raw trilinear look-up limit: Grid::value at precomputed points in the
// grid box of a shape 20 cells across (24^D values with padding: in cache, as
// a neighbour's grid is in the narrow phase), points spread over the box
// (argument 0) or within one cell of the surface (argument 1), as the
// narrow phase's look-ups are. Items = look-ups.
template <int D>
void BM_TrilinearLookup(benchmark::State& state) {
  const geometry::Grid<D> grid = geometry::sphereGrid<D>(0.5, 1.0 / 20.0);
  const bool nearSurface = state.range(0) == 1;
  const std::vector<Vec<D>> points = lookupPoints(grid, nearSurface);
  double sum = 0.0;
  for (auto _ : state) {
    for (const Vec<D>& x : points) sum += grid.value(x);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(points.size()));
  state.SetLabel(nearSurface ? "look-ups near the surface" : "look-ups in the box");
}
// The narrow phase's own look-up, trilinear (argument 0) against
// Catmull-Rom tricubic (argument 1): value at grid coordinates and, where it
// is negative, the gradient (Grid::valueAtCellsGradientBelow and its cubic
// twin), at points within one cell of the surface of a sphere 10 cells
// across (the accuracy study's baseline grid). Items = look-ups.
template <int D>
void BM_LookupAtCells(benchmark::State& state) {
  const geometry::Grid<D> grid = geometry::sphereGrid<D>(0.5, 1.0 / 10.0);
  const bool cubic = state.range(0) == 1;
  const std::vector<Vec<D>> points = surfacePointsAtCells(grid);
  double sum = 0.0;
  Vec<D> grad = Vec<D>::Zero();
  for (auto _ : state) {
    if (cubic) {
      for (const Vec<D>& g : points) sum += grid.cubicValueAtCellsGradientBelow(g, 0.0, grad);
    } else {
      for (const Vec<D>& g : points) sum += grid.valueAtCellsGradientBelow(g, 0.0, grad);
    }
    benchmark::DoNotOptimize(sum);
    benchmark::DoNotOptimize(grad);
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(points.size()));
  state.SetLabel(cubic ? "tricubic" : "trilinear");
}
BENCHMARK(BM_LookupAtCells<3>)->Arg(0)->Arg(1);
BENCHMARK(BM_LookupAtCells<2>)->Arg(0)->Arg(1);
// The batched walks' look-up (Grid::valuesAtCells, two points per
// instruction) against one at a time (Grid::valueAtCells), values only, at
// the points of BM_LookupAtCells: argument 1 batched, 0 one at a time.
// Items = look-ups.
template <int D>
void BM_BatchedLookup(benchmark::State& state) {
  const geometry::Grid<D> grid = geometry::sphereGrid<D>(0.5, 1.0 / 10.0);
  const bool batched = state.range(0) == 1;
  const std::vector<Vec<D>> points = surfacePointsAtCells(grid);
  std::vector<double> values(points.size());
  for (auto _ : state) {
    if (batched) {
      grid.valuesAtCells(points.data(), points.size(), values.data());
    } else {
      for (std::size_t j = 0; j < points.size(); ++j) values[j] = grid.valueAtCells(points[j]);
    }
    benchmark::DoNotOptimize(values.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(points.size()));
  state.SetLabel(batched ? "batched" : "one at a time");
}
BENCHMARK(BM_BatchedLookup<3>)->Arg(0)->Arg(1);
BENCHMARK(BM_BatchedLookup<2>)->Arg(0)->Arg(1);

// The grid layout for the trilinear look-up (issue: "one cache line per
// cell's corners"): a cell's 8 corner values in one 32-byte aligned block
// (8x the memory of the grid's node values), against the grid's own
// layout, where a cell's corners lie in 4 rows (2-4 cache lines).
struct alignas(32) CellCorners {
  float v[8];  // (x, y, z) = (0,0,0), (1,0,0), (0,1,0), (1,1,0), (0,0,1), (1,0,1), (0,1,1), (1,1,1)
};
struct CellCornerGrid {
  geometry::Index<3> cells;
  std::vector<CellCorners> blocks;
  explicit CellCornerGrid(const geometry::Grid<3>& g) {
    const geometry::Index<3>& n = g.dims();
    for (int a = 0; a < 3; ++a) cells[a] = n[a] - 1;
    blocks.resize(std::size_t(cells[0]) * std::size_t(cells[1]) * std::size_t(cells[2]));
    for (int z = 0; z < cells[2]; ++z) {
      for (int y = 0; y < cells[1]; ++y) {
        for (int x = 0; x < cells[0]; ++x) {
          CellCorners& b = blocks[(std::size_t(z) * std::size_t(cells[1]) + std::size_t(y)) * std::size_t(cells[0]) +
                                  std::size_t(x)];
          for (int k = 0; k < 8; ++k) b.v[k] = g.at(geometry::Index<3>(x + (k & 1), y + ((k >> 1) & 1), z + (k >> 2)));
        }
      }
    }
  }
  // Grid::valueAtCellsGradientBelow's arithmetic on a cell's block.
  [[gnu::always_inline]] double valueAtCellsGradientBelow(const Vec<3>& g, double threshold, Vec<3>& grad) const {
    int c[3];
    Vec<3> t;
    for (int a = 0; a < 3; ++a) {
      c[a] = std::clamp(int(g[a]), 0, cells[a] - 1);
      t[a] = g[a] - double(c[a]);
    }
    const float* v = blocks[(std::size_t(c[2]) * std::size_t(cells[1]) + std::size_t(c[1])) * std::size_t(cells[0]) +
                            std::size_t(c[0])].v;
    const double v000 = v[0], v100 = v[1], v010 = v[2], v110 = v[3];
    const double v001 = v[4], v101 = v[5], v011 = v[6], v111 = v[7];
    const double x00 = v000 + t[0] * (v100 - v000), x10 = v010 + t[0] * (v110 - v010);
    const double x01 = v001 + t[0] * (v101 - v001), x11 = v011 + t[0] * (v111 - v011);
    const double y0 = x00 + t[1] * (x10 - x00), y1 = x01 + t[1] * (x11 - x01);
    const double value = y0 + t[2] * (y1 - y0);
    if (value < threshold) {
      const double d00 = v100 - v000, d10 = v110 - v010, d01 = v101 - v001, d11 = v111 - v011;
      const double dy0 = d00 + t[1] * (d10 - d00), dy1 = d01 + t[1] * (d11 - d01);
      grad[0] = dy0 + t[2] * (dy1 - dy0);
      grad[1] = (x10 - x00) + t[2] * ((x11 - x01) - (x10 - x00));
      grad[2] = y1 - y0;
    }
    return value;
  }
};

// Argument 0: cells across the sphere (10: the beds' grains, 27 KB of
// values with the padding; 60: a fine grain, 1.3 MB); 1: distinct grids looked up in turn
// (1, or 256 as in a bed of many fragment shapes); 2: the layout (0: the
// grid's, 1: cell blocks). 2^16 points within a cell of the surface,
// visited grid by grid in turns of 16 (a pair's nodes are close
// together). Items = look-ups; the label says if both layouts agree.
void BM_LookupLayout(benchmark::State& state) {
  const double cells = double(state.range(0));
  const std::size_t count = std::size_t(state.range(1));
  const bool blocks = state.range(2) == 1;
  std::vector<geometry::Grid<3>> grids;
  std::vector<CellCornerGrid> cornerGrids;
  for (std::size_t k = 0; k < count; ++k) {
    // Spheres of slightly different radii (under 0.3 % apart, so the points
    // stay within about a cell of every surface): each grid its own values.
    grids.push_back(geometry::sphereGrid<3>(0.5 * (1.0 + 1e-5 * double(k)), 1.0 / cells));
    if (blocks) cornerGrids.emplace_back(grids.back());
  }
  const std::vector<Vec<3>> points = surfacePointsAtCells(grids.front());
  double sum = 0.0;
  Vec<3> grad = Vec<3>::Zero();
  constexpr std::size_t kRun = 16;
  for (auto _ : state) {
    for (std::size_t i = 0; i < points.size(); ++i) {
      const std::size_t k = (i / kRun) % count;
      sum += blocks ? cornerGrids[k].valueAtCellsGradientBelow(points[i], 0.0, grad)
                    : grids[k].valueAtCellsGradientBelow(points[i], 0.0, grad);
    }
    benchmark::DoNotOptimize(sum);
    benchmark::DoNotOptimize(grad);
  }
  bool same = true;
  if (blocks) {
    Vec<3> g1 = Vec<3>::Zero(), g2 = Vec<3>::Zero();
    for (std::size_t i = 0; i < points.size(); ++i) {
      const std::size_t k = (i / kRun) % count;
      same = same && cornerGrids[k].valueAtCellsGradientBelow(points[i], 0.0, g1) ==
                         grids[k].valueAtCellsGradientBelow(points[i], 0.0, g2) && g1 == g2;
    }
  }
  std::size_t bytes = 0;
  for (const auto& g : grids) bytes += g.bytes();
  if (blocks) {
    bytes = 0;
    for (const auto& g : cornerGrids) bytes += g.blocks.size() * sizeof(CellCorners);
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(points.size()));
  state.counters["MB"] = double(bytes) / 1e6;
  state.SetLabel(std::string(blocks ? "cell blocks" : "grid") + (same ? "" : ", DIFFERENT VALUES"));
}
BENCHMARK(BM_LookupLayout)
    ->Args({10, 1, 0})
    ->Args({10, 1, 1})
    ->Args({10, 256, 0})
    ->Args({10, 256, 1})
    ->Args({60, 1, 0})
    ->Args({60, 1, 1});

// compute() as BM_NarrowPhase with the trilinear (argument 3 = 0) or
// tricubic (1) look-up; items = node checks.
template <int D>
void BM_NarrowPhaseInterpolation(benchmark::State& state) {
  const Cluster<D> c = makeCluster<D>(int(state.range(0)), double(state.range(1)), 0.01 * double(state.range(2)));
  ContactLawDef law;
  law.interpolation = state.range(3) == 1 ? LevelSetInterpolation::Tricubic : LevelSetInterpolation::Trilinear;
  ContactSolver<D> solver(law);
  for (int warm = 0; warm < 2; ++warm) solver.compute(c.particles, c.pairs, {}, {}, 1e-6);
  for (auto _ : state) {
    solver.compute(c.particles, c.pairs, {}, {}, 1e-6);
    benchmark::DoNotOptimize(solver.pairContacts().data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(solver.nodeChecks()));
  state.counters["node contacts"] = double(solver.nodeContacts().size());
  state.SetLabel(state.range(3) == 1 ? "tricubic" : "trilinear");
}
BENCHMARK(BM_NarrowPhaseInterpolation<3>)
    ->Args({10, 10, 97, 0})
    ->Args({10, 10, 97, 1})
    ->Args({10, 10, 90, 0})
    ->Args({10, 10, 90, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK(BM_TrilinearLookup<3>)->Arg(0)->Arg(1);
BENCHMARK(BM_TrilinearLookup<2>)->Arg(1);
BENCHMARK(BM_NarrowPhase<3>)->Args({4, 20, 90, 1})->Unit(benchmark::kMillisecond)->UseRealTime();
// A bed of 1000 grains of about 2600 nodes: pressed (lattice 0.9 m, 16 % of
// the nodes in contact) and settled (lattice 0.97 m: neighbours touch, as in
// a packing at rest).
BENCHMARK(BM_NarrowPhase<3>)
    ->Args({10, 20, 90, 1})
    ->Args({10, 20, 97, 1})
    ->Args({10, 20, 97, 0})
    ->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_NarrowPhaseSpringOnly<3>)
    ->Args({10, 20, 97, 1})
    ->Args({10, 20, 97, 0})
    ->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_NarrowPhase<2>)->Args({16, 20, 90, 1})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
