#pragma once
/// @file Recorder.h
/// @brief What a run writes besides its checkpoints (internal to io): each
/// output is a Recorder that the scene declares by its `[output]` keys
/// (makeRecorders), with its own Schedule, files and checkpointed state.
///
/// The run calls, in this order (docs/design.md "Recorders"):
/// - a new run: create(), then record() at the first instant;
/// - a resumed run: load() of every recorder (each checks the files it will
///   continue and changes none), then reopen() of every recorder;
/// - after each step: record() of every recorder whose schedule is due, then
///   advance() of every schedule, then a checkpoint if one is due, which
///   save()s every recorder: a run resumed from it serves the same instants;
/// - at the end: finish() of every recorder.

#include "run/CsvFile.h"
#include "run/Schedule.h"

#include "lsdem/dynamics/State.h"
#include "lsdem/dynamics/World.h"
#include "lsdem/io/Run.h"
#include "lsdem/io/Scene.h"

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace lsdem::io {

/// @brief What a run started from: saved in its checkpoints, so a resumed run
/// measures against the same start.
struct RunBasis {
  double initialMass = 0.0;     ///< kg of the particles placed at the start
  double specimenHeight = 0.0;  ///< m, the specimen's height at the start (0 without a specimen)
};

/// @brief What recorders read besides the world: the scene, the world's
/// effects, the output folder and the run's state. Owned by the run; the
/// recorders hold a reference.
template <int D>
struct RunContext {
  const SceneDef<D>& scene;
  const SceneWorld<D>& sw;
  std::filesystem::path out;
  RunBasis basis;
  std::chrono::steady_clock::time_point started;      ///< when this process started the run
  bool stopped = false;                               ///< stopped early (known at the end)
  std::function<void(const std::string&)> note;       ///< notes for the user (what a resume repaired, tracked ids that never existed)
  RanksSummary ranks;                                 ///< a distributed run's, at its last view
  std::string failure;                                ///< the error that stopped the run ("" for none)
  double wallBefore = 0.0;                            ///< wall seconds of the processes before this one (a resumed run)

  /// kg that entered the run: the initial particles and what feeds dropped.
  double massIn() const;
  /// Wall seconds of the run: those before this process (`wallBefore`) and since `started`.
  double wallSeconds() const;
};

template <int D>
class Recorder {
 public:
  using World = dynamics::World<D>;
  virtual ~Recorder() = default;
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  /// Its name: its section in checkpoints.
  const std::string& name() const { return name_; }
  Schedule& schedule() { return schedule_; }

  /// A new run: makes its files.
  void create();
  /// A resumed run, first step: reads its state as save() wrote it and checks
  /// the files it continues (InputError when one is missing or damaged);
  /// changes no file.
  void load(dynamics::StateReader& in);
  /// A resumed run in a process that does not write the outputs (a
  /// distributed run's other ranks): its schedule only, touching no file.
  void loadSchedule(dynamics::StateReader& in);
  /// A resumed run, second step: cuts its files back to the checkpoint and
  /// continues them.
  void reopen();
  /// Its state, for a checkpoint.
  void save(dynamics::StateWriter& out);
  /// Records the world at `now`: the first instant of a run, or a due one.
  void record(const World& world, const Instant& now);
  /// The end of the run: a last record unless the last one was at `now`.
  void finish(const World& world, const Instant& now);
  /// Whether finish(world, now) records.
  bool recordsAtFinish(const Instant& now) const { return lastClock_ != now.clock; }
  /// Whether it records only what the world's removal or breakage records
  /// gained (a step in which the particle set did not change gives it
  /// nothing: a distributed run then needs no view for it).
  virtual bool recordsChangesOnly() const { return false; }

 protected:
  Recorder(std::string name, Schedule schedule, const RunContext<D>& context);
  /// Declares a CSV file in the output folder (in the constructor); its index for csv().
  std::size_t addCsv(std::string file, std::string header);
  CsvFile& csv(std::size_t k) { return csv_[k].file; }

  /// One record of the world.
  virtual void write(const World& world) = 0;
  /// What it does besides its CSV files (which the base class handles).
  virtual void onCreate() {}
  virtual void onLoad(dynamics::StateReader&) {}
  virtual void onReopen() {}
  virtual void onSave(dynamics::StateWriter&) {}
  /// After the last record.
  virtual void onFinish(const World&) {}

  const RunContext<D>& context_;

 private:
  struct Csv {
    std::string name, header;
    std::uint64_t kept = 0;  // a resumed run: the bytes kept
    CsvFile file;
  };
  std::string name_;
  Schedule schedule_;
  double lastClock_ = -1.0;  // the clock of the last record
  std::vector<Csv> csv_;
};

extern template struct RunContext<2>;
extern template struct RunContext<3>;
extern template class Recorder<2>;
extern template class Recorder<3>;

}  // namespace lsdem::io
