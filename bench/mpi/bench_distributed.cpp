/// @file bench_distributed.cpp
/// @brief Time per step of a distributed 3D bed (docs/parallel.md):
///
///     mpirun -np R lsdem_bench_distributed [grains] [steps] [nodes|time]
///
/// The dense 3D packing of bench_world (BM_WorldPacking3D), with `grains`
/// (default 5000) blocky superellipsoids of ~2100 surface nodes in about 12
/// layers, settles under gravity for 300 steps on the ranks and is then
/// timed for `steps` (default 200). Rank 0 prints, per
/// rank: wall ms per step and of it the rank's own work
/// (ExchangeStats::workSeconds), particles owned and ghosts, the exchange's share
/// of the step, the bytes and messages it sent per step, and its contacts
/// (particle pairs; those with one ghost, computed on two ranks; those of
/// two ghosts, computed for their history only); then the
/// slowest rank's ms per step, which sets the run's speed, and the slowest
/// rank's set-up and settling times. With
/// OMP_NUM_THREADS=1 and R ranks against 1, it measures the speed-up of
/// the decomposition alone. The last argument is the balance
/// (DistributedDef::Balance): by nodes (default, the run's defaults), or by
/// time, checked every 100 steps with a threshold of 1.05.
#include "lsdem/parallel/DistributedWorld.h"

#include "../Packings.h"

#include <mpi.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace lsdem;

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  const int grains = argc > 1 ? std::atoi(argv[1]) : 5000;
  const int steps = argc > 2 ? std::atoi(argv[2]) : 200;
  const int settle = 300;
  const std::string balance = argc > 3 ? argv[3] : "nodes";
  if (balance != "nodes" && balance != "time") {
    if (rank == 0) {
      std::fprintf(stderr, "lsdem_bench_distributed: balance must be nodes or time, got '%s'\n", argv[3]);
    }
    MPI_Finalize();
    return 2;
  }
  parallel::DistributedDef def;
  if (balance == "time") {
    def.balance = parallel::DistributedDef::Balance::Time;
    def.rebalanceImbalance = 1.05;
    def.rebalanceEvery = 100;
  }

  // bench_world's 3D packing (Packings.h): blocky superellipsoids, ~2100
  // nodes each, on a brick lattice about 12 layers deep, settled here on the
  // ranks (so the settling is a distributed run too).
  const auto start = std::chrono::steady_clock::now();
  const auto& shapes = bench::blockShapes3D();
  bench::PackingDef packing;
  packing.particles = std::size_t(grains);
  packing.perRow = std::max(1, int(std::lround(std::sqrt(grains / 12.0))));
  packing.settleSteps = 0;
  auto built = bench::settledWorld<3>(shapes, bench::brickLattice(shapes, packing), packing);
  dynamics::World<3>& world = *built;
  parallel::DistributedWorld<3> dist(MPI_COMM_WORLD, world, def);
  const auto settleStart = std::chrono::steady_clock::now();
  dist.run(std::uint64_t(settle));
  const auto settleEnd = std::chrono::steady_clock::now();

  const parallel::ExchangeStats before = dist.stats();
  MPI_Barrier(MPI_COMM_WORLD);
  const auto t0 = std::chrono::steady_clock::now();
  dist.run(std::uint64_t(steps));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const parallel::ExchangeStats& after = dist.stats();

  std::size_t ghosts = world.particles().size() - dist.ownedCount();
  // Particle pairs in contact on this rank: all, with one ghost (computed on
  // two ranks), of two ghosts (computed for the history only).
  double pairs = 0.0, oneGhost = 0.0, twoGhosts = 0.0;
  for (const auto& c : world.contacts().particleContacts()) {
    if (c.nodeCount == 0) continue;
    const int g = int(!dist.owned(c.a)) + int(!dist.owned(c.b));
    pairs += 1.0;
    oneGhost += g == 1;
    twoGhosts += g == 2;
  }
  // Set-up (the bed is built whole on every rank, then each keeps its own
  // part) and the settling, in seconds: with the timed steps they make the
  // whole process's time.
  const double setUp = std::chrono::duration<double>(settleStart - start).count();
  const double settling = std::chrono::duration<double>(settleEnd - settleStart).count();
  double row[14] = {1e3 * seconds / steps,
                   double(dist.ownedCount()),
                   double(ghosts),
                   (after.seconds - before.seconds) / seconds,
                   double(after.bytesSent - before.bytesSent) / steps,
                   double(after.messagesSent - before.messagesSent) / steps,
                   double(after.migrations - before.migrations) / steps,
                   pairs,
                   oneGhost,
                   twoGhosts,
                   double(after.neighbours),
                   setUp,
                   settling,
                   1e3 * (after.workSeconds - before.workSeconds) / steps};
  constexpr int kColumns = 14;
  std::vector<double> all(std::size_t(kColumns * ranks));
  MPI_Gather(row, kColumns, MPI_DOUBLE, all.data(), kColumns, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  const std::uint64_t total = dist.globalCount();
  if (rank == 0) {
    std::printf("%d grains (%llu in the run), %d ranks, %d timed steps after %d, dt %.3g s, balance by %s, %llu "
                "rebalances\n",
                grains, (unsigned long long)total, ranks, steps, settle, world.dt(), balance.c_str(),
                (unsigned long long)after.rebalances);
    std::printf(
        "rank  ms/step  work ms/step  owned  ghosts  exchange  bytes/step  messages/step  migrations/step  contacts  "
        "one-ghost  "
        "two-ghost  neighbours\n");
    double slowest = 0.0, slowestSetUp = 0.0, slowestSettling = 0.0;
    for (int r = 0; r < ranks; ++r) {
      const double* v = &all[std::size_t(kColumns * r)];
      std::printf("%4d  %7.2f  %12.2f  %5.0f  %6.0f  %7.1f%%  %10.0f  %13.1f  %15.2f  %8.0f  %9.0f  %9.0f  %10.0f\n", r,
                  v[0], v[13], v[1], v[2], 100.0 * v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10]);
      slowest = std::max(slowest, v[0]);
      slowestSetUp = std::max(slowestSetUp, v[11]);
      slowestSettling = std::max(slowestSettling, v[12]);
    }
    std::printf("slowest rank: %.2f ms/step\n", slowest);
    std::printf("set-up %.2f s, settling %.2f s (%.2f ms/step), slowest rank\n", slowestSetUp, slowestSettling,
                1e3 * slowestSettling / settle);
  }
  MPI_Finalize();
  return 0;
}
