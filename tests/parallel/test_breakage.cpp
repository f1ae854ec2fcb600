// Breakage spread over 1, 2 or 4 ranks equals the same scene in one world,
// bit for bit: the three-grains scenes (apps/scenes/three_grains/), built
// through the scene builder as `lsdem run` builds them, with the platen
// started against the stack so that grains and fragments break within a
// short run, on the cuts between the subdomains. The fragments' ids, the
// breakage log, the fines and every particle's motion are compared with a
// world that runs the same scene on each rank.
#include "lsdem/parallel/DistributedWorld.h"

#include "lsdem/io/Scene.h"
#include "lsdem/io/SceneOverride.h"
#include "support/Files.h"
#include "support/Mpi.h"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <fstream>
#include <string>
#include <variant>
#include <vector>

namespace lsdem {
namespace {

using parallel::DistributedWorld;

using test::rankOf;

// A shipped three-grains scene with `settings` applied and the text
// replacements `edits` (from, to) made, read as `lsdem run` reads it.
template <int D>
io::SceneDef<D> threeGrains(const std::string& name, const std::vector<io::SceneSetting>& settings,
                            const std::vector<std::pair<std::string, std::string>>& edits) {
  const std::string file = std::string(LSDEM_SOURCE_DIR) + "/apps/scenes/three_grains/" + name;
  std::string scene = test::readFile(file);
  for (const auto& [from, to] : edits) {
    const std::size_t at = scene.find(from);
    if (at == std::string::npos) throw std::runtime_error("test scene: '" + from + "' not in " + file);
    scene.replace(at, from.size(), to);
  }
  const auto path = test::tempPath(name);
  std::ofstream(path) << io::overrideScene(scene, settings, file);
  return std::get<io::SceneDef<D>>(io::readScene(path.string()));
}

struct Counts {
  std::size_t breakages = 0;
  std::size_t fines = 0;
  std::size_t particles = 0;
  std::size_t scaled = 0;  // fragments the density scaling scaled (serial)
};

// Runs `steps` steps of the scene in one world and spread over the ranks;
// every rank checks its time step and rank 0 compares the gathered run with
// the serial one, bit for bit. With several ranks, at least `ranksThatBreak`
// of them split grains.
template <int D>
Counts expectEqualToSerial(const io::SceneDef<D>& scene, std::uint64_t steps, std::uint64_t ranksThatBreak) {
  MPI_Comm comm = MPI_COMM_WORLD;
  io::SceneWorld<D> serial = io::buildWorld(scene);
  io::SceneWorld<D> local = io::buildWorld(scene);
  EXPECT_NE(serial.breakage, nullptr);
  DistributedWorld<D> dist(comm, *local.world);
  // Step by step: every rank takes the serial time step at every step.
  double serialSeconds = 0.0, distSeconds = 0.0;
  std::uint64_t firstOtherDt = 0, firstOtherCritical = 0;
  for (std::uint64_t s = 1; s <= steps; ++s) {
    const auto t0 = std::chrono::steady_clock::now();
    serial.world->step();
    const auto t1 = std::chrono::steady_clock::now();
    dist.step();
    serialSeconds += std::chrono::duration<double>(t1 - t0).count();
    distSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    if (firstOtherDt == 0 && local.world->dt() != serial.world->dt()) firstOtherDt = s;
    // The critical step (history's critical_dt_s) and what sets it: the
    // run's, not that of what this rank holds.
    if (firstOtherCritical == 0 && (local.world->criticalDt() != serial.world->criticalDt() ||
                                    local.world->timeStepLimit().id != serial.world->timeStepLimit().id)) {
      firstOtherCritical = s;
    }
  }
  EXPECT_EQ(firstOtherDt, 0u) << "rank " << rankOf(comm) << ": another time step from step " << firstOtherDt;
  EXPECT_EQ(firstOtherCritical, 0u) << "rank " << rankOf(comm) << ": another critical step from step "
                                    << firstOtherCritical;
  EXPECT_EQ(local.world->time(), serial.world->time());
  const std::uint64_t count = dist.globalCount();
  EXPECT_EQ(count, serial.world->particles().size());

  const auto states = dist.gather(0);
  const auto events = dist.gatherBreakageEvents(*local.breakage, 0);
  const auto removed = dist.gatherRemoved(0);
  const double mass = dist.particleMass();
  const dynamics::EnergyLedger ledger = dist.energy();
  // The view of the whole run (as `lsdem run` builds it: the scene without
  // its particles), brought up to now on rank 0.
  io::SceneDef<D> viewDef = scene;
  std::erase_if(viewDef.groups, [](const io::ParticleGroupDef<D>& g) { return g.placement != io::Placement::Feed; });
  io::SceneWorld<D> view = io::buildWorld(viewDef);
  dist.updateView(*view.world, 0);
  // Where the splits happened: a run on several ranks breaks grains on more than one.
  std::uint64_t mine = local.breakage->breakages(), ranksThatBroke = mine > 0 ? 1 : 0;
  MPI_Allreduce(MPI_IN_PLACE, &ranksThatBroke, 1, MPI_UINT64_T, MPI_SUM, comm);
  std::uint64_t migrations = dist.stats().migrations;
  MPI_Allreduce(MPI_IN_PLACE, &migrations, 1, MPI_UINT64_T, MPI_SUM, comm);

  // Density scaling: every rank's decisions, summed, are the serial ones.
  std::uint64_t scaledHere = local.world->densityScaling().scaled;
  MPI_Allreduce(MPI_IN_PLACE, &scaledHere, 1, MPI_UINT64_T, MPI_SUM, comm);
  EXPECT_EQ(scaledHere, serial.world->densityScaling().scaled);
  EXPECT_EQ(local.world->densityScaling().referenceOmega2, serial.world->densityScaling().referenceOmega2);
  // Each particle a rank holds (its own and mirrors) has the serial particle's scale and mass.
  {
    const dynamics::Particles<D>& p = serial.world->particles();
    const dynamics::Particles<D>& q = local.world->particles();
    for (std::size_t j = 0; j < q.size(); ++j) {
      const std::size_t i = std::size_t(std::find(p.id.begin(), p.id.end(), q.id[j]) - p.id.begin());
      EXPECT_LT(i, p.size()) << "id " << q.id[j];
      if (i == p.size()) break;
      EXPECT_EQ(local.world->decidedDensityScale(j), serial.world->decidedDensityScale(i)) << "id " << q.id[j];
      EXPECT_EQ(q.mass[j], p.mass[i]) << "id " << q.id[j];
    }
  }

  Counts c;
  c.breakages = serial.breakage->breakages();
  c.particles = serial.world->particles().size();
  c.fines = serial.world->removed().size();
  c.scaled = serial.world->densityScaling().scaled;
  if (rankOf(comm) != 0) return c;
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  std::printf("[ %dD, %d ranks ] %llu steps: %zu breakages on %llu ranks, %zu particles, %zu fines, %llu migrations; "
              "t = %.3g s, serial %.2f s, distributed %.2f s\n",
              D, ranks, (unsigned long long)steps, c.breakages, (unsigned long long)ranksThatBroke, c.particles,
              c.fines, (unsigned long long)migrations, serial.world->time(), serialSeconds, distSeconds);

  // The view: the run's particles, its next free id (past fragments gone as
  // fines: a checkpoint written from the view resumes with the serial ids)
  // and what sets its step.
  EXPECT_EQ(view.world->particles().size(), serial.world->particles().size());
  EXPECT_EQ(view.world->particles().nextId(), serial.world->particles().nextId());
  EXPECT_EQ(view.world->criticalDt(), serial.world->criticalDt());
  EXPECT_EQ(view.world->timeStepLimit().id, serial.world->timeStepLimit().id);
  EXPECT_EQ(view.world->dt(), serial.world->dt());

  // Every particle: the same ids, and the same motion bit for bit.
  const dynamics::Particles<D>& p = serial.world->particles();
  std::vector<std::size_t> order(p.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p.id[a] < p.id[b]; });
  EXPECT_EQ(states.size(), p.size());
  for (std::size_t k = 0; k < std::min(states.size(), p.size()); ++k) {
    const std::size_t i = order[k];
    EXPECT_EQ(states[k].id, p.id[i]) << "particle " << k << " by id";
    if (states[k].id != p.id[i]) break;
    for (int a = 0; a < D; ++a) {
      EXPECT_EQ(states[k].position[a], p.position[i][a]) << "id " << p.id[i] << " axis " << a;
      EXPECT_EQ(states[k].velocity[a], p.velocity[i][a]) << "id " << p.id[i] << " axis " << a;
    }
    if constexpr (D == 2) {
      EXPECT_EQ(states[k].orientation, p.orientation[i]) << "id " << p.id[i];
      EXPECT_EQ(states[k].angularVelocity, p.angularVelocity[i]) << "id " << p.id[i];
    } else {
      EXPECT_EQ(states[k].orientation.coeffs(), p.orientation[i].coeffs()) << "id " << p.id[i];
      EXPECT_EQ(states[k].angularVelocity, p.angularVelocity[i]) << "id " << p.id[i];
    }
  }

