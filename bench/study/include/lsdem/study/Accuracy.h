#pragma once
/// @file Accuracy.h
/// @brief The accuracy-versus-cost study behind `lsdem bench accuracy`: sweeps
/// the knobs that trade accuracy for time (grid cells across a grain, surface
/// nodes per cell length, the force formulation, the time-step fraction of the
/// critical step) and measures, against exact answers, the mass properties,
/// contact forces, restitution, spherical-cap splits and a small settled
/// packing, together with the cost of each setting (time per step, node checks
/// per step, split time, memory per particle).
///
/// Knobs are swept one at a time about a baseline (AccuracySetting's defaults:
/// 10 cells across, 1 node per cell, area-weighted law, 0.2 of the critical
/// step). The per-node law is swept over the same node densities as its own
/// knob, so the growth of its total stiffness with node density is visible
/// next to the area-weighted law's constant one. Grids store floats only:
/// there is no double-precision grid to compare against.
///
/// Every measurement is a pure function of its setting (fixed seeds, fixed
/// orientation sequences), so the errors are reproducible; only the timings
/// vary between machines. Costs are CPU seconds of the measuring thread
/// (CLOCK_THREAD_CPUTIME_ID) with the timed code run on one OpenMP thread,
/// medians of repeats: other programs running on the machine at the same time
/// take wall time from the study but hardly change these figures.
///
/// Units: the study's grains have a diameter of 1 m (mass properties, contact
/// forces, splits) or 1 cm (restitution at 1 m/s, overlaps ~5% of the
/// radius; the packing, 25x softer, overlaps ~1% of a diameter under its
/// weight); errors are relative (dimensionless)
/// unless a metric says otherwise.

#include "lsdem/dynamics/ContactLaw.h"

#include <functional>
#include <string>
#include <vector>

