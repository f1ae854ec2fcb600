/// @file Accuracy.cpp
/// @brief The sweep of the accuracy study (Accuracy.h), its Pareto front and
/// its tables; the files are written by AccuracyOutput.cpp.

#include "lsdem/study/Accuracy.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace lsdem::study {
namespace {

// The values each knob takes, quick or full, per dimension.
struct KnobLists {
  std::vector<double> cells, nodesPerCell, dtFraction;
  double referenceCells = 0.0;  // the random grain's reference grid
  int grains = 0;               // grains in the packing
  double settleSeconds = 0.1;   // simulated settling time of the packing after the fall, s
};

KnobLists knobLists(int dimension, bool quick) {
  KnobLists k;
  if (dimension == 2) {
    k.cells = quick ? std::vector<double>{6, 10, 16, 24} : std::vector<double>{6, 8, 10, 14, 20, 28, 40, 56};
    k.nodesPerCell = quick ? std::vector<double>{0.5, 1, 2, 4} : std::vector<double>{0.5, 1, 1.5, 2, 3, 4};
    k.dtFraction = quick ? std::vector<double>{0.1, 0.2, 0.4} : std::vector<double>{0.05, 0.1, 0.2, 0.4, 0.8};
    k.referenceCells = quick ? 160 : 320;
    k.grains = quick ? 100 : 300;
  } else {
    k.cells = quick ? std::vector<double>{6, 8, 12} : std::vector<double>{6, 8, 10, 14, 20, 28};
    k.nodesPerCell = quick ? std::vector<double>{0.5, 1, 2} : std::vector<double>{0.5, 1, 1.5, 2, 3};
    k.dtFraction = quick ? std::vector<double>{0.1, 0.2, 0.4} : std::vector<double>{0.05, 0.1, 0.2, 0.4, 0.8};
    k.referenceCells = quick ? 40 : 80;
    k.grains = quick ? 32 : 128;
  }
  return k;
}

// Worker threads of the sweep (each measures whole configurations on one
// OpenMP thread): two, one per core of the machines the study targets.
constexpr unsigned kStudyThreads = 2;

// A rough relative cost of a setting's packing run, for scheduling only:
// nodes per grain ~ (cells x nodes per cell)^(D-1), steps ~ cells^-0.35 /
// dtFraction (the measured trend), and the per-node law's stiffness, growing
// like nodesPerCell^(D-1), shortens the step by its square root.
double estimatedCost(const AccuracySetting& s, int dimension) {
  const double perNode = s.formulation == dynamics::ForceFormulation::PerNode
                             ? std::pow(s.nodesPerCell, 0.5 * (dimension - 1))
                             : 1.0;
  return std::pow(s.cellsAcross * s.nodesPerCell, dimension - 1) * std::pow(s.cellsAcross, -0.35) * perNode /
         s.dtFraction;
}

// Everything measured for one configuration (shared by the knobs that reach it).
struct SettingResult {
  std::vector<MetricValue> metrics;
  PackingResult packing;
  double splitSeconds = 0.0;
  std::array<double, 5> stageCpu{};  // CPU s of the measuring thread: mass, contact, restitution, split, packing
};

std::string settingKey(const AccuracySetting& s) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "%g/%g/%s/%g/%s/%d", s.cellsAcross, s.nodesPerCell, formulationName(s.formulation),
                s.dtFraction, interpolationName(s.interpolation), s.exactNodes ? 1 : 0);
  return buf;
}

template <int D>
SettingResult measure(const AccuracySetting& s, const KnobLists& lists) {
  SettingResult r;
  // Each stage appends its metrics and records the CPU time it took on this thread.
  int stage = 0;
  auto append = [&](const std::vector<MetricValue>& m, double cpu0) {
    r.metrics.insert(r.metrics.end(), m.begin(), m.end());
    r.stageCpu[std::size_t(stage++)] = threadCpuSeconds() - cpu0;
  };
  double cpu0 = threadCpuSeconds();
  append(massMetrics<D>(s.cellsAcross, lists.referenceCells), cpu0);
  cpu0 = threadCpuSeconds();
  append(contactMetrics<D>(s), cpu0);
  cpu0 = threadCpuSeconds();
  append(restitutionMetrics<D>(s), cpu0);
  cpu0 = threadCpuSeconds();
  append(splitMetrics<D>(s, r.splitSeconds), cpu0);
  cpu0 = threadCpuSeconds();
  r.packing = packingRun<D>(s, lists.grains, lists.settleSeconds);
  r.stageCpu[4] = threadCpuSeconds() - cpu0;
  r.packing.cost.splitSeconds = r.splitSeconds;
  return r;
}

