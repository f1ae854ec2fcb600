// Plots: CSV columns by header name, row filters, the kept gnuplot script and
// data files, PNG output (skipped only when gnuplot is absent), clear errors,
// and the plots of a synthetic run folder.

#include "support/Files.h"
#include "lsdem/io/Plot.h"

#include "lsdem/io/InputError.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using namespace lsdem;

namespace {

fs::path tempDir(const std::string& name) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_plot_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

bool isPng(const fs::path& p) { return slurp(p).rfind("\x89PNG\r\n\x1a\n", 0) == 0; }

// A small long-format PSD: three times, four sieves each.
void writePsd(const fs::path& file) {
  std::ofstream out(file);
  out << "time_s,sieve_size_m,percent_passing\n";
  for (const char* t : {"0", "0.5", "1"}) {
    for (int k = 0; k < 4; ++k) out << t << ',' << 0.001 * (k + 1) << ',' << 25.0 * (k + 1) - std::atof(t) << '\n';
  }
}

// PATH cleared for the life of the object (gnuplot looks absent).
struct NoPath {
  std::string saved = std::getenv("PATH") ? std::getenv("PATH") : "";
  NoPath() { setenv("PATH", "/nonexistent-lsdem", 1); }
  ~NoPath() { setenv("PATH", saved.c_str(), 1); }
};

}  // namespace

TEST(Plot, CsvColumnsAndDistinctValues) {
  const fs::path dir = tempDir("csv");
  writePsd(dir / "psd.csv");
  EXPECT_EQ(io::csvColumns((dir / "psd.csv").string()), (std::vector<std::string>{"time_s", "sieve_size_m", "percent_passing"}));
  EXPECT_EQ(io::csvDistinctValues((dir / "psd.csv").string(), "time_s"), (std::vector<std::string>{"0", "0.5", "1"}));
  EXPECT_THROW(io::csvDistinctValues((dir / "psd.csv").string(), "nope"), std::runtime_error);
  EXPECT_THROW(io::csvColumns((dir / "missing.csv").string()), std::runtime_error);
}

TEST(Plot, RendersAPngAndKeepsTheScriptAndFilteredData) {
  const fs::path dir = tempDir("render");
  writePsd(dir / "psd.csv");
  io::PlotSpec spec;
  spec.output = (dir / "out" / "psd.png").string();
  spec.title = "PSD";
  spec.xLabel = "sieve size (m)";
  spec.yLabel = "percent passing";
  spec.logX = true;
  spec.series.push_back({(dir / "psd.csv").string(), "sieve_size_m", "percent_passing", "t = 0.5 s", "time_s", "0.5"});
  spec.series.push_back({(dir / "psd.csv").string(), "sieve_size_m", "percent_passing", "it's t = 1", "time_s", "1"});
  if (!io::gnuplotAvailable()) GTEST_SKIP() << "gnuplot is not installed";
  io::renderPlot(spec);
  // The PNG, the script (with the log axis and a quoted quote) and the filtered data.
  EXPECT_TRUE(isPng(dir / "out" / "psd.png"));
  const std::string gp = slurp(dir / "out" / "psd.gp");
  EXPECT_NE(gp.find("set logscale x"), std::string::npos);
  EXPECT_NE(gp.find("'it''s t = 1'"), std::string::npos);
  EXPECT_NE(gp.find("'psd.0.dat' using 1:2"), std::string::npos);
  EXPECT_EQ(slurp(dir / "out" / "psd.0.dat"), "0.001 24.5\n0.002 49.5\n0.003 74.5\n0.004 99.5\n");
  EXPECT_EQ(slurp(dir / "out" / "psd.1.dat"), "0.001 24\n0.002 49\n0.003 74\n0.004 99\n");
  EXPECT_FALSE(fs::exists(dir / "out" / "psd.log"));
}

