#pragma once
/// @file BreakageAccuracy.h
/// @brief The breakage accuracy study behind `lsdem bench accuracy
/// --breakage`: what grid resolution, node density, force formulation and
/// fragment re-gridding do to the outcomes breakage users report (particle
/// size distribution, fragment count, fines, shape, peak stress) and what
/// each setting costs (CPU time, memory).
///
/// Shipped scenes, embedded in the study when it is built, so it needs no
/// source tree. 2D (the default): the single grain crushed between platens
/// (apps/scenes/chipping/single_grain_2d_no_chipping.toml), the three grains
/// (apps/scenes/three_grains/three_grains_2d.toml) and the small oedometer
/// (apps/scenes/chipping/oedometer_small_2d_no_chipping.toml). 3D: the single
/// grain crushed between platens with the 3D oedometer's material and
/// breakage settings (apps/scenes/single_grain/single_grain_3d.toml), on a
/// grid ladder of its own (BreakageOptions::dimension). Each run is
/// the scene with some keys replaced (io::overrideScene), written to a file
/// and run by `lsdem run FILE --threads 1` in a child process: what is
/// measured is what users run, and the child's CPU time (wait4) and peak
/// memory (its VmHWM) are the kernel's figures for that run alone.
///
/// Settings. The grid knob sets `cells_across` of every shape; the contact
/// stiffness is scaled with it so the stiffness per unit contact length (2D)
/// or area (3D) stays the shipped scene's (kn x (cells_shipped / cells)^(D-1),
/// and / node_density^(D-1) under the per-node law): refining the grid then
/// refines the same physics instead of stiffening the grains. `shape_min_cells` is scaled likewise, so the
/// shape statistics cover the same physical sizes at every resolution. Knobs
/// other than the grid are swept one at a time about the baseline
/// (BreakageSetting's defaults).
///
/// Seeds. Weibull strengths are random: every setting runs with the same
/// seeds (`effects.breakage.seed`, so the original grains draw the same
/// strengths). A setting's PSD error is the L1 distance between its mean
/// cumulative curve over the seeds and the reference's (the finest grid of
/// the ladder), beside its noise floor: the mean L1 distance between two
/// single runs of the reference with different seeds, over sqrt(seeds) (the
/// expected distance between two means of that many independent runs). The
/// paired distance (each run against the reference run of the same seed) is
/// reported too: it does not fall below the single-run seed noise, because a
/// change of resolution changes which grain breaks first and from there the
/// fragments' ids and strengths, so the same seed gives another history.

#include "lsdem/dynamics/ContactLaw.h"

#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace lsdem::study {

/// One configuration of the breakage knobs.
struct BreakageSetting {
  double cellsAcross = 20.0;  ///< grid cells across every grain (shapes.*.cells_across)
  double nodeDensity = 1.0;   ///< surface nodes per cell length (shapes.*.node_density)
  dynamics::ForceFormulation formulation = dynamics::ForceFormulation::PerNode;  ///< [contact] formulation
  double regridCells = 0.0;  ///< [effects.breakage] regrid_cells (0: off)
};

/// @brief "cells 20, nodes 1, per_node, regrid 0": a setting as one line.
std::string settingLabel(const BreakageSetting& setting);

/// A scene the study runs.
struct BreakageCase {
  std::string name;              ///< "single_grain", "three_grains", "oedometer", "single_grain_3d"
  std::string scene;             ///< the shipped scene it is, relative to apps/scenes
  std::string text;              ///< the scene file's text
  double shippedCells = 0.0;     ///< cells_across of the shipped scene
  double shippedMinCells = 5.0;  ///< [output] shape_min_cells of the shipped scene
  int dimension = 2;             ///< the scene's [simulation] dimension
  double shippedKn = 1e5;        ///< [contact] kn of the shipped scene, N/m per node
};

/// @brief The scenes of the study in `dimension` (2: the three 2D scenes; 3:
/// the 3D single grain), their text embedded at build time.
/// @note Throws std::invalid_argument for a dimension other than 2 or 3.
const std::vector<BreakageCase>& breakageCases(int dimension = 2);

/// @brief The scene text of `c` run at `setting` with Weibull seed `seed`:
/// grid, nodes, law, re-gridding and the stiffness and shape-statistics
/// scaling described in the file comment, and outputs cut to what the study
/// reads (no ParaView frames, two distributions, a checkpoint only at the end).
std::string breakageSceneText(const BreakageCase& c, const BreakageSetting& setting, std::uint64_t seed);

