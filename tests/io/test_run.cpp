// Running scenes: the outputs a run writes (read back and checked), mass
// balance with breakage, and a resumed run equal to an uninterrupted one.

#include "support/Files.h"
#include "support/VtpReader.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/Run.h"
#include "lsdem/io/Scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

using namespace lsdem;
namespace fs = std::filesystem;

using lsdem::test::readFile;

namespace {

// A 2D box with a platen crushing eight breakable grains.
const char* kCrushScene = R"(
[simulation]
dimension = 2
duration = 0.012
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
cells_across = 24
node_density = 1.0

[[particles]]
shape = "grain"
material = "rock"
placement = "grid"
region = { min = [0.0, 0.0], max = [0.0096, 0.0048] }
random_orientation = true

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
point = [0.0096, 0.0]
normal = [-1.0, 0.0]

[[planes]]
name = "platen"
point = [0.0, 0.0052]
normal = [0.0, -1.0]
velocity = [0.0, -0.15]

[effects]
gravity = [0.0, -9.81]

[effects.breakage]
criterion = "von_mises"
von_mises_strength = 3e4
reference_strength = 3e4
reference_diameter = 0.002
min_volume = 8e-8

[output]
frames = 6
history_rows = 30
distributions = 3
checkpoint_every = 0.004
progress_seconds = 1e-9

[output.specimen]
top = "platen"
bottom = "floor"
width = 0.0096
)";

struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) : path(lsdem::test::tempPath("lsdem_test_run_" + name)) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream s(text);
  for (std::string l; std::getline(s, l);) out.push_back(l);
  return out;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream s(line);
  for (std::string c; std::getline(s, c, ',');) out.push_back(c);
  if (!line.empty() && line.back() == ',') out.push_back("");
  return out;
}

fs::path writeScene(const fs::path& dir, const std::string& text) {
  const fs::path p = dir / "scene.toml";
  std::ofstream(p) << text;
  return p;
}

}  // namespace

TEST(Run, WritesEveryOutputWithExactMassBalance) {
  TempDir dir("outputs");
  io::RunOptions o;
  o.scene = writeScene(dir.path, kCrushScene).string();
  o.outDir = (dir.path / "out").string();
  const io::RunResult r = io::runScene(o);

  EXPECT_FALSE(r.stopped);
  EXPECT_GT(r.breakages, 0u) << "the platen must break grains for this test to mean anything";
  EXPECT_GT(r.particles, 8u);
  EXPECT_LT(std::abs(r.massBalanceError), 1e-12);

  // history.csv: documented columns, one row per output time, last row at the end.
  const auto history = lines(readFile(dir.path / "out" / "history.csv"));
  ASSERT_GE(history.size(), 30u);
  const auto header = split(history[0]);
  for (const char* column : {"step", "time_s", "particles", "breakages", "kinetic_J", "energy_error_J",
                             "platen_force_y_N", "stress_Pa", "strain", "void_ratio"}) {
    EXPECT_NE(std::find(header.begin(), header.end(), column), header.end()) << column;
  }
  const auto last = split(history.back());
  ASSERT_EQ(last.size(), header.size());
  EXPECT_NEAR(std::stod(last[1]), 0.012, 1e-5);
  const std::size_t strainColumn = std::size_t(std::find(header.begin(), header.end(), "strain") - header.begin());
  // The platen's travel over the initial height.
  EXPECT_NEAR(std::stod(last[strainColumn]), 0.15 * std::stod(last[1]) / 0.0052, 1e-9);

  // The time step and what set it: each row's dt is the safety factor times
  // the critical step of the limiting particle's mass and stiffness (damping
  // ratio 0.3); it only falls, and after the splits a fragment sets it.
  const auto column = [&](const char* name) {
    const auto it = std::find(header.begin(), header.end(), name);
    EXPECT_NE(it, header.end()) << name;
    return std::size_t(it - header.begin());
  };
  const std::size_t dtCol = column("dt_s"), massCol = column("dt_limit_mass_kg"),
                    kCol = column("dt_limit_stiffness_N_per_m"), genCol = column("dt_limit_generation");
  column("critical_dt_s");
  column("dt_limit_contact");
  double previous = 1.0;
  for (std::size_t k = 1; k < history.size(); ++k) {
    const auto row = split(history[k]);
    const double dt = std::stod(row[dtCol]);
    const double critical = 2.0 * std::sqrt(std::stod(row[massCol]) / std::stod(row[kCol])) * (std::sqrt(1.09) - 0.3);
    EXPECT_NEAR(dt, 0.2 * critical, 1e-12 * dt) << history[k];
    EXPECT_LE(dt, previous);
    previous = dt;
  }
  EXPECT_GT(std::stoi(last[genCol]), 0);

  // The particles frame at the end: one point per particle, ids match the summary count.
  const test::VtpFile frame = test::readVtp((dir.path / "out" / "frames" / "particles_000006.vtp").string());
  EXPECT_EQ(frame.points, r.particles);
  EXPECT_EQ(frame.pointArray("id").tuples(), r.particles);

  // PSD: percent passing reaches 100 at every snapshot; 3 snapshots plus the end.
  const auto psd = lines(readFile(dir.path / "out" / "psd.csv"));
  int full = 0;
  for (std::size_t k = 1; k < psd.size(); ++k) full += std::abs(std::stod(split(psd[k])[2]) - 100.0) < 1e-9;
  EXPECT_EQ(full, 3);

  // Breakage log: one row per breakage.
  EXPECT_EQ(lines(readFile(dir.path / "out" / "breakage_log.csv")).size(), r.breakages + 1);
  // summary.json names the mass balance.
  const std::string summary = readFile(dir.path / "out" / "summary.json");
  EXPECT_NE(summary.find("\"mass_balance\""), std::string::npos);
  EXPECT_NE(summary.find("\"time_step\""), std::string::npos);
  EXPECT_NE(summary.find("\"manual_not_applied\""), std::string::npos);
  EXPECT_EQ(summary.find("\"density_scaling\""), std::string::npos);  // not asked for
  EXPECT_NE(summary.find("\"stopped_early\": false"), std::string::npos);
}