TEST(Plot, ClearErrors) {
  const fs::path dir = tempDir("errors");
  writePsd(dir / "psd.csv");
  io::PlotSpec spec;
  spec.output = (dir / "p.png").string();
  spec.series.push_back({(dir / "psd.csv").string(), "sieve_size_m", "stress_Pa", "", "", ""});
  auto message = [&] {
    try {
      io::renderPlot(spec);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // gnuplot absent.
  {
    NoPath noPath;
    EXPECT_FALSE(io::gnuplotAvailable());
    EXPECT_NE(message().find("gnuplot is not installed"), std::string::npos);
  }
  if (!io::gnuplotAvailable()) GTEST_SKIP() << "gnuplot is not installed";
  // Absent column, wrong extension, no rows, missing CSV.
  EXPECT_NE(message().find("has no column 'stress_Pa'"), std::string::npos) << message();
  spec.series[0].y = "percent_passing";
  spec.output = (dir / "p.svg").string();
  EXPECT_NE(message().find("does not end in .png"), std::string::npos) << message();
  spec.output = (dir / "p.png").string();
  spec.series[0].filterColumn = "time_s";
  spec.series[0].filterValue = "7";
  EXPECT_NE(message().find("no series has a row"), std::string::npos) << message();
  spec.series[0].csv = (dir / "none.csv").string();
  EXPECT_NE(message().find("cannot read CSV file"), std::string::npos) << message();
}

TEST(Plot, RunFolderPlotsWhatIsThere) {
  const fs::path dir = tempDir("run");
  // No CSV files: an input error naming the folder.
  try {
    io::plotRunFolder(dir.string(), (dir / "plots").string());
    ADD_FAILURE();
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.file(), dir.string());
    EXPECT_NE(e.problem().find("holds none of history.csv"), std::string::npos);
  }
  if (!io::gnuplotAvailable()) GTEST_SKIP() << "gnuplot is not installed";
  // A history without a specimen (no stress, strain, void ratio), a PSD and shape statistics without strain.
  {
    std::ofstream h(dir / "history.csv");
    h << "step,time_s,particles,contacts,breakages,removed_mass_kg,kinetic_J,elastic_J,gravity_work_J,boundary_work_J,"
         "damping_loss_J,contact_loss_J,energy_error_J\n";
    for (int i = 0; i < 20; ++i) {
      const double t = 0.01 * i;
      h << i << ',' << t << ',' << 3 + i / 5 << ',' << 4 << ',' << i / 5 << ",0," << std::exp(-t) << ',' << 0.1 * t << ','
        << t << ",0," << 0.5 * t << ',' << 0.2 * t << ",1e-9\n";
    }
    std::ofstream s(dir / "shape_stats.csv");
    s << "time_s,particles,mean_circularity,mean_aspect_ratio\n0,3,0.9,0.8\n0.1,4,0.85,0.7\n0.2,6,0.8,0.65\n";
  }
  writePsd(dir / "psd.csv");
  const io::RunPlots plots = io::plotRunFolder(dir.string(), (dir / "plots").string());
  for (const char* png : {"energies.png", "breakages.png", "psd.png", "shape_stats.png"}) {
    EXPECT_TRUE(isPng(dir / "plots" / png)) << png;
  }
  EXPECT_EQ(plots.written.size(), 4u);
  ASSERT_EQ(plots.skipped.size(), 2u);
  EXPECT_EQ(plots.skipped[0], "stress_strain.png: history.csv has no column 'strain'");
  EXPECT_EQ(plots.skipped[1], "void_ratio.png: history.csv has no column 'stress_Pa'");
  EXPECT_FALSE(fs::exists(dir / "plots" / "stress_strain.png"));
  // The energies plot has one curve per energy column; the PSD one per time.
  const std::string gp = slurp(dir / "plots" / "energies.gp");
  EXPECT_NE(gp.find("'energies.6.dat'"), std::string::npos);
  EXPECT_NE(slurp(dir / "plots" / "psd.gp").find("'t = 1 s'"), std::string::npos);
  EXPECT_NE(slurp(dir / "plots" / "shape_stats.gp").find("set xlabel 'time (s)'"), std::string::npos);
}
