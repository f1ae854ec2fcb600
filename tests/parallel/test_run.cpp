// `lsdem run` on several ranks (parallel/DistributedRun.h): the outputs rank 0
// writes equal those of the same scene run in one process, and a run stopped
// on the ranks resumes from its checkpoint on another number of ranks to the
// outputs of the uninterrupted run. The scene is the shipped three-grains 2D
// scene with the platen started against the stack (tests/parallel/
// test_breakage.cpp), so grains break within the short run.
#include "lsdem/parallel/DistributedRun.h"

#include "lsdem/io/Run.h"
#include "lsdem/io/VtpRead.h"
#include "support/Files.h"
#include "support/Json.h"
#include "support/Mpi.h"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace lsdem {
namespace {

namespace fs = std::filesystem;
using test::rankOf;

constexpr std::uint64_t kSteps = 5000;

// A folder every rank names alike (rank 0's scratch folder).
fs::path sharedPath(const std::string& name) {
  std::string path = rankOf(MPI_COMM_WORLD) == 0 ? test::tempPath(name).string() : std::string();
  int size = int(path.size());
  MPI_Bcast(&size, 1, MPI_INT, 0, MPI_COMM_WORLD);
  path.resize(std::size_t(size));
  MPI_Bcast(path.data(), size, MPI_CHAR, 0, MPI_COMM_WORLD);
  return path;
}

// The scene file (written by rank 0): kSteps steps, the platen against the
// stack and fast, a progress call every step (to stop the run where wanted),
// `extra` lines added to [effects], then each of `edits` (text, replacement).
fs::path writeScene(const fs::path& dir, const std::string& extra = "",
                    const std::vector<std::pair<std::string, std::string>>& edits = {}) {
  if (rankOf(MPI_COMM_WORLD) == 0) {
    std::string text =
        test::readFile(std::string(LSDEM_SOURCE_DIR) + "/apps/scenes/three_grains/three_grains_2d.toml");
    const auto replace = [&](const std::string& from, const std::string& to) {
      const std::size_t at = text.find(from);
      if (at == std::string::npos) throw std::runtime_error("test scene: '" + from + "' not in three_grains_2d.toml");
      text.replace(at, from.size(), to);
    };
    replace("duration = 0.08", "steps = " + std::to_string(kSteps));
    replace("point = [0.0, 0.0035]", "point = [0.0, 0.00335]");
    replace("velocity = [0.0, -0.02]", "velocity = [0.0, -0.2]");
    replace("[output]\n", "[output]\nprogress_seconds = 1e-9\n");
    if (!extra.empty()) replace("[effects]\n", "[effects]\n" + extra);
    for (const auto& [from, to] : edits) replace(from, to);
    fs::create_directories(dir);
    std::ofstream(dir / "scene.toml") << text;
  }
  MPI_Barrier(MPI_COMM_WORLD);
  return dir / "scene.toml";
}

std::vector<std::map<std::string, std::string>> readCsv(const fs::path& file) {
  std::istringstream in(test::readFile(file));
  std::string line;
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  const auto split = [](const std::string& s) {
    std::vector<std::string> cells;
    std::stringstream ss(s);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (!s.empty() && s.back() == ',') cells.push_back("");
    return cells;
  };
  if (std::getline(in, line)) header = split(line);
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = split(line);
    std::map<std::string, std::string> row;
    for (std::size_t k = 0; k < header.size(); ++k) row[header[k]] = k < cells.size() ? cells[k] : "";
    rows.push_back(std::move(row));
  }
  return rows;
}

// `b`'s CSV file equals `a`'s: every row and column but `skip`, numbers to
// `relative` (0: as text), so sums taken in another order pass.
void expectSameCsv(const fs::path& a, const fs::path& b, const std::set<std::string>& skip, double relative) {
  const auto x = readCsv(a), y = readCsv(b);
  ASSERT_EQ(x.size(), y.size()) << b;
  ASSERT_GT(x.size(), 1u) << a;
  for (std::size_t r = 0; r < x.size(); ++r) {
    for (const auto& [column, text] : x[r]) {
      if (skip.count(column)) continue;
      const std::string& other = y[r].at(column);
      if (text == other) continue;
      char* end = nullptr;
      const double u = std::strtod(text.c_str(), &end), v = std::strtod(other.c_str(), nullptr);
      EXPECT_TRUE(relative > 0.0 && *end == '\0' && std::abs(u - v) <= relative * std::max(std::abs(u), std::abs(v)))
          << b << " row " << r << " column " << column << ": " << text << " against " << other;
    }
  }
}