TEST(Run, ResumedRunEqualsUninterruptedRun) {
  TempDir dir("resume");
  // With tracks of two grains and of two fragments (ids 8 and 9, born in the
  // crush), on an interval of the clock.
  std::string text = kCrushScene;
  text.insert(text.find("[output]\n") + 9, "track = [9, 0, 3, 8]\ntrack_every = 0.0005\n");
  const std::string scene = writeScene(dir.path, text).string();

  io::RunOptions straight;
  straight.scene = scene;
  straight.outDir = (dir.path / "straight").string();
  const io::RunResult a = io::runScene(straight);

  // Stopped part-way (after breakage has started), then resumed.
  std::atomic<bool> stop{false};
  io::RunOptions first;
  first.scene = scene;
  first.outDir = (dir.path / "resumed").string();
  first.stop = &stop;
  first.progress = [&](const io::RunProgress& p) {
    if (p.time > 0.0071) stop = true;
  };
  const io::RunResult b1 = io::runScene(first);
  ASSERT_TRUE(b1.stopped);
  io::RunOptions second;
  second.resumeDir = first.outDir;
  const io::RunResult b = io::runScene(second);

  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.particles, b.particles);
  EXPECT_EQ(a.breakages, b.breakages);
  for (const char* file : {"history.csv", "psd.csv", "breakage_log.csv", "removed.csv", "shape_stats.csv",
                           "tracks.csv", "particles.pvd", "frames/particles_000006.vtp",
                           "frames/surfaces_000006.vtp"}) {
    EXPECT_EQ(readFile(dir.path / "straight" / file), readFile(dir.path / "resumed" / file)) << file;
  }
  // tracks.csv: the first instant, every 0.5 ms of the 12 ms, the last; the
  // fragments from when they are born.
  const std::vector<std::string> tracks = lines(readFile(dir.path / "straight" / "tracks.csv"));
  ASSERT_GT(tracks.size(), 1u);
  EXPECT_EQ(tracks[1].substr(0, 6), "0,0,0,");
  EXPECT_EQ(tracks[2].substr(0, 6), "0,0,3,");
  std::set<std::string> times, fragments;
  for (std::size_t k = 1; k < tracks.size(); ++k) {
    const std::vector<std::string> c = split(tracks[k]);
    times.insert(c[1]);
    if (c[2] == "8" || c[2] == "9") fragments.insert(c[2]);
  }
  EXPECT_EQ(times.size(), 25u);
  EXPECT_EQ(fragments.size(), 2u) << "the crush must make fragments 8 and 9 for this test to mean anything";
}

// The shipped chipping scene stopped after its first chip and resumed ends
// with every output of the uninterrupted run: the chip events, their mode
// and depth and the chip counters travel in the checkpoint.
TEST(Run, ResumedRunWithChipsEqualsUninterruptedRun) {
  TempDir dir("resume_chips");
  // The shipped scene with a progress call every step (to stop it where wanted).
  std::string text = readFile(fs::path(LSDEM_SOURCE_DIR) / "apps/scenes/chipping/single_grain_2d.toml");
  const std::size_t output = text.find("[output]\n");
  ASSERT_NE(output, std::string::npos);
  text.insert(output + 9, "progress_seconds = 1e-9\n");
  const std::string scene = writeScene(dir.path, text).string();
  io::RunOptions straight;
  straight.scene = scene;
  straight.outDir = (dir.path / "straight").string();
  const io::RunResult a = io::runScene(straight);
  std::atomic<bool> stop{false};
  io::RunOptions first;
  first.scene = scene;
  first.outDir = (dir.path / "resumed").string();
  first.stop = &stop;
  first.progress = [&](const io::RunProgress& p) {
    if (p.time > 0.0125) stop = true;  // after the first chip (0.0113 s), before the first split
  };
  const io::RunResult b1 = io::runScene(first);
  ASSERT_TRUE(b1.stopped);
  ASSERT_GE(b1.breakages, 1u);
  io::RunOptions second;
  second.resumeDir = first.outDir;
  const io::RunResult b = io::runScene(second);
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.breakages, b.breakages);
  const std::string log = readFile(dir.path / "straight" / "breakage_log.csv");
  EXPECT_NE(log.find(",chip,"), std::string::npos);
  EXPECT_NE(log.find(",split,"), std::string::npos);
  for (const char* file : {"history.csv", "psd.csv", "breakage_log.csv", "removed.csv", "shape_stats.csv"}) {
    EXPECT_EQ(readFile(dir.path / "straight" / file), readFile(dir.path / "resumed" / file)) << file;
  }
}

// A run killed after a periodic checkpoint (at 0.004 s, where a frame and a
// history row fall too) and resumed from it ends with every output equal to
// the uninterrupted run's: the files as they were at the kill (rows written
// after the checkpoint included) are cut back and continued.
TEST(Run, ResumeFromAPeriodicCheckpointEqualsUninterruptedRun) {
  TempDir dir("resume_periodic");
  const std::string scene = writeScene(dir.path, kCrushScene).string();
  io::RunOptions straight;
  straight.scene = scene;
  straight.outDir = (dir.path / "straight").string();
  bool copied = false;
  straight.progress = [&](const io::RunProgress& p) {
    if (!copied && p.time > 0.0047) {  // three history rows after the checkpoint
      fs::copy(dir.path / "straight", dir.path / "killed", fs::copy_options::recursive);
      copied = true;
    }
  };
  const io::RunResult a = io::runScene(straight);
  ASSERT_TRUE(copied);
  io::RunOptions resume;
  resume.resumeDir = (dir.path / "killed").string();
  const io::RunResult b = io::runScene(resume);
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.breakages, b.breakages);
  // Every file the run wrote, frames of every series included; the summary
  // and checkpoint differ in their wall times only.
  std::size_t compared = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir.path / "straight")) {
    if (!entry.is_regular_file()) continue;
    const fs::path rel = fs::relative(entry.path(), dir.path / "straight");
    if (rel == "summary.json" || rel == "checkpoint.lsc") continue;
    EXPECT_EQ(readFile(entry.path()), readFile(dir.path / "killed" / rel)) << rel;
    ++compared;
  }
  EXPECT_GE(compared, 30u);  // CSV files, 3 series of 7 frames and their .pvd
  for (const auto& entry : fs::recursive_directory_iterator(dir.path / "killed")) {
    EXPECT_TRUE(fs::exists(dir.path / "straight" / fs::relative(entry.path(), dir.path / "killed"))) << entry.path();
  }
}

