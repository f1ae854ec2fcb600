/// @file Run.cpp
/// @brief The run loop of `lsdem run` (Run.h, docs/outputs.md): the world
/// and recorders assembled from the scene (run/RunPlan.h), the steps, the
/// checkpoints and resume, the stop flag and progress.

#include "lsdem/io/Run.h"

#include "lsdem/breakage/Breakage.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/Scene.h"
#include "lsdem/io/Vtk.h"

#include "OutputFolder.h"
#include "NumberText.h"
#include "OutputNames.h"
#include "run/Checkpoint.h"
#include "run/FrameRecorder.h"
#include "run/RunPlan.h"
#include "run/Specimen.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <map>
#include <optional>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

namespace lsdem::io {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The checkpoint's section of the run's own state (its end, its wall time).
constexpr const char* kRunSection = "run";

// Whether this process writes the run's outputs: a one-process run does; a
// distributed run's engine says which process does.
bool writesOutputs(const RunOptions& options) { return !options.engine || options.engine->writesOutputs; }

// What a world's state says of a run that failed in a step: the particle
// with a non-finite position or velocity, else the one that moves farthest
// per step against its own bounding radius where that exceeds the radius
// (no contact law holds such a step: the simulation diverged); "" when
// neither.
template <int D>
std::string divergenceNote(const dynamics::World<D>& w) {
  const dynamics::Particles<D>& p = w.particles();
  std::size_t worst = p.size();
  double worstRatio = 1.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!p.position[i].allFinite() || !p.velocity[i].allFinite()) {
      return "the simulation diverged: particle " + std::to_string(p.id[i]) + " has a non-finite position or velocity";
    }
    const double ratio = p.velocity[i].norm() * w.dt() / p.shape[i]->boundingRadius();
    if (ratio > worstRatio) {
      worstRatio = ratio;
      worst = i;
    }
  }
  if (worst == p.size()) return "";
  return "the simulation diverged: particle " + std::to_string(p.id[worst]) + " moves " + roughText(worstRatio) +
         " times its bounding radius in one step (speed " + roughText(p.velocity[worst].norm()) + " m/s, dt = " +
         roughText(w.dt()) + " s): the time step is too long for the contact stiffness or for the speeds";
}

template <int D>
class Runner {
 public:
  Runner(SceneDef<D> scene, std::string sceneText, const RunOptions& options, const fs::path& out,
         std::unique_ptr<OutputLock> lock)
      : scene_(std::move(scene)), sceneText_(std::move(sceneText)), options_(options), lock_(std::move(lock)),
        context_{scene_, sw_, out, {}, Clock::now(), false, options.note, {}, {}, 0.0} {}

