/// @file BreakageOutput.cpp
/// @brief The files of the breakage accuracy study (BreakageAccuracy.h,
/// writeBreakageFiles): the table per setting and per run (CSV), the Markdown
/// report, and the PSD error against CPU time (the Pareto front) and against
/// the grid as PNG plots. Each file is written to a temporary name and renamed.

#include "lsdem/study/BreakageAccuracy.h"

#include "lsdem/io/Plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::study {
namespace {

namespace fs = std::filesystem;

void writeAtomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw std::runtime_error("cannot rename " + tmp.string() + " to " + path.string() + ": " + ec.message());
}

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// "3 scenes" or "1 scene": the cases the report holds, for headers and plot labels.
std::string scenesLabel(const BreakageReport& report) {
  const std::size_t n = report.seedNoise.size();
  return std::to_string(n) + (n == 1 ? " scene" : " scenes");
}

std::string dimensionLabel(const BreakageReport& report) { return std::to_string(report.dimension) + "D"; }

const char* lawName(const BreakageSetting& s) {
  return s.formulation == dynamics::ForceFormulation::PerNode ? "per_node" : "area_weighted";
}

std::string settingColumns(const BreakageSetting& s) {
  return num(s.cellsAcross) + ',' + num(s.nodeDensity) + ',' + lawName(s) + ',' + num(s.regridCells);
}

// One row per case and setting, over the seeds.
std::string rowsCsv(const BreakageReport& report) {
  std::ostringstream csv;
  csv << "case,knob,knob_value,cells_across,node_density,formulation,regrid_cells,reference,seeds,"
         "psd_error,psd_error_paired,psd_error_paired_spread,d10_m,d50_m,d50_spread_m,d90_m,fragments,fragments_spread,"
         "fines_percent,"
         "fines_spread,mean_circularity,mean_aspect_ratio,peak_stress_Pa,peak_stress_spread_Pa,peak_stress_error,"
         "fragments_error,split_stress_Pa,split_stress_spread_Pa,cpu_seconds,cpu_spread,max_rss_MiB,curve\n";
  for (const BreakageRow& w : report.rows) {
    csv << w.caseName << ',' << w.knob << ',' << num(w.knobValue) << ',' << settingColumns(w.setting) << ','
        << (w.reference ? 1 : 0) << ',' << w.seeds << ',' << num(w.psdError) << ',' << num(w.pairedPsdError.mean) << ','
        << num(w.pairedPsdError.spread) << ',' << num(w.d10.mean) << ',' << num(w.d50.mean) << ',' << num(w.d50.spread)
        << ',' << num(w.d90.mean) << ',' << num(w.fragments.mean) << ',' << num(w.fragments.spread) << ','
        << num(w.finesPercent.mean) << ',' << num(w.finesPercent.spread) << ',' << num(w.circularity.mean) << ','
        << num(w.aspectRatio.mean) << ',' << num(w.peakStress.mean) << ',' << num(w.peakStress.spread) << ','
        << num(w.peakStressError) << ',' << num(w.fragmentsError) << ',' << num(w.splitStress.mean) << ','
        << num(w.splitStress.spread) << ',' << num(w.cpuSeconds.mean) << ','
        << num(w.cpuSeconds.spread) << ',' << num(w.maxRssMiB) << ',' << w.caseName << '/' << w.knob << '\n';
  }
  return csv.str();
}

// One row per run.
std::string runsCsv(const BreakageReport& report) {
  std::ostringstream csv;
  csv << "case,knob,knob_value,cells_across,node_density,formulation,regrid_cells,seed,ok,psd_error_paired,d10_m,d50_m,"
         "d90_m,fragments,breakages,fines_percent,mean_circularity,mean_aspect_ratio,peak_stress_Pa,split_stress_Pa,"
         "steps,cpu_seconds,wall_seconds,max_rss_MiB,error\n";
  for (const BreakageRun& r : report.runs) {
    std::string error = r.error;
    std::replace(error.begin(), error.end(), ',', ';');
    csv << r.caseName << ',' << r.knob << ',' << num(r.knobValue) << ',' << settingColumns(r.setting) << ',' << r.seed
        << ',' << (r.ok ? 1 : 0) << ',' << num(r.psdError) << ',' << num(r.d10) << ',' << num(r.d50) << ','
        << num(r.d90) << ',' << num(r.fragments) << ',' << num(r.breakages) << ',' << num(r.finesPercent) << ','
        << num(r.meanCircularity) << ',' << num(r.meanAspectRatio) << ',' << num(r.peakStress) << ','
        << num(r.splitStress) << ',' << num(r.steps)
        << ',' << num(r.cpuSeconds) << ',' << num(r.wallSeconds) << ',' << num(r.maxRssMiB) << ',' << error << '\n';
  }
  return csv.str();
}

// The settings over all cases (mean PSD error, summed CPU), by cost, with the
// Pareto front marked: no cheaper setting has a smaller error.
struct FrontPoint {
  std::string knob;
  double knobValue = 0.0;
  BreakageSetting setting;
  double error = 0.0, cpu = 0.0;
  int cases = 0;
  bool front = false;
};