// Without the energy ledger the motion is the same bit for bit: every
// output but the budget's columns is equal; the budget is left out.
TEST(Run, TheEnergyLedgerLeftOutChangesNothingButTheBudget) {
  TempDir dir("no_ledger");
  std::string text = kCrushScene;
  fs::create_directories(dir.path / "a");
  const std::string withLedger = writeScene(dir.path / "a", text).string();
  text.replace(text.find("[effects]\n"), 10, "[effects]\nenergy_ledger = false\n");
  fs::create_directories(dir.path / "b");
  const std::string without = writeScene(dir.path / "b", text).string();
  io::RunOptions a, b;
  a.scene = withLedger;
  a.outDir = (dir.path / "a" / "out").string();
  b.scene = without;
  b.outDir = (dir.path / "b" / "out").string();
  const io::RunResult ra = io::runScene(a), rb = io::runScene(b);
  ASSERT_GT(ra.breakages, 0u);
  EXPECT_EQ(ra.breakages, rb.breakages);
  for (const char* file : {"psd.csv", "breakage_log.csv", "removed.csv", "frames/particles_000006.vtp",
                           "frames/surfaces_000006.vtp"}) {
    EXPECT_EQ(readFile(dir.path / "a" / "out" / file), readFile(dir.path / "b" / "out" / file)) << file;
  }
  const std::vector<std::string> ha = lines(readFile(dir.path / "a" / "out" / "history.csv"));
  const std::vector<std::string> hb = lines(readFile(dir.path / "b" / "out" / "history.csv"));
  ASSERT_EQ(ha.size(), hb.size());
  const std::vector<std::string> header = split(ha[0]);
  const auto column = [&](const std::string& name) {
    return std::size_t(std::find(header.begin(), header.end(), name) - header.begin());
  };
  for (std::size_t r = 1; r < ha.size(); ++r) {
    const std::vector<std::string> ca = split(ha[r]), cb = split(hb[r]);
    ASSERT_EQ(ca.size(), cb.size());
    for (std::size_t c = 0; c < ca.size(); ++c) {
      const bool budget = c >= column("gravity_work_J") && c <= column("energy_error_J");
      if (budget) {
        EXPECT_EQ(cb[c], "") << header[c];
      } else {
        EXPECT_EQ(ca[c], cb[c]) << header[c] << " row " << r;
      }
    }
  }
  const std::string summary = readFile(dir.path / "b" / "out" / "summary.json");
  EXPECT_NE(summary.find("\"kinetic_translational\""), std::string::npos);
  EXPECT_EQ(summary.find("\"gravity_work\""), std::string::npos);
  EXPECT_NE(readFile(dir.path / "a" / "out" / "summary.json").find("\"gravity_work\""), std::string::npos);
}

TEST(Run, ResumeRefusesAChangedSceneAndAMissingCheckpoint) {
  TempDir dir("resume_bad");
  io::RunOptions o;
  o.resumeDir = (dir.path / "nothing").string();
  EXPECT_THROW(io::runScene(o), io::InputError);

  const fs::path scene = writeScene(dir.path, kCrushScene);
  io::RunOptions run;
  run.scene = scene.string();
  run.outDir = (dir.path / "out").string();
  run.steps = 5;
  io::runScene(run);
  std::ofstream(scene, std::ios::app) << "\n# edited\n";
  io::RunOptions resume;
  resume.resumeDir = run.outDir;
  try {
    io::runScene(resume);
    FAIL() << "a changed scene must be refused";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("changed since the checkpoint"), std::string::npos) << e.what();
  }
}

// A checkpoint carries a CRC-32: every single-bit flip at 24 places spread
// over the file is refused as damaged (none resumes into another run), and
// so is a truncated copy; a scene file that moved resumes from the unchanged
// copy the run keeps in its output folder.
TEST(Run, DamagedCheckpointsAreRefusedAndMovedScenesResume) {
  TempDir dir("resume_damaged");
  const fs::path scene = writeScene(dir.path, kCrushScene);
  io::RunOptions run;
  run.scene = scene.string();
  run.outDir = (dir.path / "out").string();
  run.steps = 5;
  io::runScene(run);
  const fs::path checkpoint = dir.path / "out" / "checkpoint.lsc";
  const std::string good = readFile(checkpoint);
  const auto refusal = [&](const std::string& bytes) {
    std::ofstream(checkpoint, std::ios::binary | std::ios::trunc) << bytes;
    io::RunOptions resume;
    resume.resumeDir = run.outDir;
    resume.steps = 6;
    try {
      io::runScene(resume);
    } catch (const io::InputError& e) {
      return std::string(e.what());
    }
    return std::string("resumed");
  };
  for (int k = 0; k < 24; ++k) {
    std::string bad = good;
    const std::size_t at = 8 + (bad.size() - 9) * std::size_t(k) / 23;  // past the magic, to the last byte
    bad[at] = char(bad[at] ^ (1 << (k % 8)));
    const std::string what = refusal(bad);
    EXPECT_TRUE(what.find("damaged checkpoint") != std::string::npos ||
                what.find("another lsdem version") != std::string::npos)
        << "byte " << at << ": " << what;
  }
  EXPECT_NE(refusal(good.substr(0, good.size() / 2)).find("damaged checkpoint"), std::string::npos);

  // The scene moves away; the copy in the output folder is the same scene.
  std::ofstream(checkpoint, std::ios::binary | std::ios::trunc) << good;
  fs::rename(scene, dir.path / "moved.toml");
  io::RunOptions resume;
  resume.resumeDir = run.outDir;
  resume.steps = 6;
  const io::RunResult r = io::runScene(resume);
  EXPECT_EQ(r.steps, 11u);  // 5, then 6 more
}

TEST(Run, DistributionsAtChosenTimes) {
  TempDir dir("times");
  std::string text = kCrushScene;
  text.replace(text.find("distributions = 3"), 17, "distribution_times = [0.0, 0.005, 0.0075]");
  io::RunOptions o;
  o.scene = writeScene(dir.path, text).string();
  o.outDir = (dir.path / "out").string();
  io::runScene(o);
  // Snapshots at 0, the first steps ending at or after 0.005 and 0.0075 s, and the end.
  const auto rows = lines(readFile(dir.path / "out" / "shape_stats.csv"));
  ASSERT_EQ(rows.size(), 5u);
  const double times[4] = {0.0, 0.005, 0.0075, 0.012};
  for (std::size_t k = 0; k < 4; ++k) {
    const double t = std::stod(split(rows[k + 1])[0]);
    EXPECT_GE(t, times[k] - 1e-12);
    EXPECT_LT(t, times[k] + 2e-5) << "snapshot " << k;  // within a step (dt <= 1.1e-5 s here)
  }
}

