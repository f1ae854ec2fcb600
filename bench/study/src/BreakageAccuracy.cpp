/// @file BreakageAccuracy.cpp
/// @brief The breakage accuracy study (BreakageAccuracy.h): the cases and
/// their settings, the runs in child processes, the reading of their outputs,
/// and the distances between size distributions. The summaries (rows, seed
/// noise, orders, budgets) are in BreakageSummary.cpp, the files in
/// BreakageOutput.cpp.

#include "lsdem/study/BreakageAccuracy.h"

#include "lsdem/io/SceneOverride.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace lsdem::study {
namespace {

namespace fs = std::filesystem;

// The shipped scenes, embedded by CMake: {path under apps/scenes, text}.
struct EmbeddedScene {
  const char* path;
  const char* text;
};
constexpr EmbeddedScene kEmbeddedScenes[] = {
#include "lsdem/study/ShippedScenes.inc"
};

std::string embeddedScene(const std::string& path) {
  for (const EmbeddedScene& s : kEmbeddedScenes) {
    if (path == s.path) return s.text;
  }
  throw std::logic_error("the study has no embedded scene " + path);
}

std::string number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

// The ladders, quick or full: the grid ladder, then the other knobs about the baseline.
struct Ladder {
  std::vector<double> cells, nodes, regrid;
  bool areaWeighted = true;
};

Ladder ladder(int dimension, bool quick) {
  Ladder l;
  if (dimension == 3) {
    // The 3D single grain. One run's CPU (one seed, measured before the
    // study): 0.5 s at 10 cells, 1.1 at 14, 4.9 at 20, 7.5 at 28, 31 at 40,
    // 126 at 56 (177 MB); 80 cells would take several minutes a run. Six
    // seeds of this ladder and of the three knobs at 20 cells took 1968 s of
    // CPU on a loaded machine (docs/accuracy.md), under the 40 minutes it
    // was sized for. The quick ladder is CI's smoke test of the 3D case.
    l.cells = quick ? std::vector<double>{10, 14} : std::vector<double>{10, 14, 20, 28, 40, 56};
    l.nodes = quick ? std::vector<double>{} : std::vector<double>{2};
    l.regrid = quick ? std::vector<double>{} : std::vector<double>{10};
    l.areaWeighted = !quick;
    return l;
  }
  l.cells = quick ? std::vector<double>{10, 20, 40} : std::vector<double>{10, 14, 20, 28, 40, 56, 80, 112};
  l.nodes = quick ? std::vector<double>{2} : std::vector<double>{0.5, 2, 3};
  l.regrid = quick ? std::vector<double>{10} : std::vector<double>{10, 20};
  return l;
}

// ---- reading a run's outputs ----

std::string readText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A CSV file as its header and rows of fields.
struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::size_t column(const std::string& name, const fs::path& path) const {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end()) throw std::runtime_error(path.string() + " has no column " + name);
    return std::size_t(it - header.begin());
  }
};