  // `forcedNote`: a forced resume's note, said once the run's own checks
  // have passed (not before a refusal).
  RunResult run(bool resume, const std::string& forcedNote) {
    if (options_.check) {
      scene_.world.checkFinite = true;
      scene_.world.energyLedger = true;  // the splits' energy check measures against the run's energy scale
    }
    // A distributed run: the process that writes the outputs steps a world of
    // its own (part_) and records from sw_, the view of the whole run; the
    // others step sw_.
    const RunEngineFactory* engine = options_.engine.get();
    writes_ = writesOutputs(options_);
    if (engine && writes_) {
      part_ = buildWorld(scene_);
      // The view takes the part's particles as they are (placing them can be
      // a scene's slow part: grains remeshed one by one).
      sw_ = buildWorld(viewScene());
      const dynamics::Particles<D>& p = part_.world->particles();
      for (std::size_t i = 0; i < p.size(); ++i) sw_.world->addParticle(p.definition(i));
      sw_.initialMass = part_.initialMass;
    } else {
      sw_ = buildWorld(scene_);
    }
    if (options_.check && stepped().breakage) stepped().breakage->setSplitEnergyLimit(options_.splitEnergyLimit);
    World& world = *stepped().world;
    // Everything is read and checked before any output changes.
    std::string runState;
    if (resume) {
      // (A distributed run's view too, from the same read of the file.)
      std::vector<World*> worlds{&world};
      if (&world != sw_.world.get()) worlds.push_back(sw_.world.get());
      runState = loadCheckpoint<D>(checkpointFile(), worlds);
    } else {
      context_.basis.initialMass = sw_.initialMass;
      if (scene_.specimen) context_.basis.specimenHeight = specimenHeight(*scene_.specimen, world);
    }
    end_ = runEnd(scene_, options_, world);
    // The run's own end, which its checkpoints keep: a new run's (the
    // scene's, or where its `--steps` put it); a resumed run's, the
    // checkpoint's (a resume's `--steps` sets this process's end only).
    runEnd_ = end_;
    outputEnd_.reset();
    SavedRun saved;
    if (resume) {
      saved = readRunState(runState);
      context_.basis = saved.basis;
      context_.wallBefore = saved.wallSeconds;
      // Resumed without --steps, the run ends at its own end, as it would
      // have run on (a forced resume, or a checkpoint of an earlier
      // release, takes the scene's end as it is now, if the outputs are
      // counted on the same clock: the checkpoint's schedules hold seconds
      // or steps).
      RunOptions sceneEnd = options_;
      sceneEnd.steps.reset();
      runEnd_ = saved.end && !options_.force ? *saved.end : runEnd(scene_, sceneEnd, world);
      if (saved.end && options_.force && !options_.steps && saved.end->byTime != runEnd_.byTime) {
        // (How far the scene's end is, in steps: at the current step for a
        // duration, which a step that changes would move.)
        const double left = runEnd_.byTime ? std::ceil((runEnd_.endTime - world.time()) / world.dt())
                                           : double(runEnd_.endStep) - double(world.steps());
        const std::string away =
            left > 0.0 ? "; the scene's end is " + std::string(runEnd_.byTime ? "about " : "") + numberText(left) +
                             " steps away" + (runEnd_.byTime ? " at dt = " + roughText(world.dt()) + " s" : "")
                       : "; the run is past the scene's end";
        throw InputError(checkpointFile().string(), 0, "",
                         std::string("the run's outputs are scheduled in ") + (saved.end->byTime ? "seconds" : "steps") +
                             " and the scene's end is in " + (runEnd_.byTime ? "seconds" : "steps") +
                             ": resume it with --steps N (N more steps)" + away);
      }
      if (options_.steps && saved.end && saved.end->byTime != runEnd_.byTime) {
        // Forced with --steps across clocks: the run keeps its own end and
        // clock, on which its outputs are scheduled (the scene's end, on the
        // other clock, saved as the run's, made the next resume read the
        // outputs' positions on the wrong clock).
        runEnd_ = *saved.end;
      } else if (options_.steps && !saved.end) {
        // (A checkpoint of an earlier release: its schedules are taken on
        // this process's clock, as that release took them.)
        outputEnd_ = end_;
      }
      if (!options_.steps) end_ = runEnd_;
      if (end_.finished(world.time(), world.steps()) && !saved.lastRecordsMissing) {
        // Nothing to run: nothing is written.
        RunResult r = result(false);
        r.alreadyFinished = true;
        r.nothingWritten = true;
        return r;
      }
    }
    if (!resume) checkRunLimits(scene_, options_, world, end_, sw_.initialMass);
    checkGlobalDamping(scene_, world);
    if (resume) checkToolPoses(scene_, world);
    // The outputs' schedules are the run's own (a resume's --steps moves
    // this process's end, not the instants the run records).
    checkpoints_ = checkpointSchedule(scene_, outputEnd(), world);
    // (Every process keeps the schedules; only the one that writes records.)
    recorders_ = makeRecorders(context_, outputEnd());
    // A distributed run's frames in per-rank pieces: every process writes its piece.
    if (engine && scene_.output.framePiecesPerRank) {
      for (auto& r : recorders_) {
        if (auto* f = dynamic_cast<FrameRecorder<D>*>(r.get())) frames_ = f;
      }
      if (frames_) frames_->usePieces(engine->ranks);
    }
    if (resume) loadRunState(saved);
    // Stopped while the scene was set up (placing and remeshing grains can
    // take a while): nothing has been written, and nothing is.
    if (options_.stop && options_.stop->load() && !engine) {
      RunResult r = result(true);
      r.nothingWritten = true;
      return r;
    }
    if (engine) engine_ = makeEngine(*engine);
    if (writes_) {
      claimOutputFolder(resume);
      // The copy of the scene the run read: its identity for a resume (a
      // forced resume with another scene replaces it).
      // (Not rewritten when it holds the text already: a user's own file
      // of the same scene, or a link to it, stays as it is.)
      if (readWholeFile((context_.out / "scene.toml").string(), false) != sceneText_) {
        writeFileAtomically(context_.out / "scene.toml", sceneText_);
      }
    }
    if (resume) {
      if (writes_) {
        for (auto& r : recorders_) r->reopen();
      }
      if (!forcedNote.empty() && options_.note) options_.note(forcedNote);
    } else {
      // The first instant of a new run (a resumed run has it already), with
      // its contacts: the first step would evaluate them first anyway. (A
      // failure, of the contacts or a write, stops the run as a failed step
      // does, "after step 0": the summary records the error.)
      orFail([&] {
        world.refreshContacts();
        updateView();
        if (writes_) {
          for (auto& r : recorders_) r->create();
        }
        writeFramePieces(true);
        if (writes_) {
          for (auto& r : recorders_) r->record(*sw_.world, now());
        }
      });
      advanceSchedules();
    }

    // The steps; a step (or a record of it) that fails ends the run here (failed()).
    const bool stopped = orFail([&] { return stepToEnd(world); });

    // The end (or an early stop): the checkpoint and every recorder's last
    // record, the summary the last of them. The checkpoint's outputs' state
    // is taken before those records, so that a resumed run drops them (they
    // are not on any schedule). A run that stops short of its own end (a
    // signal, a resume's --steps) writes the checkpoint first, as its way
    // on. A run at its own end writes it after them, saying whether they
    // were all written: a resume of one whose last writes failed makes them
    // again (it said "already at its end" and wrote nothing). (A write that
    // fails here stops the run as a failed step does: the summary records
    // the error.)
    orFail([&] {
      updateView();
      const bool atOwnEnd = writes_ && !stopped && atRunEnd();
      if (!atOwnEnd) writeCheckpoint();
      const std::string done = atOwnEnd ? checkpointState(false) : std::string();
      const std::string missing = atOwnEnd ? checkpointState(true) : std::string();
      context_.stopped = stopped;
      try {
        if (frames_) writeFramePieces(frames_->recordsAtFinish(now()));
        if (writes_) {
          for (auto& r : recorders_) r->finish(*sw_.world, now());
        }
      } catch (const std::exception&) {
        if (atOwnEnd) {
          try {
            writeRunState(missing);
          } catch (const std::exception&) {
            // (Not written either, as on a full disk: the last periodic
            // checkpoint stays the way on; the error below says what failed.)
          }
        }
        throw;
      }
      if (atOwnEnd) writeRunState(done);
    });
    if (writes_ && options_.progress) report(double(world.steps()) / std::max(context_.wallSeconds(), 1e-9), true);

    return result(stopped);
  }