// The energy budget's columns: each a sum of the ranks' shares (another
// order than one process's), compared within `relative` of the row's energy
// scale (its largest term), since a term can be near 0 (the balance error).
// (The kinetic and elastic energy are the view's own, compared as the other columns.)
const std::set<std::string> kLedgerColumns = {"gravity_work_J", "boundary_work_J", "damping_loss_J",
                                              "contact_loss_J", "split_release_J", "energy_error_J"};
void expectSameLedgerColumns(const fs::path& a, const fs::path& b, double relative) {
  const auto x = readCsv(a), y = readCsv(b);
  ASSERT_EQ(x.size(), y.size()) << b;
  std::size_t booked = 0;
  for (std::size_t r = 0; r < x.size(); ++r) {
    double scale = std::abs(std::stod(x[r].at("kinetic_J"))) + std::abs(std::stod(x[r].at("elastic_J")));
    for (const std::string& column : kLedgerColumns) scale = std::max(scale, std::abs(std::stod(x[r].at(column))));
    for (const std::string& column : kLedgerColumns) {
      const std::string& text = y[r].at(column);
      ASSERT_FALSE(text.empty()) << b << " row " << r << " column " << column << ": no value";
      const double u = std::stod(x[r].at(column)), v = std::stod(text);
      EXPECT_LE(std::abs(u - v), relative * scale) << b << " row " << r << " column " << column << ": " << v
                                                   << " against " << u << " (energy scale " << scale << " J)";
      booked += column != "energy_error_J" && u != 0.0;
    }
  }
  EXPECT_GT(booked, x.size()) << "the run must book energy for this check to mean anything";
}
// A split's fragments' energy is summed over the ranks (another order than
// one process's): to round-off; its gain, a difference, is left out.
const std::set<std::string> kFragmentEnergyColumns = {"fragment_energy_J", "energy_gain_J"};

void expectSameOutputs(const fs::path& serial, const fs::path& distributed) {
  expectSameCsv(serial / "history.csv", distributed / "history.csv", kLedgerColumns, 1e-12);
  expectSameLedgerColumns(serial / "history.csv", distributed / "history.csv", 1e-9);
  expectSameCsv(serial / "breakage_log.csv", distributed / "breakage_log.csv", kFragmentEnergyColumns, 0.0);
  expectSameCsv(serial / "breakage_log.csv", distributed / "breakage_log.csv", {"energy_gain_J"}, 1e-12);
  expectSameCsv(serial / "removed.csv", distributed / "removed.csv", {}, 0.0);
  expectSameCsv(serial / "psd.csv", distributed / "psd.csv", {}, 1e-12);
  expectSameCsv(serial / "shape_stats.csv", distributed / "shape_stats.csv", {}, 1e-12);
}

io::RunResult runOn(MPI_Comm comm, const fs::path& scene, const fs::path& out, std::atomic<bool>* stop = nullptr,
                    double stopAt = 0.0) {
  io::RunOptions o;
  o.scene = scene.string();
  o.outDir = out.string();
  o.threads = 1;
  o.engine = parallel::distributedRun(comm);
  if (stop) {
    o.stop = stop;
    o.progress = [stop, stopAt](const io::RunProgress& p) {
      if (p.time > stopAt) *stop = true;
    };
  }
  return io::runScene(o);
}