std::vector<std::string> splitCsvLine(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

Csv readCsv(const fs::path& path) {
  std::istringstream in(readText(path));
  Csv csv;
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(path.string() + " is empty");
  csv.header = splitCsvLine(line);
  while (std::getline(in, line)) {
    if (!line.empty()) csv.rows.push_back(splitCsvLine(line));
  }
  return csv;
}

double field(const std::vector<std::string>& row, std::size_t i) {
  if (i >= row.size() || row[i].empty()) return std::nan("");
  return std::strtod(row[i].c_str(), nullptr);
}

// The first number after "key": in the run's summary.json (the writer's
// order puts the top-level keys asked for here before any nested namesake).
double jsonNumber(const std::string& json, const std::string& key, const fs::path& path) {
  const std::string quoted = "\"" + key + "\":";
  const std::size_t at = json.find(quoted);
  if (at == std::string::npos) throw std::runtime_error(path.string() + " has no " + key);
  return std::strtod(json.c_str() + at + quoted.size(), nullptr);
}

// Fills the outcome fields of `run` from the output folder `out`.
void readOutputs(const fs::path& out, BreakageRun& run) {
  // The size distribution at the end: the last snapshot of psd.csv.
  const Csv psd = readCsv(out / "psd.csv");
  const std::size_t ct = psd.column("time_s", out / "psd.csv"), cs = psd.column("sieve_size_m", out / "psd.csv"),
                    cp = psd.column("percent_passing", out / "psd.csv");
  if (psd.rows.empty()) throw std::runtime_error((out / "psd.csv").string() + " has no rows");
  const std::string last = psd.rows.back()[ct];
  for (const auto& row : psd.rows) {
    if (row[ct] != last) continue;
    run.psd.size.push_back(std::max(field(row, cs), kPsdSizeFloor));
    run.psd.passing.push_back(std::clamp(field(row, cp) / 100.0, 0.0, 1.0));
  }
  run.d10 = sizeQuantile(run.psd, 0.1);
  run.d50 = sizeQuantile(run.psd, 0.5);
  run.d90 = sizeQuantile(run.psd, 0.9);

  // Shape statistics at the end.
  const Csv shapes = readCsv(out / "shape_stats.csv");
  if (!shapes.rows.empty()) {
    run.meanCircularity = field(shapes.rows.back(), shapes.column("mean_circularity", out / "shape_stats.csv"));
    run.meanAspectRatio = field(shapes.rows.back(), shapes.column("mean_aspect_ratio", out / "shape_stats.csv"));
  }

  // The peak specimen stress over the run, and the counts at its end.
  const Csv history = readCsv(out / "history.csv");
  const std::size_t cstress = history.column("stress_Pa", out / "history.csv"),
                    cbreak = history.column("breakages", out / "history.csv");
  run.splitStress = std::nan("");
  for (const auto& row : history.rows) {
    const double s = field(row, cstress);
    if (std::isfinite(s)) run.peakStress = std::max(run.peakStress, s);
    // The first row with a split: the stress the specimen carried as it broke
    // (the row's, so within one history interval of the split).
    if (std::isnan(run.splitStress) && field(row, cbreak) > 0.0 && std::isfinite(s)) run.splitStress = s;
  }
  const std::string summary = readText(out / "summary.json");
  run.steps = jsonNumber(summary, "steps", out / "summary.json");
  run.fragments = jsonNumber(summary, "particles", out / "summary.json");
  run.breakages = jsonNumber(summary, "breakages", out / "summary.json");
  run.finesPercent = jsonNumber(summary, "fines_percent", out / "summary.json");
}

// Runs `lsdem run scene --out out --threads 1 --quiet --overwrite` and waits
// for it; its output goes to out.log. Returns the child's exit status.
int runChild(const std::string& exe, const fs::path& scene, const fs::path& out, const fs::path& log,
             BreakageRun& run) {
  std::vector<std::string> args = {exe,         "run", scene.string(), "--out",      out.string(),
                                   "--threads", "1",   "--quiet",      "--overwrite"};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = 0;
  const auto start = std::chrono::steady_clock::now();
  const int rc = posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw std::runtime_error("cannot start " + exe + ": " + std::strerror(rc));
  // Wait, reading the child's peak resident memory (VmHWM of its own image)
  // as it runs: the kernel's ru_maxrss of a child also holds the memory of
  // the process that spawned it, so it cannot tell a small run from its parent.
  const fs::path statusFile = "/proc/" + std::to_string(pid) + "/status";
  int status = 0;
  rusage usage{};
  double peakKiB = 0.0;
  for (;;) {
    const pid_t got = wait4(pid, &status, WNOHANG, &usage);
    if (got == pid) break;
    if (got < 0 && errno != EINTR) throw std::runtime_error("waiting for " + exe + ": " + std::strerror(errno));
    std::ifstream in(statusFile);
    for (std::string line; std::getline(in, line);) {
      if (line.rfind("VmHWM:", 0) == 0) peakKiB = std::max(peakKiB, std::strtod(line.c_str() + 6, nullptr));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  run.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.cpuSeconds = double(usage.ru_utime.tv_sec) + 1e-6 * double(usage.ru_utime.tv_usec) +
                   double(usage.ru_stime.tv_sec) + 1e-6 * double(usage.ru_stime.tv_usec);
  run.maxRssMiB = peakKiB / 1024.0;
  return status;
}

// A finished run of an earlier study to reuse: the same scene text, its
// summary written, its measured cost kept (CPU s, wall s, peak MiB).
bool reusableRun(const fs::path& scene, const std::string& text, const fs::path& out, const fs::path& cost,
                 BreakageRun& run) {
  std::error_code ec;
  if (!fs::is_regular_file(cost, ec) || !fs::is_regular_file(out / "summary.json", ec)) return false;
  if (!fs::is_regular_file(scene, ec) || readText(scene) != text) return false;
  std::istringstream in(readText(cost));
  return static_cast<bool>(in >> run.cpuSeconds >> run.wallSeconds >> run.maxRssMiB);
}

// The last non-empty line of a log (the run's one-line error).
std::string lastLine(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  return last;
}

std::string runName(const BreakageRun& r) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%s_c%g_n%g_%s_r%g_s%llu", r.caseName.c_str(), r.setting.cellsAcross,
                r.setting.nodeDensity, dynamics::ForceFormulation::PerNode == r.setting.formulation ? "pn" : "aw",
                r.setting.regridCells, static_cast<unsigned long long>(r.seed));
  return buf;
}

}  // namespace