/// Sieve sizes below this count as this, m: 1% of the study's 1 mm grains.
/// Fines can be removed with a sieve size of 0 (slivers) or of nanometres;
/// on a log axis they would stretch the distance between distributions
/// without bound, so all dust sits at one size.
inline constexpr double kPsdSizeFloor = 1e-5;

/// A cumulative size distribution: sieve sizes (m, ascending) and the mass
/// fraction passing at each (in [0, 1], non-decreasing, the last 1).
struct SizeDistribution {
  std::vector<double> size;
  std::vector<double> passing;
};

/// @brief The size below which `fraction` of the mass passes (d10: 0.1),
/// linear in log size between the points; the smallest size when the first
/// point passes more than `fraction` already.
/// @note Throws std::invalid_argument for an empty distribution or a fraction outside (0, 1].
double sizeQuantile(const SizeDistribution& psd, double fraction);

/// @brief The mean of cumulative curves: at every size of any of them, the
/// mean of their passing fractions (each a step function as in psdDistance).
SizeDistribution meanDistribution(const std::vector<SizeDistribution>& curves);

/// @brief The L1 distance between two cumulative curves over log10 of the
/// size: the integral of |P_a - P_b| d(log10 s), each curve a step function
/// (the fraction passing at s is that of the largest sieve size <= s, 0 below
/// the smallest), in decades. 0 for identical curves; a shift of every size
/// by a factor f gives |log10 f|.
double psdDistance(const SizeDistribution& a, const SizeDistribution& b);

/// What one run (a case, a setting, a seed) produced and cost.
struct BreakageRun {
  std::string caseName;
  std::string knob;        ///< "cells", "nodes", "law", "regrid"
  double knobValue = 0.0;  ///< the knob's value (law: 0 per_node, 1 area_weighted)
  BreakageSetting setting;
  std::uint64_t seed = 0;
  bool ok = false;      ///< false: the run failed (error says why)
  bool reused = false;  ///< read from an earlier study (--resume): its cost is as measured then
  std::string error;
  SizeDistribution psd;                    ///< at the end of the run, fines included
  double d10 = 0.0, d50 = 0.0, d90 = 0.0;  ///< m
  double psdError = 0.0;                   ///< psdDistance to the reference run with the same seed, decades
  double fragments = 0.0;                  ///< particles at the end
  double breakages = 0.0;                  ///< splits over the run
  double finesPercent = 0.0;               ///< mass removed as fines, % of the initial mass
  double meanCircularity = 0.0;            ///< at the end, pieces at least shape_min_cells across (2D: 4 pi A / P^2)
  double meanAspectRatio = 0.0;            ///< likewise, shortest / longest best-fit semi-axis
  double peakStress = 0.0;                 ///< largest specimen stress over the run, Pa (N/m per m in 2D)
  double splitStress = 0.0;                ///< specimen stress at the first split (history row), Pa; NaN: no split
  double steps = 0.0;
  double cpuSeconds = 0.0;  ///< user + system CPU of the run's process (one OpenMP thread)
  double wallSeconds = 0.0;
  double maxRssMiB = 0.0;  ///< peak resident memory of the run's process, MiB
};

/// A mean and a spread (sample standard deviation; 0 for one value).
struct MeanSpread {
  double mean = 0.0;
  double spread = 0.0;
};

/// @brief The mean and sample standard deviation of `values` (0, 0 when empty).
MeanSpread meanSpread(const std::vector<double>& values);

/// A setting of one case summarised over its seeds.
struct BreakageRow {
  std::string caseName;
  std::string knob;
  double knobValue = 0.0;
  BreakageSetting setting;
  int seeds = 0;              ///< runs that finished
  bool reference = false;     ///< the reference setting (finest grid)
  SizeDistribution meanPsd;   ///< meanDistribution of its runs' curves
  double psdError = 0.0;      ///< psdDistance(meanPsd, the reference row's meanPsd), decades
  MeanSpread pairedPsdError;  ///< the runs' paired errors (BreakageRun::psdError)
  MeanSpread d10, d50, d90, fragments, finesPercent, circularity, aspectRatio, peakStress, cpuSeconds;
  MeanSpread splitStress;        ///< over the runs that split
  double peakStressError = 0.0;  ///< |mean peak stress / the reference's - 1|
  double fragmentsError = 0.0;   ///< |mean fragments / the reference's - 1|
  double maxRssMiB = 0.0;        ///< largest over the seeds
};