std::vector<FrontPoint> frontPoints(const BreakageReport& report) {
  std::vector<FrontPoint> points;
  std::size_t cases = report.seedNoise.size();
  for (const BreakageRow& w : report.rows) {
    auto it = std::find_if(points.begin(), points.end(),
                           [&](const FrontPoint& p) { return p.knob == w.knob && p.knobValue == w.knobValue; });
    if (it == points.end()) {
      FrontPoint p;
      p.knob = w.knob;
      p.knobValue = w.knobValue;
      p.setting = w.setting;
      points.push_back(p);
      it = points.end() - 1;
    }
    if (w.seeds == 0 || !std::isfinite(w.psdError)) continue;
    it->error += w.psdError;
    it->cpu += w.cpuSeconds.mean;
    ++it->cases;
  }
  std::erase_if(points, [&](const FrontPoint& p) { return p.cases == 0 || std::size_t(p.cases) != cases; });
  for (FrontPoint& p : points) p.error /= p.cases;
  std::sort(points.begin(), points.end(), [](const FrontPoint& a, const FrontPoint& b) { return a.cpu < b.cpu; });
  double best = INFINITY;
  for (FrontPoint& p : points) {
    if (p.error < best) {
      p.front = true;
      best = p.error;
    }
  }
  return points;
}

std::string frontCsv(const std::vector<FrontPoint>& points) {
  std::ostringstream csv;
  // The reference's error is 0 by definition: the log axes of the plot leave it out.
  csv << "knob,knob_value,cells_across,node_density,formulation,regrid_cells,psd_error,cpu_seconds,on_front\n";
  for (const FrontPoint& p : points) {
    csv << p.knob << ',' << num(p.knobValue) << ',' << settingColumns(p.setting) << ',' << num(p.error) << ','
        << num(p.cpu) << ',' << (p.front ? 1 : 0) << '\n';
  }
  return csv.str();
}

std::string ms(const MeanSpread& m, const char* format, double scale = 1.0) {
  return fmt(format, scale * m.mean) + " ± " + fmt(format, scale * m.spread);
}

}  // namespace

std::string breakageMarkdown(const BreakageReport& report) {
  std::ostringstream md;
  md << "# Breakage accuracy against cost (" << dimensionLabel(report) << ", " << (report.quick ? "quick" : "full")
     << " ladder, " << report.seeds << " seeds)\n\n";
  md << "| case | knob | setting | seeds | PSD error (decades) | paired | d10 / d50 / d90 (mm) | fragments | fines % "
        "| circularity | aspect ratio | peak stress (kPa) | stress at first split (kPa) | CPU s | max MiB |\n"
     << "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
  for (const BreakageRow& w : report.rows) {
    md << "| " << w.caseName << " | " << w.knob << " | " << settingLabel(w.setting) << (w.reference ? " (ref)" : "")
       << " | " << w.seeds << " | " << fmt("%.4f", w.psdError) << " | " << ms(w.pairedPsdError, "%.3f") << " | "
       << fmt("%.3f", 1e3 * w.d10.mean) << " / " << fmt("%.3f", 1e3 * w.d50.mean) << " / "
       << fmt("%.3f", 1e3 * w.d90.mean) << " | " << ms(w.fragments, "%.1f") << " | " << ms(w.finesPercent, "%.1f")
       << " | " << fmt("%.3f", w.circularity.mean) << " | " << fmt("%.3f", w.aspectRatio.mean) << " | "
       << ms(w.peakStress, "%.1f", 1e-3) << " | " << ms(w.splitStress, "%.1f", 1e-3) << " | "
       << ms(w.cpuSeconds, "%.2f") << " | " << fmt("%.0f", w.maxRssMiB)
       << " |\n";
  }
  md << "\n## Seed noise\n\n| case | L1 between two seeds at the reference (decades) | noise floor of the means |\n"
     << "| --- | --- | --- |\n";
  for (std::size_t i = 0; i < report.seedNoise.size(); ++i) {
    md << "| " << report.seedNoise[i].first << " | " << ms(report.seedNoise[i].second, "%.4f") << " | "
       << fmt("%.4f", i < report.noiseFloor.size() ? report.noiseFloor[i].second : 0.0) << " |\n";
  }
  md << "\n## Observed orders (error ~ cells^-p over the grid ladder)\n\n| case | metric | p | points |\n"
     << "| --- | --- | --- | --- |\n";
  for (const ConvergenceOrder& o : report.orders) {
    md << "| " << o.caseName << " | " << o.metric << " | " << (o.points >= 2 ? fmt("%.2f", o.order) : "-") << " | "
       << o.points << " |\n";
  }
  md << "\n## Budgets\n\n| budget | PSD error bound (decades) | setting | PSD error | CPU s (" << scenesLabel(report)
     << ") | per scene | max MiB |\n| --- | --- | --- | --- | --- | --- | --- |\n";
  for (const BreakageBudget& b : report.budgets) {
    md << "| " << b.name << " | " << fmt("%.4f", b.target) << " | ";
    if (!b.reached) {
      md << "not reached | | | | |\n";
      continue;
    }
    std::string perCase;
    for (const auto& [name, cpu] : b.cpuByCase)
      perCase += (perCase.empty() ? "" : ", ") + name + " " + fmt("%.2f", cpu);
    md << settingLabel(b.setting) << (b.isReference ? " (the reference: not verified beyond)" : "") << " | "
       << fmt("%.4f", b.psdError) << " | " << fmt("%.1f", b.cpuSeconds) << " | " << perCase << " | "
       << fmt("%.0f", b.maxRssMiB) << " |\n";
  }
  md << "\n";
  for (const std::string& note : report.notes) md << "- " << note << '\n';
  md << "\nThe study took " << fmt("%.0f", report.wallSeconds) << " s wall, " << fmt("%.0f", report.cpuSeconds)
     << " s CPU in its runs";
  std::size_t reused = 0;
  for (const BreakageRun& r : report.runs) reused += r.reused ? 1 : 0;
  if (reused > 0) md << " (" << reused << " of them read from an earlier study, their CPU as measured then)";
  md << ".\n";
  return md.str();
}

