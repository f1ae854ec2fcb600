#pragma once
/// @file RunPlan.h
/// @brief The plan of a run (internal to io): where it ends, the limits a
/// scene must respect to end in bounded time with finite numbers, and the
/// recorders its `[output]` keys declare.

#include "run/Recorder.h"

#include "lsdem/io/Run.h"

#include <memory>
#include <vector>

namespace lsdem::io {

/// @brief Where a run ends, and the clock it counts in: simulated time for a
/// scene with a duration, steps for one with a step count or for `--steps`.
struct RunEnd {
  bool byTime = true;
  double endTime = 0.0;        ///< s (byTime)
  std::uint64_t endStep = 0;   ///< (!byTime)
  double span = 0.0;           ///< the clock's span over the run: s, or steps

  Instant now(double time, std::uint64_t steps) const { return {time, steps, byTime ? time : double(steps)}; }
  bool finished(double time, std::uint64_t steps) const;
  /// Done, in [0, 1].
  double fraction(double time, std::uint64_t steps) const;
  /// Steps left at a step of `dt`.
  double stepsLeft(double time, std::uint64_t steps, double dt) const;
  /// The interval of `n` records spread over the span (at least one step on
  /// a step clock, where a record falls on the first step at or after its
  /// instant); 0 for n = 0.
  double every(std::uint64_t n) const;
};

/// @brief The end of a run of `scene` with `options` from the state `world`
/// is in (a resumed run's `--steps` count from its checkpoint).
template <int D>
RunEnd runEnd(const SceneDef<D>& scene, const RunOptions& options, const dynamics::World<D>& world);

/// @brief Refuses (InputError naming the scene key) a new run that cannot end
/// in bounded time with finite numbers: a duration or checkpoint interval
/// under one step, more than 1e9 steps, speeds whose kinetic energy a double
/// cannot hold.
template <int D>
void checkRunLimits(const SceneDef<D>& scene, const RunOptions& options, const dynamics::World<D>& world,
                    const RunEnd& end, double initialMass);

/// @brief Refuses (InputError at `effects.global_damping`) a global damping
/// C_g with C_g dt >= 1 at the world's time step: a new run's or a resumed
/// one's (a forced resume may have changed it).
template <int D>
void checkGlobalDamping(const SceneDef<D>& scene, const dynamics::World<D>& world);

/// @brief Refuses (InputError at the tool's `motion`, or its table) a resume
/// whose scene puts a tool elsewhere at the checkpoint's time than the
/// checkpointed run had it (World::savedToolPoses): an edited motion,
/// resumed with --force, would move the tool into the grains at once. A
/// motion may change past the checkpoint (docs/outputs.md).
template <int D>
void checkToolPoses(const SceneDef<D>& scene, const dynamics::World<D>& world);

/// @brief The checkpoints' schedule: every `[output] checkpoint_every` (s; in
/// whole steps on a step clock), first after one interval.
template <int D>
Schedule checkpointSchedule(const SceneDef<D>& scene, const RunEnd& end, const dynamics::World<D>& world);

/// @brief The recorders the scene's `[output]` declares, in the order they
/// record: removed.csv and breakage_log.csv (always), history.csv
/// (`history_rows`), the ParaView series (`frames` > 0, `vtk`), the
/// distributions (`distributions` or `distribution_times`), tracks.csv
/// (`track`), and summary.json (last: it follows the frames, and is written
/// at the end).
template <int D>
std::vector<std::unique_ptr<Recorder<D>>> makeRecorders(const RunContext<D>& context, const RunEnd& end);

}  // namespace lsdem::io
