/// @file AccuracyOutput.cpp
/// @brief The files of the accuracy study: accuracy.csv, accuracy.md and the
/// error-versus-time plots (Accuracy.h, writeAccuracyFiles). bench/study is a
/// study application library, so it writes its own report files; each is
/// written to a temporary name and renamed into place.

#include "lsdem/study/Accuracy.h"

#include "lsdem/io/Plot.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::study {
namespace {

// Writes `text` to `path` through a temporary file and a rename.
void writeAtomically(const std::filesystem::path& path, const std::string& text) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw std::runtime_error("cannot rename " + tmp.string() + " to " + path.string() + ": " + ec.message());
}

// Draws `spec`; a plot with nothing to draw on its log axes (all errors 0) is
// recorded as skipped under `name`.
void drawOrSkip(const io::PlotSpec& spec, const std::string& name, AccuracyFiles& files) {
  try {
    io::renderPlot(spec);
    files.plots.push_back(spec.output);
  } catch (const std::runtime_error&) {
    files.skippedPlots.push_back(name);
  }
}

std::string number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

// The long-format table: one row per (setting, metric).
std::string csvText(const AccuracyReport& report) {
  std::ostringstream csv;
  csv << "dimension,knob,setting,cells_across,nodes_per_cell,formulation,dt_fraction,metric,value,reference,error,"
         "step_seconds,steps,run_seconds,node_checks_per_step,split_seconds,bytes_per_particle,curve\n";
  for (const auto& p : report.points) {
    csv << report.dimension << ',' << p.knob << ',' << number(p.setting) << ',' << number(p.config.cellsAcross) << ','
        << number(p.config.nodesPerCell) << ',' << formulationName(p.config.formulation) << ','
        << number(p.config.dtFraction) << ',' << p.metric.metric << ',' << number(p.metric.value) << ','
        << number(p.metric.reference) << ',' << number(p.metric.error) << ',' << number(p.cost.stepSeconds) << ','
        << number(p.cost.steps) << ',' << number(p.cost.runSeconds) << ',' << number(p.cost.nodeChecksPerStep) << ','
        << number(p.cost.splitSeconds) << ',' << number(p.cost.bytesPerParticle) << ',' << p.metric.metric << '/'
        << p.knob << '\n';
  }
  return csv.str();
}

}  // namespace

AccuracyFiles writeAccuracyFiles(const AccuracyReport& report, const std::string& directory) {
  namespace fs = std::filesystem;
  const fs::path dir(directory);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) throw std::runtime_error("cannot create the directory " + directory);

  AccuracyFiles files;
  files.csv = (dir / "accuracy.csv").string();
  files.markdown = (dir / "accuracy.md").string();
  writeAtomically(files.csv, csvText(report));
  writeAtomically(files.markdown, accuracyMarkdown(report));

  // One log-log plot per metric: error against run time, one curve per knob.
  if (io::gnuplotAvailable()) {
    std::vector<std::string> metrics, knobs;
    for (const auto& p : report.points) {
      if (std::find(metrics.begin(), metrics.end(), p.metric.metric) == metrics.end()) metrics.push_back(p.metric.metric);
      if (std::find(knobs.begin(), knobs.end(), p.knob) == knobs.end()) knobs.push_back(p.knob);
    }
    for (const std::string& m : metrics) {
      io::PlotSpec spec;
      spec.output = (dir / ("error_vs_time_" + m + ".png")).string();
      spec.title = m + " (" + std::to_string(report.dimension) + "D)";
      spec.xLabel = "packing run, CPU seconds on 1 thread";
      spec.yLabel = "error (relative)";
      spec.logX = true;
      spec.logY = true;
      for (const std::string& k : knobs) {
        io::PlotSeries s;
        s.csv = files.csv;
        s.x = "run_seconds";
        s.y = "error";
        s.title = k;
        s.filterColumn = "curve";
        s.filterValue = m + "/" + k;
        spec.series.push_back(s);
      }
      drawOrSkip(spec, m, files);
    }

    // The contact stiffness ratio of both laws against the node density:
    // flat for the area-weighted law, slope D - 1 for the per-node law.
    io::PlotSpec stiffness;
    stiffness.output = (dir / "stiffness_vs_nodes_per_cell.png").string();
    stiffness.title = "total contact stiffness / area-weighted continuum (" + std::to_string(report.dimension) + "D)";
    stiffness.xLabel = "surface nodes per cell length";
    stiffness.yLabel = "F / (kn / w_ref int delta dA)";
    stiffness.logX = true;
    stiffness.logY = true;
    for (const char* law : {"nodes_per_cell", "nodes_per_cell_per_node"}) {
      for (const char* contact : {"plane", "pair"}) {
        io::PlotSeries s;
        s.csv = files.csv;
        s.x = "nodes_per_cell";
        s.y = "value";
        s.title = std::string(law == std::string("nodes_per_cell") ? "area-weighted" : "per-node") + ", " + contact;
        s.filterColumn = "curve";
        s.filterValue = std::string("stiffness_") + contact + "/" + law;
        stiffness.series.push_back(s);
      }
    }
    drawOrSkip(stiffness, "stiffness_vs_nodes_per_cell", files);

    // Convergence in the grid: the errors of the exact-reference metrics against cells across.
    io::PlotSpec cells;
    cells.output = (dir / "error_vs_cells.png").string();
    cells.title = "error against grid resolution (" + std::to_string(report.dimension) + "D)";
    cells.xLabel = "grid cells across the grain";
    cells.yLabel = "error (relative)";
    cells.logX = true;
    cells.logY = true;
    for (const char* m : {"volume_sphere", "inertia_sphere", "inertia_grain", "force_plane", "force_pair",
                          "force_face", "ripple_plane", "cap_volume", "restitution"}) {
      io::PlotSeries s;
      s.csv = files.csv;
      s.x = "cells_across";
      s.y = "error";
      s.title = m;
      s.filterColumn = "curve";
      s.filterValue = std::string(m) + "/cells";
      cells.series.push_back(s);
    }
    drawOrSkip(cells, "error_vs_cells", files);
  }
  return files;
}

}  // namespace lsdem::study
