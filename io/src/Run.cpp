/// @file Run.cpp
/// @brief The run loop of `lsdem run`: steps, outputs between steps,
/// checkpoints and resume (Run.h, docs/outputs.md).

#include "lsdem/io/Run.h"

#include "lsdem/breakage/Criteria.h"
#include "lsdem/breakage/GrainStress.h"
#include "lsdem/geometry/Contours.h"
#include "lsdem/io/BreakageLog.h"
#include "lsdem/io/GrainFile.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/RunSummary.h"
#include "lsdem/io/Scene.h"
#include "lsdem/io/Vtk.h"

#include "Checksum.h"
#include "OutputFolder.h"
#include "OutputNames.h"

#include <algorithm>
#include <charconv>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <cerrno>
#include <cstring>
#include <sstream>
#include <variant>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

namespace lsdem::io {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using geometry::Vec;

constexpr char kCheckpointMagic[8] = {'L', 'S', 'D', 'E', 'M', 'C', 'K', 'P'};
// 2: a CRC-32 of everything before it closes the file.
constexpr std::uint32_t kCheckpointVersion = 2;
constexpr const char* kCheckpointFile = outputs::kCheckpoint;
// The most steps a scene may imply (duration / dt, or steps); longer runs go
// in parts with --steps and --resume (docs/reliability.md).
constexpr double kMaxSteps = 1e9;
// The largest energy scale (J) a scene may reach by its accelerations and
// speeds: room for the sums and products of the energy ledger in doubles.
constexpr double kMaxEnergyScale = 1e300;

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Shortest text that reads back to the same double.
std::string num(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

std::uint64_t fnv1a(const std::string& bytes) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::string readWholeFile(const std::string& path, bool mustExist = true);

// A checkpoint's bytes, its magic, format version and CRC-32 checked, the
// checksum removed.
std::string readCheckpointFile(const std::string& path) {
  std::string bytes = readWholeFile(path);
  if (bytes.size() < 8 || std::memcmp(bytes.data(), kCheckpointMagic, 8) != 0) {
    throw InputError(path, 0, "", "not an lsdem checkpoint");
  }
  if (bytes.size() < 8 + 4 + 4) throw InputError(path, 0, "", "truncated checkpoint");
  std::uint32_t version = 0;
  std::memcpy(&version, bytes.data() + 8, 4);
  if (version != kCheckpointVersion) {
    throw InputError(path, 0, "", "checkpoint of another lsdem version (format " + std::to_string(version) +
                                      ", this lsdem reads " + std::to_string(kCheckpointVersion) + ")");
  }
  std::uint32_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
  if (crc32Of(bytes.data(), bytes.size() - 4) != stored) {
    throw InputError(path, 0, "",
                     "damaged checkpoint: its checksum does not match its contents (a partial copy, a bit flip or an edit)");
  }
  bytes.resize(bytes.size() - 4);
  return bytes;
}

// A file's bytes; a file that cannot be read is an InputError, or empty
// when it need not exist.
std::string readWholeFile(const std::string& path, bool mustExist) {
  std::ifstream in(path, std::ios::binary);
  if (!in && !mustExist) return {};
  if (!in) throw InputError(path, 0, "", "cannot read the file");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Why the last write failed (a full disk: "No space left on device").
std::string writeError() { return errno != 0 ? std::strerror(errno) : "write failed"; }

// How many bytes of a CSV file a resumed run keeps: the `recorded` size the
// checkpoint saw (whole rows; the first is `header`), or, when the file is shorter or holds NUL
// bytes before that size (cut by a kill or a full disk, or a machine crash
// that left a block of zeros), what lies before its last whole row. Reads
// and checks only: nothing is changed until every output has been checked.
std::uint64_t keptCsvSize(const fs::path& path, std::uint64_t recorded, const std::string& header) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputError(path.string(), 0, "", "missing or unreadable: the run's outputs are incomplete, cannot resume");
  }
  // Rows are appended under the columns this scene writes.
  std::string first;
  if (std::getline(in, first) && !in.eof() && first != header) {
    throw InputError(path.string(), 1, "", "its columns are not those this scene writes (another scene's file?)");
  }
  in.clear();
  in.seekg(0);
  std::uint64_t read = 0, wholeRows = 0;
  std::string chunk(std::size_t(1) << 20, '\0');
  while (read < recorded) {
    in.read(chunk.data(), std::streamsize(std::min<std::uint64_t>(chunk.size(), recorded - read)));
    const std::size_t n = std::size_t(in.gcount());
    if (n == 0) break;
    const std::size_t nul = std::string_view(chunk.data(), n).find('\0');
    const std::size_t valid = nul == std::string_view::npos ? n : nul;
    const std::size_t lastBreak = std::string_view(chunk.data(), valid).rfind('\n');
    if (lastBreak != std::string_view::npos) wholeRows = read + lastBreak + 1;
    read += valid;
    if (valid < n) break;
  }
  return read == recorded ? recorded : wholeRows;
}

// One CSV file of the run, appended row by row and flushed, so a run that
// stops keeps every row written. A resumed run cuts it back to the size it had
// at the checkpoint. Every row is checked before it is written: a non-finite
// number (the simulation diverged) stops the run instead of reaching the file.
// A write that fails (a full disk) stops the run, naming the file.
class CsvFile {
 public:
  /// A new file holding the header.
  void create(const fs::path& path, const std::string& header) {
    path_ = path;
    columns_ = cells(header);
    out_.open(path, std::ios::trunc | std::ios::binary);
    if (!out_) throw std::runtime_error("cannot write " + path.string() + ": " + writeError());
    write(header + '\n');
  }
  /// A resumed run's file, cut to its first `size` bytes (keptCsvSize) and
  /// appended to; the header again when nothing of it is kept.
  void resume(const fs::path& path, const std::string& header, std::uint64_t size) {
    path_ = path;
    columns_ = cells(header);
    std::error_code ec;
    fs::resize_file(path, size, ec);
    if (ec) throw std::runtime_error("cannot cut " + path.string() + " back to the checkpoint: " + ec.message());
    out_.open(path, std::ios::app | std::ios::binary);
    if (!out_) throw std::runtime_error("cannot write " + path.string() + ": " + writeError());
    if (size == 0) write(header + '\n');
  }
  /// One row (no line break).
  void row(const std::string& line) { write(line + '\n'); }
  /// Whole rows, each ending in a line break.
  void write(const std::string& rows) {
    checkFinite(rows);
    errno = 0;
    out_ << rows;
    out_.flush();
    if (!out_) throw std::runtime_error("cannot write " + path_.string() + ": " + writeError());
  }
  std::uint64_t size() {
    out_.flush();
    return std::uint64_t(fs::file_size(path_));
  }