std::string settingLabel(const BreakageSetting& s) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "cells %g, nodes %g, %s, regrid %g", s.cellsAcross, s.nodeDensity,
                s.formulation == dynamics::ForceFormulation::PerNode ? "per_node" : "area_weighted", s.regridCells);
  return buf;
}

const std::vector<BreakageCase>& breakageCases(int dimension) {
  static const std::vector<BreakageCase> cases2 = {
      {"single_grain", "chipping/single_grain_2d_no_chipping.toml",
       embeddedScene("chipping/single_grain_2d_no_chipping.toml"), 40.0, 10.0, 2, 1e5},
      {"three_grains", "three_grains/three_grains_2d.toml", embeddedScene("three_grains/three_grains_2d.toml"), 40.0,
       5.0, 2, 1e5},
      {"oedometer", "chipping/oedometer_small_2d_no_chipping.toml",
       embeddedScene("chipping/oedometer_small_2d_no_chipping.toml"), 24.0, 6.0, 2, 1e5},
  };
  static const std::vector<BreakageCase> cases3 = {
      {"single_grain_3d", "single_grain/single_grain_3d.toml", embeddedScene("single_grain/single_grain_3d.toml"),
       20.0, 5.0, 3, 3.2e3},
  };
  if (dimension == 2) return cases2;
  if (dimension == 3) return cases3;
  throw std::invalid_argument("the breakage study has 2D and 3D scenes, not " + std::to_string(dimension) + "D");
}

std::string breakageSceneText(const BreakageCase& c, const BreakageSetting& s, std::uint64_t seed) {
  // The shipped stiffness per unit contact length (2D) or area (3D): kn per
  // node at one node per cell of the shipped grid, carried to this grid and
  // node density (node spacing ~ 1 / (cells x node_density); a node stands
  // for spacing^(D-1) of surface).
  const bool perNode = s.formulation == dynamics::ForceFormulation::PerNode;
  const double faces = double(c.dimension - 1);
  const double kn = c.shippedKn * std::pow(c.shippedCells / s.cellsAcross, faces) /
                    (perNode ? std::pow(s.nodeDensity, faces) : 1.0);
  const std::vector<io::SceneSetting> settings = {
      {"simulation.threads", "1"},
      {"shapes.*.cells_across", number(s.cellsAcross)},
      {"shapes.*.node_density", number(s.nodeDensity)},
      {"contact.formulation", perNode ? "\"per_node\"" : "\"area_weighted\""},
      {"contact.kn", number(kn)},
      {"effects.breakage.regrid_cells", number(s.regridCells)},
      {"effects.breakage.seed", std::to_string(seed)},
      {"output.frames", "0"},
      {"output.vtk", "[]"},
      {"output.distributions", "2"},
      {"output.checkpoint_every", "0"},
      {"output.history_rows", "2000"},
      {"output.shape_min_cells", number(c.shippedMinCells * s.cellsAcross / c.shippedCells)},
  };
  return io::overrideScene(c.text, settings, c.scene);
}