/// An observed convergence order: error ~ C cells^-order, fitted by least
/// squares in log-log over the grid ladder without its reference.
struct ConvergenceOrder {
  std::string caseName;
  std::string metric;  ///< "psd_l1", "d50", "peak_stress", "split_stress", "fragments"
  double order = 0.0;
  int points = 0;  ///< ladder points in the fit (errors > 0)
};

/// @brief The least-squares slope -d log(error) / d log(cells) of the
/// positive errors; points = how many were used (the order is 0 with fewer than 2).
ConvergenceOrder fitOrder(const std::vector<double>& cells, const std::vector<double>& errors);

/// A recommended budget: the cheapest setting whose PSD error (BreakageRow::
/// psdError), averaged over the cases, is at most `target`, a multiple of the
/// mean noise floor: 3x fast, 2x balanced, 1x publication (indistinguishable
/// from the finest grid with this many seeds).
struct BreakageBudget {
  std::string name;     ///< "fast", "balanced", "publication"
  double target = 0.0;  ///< PSD error bound, decades
  bool reached = false;
  bool isReference = false;  ///< only the reference itself reached it (not verified beyond the ladder)
  std::string knob;
  double knobValue = 0.0;
  BreakageSetting setting;
  double psdError = 0.0;                                  ///< mean over the cases of the mean over seeds
  double cpuSeconds = 0.0;                                ///< sum over the cases of the mean CPU seconds of a run
  double maxRssMiB = 0.0;                                 ///< largest over the cases
  std::vector<std::pair<std::string, double>> cpuByCase;  ///< mean CPU s per case
};

/// What to run.
struct BreakageOptions {
  int dimension = 2;   ///< 2: the three 2D scenes; 3: the 3D single grain (its own grid ladder)
  bool quick = false;  ///< the short ladder (CI) instead of the full one
  int seeds = 0;       ///< Weibull seeds per setting (0: 2 quick, 6 full)
  int jobs = 2;        ///< runs at once (child processes)
  /// Reuse the finished runs an earlier study left in outDir/runs: a run
  /// whose scene file is this setting's text, whose summary.json exists and
  /// whose measured cost was kept (NAME.cost) is read instead of run again.
  bool resume = false;
  std::string executable;                          ///< the lsdem program that runs the scenes (`lsdem run`)
  std::string outDir = "bench-accuracy-breakage";  ///< runs/ (scenes and their outputs) and the report go here
  /// Called with one line per finished run (progress); may be empty.
  std::function<void(const std::string&)> progress;
};

/// The study's result.
struct BreakageReport {
  int dimension = 2;
  bool quick = false;
  int seeds = 0;
  double wallSeconds = 0.0;  ///< the whole study
  double cpuSeconds = 0.0;   ///< CPU seconds of all its runs
  std::vector<BreakageRun> runs;
  std::vector<BreakageRow> rows;
  std::vector<std::pair<std::string, MeanSpread>> seedNoise;  ///< per case: L1 between the reference runs of two seeds
  std::vector<std::pair<std::string, double>> noiseFloor;     ///< per case: seedNoise mean / sqrt(reference seeds)
  std::vector<ConvergenceOrder> orders;
  std::vector<BreakageBudget> budgets;
  std::vector<std::string> notes;
};

/// @brief Runs every case at every setting and seed, `jobs` child processes at
/// a time, and summarises them (rows, seed noise, orders, budgets).
/// @note Throws std::invalid_argument for an empty executable, seeds < 0 or
/// jobs < 1; std::runtime_error when a run's folder cannot be made. A run that
/// fails is kept with ok = false and its error; the summaries leave it out.
BreakageReport runBreakageStudy(const BreakageOptions& options);

/// @brief Rows, seed noise, orders and budgets from `report.runs` (each
/// run's psdError is filled in against its case's reference run of the same seed).
void summariseBreakage(BreakageReport& report);

/// The files writeBreakageFiles made.
struct BreakageFiles {
  std::string csv;                 ///< breakage_accuracy.csv: one row per setting and case
  std::string runsCsv;             ///< breakage_runs.csv: one row per run (seed)
  std::string markdown;            ///< breakage_accuracy.md: tables, noise, orders, budgets
  std::vector<std::string> plots;  ///< psd_error_vs_time.png, psd_error_vs_cells.png (empty without gnuplot)
};

/// @brief Writes the report's files into `directory` (created if missing).
/// @note Throws std::runtime_error when a file cannot be written.
BreakageFiles writeBreakageFiles(const BreakageReport& report, const std::string& directory);

/// @brief The Markdown report (also the body of breakage_accuracy.md).
std::string breakageMarkdown(const BreakageReport& report);

}  // namespace lsdem::study