 private:
  static std::vector<std::string> cells(const std::string& line) {
    std::vector<std::string> out(1);
    for (const char c : line) {
      if (c == ',') {
        out.emplace_back();
      } else {
        out.back() += c;
      }
    }
    return out;
  }
  // Numbers are written by std::to_chars: a non-finite one is a whole cell
  // "inf", "-inf", "nan" or "-nan".
  void checkFinite(const std::string& rows) const {
    std::size_t begin = 0;
    while (begin < rows.size()) {
      std::size_t end = rows.find('\n', begin);
      if (end == std::string::npos) end = rows.size();
      const std::vector<std::string> row = cells(rows.substr(begin, end - begin));
      for (std::size_t k = 0; k < row.size(); ++k) {
        const std::string& c = row[k];
        if (c != "inf" && c != "-inf" && c != "nan" && c != "-nan") continue;
        const std::string column = k < columns_.size() ? columns_[k] : "column " + std::to_string(k + 1);
        throw std::runtime_error(path_.string() + ": " + column + " = " + c + " in the row of " +
                                 columns_.front() + " " + row.front() +
                                 ": the simulation diverged (a non-finite value); the run stops here, the row is "
                                 "not written");
      }
      begin = end + 1;
    }
  }

  fs::path path_;
  std::vector<std::string> columns_;
  std::ofstream out_;
};

// Output times: every `interval` of a clock (simulated time, or steps).
struct Schedule {
  double interval = 0.0;  // <= 0: never
  double next = 0.0;
  bool due(double clock) const { return interval > 0.0 && clock >= next - 1e-9 * interval; }
  // Moves `next` past `clock` in bounded time: an interval far below the
  // clock's step skips the missed times at once, and one below the clock's
  // rounding moves to just past the clock.
  void advance(double clock) {
    const double until = clock + 1e-9 * interval;
    if ((until - next) / interval > 1e6) next += std::floor((until - next) / interval) * interval;
    while (next <= until) {
      const double n = next + interval;
      next = n > next ? n : std::nextafter(until, std::numeric_limits<double>::infinity());
    }
  }
};

template <int D>
class Runner {
 public:
  Runner(SceneDef<D> scene, std::string sceneText, const RunOptions& options, const std::string& outDir,
         std::unique_ptr<OutputLock> lock)
      : scene_(std::move(scene)),
        sceneText_(std::move(sceneText)),
        sceneHash_(fnv1a(sceneText_)),
        options_(options),
        out_(outDir),
        lock_(std::move(lock)) {}

  RunResult run(bool resume) {
    const Clock::time_point start = Clock::now();
    start_ = start;
    if (options_.check) scene_.world.checkFinite = true;
    sw_ = buildWorld(scene_);
    if (options_.check && sw_.breakage) sw_.breakage->setSplitEnergyLimit(options_.splitEnergyLimit);
    World& world = *sw_.world;
    std::optional<std::map<std::string, std::uint64_t>> sizes;
    if (resume) {
      sizes = loadCheckpoint();
    } else {
      initialMass_ = sw_.initialMass;
      h0_ = specimenHeight();
    }
    setEnd(world);
    // Everything is checked: now the outputs.
    claimOutputFolder(resume);
    // The copy of the scene the run read: its identity for a resume (a
    // forced resume with another scene replaces it).
    if (!resume || readWholeFile((out_ / "scene.toml").string(), false) != sceneText_) {
      writeFileAtomically(out_ / "scene.toml", sceneText_);
    }
    openOutputs(sizes);

    // Frames at the start of a new run (a resumed run has them already).
    if (!resume) {
      writeFrame();
      writeDistributions();
      distributionTimeDue();  // times at or before the start are this snapshot
      writeHistoryRow();
      advanceSchedules();
    }

    // The loop: one step, then whatever output is due.
    Clock::time_point lastReport = Clock::now();
    std::uint64_t stepsAtReport = world.steps();
    bool stopped = false;
    while (!finished(world)) {
      if (options_.stop && options_.stop->load()) {
        stopped = true;
        break;
      }
      world.step();
      const double clock = clockValue();
      appendLogs();
      if (history_.due(clock)) writeHistoryRow();
      if (frames_.due(clock)) writeFrame();
      if (distributions_.due(clock) || distributionTimeDue()) writeDistributions();
      // The schedules move past this step before a periodic checkpoint saves
      // them: a run resumed from it (after a kill) must not write this step's
      // outputs again.
      const bool checkpoint = checkpoints_.due(clock);
      advanceSchedules();
      if (checkpoint) writeCheckpoint();
      if (options_.progress && secondsSince(lastReport) >= scene_.output.progressSeconds) {
        const double dtWall = secondsSince(lastReport);
        report(start, double(world.steps() - stepsAtReport) / dtWall, false);
        lastReport = Clock::now();
        stepsAtReport = world.steps();
      }
    }

    // The end (or an early stop): the checkpoint first, so that a resumed run
    // drops what follows (it is not on the output schedule), then a final
    // frame, history row and distribution, and the summary.
    wallSeconds_ = secondsSince(start);
    writeCheckpoint();
    const double clock = clockValue();
    if (lastHistoryClock_ != clock) writeHistoryRow();
    if (lastFrameClock_ != clock) writeFrame();
    if (lastDistributionClock_ != clock) writeDistributions();
    writeProductPsd();
    wallSeconds_ = secondsSince(start);
    writeSummary(stopped, true);
    if (options_.progress) report(start, double(world.steps()) / std::max(wallSeconds_, 1e-9), true);

    RunResult r;
    r.outDir = out_.string();
    r.dimension = D;
    r.steps = world.steps();
    r.time = world.time();
    r.wallSeconds = wallSeconds_;
    r.stopped = stopped;
    r.particles = world.particles().size();
    r.breakages = sw_.breakage ? sw_.breakage->breakages() : 0;
    r.massIn = massIn();
    r.massOut = world.particleMass() + world.removedMass();
    r.massBalanceError = r.massIn > 0.0 ? (r.massOut - r.massIn) / r.massIn : 0.0;
    return r;
  }