 private:
  using World = dynamics::World<D>;

  // The steps to the end, or to a stop (true). The loop: one step, then
  // the records due, then a checkpoint if due. The schedules move past this
  // step before the checkpoint saves them: a run resumed from it (after a
  // kill) serves the next instants, as this run does.
  bool stepToEnd(World& world) {
    Clock::time_point lastReport = Clock::now();
    std::uint64_t stepsAtReport = world.steps();
    while (!end_.finished(world.time(), world.steps())) {
      bool stop = options_.stop && options_.stop->load();
      if (engine_) stop = engine_->anyStop(stop);
      if (stop) return true;
      if (engine_) {
        engine_->step();
      } else {
        world.step();
      }
      const Instant t = now();
      const bool checkpoint = checkpoints_.due(t);
      // A distributed run's view is brought up to date when a record needs
      // it: not for the removal and breakage logs (due every step) while the
      // particle set has not changed since the last view.
      const bool changed = engine_ && engine_->particleSetChanges() != changesAtView_;
      bool due = checkpoint;
      for (auto& r : recorders_) {
        due = due || (r->schedule().due(t) && (!engine_ || !r->recordsChangesOnly() || changed));
      }
      if (due) updateView();
      // (Every process keeps the schedules: they agree.)
      if (frames_ && frames_->schedule().due(t)) writeFramePieces(true);
      if (writes_) {
        for (auto& r : recorders_) {
          if (r->schedule().due(t)) r->record(*sw_.world, t);
        }
      }
      advanceSchedules();
      // (One due at the run's own end is written after its last records:
      // see run().)
      if (checkpoint && !atRunEnd()) writeCheckpoint();
      if (writes_ && options_.progress && secondsSince(lastReport) >= scene_.output.progressSeconds) {
        report(double(world.steps() - stepsAtReport) / secondsSince(lastReport), false);
        lastReport = Clock::now();
        stepsAtReport = world.steps();
      }
    }
    return false;
  }