  // The breakage log: the same splits, in the same order, with the same ids.
  const auto& ref = serial.breakage->events();
  EXPECT_EQ(events.size(), ref.size());
  for (std::size_t e = 0; e < std::min(events.size(), ref.size()); ++e) {
    EXPECT_EQ(events[e].time, ref[e].time) << "event " << e;
    EXPECT_EQ(events[e].parent, ref[e].parent) << "event " << e;
    EXPECT_EQ(events[e].children, ref[e].children) << "event " << e;
    EXPECT_EQ(events[e].finesVolumes, ref[e].finesVolumes) << "event " << e;
    EXPECT_EQ(events[e].fragmentMass, ref[e].fragmentMass) << "event " << e;
    EXPECT_EQ(events[e].childVolumes, ref[e].childVolumes) << "event " << e;
    EXPECT_EQ(events[e].criterionValue, ref[e].criterionValue) << "event " << e;
    EXPECT_EQ(events[e].planeNormal, ref[e].planeNormal) << "event " << e;
    EXPECT_EQ(events[e].planeOffset, ref[e].planeOffset) << "event " << e;
    // The fragments' springs, summed over the ranks.
    EXPECT_NEAR(events[e].fragmentSpringEnergy, ref[e].fragmentSpringEnergy,
                1e-12 * std::abs(ref[e].fragmentSpringEnergy) + 1e-300)
        << "event " << e;
  }