// The same scene in this process alone (rank 0; the others wait).
io::RunResult runSerial(const fs::path& scene, const fs::path& out) {
  io::RunResult r;
  if (rankOf(MPI_COMM_WORLD) == 0) {
    io::RunOptions o;
    o.scene = scene.string();
    o.outDir = out.string();
    o.threads = 1;
    r = io::runScene(o);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  return r;
}

// Runs `scene` in one process (rank 0) and on the ranks; rank 0 checks that
// the outputs are the same. Returns the one-process run's result (rank 0).
io::RunResult expectSameAsOneProcess(const fs::path& scene, const fs::path& dir) {
  const io::RunResult serial = runSerial(scene, dir / "serial");
  const io::RunResult spread = runOn(MPI_COMM_WORLD, scene, dir / "spread");
  EXPECT_EQ(spread.steps, kSteps);
  if (rankOf(MPI_COMM_WORLD) == 0) {
    EXPECT_EQ(spread.particles, serial.particles);
    EXPECT_EQ(spread.breakages, serial.breakages);
    EXPECT_LT(std::abs(spread.massBalanceError), 1e-14);
    expectSameOutputs(dir / "serial", dir / "spread");
  }
  return serial;
}

TEST(DistributedRun, OutputsEqualThoseOfOneProcess) {
  const fs::path dir = sharedPath("run_outputs");
  const io::RunResult serial = expectSameAsOneProcess(writeScene(dir), dir);
  if (rankOf(MPI_COMM_WORLD) != 0) return;
  EXPECT_GE(serial.breakages, 10u) << "the scene must break grains for this test to mean anything";
  // summary.json says how the ranks shared the run; one process's has no such block.
  int ranks = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  EXPECT_EQ(test::readFile(dir / "serial" / "summary.json").find("\"parallel\""), std::string::npos);
  const std::string summary = test::readFile(dir / "spread" / "summary.json");
  if (ranks == 1) {
    EXPECT_EQ(summary.find("\"parallel\""), std::string::npos);
    return;
  }
  EXPECT_NE(summary.find("\"parallel\""), std::string::npos);
  EXPECT_NE(summary.find("\"ranks\": " + std::to_string(ranks) + ","), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"balance\": \"nodes\""), std::string::npos);
  const auto number = [&](const std::string& key) { return test::jsonNumber(summary, key); };
  EXPECT_GE(number("owned_min"), 0.0);
  EXPECT_GE(number("owned_max"), std::max(1.0, number("owned_min")));
  EXPECT_GE(number("work_imbalance"), 1.0);
  EXPECT_GT(number("bytes_sent_per_step"), 0.0);
  EXPECT_GE(number("largest_wait_share"), 0.0);
  EXPECT_LT(number("largest_wait_share"), 1.0);
}

// The scene with a servo platen (a tool) in place of the moving plane: the
// servo moves by the load of the whole run (DistributedWorld::boundaryLoads),
// and the view evaluates only the tool contacts the ranks found. The
// outputs, the platen's load among them, are those of one process.
TEST(DistributedRun, ServoPlatenOutputsEqualThoseOfOneProcess) {
  const fs::path dir = sharedPath("run_servo");
  const fs::path scene = writeScene(
      dir, "",
      {{"[[planes]]\nname = \"platen\"\npoint = [0.0, 0.00335]\nnormal = [0.0, -1.0]\nvelocity = [0.0, -0.2]\n",
        "[[tools]]\nname = \"platen\"\nshape = \"plate\"\nposition = [0.0, 0.00355]\n"
        "[tools.motion]\ntype = \"servo\"\ndirection = [0.0, -1.0]\ntarget_force = 20.0\ngain = 0.01\nmax_speed = 0.2\n"},
       {"[[particles]]",
        "[shapes.plate]\nkind = \"box\"\nhalf_extents = [0.0012, 0.0002]\nspacing = 2.5e-5\n\n[[particles]]"}});
  expectSameAsOneProcess(scene, dir);
  if (rankOf(MPI_COMM_WORLD) != 0) return;
  // The servo pressed on the stack: the platen carried a load.
  double most = 0.0;
  for (const auto& row : readCsv(dir / "serial" / "history.csv")) {
    most = std::max(most, std::stod(row.at("platen_force_y_N")));
  }
  EXPECT_GT(most, 1.0) << "the servo must press on the grains for this test to mean anything";
}

