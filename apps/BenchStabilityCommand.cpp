/// @file BenchStabilityCommand.cpp
/// @brief `lsdem bench stability [--case NAME] [--dim 2|3] [--long] [--out DIR]`:
/// runs the stability cases (lsdem/study/Stability.h), prints a table (case,
/// dim, steps, breakages, energy excess %, mass error, max overlap, min dt,
/// wall time, PASS/FAIL) and writes DIR/stability.csv. Exits non-zero when a
/// case fails.

#include "Commands.h"

#include "lsdem/io/InputError.h"

#include "lsdem/study/Stability.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::apps {
namespace {

struct StabilityOptionsCli {
  std::string caseName;
  int dimension = 0;
  bool isLong = false;
  std::string out = ".";
};

int runStability(const StabilityOptionsCli& o) {
  // Pick the cases.
  std::vector<study::StabilityCase> cases;
  std::string names;
  for (const study::StabilityCase& c : study::stabilityCases()) {
    if (c.dimension == 2) names += (names.empty() ? "" : ", ") + c.name;
    if (!o.caseName.empty() && c.name != o.caseName) continue;
    if (o.dimension != 0 && c.dimension != o.dimension) continue;
    cases.push_back(c);
  }
  if (cases.empty()) {
    throw io::InputError("--case", 0, "", "no stability case named '" + o.caseName + "' (cases: " + names + ")");
  }
  requireWritableFolder("--out", o.out);

  // Run them, one row as each ends.
  std::cout << study::stabilityTableHeader() << '\n' << std::flush;
  std::vector<study::StabilityResult> results;
  bool allPassed = true;
  for (const study::StabilityCase& c : cases) {
    results.push_back(c.run(o.isLong ? study::CaseLength::Long : study::CaseLength::Short));
    const study::StabilityResult& r = results.back();
    std::cout << study::stabilityTableRow(r) << '\n';
    for (const std::string& f : r.failures) std::cout << "    " << f << '\n';
    std::cout << std::flush;
    allPassed = allPassed && r.passed();
  }

  // The CSV.
  std::filesystem::create_directories(o.out);
  const std::filesystem::path path = std::filesystem::path(o.out) / "stability.csv";
  std::ofstream file(path);
  if (!file) throw std::runtime_error("cannot write " + path.string());
  study::writeStabilityCsv(results, file);
  std::cout << "wrote " << path.string() << '\n';
  return allPassed ? 0 : 3;
}

}  // namespace

void addStabilityBench(CLI::App& bench) {
  auto o = std::make_shared<StabilityOptionsCli>();
  CLI::App* cmd = bench.add_subcommand(
      "stability", "hard cases (fragments at the resolution limit, cascades, impacts, ...) checked for stability");
  cmd->add_option("--case", o->caseName, "run only this case (split_limits, cascade, split_in_contact, mass_ratio, "
                                         "tool_crush, impact, grid_edge, settled)");
  cmd->add_option("--dim", o->dimension, "run only this dimension")->check(CLI::IsMember({2, 3}));
  cmd->add_flag("--long", o->isLong, "the long versions (>= 1000-breakage cascades, 10^6-step settled packing)");
  cmd->add_option("--out", o->out, "directory for stability.csv")->capture_default_str();
  cmd->callback([o] {
    const int code = runStability(*o);
    if (code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace lsdem::apps