 private:
  using World = dynamics::World<D>;

  double massIn() const {
    double fed = 0.0;
    for (const auto* f : sw_.feeds) fed += f->droppedMass();
    return initialMass_ + fed;
  }

  // ---- the end of the run and the output clocks ----
  void setEnd(const World& world) {
    byTime_ = scene_.duration > 0.0 && !options_.steps;
    if (options_.steps) {
      endStep_ = world.steps() + *options_.steps;
    } else if (!byTime_) {
      endStep_ = scene_.steps;
    }
    endTime_ = scene_.duration;
    const double span = byTime_ ? scene_.duration : double(options_.steps ? endStep_ : scene_.steps);
    const auto every = [&](std::uint64_t n) { return n > 0 ? span / double(n) : 0.0; };
    const auto roundSteps = [&](double v) { return byTime_ || v <= 0.0 ? v : std::max(1.0, std::floor(v)); };
    frames_.interval = roundSteps(every(scene_.output.frames));
    history_.interval = roundSteps(every(scene_.output.historyRows));
    distributions_.interval = scene_.output.distributionTimes.empty()
                                  ? roundSteps(every(scene_.output.distributions > 1 ? scene_.output.distributions - 1 : 0))
                                  : 0.0;
    checkpoints_.interval = scene_.output.checkpointEvery > 0.0
                                ? (byTime_ ? scene_.output.checkpointEvery
                                           : std::max(1.0, std::floor(scene_.output.checkpointEvery / std::max(world.dt(), 1e-300))))
                                : 0.0;
    if (!resumed_) {
      checkLimits(world, span);
      frames_.next = distributions_.next = history_.next = 0.0;
      checkpoints_.next = checkpoints_.interval;
    }
  }
  [[noreturn]] void refuse(const std::string& key, const std::string& what) const {
    const auto line = scene_.keyLines.find(key);
    throw InputError(scene_.file, line != scene_.keyLines.end() ? line->second : 0, key, what);
  }

  // What a new run must respect to end in bounded time with finite numbers:
  // the end and the checkpoint interval at least one step, at most kMaxSteps
  // steps, and speeds whose kinetic energy a double can hold.
  void checkLimits(const World& world, double span) const {
    const double dt = world.dt();
    if (!(dt > 0.0)) return;
    if (byTime_ && scene_.duration < dt) {
      refuse("simulation.duration", "duration = " + num(scene_.duration) + " s is shorter than one time step (dt = " +
                                        num(dt) + " s)");
    }
    if (!options_.steps) {
      const double steps = byTime_ ? scene_.duration / dt : double(scene_.steps);
      if (steps > kMaxSteps) {
        refuse(byTime_ ? "simulation.duration" : "simulation.steps",
               "needs " + num(std::ceil(steps)) + " steps (dt = " + num(dt) +
                   " s), over the limit of 1e9 per run; run it in parts with --steps and --resume");
      }
    }
    if (scene_.output.checkpointEvery > 0.0 && scene_.output.checkpointEvery < dt) {
      refuse("output.checkpoint_every", "checkpoint_every = " + num(scene_.output.checkpointEvery) +
                                            " s is shorter than one time step (dt = " + num(dt) + " s)");
    }
    // Speeds: free fall over the run, initial velocities, moving planes.
    const double seconds = byTime_ ? span : span * dt;
    const double mass = std::max(sw_.initialMass, 1.0);
    const auto energyOf = [&](double speed) { return 0.5 * mass * speed * speed; };
    const auto check = [&](const std::string& key, double speed, const std::string& what) {
      if (!(energyOf(speed) <= kMaxEnergyScale) || !(speed * seconds <= kMaxEnergyScale)) {
        refuse(key, what + " reaches " + num(speed) + " m/s over the run: beyond what double precision can carry");
      }
    };
    if (scene_.world.gravity) check("effects.gravity", scene_.world.gravity->stableNorm() * seconds, "free fall");
    for (std::size_t g = 0; g < scene_.groups.size(); ++g) {
      check("particles[" + std::to_string(g) + "].velocity", scene_.groups[g].velocity.stableNorm(), "the velocity");
    }
    for (std::size_t k = 0; k < scene_.planes.size(); ++k) {
      check("planes[" + std::to_string(k) + "].velocity", scene_.planes[k].plane.velocity.stableNorm(), "the velocity");
    }
  }

  // Snapshots at the scene's distribution_times (simulated time, s).
  bool distributionTimeDue() {
    const std::vector<double>& times = scene_.output.distributionTimes;
    bool due = false;
    while (nextDistributionTime_ < times.size() && sw_.world->time() >= times[nextDistributionTime_]) {
      ++nextDistributionTime_;
      due = true;
    }
    return due;
  }
  bool finished(const World& world) const {
    if (byTime_) return world.time() >= endTime_ * (1.0 - 1e-12);
    return world.steps() >= endStep_;
  }
  double clockValue() const { return byTime_ ? sw_.world->time() : double(sw_.world->steps()); }
  void advanceSchedules() {
    const double clock = clockValue();
    for (Schedule* s : {&frames_, &history_, &distributions_, &checkpoints_}) {
      if (s->interval > 0.0) s->advance(clock);
    }
  }

  // ---- outputs ----
  // The folder is created and locked; a new run refuses another run's
  // outputs in it, or removes them with `overwrite`.
  void claimOutputFolder(bool resume) {
    std::error_code ec;
    fs::create_directories(out_, ec);
    if (ec) throw std::runtime_error("cannot create the output folder " + out_.string() + ": " + ec.message());
    if (!lock_) lock_ = std::make_unique<OutputLock>(out_);
    if (resume) return;
    checkOutputFolder(out_, options_.overwrite);
    removeRunOutputs(out_);
  }