  // Fines: the same records; their mass summed in the serial order is the
  // effect's total bit for bit; the mass balance holds to round-off.
  const auto& gone = serial.world->removed();
  EXPECT_EQ(removed.size(), gone.size());
  double finesMass = 0.0;
  for (std::size_t k = 0; k < std::min(removed.size(), gone.size()); ++k) {
    EXPECT_EQ(removed[k].id, gone[k].id) << "removal " << k;
    EXPECT_EQ(removed[k].time, gone[k].time) << "removal " << k;
    EXPECT_EQ(removed[k].mass, gone[k].mass) << "removal " << k;
    EXPECT_EQ(removed[k].reason, gone[k].reason) << "removal " << k;
    finesMass += removed[k].mass;
  }
  EXPECT_EQ(finesMass, serial.breakage->finesMass());
  const double total = serial.world->particleMass() + serial.world->removedMass();
  EXPECT_NEAR(mass + finesMass, total, 1e-12 * total);
  EXPECT_NEAR(mass, serial.world->particleMass(), 1e-12 * total);
  // The energy budget, summed over the ranks (each books its own particles
  // and pairs), is the serial one: the splits' fines, fragments and springs.
  const dynamics::EnergyLedger& budget = serial.world->energy();
  test::expectSameLedger(ledger, budget);
  EXPECT_GT(budget.removedEnergy, 0.0);
  EXPECT_NE(budget.splitRelease, 0.0);
  EXPECT_GT(budget.contactLoss, 0.0);
  EXPECT_NE(budget.boundaryWork, 0.0);
  // Splits on several ranks, where the scene gives them.
  if (ranks > 1) {
    EXPECT_GE(ranksThatBroke, ranksThatBreak);
  }
  return c;
}

// The 2D stack: the platen starts on the top grain and comes down 10x
// faster; the stack is crushed into many fragments and fines.
TEST(DistributedBreakage, ThreeGrains2DEqualsSerialBitForBit) {
  const auto scene = threeGrains<2>("three_grains_2d.toml", {},
                                    {{"point = [0.0, 0.0035]", "point = [0.0, 0.00335]"},
                                     {"velocity = [0.0, -0.02]", "velocity = [0.0, -0.2]"}});
  const Counts c = expectEqualToSerial(scene, 6000, 2);
  EXPECT_GE(c.breakages, 20u);
  EXPECT_GT(c.fines, 0u);
}

// The same with density scaling of the fragments under half a grain: each
// rank scales its own fragments from the whole run's reference, and a
// fragment's scale travels with it to the ranks that mirror or take it.
TEST(DistributedBreakage, ThreeGrains2DWithDensityScalingEqualsSerialBitForBit) {
  const auto scene = threeGrains<2>("three_grains_2d.toml",
                                    {{"simulation.density_scaling_below", "0.0005"},
                                     {"simulation.density_scaling_max", "100"}},
                                    {{"point = [0.0, 0.0035]", "point = [0.0, 0.00335]"},
                                     {"velocity = [0.0, -0.02]", "velocity = [0.0, -0.2]"}});
  ASSERT_TRUE(scene.world.densityScaling);
  const Counts c = expectEqualToSerial(scene, 6000, 2);
  EXPECT_GE(c.breakages, 20u);
  EXPECT_GE(c.scaled, 3u);
}

// The 3D stack likewise (platen 7.5x faster): the grains break into a few
// fragments and fines.
TEST(DistributedBreakage, ThreeGrains3DEqualsSerialBitForBit) {
  const auto scene = threeGrains<3>("three_grains_3d.toml", {},
                                    {{"point = [0.0, 0.0, 0.0035]", "point = [0.0, 0.0, 0.0034]"},
                                     {"velocity = [0.0, 0.0, -0.04]", "velocity = [0.0, 0.0, -0.3]"}});
  const Counts c = expectEqualToSerial(scene, 14500, 1);
  EXPECT_GE(c.breakages, 5u);
  EXPECT_GT(c.fines, 0u);
}

// A packing of 500 grains in 3D (tests/parallel/packing_500_3d.toml) crushed
// by a platen from the top layer, 2000 steps: grains break on more than one
// rank, and the run equals the one-process run bit for bit.
TEST(DistributedBreakage, PackingOf500Grains3DEqualsSerialBitForBit) {
  const std::string file = std::string(LSDEM_SOURCE_DIR) + "/tests/parallel/packing_500_3d.toml";
  const auto scene = std::get<io::SceneDef<3>>(io::readScene(file));
  const Counts c = expectEqualToSerial(scene, 2000, 2);
  EXPECT_GE(c.breakages, 10u);
  EXPECT_GE(c.particles, 510u);
}

}  // namespace
}  // namespace lsdem
