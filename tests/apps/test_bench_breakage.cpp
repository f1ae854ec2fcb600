// `lsdem bench accuracy --breakage --quick` end to end, as CI runs it: the
// shipped scenes on the quick ladder through `lsdem run`, the table, the
// report with its budgets, the plots; and its option errors.

#include "support/Files.h"
#include "support/Process.h"
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

namespace fs = std::filesystem;

namespace {

using Result = lsdem::test::ProcessResult;

// `lsdem ARGS`, stdout and stderr together.
Result run(const std::string& args) { return lsdem::test::runShell(std::string(LSDEM_BINARY) + " " + args); }

// The rows of a CSV file as maps from its header's names.
std::vector<std::map<std::string, std::string>> readCsv(const fs::path& path) {
  std::istringstream in(lsdem::test::readFile(path));
  std::vector<std::map<std::string, std::string>> rows;
  std::string line;
  std::vector<std::string> header;
  const auto split = [](const std::string& l) {
    std::vector<std::string> f;
    std::string x;
    std::istringstream s(l);
    while (std::getline(s, x, ',')) f.push_back(x);
    return f;
  };
  if (std::getline(in, line)) header = split(line);
  while (std::getline(in, line)) {
    const auto f = split(line);
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size() && i < f.size(); ++i) row[header[i]] = f[i];
    rows.push_back(row);
  }
  return rows;
}

double num(const std::map<std::string, std::string>& row, const std::string& key) {
  const auto it = row.find(key);
  return it == row.end() || it->second.empty() ? std::nan("") : std::stod(it->second);
}

}  // namespace