namespace lsdem::study {

/// One configuration of the knobs.
struct AccuracySetting {
  double cellsAcross = 10.0;  ///< grid cells across a grain's smallest dimension (diameter of the sphere)
  double nodesPerCell = 1.0;  ///< surface nodes per cell length (the paper's pts/pix)
  dynamics::ForceFormulation formulation = dynamics::ForceFormulation::AreaWeighted;  ///< linear law's formulation
  double dtFraction = 0.2;    ///< time step as a fraction of the critical step (WorldDef::dtSafety)
  /// The narrow phase's look-up in the other body's level set (ContactLawDef::interpolation).
  dynamics::LevelSetInterpolation interpolation = dynamics::LevelSetInterpolation::Trilinear;
  /// Surface nodes on the exact surface of the sphere / random grain
  /// (ShapeDef::exactNodes), or on the grid's multilinear zero set.
  bool exactNodes = true;
};

/// @brief The knob's CSV name of a formulation: "per_node" or "area_weighted".
const char* formulationName(dynamics::ForceFormulation formulation);
/// @brief The CSV name of an interpolation: "trilinear" or "tricubic".
const char* interpolationName(dynamics::LevelSetInterpolation interpolation);

/// One measured quantity of one setting, against its reference.
struct MetricValue {
  std::string metric;      ///< metric name (docs/accuracy.md lists them)
  double value = 0.0;      ///< measured value
  double reference = 0.0;  ///< exact value, or the finest setting's value
  double error = 0.0;      ///< relative error |value - reference| / |reference| (absolute where the reference is 0)
};

/// The cost of one setting, measured on the packing run and the sphere split.
/// Times are CPU seconds of one thread (the timed code runs single-threaded).
struct AccuracyCost {
  double stepSeconds = 0.0;        ///< CPU seconds per packing step on 1 thread (median over blocks of 50 steps)
  double runSeconds = 0.0;         ///< stepSeconds x steps the packing needs for its fixed simulated time, CPU s
  double nodeChecksPerStep = 0.0;  ///< nodes tested against a level set or plane per step (packing, mean)
  double splitSeconds = 0.0;       ///< CPU seconds of one sphere split on 1 thread (median of repeats)
  double bytesPerParticle = 0.0;   ///< Shape::bytes() of a grain + the particle store's bytes per particle
  double steps = 0.0;              ///< steps of the packing run
};

/// One row of the study: a knob setting, a metric, and the cost of the setting.
struct AccuracyPoint {
  /// "cells", "cells_tricubic" (the cells sweep with the tricubic look-up),
  /// "cells_grid_nodes" (the cells sweep with nodes on the grid's zero set),
  /// "nodes_per_cell", "nodes_per_cell_per_node", "dt_fraction"
  std::string knob;
  double setting = 0.0;     ///< the knob's value in this row
  AccuracySetting config;   ///< the full configuration
  MetricValue metric;
  AccuracyCost cost;
};

/// The cheapest setting that reaches a target error for one metric.
struct ParetoChoice {
  std::string metric;
  double target = 0.0;      ///< relative error to reach
  bool reached = false;     ///< false: no setting of the sweep reaches it
  std::string knob;         ///< the cheapest setting's knob ...
  double setting = 0.0;     ///< ... and value
  AccuracySetting config;   ///< its full configuration
  double error = 0.0;       ///< its error
  double runSeconds = 0.0;  ///< its cost (AccuracyCost::runSeconds)
};

/// What to run.
struct AccuracyOptions {
  int dimension = 3;   ///< 2 or 3
  bool quick = false;  ///< short sweep (under two minutes on 2 cores) instead of the full one
  /// Called with one line per finished stage (progress report); may be empty.
  std::function<void(const std::string&)> progress;
};

/// The study's result.
struct AccuracyReport {
  int dimension = 3;
  bool quick = false;
  double wallSeconds = 0.0;              ///< the whole study, wall clock
  double cpuSeconds = 0.0;               ///< the whole study, CPU seconds of all its threads
  std::vector<AccuracyPoint> points;     ///< every (setting, metric) row
  std::vector<ParetoChoice> pareto;      ///< per metric and target (1%, 0.1%)
  std::vector<std::string> notes;        ///< notes for the table (references used, what is not offered)
};

/// @brief CPU seconds used so far by the calling thread
/// (clock_gettime(CLOCK_THREAD_CPUTIME_ID)); differences time code on that
/// thread whatever else runs on the machine.
double threadCpuSeconds();

/// @brief CPU seconds used so far by the whole process, all threads
/// (clock_gettime(CLOCK_PROCESS_CPUTIME_ID)).
double processCpuSeconds();

/// @brief While alive, OpenMP parallel regions started by the constructing
/// thread run on one thread (omp_set_num_threads(1)); the destructor restores
/// the previous count. Results do not change (lsdem is bitwise identical for
/// any thread count); only the timing becomes a one-thread CPU time.
/// Without OpenMP it does nothing.
class SingleThreadScope {
 public:
  SingleThreadScope();
  ~SingleThreadScope();
  SingleThreadScope(const SingleThreadScope&) = delete;
  SingleThreadScope& operator=(const SingleThreadScope&) = delete;

