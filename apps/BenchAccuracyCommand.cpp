/// @file BenchAccuracyCommand.cpp
/// @brief `lsdem bench accuracy [--dim 2|3] [--quick] [--out DIR]`: runs the
/// accuracy-versus-cost study (lsdem/study/Accuracy.h), prints one progress
/// line per setting (its CPU time by stage) and the Pareto front, and writes
/// DIR/accuracy.csv, DIR/accuracy.md and the PNG plots (docs/accuracy.md).

#include "Commands.h"

#include "lsdem/study/Accuracy.h"

#include <cmath>
#include <iostream>
#include <memory>
#include <string>

namespace lsdem::apps {
namespace {

struct AccuracyOptionsCli {
  int dimension = 3;
  bool quick = false;
  std::string out = "bench-accuracy";
};

void runAccuracy(const AccuracyOptionsCli& o) {
  // The sweep, reporting each setting as it ends.
  study::AccuracyOptions options;
  options.dimension = o.dimension;
  options.quick = o.quick;
  options.progress = [](const std::string& line) { std::cout << "  " << line << '\n' << std::flush; };
  std::cout << "lsdem bench accuracy: " << o.dimension << "D, " << (o.quick ? "quick" : "full") << " sweep\n"
            << std::flush;
  const study::AccuracyReport report = study::runAccuracyStudy(options);

  // The files and the Pareto front.
  const study::AccuracyFiles files = study::writeAccuracyFiles(report, o.out);
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
  cmd->add_option("--dim", opts->dimension, "dimension of the study, 2 or 3 (default 3)")
      ->check(CLI::IsMember({2, 3}));
  cmd->add_flag("--quick", opts->quick, "short sweep (under two minutes on 2 cores)");
  cmd->add_option("--out", opts->out, "output directory (default bench-accuracy)");
  cmd->callback([opts] { runAccuracy(*opts); });
}

}  // namespace lsdem::apps