// Shape statistics leave out particles under [output] shape_min_cells cells
// across: a disc 20 cells across is counted (circularity near 1), one 3 cells
// across is not; with shape_min_cells = 0 both are.
TEST(Run, ShapeStatisticsLeaveOutUnresolvedParticles) {
  const std::string base = R"([simulation]
dimension = 2
steps = 2

[contact]
kn = 1e5

[materials.rock]
density = 2000.0

[shapes.big]
kind = "circle"
radius = 0.01
cells_across = 20

[shapes.tiny]
kind = "circle"
radius = 0.01
cells_across = 3

[[particles]]
shape = "big"
material = "rock"
placement = "list"
positions = [[0.0, 0.05]]

[[particles]]
shape = "tiny"
material = "rock"
placement = "list"
positions = [[0.05, 0.05]]

[output]
distributions = 2
)";
  for (const double minCells : {5.0, 0.0}) {
    TempDir dir(minCells > 0.0 ? "shape_min_default" : "shape_min_zero");
    std::string text = base;
    if (minCells == 0.0) text += "shape_min_cells = 0\n";
    io::RunOptions o;
    o.scene = writeScene(dir.path, text).string();
    o.outDir = (dir.path / "out").string();
    io::runScene(o);
    const auto rows = lines(readFile(dir.path / "out" / "shape_stats.csv"));
    ASSERT_GE(rows.size(), 2u);
    EXPECT_EQ(split(rows[0]).back(), "shape_particles");
    const auto first = split(rows[1]);
    EXPECT_EQ(first[2], "2");  // particles
    EXPECT_EQ(first.back(), minCells > 0.0 ? "1" : "2") << rows[1];
    if (minCells > 0.0) {
      EXPECT_NEAR(std::stod(first[3]), 1.0, 0.02) << "the big disc's circularity";
    }
    // Histograms count the same particles.
    std::size_t counted = 0;
    for (const std::string& row : lines(readFile(dir.path / "out" / "shape_histograms.csv"))) {
      const auto cells = split(row);
      if (cells[0] == first[0] && cells[2] == "circularity") counted += std::stoul(cells[5]);
    }
    EXPECT_EQ(counted, minCells > 0.0 ? 1u : 2u);
  }
}

namespace {

// One disc resting on a floor: the scene the limit checks below edit.
const char* kDiscScene = R"([simulation]
dimension = 2
duration = 0.01

[contact]
kn = 1e5

[shapes.disc]
kind = "circle"
radius = 0.01
cells_across = 12

[[particles]]
shape = "disc"
density = 2000.0
placement = "list"
positions = [[0.0, 0.0099]]

[[planes]]
name = "floor"
point = [0.0, 0.0]
normal = [0.0, 1.0]

[effects]
gravity = [0.0, -9.81]

[output]
frames = 2
)";

std::string editScene(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

}  // namespace

// A run that could not end in bounded time or would overflow is refused
// before anything is written, naming the file, line and key (issue 16: these
// hung in Schedule::advance or wrote inf and NaN with exit code 0).
TEST(Run, RunsThatCannotEndOrWouldOverflowAreRefusedBeforeWriting) {
  struct Case {
    std::string name, from, to;
    int line;
    std::string key, message;
  };
  const std::vector<Case> cases = {
      {"tiny_duration", "duration = 0.01", "duration = 1e-308", 3, "simulation.duration", "shorter than one time step"},
      {"tiny_checkpoints", "frames = 2", "frames = 2\ncheckpoint_every = 1e-308", 29, "output.checkpoint_every",
       "shorter than one time step"},
      {"too_many_steps", "duration = 0.01", "duration = 1e8", 3, "simulation.duration", "over the limit of 1e9"},
      {"overflowing_gravity", "gravity = [0.0, -9.81]", "gravity = [0.0, -1e308]", 25, "effects.gravity",
       "double precision"},
      {"overflowing_velocity", "positions = [[0.0, 0.0099]]", "positions = [[0.0, 0.0099]]\nvelocity = [1e200, 0.0]",
       18, "particles[0].velocity", "double precision"},
      // (A stiffness that overflows came out 0: the run stopped at its first
      // instant, "contact solver: dt must be > 0 s, got 0", no key, exit 1.)
      {"overflowing_kn", "kn = 1e5", "kn = 1e308", 5, "contact", "is not a finite positive number (kn = 1e+308"},
      // (C_g dt past 2 made energy with exit 0: kinetic energy 1e177 J.)
      {"strong_global_damping", "gravity = [0.0, -9.81]", "gravity = [0.0, -9.81]\nglobal_damping = 1e9", 26,
       "effects.global_damping", "it must stay below 1"},
      {"overflowing_ks", "kn = 1e5", "kn = 1e5\nfriction = 0.5\nks = 1e308", 5, "contact", "is not a finite positive number"},
  };
  for (const Case& c : cases) {
    TempDir dir("limits_" + c.name);
    io::RunOptions o;
    o.scene = writeScene(dir.path, editScene(kDiscScene, c.from, c.to)).string();
    o.outDir = (dir.path / "out").string();
    try {
      io::runScene(o);
      ADD_FAILURE() << c.name << ": accepted";
    } catch (const io::InputError& e) {
      EXPECT_EQ(e.file(), o.scene) << c.name;
      EXPECT_EQ(e.line(), c.line) << c.name << ": " << e.what();
      EXPECT_EQ(e.key(), c.key) << c.name << ": " << e.what();
      EXPECT_NE(e.problem().find(c.message), std::string::npos) << c.name << ": " << e.what();
    }
    EXPECT_FALSE(fs::exists(o.outDir)) << c.name << ": nothing is written for a refused run";
  }
}

// Output intervals far shorter than a step (here 1e-10 s against dt ~ 2.6e-4 s)
// write at most one row per step and end at once.
TEST(Run, OutputIntervalsBelowTheStepStayBounded) {
  TempDir dir("short_intervals");
  io::RunOptions o;
  o.scene = writeScene(dir.path, editScene(kDiscScene, "frames = 2", "frames = 2\nhistory_rows = 100000000")).string();
  o.outDir = (dir.path / "out").string();
  const io::RunResult r = io::runScene(o);
  // The first row, then one per step.
  EXPECT_EQ(lines(readFile(dir.path / "out" / "history.csv")).size(), 1u + 1u + r.steps);
}

// A run of `steps` steps of the disc scene with its `frames = 2` line
// replaced by `outputKeys`, into dir/out.
io::RunOptions discRun(const TempDir& dir, const std::string& outputKeys, std::uint64_t steps) {
  io::RunOptions o;
  o.scene = writeScene(dir.path, editScene(kDiscScene, "frames = 2", outputKeys)).string();
  o.outDir = (dir.path / "out").string();
  o.steps = steps;
  return o;
}

// The notes a run of `o` gives, in order.
std::vector<std::string> runNotes(io::RunOptions o) {
  std::vector<std::string> notes;
  o.note = [&](const std::string& n) { notes.push_back(n); };
  io::runScene(o);
  return notes;
}

