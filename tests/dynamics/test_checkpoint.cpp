// A world saved between steps and restored into a freshly built world of the
// same definition continues bit for bit like the world that was never stopped.

#include "support/Shapes.h"
#include "lsdem/dynamics/World.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <memory>

using namespace lsdem;
using namespace lsdem::dynamics;

namespace {

template <int D>
struct Heap {
  std::shared_ptr<const geometry::Shape<D>> small = test::sphereShape<D>(0.01, 8);
  std::shared_ptr<const geometry::Shape<D>> large = test::sphereShape<D>(0.015, 10);

  // A heap of spheres falling into a box with friction and damping, a servo
  // platen pressing from above, and a feed dropping more spheres.
  double frictionFrom = 0.0;  // s (ContactLawDef::frictionFrom)

  std::unique_ptr<World<D>> build() const {
    WorldDef<D> def;
    def.contact.frictionFrom = frictionFrom;
    def.contact.kn = 2e4;
    def.contact.ks = 1.6e4;
    def.gravity = Vec<D>(-9.81 * Vec<D>::Unit(1));
    def.localDamping = 0.1;
    auto w = std::make_unique<World<D>>(def);
    for (int a = 0; a < D; ++a) {
      PlaneDef<D> lo, hi;
      lo.plane.point = Vec<D>::Zero();
      lo.plane.normal = Vec<D>::Unit(a);
      w->addPlane(lo);
      if (a == 1) continue;
      hi.plane.point = 0.1 * Vec<D>::Unit(a);
      hi.plane.normal = -Vec<D>::Unit(a);
      w->addPlane(hi);
    }
    ToolDef<D> platen;
    platen.name = "platen";
    platen.shape = large;
    ServoPlatenDef<D> servo;
    servo.position = Vec<D>::Constant(0.05);
    servo.position[1] = 0.2;
    servo.targetForce = 0.5;
    servo.gain = 1e-3;
    servo.maxSpeed = 0.2;
    platen.motion = ServoPlaten<D>(servo);
    w->addTool(platen);
    int n = 0;
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 3; ++j) {
        ParticleDef<D> p;
        p.shape = (i + j) % 2 ? small : large;
        p.position = Vec<D>::Constant(0.05);
        p.position[0] = 0.02 + 0.022 * i;
        p.position[1] = 0.02 + 0.03 * j + 0.003 * (i % 2);
        p.velocity[0] = 0.05 * ((n++ % 3) - 1.0);
        w->addParticle(p);
      }
    }
    FeedDef<D> feed;
    feed.shapes = {small, large};
    feed.point = Vec<D>::Constant(0.05);
    feed.point[1] = 0.14;
    feed.interval = 0.02;
    feed.count = 3;
    w->addEffect(std::make_unique<Feed<D>>(feed));
    return w;
  }
};

template <int D>
void expectSameState(const World<D>& a, const World<D>& b) {
  ASSERT_EQ(a.particles().size(), b.particles().size());
  EXPECT_EQ(a.steps(), b.steps());
  EXPECT_EQ(a.time(), b.time());
  for (std::size_t i = 0; i < a.particles().size(); ++i) {
    EXPECT_EQ(a.particles().id[i], b.particles().id[i]);
    EXPECT_EQ(std::memcmp(a.particles().position[i].data(), b.particles().position[i].data(), sizeof(double) * D), 0)
        << "particle " << i;
    EXPECT_EQ(std::memcmp(a.particles().velocity[i].data(), b.particles().velocity[i].data(), sizeof(double) * D), 0)
        << "particle " << i;
  }
  EXPECT_EQ(a.energy().boundaryWork, b.energy().boundaryWork);
  EXPECT_EQ(a.energy().contactLoss, b.energy().contactLoss);
  EXPECT_EQ(a.toolPoses()[0].position, b.toolPoses()[0].position);
}

// A world's state, its shapes numbered as they come (the table gives them back).
template <int D>
struct SavedState {
  std::vector<char> bytes;
  std::vector<std::shared_ptr<const geometry::Shape<D>>> table;
};

// `wallClock` false: the stage times written as zeros (StateWriter::setWallClock).
template <int D>
SavedState<D> save(const World<D>& w, bool wallClock = true) {
  SavedState<D> saved;
  std::map<const geometry::Shape<D>*, std::uint32_t> index;
  StateWriter out;
  out.setWallClock(wallClock);
  w.saveState(out, [&](const std::shared_ptr<const geometry::Shape<D>>& s) {
    auto [it, added] = index.emplace(s.get(), std::uint32_t(saved.table.size()));
    if (added) saved.table.push_back(s);
    return it->second;
  });
  saved.bytes = out.bytes();
  return saved;
}

// Restores a saved state into `w` (built from the same setup); all of it is read.
template <int D>
void restore(World<D>& w, const SavedState<D>& saved) {
  StateReader in(saved.bytes.data(), saved.bytes.size());
  w.loadState(in, [&](std::uint32_t k) { return saved.table.at(k); });
  EXPECT_TRUE(in.atEnd());
}