  void openOutputs(const std::optional<std::map<std::string, std::uint64_t>>& sizes) {
    // The CSV files and their headers.
    std::vector<std::pair<std::string, std::string>> files;
    std::string header =
        "step,time_s,dt_s,critical_dt_s,dt_limit_id,dt_limit_generation,dt_limit_diameter_m,dt_limit_nodes,"
        "dt_limit_mass_kg,dt_limit_stiffness_N_per_m,dt_limit_patch_nodes,dt_limit_contact,particles,contacts,breakages,removed_mass_kg,"
        "kinetic_J,elastic_J,gravity_work_J,boundary_work_J,damping_loss_J,contact_loss_J,split_release_J,"
        "energy_error_J";
    const char* axes[3] = {"x", "y", "z"};
    for (const std::string& name : sw_.world->planeNames()) {
      for (int a = 0; a < D; ++a) header += "," + name + "_force_" + axes[a] + "_N";
    }
    for (const auto& tool : sw_.world->tools()) {
      for (int a = 0; a < D; ++a) header += "," + tool.name + "_force_" + axes[a] + "_N";
      header += "," + tool.name + "_power_W";
    }
    if (scene_.specimen) header += ",height_m,stress_Pa,strain,void_ratio";
    files.emplace_back(outputs::kHistory, header);
    files.emplace_back(outputs::kPsd, "time_s,sieve_size_m,percent_passing");
    files.emplace_back(outputs::kShapeStats,
                       "time_s,strain,particles,mean_circularity,mean_aspect_ratio,mean_sieve_size_m,shape_particles");
    files.emplace_back(outputs::kShapeHistograms, "time_s,strain,quantity,bin_low,bin_high,count");
    files.emplace_back(outputs::kRemoved, "id,time_s,mass_kg,volume,sieve_size_m,reason");
    {
      std::ostringstream h;
      writeBreakageLogHeader<D>(h);
      std::string s = h.str();
      if (!s.empty() && s.back() == '\n') s.pop_back();
      files.emplace_back(outputs::kBreakageLog, s);
    }
    // A resumed run checks every file before it changes any: one that is
    // missing or damaged leaves them all as they were.
    std::map<std::string, std::uint64_t> kept;
    if (sizes) {
      for (const auto& [name, h] : files) {
        const auto it = sizes->find(name);
        if (it == sizes->end()) {
          throw InputError((out_ / kCheckpointFile).string(), 0, name, "missing in the checkpoint");
        }
        kept[name] = keptCsvSize(out_ / name, it->second, h);
        if (kept[name] < it->second && options_.note) {
          options_.note((out_ / name).string() + ": cut short of the " + std::to_string(it->second) +
                        " bytes the checkpoint saw (a kill, a full disk or a crash): continued after its last whole "
                        "row, at byte " + std::to_string(kept[name]) + "; the rows between are missing");
        }
      }
    }
    // ParaView series (a resumed run's are read, and refused when damaged, here).
    FrameWriterDef<D> def;
    def.directory = out_;
    def.encoding = scene_.output.vtkFormat;
    def.particles = scene_.output.particles;
    def.surfaces = scene_.output.surfaces;
    def.boundaries = scene_.output.boundaries;
    def.contacts = scene_.output.contacts;
    if (scene_.domain) def.extent = *scene_.domain;
    def.resume = resumed_;
    if (scene_.output.frames > 0) frameWriter_.emplace(def);
    // Now the files are cut back to the checkpoint, or made.
    for (const auto& [name, h] : files) {
      if (sizes) {
        csv_[name].resume(out_ / name, h, kept[name]);
      } else {
        csv_[name].create(out_ / name, h);
      }
    }
    if (frameWriter_ && resumed_) frameWriter_->truncateAfter(lastFrameTime_);
  }

  void writeHistoryRow() {
    const World& w = *sw_.world;
    const dynamics::EnergyLedger& e = w.energy();
    // What set the time step (a grain still to come has no id: -1).
    const dynamics::TimeStepLimit& lim = stepLimit(w);
    const std::string limit = num(w.criticalDt()) + "," +
                              (lim.id == dynamics::kNoParent ? std::string("-1") : std::to_string(lim.id)) + "," +
                              std::to_string(lim.generation) + "," + num(lim.diameter) + "," +
                              std::to_string(lim.nodes) + "," + num(lim.mass) + "," + num(lim.stiffness) + "," +
                              std::to_string(lim.patchNodes) + "," + limitContactName(w, lim.boundary);
    std::string row = std::to_string(w.steps()) + "," + num(w.time()) + "," + num(w.dt()) + "," + limit + "," +
                      std::to_string(w.particles().size()) + "," + std::to_string(w.contacts().pairContacts().size()) +
                      "," + std::to_string(sw_.breakage ? sw_.breakage->breakages() : 0) + "," + num(w.removedMass()) +
                      "," + num(e.kineticTranslational + e.kineticRotational) + "," + num(e.elastic) + "," +
                      num(e.gravityWork) + "," + num(e.boundaryWork) + "," + num(e.dampingLoss) + "," +
                      num(e.contactLoss) + "," + num(e.splitRelease) + "," + num(e.balanceError());
    const auto& loads = w.boundaryLoads();
    for (std::size_t k = 0; k < w.planes().size(); ++k) {
      for (int a = 0; a < D; ++a) row += "," + num(k < loads.planeForce.size() ? loads.planeForce[k][a] : 0.0);
    }
    for (std::size_t k = 0; k < w.tools().size(); ++k) {
      const bool have = k < loads.toolForce.size();
      for (int a = 0; a < D; ++a) row += "," + num(have ? loads.toolForce[k][a] : 0.0);
      // Power the tool delivers to the particles (drawn from its drive), W.
      double power = 0.0;
      if (have) {
        power = -loads.toolForce[k].dot(w.toolPoses()[k].velocity) -
                dynamics::Rotation<D>::dot(loads.toolTorque[k], w.toolPoses()[k].angularVelocity);
      }
      row += "," + num(power);
    }
    if (scene_.specimen) {
      const double h = specimenHeight();
      const double stress = specimenStress();
      const double solid = solidVolume();
      const double total = h * scene_.specimen->width;
      row += "," + num(h) + "," + num(stress) + "," + num(h0_ > 0.0 ? (h0_ - h) / h0_ : 0.0) + "," +
             num(solid > 0.0 ? (total - solid) / solid : 0.0);
    }
    csv_[outputs::kHistory].row(row);
    lastHistoryClock_ = clockValue();
  }

