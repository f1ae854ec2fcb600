// Determinism of a whole world (issue 16): a scene of over 500 grains with
// breakage, stepped at 1, 2 and 4 OpenMP threads, ends in byte-identical
// states. Enough grains and contacts that the parallel loops run (the
// integrator's above 512 particles, the narrow phase's above 32 pairs) and
// grains break (the splits run in parallel too).

#include "support/Files.h"
#include "lsdem/io/Scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

using namespace lsdem;
namespace fs = std::filesystem;

namespace {

// Two blocks of random grains (18 x 30 each) thrown at each other in a box:
// they meet within 20 steps, and weak grains break.
const char* kCollisionScene = R"([simulation]
dimension = 2
steps = 1500
seed = 3

[contact]
kn = 2e5
friction = 0.4
damping_ratio = 0.3

[materials.rock]
density = 2650.0

[shapes.grain]
kind = "random_grain"
equivalent_diameter = 0.002
elongation = 1.2
roughness = 0.05
seed = 4
cells_across = 12
node_density = 1.0

[[particles]]
shape = "grain"
material = "rock"
placement = "grid"
region = { min = [0.0, 0.0], max = [0.072, 0.024] }
random_orientation = true
velocity = [0.0, 1.0]

[[particles]]
shape = "grain"
material = "rock"
placement = "grid"
region = { min = [0.0, 0.024], max = [0.072, 0.048] }
random_orientation = true
velocity = [0.0, -1.0]

[[planes]]
name = "floor"
point = [0.0, 0.0]
normal = [0.0, 1.0]

[[planes]]
name = "left"
point = [0.0, 0.0]
normal = [1.0, 0.0]

[[planes]]
name = "right"
point = [0.072, 0.0]
normal = [-1.0, 0.0]

[[planes]]
name = "top"
point = [0.0, 0.048]
normal = [0.0, -1.0]

[effects]
gravity = [0.0, -9.81]

[effects.breakage]
criterion = "von_mises"
von_mises_strength = 3e4
reference_strength = 3e4
reference_diameter = 0.002
min_volume = 8e-8
)";

struct FinalState {
  std::size_t particles = 0;
  std::size_t breakages = 0;
  std::size_t chips = 0;
  std::size_t mostPairs = 0;     // the most touching pairs in a step
  std::string kinematics;        // id, position, velocity, orientation, angular velocity of every particle, in store order
  std::string books;             // energy ledger, time step, removed particles (id, mass, size)
};

// The same collision with chipping declared (corners and asperities of the
// grains chip where the blocks meet).
std::string chippingScene() {
  return std::string(kCollisionScene) + R"(
[effects.breakage.chipping]
reference_strength = 1e5
reference_depth = 1e-3
depth_fraction = 0.3
max_width_to_depth = 8.0
)";
}

FinalState run(int threads, std::size_t steps, const std::string& text = kCollisionScene) {
#ifdef LSDEM_HAVE_OPENMP
  omp_set_num_threads(threads);
  EXPECT_EQ(omp_get_max_threads(), threads);
#else
  (void)threads;
#endif
  const fs::path file = lsdem::test::tempPath("lsdem_test_determinism.toml");
  std::ofstream(file) << text;
  const io::SceneDef<2> scene = std::get<io::SceneDef<2>>(io::readScene(file.string()));
  fs::remove(file);
  io::SceneWorld<2> sw = io::buildWorld(scene);
  dynamics::World<2>& w = *sw.world;
  FinalState s;
  for (std::size_t k = 0; k < steps; ++k) {
    w.step();
    s.mostPairs = std::max(s.mostPairs, w.contacts().pairContacts().size());
  }
  const auto& p = w.particles();
  s.particles = p.size();
  s.breakages = sw.breakage ? sw.breakage->breakages() : 0;
  s.chips = sw.breakage ? sw.breakage->chips() : 0;
  const auto put = [&](const void* data, std::size_t n) { s.kinematics.append(static_cast<const char*>(data), n); };
  for (std::size_t i = 0; i < p.size(); ++i) {
    put(&p.id[i], sizeof(p.id[i]));
    put(p.position[i].data(), sizeof(double) * 2);
    put(p.velocity[i].data(), sizeof(double) * 2);
    put(&p.orientation[i], sizeof(p.orientation[i]));
    put(&p.angularVelocity[i], sizeof(p.angularVelocity[i]));
  }
  // (Not the saved world state as a whole: it holds the stages' wall-clock times.)
  const dynamics::EnergyLedger& e = w.energy();
  for (const double v : {e.kineticTranslational, e.kineticRotational, e.elastic, e.gravityWork, e.boundaryWork,
                         e.dampingLoss, e.contactLoss, e.removedEnergy, e.splitRelease, w.dt(), w.time()}) {
    s.books.append(reinterpret_cast<const char*>(&v), sizeof(v));
  }
  for (const dynamics::RemovedParticle& r : w.removed()) {
    s.books.append(reinterpret_cast<const char*>(&r.id), sizeof(r.id));
    s.books.append(reinterpret_cast<const char*>(&r.mass), sizeof(r.mass));
    s.books.append(reinterpret_cast<const char*>(&r.sieveSize), sizeof(r.sieveSize));
  }
  return s;
}

}  // namespace

TEST(Determinism, WorldWithBreakageIsBitwiseTheSameAt1And2And4Threads) {
  const std::size_t steps = 1500;
  const FinalState one = run(1, steps);
  // The scene does what the test needs: over 512 grains, pairs for the
  // threads to share, breakages.
  ASSERT_GT(one.particles, 512u);
  ASSERT_GT(one.mostPairs, 100u);
  ASSERT_GT(one.breakages, 20u);
  RecordProperty("particles", std::to_string(one.particles));
  RecordProperty("breakages", std::to_string(one.breakages));
  for (const int threads : {2, 4}) {
    const FinalState n = run(threads, steps);
    EXPECT_EQ(n.particles, one.particles) << threads << " threads";
    EXPECT_EQ(n.breakages, one.breakages) << threads << " threads";
    EXPECT_TRUE(n.kinematics == one.kinematics) << threads << " threads: positions or velocities differ";
    EXPECT_TRUE(n.books == one.books) << threads << " threads: energies, time step or removals differ";
  }
#ifdef LSDEM_HAVE_OPENMP
  omp_set_num_threads(2);
#endif
}

// Chips are applied with the splits in ascending global id, their strengths
// keyed by grain and partner: the same chips and states at any thread count.
TEST(Determinism, ChippingIsBitwiseTheSameAt1And2Threads) {
  const std::size_t steps = 800;
  const FinalState one = run(1, steps, chippingScene());
  ASSERT_GT(one.chips, 5u);
  RecordProperty("chips", std::to_string(one.chips));
  const FinalState two = run(2, steps, chippingScene());
  EXPECT_EQ(two.chips, one.chips);
  EXPECT_EQ(two.breakages, one.breakages);
  EXPECT_EQ(two.particles, one.particles);
  EXPECT_TRUE(two.kinematics == one.kinematics) << "positions or velocities differ";
  EXPECT_TRUE(two.books == one.books) << "energies, time step or removals differ";
#ifdef LSDEM_HAVE_OPENMP
  omp_set_num_threads(2);
#endif
}