// A run of a number of steps records as many intervals as it asks for when
// they do not divide the steps: 300 steps in 80 frames and 7 history rows
// (before, intervals rounded down to whole steps made 101 frames and 9 rows:
// 100 and 8 intervals).
TEST(Run, RecordsOnAStepClockAreAsManyAsAskedFor) {
  TempDir dir("step_clock_records");
  const io::RunResult r = io::runScene(discRun(dir, "frames = 80\nhistory_rows = 7", 300));
  ASSERT_EQ(r.steps, 300u);
  // summary.json's first time step is the one the first step took (history row 0's).
  const std::string summary = readFile(dir.path / "out" / "summary.json");
  const std::size_t at = summary.find("\"first\": ");
  ASSERT_NE(at, std::string::npos) << summary;
  const std::string pvd = readFile(dir.path / "out" / "particles.pvd");
  std::size_t frames = 0;
  for (std::size_t at = pvd.find("<DataSet"); at != std::string::npos; at = pvd.find("<DataSet", at + 1)) ++frames;
  EXPECT_EQ(frames, 81u);  // the first, then one per interval (the last at the end)
  // The header, the first row, then one per interval.
  const auto rows = lines(readFile(dir.path / "out" / "history.csv"));
  ASSERT_EQ(rows.size(), 1u + 1u + 7u);
  // Row k is at the first step at or after k 300 / 7 (a whole step count).
  const std::vector<std::string> header = split(rows[0]);
  const std::size_t stepColumn = std::size_t(std::find(header.begin(), header.end(), "step") - header.begin());
  ASSERT_LT(stepColumn, header.size()) << rows[0];
  const std::size_t dtColumn = std::size_t(std::find(header.begin(), header.end(), "dt_s") - header.begin());
  ASSERT_LT(dtColumn, header.size()) << rows[0];
  EXPECT_EQ(std::stod(summary.substr(at + 9)), std::stod(split(rows[1])[dtColumn]));
  for (int k = 0; k <= 7; ++k) {
    EXPECT_EQ(std::stoul(split(rows[std::size_t(k) + 1])[stepColumn]), std::size_t(std::ceil(300.0 * k / 7.0 - 1e-9)))
        << rows[std::size_t(k) + 1];
  }
}

// A tracked id no particle ever had is said at the end of the run (a
// fragment's id, given later, may be tracked: only ids never given are).
TEST(Run, ATrackedIdThatNeverExistedIsNoted) {
  TempDir dir("track_never");
  const std::vector<std::string> notes = runNotes(discRun(dir, "frames = 2\ntrack = [0, 99]", 3));
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_EQ(notes[0], "output.track: no particle of this run had the id 99 (ids given so far: 0 to 0); tracks.csv "
                      "has no rows for it");
  // Particle 0's rows are there: the first instant, every step, the last.
  EXPECT_EQ(lines(readFile(dir.path / "out" / "tracks.csv")).size(), 1u + 4u);
}

// Size-distribution times after the scene's end are said at the start, at
// their key's line (they are kept: a resume with --steps may reach them).
TEST(Run, DistributionTimesPastTheEndAreNoted) {
  TempDir dir("distribution_times_past");
  const io::RunOptions o = discRun(dir, "frames = 2\ndistribution_times = [0.002, 0.02, 0.5]", 3);
  const std::vector<std::string> notes = runNotes(o);
  ASSERT_EQ(notes.size(), 1u);
  const std::string text = readFile(o.scene);
  const auto line = 1 + std::count(text.begin(), text.begin() + std::ptrdiff_t(text.find("distribution_times")), '\n');
  EXPECT_EQ(notes[0], o.scene + ":" + std::to_string(line) +
                          ": output.distribution_times: 2 of its 3 times come after the scene's end (duration = "
                          "0.01 s): a run to its end does not record them");
}

// A folder holding a user's own scene.toml (and no run's outputs) is not
// written into, --overwrite or not: the run's copy of its scene would replace
// the file. Running that very scene into its own folder is fine.
TEST(Run, AUsersOwnSceneTomlIsNotReplaced) {
  TempDir dir("own_scene");
  const std::string own = editScene(kDiscScene, "frames = 2", "frames = 0");
  std::ofstream(dir.path / "scene.toml") << own;
  fs::create_directories(dir.path / "scenes");
  io::RunOptions o;
  o.scene = writeScene(dir.path / "scenes", kDiscScene).string();
  o.outDir = dir.path.string();
  o.steps = 2;
  for (const bool overwrite : {false, true}) {
    o.overwrite = overwrite;
    try {
      io::runScene(o);
      ADD_FAILURE() << "ran into a folder holding another scene.toml";
    } catch (const io::InputError& e) {
      EXPECT_EQ(e.file(), (dir.path / "scene.toml").string());
      EXPECT_NE(e.problem().find("is not a run's copy of its scene"), std::string::npos) << e.what();
    }
    EXPECT_EQ(readFile(dir.path / "scene.toml"), own);
    EXPECT_FALSE(fs::exists(dir.path / "summary.json"));
  }
  o.scene = (dir.path / "scene.toml").string();
  o.overwrite = false;
  EXPECT_EQ(io::runScene(o).steps, 2u);
  EXPECT_EQ(readFile(dir.path / "scene.toml"), own);
}

// A diverging run (a stiff contact with a forced, far too large step) stops
// with an error at the first non-finite value; no row holding one is written.
TEST(Run, ADivergedRunStopsBeforeWritingANonFiniteRow) {
  TempDir dir("diverged");
  const std::string scene = R"([simulation]
dimension = 2
steps = 3000
dt = 0.01
force_dt = true

[contact]
kn = 1e9

[shapes.disc]
kind = "circle"
radius = 0.01
cells_across = 12

[[particles]]
shape = "disc"
density = 2000.0
placement = "list"
positions = [[0.0, 0.0]]

[[planes]]
name = "low"
point = [0.0, -0.0095]
normal = [0.0, 1.0]

[[planes]]
name = "high"
point = [0.0, 0.0095]
normal = [0.0, -1.0]

[output]
history_rows = 3000
)";
  io::RunOptions o;
  o.scene = writeScene(dir.path, scene).string();
  o.outDir = (dir.path / "out").string();
  try {
    io::runScene(o);
    FAIL() << "a diverging run must stop with an error";
  } catch (const io::InputError& e) {
    FAIL() << "not an input error: " << e.what();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("diverged"), std::string::npos) << e.what();
  }
  const std::string history = readFile(dir.path / "out" / "history.csv");
  EXPECT_GT(lines(history).size(), 10u) << "the rows before the divergence stay";
  for (const char* bad : {"inf", "nan"}) EXPECT_EQ(history.find(bad), std::string::npos) << bad;
  // The summary says the run stopped, and why.
  const std::string summary = readFile(dir.path / "out" / "summary.json");
  EXPECT_NE(summary.find("\"stopped_early\": true"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"error\": \"after step "), std::string::npos) << summary;
}