 private:
  int previousThreads_ = 1;  ///< omp_get_max_threads() before the scope
};

/// @brief Runs the sweep of `options` and returns every point and the Pareto choices.
/// The distinct configurations are measured on two worker threads, each with
/// its OpenMP regions on one thread (SingleThreadScope); the results do not
/// depend on that (every measurement is a pure function of its setting), and
/// the progress lines arrive in the order the settings finish.
/// @note Throws std::invalid_argument for a dimension other than 2 or 3; an
/// exception thrown by a measurement is rethrown after the workers have stopped.
AccuracyReport runAccuracyStudy(const AccuracyOptions& options);

/// @brief For each metric and target error, the setting with the smallest
/// AccuracyCost::runSeconds whose error is at most the target.
std::vector<ParetoChoice> paretoFront(const std::vector<AccuracyPoint>& points, const std::vector<double>& targets);

/// @brief The Pareto choices as printable lines: metric, target, the
/// cheapest configuration (cells, nodes per cell, law, dt fraction), its error
/// and its packing run's CPU seconds.
std::string paretoText(const std::vector<ParetoChoice>& choices);

// ---- the measurements (each a pure function of its setting) ----

/// @brief Mass properties against exact answers: volume, centroid and
/// principal inertia of a sphere (circle) of diameter 1 m and of an ellipsoid
/// (ellipse) of semi-axes 0.5, 0.35[, 0.25] m, each from
/// geometry::massProperties of its grid (eq. 24-30, extrapolated estimator), and
/// of a random grain (equivalent diameter 1 m) against the same grain at
/// `referenceCells`. Centroid errors are |c - c_ref| / diameter.
/// @param cellsAcross grid cells across the smallest dimension, > 2.
/// @param referenceCells cells of the random grain's reference grid.
template <int D>
std::vector<MetricValue> massMetrics(double cellsAcross, double referenceCells);

/// @brief Normal contact force of a sphere (circle) of diameter 1 m on a plane
/// and of two such spheres, at overlap 2% of the radius, averaged over 32
/// orientations, against the linear law integrated over the exact surfaces:
/// F_ref = (kn / w) int delta (n . e) dA, with w = w_ref (referenceNodeWeight)
/// for the area-weighted law and the mean node weight for the per-node law;
/// plus the ripple (max - min) / mean over those orientations (the contact
/// sliding across nodes) and the stiffness ratio F / F_ref(w_ref), which stays
/// at 1 for the area-weighted law and grows like nodesPerCell^(D-1) for the
/// per-node law.
template <int D>
std::vector<MetricValue> contactMetrics(const AccuracySetting& setting);

/// @brief Coefficient of restitution of a sphere (circle) of diameter 1 cm
/// striking a plane at 1 m/s (no gravity, no friction), with the contact
/// damping set for e = 0.5 (dampingRatioForRestitution), against 0.5.
template <int D>
std::vector<MetricValue> restitutionMetrics(const AccuracySetting& setting);

/// @brief A sphere (circle) of radius 0.5 m split by the plane y = 0.15 m
/// (breakage::splitShape): the corrected volumes and the centroids of the two
/// pieces against the exact spherical caps (circular segments), and the mass
/// balance of the split before correction (SplitResult::rawRelativeError).
/// @param splitSeconds receives the median CPU time of one split on one thread, s.
template <int D>
std::vector<MetricValue> splitMetrics(const AccuracySetting& setting, double& splitSeconds);

/// The outcome of one packing run.
struct PackingResult {
  double floorStress = 0.0;   ///< floor normal force / floor area (Pa; N/m per metre of thickness in 2D)
  double coordination = 0.0;  ///< 2 x touching particle pairs / particles
  double loadBalance = 0.0;   ///< |vertical wall load - weight| / weight at the end (0 when at rest)
  double kineticRatio = 0.0;  ///< kinetic energy at the end / potential energy released
  AccuracyCost cost;          ///< step time, node checks, memory (splitSeconds left 0)
};

/// @brief A fixed small packing settled by gravity in a box of planes:
/// `grains` random grains (equivalent diameters 0.8-1.2 cm, 8 distinct
/// shapes) dropped from a loose lattice and run for a fixed simulated time,
/// the top layer's fall time 2 sqrt(2 H / g) plus `settleSeconds`. The run is
/// single-threaded and its cost is the thread's CPU time (AccuracyCost).
/// @param grains number of grains, >= 1.
/// @param settleSeconds simulated settling time after the fall, s, >= 0.
/// @note Throws std::invalid_argument for grains < 1 or a negative settling time.
template <int D>
PackingResult packingRun(const AccuracySetting& setting, int grains, double settleSeconds = 0.1);

/// The files writeAccuracyFiles made.
struct AccuracyFiles {
  std::string csv;                 ///< accuracy.csv
  std::string markdown;            ///< accuracy.md
  /// error_vs_time_<metric>.png, stiffness_vs_nodes_per_cell.png and
  /// error_vs_cells.png (empty without gnuplot)
  std::vector<std::string> plots;
  std::vector<std::string> skippedPlots;  ///< metrics not plotted (no positive error to draw on a log axis)
};

/// @brief Writes accuracy.csv (one row per point, long format), accuracy.md
/// (the table, notes and Pareto choices) and, when gnuplot is installed,
/// error_vs_time_<metric>.png (log-log, one curve per knob), the stiffness
/// ratio against nodes per cell for both laws (stiffness_vs_nodes_per_cell.png)
/// and the errors against cells across (error_vs_cells.png) into `directory`
/// (created if missing). Each file is written to a temporary name and renamed.
/// @note Throws std::runtime_error when a file cannot be written.
AccuracyFiles writeAccuracyFiles(const AccuracyReport& report, const std::string& directory);

/// @brief The Markdown table of the report (also the body of accuracy.md).
std::string accuracyMarkdown(const AccuracyReport& report);

}  // namespace lsdem::study