// One progress line: the setting, its CPU time by stage and the packing's outcome.
std::string progressLine(const std::string& knob, double value, const SettingResult& r) {
  const auto& c = r.stageCpu;
  const auto& pk = r.packing;
  char line[320];
  std::snprintf(line, sizeof line,
                "%-24s %-6g %5.1f s CPU (mass %.1f, contact %.1f, restitution %.1f, split %.1f, packing %.1f); "
                "packing %.0f steps, %.3g ms/step on 1 thread, Z = %.2f, KE ratio %.2g",
                knob.c_str(), value, c[0] + c[1] + c[2] + c[3] + c[4], c[0], c[1], c[2], c[3], c[4], pk.cost.steps,
                1e3 * pk.cost.stepSeconds, pk.coordination, pk.kineticRatio);
  return line;
}

template <int D>
AccuracyReport runStudy(const AccuracyOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const double cpuStart = processCpuSeconds();
  const KnobLists lists = knobLists(D, options.quick);
  AccuracyReport report;
  report.dimension = D;
  report.quick = options.quick;
  auto say = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };

  // The settings: each knob swept about the baseline; the per-node law over the node densities.
  struct Planned {
    std::string knob;
    double value;
    AccuracySetting config;
  };
  std::vector<Planned> plan;
  const AccuracySetting base;
  for (double c : lists.cells) plan.push_back({"cells", c, [&] { auto s = base; s.cellsAcross = c; return s; }()});
  // The two method knobs over the same cells and the baseline's (10, which
  // the quick list skips), so they compare with the baseline directly.
  std::vector<double> methodCells = lists.cells;
  if (std::find(methodCells.begin(), methodCells.end(), base.cellsAcross) == methodCells.end()) {
    methodCells.push_back(base.cellsAcross);
    std::sort(methodCells.begin(), methodCells.end());
  }
  for (double c : methodCells) {
    plan.push_back({"cells_tricubic", c, [&] {
                      auto s = base;
                      s.cellsAcross = c;
                      s.interpolation = dynamics::LevelSetInterpolation::Tricubic;
                      return s;
                    }()});
  }
  for (double c : methodCells) {
    plan.push_back({"cells_grid_nodes", c, [&] {
                      auto s = base;
                      s.cellsAcross = c;
                      s.exactNodes = false;
                      return s;
                    }()});
  }
  for (double n : lists.nodesPerCell) {
    plan.push_back({"nodes_per_cell", n, [&] { auto s = base; s.nodesPerCell = n; return s; }()});
  }
  for (double n : lists.nodesPerCell) {
    plan.push_back({"nodes_per_cell_per_node", n, [&] {
                      auto s = base;
                      s.nodesPerCell = n;
                      s.formulation = dynamics::ForceFormulation::PerNode;
                      return s;
                    }()});
  }
  for (double f : lists.dtFraction) {
    plan.push_back({"dt_fraction", f, [&] { auto s = base; s.dtFraction = f; return s; }()});
  }

  // The packing's reference: the finest grid, baseline nodes, the smallest time-step fraction.
  AccuracySetting finest = base;
  finest.cellsAcross = lists.cells.back();
  finest.dtFraction = lists.dtFraction.front();
  const std::string finestKey = settingKey(finest);

  // The distinct configurations, longest first (a rough estimate), so that no
  // long run trails at the end while the other worker idles.
  struct Task {
    std::string knob;
    double value;
    AccuracySetting config;
  };
  std::vector<Task> tasks{{"packing reference", finest.cellsAcross, finest}};
  for (const Planned& p : plan) {
    const std::string key = settingKey(p.config);
    const auto sameKey = [&](const Task& t) { return settingKey(t.config) == key; };
    const bool seen = std::any_of(tasks.begin(), tasks.end(), sameKey);
    if (!seen) tasks.push_back({p.knob, p.value, p.config});
  }
  std::stable_sort(tasks.begin(), tasks.end(), [](const Task& a, const Task& b) {
    return estimatedCost(a.config, D) > estimatedCost(b.config, D);
  });

  // Measure them on two worker threads, each running its OpenMP regions on
  // one thread: every measurement is a pure function of its configuration, so
  // the results do not depend on the order, and the costs are the CPU time of
  // the measuring thread.
  std::vector<SettingResult> measured(tasks.size());
  std::vector<std::exception_ptr> failures(tasks.size());
  std::atomic<std::size_t> next{0};
  std::mutex sayMutex;
  auto worker = [&] {
    const SingleThreadScope oneThread;
    for (std::size_t t = next++; t < tasks.size(); t = next++) {
      try {
        measured[t] = measure<D>(tasks[t].config, lists);
        const std::string line = progressLine(tasks[t].knob, tasks[t].value, measured[t]);
        const std::lock_guard<std::mutex> lock(sayMutex);
        say(line);
      } catch (...) {
        failures[t] = std::current_exception();
      }
    }
  };
  const unsigned workers = std::max(1u, std::min(kStudyThreads, std::thread::hardware_concurrency()));
  std::vector<std::thread> threads;
  for (unsigned w = 1; w < workers; ++w) threads.emplace_back(worker);
  worker();
  for (auto& t : threads) t.join();
  for (const auto& f : failures) {
    if (f) std::rethrow_exception(f);
  }
  std::map<std::string, SettingResult> results;
  for (std::size_t t = 0; t < tasks.size(); ++t) results.emplace(settingKey(tasks[t].config), measured[t]);
  const PackingResult& ref = results[finestKey].packing;

  // The rows: the setting's metrics plus the packing metrics against the reference.
  for (const Planned& p : plan) {
    const SettingResult& r = results[settingKey(p.config)];
    std::vector<MetricValue> metrics = r.metrics;
    const PackingResult& pk = r.packing;
    metrics.push_back({"packing_floor_stress", pk.floorStress, ref.floorStress,
                       std::abs(pk.floorStress - ref.floorStress) / ref.floorStress});
    metrics.push_back({"packing_coordination", pk.coordination, ref.coordination,
                       std::abs(pk.coordination - ref.coordination) / std::max(ref.coordination, 1e-300)});
    metrics.push_back({"packing_load_balance", pk.loadBalance, 0.0, pk.loadBalance});
    for (const MetricValue& m : metrics) report.points.push_back({p.knob, p.value, p.config, m, pk.cost});
  }

  // Notes and the Pareto front.
  char note[512];
  std::snprintf(note, sizeof note,
                "Baseline: %g cells across, %g node per cell, area-weighted law, dt = %g x critical; each knob is "
                "swept alone about it.",
                base.cellsAcross, base.nodesPerCell, base.dtFraction);
  report.notes.push_back(note);
  report.notes.push_back(
      "Grids store float values only: lsdem offers no double-precision grid storage, so there is no float-vs-double "
      "knob.");
  std::snprintf(note, sizeof note,
                "References: exact answers, except the random grain (its own grid at %g cells across) and the packing "
                "stress and coordination (the run at %g cells, dt fraction %g).",
                lists.referenceCells, finest.cellsAcross, finest.dtFraction);
  report.notes.push_back(note);
  std::snprintf(note, sizeof note, "Packing: %d random grains of 0.8-1.2 cm settled by gravity in a box of planes.",
                lists.grains);
  report.notes.push_back(note);
  report.pareto = paretoFront(report.points, {0.01, 0.001});
  report.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.cpuSeconds = processCpuSeconds() - cpuStart;
  return report;
}