  // The run's result as the view holds it. (A process of a distributed run
  // that does not write the outputs reports its own part.)
  RunResult result(bool stopped) const {
    const World& view = *sw_.world;
    RunResult r;
    r.outDir = context_.out.string();
    r.dimension = D;
    r.steps = view.steps();
    r.time = view.time();
    r.wallSeconds = context_.wallSeconds();
    r.stopped = stopped;
    r.particles = view.particles().size();
    r.breakages = sw_.breakage ? sw_.breakage->breakages() : 0;
    r.massIn = context_.massIn();
    r.massOut = view.particleMass() + view.removedMass();
    r.massBalanceError = r.massIn > 0.0 ? (r.massOut - r.massIn) / r.massIn : 0.0;
    return r;
  }
  // f(), whose error (but an input error, which is the user's to fix and
  // says where) ends the run as a failed step does (failed()).
  template <class F>
  decltype(auto) orFail(F&& f) {
    try {
      return f();
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      failed(e);
    }
  }
  // A step (or a record of it) that failed: the error says where, and what
  // the state says (divergenceNote); the summary records it (stopped early,
  // with the error) from the state as it is. The outputs keep what was
  // written; the checkpoint stays the last one written, of a sound state.
  [[noreturn]] void failed(const std::exception& e) {
    std::string what = e.what();
    // (An error that already says the run diverged is left as it is.)
    if (what.find("diverged") == std::string::npos) {
      const std::string note = divergenceNote(*stepped().world);
      if (!note.empty()) what = note + " (the step failed: " + what + ")";
    }
    stopWith(where() + what);
  }
  // Where the run is, as a failure's message begins: the world's count is
  // that of the steps it finished, so a failure inside a step comes after
  // the last of them, as does one in their records.
  std::string where() const {
    const World& w = *stepped().world;
    return "after step " + std::to_string(w.steps()) + " (t = " + roughText(w.time()) + " s): ";
  }
  // Ends the run with `message`: the summary records it (stopped early,
  // with the error) from the state as it is, then it is thrown.
  [[noreturn]] void stopWith(const std::string& message) {
    if (writes_) {
      context_.stopped = true;
      context_.failure = message;
      try {
        recorders_.back()->record(*sw_.world, now());
      } catch (const std::exception&) {
        // (The summary could not be written: the error below still says what failed.)
      }
    }
    throw std::runtime_error(message);
  }
  static double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
  fs::path checkpointFile() const { return context_.out / outputs::kCheckpoint; }
  // The world this process steps.
  SceneWorld<D>& stepped() { return part_.world ? part_ : sw_; }
  const SceneWorld<D>& stepped() const { return part_.world ? part_ : sw_; }
  // Whether the run is at its own end (not only this process's).
  bool atRunEnd() const { return runEnd_.finished(stepped().world->time(), stepped().world->steps()); }
  // The instant on the run's own clock, the outputs' schedules' (a resume's
  // --steps counts this process's end in steps, whatever that clock).
  Instant now() const { return outputEnd().now(stepped().world->time(), stepped().world->steps()); }
  // The end the outputs' schedules are spread over, on their clock: the
  // run's own, but where a resume set another (outputEnd_).
  const RunEnd& outputEnd() const { return outputEnd_ ? *outputEnd_ : runEnd_; }
  // The scene of a distributed run's view, without its particles (the view
  // takes the part's). Its energy ledger is the sum of the parts'
  // (DistributedWorld::updateView).
  SceneDef<D> viewScene() const {
    SceneDef<D> s = scene_;
    // (Its particles are the run's; a feed stays, as the effect whose state the view shows.)
    std::erase_if(s.groups, [](const ParticleGroupDef<D>& g) { return g.placement != Placement::Feed; });
    s.world.checkFinite = false;
    return s;
  }
  std::unique_ptr<RunEngine<D>> makeEngine(const RunEngineFactory& factory) {
    const auto& make = [&]() -> const auto& {
      if constexpr (D == 2) {
        return factory.make2;
      } else {
        return factory.make3;
      }
    }();
    if (!make) throw std::logic_error("a distributed run's engine for " + std::to_string(D) + "D is missing");
    return make(stepped(), scene_.parallel);
  }
  // A distributed run: the view of the whole run brought up to now (collective).
  void updateView() {
    if (!engine_) return;
    changesAtView_ = engine_->particleSetChanges();
    engine_->updateView(sw_);
    context_.ranks = engine_->ranksSummary();
  }
  // A distributed run whose frames are per-rank pieces, when the writing
  // process writes a frame now (`due` there): every process writes its piece
  // of the world it steps first (collective: every process calls it when a
  // frame may be due). Without pieces: nothing.
  void writeFramePieces(bool due) {
    if (!frames_) return;
    constexpr std::uint64_t kNone = ~std::uint64_t(0);
    const std::uint64_t number = engine_->fromWriter(writes_ && due ? frames_->nextFrame() : kNone);
    if (number == kNone) return;
    std::exception_ptr failed;
    try {
      frames_->writePiece(*stepped().world, number, options_.engine->rank);
    } catch (...) {
      failed = std::current_exception();
    }
    // The frame's index names every piece: written once they all are, and
    // never when one is missing (every process stops alike).
    if (engine_->any(failed != nullptr)) {
      if (failed) std::rethrow_exception(failed);
      throw std::runtime_error("frame " + std::to_string(number) + ": another process could not write its piece");
    }
  }
  void advanceSchedules() {
    const Instant t = now();
    for (auto& r : recorders_) r->schedule().advance(t);
    checkpoints_.advance(t);
  }

