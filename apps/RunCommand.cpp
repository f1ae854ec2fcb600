/// @file RunCommand.cpp
/// @brief `lsdem run SCENE.toml [--out DIR] [--overwrite] [--steps N] [--threads N] [--quiet]`
/// and `lsdem run [SCENE.toml] --resume DIR [--force]`: runs a scene (io/Run.h) with a progress line,
/// and stops cleanly on Ctrl-C or SIGTERM (final frame, summary and checkpoint
/// written; exit code 130 or 143, 128 + the signal).

#include "Commands.h"

#include "lsdem/io/Run.h"
#include "lsdem/io/Scene.h"

#ifdef LSDEM_HAVE_MPI
#include "lsdem/parallel/DistributedRun.h"
#endif

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace lsdem::apps {
namespace {

std::atomic<bool> gStop{false};
std::atomic<int> gSignal{0};  // the signal that asked the run to stop

std::atomic<bool> gAnnounce{false};  // say that the run will stop (not with --quiet)

extern "C" void onStopSignal(int signal) {
  gSignal.store(signal);
  gStop.store(true);
  // A second one ends the program at once.
  std::signal(signal, SIG_DFL);
  // (write: the only output a signal handler may make. The set-up of a
  // large scene does not look at the flag, so the run may take a while to
  // stop: it says so at once.)
  if (gAnnounce.load()) {
    static const char kNote[] = "\nlsdem: stopping at the next step (again to quit at once)\n";
    [[maybe_unused]] const auto written = ::write(2, kNote, sizeof(kNote) - 1);
  }
}

std::string duration(double s) {
  char buf[64];
  if (s < 60.0) {
    std::snprintf(buf, sizeof(buf), "%.0f s", s);
  } else if (s < 3600.0) {
    std::snprintf(buf, sizeof(buf), "%d min %02d s", int(s) / 60, int(s) % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%d h %02d min", int(s) / 3600, (int(s) % 3600) / 60);
  }
  return buf;
}

struct RunArgs {
  std::string scene;
  std::string out;
  std::string resume;
  long long steps = -1;
  int threads = -1;
  bool quiet = false;
  bool overwrite = false;
  bool force = false;
  bool check = false;
  double splitEnergyLimit = io::kCheckSplitEnergyLimit;
};

void runCommand(const RunArgs& a) {
  if (a.scene.empty() && a.resume.empty()) throw CLI::ValidationError("lsdem run", "give a scene file, or --resume DIR");
  io::RunOptions o;
  o.scene = a.scene;
  o.outDir = a.out;
  o.resumeDir = a.resume;
  if (a.steps >= 0) o.steps = std::uint64_t(a.steps);
  o.threads = a.threads;
  o.overwrite = a.overwrite;
  o.force = a.force;
  o.check = a.check;
  o.splitEnergyLimit = a.splitEnergyLimit;
  o.stop = &gStop;
  // On several MPI ranks, rank 0 writes the outputs and speaks for the run.
  const bool speaks = mpiRank() == 0;
#ifdef LSDEM_HAVE_MPI
  if (mpiRanks() > 1) o.engine = parallel::distributedRun(MPI_COMM_WORLD);
#endif
  if (speaks) o.note = [](const std::string& line) { std::cerr << "lsdem: note: " << line << '\n'; };
  const bool terminal = isatty(fileno(stderr)) != 0;
  if (!a.quiet && speaks) {
    o.progress = [terminal](const io::RunProgress& p) {
      const char* timeLeft = p.done ? "wall" : "ETA";
      const std::string left = duration(p.done ? p.wallSeconds : p.etaSeconds);
      if (!terminal) {
        // A log (stderr not a terminal): every field, in an order that
        // stays put for the scripts that read it (`step N ... M contacts`).
        char line[256];
        std::snprintf(line, sizeof(line),
                      "step %llu  t = %.4g s (%.1f%%)  %.0f steps/s  %zu particles  %zu contacts  %zu breakages  %s %s",
                      static_cast<unsigned long long>(p.steps), p.time, 100.0 * p.fraction, p.stepsPerSecond,
                      p.particles, p.contacts, p.breakages, timeLeft, left.c_str());
        std::cerr << line << '\n';
        return;
      }
      // Fields in display order, each with its rank (lower: dropped first)
      // so the line fits 80 columns: the least needed go when it would not.
      struct Field {
        std::string text;
        int rank;
      };
      char buf[64];
      std::vector<Field> fields;
      const auto add = [&](int rank, const char* format, auto... values) {
        std::snprintf(buf, sizeof(buf), format, values...);
        fields.push_back({buf, rank});
      };
      add(9, "%5.1f%%", 100.0 * p.fraction);
      add(8, "t %.4g s", p.time);
      add(5, "step %llu", static_cast<unsigned long long>(p.steps));
      add(4, "%.0f/s", p.stepsPerSecond);
      add(6, "%zu particles", p.particles);
      add(2, "%zu contacts", p.contacts);
      add(3, "%zu breakages", p.breakages);
      add(7, "%s %s", timeLeft, left.c_str());
      const auto width = [&] {
        std::size_t w = 0;
        for (const Field& f : fields) w += f.text.size() + (w > 0 ? 2 : 0);
        return w;
      };
      while (width() > 79 && fields.size() > 1) {
        fields.erase(std::min_element(fields.begin(), fields.end(),
                                      [](const Field& x, const Field& y) { return x.rank < y.rank; }));
      }
      std::string line;
      for (const Field& f : fields) line += (line.empty() ? "" : "  ") + f.text;
      std::cerr << '\r' << line << "\033[K" << (p.done ? "\n" : "") << std::flush;
    };
  }
  gStop.store(false);
  gSignal.store(0);
  gAnnounce.store(!a.quiet && speaks);
  std::signal(SIGINT, onStopSignal);
  std::signal(SIGTERM, onStopSignal);
  const io::RunResult r = io::runScene(o);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  if (r.nothingWritten && r.stopped) {
    if (speaks) std::cerr << "lsdem: stopped during the set-up; nothing written\n";
    throw CLI::RuntimeError(128 + (gSignal.load() != 0 ? gSignal.load() : SIGINT));
  }
  if (r.alreadyFinished) {
    // (Said also with --quiet: a script that resumes until done learns it is.)
    if (speaks) {
      std::cerr << "lsdem: " << r.outDir << ": the run is already at its end (step " << r.steps << ", t = " << r.time
                << " s); nothing to resume, nothing written (give --steps N to run N more steps, or --force with "
                   "a scene that ends later)\n";
    }
    return;
  }
  if (!a.quiet && speaks) {
    std::cout << (mpiRanks() > 1 ? "on " + std::to_string(mpiRanks()) + " MPI ranks, " : std::string())
              << (r.stopped ? "stopped" : "finished") << ": " << r.steps << " steps, t = " << r.time << " s, "
              << r.particles << " particles, " << r.breakages << " breakages, mass balance " << r.massBalanceError
              << " (relative), wall " << duration(r.wallSeconds) << "\n"
              << "outputs in " << r.outDir << (r.stopped ? " (continue with: lsdem run --resume " + r.outDir + ")" : "")
              << '\n';
  }
  if (r.stopped) throw CLI::RuntimeError(128 + (gSignal.load() != 0 ? gSignal.load() : SIGINT));
}

}  // namespace

void addRunCommand(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand("run", "run a scene file (docs/scenes.md); outputs in docs/outputs.md");
  cmd->add_option("scene", args->scene, "scene file (TOML)");
  cmd->add_option("--out,-o", args->out, "output folder (default: the scene's [output] dir)");
  cmd->add_option("--steps", args->steps,
                  "run this many steps instead of the scene's duration (with --resume: this many more steps; a "
                  "resumed run without it ends where the run it continues would have)")
      ->check(atLeast<true>(1));
  cmd->add_option("--threads", args->threads, "OpenMP threads (0: all cores; default: the scene's)")
      ->check(atLeast<true>(0, io::kMaxThreads));
  CLI::Option* resume = cmd->add_option(
      "--resume", args->resume,
      "continue the run whose outputs are in DIR from its checkpoint (with the scene given, or the checkpoint's)");
  cmd->add_flag("--overwrite", args->overwrite,
                "replace the outputs of another run in the output folder (without it such a folder is refused)")
      ->excludes(resume);
  cmd->add_flag("--force", args->force,
                "resume even when the scene is not the checkpoint's (edited, or another run's checkpoint)")
      ->needs(resume);
  CLI::Option* check = cmd->add_flag(
      "--check", args->check,
      "stop the run (exit 1) at a NaN or Inf in the state, or at a split that makes energy (docs/reliability.md)");
  cmd->add_option("--split-energy-limit", args->splitEnergyLimit,
                  "with --check: largest energy a split may add, as a fraction of the run's energy scale (default 0.05)")
      ->check(CLI::Validator(
          [](const std::string& text) {
            double v = 0.0;
            try {
              v = std::stod(text);
            } catch (const std::exception&) {
              return std::string("must be a number >= 0, got '") + text + "'";
            }
            return v >= 0.0 && std::isfinite(v) ? std::string() : "must be a finite number >= 0, got " + text;
          },
          "FRACTION >= 0"))
      ->needs(check);
  cmd->add_flag("--quiet,-q", args->quiet, "no progress line and no final report");
  cmd->callback([args] { runCommand(*args); });
}

}  // namespace lsdem::apps