// The error of a metric as a percentage with three significant digits.
std::string percent(double error) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", 100.0 * error);
  return buf;
}

}  // namespace

AccuracyReport runAccuracyStudy(const AccuracyOptions& options) {
  if (options.dimension == 2) return runStudy<2>(options);
  if (options.dimension == 3) return runStudy<3>(options);
  throw std::invalid_argument("accuracy study: dimension must be 2 or 3, got " + std::to_string(options.dimension));
}

std::vector<ParetoChoice> paretoFront(const std::vector<AccuracyPoint>& points, const std::vector<double>& targets) {
  // Metrics in order of first appearance.
  std::vector<std::string> metrics;
  for (const auto& p : points) {
    if (std::find(metrics.begin(), metrics.end(), p.metric.metric) == metrics.end()) metrics.push_back(p.metric.metric);
  }
  std::vector<ParetoChoice> out;
  for (const std::string& m : metrics) {
    for (double target : targets) {
      ParetoChoice c;
      c.metric = m;
      c.target = target;
      for (const auto& p : points) {
        if (p.metric.metric != m || !(p.metric.error <= target)) continue;
        if (!c.reached || p.cost.runSeconds < c.runSeconds) {
          c.reached = true;
          c.knob = p.knob;
          c.setting = p.setting;
          c.config = p.config;
          c.error = p.metric.error;
          c.runSeconds = p.cost.runSeconds;
        }
      }
      out.push_back(c);
    }
  }
  return out;
}