  // The folder is created and locked; a new run refuses another run's
  // outputs in it, or removes them with `overwrite`.
  void claimOutputFolder(bool resume) {
    std::error_code ec;
    fs::create_directories(context_.out, ec);
    if (ec) throw std::runtime_error("cannot create the output folder " + context_.out.string() + ": " + ec.message());
    if (!lock_) lock_ = std::make_unique<OutputLock>(context_.out);
    if (resume) return;
    checkOutputFolder(context_.out, options_.overwrite, sceneText_);
    removeRunOutputs(context_.out);
  }

  // A periodic checkpoint, and the summary brought up to date with it.
  void writeCheckpoint() {
    if (!writes_) return;
    writeRunState(checkpointState(false));
    recorders_.back()->record(*sw_.world, now());  // the summary stays current with the checkpoints
  }
  // The checkpoint of the world now with the run's state `state` (checkpointState).
  void writeRunState(const std::string& state) {
    io::writeCheckpoint<D>(checkpointFile(), scene_.file, sceneHash(sceneText_), *sw_.world, state);
  }
  // The run's state: its basis, the checkpoints' schedule, and one section
  // per recorder (by name), each as the recorder saved it; the run's own
  // section says whether the last records of the run's end are missing
  // (`lastRecordsMissing`: written at the end, they failed).
  std::string checkpointState(bool lastRecordsMissing) {
    dynamics::StateWriter s;
    s.putTag("run");
    s.put(context_.basis.initialMass);
    s.put(context_.basis.specimenHeight);
    checkpoints_.save(s);
    s.put(std::uint64_t(recorders_.size() + 1));
    for (auto& r : recorders_) {
      dynamics::StateWriter section;
      r->save(section);
      s.putString(r->name());
      s.putVector(section.bytes());
    }
    // The run's end and the wall seconds so far (readRunState; checkpoints
    // of earlier releases have no such section).
    dynamics::StateWriter run;
    run.put(std::uint8_t(runEnd_.byTime));
    run.put(runEnd_.endTime);
    run.put(runEnd_.endStep);
    run.put(runEnd_.span);
    run.put(context_.wallSeconds());
    run.put(std::uint8_t(lastRecordsMissing));
    s.putString(kRunSection);
    s.putVector(run.bytes());
    return std::string(s.bytes().begin(), s.bytes().end());
  }

