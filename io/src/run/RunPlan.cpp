/// @file RunPlan.cpp
/// @brief The plan of a run (RunPlan.h).

#include "run/RunPlan.h"

#include "NumberText.h"
#include "run/BreakageLogRecorder.h"
#include "run/DistributionRecorder.h"
#include "run/FrameRecorder.h"
#include "run/HistoryRecorder.h"
#include "run/RemovedLog.h"
#include "run/SummaryRecorder.h"
#include "run/TrackRecorder.h"

#include "lsdem/io/InputError.h"

#include <algorithm>
#include <cmath>

namespace lsdem::io {

namespace {

// The most steps a scene may imply (duration / dt, or steps); longer runs go
// in parts with --steps and --resume (docs/reliability.md).
constexpr double kMaxSteps = 1e9;
// The largest energy scale (J) a scene may reach by its accelerations and
// speeds: room for the sums and products of the energy ledger in doubles.
constexpr double kMaxEnergyScale = 1e300;

// Every `seconds` of simulated time from `first` intervals on: in a run to a
// duration the clock is time; in a run of a number of steps, whole steps
// (at least one) of the time step `dt`.
Schedule everySeconds(double seconds, const RunEnd& end, double dt, double first) {
  const double interval = end.byTime ? seconds : std::max(1.0, std::floor(seconds / std::max(dt, 1e-300)));
  return Schedule::every(interval, first * interval);
}

}  // namespace

bool RunEnd::finished(double time, std::uint64_t steps) const {
  if (byTime) return time >= endTime * (1.0 - 1e-12);
  return steps >= endStep;
}

double RunEnd::fraction(double time, std::uint64_t steps) const {
  const double f = byTime ? time / endTime : double(steps) / double(std::max<std::uint64_t>(endStep, 1));
  return std::clamp(f, 0.0, 1.0);
}

double RunEnd::stepsLeft(double time, std::uint64_t steps, double dt) const {
  return byTime ? std::max(0.0, endTime - time) / dt : double(endStep > steps ? endStep - steps : 0);
}

double RunEnd::every(std::uint64_t n) const {
  // On a step clock the interval may be fractional: record k falls on the
  // first step at or after k span / n, so n intervals cover the span (a
  // whole-step interval rounded down would make more: 300 steps in 80
  // frames at every 3 steps made 100).
  const double v = n > 0 ? span / double(n) : 0.0;
  return byTime || v <= 0.0 ? v : std::max(1.0, v);
}

template <int D>
RunEnd runEnd(const SceneDef<D>& scene, const RunOptions& options, const dynamics::World<D>& world) {
  RunEnd e;
  e.byTime = scene.duration > 0.0 && !options.steps;
  if (options.steps) {
    e.endStep = world.steps() + *options.steps;
  } else if (!e.byTime) {
    e.endStep = scene.steps;
  }
  e.endTime = scene.duration;
  e.span = e.byTime ? scene.duration : double(options.steps ? e.endStep : scene.steps);
  return e;
}

namespace {
// An input error at the scene's key `key` (its line where the reader kept it).
template <int D>
InputError keyError(const SceneDef<D>& scene, const std::string& key, const std::string& what) {
  const auto line = scene.keyLines.find(key);
  return InputError(scene.file, line != scene.keyLines.end() ? line->second : 0, key, what);
}
}  // namespace

template <int D>
void checkGlobalDamping(const SceneDef<D>& scene, const dynamics::World<D>& world) {
  // Global damping is a force -C_g m v of the step's start: past C_g dt = 1 a
  // step more than stops the motion it damps, past 2 it makes energy (the
  // kinetic energy grew to 1e177 J at C_g dt = 2.7). The step only shrinks
  // during a run, so its start (or a resume's) is where C_g dt is largest.
  const double dt = world.dt();
  if (!scene.world.globalDamping || !(dt > 0.0) || *scene.world.globalDamping * dt < 1.0) return;
  throw keyError(scene, "effects.global_damping",
                 "global_damping = " + numberText(*scene.world.globalDamping) + " 1/s times the time step (" +
                     roughText(dt) + " s) is " + roughText(*scene.world.globalDamping * dt) +
                     ": it must stay below 1 (an explicit damping force that strong reverses the velocities it "
                     "damps, and past 2 makes energy); lower it");
}

template <int D>
void checkToolPoses(const SceneDef<D>& scene, const dynamics::World<D>& world) {
  const auto& saved = world.savedToolPoses();
  const auto& now = world.toolPoses();
  for (std::size_t k = 0; k < saved.size() && k < now.size(); ++k) {
    // How far a point of the tool moves from the saved pose to this one, at
    // most: the origin's move and the turn over the tool's reach from it
    // (its node tree's root sphere, about the body frame's origin).
    const geometry::Shape<D>& shape = *world.tools()[k].shape;
    const auto& root = shape.nodeTree().cells;
    const double reach = root.empty() ? shape.boundingRadius() : root[0].centre.norm() + root[0].radius;
    const geometry::Mat<D> turn =
        dynamics::Rotation<D>::matrix(now[k].orientation) - dynamics::Rotation<D>::matrix(saved[k].orientation);
    const double moved = (now[k].position - saved[k].position).norm() + turn.norm() * reach;
    // (Far below any contact overlap; the same motion gives the same pose bit for bit.)
    if (!(moved > 1e-9 * (reach + now[k].position.norm()))) continue;
    const std::string key = "tools[" + std::to_string(k) + "]";
    throw keyError(scene, scene.keyLines.count(key + ".motion") ? key + ".motion" : key,
                   "puts tool '" + world.tools()[k].name + "' up to " + roughText(moved) +
                       " m from where the run had it at the checkpoint (t = " + numberText(world.time()) +
                       " s): a resumed run's tools must follow the run's path up to the checkpoint, or the tool "
                       "would jump into the grains (a motion may change after it: key frames added from a frame "
                       "at that time holding the tool's pose there; a frame added after a resting tool moves it "
                       "at the checkpoint already)");
  }
}

template <int D>
void checkRunLimits(const SceneDef<D>& scene, const RunOptions& options, const dynamics::World<D>& world,
                    const RunEnd& end, double initialMass) {
  const auto refuse = [&](const std::string& key, const std::string& what) { throw keyError(scene, key, what); };
  const auto num = [](double v) { return numberText(v); };
  const double dt = world.dt();
  if (!(dt > 0.0)) return;
  if (end.byTime && scene.duration < dt) {
    refuse("simulation.duration",
           "duration = " + num(scene.duration) + " s is shorter than one time step (dt = " + num(dt) + " s)");
  }
  if (!options.steps) {
    const double steps = end.byTime ? scene.duration / dt : double(scene.steps);
    if (steps > kMaxSteps) {
      refuse(end.byTime ? "simulation.duration" : "simulation.steps",
             "needs " + num(std::ceil(steps)) + " steps (dt = " + num(dt) +
                 " s), over the limit of 1e9 per run; run it in parts with --steps and --resume");
    }
  }
  if (scene.output.checkpointEvery > 0.0 && scene.output.checkpointEvery < dt) {
    refuse("output.checkpoint_every", "checkpoint_every = " + num(scene.output.checkpointEvery) +
                                          " s is shorter than one time step (dt = " + num(dt) + " s)");
  }
  // Speeds: free fall over the run, initial velocities, moving planes.
  const double seconds = end.byTime ? end.span : end.span * dt;
  const double mass = std::max(initialMass, 1.0);
  const auto check = [&](const std::string& key, double speed, const std::string& what) {
    if (!(0.5 * mass * speed * speed <= kMaxEnergyScale) || !(speed * seconds <= kMaxEnergyScale)) {
      refuse(key, what + " reaches " + num(speed) + " m/s over the run: beyond what double precision can carry");
    }
  };
  if (scene.world.gravity) check("effects.gravity", scene.world.gravity->stableNorm() * seconds, "free fall");
  for (std::size_t g = 0; g < scene.groups.size(); ++g) {
    check("particles[" + std::to_string(g) + "].velocity", scene.groups[g].velocity.stableNorm(), "the velocity");
  }
  for (std::size_t k = 0; k < scene.planes.size(); ++k) {
    check("planes[" + std::to_string(k) + "].velocity", scene.planes[k].plane.velocity.stableNorm(), "the velocity");
  }
}

template <int D>
Schedule checkpointSchedule(const SceneDef<D>& scene, const RunEnd& end, const dynamics::World<D>& world) {
  const double every = scene.output.checkpointEvery;
  if (!(every > 0.0)) return {};
  return everySeconds(every, end, world.dt(), 1.0);
}

template <int D>
std::vector<std::unique_ptr<Recorder<D>>> makeRecorders(const RunContext<D>& context, const RunEnd& end) {
  const OutputDef& o = context.scene.output;
  std::vector<std::unique_ptr<Recorder<D>>> r;
  r.push_back(std::make_unique<RemovedLog<D>>(context));
  r.push_back(std::make_unique<BreakageLogRecorder<D>>(context));
  r.push_back(std::make_unique<HistoryRecorder<D>>(Schedule::every(end.every(o.historyRows)), context));
  const Schedule frames = o.frames > 0 ? Schedule::every(end.every(o.frames)) : Schedule();
  if (o.frames > 0) r.push_back(std::make_unique<FrameRecorder<D>>(frames, context));
  r.push_back(std::make_unique<DistributionRecorder<D>>(
      o.distributionTimes.empty() ? Schedule::every(end.every(o.distributions > 1 ? o.distributions - 1 : 0))
                                  : Schedule::at(o.distributionTimes),
      context));
  if (!o.track.empty()) {
    r.push_back(std::make_unique<TrackRecorder<D>>(
        o.trackEvery > 0.0 ? everySeconds(o.trackEvery, end, context.sw.world->dt(), 0.0) : Schedule::everyStep(),
        context));
  }
  r.push_back(std::make_unique<SummaryRecorder<D>>(frames, context));
  return r;
}

#define LSDEM_RUN_PLAN(D)                                                                                          \
  template RunEnd runEnd<D>(const SceneDef<D>&, const RunOptions&, const dynamics::World<D>&);                     \
  template void checkGlobalDamping<D>(const SceneDef<D>&, const dynamics::World<D>&);                               \
  template void checkToolPoses<D>(const SceneDef<D>&, const dynamics::World<D>&);                                   \
  template void checkRunLimits<D>(const SceneDef<D>&, const RunOptions&, const dynamics::World<D>&, const RunEnd&, \
                                  double);                                                                         \
  template Schedule checkpointSchedule<D>(const SceneDef<D>&, const RunEnd&, const dynamics::World<D>&);           \
  template std::vector<std::unique_ptr<Recorder<D>>> makeRecorders<D>(const RunContext<D>&, const RunEnd&);
LSDEM_RUN_PLAN(2)
LSDEM_RUN_PLAN(3)
#undef LSDEM_RUN_PLAN

}  // namespace lsdem::io
