// The run's parts one at a time (io/src/run): the Schedule every recorder and
// the checkpoints share, and each recorder's file, record, checkpointed state
// and resume.

#include "support/Files.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/Scene.h"
#include "NumberText.h"
#include "run/BreakageLogRecorder.h"
#include "run/DistributionRecorder.h"
#include "run/FrameRecorder.h"
#include "run/HistoryRecorder.h"
#include "run/RemovedLog.h"
#include "run/Schedule.h"
#include "run/SummaryRecorder.h"
#include "run/TrackRecorder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

using namespace lsdem;
using namespace lsdem::io;
namespace fs = std::filesystem;
using lsdem::test::readFile;

namespace {

// Four discs on a floor between walls, pressed by a platen: a specimen.
const char* kScene = R"(
[simulation]
dimension = 2
steps = 400
dt = 2e-6

[contact]
kn = 2e5

[materials.rock]
density = 2650.0

[shapes.disc]
kind = "circle"
radius = 0.001
cells_across = 12

[[particles]]
shape = "disc"
material = "rock"
positions = [[0.001, 0.001], [0.003, 0.001], [0.005, 0.001], [0.007, 0.001]]

[[planes]]
name = "floor"
point = [0.0, 0.0]
normal = [0.0, 1.0]

[[planes]]
name = "platen"
point = [0.0, 0.0021]
normal = [0.0, -1.0]
velocity = [0.0, -0.5]

[output]
frames = 4

[output.specimen]
top = "platen"
bottom = "floor"
width = 0.008
)";

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream s(text);
  for (std::string l; std::getline(s, l);) out.push_back(l);
  return out;
}

std::size_t cells(const std::string& line) { return std::size_t(std::count(line.begin(), line.end(), ',')) + 1; }

// A scene, its world and a run context writing into a scratch folder.
struct Run2 {
  fs::path dir;
  SceneDef<2> scene;
  SceneWorld<2> sw;
  RunContext<2> context;

  explicit Run2(const std::string& name)
      : dir(lsdem::test::tempPath("recorders_" + name)),
        scene(read(dir)),
        sw(buildWorld(scene)),
        context{scene, sw, dir, {sw.initialMass, 0.0021}, std::chrono::steady_clock::now(), false, {}, {}, {}, 0.0} {}

  static SceneDef<2> read(const fs::path& dir) {
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::ofstream(dir / "scene.toml") << kScene;
    return std::get<SceneDef<2>>(readScene((dir / "scene.toml").string()));
  }
  Instant now() const { return {sw.world->time(), sw.world->steps(), double(sw.world->steps())}; }
  void steps(int n) {
    for (int k = 0; k < n; ++k) sw.world->step();
  }
};

// The state a recorder saves, read back as a checkpoint would.
template <class R>
std::vector<char> saved(R& r) {
  dynamics::StateWriter w;
  r.save(w);
  return w.bytes();
}

// The example of docs/design.md "Adding a recorder", as it stands there.
// contacts.csv: step, time and the contacts (particle pairs, and particles on
// planes and tools) at each record.
template <int D>
class ContactCount final : public Recorder<D> {
 public:
  using typename Recorder<D>::World;
  ContactCount(Schedule schedule, const RunContext<D>& context)
      : Recorder<D>("contact_count", std::move(schedule), context) {
    file_ = this->addCsv("contacts.csv", "step,time_s,contacts");
  }

 private:
  void write(const World& w) override {
    this->csv(file_).row(std::to_string(w.steps()) + "," + numberText(w.time()) + "," +
                         std::to_string(w.contacts().pairContacts().size()));
  }
  std::size_t file_ = 0;
};

}  // namespace

TEST(Schedule, EveryIntervalIsDueOnceAtEachMultiple) {
  Schedule s = Schedule::every(10.0);
  int served = 0;
  for (std::uint64_t step = 0; step <= 100; ++step) {
    const Instant now{0.0, step, double(step)};
    if (s.due(now)) ++served;
    s.advance(now);
  }
  EXPECT_EQ(served, 11);  // 0, 10, ..., 100
  EXPECT_FALSE(Schedule().due({1.0, 1, 1.0}));
  EXPECT_TRUE(Schedule::everyStep().due({1.0, 1, 1.0}));
}