  // A checkpoint's run state (writeCheckpoint), read whole.
  struct SavedRun {
    RunBasis basis;
    Schedule schedule;  // the checkpoints' schedule's position (Schedule::continueFrom)
    std::map<std::string, std::vector<char>> sections;
    std::optional<RunEnd> end;  // absent in checkpoints of earlier releases
    double wallSeconds = 0.0;
    bool lastRecordsMissing = false;  // at the run's end, its last records failed (checkpointState)
  };
  SavedRun readRunState(const std::string& bytes) const {
    SavedRun saved;
    asCheckpointError(checkpointFile().string(), [&] {
      dynamics::StateReader s(bytes.data(), bytes.size());
      s.expectTag("run");
      saved.basis.initialMass = s.get<double>();
      saved.basis.specimenHeight = s.get<double>();
      saved.schedule.load(s);
      for (std::uint64_t k = s.get<std::uint64_t>(); k > 0; --k) {
        const std::string name = s.getString();
        s.getVector(saved.sections[name]);
      }
      const auto run = saved.sections.find(kRunSection);
      if (run != saved.sections.end()) {
        dynamics::StateReader r(run->second.data(), run->second.size());
        RunEnd end;
        end.byTime = r.get<std::uint8_t>() != 0;
        end.endTime = r.get<double>();
        end.endStep = r.get<std::uint64_t>();
        end.span = r.get<double>();
        saved.end = end;
        saved.wallSeconds = r.get<double>();
        // (Checkpoints of earlier releases end here: their runs' records were written.)
        saved.lastRecordsMissing = !r.atEnd() && r.get<std::uint8_t>() != 0;
      }
    });
    return saved;
  }
  void loadRunState(const SavedRun& saved) {
    asCheckpointError(checkpointFile().string(), [&] {
      checkpoints_.continueFrom(saved.schedule);
      for (auto& r : recorders_) {
        const auto it = saved.sections.find(r->name());
        if (it == saved.sections.end()) {
          throw InputError(checkpointFile().string(), 0, "",
                           "holds no state of the " + r->name() +
                               " output, which this scene writes (a forced resume with other [output] keys)");
        }
        dynamics::StateReader section(it->second.data(), it->second.size());
        if (writes_) {
          r->load(section);
        } else {
          r->loadSchedule(section);
        }
      }
    });
  }

  // A distributed run's particles, contacts and breakages are those of the
  // view at the last instant an output was due.
  void report(double rate, bool done) const {
    const World& w = *stepped().world;
    RunProgress p;
    p.steps = w.steps();
    p.time = w.time();
    p.endTime = end_.byTime ? end_.endTime : double(end_.endStep) * w.dt();
    p.fraction = end_.fraction(w.time(), w.steps());
    p.stepsPerSecond = rate;
    p.wallSeconds = context_.wallSeconds();
    // The steps left at the current step and the current rate: the share of
    // the run done so far would mislead after a resume (this process did only
    // part of it) and when the step falls as grains break.
    const double stepsLeft = end_.stepsLeft(w.time(), w.steps(), w.dt());
    p.etaSeconds = rate > 0.0 && std::isfinite(stepsLeft) ? stepsLeft / rate : 0.0;
    p.particles = sw_.world->particles().size();
    p.contacts = sw_.world->contacts().pairContacts().size();
    p.breakages = sw_.breakage ? sw_.breakage->breakages() : 0;
    p.done = done;
    options_.progress(p);
  }