  // Specimen height: from the bottom plane to the face of the top boundary (m).
  double specimenHeight() const {
    if (!scene_.specimen) return 0.0;
    const World& w = *sw_.world;
    const auto& names = w.planeNames();
    const auto bottomIt = std::find(names.begin(), names.end(), scene_.specimen->bottom);
    if (bottomIt == names.end()) return 0.0;
    const dynamics::Plane<D>& bottom = w.planes()[std::size_t(bottomIt - names.begin())];
    const auto topIt = std::find(names.begin(), names.end(), scene_.specimen->top);
    if (topIt != names.end()) return bottom.signedDistance(w.planes()[std::size_t(topIt - names.begin())].point);
    for (std::size_t k = 0; k < w.tools().size(); ++k) {
      if (w.tools()[k].name != scene_.specimen->top) continue;
      const dynamics::ToolPose<D>& pose = w.toolPoses()[k];
      const geometry::Mat<D> r = dynamics::Rotation<D>::matrix(pose.orientation);
      double lowest = std::numeric_limits<double>::infinity();
      for (const Vec<D>& x : pose.shape->nodes().positions) lowest = std::min(lowest, bottom.normal.dot(r * x));
      return bottom.signedDistance(pose.position) + lowest;
    }
    return 0.0;
  }
  // Vertical stress: the top boundary's load along the bottom's normal over the width/area (Pa).
  double specimenStress() const {
    const World& w = *sw_.world;
    const auto& names = w.planeNames();
    const auto bottomIt = std::find(names.begin(), names.end(), scene_.specimen->bottom);
    if (bottomIt == names.end()) return 0.0;
    const Vec<D> n = w.planes()[std::size_t(bottomIt - names.begin())].normal;
    const auto& loads = w.boundaryLoads();
    const auto topIt = std::find(names.begin(), names.end(), scene_.specimen->top);
    Vec<D> f = Vec<D>::Zero();
    if (topIt != names.end()) {
      const std::size_t k = std::size_t(topIt - names.begin());
      if (k < loads.planeForce.size()) f = loads.planeForce[k];
    } else {
      for (std::size_t k = 0; k < w.tools().size(); ++k) {
        if (w.tools()[k].name == scene_.specimen->top && k < loads.toolForce.size()) f = loads.toolForce[k];
      }
    }
    return f.dot(n) / scene_.specimen->width;
  }
  double solidVolume() const {
    const auto& p = sw_.world->particles();
    double v = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i) v += p.shape[i]->volume();
    return v;
  }

  void appendLogs() {
    const World& w = *sw_.world;
    for (; removedWritten_ < w.removed().size(); ++removedWritten_) {
      const dynamics::RemovedParticle& r = w.removed()[removedWritten_];
      csv_[outputs::kRemoved].row(std::to_string(r.id) + "," + num(r.time) + "," + num(r.mass) + "," + num(r.volume) + "," +
                              num(r.sieveSize) + "," + r.reason);
    }
    if (sw_.breakage && eventsWritten_ < sw_.breakage->events().size()) {
      const auto& events = sw_.breakage->events();
      std::ostringstream rows;
      writeBreakageLogRows<D>(std::span(events).subspan(eventsWritten_), rows);
      csv_[outputs::kBreakageLog].write(rows.str());
      eventsWritten_ = events.size();
    }
  }