// A fractional interval on a step clock (30,000 records over 1e5 steps):
// record k falls on the first step at or after k x interval for every k, the
// last one too (summed intervals drifted 3,244 of them a step late).
TEST(Schedule, FractionalIntervalsDoNotDrift) {
  const double interval = 100000.0 / 30000.0;
  Schedule s = Schedule::every(interval);
  std::uint64_t k = 0;
  for (std::uint64_t step = 0; step <= 100000; ++step) {
    const Instant now{0.0, step, double(step)};
    if (s.due(now)) {
      ASSERT_EQ(step, std::uint64_t(std::ceil(double(k) * interval - 1e-9 * interval))) << "record " << k;
      ++k;
    }
    s.advance(now);
  }
  EXPECT_EQ(k, 30001u);
}

TEST(Schedule, IntervalsFarBelowTheClockStepStayBounded) {
  Schedule s = Schedule::every(1e-30);
  const Instant now{1.0, 1, 1.0};
  EXPECT_TRUE(s.due(now));
  s.advance(now);  // returns at once, past the clock
  EXPECT_FALSE(s.due(now));
  EXPECT_TRUE(s.due({1.0 + 1e-9, 2, 1.0 + 1e-9}));
}

TEST(Schedule, ListedTimesAreDueOnceEachAndResumeWhereTheyWere) {
  Schedule s = Schedule::at({0.5, 1.0, 1.0000001, 2.0});
  EXPECT_FALSE(s.due({0.4, 4, 0.4}));
  EXPECT_TRUE(s.due({0.5, 5, 0.5}));
  s.advance({0.5, 5, 0.5});
  EXPECT_FALSE(s.due({0.6, 6, 0.6}));
  // Two times within one step: one record, both served.
  EXPECT_TRUE(s.due({1.1, 11, 1.1}));
  s.advance({1.1, 11, 1.1});
  dynamics::StateWriter w;
  s.save(w);
  Schedule r = Schedule::at({0.5, 1.0, 1.0000001, 2.0});
  dynamics::StateReader in(w.bytes().data(), w.bytes().size());
  r.load(in);
  EXPECT_FALSE(r.due({1.9, 19, 1.9}));
  EXPECT_TRUE(r.due({2.0, 20, 2.0}));
}

TEST(Recorders, HistoryRowsMatchTheHeaderAndTheSpecimen) {
  Run2 run("history");
  HistoryRecorder<2> h(Schedule::every(100.0), run.context);
  h.create();
  h.record(*run.sw.world, run.now());
  run.steps(200);
  h.record(*run.sw.world, run.now());
  const std::vector<std::string> rows = lines(readFile(run.dir / "history.csv"));
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_NE(rows[0].find("floor_force_y_N"), std::string::npos);
  EXPECT_NE(rows[0].find(",height_m,stress_Pa,strain,void_ratio"), std::string::npos);
  for (const std::string& r : rows) EXPECT_EQ(cells(r), cells(rows[0])) << r;
  EXPECT_EQ(rows[2].substr(0, 4), "200,");
  // The platen moved 200 steps x 2e-6 s x 0.5 m/s = 0.2 mm down from 2.1 mm.
  std::vector<std::string> c;
  std::stringstream s(rows[2]);
  for (std::string x; std::getline(s, x, ',');) c.push_back(x);
  const double height = std::stod(c[c.size() - 4]), strain = std::stod(c[c.size() - 2]);
  EXPECT_NEAR(height, 0.0021 - 2e-4, 1e-12);
  EXPECT_NEAR(strain, 2e-4 / 0.0021, 1e-9);
}

TEST(Recorders, DistributionsEndAtAllTheMassAndWriteNoProductWithoutOutflow) {
  Run2 run("distributions");
  DistributionRecorder<2> d(Schedule(), run.context);
  d.create();
  d.record(*run.sw.world, run.now());
  d.finish(*run.sw.world, run.now());  // at the same instant: no second record
  const std::vector<std::string> psd = lines(readFile(run.dir / "psd.csv"));
  ASSERT_EQ(psd.size(), 5u);  // the header, four discs
  EXPECT_EQ(psd.back().substr(psd.back().rfind(',') + 1), "100");
  const std::vector<std::string> stats = lines(readFile(run.dir / "shape_stats.csv"));
  ASSERT_EQ(stats.size(), 2u);
  EXPECT_EQ(stats[1].substr(0, 4), "0,0,");  // time 0, strain 0
  EXPECT_EQ(lines(readFile(run.dir / "shape_histograms.csv")).size(), 21u);
  EXPECT_FALSE(fs::exists(run.dir / "product_psd.csv"));
}

