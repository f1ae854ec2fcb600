#pragma once
/// @file Run.h
/// @brief Running a scene: the step loop with its outputs (docs/outputs.md),
/// written between steps and never inside one: ParaView series, CSV
/// histories, size and shape distributions, the breakage and removal logs,
/// `summary.json` (kept current), and checkpoints from which `resume`
/// continues bit for bit.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace lsdem::dynamics {
template <int D>
class World;
}

namespace lsdem::io {

template <int D>
struct SceneWorld;
struct ParallelDef;

/// What the ranks of a distributed run did so far (summary.json
/// "parallel"), taken over every rank at each view of the run.
struct RanksSummary {
  int ranks = 1;                       ///< processes in the run (1: not distributed, not written)
  bool balanceByTime = false;          ///< `[parallel] balance = "time"`
  std::uint64_t rebalances = 0;        ///< decompositions rebuilt
  std::uint64_t migrations = 0;        ///< particles handed to another owner, all ranks
  std::uint64_t allToAllExchanges = 0; ///< exchanges that needed every rank (after a rebalance)
  double bytesPerStep = 0.0;           ///< bytes sent per step, all ranks
  std::uint64_t ownedMin = 0, ownedMax = 0;  ///< particles a rank owns now, least and most
  /// The busiest rank's own work over the mean (1: even), and the largest
  /// share of a rank's steps spent in the exchanges and collectives (the
  /// wait for the others included), since the start of this process.
  double workImbalance = 1.0;
  double largestWaitShare = 0.0;
};

/// @brief How a run steps its world. Without one (RunOptions::engine null)
/// the run steps its world in this process. A distributed run
/// (lsdem::parallel, `mpirun -np N lsdem run`) runs runScene in every
/// process alike: each builds the world from the scene (or restores it from
/// the checkpoint) and hands it to its engine, which steps its part of the
/// run; one process writes the outputs, from a view of the whole run that
/// the engine brings up to date at the instants the outputs are due
/// (docs/parallel.md "lsdem run on N ranks").
template <int D>
class RunEngine {
 public:
  virtual ~RunEngine() = default;
  /// @brief One step of the run (collective: every process calls it).
  virtual void step() = 0;
  /// @brief Brings `view` (on the process that writes the outputs: a world
  /// built from the same scene, which nothing steps) up to the whole run now.
  /// Collective; the other processes pass their own world, untouched.
  virtual void updateView(SceneWorld<D>& view) = 0;
  /// @brief Whether any process was asked to stop (collective).
  virtual bool anyStop(bool stop) = 0;
  /// @brief The writing process's `value`, on every process (collective).
  virtual std::uint64_t fromWriter(std::uint64_t value) = 0;
  /// @brief Whether `here` holds on any process (collective: returns once
  /// every process asked).
  virtual bool any(bool here) = 0;
  /// @brief How many times the run's particle set changed so far (a batch of
  /// splits, a removal or an addition anywhere), the same on every process:
  /// a view for the removal and breakage logs is needed only after a change.
  virtual std::uint64_t particleSetChanges() = 0;
  /// @brief What the ranks did so far, on the writing process (collective).
  virtual RanksSummary ranksSummary() = 0;
};

/// @brief Makes a run's engine for the world each process built alike,
/// with the scene's `[parallel]` settings.
struct RunEngineFactory {
  bool writesOutputs = true;  ///< this process writes the outputs (one process of a run does)
  int rank = 0;               ///< this process's number in the run, from 0 (the writing one's is 0)
  int ranks = 1;              ///< processes in the run
  std::function<std::unique_ptr<RunEngine<2>>(SceneWorld<2>&, const ParallelDef&)> make2;
  std::function<std::unique_ptr<RunEngine<3>>(SceneWorld<3>&, const ParallelDef&)> make3;
};

/// Where a run stands (for progress lines).
struct RunProgress {
  std::uint64_t steps = 0;        ///< steps done
  double time = 0.0;              ///< simulated time, s
  double endTime = 0.0;           ///< simulated time at the end, s (estimate for step-count runs)
  double fraction = 0.0;          ///< done, in [0, 1]
  double stepsPerSecond = 0.0;    ///< over the last report interval
  double wallSeconds = 0.0;       ///< of the run: this process's, and a resumed run's earlier processes' up to their last checkpoint
  double etaSeconds = 0.0;        ///< estimate of the wall time left: the steps left at the current dt over the current steps per second
  std::size_t particles = 0;
  std::size_t contacts = 0;
  std::size_t breakages = 0;
  bool done = false;              ///< the last report
};

/// The default bound of `lsdem run --check` on a split's energy gain, as a
/// fraction of the run's energy scale (docs/breakage.md "Energy check").
inline constexpr double kCheckSplitEnergyLimit = 0.05;

struct RunOptions {
  std::string scene;                        ///< scene file; when resuming, empty: the checkpoint's (or its copy in the folder)
  std::string outDir;                       ///< output folder; empty: the scene's [output] dir
  std::optional<std::uint64_t> steps;       ///< run this many steps (from the start or the checkpoint) instead of to the run's end (a new run: the scene's; a resume: the checkpoint's)
  int threads = -1;                         ///< OpenMP threads; < 0: the scene's; 0: all cores
  std::string resumeDir;                    ///< non-empty: continue the run whose outputs are in this folder
  bool overwrite = false;                   ///< a new run replaces another run's outputs in its folder (else refused)
  bool force = false;                       ///< resume even with a scene that is not the checkpoint's (else refused), to the scene's end
  /// Checks that cannot be fooled (`lsdem run --check`): every particle's
  /// position, orientation, velocities, force and torque are checked for
  /// NaN/Inf each step (WorldDef::checkFinite), and a split whose fragments
  /// hold more mechanical energy than their parent by more than
  /// `splitEnergyLimit` of the run's energy scale, or whose energy is not
  /// finite, stops the run (Breakage.h "Energy check"). Either ends the run
  /// with std::runtime_error (exit 1), outputs kept.
  bool check = false;
  double splitEnergyLimit = kCheckSplitEnergyLimit;
  const std::atomic<bool>* stop = nullptr;  ///< set (e.g. by Ctrl-C) to stop after the current step
  std::function<void(const RunProgress&)> progress;  ///< called every [output] progress_seconds and at the end
  std::function<void(const std::string&)> note;      ///< called with each line of the scene's notes before the run starts
  /// Null: the run steps its world in this process; else a distributed run's engine (RunEngine).
  std::shared_ptr<const RunEngineFactory> engine;
};

struct RunResult {
  std::string outDir;
  int dimension = 0;
  std::uint64_t steps = 0;
  double time = 0.0;              ///< simulated, s
  double wallSeconds = 0.0;
  bool stopped = false;           ///< stopped early by `stop`
  bool alreadyFinished = false;   ///< a resume of a run already at its end: nothing was run or written
  bool nothingWritten = false;    ///< no output changed (already finished, or stopped during the set-up)
  std::size_t particles = 0;
  std::size_t breakages = 0;
  double massIn = 0.0;            ///< initial + fed mass, kg
  double massOut = 0.0;           ///< particles + removed (outflow, fines), kg
  double massBalanceError = 0.0;  ///< (massOut - massIn) / massIn
};

/// @brief Runs (or resumes) a scene and writes its outputs.
/// @note Throws InputError for a bad scene or checkpoint, for an output
/// folder that another live run holds (its lock file, `lsdem.lock`), and for
/// a new run into a folder holding another run's outputs unless `overwrite`,
/// for a resume with a scene whose text is not the checkpoint's (edited,
/// given, or a checkpoint copied from another run's folder) unless `force`;
/// std::runtime_error when an output cannot be written. A run that stops early (stop flag)
/// writes a final frame, summary and checkpoint first.
RunResult runScene(const RunOptions& options);

}  // namespace lsdem::io