TEST(BenchBreakage, QuickStudyWritesItsTableReportAndPlots) {
  const fs::path out = lsdem::test::tempPath("bench_breakage");
  const Result r = run("bench accuracy --breakage --quick --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("fast:"), std::string::npos) << r.output;

  // One row per case and setting: 3 grids, 1 node density, 1 law, 1 re-gridding, 2 seeds each.
  const auto rows = readCsv(out / "breakage_accuracy.csv");
  ASSERT_EQ(rows.size(), 3u * 6u);
  std::map<std::string, int> perCase;
  for (const auto& w : rows) {
    ++perCase[w.at("case")];
    EXPECT_EQ(num(w, "seeds"), 2.0) << w.at("case") << " " << w.at("knob");
    const bool reference = w.at("reference") == "1";
    EXPECT_EQ(reference, w.at("knob") == "cells" && num(w, "cells_across") == 40.0);
    // The reference is its own: error 0; the others measure something.
    if (reference) {
      EXPECT_EQ(num(w, "psd_error"), 0.0);
    } else {
      EXPECT_GE(num(w, "psd_error"), 0.0);
    }
    // Every scene breaks its grains, is loaded, and costs something.
    EXPECT_GT(num(w, "fragments"), 1.0) << w.at("case");
    EXPECT_GT(num(w, "peak_stress_Pa"), 1e3) << w.at("case");
    EXPECT_GT(num(w, "d90_m"), num(w, "d10_m")) << w.at("case");
    EXPECT_GT(num(w, "d50_m"), 1e-5) << w.at("case");
    EXPECT_LT(num(w, "d50_m"), 2e-3) << w.at("case");
    EXPECT_GE(num(w, "fines_percent"), 0.0);
    EXPECT_LT(num(w, "fines_percent"), 100.0);
    EXPECT_GT(num(w, "cpu_seconds"), 0.0);
    EXPECT_GT(num(w, "max_rss_MiB"), 1.0);
  }
  EXPECT_EQ(perCase.size(), 3u);
  // The coarsest grid of the ladder differs from the finest somewhere.
  double coarsest = 0.0;
  for (const auto& w : rows) {
    if (w.at("knob") == "cells" && num(w, "cells_across") == 10.0) coarsest += num(w, "psd_error");
  }
  EXPECT_GT(coarsest, 0.0);

  // 36 runs, all finished, with the same seeds on every setting.
  const auto runs = readCsv(out / "breakage_runs.csv");
  ASSERT_EQ(runs.size(), 36u);
  for (const auto& x : runs) {
    EXPECT_EQ(x.at("ok"), "1") << x.at("error");
    EXPECT_TRUE(x.at("seed") == "101" || x.at("seed") == "102") << x.at("seed");
  }

  // The report with its budgets, and the plots when gnuplot is there.
  const std::string md = lsdem::test::readFile(out / "breakage_accuracy.md");
  for (const char* part : {"## Seed noise", "## Observed orders", "| fast |", "| balanced |", "| publication |"}) {
    EXPECT_NE(md.find(part), std::string::npos) << part;
  }
  if (std::system("command -v gnuplot >/dev/null 2>&1") == 0) {
    EXPECT_TRUE(fs::is_regular_file(out / "psd_error_vs_time.png"));
    EXPECT_TRUE(fs::is_regular_file(out / "psd_error_vs_cells.png"));
  }

  // --resume reads the finished runs again instead of running them: the
  // same table, costs included; a run whose cost file is gone runs again.
  const std::string table = lsdem::test::readFile(out / "breakage_accuracy.csv");
  fs::remove(out / "runs" / "single_grain_c10_n1_pn_r0_s101.cost");
  const Result again = run("bench accuracy --breakage --quick --resume --out " + out.string());
  ASSERT_EQ(again.code, 0) << again.output;
  EXPECT_TRUE(fs::is_regular_file(out / "runs" / "single_grain_c10_n1_pn_r0_s101.cost"));
  const auto rerun = readCsv(out / "breakage_runs.csv");
  ASSERT_EQ(rerun.size(), runs.size());
  for (std::size_t i = 0; i < runs.size(); ++i) {
    if (runs[i].at("case") == "single_grain" && runs[i].at("cells_across") == "10" && runs[i].at("seed") == "101" &&
        runs[i].at("knob") == "cells") {
      continue;  // run again: its CPU time is a new measurement
    }
    EXPECT_EQ(rerun[i].at("cpu_seconds"), runs[i].at("cpu_seconds")) << i;
    EXPECT_EQ(rerun[i].at("psd_error_paired"), runs[i].at("psd_error_paired")) << i;
  }
}

// `--breakage --dim 3 --quick`: the 3D single grain on the quick ladder (10
// and 14 cells, two seeds: four runs of about a second each). Every run
// splits the grain, keeps its mass (pieces + fines = the grain), and the
// table compares the 10-cell grid with the 14-cell reference.
TEST(BenchBreakage, Quick3DLadderCrushesTheGrainAndKeepsItsMass) {
  const fs::path out = lsdem::test::tempPath("bench_breakage_3d");
  fs::remove_all(out);
  const Result r = run("bench accuracy --breakage --dim 3 --quick --jobs 1 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("3D, quick ladder"), std::string::npos) << r.output;

  const auto runs = readCsv(out / "breakage_runs.csv");
  ASSERT_EQ(runs.size(), 4u);
  for (const auto& x : runs) {
    EXPECT_EQ(x.at("case"), "single_grain_3d");
    EXPECT_EQ(x.at("ok"), "1") << x.at("error");
    EXPECT_GE(num(x, "breakages"), 1.0) << x.at("cells_across") << " seed " << x.at("seed");
    EXPECT_GT(num(x, "fragments"), 2.0);
    // Loaded to the grain's strength (35 MPa at 2 mm, about 44 MPa at 1.6 mm; Weibull m = 3).
    EXPECT_GT(num(x, "split_stress_Pa"), 5e6);
    EXPECT_LT(num(x, "split_stress_Pa"), 2e8);
    EXPECT_GE(num(x, "peak_stress_Pa"), num(x, "split_stress_Pa"));
    EXPECT_GT(num(x, "mean_circularity"), 0.3);  // Wadell sphericity of the pieces
    EXPECT_LE(num(x, "mean_circularity"), 1.05);
    EXPECT_LT(num(x, "d50_m"), 1.6e-3);
    EXPECT_GT(num(x, "cpu_seconds"), 0.0);

    // Mass balance of the run: pieces + fines = the grain, to round-off.
    char name[96];
    std::snprintf(name, sizeof name, "single_grain_3d_c%s_n1_pn_r0_s%s", x.at("cells_across").c_str(),
                  x.at("seed").c_str());
    const std::string summary = lsdem::test::readFile(out / "runs" / name / "summary.json");
    const std::size_t block = summary.find("\"mass_balance\":");
    ASSERT_NE(block, std::string::npos) << name;
    const auto value = [&](const std::string& key) {
      const std::size_t at = summary.find("\"" + key + "\":", block);
      EXPECT_NE(at, std::string::npos) << key;
      return at == std::string::npos ? std::nan("") : std::strtod(summary.c_str() + at + key.size() + 3, nullptr);
    };
    const double initial = value("initial"), pieces = value("particles"), removed = value("removed");
    EXPECT_NEAR(initial, 5.25e-6, 0.05e-6) << name;  // 2450 kg/m^3 x 2.14e-9 m^3
    EXPECT_NEAR(pieces + removed, initial, 1e-12 * initial) << name;
    EXPECT_LT(std::abs(value("relative_error")), 1e-12) << name;
    EXPECT_GT(pieces, 0.5 * initial) << name;  // most of the grain stays as pieces
    EXPECT_NEAR(100.0 * removed / initial, num(x, "fines_percent"), 1e-4) << name;
  }

  // One row per grid; the coarse grid differs from the reference.
  const auto rows = readCsv(out / "breakage_accuracy.csv");
  ASSERT_EQ(rows.size(), 2u);
  for (const auto& w : rows) {
    EXPECT_EQ(num(w, "seeds"), 2.0);
    EXPECT_EQ(w.at("reference") == "1", num(w, "cells_across") == 14.0);
    if (num(w, "cells_across") == 10.0) {
      EXPECT_GT(num(w, "psd_error"), 0.0);
    }
  }
  const std::string md = lsdem::test::readFile(out / "breakage_accuracy.md");
  EXPECT_NE(md.find("(3D, quick ladder, 2 seeds)"), std::string::npos) << md.substr(0, 200);
  EXPECT_NE(md.find("| single_grain_3d | psd_l1 |"), std::string::npos);
}

TEST(BenchBreakage, OptionErrorsAreOneLine) {
  for (const char* args : {"bench accuracy --breakage --dim 4", "bench accuracy --seeds 3 --quick",
                           "bench accuracy --resume --quick", "bench accuracy --breakage --jobs 0",
                           "bench accuracy --breakage --dim 3 --seeds 0"}) {
    const Result r = run(args);
    EXPECT_NE(r.code, 0) << args;
    EXPECT_FALSE(r.output.empty()) << args;
  }
  const Result r = run("bench accuracy --seeds 3 --quick");
  EXPECT_NE(r.output.find("only with --breakage"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find('\n'), r.output.size() - 1) << r.output;
}