BreakageFiles writeBreakageFiles(const BreakageReport& report, const std::string& directory) {
  const fs::path dir(directory);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) throw std::runtime_error("cannot create the directory " + directory);

  BreakageFiles files;
  files.csv = (dir / "breakage_accuracy.csv").string();
  files.runsCsv = (dir / "breakage_runs.csv").string();
  files.markdown = (dir / "breakage_accuracy.md").string();
  const std::string front = (dir / "breakage_front.csv").string();
  writeAtomically(files.csv, rowsCsv(report));
  writeAtomically(files.runsCsv, runsCsv(report));
  writeAtomically(front, frontCsv(frontPoints(report)));
  writeAtomically(files.markdown, breakageMarkdown(report));
  // The mean noise floor as a line across the costs of the settings.
  const std::string floorCsv = (dir / "breakage_noise_floor.csv").string();
  {
    const std::vector<FrontPoint> points = frontPoints(report);
    double floor = 0.0;
    for (const auto& [name, f] : report.noiseFloor) floor += f / double(report.noiseFloor.size());
    std::ostringstream csv;
    csv << "cpu_seconds,psd_error\n";
    if (!points.empty()) {
      csv << num(0.7 * points.front().cpu) << ',' << num(floor) << '\n'
          << num(1.4 * points.back().cpu) << ',' << num(floor) << '\n';
    }
    writeAtomically(floorCsv, csv.str());
  }
  if (!io::gnuplotAvailable()) return files;

  std::vector<std::string> cases;
  for (const auto& [name, n] : report.seedNoise) cases.push_back(name);
  const auto draw = [&](const io::PlotSpec& spec) {
    try {
      io::renderPlot(spec);
      files.plots.push_back(spec.output);
    } catch (const std::runtime_error&) {
      // nothing to draw on the log axes (every error 0): no plot
    }
  };

  // The Pareto front: PSD error against CPU time, every setting (mean over
  // the scenes) and the front, and each scene's grid ladder.
  io::PlotSpec pareto;
  pareto.output = (dir / "psd_error_vs_time.png").string();
  const std::string scenes = scenesLabel(report);
  pareto.title = "PSD error against cost (" + dimensionLabel(report) + ", mean over seeds)";
  pareto.xLabel = "CPU s on one thread (" + scenes + (report.seedNoise.size() == 1 ? ")" : ": sum)");
  pareto.yLabel = "PSD L1 error vs finest grid, decades";
  pareto.logX = pareto.logY = true;
  using Style = io::PlotSeries::Style;
  pareto.series.push_back({front, "cpu_seconds", "psd_error", "every setting (" + scenes + ")", "", "", Style::Points});
  pareto.series.push_back(
      {front, "cpu_seconds", "psd_error", "Pareto front (" + scenes + ")", "on_front", "1", Style::LinesPoints});
  pareto.series.push_back({floorCsv, "cpu_seconds", "psd_error", "noise floor", "", "", Style::Spec});
  for (const std::string& c : cases) {
    pareto.series.push_back(
        {files.csv, "cpu_seconds", "psd_error", c + " grid", "curve", c + "/cells", Style::LinesPoints});
  }
  draw(pareto);

  // The errors against the grid, per scene.
  io::PlotSpec cells;
  cells.output = (dir / "psd_error_vs_cells.png").string();
  cells.title = "PSD error against grid resolution (" + dimensionLabel(report) + ")";
  cells.xLabel = "grid cells across a grain";
  cells.yLabel = "PSD L1 error vs finest grid, decades";
  cells.logX = cells.logY = true;
  for (const std::string& c : cases) {
    cells.series.push_back({files.csv, "cells_across", "psd_error", c, "curve", c + "/cells", Style::LinesPoints});
  }
  draw(cells);
  return files;
}

}  // namespace lsdem::study
