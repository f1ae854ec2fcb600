#pragma once
/// @file Commands.h
/// @brief The subcommands of `lsdem`. Each adds itself to the CLI11 app; its
/// callback runs the command and throws io::InputError for bad input.

#include <CLI/CLI.hpp>

#include <array>
#include <cmath>
#include <limits>
#include <string>

namespace lsdem::apps {

/// An option's check: a whole number (Integer) or a finite number of at
/// least `least` (and at most `most`). Its error names the value as given
/// ("--steps: must be a whole number >= 1, got -5"); CLI11's own range
/// checks print the largest double in full.
template <bool Integer>
CLI::Validator atLeast(double least, double most = std::numeric_limits<double>::infinity()) {
  const auto text = [](double v) {
    return Integer ? std::to_string(static_cast<long long>(v)) : CLI::detail::to_string(v);
  };
  const std::string bound = std::isfinite(most) ? "in [" + text(least) + ", " + text(most) + "]" : ">= " + text(least);
  const std::string kind = Integer ? "a whole number" : "a number";
  return CLI::Validator(
      [least, most, bound, kind](const std::string& text) {
        double v = 0.0;
        std::size_t used = 0;
        try {
          v = Integer ? double(std::stoll(text, &used)) : std::stod(text, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != text.size() || !std::isfinite(v) || v < least || v > most) {
          return "must be " + kind + " " + bound + ", got '" + text + "'";
        }
        return std::string();
      },
      (Integer ? "INT " : "NUMBER ") + bound);
}

/// An image size option ("--size WxH", x or X): whole numbers of pixels in
/// [64, 8000] each; io::InputError naming the option otherwise. (render and
/// paraview take the same sizes.)
std::array<int, 2> imageSize(const std::string& text);

/// A number option that must be finite and > 0: io::InputError naming the
/// option otherwise ("--spacing: must be positive, got 0").
void requirePositive(const std::string& option, double v);

/// An output folder option: made if missing, and a file can be written in
/// it; io::InputError naming the option otherwise. Checked before a long
/// study runs (it failed after the run).
void requireWritableFolder(const std::string& option, const std::string& dir);

/// The MPI ranks `lsdem` runs on (1 unless started by mpirun with -np > 1, in
/// a build with LSDEM_MPI), and this process's rank.
int mpiRanks();
int mpiRank();

/// `lsdem shape FILE.toml [--json]`: mass properties, descriptors, grid and nodes of one shape.
void addShapeCommand(CLI::App& app);

/// `lsdem run SCENE.toml [--out DIR] [--steps N] [--threads N] [--quiet]`, `lsdem run --resume DIR`.
void addRunCommand(CLI::App& app);

/// `lsdem split FILE.toml --plane nx,ny[,nz],d [--json]`: level-set splitting of one shape by a plane.
void addSplitCommand(CLI::App& app);

/// `lsdem bench stability [--case NAME] [--dim 2|3] [--long] [--out DIR]`: the stability suite (docs/stability.md).
void addStabilityBench(CLI::App& bench);

/// `lsdem bench accuracy [--dim 2|3] [--quick] [--out DIR]`: accuracy against cost of the knobs (docs/accuracy.md).
void addAccuracyBench(CLI::App& bench);

void addMesh2lsCommand(CLI::App& app);  ///< `lsdem mesh2ls MESH --spacing H -o OUT.lsg`: CAD mesh -> grain file (docs/grains.md).
void addCt2lsCommand(CLI::App& app);  ///< `lsdem ct2ls IMAGE -o DIR`: labelled CT volume -> one grain file per label (docs/tomography.md).
void addPlotCommand(CLI::App& app);  ///< `lsdem plot DIR [--out PLOTDIR]`: PNG plots of a run's CSV histories (docs/plots.md).
void addRenderCommand(CLI::App& app);  ///< `lsdem render DIR [--frame N|last] -o IMAGE.png [--view AZ,EL]`: PNG of one frame of a run (docs/render.md).
void addParaviewCommand(CLI::App& app);  ///< `lsdem paraview DIR [--screenshot FILE.png] [--time T]`: the run in ParaView, or a PNG of it (docs/paraview.md).

}  // namespace lsdem::apps