double sizeQuantile(const SizeDistribution& psd, double fraction) {
  if (psd.size.empty() || psd.size.size() != psd.passing.size()) {
    throw std::invalid_argument("sizeQuantile: empty size distribution");
  }
  if (!(fraction > 0.0 && fraction <= 1.0)) throw std::invalid_argument("sizeQuantile: fraction outside (0, 1]");
  if (psd.passing.front() >= fraction) return psd.size.front();
  for (std::size_t i = 1; i < psd.size.size(); ++i) {
    if (psd.passing[i] < fraction) continue;
    const double p0 = psd.passing[i - 1], p1 = psd.passing[i];
    const double t = p1 > p0 ? (fraction - p0) / (p1 - p0) : 1.0;
    return std::exp(std::log(psd.size[i - 1]) + t * (std::log(psd.size[i]) - std::log(psd.size[i - 1])));
  }
  return psd.size.back();
}

namespace {

// The passing fraction of a step-function curve at log10 size v.
double passingAt(const SizeDistribution& d, double v) {
  double p = 0.0;
  for (std::size_t i = 0; i < d.size.size() && std::log10(d.size[i]) <= v; ++i) p = d.passing[i];
  return p;
}

}  // namespace

SizeDistribution meanDistribution(const std::vector<SizeDistribution>& curves) {
  SizeDistribution mean;
  for (const SizeDistribution& c : curves) mean.size.insert(mean.size.end(), c.size.begin(), c.size.end());
  std::sort(mean.size.begin(), mean.size.end());
  mean.size.erase(std::unique(mean.size.begin(), mean.size.end()), mean.size.end());
  for (double s : mean.size) {
    double p = 0.0;
    for (const SizeDistribution& c : curves) p += passingAt(c, std::log10(s)) / double(curves.size());
    mean.passing.push_back(p);
  }
  return mean;
}

double psdDistance(const SizeDistribution& a, const SizeDistribution& b) {
  // Every breakpoint of either step function, in log10 size.
  std::vector<double> x;
  for (double s : a.size) x.push_back(std::log10(s));
  for (double s : b.size) x.push_back(std::log10(s));
  std::sort(x.begin(), x.end());
  x.erase(std::unique(x.begin(), x.end()), x.end());
  double l1 = 0.0;
  for (std::size_t i = 0; i + 1 < x.size(); ++i) {
    l1 += std::abs(passingAt(a, x[i]) - passingAt(b, x[i])) * (x[i + 1] - x[i]);
  }
  return l1;
}

