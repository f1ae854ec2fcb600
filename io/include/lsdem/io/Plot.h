#pragma once
/// @file Plot.h
/// @brief PNG plots of CSV histories drawn with gnuplot (docs/plots.md): a
/// plot is a list of series, each two columns of a CSV file picked by header
/// name, optionally restricted to the rows where one column has one value.
/// The gnuplot script is kept beside the PNG so the user can edit and rerun it.

#include <string>
#include <vector>

namespace lsdem::io {

/// One curve of a plot: column `y` against column `x` of the CSV file `csv`.
struct PlotSeries {
  std::string csv;           ///< path of a CSV file with a header row (comma separated)
  std::string x;             ///< header name of the x column
  std::string y;             ///< header name of the y column
  std::string title;         ///< legend entry (empty: the y column's name)
  std::string filterColumn;  ///< when not empty, only rows where this column ...
  std::string filterValue;   ///< ... equals this text (compared as written in the file)
  /// How the series is drawn: as PlotSpec::lines says, or lines with a
  /// marker at each point (a one-point series shows), or markers alone.
  enum class Style { Spec, LinesPoints, Points } style = Style::Spec;
};

/// A plot: one PNG with one or more series.
struct PlotSpec {
  std::string output;  ///< path of the PNG to write (ends in .png)
  std::string title, xLabel, yLabel;
  bool logX = false, logY = false;  ///< logarithmic axes (rows with values <= 0 on them are left out)
  bool lines = true;                ///< lines through the points; false draws points only
  std::vector<PlotSeries> series;
};

/// @brief True when a `gnuplot` executable is on the PATH.
bool gnuplotAvailable();

/// @brief Draws a plot: writes one data file per series next to the output
/// (<stem>.<i>.dat, two whitespace-separated columns, rows whose x or y is not
/// a finite number left out), the gnuplot script <stem>.gp (run it with
/// `gnuplot <stem>.gp` in the output's folder to redraw), and runs gnuplot with
/// the pngcairo terminal (png when pngcairo is missing) to make the PNG.
/// @param spec the plot; its series' CSV files must exist.
/// @note Throws std::runtime_error with a one-line message when gnuplot is not
/// installed or fails, a CSV file cannot be read, a column is absent, the
/// output does not end in .png, or no series has a row to draw. Series without
/// rows are left out of the plot when another series has some.
void renderPlot(const PlotSpec& spec);

/// @brief The header names of a CSV file (its first line split at commas).
/// @note Throws std::runtime_error when the file cannot be read or is empty.
std::vector<std::string> csvColumns(const std::string& csv);

/// @brief The distinct texts of one column of a CSV file, in order of first appearance.
/// @note Throws std::runtime_error when the file cannot be read or has no such column.
std::vector<std::string> csvDistinctValues(const std::string& csv, const std::string& column);

/// What plotRunFolder made.
struct RunPlots {
  std::vector<std::string> written;  ///< PNG files written
  std::vector<std::string> skipped;  ///< plots left out and why ("stress_strain.png: history.csv has no column 'strain'")
};

/// @brief Which of history.csv, psd.csv, shape_stats.csv and breakage_log.csv
/// a run's output folder holds (file names, in that order).
/// @note Throws io::InputError (file = dir) when `dir` is not a folder or holds none of them.
std::vector<std::string> runFolderCsvFiles(const std::string& dir);

/// @brief The plots of a run's output folder (docs/plots.md): energies,
/// breakages, stress-strain and void ratio from history.csv, the particle size
/// distribution from psd.csv (at most 8 times: the first, the last and evenly
/// between), shape statistics from shape_stats.csv and breakage stresses from
/// breakage_log.csv, each drawn when its file and columns are there.
/// @param dir the run's output folder.
/// @param outDir folder for the PNG files, scripts and data (created when missing).
/// @note Throws io::InputError (file = dir) when `dir` is not a folder or holds
/// none of the four CSV files; std::runtime_error from renderPlot.
RunPlots plotRunFolder(const std::string& dir, const std::string& outDir);

}  // namespace lsdem::io