// A diverging run with breakage: the splits of grains flung to 1e8 m fail
// (their cut's two points coincide in floating point) before any value is
// infinite. The error says the run diverged, which particle and how fast,
// with the failed split's own message after it; the summary records it.
TEST(Run, ADivergedRunWithBreakageSaysItDiverged) {
  TempDir dir("diverged_breakage");
  std::string text = readFile(fs::path(LSDEM_SOURCE_DIR) / "apps/scenes/three_grains/three_grains_2d.toml");
  text = editScene(text, "dt = \"auto\"", "dt = 2e-4\nforce_dt = true");
  io::RunOptions o;
  o.scene = writeScene(dir.path, text).string();
  o.outDir = (dir.path / "out").string();
  o.steps = 3000;
  std::string message;
  try {
    io::runScene(o);
  } catch (const io::InputError& e) {
    FAIL() << "not an input error: " << e.what();
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  ASSERT_FALSE(message.empty()) << "a diverging run must stop with an error";
  EXPECT_EQ(message.rfind("after step ", 0), 0u) << message;
  EXPECT_NE(message.find("the simulation diverged: particle "), std::string::npos) << message;
  EXPECT_NE(message.find("times its bounding radius in one step"), std::string::npos) << message;
  const std::string summary = readFile(dir.path / "out" / "summary.json");
  EXPECT_NE(summary.find("\"stopped_early\": true"), std::string::npos) << summary;
  EXPECT_NE(summary.find("the simulation diverged"), std::string::npos) << summary;
}

// A resume that fails (an output missing or damaged) changes none of the
// outputs it would have cut back and appended to (issue 16: history.csv was
// cut before the missing file was found).
TEST(Run, AFailedResumeLeavesTheOutputsAsTheyWere) {
  for (const std::string damage : {"psd.csv missing", "particles.pvd damaged"}) {
    TempDir dir("failed_resume");
    io::RunOptions run;
    run.scene = writeScene(dir.path, editScene(kDiscScene, "frames = 2", "frames = 2\nhistory_rows = 2")).string();
    run.outDir = (dir.path / "out").string();
    run.steps = 7;  // rows at steps 0, 4 (the first at or after 3.5) and 7, then the checkpoint
    io::runScene(run);
    const fs::path out = dir.path / "out";
    if (damage == "psd.csv missing") {
      fs::remove(out / "psd.csv");
    } else {
      std::ofstream(out / "particles.pvd", std::ios::trunc) << "<VTKFile><Collection><DataSet file=\"x\"/>";
    }
    std::map<std::string, std::string> before;
    for (const char* file : {"history.csv", "shape_stats.csv", "removed.csv", "breakage_log.csv", "particles.pvd"}) {
      before[file] = readFile(out / file);
    }
    ASSERT_EQ(lines(before["history.csv"]).size(), 1u + 3u);
    io::RunOptions resume;
    resume.resumeDir = run.outDir;
    resume.steps = 2;
    try {
      io::runScene(resume);
      ADD_FAILURE() << damage << ": resumed";
    } catch (const io::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(damage.substr(0, damage.find(' '))), std::string::npos) << e.what();
    }
    for (const auto& [file, text] : before) EXPECT_EQ(readFile(out / file), text) << damage << ": " << file;
  }
}

// A CSV file cut mid-row short of the checkpoint's size, or whose tail the
// checkpoint saw became zeros (a machine crash), is continued after its last
// whole row: no NUL bytes, no partial row (issue 16: it was padded with
// NULs); the resume says so.
TEST(Run, ResumeRepairsACsvCutMidRow) {
  for (const bool zeros : {false, true}) {
    TempDir dir(zeros ? "repair_zeros" : "repair_cut");
    io::RunOptions run;
    run.scene = writeScene(dir.path, editScene(kDiscScene, "frames = 2", "frames = 2\nhistory_rows = 1000")).string();
    run.outDir = (dir.path / "out").string();
    run.steps = 20;  // a row per step: 21 rows
    io::runScene(run);
    const fs::path history = dir.path / "out" / "history.csv";
    const std::string whole = readFile(history);
    const auto rows = lines(whole);
    ASSERT_EQ(rows.size(), 22u);
    // Cut in the middle of the row of step 18.
    const std::size_t cut = whole.size() - rows[21].size() - 1 - rows[20].size() - 1 - rows[19].size() / 2;
    std::string damaged = whole.substr(0, cut);
    if (zeros) damaged.append(whole.size() - cut, '\0');
    std::ofstream(history, std::ios::binary | std::ios::trunc) << damaged;

    io::RunOptions resume;
    resume.resumeDir = run.outDir;
    resume.steps = 3;
    std::string notes;
    resume.note = [&](const std::string& line) { notes += line + "\n"; };
    io::runScene(resume);
    EXPECT_NE(notes.find(history.string() + ": cut short of the " + std::to_string(whole.size()) + " bytes"),
              std::string::npos)
        << notes;
    const std::string repaired = readFile(history);
    EXPECT_EQ(repaired.find('\0'), std::string::npos);
    ASSERT_FALSE(repaired.empty());
    EXPECT_EQ(repaired.back(), '\n');
    const auto after = lines(repaired);
    const std::size_t columns = split(after[0]).size();
    for (const std::string& row : after) EXPECT_EQ(split(row).size(), columns) << row;
    // Rows to step 17, then steps 21, 22, 23 of the resumed part.
    ASSERT_EQ(after.size(), 1u + 18u + 3u);
    EXPECT_EQ(after[18], rows[18]);
    EXPECT_EQ(split(after[19])[0], "21");
    EXPECT_EQ(split(after.back())[0], "23");
  }
}