  void writeDistributions() {
    const World& w = *sw_.world;
    const auto& p = w.particles();
    const std::string t = num(w.time());
    const std::string strain = scene_.specimen && h0_ > 0.0 ? num((h0_ - specimenHeight()) / h0_) : "";
    // Particle size distribution by mass against sieve size (eq. 21).
    // Shape statistics only of the particles resolved on their grids ([output] shape_min_cells).
    std::vector<std::pair<double, double>> sizes;
    double total = 0.0, circ = 0.0, aspect = 0.0, sieve = 0.0;
    std::vector<std::size_t> resolved;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const auto& d = p.shape[i]->descriptors();
      sizes.emplace_back(d.sieveSize, w.unscaledMass(i));
      total += w.unscaledMass(i);
      sieve += d.sieveSize;
      if (d.equivalentDiameter >= scene_.output.shapeMinCells * p.shape[i]->grid().spacing()) {
        resolved.push_back(i);
        circ += d.circularity;
        aspect += d.aspectRatio;
      }
    }
    // Fines removed so far count as passing at their own size (paper section
    // 3: removed particles are kept in the PSD).
    for (const dynamics::RemovedParticle& r : w.removed()) {
      if (r.reason != "fines") continue;
      sizes.emplace_back(r.sieveSize, r.mass);
      total += r.mass;
    }
    std::sort(sizes.begin(), sizes.end());
    double passing = 0.0;
    std::string rows;
    for (const auto& [size, mass] : sizes) {
      passing += mass;
      rows += t + "," + num(size) + "," + num(100.0 * passing / total) + "\n";
    }
    csv_[outputs::kPsd].write(rows);
    const double n = double(std::max<std::size_t>(p.size(), 1));
    const double m = double(std::max<std::size_t>(resolved.size(), 1));
    csv_[outputs::kShapeStats].row(t + "," + strain + "," + std::to_string(p.size()) + "," + num(circ / m) + "," +
                                num(aspect / m) + "," + num(sieve / n) + "," + std::to_string(resolved.size()));
    // Histograms of circularity (sphericity) and aspect ratio, 10 bins on [0, 1].
    for (const char* quantity : {"circularity", "aspect_ratio"}) {
      std::array<std::size_t, 10> bins{};
      for (const std::size_t i : resolved) {
        const auto& d = p.shape[i]->descriptors();
        const double v = std::string(quantity) == "circularity" ? d.circularity : d.aspectRatio;
        bins[std::size_t(std::clamp(int(v * 10.0), 0, 9))]++;
      }
      std::string out;
      for (std::size_t b = 0; b < bins.size(); ++b) {
        out += t + "," + strain + "," + quantity + "," + num(0.1 * double(b)) + "," + num(0.1 * double(b + 1)) + "," +
               std::to_string(bins[b]) + "\n";
      }
      csv_[outputs::kShapeHistograms].write(out);
    }
    lastDistributionClock_ = clockValue();
  }

  // The size distribution of the particles that left through the discharge
  // (a crusher's product), or through the outflow when no discharge is declared.
  void writeProductPsd() const {
    const std::string product = scene_.world.discharge ? "discharge" : "outflow";
    std::vector<std::pair<double, double>> sizes;
    double total = 0.0;
    for (const auto& r : sw_.world->removed()) {
      if (r.reason != product) continue;
      sizes.emplace_back(r.sieveSize, r.mass);
      total += r.mass;
    }
    if (sizes.empty()) return;
    std::sort(sizes.begin(), sizes.end());
    std::string text = "sieve_size_m,percent_passing,mass_kg\n";
    double passing = 0.0;
    for (const auto& [size, mass] : sizes) {
      passing += mass;
      text += num(size) + "," + num(100.0 * passing / total) + "," + num(mass) + "\n";
    }
    writeFileAtomically(out_ / outputs::kProductPsd, text);
  }

  void writeFrame() {
    if (!frameWriter_) return;
    const World& w = *sw_.world;
    // Like the CSV rows, a frame holds finite numbers only.
    for (std::size_t i = 0; i < w.particles().size(); ++i) {
      if (!w.particles().position[i].allFinite() || !w.particles().velocity[i].allFinite()) {
        throw std::runtime_error("frame at step " + std::to_string(w.steps()) + ": particle " +
                                 std::to_string(w.particles().id[i]) +
                                 " has a non-finite position or velocity: the simulation diverged; the run stops here");
      }
    }
    // Stress measure per particle: the breakage criterion's characteristic
    // stress, von Mises without breakage (Pa).
    if (!criterion_) {
      breakage::CriterionDef def;
      if (scene_.breakage) def = scene_.breakage->criterion;
      criterion_ = breakage::makeCriterion(def);
    }
    // (Contacts are read only while they describe the particles: not right
    // after a breakage or removal, when the frame shows zero stresses.)
    stressMeasure_.assign(w.particles().size(), 0.0);
    if (w.contactsCurrent()) breakage::grainStresses(w.particles(), w.contacts(), stress_);
    for (std::size_t i = 0; w.contactsCurrent() && i < stressMeasure_.size() && i < stress_.size(); ++i) {
      stressMeasure_[i] = criterion_->characteristicStress(breakage::principalStressTriple<D>(stress_[i]));
    }
    frameWriter_->write(w, stressMeasure_);
    lastFrameClock_ = clockValue();
    lastFrameTime_ = w.time();
    // The summary stays current with the frames.
    wallSeconds_ = secondsSince(start_);
    writeSummary(false);
  }

  /// Fragments against their own surfaces (docs/breakage.md): for every
  /// fragment (generation > 0) at least [output] shape_min_cells cells of its
  /// own grid across, its mass over the material density times the volume
  /// its zero level set encloses (as the surfaces output draws it) minus 1;
  /// the largest |deviation|, the mean and how many were checked.
  void writeFragmentDensity(JsonWriter& j) const {
    const auto& p = sw_.world->particles();
    double worst = 0.0, sum = 0.0;
    std::size_t checked = 0, regridded = 0, over3 = 0, worstIndex = 0;
    // On a grid of its own finer than the one it was cut from.
    const auto isRegridded = [](const geometry::Shape<D>& shape) {
      return shape.grid().spacing() < 0.999 * shape.contactSpacing();
    };
    for (std::size_t i = 0; i < p.size(); ++i) {
      const geometry::Shape<D>& shape = *p.shape[i];
      if (isRegridded(shape)) ++regridded;
      if (p.generation[i] == 0) continue;
      if (shape.descriptors().equivalentDiameter < scene_.output.shapeMinCells * shape.grid().spacing()) continue;
      const double enclosed = geometry::enclosedVolume<D>(shape.grid());
      if (!(enclosed > 0.0)) continue;
      // mass = density x the shape's volume (its share of the parent's), so
      // mass / (density x enclosed) - 1 = volume / enclosed - 1.
      const double deviation = shape.volume() / enclosed - 1.0;
      if (std::abs(deviation) >= worst) {
        worst = std::abs(deviation);
        worstIndex = i;
      }
      over3 += std::abs(deviation) > 0.03;
      sum += deviation;
      ++checked;
    }
    j.key("fragments").beginObject()
        .field("regridded", regridded)
        .field("density_checked", checked)
        .field("density_max_abs_deviation", worst)
        .field("density_mean_deviation", checked ? sum / double(checked) : 0.0)
        .field("density_over_3_percent", over3);
    if (checked > 0) {
      // The fragment with the largest deviation: which one, how old, how big.
      const geometry::Shape<D>& shape = *p.shape[worstIndex];
      j.key("density_worst").beginObject()
          .field("id", p.id[worstIndex])
          .field("generation", p.generation[worstIndex])
          .field("diameter", shape.descriptors().equivalentDiameter)
          .field("parent_cells_across", shape.descriptors().equivalentDiameter / shape.contactSpacing())
          .field("regridded", isRegridded(shape))
          .endObject();
    }
    j.endObject();
  }

  void writeSummary(bool stopped, bool final = false) const {
    const World& w = *sw_.world;
    std::ostringstream s;
    writeRunSummary<D>(w, wallSeconds_, s, [&](JsonWriter& j) {
      const double in = massIn(), outMass = w.particleMass() + w.removedMass();
      j.field("scene", scene_.file);
      j.field("stopped_early", stopped);
      j.key("mass_balance").beginObject()
          .field("initial", initialMass_)
          .field("fed", in - initialMass_)
          .field("particles", w.particleMass())
          .field("removed", w.removedMass())
          .field("relative_error", in > 0.0 ? (outMass - in) / in : 0.0)
          .endObject();
      if (sw_.breakage) {
        const auto& b = *sw_.breakage;
        j.key("breakage").beginObject()
            .field("breakages", b.breakages())
            .field("fines_mass", b.finesMass())
            .field("fines_percent", massIn() > 0.0 ? 100.0 * b.finesMass() / massIn() : 0.0)
            .field("raw_volume_error", b.rawVolumeError())
            .field("unsplit_failures", b.unsplitFailures())
            .field("unsplittable", b.unsplittable())
            .field("largest_split_energy_gain", b.largestEnergyGain())
            .field("largest_split_energy_gain_J", b.largestEnergyGainJoules())
            .field("unchecked_splits", b.uncheckedSplits());
        j.key("manual_not_applied").beginArray();
        for (const breakage::ManualBreakNotApplied& n : b.manualNotApplied()) {
          j.beginObject().field("time", n.time).field("particle", n.particle).field("reason", n.reason).endObject();
        }
        j.endArray().endObject();
        if (final) writeFragmentDensity(j);
      }
    });
    writeFileAtomically(out_ / outputs::kSummary, s.str());
  }

  void report(Clock::time_point start, double rate, bool done) {
    const World& w = *sw_.world;
    RunProgress p;
    p.steps = w.steps();
    p.time = w.time();
    p.endTime = byTime_ ? endTime_ : double(endStep_) * w.dt();
    p.fraction = byTime_ ? w.time() / endTime_ : double(w.steps()) / double(std::max<std::uint64_t>(endStep_, 1));
    p.fraction = std::clamp(p.fraction, 0.0, 1.0);
    p.stepsPerSecond = rate;
    p.wallSeconds = secondsSince(start);
    // The steps left at the current step and the current rate: the share of
    // the run done so far would mislead after a resume (this process did only
    // part of it) and when the step falls as grains break.
    const double stepsLeft = byTime_ ? std::max(0.0, endTime_ - w.time()) / w.dt()
                                     : double(endStep_ > w.steps() ? endStep_ - w.steps() : 0);
    p.etaSeconds = rate > 0.0 && std::isfinite(stepsLeft) ? stepsLeft / rate : 0.0;
    p.particles = w.particles().size();
    p.contacts = w.contacts().pairContacts().size();
    p.breakages = sw_.breakage ? sw_.breakage->breakages() : 0;
    p.done = done;
    options_.progress(p);
  }

  // ---- checkpoints ----
  void writeCheckpoint() {
    const World& w = *sw_.world;
    // World state, numbering the particles' shapes as they come.
    std::map<const geometry::Shape<D>*, std::uint32_t> index;
    std::vector<const geometry::Shape<D>*> shapes;
    dynamics::StateWriter state;
    w.saveState(state, [&](const std::shared_ptr<const geometry::Shape<D>>& s) {
      const auto [it, added] = index.emplace(s.get(), std::uint32_t(shapes.size()));
      if (added) shapes.push_back(s.get());
      return it->second;
    });
    // Runner state: clocks, log positions, CSV sizes.
    dynamics::StateWriter runner;
    runner.putTag("runner");
    runner.put(initialMass_);
    runner.put(h0_);
    for (const Schedule* s : {&frames_, &history_, &distributions_, &checkpoints_}) runner.put(s->next);
    runner.put(lastHistoryClock_);
    runner.put(lastFrameClock_);
    runner.put(lastDistributionClock_);
    runner.put(lastFrameTime_);
    runner.put(std::uint64_t(nextDistributionTime_));
    runner.put(std::uint64_t(removedWritten_));
    runner.put(std::uint64_t(eventsWritten_));
    runner.put(std::uint64_t(csv_.size()));
    for (auto& [name, file] : csv_) {
      runner.putString(name);
      runner.put(file.size());
    }

    std::ostringstream out(std::ios::binary);
    out.write(kCheckpointMagic, 8);
    const auto put = [&](const auto& v) { out.write(reinterpret_cast<const char*>(&v), sizeof(v)); };
    const auto putBytes = [&](const std::string& b) {
      put(std::uint64_t(b.size()));
      out.write(b.data(), std::streamsize(b.size()));
    };
    put(kCheckpointVersion);
    put(std::int32_t(D));
    putBytes(fs::absolute(scene_.file).string());
    put(sceneHash_);
    put(std::uint64_t(shapes.size()));
    for (const geometry::Shape<D>* s : shapes) {
      std::ostringstream g(std::ios::binary);
      writeGrain<D>(g, *s, GrainFormat::Binary);
      putBytes(g.str());
    }
    putBytes(std::string(state.bytes().begin(), state.bytes().end()));
    putBytes(std::string(runner.bytes().begin(), runner.bytes().end()));
    std::string file = out.str();
    const std::uint32_t crc = crc32Of(file.data(), file.size());
    file.append(reinterpret_cast<const char*>(&crc), 4);
    writeFileAtomically(out_ / kCheckpointFile, file);
    wallSeconds_ = secondsSince(start_);
    writeSummary(false);
  }

  std::map<std::string, std::uint64_t> loadCheckpoint() {
    const std::string path = (out_ / kCheckpointFile).string();
    const std::string bytes = readCheckpointFile(path);
    std::size_t pos = 0;
    const auto fail = [&](const std::string& what) { throw InputError(path, 0, "", what); };
    const auto take = [&](std::size_t n) {
      if (n > bytes.size() - pos) fail("truncated checkpoint");
      const char* p = bytes.data() + pos;
      pos += n;
      return p;
    };
    const auto get = [&]<class T>(T) {
      T v;
      std::memcpy(&v, take(sizeof(T)), sizeof(T));
      return v;
    };
    const auto getBytes = [&]() {
      const std::uint64_t n = get(std::uint64_t{});
      const char* p = take(std::size_t(n));
      return std::string(p, std::size_t(n));
    };
    take(8);
    get(std::uint32_t{});  // the version, checked by readCheckpointFile
    if (get(std::int32_t{}) != D) fail("checkpoint of another dimension");
    getBytes();  // scene path, read by runScene
    get(std::uint64_t{});
    std::vector<std::shared_ptr<const geometry::Shape<D>>> shapes(std::size_t(get(std::uint64_t{})));
    for (auto& s : shapes) {
      std::istringstream g(getBytes(), std::ios::binary);
      s = readGrain<D>(g, path);
    }
    const std::string state = getBytes();
    const std::string runner = getBytes();
    try {
      dynamics::StateReader in(state.data(), state.size());
      sw_.world->loadState(in, [&](std::uint32_t k) {
        if (k >= shapes.size()) throw std::runtime_error("shape " + std::to_string(k) + " is not in the checkpoint");
        return shapes[k];
      });
      dynamics::StateReader r(runner.data(), runner.size());
      r.expectTag("runner");
      initialMass_ = r.get<double>();
      h0_ = r.get<double>();
      for (Schedule* s : {&frames_, &history_, &distributions_, &checkpoints_}) s->next = r.get<double>();
      lastHistoryClock_ = r.get<double>();
      lastFrameClock_ = r.get<double>();
      lastDistributionClock_ = r.get<double>();
      lastFrameTime_ = r.get<double>();
      nextDistributionTime_ = std::size_t(r.get<std::uint64_t>());
      removedWritten_ = std::size_t(r.get<std::uint64_t>());
      eventsWritten_ = std::size_t(r.get<std::uint64_t>());
      std::map<std::string, std::uint64_t> sizes;
      const std::uint64_t n = r.get<std::uint64_t>();
      for (std::uint64_t k = 0; k < n; ++k) {
        const std::string name = r.getString();
        sizes[name] = r.get<std::uint64_t>();
      }
      resumed_ = true;
      return sizes;
    } catch (const std::runtime_error& e) {
      if (dynamic_cast<const InputError*>(&e)) throw;
      fail(e.what());
    }
    return {};
  }

  SceneDef<D> scene_;
  std::string sceneText_;    // the scene file's text as the run read it
  std::uint64_t sceneHash_;  // its hash, the run's identity in checkpoints
  RunOptions options_;
  fs::path out_;
  std::unique_ptr<OutputLock> lock_;  // held while the run writes into out_
  SceneWorld<D> sw_;
  bool resumed_ = false;
  bool byTime_ = true;
  double endTime_ = 0.0;
  std::uint64_t endStep_ = 0;
  Schedule frames_, history_, distributions_, checkpoints_;
  double lastHistoryClock_ = -1.0, lastFrameClock_ = -1.0, lastDistributionClock_ = -1.0;
  double lastFrameTime_ = -1.0;  // simulated time of the last frame on the schedule, s
  std::size_t nextDistributionTime_ = 0;  // index into [output] distribution_times
  std::map<std::string, CsvFile> csv_;
  std::optional<FrameWriter<D>> frameWriter_;
  std::unique_ptr<breakage::Criterion> criterion_;
  std::vector<geometry::Mat<D>> stress_;
  std::vector<double> stressMeasure_;
  std::size_t removedWritten_ = 0, eventsWritten_ = 0;
  double initialMass_ = 0.0;
  double h0_ = 0.0;
  double wallSeconds_ = 0.0;
  Clock::time_point start_;
};