TEST(Recorders, RemovedLogWritesEachRemovalOnceAcrossAResume) {
  Run2 run("removed");
  RemovedLog<2> log(run.context);
  log.create();
  run.sw.world->removeParticle(0, "outflow");
  log.record(*run.sw.world, run.now());
  log.record(*run.sw.world, run.now());
  const std::vector<char> state = saved(log);  // a checkpoint after one removal
  run.sw.world->removeParticle(0, "outflow");
  log.record(*run.sw.world, run.now());
  EXPECT_EQ(lines(readFile(run.dir / "removed.csv")).size(), 3u);
  // Resumed from the checkpoint: the second row is cut, written again once.
  RemovedLog<2> resumed(run.context);
  dynamics::StateReader in(state.data(), state.size());
  resumed.load(in);
  EXPECT_EQ(lines(readFile(run.dir / "removed.csv")).size(), 3u);  // load changes nothing
  resumed.reopen();
  EXPECT_EQ(lines(readFile(run.dir / "removed.csv")).size(), 2u);
  resumed.record(*run.sw.world, run.now());
  const std::vector<std::string> rows = lines(readFile(run.dir / "removed.csv"));
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[1].substr(rows[1].rfind(',') + 1), "outflow");
  EXPECT_NE(rows[1].substr(0, rows[1].find(',')), rows[2].substr(0, rows[2].find(',')));
}

TEST(Recorders, AResumeRefusesADamagedFileBeforeChangingAny) {
  Run2 run("damaged");
  RemovedLog<2> log(run.context);
  log.create();
  const std::vector<char> state = saved(log);
  std::ofstream(run.dir / "removed.csv") << "another,header\n";
  RemovedLog<2> resumed(run.context);
  dynamics::StateReader in(state.data(), state.size());
  EXPECT_THROW(resumed.load(in), InputError);
  EXPECT_EQ(readFile(run.dir / "removed.csv"), "another,header\n");
}

TEST(Recorders, BreakageLogWithoutBreakageHoldsItsHeaderOnly) {
  Run2 run("breakage_log");
  BreakageLogRecorder<2> log(run.context);
  log.create();
  run.steps(10);
  log.record(*run.sw.world, run.now());
  const std::vector<std::string> rows = lines(readFile(run.dir / "breakage_log.csv"));
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_GT(cells(rows[0]), 10u);
}

TEST(Recorders, FramesAfterTheCheckpointAreDroppedOnResume) {
  Run2 run("frames");
  FrameRecorder<2> frames(Schedule(), run.context);
  frames.create();
  frames.record(*run.sw.world, run.now());
  run.steps(50);
  frames.record(*run.sw.world, run.now());
  const std::vector<char> state = saved(frames);
  const std::string atCheckpoint = readFile(run.dir / "particles.pvd");
  run.steps(50);
  frames.record(*run.sw.world, run.now());
  ASSERT_TRUE(fs::exists(run.dir / "frames/particles_000002.vtp"));
  FrameRecorder<2> resumed(Schedule(), run.context);
  dynamics::StateReader in(state.data(), state.size());
  resumed.load(in);
  resumed.reopen();
  EXPECT_EQ(readFile(run.dir / "particles.pvd"), atCheckpoint);
}

TEST(Recorders, SummarySaysWhetherTheRunStoppedOnlyAtTheEnd) {
  Run2 run("summary");
  SummaryRecorder<2> summary(Schedule(), run.context);
  summary.create();
  run.context.stopped = true;
  summary.record(*run.sw.world, run.now());
  EXPECT_NE(readFile(run.dir / "summary.json").find("\"stopped_early\": false"), std::string::npos);
  summary.finish(*run.sw.world, run.now());
  const std::string text = readFile(run.dir / "summary.json");
  EXPECT_NE(text.find("\"stopped_early\": true"), std::string::npos);
  EXPECT_NE(text.find("\"relative_error\": 0"), std::string::npos);
}