// Stopped on every rank after its first breakages, resumed on half of the
// ranks (one when there are one or two): the outputs are those of the run
// that was not stopped.
TEST(DistributedRun, ResumesOnAnotherNumberOfRanks) {
  const fs::path dir = sharedPath("run_resume");
  const fs::path scene = writeScene(dir);
  const io::RunResult serial = runSerial(scene, dir / "serial");
  std::atomic<bool> stop{false};
  const io::RunResult first = runOn(MPI_COMM_WORLD, scene, dir / "resumed", &stop, 0.0052);
  EXPECT_TRUE(first.stopped);
  int ranks = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  const int rank = rankOf(MPI_COMM_WORLD);
  const int resumers = std::max(1, ranks / 2);
  MPI_Comm half = MPI_COMM_NULL;
  MPI_Comm_split(MPI_COMM_WORLD, rank < resumers ? 0 : MPI_UNDEFINED, rank, &half);
  if (half != MPI_COMM_NULL) {
    io::RunOptions o;
    o.resumeDir = (dir / "resumed").string();
    o.threads = 1;
    o.engine = parallel::distributedRun(half);
    const io::RunResult second = io::runScene(o);
    EXPECT_FALSE(second.stopped);
    if (rank == 0) {
      EXPECT_EQ(second.steps, serial.steps);
      EXPECT_EQ(second.particles, serial.particles);
      EXPECT_EQ(second.breakages, serial.breakages);
      EXPECT_GT(second.breakages, first.breakages) << "the run must break grains after the stop";
    }
    MPI_Comm_free(&half);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  if (rank == 0) expectSameOutputs(dir / "serial", dir / "resumed");
}

// Frames in per-rank pieces (`[output] frame_pieces = "ranks"`): each frame
// of particles, surfaces and contacts is an index (.pvtp) of one piece per
// rank, each written by its rank from the particles it owns; read together
// they are the frame rank 0 writes whole from its view: the same particles
// at the same places, the same surface cells and force chains.
TEST(DistributedRun, FramesInPiecesPerRankShowTheGatheredFrames) {
  const fs::path dir = sharedPath("run_pieces");
  const fs::path whole = writeScene(dir / "gathered");
  const fs::path pieces = writeScene(dir / "pieces", "", {{"[output]\n", "[output]\nframe_pieces = \"ranks\"\n"}});
  runOn(MPI_COMM_WORLD, whole, dir / "gathered" / "out");
  runOn(MPI_COMM_WORLD, pieces, dir / "pieces" / "out");
  if (rankOf(MPI_COMM_WORLD) != 0) return;
  int ranks = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  // Each particle's id, position and stress in a frame, by id.
  struct Shown {
    std::array<double, 3> position;
    double stress;
  };
  const auto byId = [](const io::VtpPiece& piece) {
    std::map<std::uint64_t, Shown> out;
    const std::vector<double> id = io::arrayAsDoubles(*io::findArray(piece.pointData, "id"));
    const std::vector<double> stress = io::arrayAsDoubles(*io::findArray(piece.pointData, "stress"));
    for (std::size_t k = 0; k < id.size(); ++k) {
      out[std::uint64_t(id[k])] = {{piece.points[3 * k], piece.points[3 * k + 1], piece.points[3 * k + 2]}, stress[k]};
    }
    EXPECT_EQ(out.size(), id.size()) << "a particle shown twice";
    return out;
  };
  std::size_t frames = 0, broken = 0;
  for (const char* series : {"particles", "surfaces", "contacts"}) {
    const auto a = io::readPvd(dir / "gathered" / "out" / (std::string(series) + ".pvd"));
    const auto b = io::readPvd(dir / "pieces" / "out" / (std::string(series) + ".pvd"));
    ASSERT_EQ(a.size(), b.size()) << series;
    ASSERT_GE(a.size(), 3u) << series;
    for (std::size_t f = 0; f < a.size(); ++f) {
      EXPECT_EQ(a[f].time, b[f].time) << series << " frame " << f;
      ASSERT_EQ(fs::path(b[f].file).extension(), ".pvtp") << series << " frame " << f;
      const std::string index = test::readFile(dir / "pieces" / "out" / b[f].file);
      std::size_t named = 0;
      for (std::size_t at = index.find("<Piece "); at != std::string::npos; at = index.find("<Piece ", at + 1)) ++named;
      EXPECT_EQ(named, std::size_t(ranks)) << b[f].file;
      const io::VtpPiece x = io::readVtp(dir / "gathered" / "out" / a[f].file);
      const io::VtpPiece y = io::readVtp(dir / "pieces" / "out" / b[f].file);
      EXPECT_EQ(y.pointCount(), x.pointCount()) << b[f].file;
      EXPECT_EQ(y.cellCount(), x.cellCount()) << b[f].file;
      if (std::string(series) != "particles") continue;
      const auto u = byId(x), v = byId(y);
      ASSERT_EQ(u.size(), v.size()) << b[f].file;
      for (const auto& [id, shown] : u) {
        const auto it = v.find(id);
        ASSERT_NE(it, v.end()) << b[f].file << ": particle " << id << " missing";
        EXPECT_EQ(it->second.position, shown.position) << b[f].file << ": particle " << id;
        EXPECT_NEAR(it->second.stress, shown.stress, 1e-9 * std::abs(shown.stress)) << b[f].file << ": particle " << id;
      }
      ++frames;
      broken += std::any_of(u.begin(), u.end(), [](const auto& e) { return e.first > 2; });
    }
  }
  EXPECT_GE(frames, 3u);
  EXPECT_GT(broken, 0u) << "the run must break grains for this test to mean anything";
}

// The shipped jaw crusher (CSS 50 mm) for 150,000 steps (1.5 s): a feed
// drops grains into the chamber, the jaws break them and grains leave through
// the outflow, each decided on every rank alike. The outputs are those of
// one process: the same grains dropped with the same ids, the same
// breakages and removal records.
TEST(DistributedRun, JawCrusherWithFeedAndOutflowOutputsEqualThoseOfOneProcess) {
  const fs::path dir = sharedPath("run_jaw_crusher");
  const fs::path scene = dir / "scene.toml";
  if (rankOf(MPI_COMM_WORLD) == 0) {
    std::string text =
        test::readFile(std::string(LSDEM_SOURCE_DIR) + "/apps/scenes/jaw_crusher/jaw_crusher_css50.toml");
    for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
             {"duration = 20.0", "steps = 150000"}, {"frames = 80", "frames = 1"}, {"history_rows = 2000", "history_rows = 200"}}) {
      const std::size_t at = text.find(from);
      if (at == std::string::npos) throw std::runtime_error("test scene: '" + from + "' not in jaw_crusher_css50.toml");
      text.replace(at, from.size(), to);
    }
    fs::create_directories(dir);
    std::ofstream(scene) << text;
  }
  MPI_Barrier(MPI_COMM_WORLD);
  const io::RunResult serial = runSerial(scene, dir / "serial");
  const io::RunResult spread = runOn(MPI_COMM_WORLD, scene, dir / "spread");
  if (rankOf(MPI_COMM_WORLD) != 0) return;
  EXPECT_EQ(spread.steps, serial.steps);
  EXPECT_EQ(spread.particles, serial.particles);
  EXPECT_EQ(spread.breakages, serial.breakages);
  expectSameOutputs(dir / "serial", dir / "spread");
  // The run was what the test is for: grains fed (ids past the first
  // grain's), broken, and gone through the outflow.
  EXPECT_GE(serial.breakages, 2u);
  std::size_t outflow = 0;
  std::uint64_t largestId = 0;
  for (const auto& row : readCsv(dir / "serial" / "removed.csv")) {
    outflow += row.at("reason") == "outflow";
    largestId = std::max<std::uint64_t>(largestId, std::stoull(row.at("id")));
  }
  EXPECT_GE(outflow, 2u);
  EXPECT_GE(largestId, 5u);
}

}  // namespace
}  // namespace lsdem