BreakageReport runBreakageStudy(const BreakageOptions& options) {
  if (options.executable.empty()) throw std::invalid_argument("the breakage study needs the lsdem executable");
  if (options.seeds < 0) throw std::invalid_argument("seeds must be >= 0");
  if (options.jobs < 1) throw std::invalid_argument("jobs must be >= 1");
  const std::vector<BreakageCase>& cases = breakageCases(options.dimension);
  const auto start = std::chrono::steady_clock::now();
  BreakageReport report;
  report.dimension = options.dimension;
  report.quick = options.quick;
  report.seeds = options.seeds > 0 ? options.seeds : (options.quick ? 2 : 6);

  // The runs: the grid ladder, then the other knobs about the baseline.
  const Ladder l = ladder(options.dimension, options.quick);
  std::vector<std::pair<std::string, std::pair<double, BreakageSetting>>> settings;
  for (double c : l.cells) {
    BreakageSetting s;
    s.cellsAcross = c;
    settings.push_back({"cells", {c, s}});
  }
  for (double n : l.nodes) {
    BreakageSetting s;
    s.nodeDensity = n;
    settings.push_back({"nodes", {n, s}});
  }
  if (l.areaWeighted) {
    BreakageSetting s;
    s.formulation = dynamics::ForceFormulation::AreaWeighted;
    settings.push_back({"law", {1.0, s}});
  }
  for (double r : l.regrid) {
    BreakageSetting s;
    s.regridCells = r;
    settings.push_back({"regrid", {r, s}});
  }
  std::vector<BreakageRun> runs;
  for (const BreakageCase& c : cases) {
    for (const auto& [knob, value] : settings) {
      for (int k = 0; k < report.seeds; ++k) {
        BreakageRun r;
        r.caseName = c.name;
        r.knob = knob;
        r.knobValue = value.first;
        r.setting = value.second;
        r.seed = std::uint64_t(101 + k);
        runs.push_back(r);
      }
    }
  }
  // The most expensive first (finest grids, most nodes), so the two workers end together.
  std::stable_sort(runs.begin(), runs.end(), [](const BreakageRun& a, const BreakageRun& b) {
    return a.setting.cellsAcross * a.setting.nodeDensity > b.setting.cellsAcross * b.setting.nodeDensity;
  });

  const fs::path root = fs::path(options.outDir) / "runs";
  std::error_code ec;
  fs::create_directories(root, ec);
  if (ec || !fs::is_directory(root)) throw std::runtime_error("cannot create the directory " + root.string());

  // The workers: each takes the next run, writes its scene, runs it and reads its outputs.
  std::atomic<std::size_t> next{0};
  std::mutex progressMutex;
  std::size_t done = 0;
  const auto work = [&] {
    for (std::size_t i = next++; i < runs.size(); i = next++) {
      BreakageRun& r = runs[i];
      const BreakageCase* c = nullptr;
      for (const BreakageCase& bc : cases) {
        if (bc.name == r.caseName) c = &bc;
      }
      const std::string name = runName(r);
      const fs::path scene = root / (name + ".toml"), out = root / name, log = root / (name + ".log"),
                     cost = root / (name + ".cost");
      try {
        const std::string text = breakageSceneText(*c, r.setting, r.seed);
        if (options.resume && reusableRun(scene, text, out, cost, r)) {
          readOutputs(out, r);
          r.ok = true;
          r.reused = true;
        } else {
          fs::remove(cost);
          std::ofstream(scene, std::ios::binary | std::ios::trunc) << text;
          const int status = runChild(options.executable, scene, out, log, r);
          if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
            r.error = "lsdem run failed: " + lastLine(log);
          } else {
            readOutputs(out, r);
            r.ok = true;
            // The measured cost, for a later --resume.
            // Written to round-trip exactly, so a resumed study's tables equal this one's.
            char line[96];
            std::snprintf(line, sizeof line, "%.17g %.17g %.17g\n", r.cpuSeconds, r.wallSeconds, r.maxRssMiB);
            std::ofstream(cost) << line;
          }
        }
      } catch (const std::exception& e) {
        r.error = e.what();
      }
      if (options.progress) {
        std::lock_guard<std::mutex> lock(progressMutex);
        ++done;
        char buf[320];
        if (r.ok) {
          std::snprintf(buf, sizeof buf,
                        "[%zu/%zu] %-12s %-38s seed %llu: %3.0f pieces, d50 %.3g mm, fines %4.1f %%, peak %.3g kPa, "
                        "%.1f s CPU, %.0f MiB",
                        done, runs.size(), r.caseName.c_str(), settingLabel(r.setting).c_str(),
                        static_cast<unsigned long long>(r.seed), r.fragments, 1e3 * r.d50, r.finesPercent,
                        1e-3 * r.peakStress, r.cpuSeconds, r.maxRssMiB);
        } else {
          std::snprintf(buf, sizeof buf, "[%zu/%zu] %-12s %-38s seed %llu: FAILED: %s", done, runs.size(),
                        r.caseName.c_str(), settingLabel(r.setting).c_str(), static_cast<unsigned long long>(r.seed),
                        r.error.c_str());
        }
        options.progress(buf);
      }
    }
  };
  std::vector<std::thread> workers;
  for (int j = 0; j < options.jobs; ++j) workers.emplace_back(work);
  for (std::thread& t : workers) t.join();

  report.runs = std::move(runs);
  summariseBreakage(report);
  report.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const BreakageRun& r : report.runs) report.cpuSeconds += r.cpuSeconds;
  return report;
}

}  // namespace lsdem::study
