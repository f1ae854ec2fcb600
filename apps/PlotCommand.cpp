/// @file PlotCommand.cpp
/// @brief `lsdem plot DIR [--out PLOTDIR]`: PNG plots of the CSV histories of a
/// run's output folder with gnuplot (docs/plots.md). Exit 3 when gnuplot is
/// not installed, 2 when DIR holds none of the CSV files.

#include "Commands.h"

#include "lsdem/io/Plot.h"

#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

namespace lsdem::apps {

void addPlotCommand(CLI::App& app) {
  struct Options {
    std::string dir;
    std::string out;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("plot", "PNG plots of a run's CSV histories (needs gnuplot)");
  cmd->add_option("dir", opts->dir, "a run's output folder (history.csv, psd.csv, shape_stats.csv, breakage_log.csv)")
      ->required();
  cmd->add_option("--out", opts->out, "folder for the PNG files and gnuplot scripts (default DIR/plots)");
  cmd->callback([opts] {
    const std::string out = opts->out.empty() ? (std::filesystem::path(opts->dir) / "plots").string() : opts->out;
    // Without gnuplot: say so once (after checking DIR, so bad input is reported first) and exit 3.
    if (!io::gnuplotAvailable()) {
      io::runFolderCsvFiles(opts->dir);  // throws for a DIR without CSV files
      std::cerr << "lsdem plot: gnuplot is not installed (apt-get install gnuplot-nox); the CSV files in " << opts->dir
                << " can be plotted with any tool\n";
      throw CLI::RuntimeError(3);
    }
    // DIR first, then an --out that cannot be written (it was a filesystem
    // error, exit 1).
    io::runFolderCsvFiles(opts->dir);
    if (!opts->out.empty()) requireWritableFolder("--out", out);
    const io::RunPlots plots = io::plotRunFolder(opts->dir, out);
    for (const std::string& png : plots.written) std::cout << "wrote " << png << '\n';
    for (const std::string& why : plots.skipped) std::cout << "skipped " << why << '\n';
    // Nothing drawn (CSV files without rows, or without the columns drawn;
    // the reasons are above): exit 3, as without gnuplot.
    if (plots.written.empty()) {
      std::cerr << "lsdem plot: nothing to plot in " << opts->dir << "; nothing drawn\n";
      throw CLI::RuntimeError(3);
    }
  });
}

}  // namespace lsdem::apps