// The scene a resumed run uses: the one given, else the one the checkpoint
// names, else (it moved) the copy in the output folder. It must be the
// checkpoint's scene, and the folder's copy too (a checkpoint copied in from
// another run is not this folder's), unless forced.
std::string resumeScene(const RunOptions& options) {
  const std::string& dir = options.resumeDir;
  const std::string path = (fs::path(dir) / kCheckpointFile).string();
  if (!fs::exists(path)) throw InputError(path, 0, "", "no checkpoint to resume from (is this a run's output folder?)");
  const std::string bytes = readCheckpointFile(path);
  std::size_t pos = 8 + 4 + 4;
  if (bytes.size() < pos + 8) throw InputError(path, 0, "", "truncated checkpoint");
  std::uint64_t n = 0;
  std::memcpy(&n, bytes.data() + pos, 8);
  pos += 8;
  if (n > bytes.size() - pos - 8) throw InputError(path, 0, "", "truncated checkpoint");
  const std::string named(bytes.data() + pos, std::size_t(n));
  pos += std::size_t(n);
  std::uint64_t hash = 0;
  std::memcpy(&hash, bytes.data() + pos, 8);

  const fs::path copy = fs::path(dir) / "scene.toml";
  const bool haveCopy = fs::exists(copy);
  const bool copyMatches = haveCopy && fnv1a(readWholeFile(copy.string())) == hash;
  std::string scene = options.scene;
  if (scene.empty()) {
    if (fs::exists(named)) {
      scene = named;
    } else if (haveCopy) {
      scene = copy.string();
    } else {
      throw InputError(path, 0, "", "its scene file " + named + " no longer exists (nor does a copy in " + dir + ")");
    }
  }
  std::optional<InputError> mismatch;
  if (haveCopy && !copyMatches) {
    mismatch.emplace(path, 0, "",
                     "written by a run of another scene than " + copy.string() +
                         " (a checkpoint copied from another run, or an edited copy)");
  } else if (fnv1a(readWholeFile(scene)) != hash) {
    mismatch.emplace(scene, 0, "",
                     options.scene.empty()
                         ? "the scene file changed since the checkpoint in " + dir + " was written"
                         : "not the scene of the run in " + dir + " (its checkpoint names " + named + ")");
  }
  if (!mismatch) return scene;
  if (!options.force) {
    throw InputError(mismatch->file(), 0, "", mismatch->problem() + "; give --force to resume with it anyway");
  }
  if (options.note) options.note(std::string(mismatch->what()) + ": resumed with " + scene + " anyway (--force)");
  return scene;
}

