/// @file Plot.cpp
/// @brief PNG plots of CSV histories with gnuplot (docs/plots.md).

#include "lsdem/io/Plot.h"

#include "lsdem/io/InputError.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

namespace lsdem::io {
namespace {

namespace fs = std::filesystem;

std::string trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r\n");
  return std::string(s.substr(first, last - first + 1));
}

std::vector<std::string> splitCells(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells.push_back(trim(std::string_view(line).substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) return cells;
    start = comma + 1;
  }
}

/// A CSV file opened at its first data row, with its header.
struct CsvFile {
  std::ifstream in;
  std::vector<std::string> header;

  explicit CsvFile(const std::string& path) : in(path) {
    if (!in) {
      const std::error_code ec(errno, std::generic_category());
      throw std::runtime_error("cannot read CSV file '" + path + "': " + ec.message());
    }
    std::string line;
    if (!std::getline(in, line) || trim(line).empty()) throw std::runtime_error("CSV file '" + path + "' has no header row");
    header = splitCells(line);
  }
  /// Index of a column by header name, or -1.
  int column(const std::string& name) const {
    const auto it = std::find(header.begin(), header.end(), name);
    return it == header.end() ? -1 : int(it - header.begin());
  }
  int requireColumn(const std::string& name, const std::string& path) const {
    const int c = column(name);
    if (c < 0) throw std::runtime_error("CSV file '" + path + "' has no column '" + name + "'");
    return c;
  }
};

bool finiteNumber(const std::string& cell, double& v) {
  const char* first = cell.data();
  const char* last = first + cell.size();
  if (first != last && *first == '+') ++first;
  const auto r = std::from_chars(first, last, v);
  return r.ec == std::errc() && r.ptr == last && std::isfinite(v);
}

/// A text as a gnuplot single-quoted string (a quote is doubled).
std::string quoted(const std::string& s) {
  std::string q(1, '\'');
  for (char c : s) {
    q.push_back(c);
    if (c == '\'') q.push_back(c);
  }
  q.push_back('\'');
  return q;
}

/// Writes the (x, y) rows of one series to `dat`; returns the row count.
std::size_t writeSeriesData(const PlotSeries& s, bool logX, bool logY, const fs::path& dat) {
  CsvFile csv(s.csv);
  const int cx = csv.requireColumn(s.x, s.csv);
  const int cy = csv.requireColumn(s.y, s.csv);
  const int cf = s.filterColumn.empty() ? -1 : csv.requireColumn(s.filterColumn, s.csv);
  std::ofstream out(dat);
  if (!out) throw std::runtime_error("cannot write plot data '" + dat.string() + "'");
  std::size_t rows = 0;
  std::string line;
  // Keep the rows that pass the filter and hold finite numbers (positive on log axes).
  while (std::getline(csv.in, line)) {
    if (trim(line).empty()) continue;
    const std::vector<std::string> cells = splitCells(line);
    const int need = std::max({cx, cy, cf});
    if (int(cells.size()) <= need) continue;
    if (cf >= 0 && cells[std::size_t(cf)] != s.filterValue) continue;
    double x = 0.0, y = 0.0;
    if (!finiteNumber(cells[std::size_t(cx)], x) || !finiteNumber(cells[std::size_t(cy)], y)) continue;
    if ((logX && x <= 0.0) || (logY && y <= 0.0)) continue;
    out << cells[std::size_t(cx)] << ' ' << cells[std::size_t(cy)] << '\n';
    ++rows;
  }
  if (!out) throw std::runtime_error("cannot write plot data '" + dat.string() + "'");
  return rows;
}

/// Runs `gnuplot SCRIPT` in `folder`; its messages go to `log`. Returns the exit status.
int runGnuplot(const fs::path& folder, const std::string& script, const fs::path& log) {
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("cannot start gnuplot (fork failed)");
  if (pid == 0) {
    // Child: into the plot folder, messages to the log, then gnuplot.
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      close(fd);
    }
    if (chdir(folder.c_str()) != 0) _exit(126);
    execlp("gnuplot", "gnuplot", script.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error("waiting for gnuplot failed");
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

/// The first line of gnuplot's messages that reads like an error, or the last line.
std::string gnuplotMessage(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last, error;
  while (std::getline(in, line)) {
    if (trim(line).empty()) continue;
    last = trim(line);
    if (error.empty() && (line.find("error") != std::string::npos || line.find("rror:") != std::string::npos)) error = last;
  }
  return error.empty() ? last : error;
}

/// renderPlot's error when no series has a row to draw (plotRunFolder skips such plots).
class NoRowsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace

bool gnuplotAvailable() {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  // Look for an executable `gnuplot` in every PATH entry (an empty entry is the current folder).
  std::istringstream entries(path);
  for (std::string dir; std::getline(entries, dir, ':');) {
    const fs::path candidate = (dir.empty() ? fs::current_path() : fs::path(dir)) / "gnuplot";
    if (access(candidate.c_str(), X_OK) == 0) return true;
  }
  return false;
}

std::vector<std::string> csvColumns(const std::string& csv) { return CsvFile(csv).header; }

std::vector<std::string> csvDistinctValues(const std::string& csv, const std::string& column) {
  CsvFile file(csv);
  const int c = file.requireColumn(column, csv);
  std::vector<std::string> values;
  std::string line;
  while (std::getline(file.in, line)) {
    if (trim(line).empty()) continue;
    const std::vector<std::string> cells = splitCells(line);
    if (int(cells.size()) <= c) continue;
    if (std::find(values.begin(), values.end(), cells[std::size_t(c)]) == values.end()) values.push_back(cells[std::size_t(c)]);
  }
  return values;
}

namespace {
// What a plot with no row to draw adds to its reason when an axis is
// logarithmic (the rows with values <= 0 there were left out).
std::string logAxisNote(const PlotSpec& spec) {
  return spec.logX || spec.logY ? " (a log axis takes positive values only)" : "";
}
}  // namespace

void renderPlot(const PlotSpec& spec) {
  // Check the request and gnuplot.
  const fs::path output(spec.output);
  if (output.extension() != ".png") throw std::runtime_error("plot output '" + spec.output + "' does not end in .png");
  if (spec.series.empty()) throw std::runtime_error("plot '" + spec.output + "' has no series");
  if (!gnuplotAvailable()) throw std::runtime_error("gnuplot is not installed (apt-get install gnuplot-nox)");
  const fs::path folder = output.has_parent_path() ? output.parent_path() : fs::path(".");
  fs::create_directories(folder);
  const std::string stem = output.stem().string();

  // One data file per series; series without rows are left out.
  std::vector<std::string> curves;
  for (std::size_t i = 0; i < spec.series.size(); ++i) {
    const PlotSeries& s = spec.series[i];
    const std::string dat = stem + "." + std::to_string(i) + ".dat";
    if (writeSeriesData(s, spec.logX, spec.logY, folder / dat) == 0) {
      std::error_code ec;
      fs::remove(folder / dat, ec);  // (nothing to draw: not left behind)
      continue;
    }
    const std::string style = s.style == PlotSeries::Style::LinesPoints ? "linespoints lw 2 pt 7 ps 1"
                              : s.style == PlotSeries::Style::Points    ? "points pt 6 ps 1"
                              : spec.lines                              ? "lines lw 2"
                                                                        : "points pt 7 ps 0.6";
    curves.push_back(quoted(dat) + " using 1:2 with " + style + " title " + quoted(s.title.empty() ? s.y : s.title));
  }
  if (curves.empty()) {
    throw NoRowsError("plot '" + spec.output + "': no series has a row to draw" + logAxisNote(spec));
  }

  // The gnuplot script, kept for the user.
  const std::string script = stem + ".gp";
  {
    std::ofstream gp(folder / script);
    gp << "# " << spec.title << " (lsdem plot; redraw with `gnuplot " << script << "` in this folder)\n"
       << "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) { set terminal pngcairo size 960,640 noenhanced } "
          "else { set terminal png size 960,640 noenhanced }\n"
       << "set output " << quoted(output.filename().string()) << "\n"
       << "set title " << quoted(spec.title) << "\n"
       << "set xlabel " << quoted(spec.xLabel) << "\n"
       << "set ylabel " << quoted(spec.yLabel) << "\n"
       << "set grid\nset key outside right top\n";
    if (spec.logX) gp << "set logscale x\n";
    if (spec.logY) gp << "set logscale y\n";
    gp << "plot ";
    for (std::size_t i = 0; i < curves.size(); ++i) gp << (i ? ", \\\n     " : "") << curves[i];
    gp << "\n";
    if (!gp) throw std::runtime_error("cannot write gnuplot script '" + (folder / script).string() + "'");
  }

  // Draw.
  const fs::path log = folder / (stem + ".log");
  std::error_code ec;
  fs::remove(output, ec);
  const int status = runGnuplot(folder, script, log);
  if (status == 127) throw std::runtime_error("gnuplot is not installed (apt-get install gnuplot-nox)");
  if (status != 0 || !fs::exists(output) || fs::file_size(output) == 0) {
    throw std::runtime_error("gnuplot failed on " + (folder / script).string() + ": " + gnuplotMessage(log));
  }
  fs::remove(log, ec);
}

std::vector<std::string> runFolderCsvFiles(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(dir, 0, "", "is not a folder");
  std::vector<std::string> found;
  for (const char* name : {"history.csv", "psd.csv", "shape_stats.csv", "breakage_log.csv"}) {
    if (fs::is_regular_file(fs::path(dir) / name, ec)) found.push_back(name);
  }
  if (found.empty()) {
    throw InputError(dir, 0, "", "holds none of history.csv, psd.csv, shape_stats.csv, breakage_log.csv (is it a run's output folder?)");
  }
  return found;
}

RunPlots plotRunFolder(const std::string& dir, const std::string& outDir) {
  runFolderCsvFiles(dir);
  const fs::path d(dir), out(outDir);
  const fs::path history = d / "history.csv", psd = d / "psd.csv", shape = d / "shape_stats.csv",
                 log = d / "breakage_log.csv";

  RunPlots result;
  // Draws a plot whose columns are all in its files; otherwise records why not.
  auto draw = [&](const std::string& name, PlotSpec spec) {
    spec.output = (out / name).string();
    std::vector<PlotSeries> present;
    std::string missing;
    for (const PlotSeries& s : spec.series) {
      const std::vector<std::string> cols = csvColumns(s.csv);
      bool ok = true;
      for (const std::string* c : {&s.x, &s.y, &s.filterColumn}) {
        if (c->empty() || std::find(cols.begin(), cols.end(), *c) != cols.end()) continue;
        ok = false;
        if (missing.empty()) missing = fs::path(s.csv).filename().string() + " has no column '" + *c + "'";
      }
      if (ok) present.push_back(s);
    }
    if (present.empty()) {
      result.skipped.push_back(name + ": " + missing);
      return;
    }
    spec.series = present;
    try {
      renderPlot(spec);
    } catch (const NoRowsError&) {
      result.skipped.push_back(name + ": no rows with numbers to draw" + logAxisNote(spec));
      return;
    }
    result.written.push_back(spec.output);
  };
  auto series = [](const fs::path& csv, const std::string& x, const std::string& y, const std::string& title = "") {
    return PlotSeries{csv.string(), x, y, title, "", ""};
  };

  // history.csv: energies, breakages, stress-strain, void ratio.
  if (fs::exists(history)) {
    PlotSpec energies{"", "Energy budget", "time (s)", "energy (J)", false, false, true, {}};
    for (const char* c : {"kinetic_J", "elastic_J", "gravity_work_J", "boundary_work_J", "damping_loss_J",
                          "contact_loss_J", "split_release_J", "energy_error_J"}) {
      energies.series.push_back(series(history, "time_s", c));
    }
    draw("energies.png", energies);
    draw("breakages.png", PlotSpec{"", "Breakages and particles", "time (s)", "count", false, false, true,
                                   {series(history, "time_s", "breakages"), series(history, "time_s", "particles")}});
    draw("stress_strain.png", PlotSpec{"", "Stress-strain", "strain", "stress (Pa)", false, false, true,
                                       {series(history, "strain", "stress_Pa", "stress")}});
    draw("void_ratio.png", PlotSpec{"", "Void ratio", "stress (Pa)", "void ratio", true, false, true,
                                    {series(history, "stress_Pa", "void_ratio", "void ratio")}});
    // Forces on the tools (a tool is a boundary with a power column), one plot each.
    const std::vector<std::string> cols = csvColumns(history.string());
    for (const std::string& c : cols) {
      const std::string suffix = "_power_W";
      if (c.size() <= suffix.size() || c.compare(c.size() - suffix.size(), suffix.size(), suffix) != 0) continue;
      const std::string tool = c.substr(0, c.size() - suffix.size());
      PlotSpec forces{"", "Force of the particles on " + tool, "time (s)", "force (N)", false, false, true, {}};
      for (const char* axis : {"x", "y", "z"}) {
        const std::string column = tool + "_force_" + axis + "_N";
        if (std::find(cols.begin(), cols.end(), column) != cols.end()) forces.series.push_back(series(history, "time_s", column));
      }
      draw(tool + "_force.png", forces);
    }
  }

  // psd.csv: one curve per time (at most 8: first, last and evenly between).
  if (fs::exists(psd)) {
    PlotSpec spec{"", "Particle size distribution", "sieve size (m)", "percent passing", true, false, true, {}};
    const std::vector<std::string> cols = csvColumns(psd.string());
    if (std::find(cols.begin(), cols.end(), "time_s") == cols.end()) {
      result.skipped.push_back("psd.png: psd.csv has no column 'time_s'");
    } else {
      const std::vector<std::string> times = csvDistinctValues(psd.string(), "time_s");
      const std::size_t n = std::min<std::size_t>(times.size(), 8);
      for (std::size_t k = 0; k < n; ++k) {
        const std::size_t i = n == 1 ? 0 : (k * (times.size() - 1)) / (n - 1);
        spec.series.push_back(PlotSeries{psd.string(), "sieve_size_m", "percent_passing", "t = " + times[i] + " s",
                                         "time_s", times[i]});
      }
      if (spec.series.empty()) {
        result.skipped.push_back("psd.png: psd.csv has no rows");
      } else {
        draw("psd.png", spec);
      }
    }
  }

  // shape_stats.csv: mean circularity and aspect ratio against strain, or time.
  if (fs::exists(shape)) {
    const std::vector<std::string> cols = csvColumns(shape.string());
    // Against strain when the run had a specimen (the column then holds numbers).
    bool strain = false;
    if (std::find(cols.begin(), cols.end(), "strain") != cols.end()) {
      for (const std::string& v : csvDistinctValues(shape.string(), "strain")) strain = strain || !v.empty();
    }
    const std::string x = strain ? "strain" : "time_s";
    draw("shape_stats.png", PlotSpec{"", "Shape statistics", strain ? "strain" : "time (s)", "mean", false, false, true,
                                     {series(shape, x, "mean_circularity", "mean circularity / sphericity"),
                                      series(shape, x, "mean_aspect_ratio", "mean aspect ratio")}});
  }

  // breakage_log.csv: the criterion value and strength of each break against time.
  if (fs::exists(log)) {
    draw("breakage_stress.png", PlotSpec{"", "Breakage events", "time (s)", "stress (Pa)", false, false, false,
                                         {series(log, "time_s", "criterion_value_Pa", "criterion value"),
                                          series(log, "time_s", "strength_Pa", "strength")}});
  }
  return result;
}

}  // namespace lsdem::io