std::string paretoText(const std::vector<ParetoChoice>& choices) {
  std::ostringstream out;
  char line[320];
  std::snprintf(line, sizeof line, "%-22s %7s  %-50s %10s %9s\n", "metric", "target",
                "cheapest setting (cells, nodes/cell, law, dt fraction)", "error", "run CPU s");
  out << line;
  for (const auto& c : choices) {
    // The knob that reached it, then the full configuration.
    std::string setting = "(none reaches it)";
    if (c.reached) {
      char v[160];
      std::snprintf(v, sizeof v, "%s=%g (%g, %g, %s, %g)", c.knob.c_str(), c.setting, c.config.cellsAcross,
                    c.config.nodesPerCell, formulationName(c.config.formulation), c.config.dtFraction);
      setting = v;
    }
    std::snprintf(line, sizeof line, "%-22s %6s%%  %-50s %9s%% %9.3g\n", c.metric.c_str(), percent(c.target).c_str(),
                  setting.c_str(), c.reached ? percent(c.error).c_str() : "-", c.reached ? c.runSeconds : 0.0);
    out << line;
  }
  return out.str();
}

std::string accuracyMarkdown(const AccuracyReport& report) {
  std::ostringstream md;
  md << "# Accuracy and cost (" << report.dimension << "D, " << (report.quick ? "--quick" : "full sweep") << ")\n\n";
  md << "Regenerate: `lsdem bench accuracy --dim " << report.dimension << (report.quick ? " --quick" : "")
     << "` (" << std::lround(report.wallSeconds) << " s wall, " << std::lround(report.cpuSeconds)
     << " s CPU on this machine). Costs are CPU times of one thread (the timed runs are single-threaded), "
        "but other work on the machine still raises them (shared caches and memory bandwidth: up to 2x on a "
        "loaded 2-core machine), so compare costs from one run, or from runs on an idle machine.\n\n";

  // The settings in the order of the sweep, with their cost.
  struct Row {
    std::string knob;
    double setting;
    AccuracyCost cost;
    std::map<std::string, double> error;
    std::map<std::string, double> value;
  };
  std::vector<Row> rows;
  std::vector<std::string> metrics;
  for (const auto& p : report.points) {
    if (rows.empty() || rows.back().knob != p.knob || rows.back().setting != p.setting) {
      rows.push_back({p.knob, p.setting, p.cost, {}, {}});
    }
    rows.back().error[p.metric.metric] = p.metric.error;
    rows.back().value[p.metric.metric] = p.metric.value;
    if (std::find(metrics.begin(), metrics.end(), p.metric.metric) == metrics.end()) metrics.push_back(p.metric.metric);
  }

  md << "## Cost per setting\n\n";
  md << "| knob | value | CPU ms/step (1 thread) | steps | run CPU s | node checks/step | split CPU ms | "
        "KiB/particle |\n";
  md << "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  char buf[512];
  for (const Row& r : rows) {
    std::snprintf(buf, sizeof buf, "| %s | %g | %.3g | %.0f | %.3g | %.3g | %.3g | %.3g |\n", r.knob.c_str(), r.setting,
                  1e3 * r.cost.stepSeconds, r.cost.steps, r.cost.runSeconds, r.cost.nodeChecksPerStep,
                  1e3 * r.cost.splitSeconds, r.cost.bytesPerParticle / 1024.0);
    md << buf;
  }

  // Errors in percent, in groups of columns.
  const std::vector<std::vector<std::string>> groups{
      {"volume_sphere", "inertia_sphere", "volume_ellipsoid", "inertia_ellipsoid", "volume_grain", "centroid_grain",
       "inertia_grain"},
      {"force_plane", "ripple_plane", "stiffness_plane", "force_pair", "ripple_pair", "stiffness_pair", "force_face",
       "ripple_face", "restitution"},
      {"cap_volume", "cap_centroid", "split_mass", "packing_floor_stress", "packing_coordination",
       "packing_load_balance"}};
  const char* titles[] = {"Mass properties: error in %", "Contact: error in %", "Splits and packing: error in %"};
  for (std::size_t g = 0; g < groups.size(); ++g) {
    md << "\n## " << titles[g] << "\n\n| knob | value |";
    for (const auto& m : groups[g]) md << " " << m << " |";
    md << "\n| --- | ---: |";
    for (std::size_t i = 0; i < groups[g].size(); ++i) md << " ---: |";
    md << "\n";
    for (const Row& r : rows) {
      std::snprintf(buf, sizeof buf, "| %s | %g |", r.knob.c_str(), r.setting);
      md << buf;
      for (const auto& m : groups[g]) {
        const auto it = r.error.find(m);
        md << " " << (it == r.error.end() ? std::string("-") : percent(it->second)) << " |";
      }
      md << "\n";
    }
  }

  // The contact stiffness F / F_ref(w_ref) as a value: flat for the
  // area-weighted law, growing like nodesPerCell^(D-1) for the per-node law.
  md << "\n## Contact stiffness ratio F / (kn / w_ref int delta dA) (value, 1 = exact area-weighted law)\n\n"
        "| knob | value | stiffness_plane | stiffness_pair | restitution e (target 0.5) |\n| --- | ---: | ---: | ---: | ---: "
        "|\n";
  for (const Row& r : rows) {
    if (r.knob.rfind("nodes_per_cell", 0) != 0) continue;
    std::snprintf(buf, sizeof buf, "| %s | %g | %.3f | %.3f | %.3f |\n", r.knob.c_str(), r.setting,
                  r.value.at("stiffness_plane"), r.value.at("stiffness_pair"), r.value.at("restitution"));
    md << buf;
  }

  // Observed order in cells: least-squares slope of log(error) against log(cells).
  md << "\n## Observed convergence order in cells across (slope of log error vs log cells)\n\n| metric | order |\n| --- "
        "| ---: |\n";
  for (const auto& m : metrics) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int n = 0;
    for (const Row& r : rows) {
      const auto it = r.error.find(m);
      if (r.knob != "cells" || it == r.error.end() || !(it->second > 0.0)) continue;
      const double x = std::log(r.setting), y = std::log(it->second);
      sx += x, sy += y, sxx += x * x, sxy += x * y, ++n;
    }
    if (n < 2) continue;
    const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    std::snprintf(buf, sizeof buf, "| %s | %.2f |\n", m.c_str(), -slope);
    md << buf;
  }

  md << "\n## Pareto front: cheapest setting per target error\n\n```\n" << paretoText(report.pareto) << "```\n";
  md << "\n## Notes\n\n";
  for (const auto& n : report.notes) md << "- " << n << "\n";
  return md.str();
}

}  // namespace lsdem::study