template <int D>
RunResult runOf(SceneDef<D> scene, std::string sceneText, const RunOptions& options, std::unique_ptr<OutputLock> lock) {
  const std::string out =
      !options.resumeDir.empty() ? options.resumeDir : (!options.outDir.empty() ? options.outDir : scene.output.dir);
  // A folder that exists is claimed before the world is built: another run
  // in it is refused at once.
  if (!lock && fs::is_directory(out)) {
    lock = std::make_unique<OutputLock>(out);
    checkOutputFolder(out, options.overwrite);
  }
#ifdef LSDEM_HAVE_OPENMP
  const int threads = options.threads >= 0 ? options.threads : scene.threads;
  if (threads > 0) omp_set_num_threads(threads);
#endif
  Runner<D> runner(std::move(scene), std::move(sceneText), options, out, std::move(lock));
  return runner.run(!options.resumeDir.empty());
}

}  // namespace

RunResult runScene(const RunOptions& options) {
  // A resumed run holds its folder from the start: no other run may write
  // its checkpoint while it is read.
  std::unique_ptr<OutputLock> lock;
  if (!options.resumeDir.empty() && fs::is_directory(options.resumeDir)) {
    lock = std::make_unique<OutputLock>(options.resumeDir);
  }
  const std::string scenePath = options.resumeDir.empty() ? options.scene : resumeScene(options);
  AnySceneDef scene = readScene(scenePath);
  std::string text = readWholeFile(scenePath);
  if (options.note) std::visit([&](const auto& s) { for (const std::string& n : s.notes) options.note(n); }, scene);
  if (auto* s2 = std::get_if<SceneDef<2>>(&scene)) {
    return runOf<2>(std::move(*s2), std::move(text), options, std::move(lock));
  }
  return runOf<3>(std::move(std::get<SceneDef<3>>(scene)), std::move(text), options, std::move(lock));
}

}  // namespace lsdem::io