// `frictionLate`: friction acts only from halfway through the resumed part,
// so the saved state has no shear history and the switch happens after the restore.
template <int D>
void checkpointRoundTrip(bool frictionLate = false) {
  Heap<D> setup;
  const std::uint64_t before = 1500, after = 1500;
  if (frictionLate) {
    auto probe = setup.build();
    probe->run(before);
    setup.frictionFrom = 1.5 * probe->time();
  }

  // Uninterrupted run.
  auto straight = setup.build();
  straight->run(before + after);

  // Stopped after `before` steps: state saved with a shape table.
  auto first = setup.build();
  first->run(before);
  const SavedState<D> saved = save(*first);
  if (frictionLate) {
    ASSERT_EQ(first->contacts().historySize(), 0u) << "frictionless until friction_from";
  } else {
    ASSERT_GT(first->contacts().historySize(), 0u) << "the test needs shear history to carry over";
  }

  // Restored into a fresh world and continued.
  auto resumed = setup.build();
  EXPECT_TRUE(resumed->savedToolPoses().empty());
  restore(*resumed, saved);
  expectSameState(*first, *resumed);
  // The platen's pose as the saved run had it (a resume compares it with its own motion's).
  ASSERT_EQ(resumed->savedToolPoses().size(), 1u);
  EXPECT_EQ(resumed->savedToolPoses()[0].position, first->toolPoses()[0].position);
  // A resume of the same scene poses it there again, bit for bit (a servo
  // platen from its restored travel), so its check never trips on one.
  EXPECT_EQ(resumed->toolPoses()[0].position, resumed->savedToolPoses()[0].position);
  EXPECT_EQ(Rotation<D>::matrix(resumed->toolPoses()[0].orientation),
            Rotation<D>::matrix(resumed->savedToolPoses()[0].orientation));
  EXPECT_NE(first->toolPoses()[0].position[1], 0.2) << "the platen moved from its start";
  resumed->run(after);
  expectSameState(*straight, *resumed);
  EXPECT_GT(resumed->particles().size(), 12u);  // the feed kept dropping
  if (frictionLate) {
    EXPECT_GT(resumed->contacts().historySize(), 0u) << "friction acts at the end";
  }
}

}  // namespace

TEST(Checkpoint, ResumedRunEqualsUninterruptedRun2D) { checkpointRoundTrip<2>(); }
TEST(Checkpoint, ResumedRunEqualsUninterruptedRun3D) { checkpointRoundTrip<3>(); }
TEST(Checkpoint, ResumedRunCrossingFrictionFromEqualsUninterruptedRun2D) { checkpointRoundTrip<2>(true); }
TEST(Checkpoint, ResumedRunCrossingFrictionFromEqualsUninterruptedRun3D) { checkpointRoundTrip<3>(true); }

TEST(Checkpoint, StateOfAnotherSceneIsRefused) {
  Heap<2> setup;
  auto a = setup.build();
  a->run(10);
  StateWriter out;
  a->saveState(out, [](const auto&) { return 0u; });
  WorldDef<2> def;
  World<2> other(def);  // no planes, no tools, no effects
  StateReader in(out.bytes().data(), out.bytes().size());
  EXPECT_THROW(other.loadState(in, [&](std::uint32_t) { return setup.small; }), std::runtime_error);
  // Truncated state.
  auto b = setup.build();
  StateReader cut(out.bytes().data(), out.bytes().size() / 2);
  EXPECT_THROW(b->loadState(cut, [&](std::uint32_t) { return setup.small; }), std::runtime_error);
}

// Two worlds that reach the same state write the same bytes, wall-clock
// stage times aside (written as zeros with setWallClock(false)): no padding
// or other uninitialised memory in the archive. The second world runs with
// other allocations and stack use in between, and a world restored from the
// first's state writes it back unchanged.
template <int D>
void sameStateSameBytes() {
  Heap<D> setup;
  auto a = setup.build();
  a->run(800);
  std::vector<std::vector<double>> noise;  // other allocations between the two runs
  for (int k = 0; k < 50; ++k) noise.emplace_back(std::size_t(100 + k), 1.0 + k);
  auto b = setup.build();
  b->run(800);
  const std::vector<char> bytesA = save(*a, false).bytes, bytesB = save(*b, false).bytes;
  ASSERT_GT(a->contacts().nodeContacts().size(), 0u) << "the test needs node contacts in the state";
  ASSERT_EQ(bytesA.size(), bytesB.size());
  const auto firstDiff = std::mismatch(bytesA.begin(), bytesA.end(), bytesB.begin()).first - bytesA.begin();
  EXPECT_EQ(std::size_t(firstDiff), bytesA.size()) << "first differing byte of " << bytesA.size();

  // Restored from a's full state (with its clocks) and saved again.
  const SavedState<D> full = save(*a);
  auto c = setup.build();
  restore(*c, full);
  EXPECT_TRUE(save(*c).bytes == full.bytes);
}

TEST(Checkpoint, SameStateSameBytes2D) { sameStateSameBytes<2>(); }
TEST(Checkpoint, SameStateSameBytes3D) { sameStateSameBytes<3>(); }

// A state saved right after a feed added a grain (its contact records stale:
// the next step re-evaluates them) resumes like the uninterrupted run. Before,
// a restored world took the saved records as current and went its own way.
TEST(Checkpoint, StateSavedAfterAFeedAddedAGrainResumesEqual) {
  Heap<2> setup;
  auto first = setup.build();
  std::uint64_t steps = 0;
  do {
    first->step();
    ++steps;
  } while (first->contactsCurrent() && steps < 20000);
  ASSERT_FALSE(first->contactsCurrent()) << "the feed never dropped a grain";
  auto resumed = setup.build();
  restore(*resumed, save(*first));
  EXPECT_FALSE(resumed->contactsCurrent());
  auto straight = setup.build();
  straight->run(steps + 300);
  resumed->run(300);
  expectSameState(*straight, *resumed);
}
