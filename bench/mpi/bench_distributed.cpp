/// @file bench_distributed.cpp
/// @brief Time per step of a distributed 3D bed (docs/parallel.md):
///
///     mpirun -np R lsdem_bench_distributed [grains] [steps]
///
/// A bed of `grains` (default 5000) spheres and ellipsoids, 10 grid cells
/// across, on a lattice in a box of planes, falls under gravity for 300
/// steps and is then timed for `steps` (default 200). Rank 0 prints, per
/// rank: wall ms per step, particles owned and ghosts, the exchange's share
/// of the step, and the bytes and messages it sent per step; then the
/// slowest rank's ms per step, which sets the run's speed. With
/// OMP_NUM_THREADS=1 and R ranks against 1, it measures the speed-up of
/// the decomposition alone.
#include "lsdem/parallel/DistributedWorld.h"

#include "lsdem/geometry/ShapeDef.h"

#include <mpi.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
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

  const double d = 0.01, pitch = 1.05 * d;
  const int side = std::max(1, int(std::lround(std::cbrt(grains / 2.0))));  // a bed twice as wide as high
  const int wide = 2 * side;
  dynamics::WorldDef<3> def;
  def.gravity = geometry::Vec<3>(0.0, -9.81, 0.0);
  def.localDamping = 0.2;
  def.contact.kn = 2e5;
  def.contact.ks = 1.6e5;
  def.contact.friction = 0.5;
  def.contact.dampingRatio = 0.3;
  dynamics::World<3> world(def);
  dynamics::PlaneDef<3> floor;
  floor.plane.normal = geometry::Vec<3>::UnitY();
  world.addPlane(floor);
  for (int a : {0, 2}) {
    dynamics::PlaneDef<3> lo, hi;
    lo.plane.normal = geometry::Vec<3>::Unit(a);
    hi.plane.point = geometry::Vec<3>::Unit(a) * ((a == 0 ? wide : side) * pitch);
    hi.plane.normal = -geometry::Vec<3>::Unit(a);
    world.addPlane(lo);
    world.addPlane(hi);
  }
  geometry::ShapeDef<3> sphere;
  sphere.kind = geometry::ShapeKind::Sphere;
  sphere.radius = 0.5 * d;
  sphere.cellsAcross = 10;
  geometry::ShapeDef<3> ellipsoid;
  ellipsoid.kind = geometry::ShapeKind::Ellipsoid;
  ellipsoid.semiAxes = geometry::Vec<3>(0.5 * d, 0.4 * d, 0.4 * d);
  ellipsoid.cellsAcross = 10;
  const auto shapes = std::vector{geometry::buildShape(sphere), geometry::buildShape(ellipsoid)};
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < grains; ++k) {
    const int x = k % wide, z = (k / wide) % side, y = k / (wide * side);
    dynamics::ParticleDef<3> p;
    p.shape = shapes[std::size_t(k % 2)];
    p.position = geometry::Vec<3>((x + 0.5) * pitch, (y + 0.6) * pitch, (z + 0.5) * pitch) +
                 0.02 * d * geometry::Vec<3>(u(rng), u(rng), u(rng));
    p.orientation = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
    world.addParticle(p);
  }
  parallel::DistributedWorld<3> dist(MPI_COMM_WORLD, world);
  dist.run(std::uint64_t(settle));

  const parallel::ExchangeStats before = dist.stats();
  MPI_Barrier(MPI_COMM_WORLD);
  const auto t0 = std::chrono::steady_clock::now();
  dist.run(std::uint64_t(steps));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const parallel::ExchangeStats& after = dist.stats();

  std::size_t ghosts = world.particles().size() - dist.ownedCount();
  double row[7] = {1e3 * seconds / steps,
                   double(dist.ownedCount()),
                   double(ghosts),
                   (after.seconds - before.seconds) / seconds,
                   double(after.bytesSent - before.bytesSent) / steps,
                   double(after.messagesSent - before.messagesSent) / steps,
                   double(after.migrations - before.migrations) / steps};
  std::vector<double> all(std::size_t(7 * ranks));
  MPI_Gather(row, 7, MPI_DOUBLE, all.data(), 7, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  const std::uint64_t total = dist.globalCount();
  if (rank == 0) {
    std::printf("%d grains (%llu in the run), %d ranks, %d timed steps after %d, dt %.3g s\n", grains,
                (unsigned long long)total, ranks, steps, settle, world.dt());
    std::printf("rank  ms/step  owned  ghosts  exchange  bytes/step  messages/step  migrations/step\n");
    double slowest = 0.0;
    for (int r = 0; r < ranks; ++r) {
      const double* v = &all[std::size_t(7 * r)];
      std::printf("%4d  %7.2f  %5.0f  %6.0f  %7.1f%%  %10.0f  %13.1f  %15.2f\n", r, v[0], v[1], v[2], 100.0 * v[3], v[4],
                  v[5], v[6]);
      slowest = std::max(slowest, v[0]);
    }
    std::printf("slowest rank: %.2f ms/step\n", slowest);
  }
  MPI_Finalize();
  return 0;
}
