/// @file BenchAccuracyCommand.cpp
/// @brief `lsdem bench accuracy [--dim 2|3] [--quick] [--out DIR]`: runs the
/// accuracy-versus-cost study (lsdem/study/Accuracy.h), prints one progress
/// line per setting (its CPU time by stage) and the Pareto front, and writes
/// DIR/accuracy.csv, DIR/accuracy.md and the PNG plots (docs/accuracy.md).
/// With `--breakage [--dim 2|3] [--seeds N] [--jobs N]`: the breakage study
/// (lsdem/study/BreakageAccuracy.h; 2D unless --dim 3 asks for the 3D single
/// grain), whose runs are this program's `lsdem run` in child processes; it
/// writes DIR/breakage_accuracy.{csv,md}, the runs and the PSD error plots
/// (docs/accuracy.md "Breakage outcomes").

#include "Commands.h"

#include "lsdem/io/InputError.h"
#include "lsdem/study/Accuracy.h"
#include "lsdem/study/BreakageAccuracy.h"

#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

namespace lsdem::apps {
namespace {

struct AccuracyOptionsCli {
  int dimension = 3;
  bool quick = false;
  std::string out;  // empty: bench-accuracy, or bench-accuracy-breakage with --breakage
  bool breakage = false;
  bool dimensionGiven = false;
  bool breakageOptionGiven = false;  // --seeds, --jobs or --resume
  int seeds = 0;
  int jobs = 2;
  bool resume = false;
};

void runBreakage(const AccuracyOptionsCli& o) {
  // Without --dim the breakage study is the 2D one (its scenes came first);
  // --dim 3 runs the 3D single grain.
  const int dimension = o.dimensionGiven ? o.dimension : 2;
  // The runs are this very program's `lsdem run`.
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("cannot find the lsdem executable (/proc/self/exe): " + ec.message());
  study::BreakageOptions options;
  options.dimension = dimension;
  options.quick = o.quick;
  options.seeds = o.seeds;
  options.jobs = o.jobs;
  options.resume = o.resume;
  options.executable = exe.string();
  options.outDir = o.out.empty() ? (dimension == 3 ? "bench-accuracy-breakage-3d" : "bench-accuracy-breakage") : o.out;
  requireWritableFolder("--out", options.outDir);
  options.progress = [](const std::string& line) { std::cout << "  " << line << '\n' << std::flush; };
  std::cout << "lsdem bench accuracy --breakage: " << dimension << "D, " << (o.quick ? "quick" : "full") << " ladder, "
            << (o.seeds > 0 ? std::to_string(o.seeds) : std::string(o.quick ? "2" : "6")) << " seeds, " << o.jobs
            << " runs at once\n"
            << std::flush;
  const study::BreakageReport report = study::runBreakageStudy(options);
  const study::BreakageFiles files = study::writeBreakageFiles(report, options.outDir);

  // The budgets and the failed runs, then the files.
  std::cout << "\nBudgets (cheapest setting within a fraction of the seed noise):\n";
  for (const study::BreakageBudget& b : report.budgets) {
    std::cout << "  " << b.name << ": ";
    if (!b.reached) {
      std::cout << "not reached\n";
      continue;
    }
    std::cout << study::settingLabel(b.setting) << ", PSD error " << b.psdError << " decades (bound " << b.target
              << "), " << b.cpuSeconds << " s CPU for "
              << (dimension == 3 ? "the 3D single grain" : "the three scenes") << "\n";
  }
  std::size_t failed = 0;
  for (const study::BreakageRun& r : report.runs) failed += r.ok ? 0 : 1;
  std::cout << "wrote " << files.csv << ", " << files.markdown << " and " << files.plots.size() << " plots";
  if (files.plots.empty()) std::cout << " (gnuplot not found, or nothing to plot)";
  std::cout << "; study took " << std::lround(report.wallSeconds) << " s wall, " << std::lround(report.cpuSeconds)
            << " s CPU in " << report.runs.size() << " runs\n";
  if (failed > 0) {
    throw std::runtime_error(std::to_string(failed) + " of the study's runs failed (" + files.runsCsv +
                             " names them; each run's log is in runs/)");
  }
}

void runAccuracy(const AccuracyOptionsCli& o) {
  if (o.breakage) {
    runBreakage(o);
    return;
  }
  if (o.breakageOptionGiven) throw io::InputError("--seeds/--jobs/--resume", 0, "", "only with --breakage");
  const std::string out = o.out.empty() ? "bench-accuracy" : o.out;
  requireWritableFolder("--out", out);
  // The sweep, reporting each setting as it ends.
  study::AccuracyOptions options;
  options.dimension = o.dimension;
  options.quick = o.quick;
  options.progress = [](const std::string& line) { std::cout << "  " << line << '\n' << std::flush; };
  std::cout << "lsdem bench accuracy: " << o.dimension << "D, " << (o.quick ? "quick" : "full") << " sweep\n"
            << std::flush;
  const study::AccuracyReport report = study::runAccuracyStudy(options);

  // The files and the Pareto front.
  const study::AccuracyFiles files = study::writeAccuracyFiles(report, out);
  std::cout << "\nPareto front (cheapest setting reaching each target error):\n"
            << study::paretoText(report.pareto) << '\n';
  std::cout << "wrote " << files.csv << ", " << files.markdown << " and " << files.plots.size() << " plots";
  if (files.plots.empty()) std::cout << " (gnuplot not found, or nothing to plot)";
  std::cout << "; study took " << std::lround(report.wallSeconds) << " s wall, " << std::lround(report.cpuSeconds)
            << " s CPU\n";
}

}  // namespace

void addAccuracyBench(CLI::App& bench) {
  auto opts = std::make_shared<AccuracyOptionsCli>();
  CLI::App* cmd = bench.add_subcommand(
      "accuracy", "accuracy against cost: grid cells, nodes per cell, force formulation, time-step fraction");
  CLI::Option* dim = cmd->add_option("--dim", opts->dimension,
                                     "dimension of the study, 2 or 3 (default 3; with --breakage default 2)")
                         ->check(CLI::IsMember({2, 3}));
  cmd->add_flag("--quick", opts->quick, "short sweep (under two minutes on 2 cores; --breakage: under three)");
  cmd->add_option("--out", opts->out,
                  "output directory (default bench-accuracy, with --breakage bench-accuracy-breakage, "
                  "bench-accuracy-breakage-3d with --dim 3)");
  cmd->add_flag("--breakage", opts->breakage,
                "the breakage study instead: PSD, fragments, fines, shape and peak stress of shipped scenes (three "
                "2D ones; with --dim 3 a 3D single grain) against grid, nodes, force law and re-gridding "
                "(docs/accuracy.md)");
  CLI::Option* seeds =
      cmd->add_option("--seeds", opts->seeds, "--breakage: Weibull seeds per setting (default 2 quick, 6 full)")
          ->check(CLI::Range(1, 64));
  CLI::Option* jobs =
      cmd->add_option("--jobs", opts->jobs, "--breakage: runs at once, each a child process on one thread (default 2)")
          ->check(CLI::Range(1, 64));
  CLI::Option* resume = cmd->add_flag(
      "--resume", opts->resume,
      "--breakage: reuse the finished runs an earlier study left in DIR/runs (same scene text, cost kept)");
  cmd->callback([opts, dim, seeds, jobs, resume] {
    opts->dimensionGiven = dim->count() > 0;
    opts->breakageOptionGiven = seeds->count() + jobs->count() + resume->count() > 0;
    runAccuracy(*opts);
  });
}

}  // namespace lsdem::apps