// The design page's example recorder, run the way the run loop runs it: the
// first instant, the due ones, the last; by the end the platen presses the
// four discs onto the floor.
TEST(Recorders, TheDesignPagesExampleRecordsOnItsSchedule) {
  Run2 run("example");
  ContactCount<2> count(Schedule::every(100.0), run.context);
  count.create();
  count.record(*run.sw.world, run.now());
  count.schedule().advance(run.now());
  for (int k = 0; k < 400; ++k) {
    run.steps(1);
    if (count.schedule().due(run.now())) count.record(*run.sw.world, run.now());
    count.schedule().advance(run.now());
  }
  count.finish(*run.sw.world, run.now());  // step 400 was recorded: no second row
  const std::vector<std::string> rows = lines(readFile(run.dir / "contacts.csv"));
  ASSERT_EQ(rows.size(), 6u);  // the header, steps 0, 100, 200, 300, 400
  EXPECT_EQ(rows[1], "0,0,0");
  EXPECT_EQ(rows[5].substr(0, 4), "400,");
  EXPECT_EQ(rows[5].substr(rows[5].rfind(',') + 1), "8");  // four discs on the floor and under the platen
}

// tracks.csv: the listed particles' state, ascending ids, read back exactly
// (shortest round-trip numbers); a particle that moved in the store (a
// removal swapped it into the hole) is still found, one that left gives no
// row, and a resume cuts the file back to the checkpoint's rows.
TEST(Recorders, TracksHoldTheListedParticlesStateExactlyAcrossMovesAndAResume) {
  Run2 run("tracks");
  run.scene.output.track = {3, 1, 0};
  TrackRecorder<2> tracks(Schedule::everyStep(), run.context);
  tracks.create();
  tracks.record(*run.sw.world, run.now());
  run.steps(300);  // the platen has reached the discs: forces and torques are not zero
  tracks.record(*run.sw.world, run.now());
  const std::vector<char> state = saved(tracks);

  const auto column = [](const std::string& row, std::size_t k) {
    std::vector<std::string> c;
    std::stringstream s(row);
    for (std::string x; std::getline(s, x, ',');) c.push_back(x);
    return std::stod(c.at(k));
  };
  std::vector<std::string> rows = lines(readFile(run.dir / "tracks.csv"));
  ASSERT_EQ(rows.size(), 7u);  // the header, ids 0, 1, 3 at steps 0 and 300
  EXPECT_EQ(rows[0], "step,time_s,id,x_m,y_m,vx_m_per_s,vy_m_per_s,wz_rad_per_s,fx_N,fy_N,tz_N_m");
  EXPECT_EQ(TrackRecorder<3>::header(),
            "step,time_s,id,x_m,y_m,z_m,vx_m_per_s,vy_m_per_s,vz_m_per_s,wx_rad_per_s,wy_rad_per_s,wz_rad_per_s,"
            "fx_N,fy_N,fz_N,tx_N_m,ty_N_m,tz_N_m");
  EXPECT_EQ(rows[1], "0,0,0,0.001,0.001,0,0,0,0,0,0");
  EXPECT_EQ(rows[3].substr(0, 18), "0,0,3,0.007,0.001,");
  const dynamics::Particles<2>& p = run.sw.world->particles();
  for (std::size_t r = 4; r < 7; ++r) {
    const std::size_t i = std::size_t(column(rows[r], 2));  // ids are indices before any removal
    EXPECT_EQ(rows[r].substr(0, 4), "300,");
    EXPECT_EQ(column(rows[r], 1), run.sw.world->time());
    EXPECT_EQ(column(rows[r], 3), p.position[i].x());
    EXPECT_EQ(column(rows[r], 4), p.position[i].y());
    EXPECT_EQ(column(rows[r], 6), p.velocity[i].y());
    EXPECT_EQ(column(rows[r], 7), p.angularVelocity[i]);
    EXPECT_EQ(column(rows[r], 9), p.force[i].y());
    EXPECT_EQ(column(rows[r], 10), p.torque[i]);
  }
  EXPECT_GT(std::abs(column(rows[6], 9)), 0.0);  // id 3 is pressed

  // Particle 0 leaves; particle 3 takes its place in the store.
  const double x3 = p.position[3].x();
  run.sw.world->removeParticle(0, "outflow");
  tracks.record(*run.sw.world, run.now());
  rows = lines(readFile(run.dir / "tracks.csv"));
  ASSERT_EQ(rows.size(), 9u);
  EXPECT_EQ(column(rows[7], 2), 1.0);
  EXPECT_EQ(column(rows[8], 2), 3.0);
  EXPECT_EQ(column(rows[8], 3), x3);

  TrackRecorder<2> resumed(Schedule::everyStep(), run.context);
  dynamics::StateReader in(state.data(), state.size());
  resumed.load(in);
  resumed.reopen();
  EXPECT_EQ(lines(readFile(run.dir / "tracks.csv")).size(), 7u);
}