// A checkpoint carries the hash of the scene text its run read (kept as
// scene.toml in the folder): a checkpoint copied in from another run's
// folder, or a resume given another scene, is refused and changes nothing;
// forced, the run continues with the scene given, whose copy then replaces
// scene.toml (and later resumes need no force).
TEST(Run, ResumeWithAnotherSceneIsRefusedUnlessForced) {
  TempDir dir("scene_identity");
  fs::create_directories(dir.path / "a");
  fs::create_directories(dir.path / "b");
  const fs::path sceneA = writeScene(dir.path / "a", kDiscScene);
  const fs::path sceneB = writeScene(dir.path / "b", editScene(kDiscScene, "gravity = [0.0, -9.81]", "gravity = [0.0, -5.0]"));
  for (const fs::path& scene : {sceneA, sceneB}) {
    io::RunOptions run;
    run.scene = scene.string();
    run.outDir = (scene.parent_path() / "out").string();
    run.steps = 5;
    io::runScene(run);
  }
  const fs::path outA = dir.path / "a" / "out", outB = dir.path / "b" / "out";
  const auto refusal = [](io::RunOptions o) {
    o.steps = 2;
    try {
      io::runScene(o);
    } catch (const io::InputError& e) {
      return std::string(e.what());
    }
    return std::string("resumed");
  };

  // A's checkpoint copied into B's folder.
  const std::string checkpointB = readFile(outB / "checkpoint.lsc");
  const std::string historyB = readFile(outB / "history.csv");
  fs::copy_file(outA / "checkpoint.lsc", outB / "checkpoint.lsc", fs::copy_options::overwrite_existing);
  io::RunOptions foreign;
  foreign.resumeDir = outB.string();
  EXPECT_EQ(refusal(foreign), (outB / "checkpoint.lsc").string() + ": written by a run of another scene than " +
                                  (outB / "scene.toml").string() +
                                  " (a checkpoint copied from another run, or an edited copy); give --force to resume "
                                  "with it anyway");
  EXPECT_EQ(readFile(outB / "history.csv"), historyB);
  std::ofstream(outB / "checkpoint.lsc", std::ios::binary | std::ios::trunc) << checkpointB;

  // B's scene given to resume A's run.
  io::RunOptions given;
  given.resumeDir = outA.string();
  given.scene = sceneB.string();
  EXPECT_NE(refusal(given).find(sceneB.string() + ": not the scene of the run in " + outA.string()), std::string::npos)
      << refusal(given);
  // A's own scene given: resumed.
  given.scene = sceneA.string();
  EXPECT_EQ(refusal(given), "resumed");

  // Forced with B's scene: a note, B's text becomes A's folder's copy and
  // identity, and the next resume needs no force.
  given.scene = sceneB.string();
  given.force = true;
  std::string notes;
  given.note = [&](const std::string& line) { notes += line + "\n"; };
  EXPECT_EQ(refusal(given), "resumed");
  EXPECT_NE(notes.find("resumed with " + sceneB.string() + " anyway (--force)"), std::string::npos) << notes;
  EXPECT_EQ(readFile(outA / "scene.toml"), readFile(sceneB));
  io::RunOptions next;
  next.resumeDir = outA.string();
  next.scene = sceneB.string();
  EXPECT_EQ(refusal(next), "resumed");

  // Forced with what the checkpoint holds or runs from the start edited (a
  // plane's velocity, the particles' density): refused at the table, and
  // nothing changes (the plane jumped; the particles were the checkpoint's).
  const std::string historyA = readFile(outA / "history.csv");
  for (const auto& [from, to, key, line] :
       {std::tuple<std::string, std::string, std::string, int>{"normal = [0.0, 1.0]",
                                                               "normal = [0.0, 1.0]\nvelocity = [0.0, 0.1]", "planes", 19},
        {"density = 2000.0", "density = 100.0", "particles", 13}}) {
    fs::create_directories(dir.path / "c");
    const fs::path sceneC = writeScene(dir.path / "c", editScene(readFile(sceneB), from, to));
    io::RunOptions edited = next;
    edited.scene = sceneC.string();
    edited.force = true;
    EXPECT_EQ(refusal(edited), sceneC.string() + ":" + std::to_string(line) + ": " + key + ": differs from the run's (" +
                                   (outA / "scene.toml").string() +
                                   "): a forced resume takes the scene's output, end, contact law, effects, feeds "
                                   "and tools as they are now, but its particles, shapes, materials and planes must "
                                   "be the run's");
    EXPECT_EQ(readFile(outA / "history.csv"), historyA);
    EXPECT_EQ(readFile(outA / "scene.toml"), readFile(sceneB));
  }
  // What may change: a number written another way, a comment, a plane's own
  // contact material (as [contact] may).
  const fs::path sceneD = writeScene(
      dir.path / "c", editScene(editScene(readFile(sceneB), "density = 2000.0", "density = 2000  # kg/m^3"),
                                "normal = [0.0, 1.0]", "normal = [0, 1]\nmaterial = { kn = 2e5 }"));
  io::RunOptions allowed = next;
  allowed.scene = sceneD.string();
  allowed.force = true;
  EXPECT_EQ(refusal(allowed), "resumed");
}

// An effect may change on a forced resume, within its limits: a global
// damping raised past what the step allows is refused at its line, as for a
// new run, and the run's outputs stay as they were.
TEST(Run, AForcedResumeChecksTheGlobalDamping) {
  TempDir dir("forced_damping");
  const std::string text = editScene(kDiscScene, "gravity = [0.0, -9.81]", "gravity = [0.0, -9.81]\nglobal_damping = 1.0");
  const fs::path scene = writeScene(dir.path, text);
  io::RunOptions run;
  run.scene = scene.string();
  run.outDir = (dir.path / "out").string();
  run.steps = 3;
  io::runScene(run);
  const std::string history = readFile(dir.path / "out" / "history.csv");
  std::ofstream(scene, std::ios::trunc) << editScene(text, "global_damping = 1.0", "global_damping = 1e9");
  io::RunOptions resume;
  resume.resumeDir = run.outDir;
  resume.force = true;
  resume.steps = 3;
  try {
    io::runScene(resume);
    ADD_FAILURE() << "resumed";
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.line(), 26) << e.what();
    EXPECT_EQ(e.key(), "effects.global_damping") << e.what();
    EXPECT_NE(e.problem().find("global_damping = 1e+09 1/s times the time step"), std::string::npos) << e.what();
  }
  EXPECT_EQ(readFile(dir.path / "out" / "history.csv"), history);
}

// A run whose every particle breaks into fines runs on to its end with
// none left (a feed could still come): nothing sets a step, and history.csv
// leaves critical_dt_s empty, as summary.json writes null. (It was read as
// a non-finite value, "the simulation diverged", exit 1.)
TEST(Run, ARunWithEveryParticleTurnedToFinesRunsToItsEnd) {
  TempDir dir("all_fines");
  const fs::path scene = writeScene(
      dir.path, std::string(kDiscScene) + "\n[effects.breakage]\nmin_volume = 1.0\n[[effects.breakage.manual]]\n"
                                          "particle = 0\ntime = 0.0\npoint = [0.0, 0.0099]\n");
  io::RunOptions run;
  run.scene = scene.string();
  run.outDir = (dir.path / "out").string();
  run.steps = 4;
  const io::RunResult r = io::runScene(run);
  EXPECT_EQ(r.steps, 4u);
  std::istringstream history(readFile(dir.path / "out" / "history.csv"));
  std::string line;
  std::vector<std::string> rows;
  while (std::getline(history, line)) rows.push_back(line);
  ASSERT_EQ(rows.size(), 6u);
  const auto cell = [](const std::string& row, int k) {
    std::size_t at = 0;
    for (int c = 0; c < k; ++c) at = row.find(',', at) + 1;
    return row.substr(at, row.find(',', at) - at);
  };
  EXPECT_EQ(cell(rows[0], 3), "critical_dt_s");
  EXPECT_EQ(cell(rows[0], 12), "particles");
  EXPECT_GT(std::stod(cell(rows[1], 3)), 0.0);  // step 0: the disc
  EXPECT_EQ(cell(rows[1], 12), "1");
  for (std::size_t k = 2; k < rows.size(); ++k) {
    EXPECT_EQ(cell(rows[k], 3), "") << rows[k];
    EXPECT_EQ(cell(rows[k], 12), "0") << rows[k];
  }
  EXPECT_NE(readFile(dir.path / "out" / "summary.json").find("\"critical_dt\": null"), std::string::npos);
  EXPECT_NE(readFile(dir.path / "out" / "removed.csv").find(",fines"), std::string::npos);
}