  SceneDef<D> scene_;
  std::string sceneText_;  // the scene file's text as the run read it: its identity in checkpoints
  RunOptions options_;
  std::unique_ptr<OutputLock> lock_;  // held while the run writes into its folder
  SceneWorld<D> sw_;      // the world the outputs read (and, but in a distributed run's writing process, the one stepped)
  SceneWorld<D> part_;    // a distributed run's writing process: the world it steps (its part of the run)
  bool writes_ = true;    // this process writes the outputs
  std::unique_ptr<RunEngine<D>> engine_;  // a distributed run's; null: steps here
  std::uint64_t changesAtView_ = 0;       // engine_->particleSetChanges() at the last view
  FrameRecorder<D>* frames_ = nullptr;    // a distributed run's frames in per-rank pieces (in recorders_)
  RunContext<D> context_;
  RunEnd end_;     // this process's end
  RunEnd runEnd_;  // the run's own end (its checkpoints keep it: checkpointState)
  std::optional<RunEnd> outputEnd_;  // the outputs' schedules' end, where not runEnd_ (outputEnd())
  Schedule checkpoints_;
  std::vector<std::unique_ptr<Recorder<D>>> recorders_;  // the summary last
};

template <int D>
RunResult runOf(SceneDef<D> scene, std::string sceneText, const RunOptions& options, std::unique_ptr<OutputLock> lock,
                const std::string& forcedNote) {
  const std::string out =
      !options.resumeDir.empty() ? options.resumeDir : (!options.outDir.empty() ? options.outDir : scene.output.dir);
  // A folder that exists is claimed before the world is built: another run
  // in it is refused at once.
  if (writesOutputs(options) && !lock && fs::is_directory(out)) {
    lock = std::make_unique<OutputLock>(out);
    checkOutputFolder(out, options.overwrite, sceneText);
  }
#ifdef LSDEM_HAVE_OPENMP
  // The command line's threads are set already (runScene); else the scene's.
  if (options.threads < 0 && scene.threads > 0) omp_set_num_threads(scene.threads);
#endif
  Runner<D> runner(std::move(scene), std::move(sceneText), options, out, std::move(lock));
  return runner.run(!options.resumeDir.empty(), forcedNote);
}

}  // namespace

RunResult runScene(const RunOptions& options) {
  // A resumed run holds its folder from the start: no other run may write
  // its checkpoint while it is read.
  std::unique_ptr<OutputLock> lock;
  if (writesOutputs(options) && !options.resumeDir.empty() && fs::is_directory(options.resumeDir)) {
    lock = std::make_unique<OutputLock>(options.resumeDir);
  }
  std::string forcedNote;
  const std::string scenePath = options.resumeDir.empty() ? options.scene : resumeScene(options, &forcedNote);
#ifdef LSDEM_HAVE_OPENMP
  // The threads asked for on the command line apply to building the shapes
  // (reading the scene) as well; the scene's own `threads` once it is read.
  if (options.threads > 0) omp_set_num_threads(options.threads);
#endif
  AnySceneDef scene = readScene(scenePath);
  std::string text = readWholeFile(scenePath);
  if (options.note) std::visit([&](const auto& s) { for (const std::string& n : s.notes) options.note(n); }, scene);
  if (auto* s2 = std::get_if<SceneDef<2>>(&scene)) {
    return runOf<2>(std::move(*s2), std::move(text), options, std::move(lock), forcedNote);
  }
  return runOf<3>(std::move(std::get<SceneDef<3>>(scene)), std::move(text), options, std::move(lock), forcedNote);
}

}  // namespace lsdem::io