// A tool's motion may change on a forced resume past the checkpoint, not
// before it: a scene that puts the tool elsewhere at the checkpoint's time
// (here a platen's speed, edited) is refused at its motion's line, and the
// run's outputs stay as they were; one that changes it only after (the
// platen's travel, ending later than the checkpoint) resumes.
TEST(Run, AForcedResumeKeepsEachToolOnItsPathToTheCheckpoint) {
  TempDir dir("forced_tool");
  const std::string text = std::string(kDiscScene) +
                           "\n[[tools]]\nname = \"ram\"\nshape = \"disc\"\nposition = [0.1, 0.1]\n[tools.motion]\n"
                           "type = \"platen\"\ndirection = [0.0, -1.0]\nspeed = 0.1\ntravel = 1.0\n";
  const fs::path scene = writeScene(dir.path, text);
  io::RunOptions run;
  run.scene = scene.string();
  run.outDir = (dir.path / "out").string();
  run.steps = 3;
  io::runScene(run);
  const std::string history = readFile(dir.path / "out" / "history.csv");
  const int motionLine = int(std::count(text.begin(), text.begin() + std::ptrdiff_t(text.find("[tools.motion]")), '\n')) + 1;
  io::RunOptions resume;
  resume.resumeDir = run.outDir;
  resume.force = true;
  resume.steps = 3;
  std::ofstream(scene, std::ios::trunc) << editScene(text, "speed = 0.1", "speed = 0.2");
  try {
    io::runScene(resume);
    ADD_FAILURE() << "resumed";
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.line(), motionLine) << e.what();
    EXPECT_EQ(e.key(), "tools[0].motion") << e.what();
    EXPECT_NE(e.problem().find("puts tool 'ram' up to "), std::string::npos) << e.what();
    EXPECT_NE(e.problem().find("must follow the run's path up to the checkpoint, or the tool would jump"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(readFile(dir.path / "out" / "history.csv"), history);
  std::ofstream(scene, std::ios::trunc) << editScene(text, "travel = 1.0", "travel = 0.5");
  EXPECT_EQ(io::runScene(resume).steps, 6u);
}

// A run given --steps and stopped part-way ends, resumed without --steps,
// where the uninterrupted run ends (its checkpoint keeps its end), with the
// same outputs; resumed again, it is at its end: nothing is run or written.
// The wall time of the summary is that of both processes.
TEST(Run, AResumedRunEndsWhereItsOwnStepsSaid) {
  TempDir dir("resume_steps");
  const std::string scene =
      writeScene(dir.path, editScene(kDiscScene, "frames = 2", "frames = 2\nhistory_rows = 40\nprogress_seconds = 1e-9"))
          .string();
  constexpr std::uint64_t kSteps = 300;

  io::RunOptions straight;
  straight.scene = scene;
  straight.outDir = (dir.path / "straight").string();
  straight.steps = kSteps;
  const io::RunResult a = io::runScene(straight);
  ASSERT_EQ(a.steps, kSteps);

  std::atomic<bool> stop{false};
  io::RunOptions first = straight;
  first.outDir = (dir.path / "resumed").string();
  first.stop = &stop;
  first.progress = [&](const io::RunProgress& p) {
    if (p.steps >= 200) stop = true;
  };
  const io::RunResult b1 = io::runScene(first);
  ASSERT_TRUE(b1.stopped);
  ASSERT_LT(b1.steps, kSteps);
  io::RunOptions second;
  second.resumeDir = first.outDir;
  const auto start = std::chrono::steady_clock::now();
  const io::RunResult b = io::runScene(second);
  const double secondSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_FALSE(b.alreadyFinished);
  EXPECT_EQ(b.steps, kSteps) << "not the scene's own end (32 steps)";
  // (The first process's up to its checkpoint, two thirds of the steps.)
  EXPECT_GT(b.wallSeconds, secondSeconds) << "the wall time of both processes";
  for (const char* file : {"history.csv", "psd.csv", "particles.pvd"}) {
    EXPECT_EQ(readFile(dir.path / "straight" / file), readFile(dir.path / "resumed" / file)) << file;
  }

  // Again: at its end already. Nothing changes, not even the summary.
  const std::string summary = readFile(dir.path / "resumed" / "summary.json");
  const std::string checkpoint = readFile(dir.path / "resumed" / "checkpoint.lsc");
  const io::RunResult c = io::runScene(second);
  EXPECT_TRUE(c.alreadyFinished);
  EXPECT_EQ(c.steps, kSteps);
  EXPECT_EQ(c.massIn, b.massIn);
  EXPECT_EQ(readFile(dir.path / "resumed" / "summary.json"), summary);
  EXPECT_EQ(readFile(dir.path / "resumed" / "checkpoint.lsc"), checkpoint);

  // With --steps, that many more; the run's own end stays where it was.
  io::RunOptions more = second;
  more.steps = 50;
  EXPECT_EQ(io::runScene(more).steps, kSteps + 50);
  const io::RunResult d = io::runScene(second);
  EXPECT_TRUE(d.alreadyFinished);
  EXPECT_EQ(d.steps, kSteps + 50);
}

// A stop asked for before the set-up is done (Ctrl-C while grains are
// placed): the run ends without a step and without writing anything, not
// even the output folder.
TEST(Run, AStopDuringTheSetUpWritesNothing) {
  TempDir dir("stop_in_setup");
  std::atomic<bool> stop{true};
  io::RunOptions o;
  o.scene = writeScene(dir.path, kDiscScene).string();
  o.outDir = (dir.path / "out").string();
  o.stop = &stop;
  const io::RunResult r = io::runScene(o);
  EXPECT_TRUE(r.stopped);
  EXPECT_TRUE(r.nothingWritten);
  EXPECT_EQ(r.steps, 0u);
  EXPECT_FALSE(fs::exists(dir.path / "out"));
}
