#pragma once
/// @file Stability.h
/// @brief The stability suite: hard cases that hunt for numerical instability
/// in contact, integration and breakage, each checked against the same
/// invariants every step. The unit suite (tests/stability) runs the short
/// versions; `lsdem bench stability` runs all of them, short or long.
///
/// What "stable" means (checkInvariants; limits in StabilityLimits):
///   - no NaN or Inf anywhere in the particle state, checked every step;
///   - energy never grows without a source: kinetic + elastic energy now plus
///     what damping, friction and removals took away never exceeds the initial
///     energy plus the work of gravity and of moving planes and tools plus
///     the net kinetic energy breakage added, by more than 1 % of the energy
///     scale (initial energy plus positive work, or the energy now if larger);
///   - after each split the fragments' kinetic energy does not exceed the
///     parent's beyond the split's own inertia error (Split.h: a fragment keeps
///     the parent's spin, so the energy changes by (1/2) w.(I_comb - I_parent) w);
///   - mass: fragments + fines equal the parent to 1e-12 relative, and the
///     particles plus everything removed equal the initial mass to 1e-9 relative
///     over the whole run;
///   - no particle centroid leaves a closed container;
///   - the deepest node overlap stays below a stated fraction of the smaller
///     body's equivalent diameter (a plane or tool counts as infinitely large);
///   - the automatic time step never exceeds the safety fraction of the critical
///     step of the particles present (re-computed independently after every
///     change of the particles, so a new smallest fragment is covered).
///
/// Units: SI throughout (m, kg, s, J); 2D masses and energies are per metre of
/// thickness.

#include "lsdem/dynamics/World.h"

#include <cstddef>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace lsdem::breakage {
template <int D>
class Breakage;
}

namespace lsdem::study {

/// How long a case runs: the short version fits the unit suite (seconds), the
/// long one is the bench (`lsdem bench stability --long`).
enum class CaseLength { Short, Long };

/// The limits checkInvariants() applies (see the file comment).
struct StabilityLimits {
  double energyExcess = 0.01;       ///< energy excess, fraction of the energy scale
  double splitMassError = 1e-12;    ///< |fragments + fines - parent| / parent, per split
  double massError = 1e-9;          ///< |particles + removed - initial| / initial, whole run
  double overlapFraction = 0.1;     ///< deepest node overlap / smaller body's equivalent diameter
  double splitEnergyGain = 1e-12;   ///< allowed fragment KE gain beyond the inertia error, fraction of the parent's KE
};

/// What one case measured. Every field is a maximum or total over the run.
struct StabilityResult {
  std::string name;                   ///< case name
  int dimension = 0;                  ///< 2 or 3
  std::uint64_t steps = 0;            ///< steps run (splitter-only cases: splits tried)
  std::size_t breakages = 0;          ///< splits applied
  std::size_t particles = 0;          ///< particles at the end
  double maxEnergyExcess = 0.0;       ///< max over steps of the energy excess, fraction of the energy scale
  double maxSplitEnergyGain = 0.0;    ///< max over splits of (KE_children - KE_parent - inertia bound) / KE_parent (BreakageEvent::inertiaEnergyBound)
  double maxSplitMassError = 0.0;     ///< max over splits, relative
  double maxMassError = 0.0;          ///< max over steps of the run's mass balance error, relative
  double maxOverlapFraction = 0.0;    ///< deepest overlap / smaller body's equivalent diameter
  std::size_t escaped = 0;            ///< particles found outside the closed container (max over steps)
  std::size_t nonFinite = 0;          ///< steps (or splits) with a NaN or Inf in the state
  std::size_t unsafeDtSteps = 0;      ///< steps whose dt exceeded safety x the critical step of the particles present
  double minDt = std::numeric_limits<double>::infinity();  ///< smallest time step used, s
  double maxDt = 0.0;                 ///< largest time step used, s
  double seconds = 0.0;               ///< wall-clock time of the case, s
  std::size_t minBreakages = 0;       ///< the case needs at least this many splits
  /// The case's stated overlap limit (fraction of the smaller body's
  /// equivalent diameter); 0 takes StabilityLimits::overlapFraction. The
  /// crushing cases (soft contacts for speed, kn = 2e5 N/m per node, small
  /// fragments loaded by a platen or tool) state 0.3.
  double overlapLimit = 0.0;
  std::string note;                   ///< what the case did, in a few words
  std::vector<std::string> violations;  ///< case-specific violations found during the run (copied into failures)
  std::vector<std::string> failures;  ///< one line per violated invariant (filled by checkInvariants)

  /// @brief True when no invariant was violated.
  bool passed() const { return failures.empty(); }
};

/// @brief Compares a result with the limits and records one failure line per
/// violated invariant in `result.failures` (cleared first).
void checkInvariants(StabilityResult& result, const StabilityLimits& limits = {});

/// @brief Watches a world step by step and gathers the invariants of the file
/// comment into a StabilityResult.
///
/// Use: construct after the world is built (particles, walls, effects), then
/// call observe() after every world.step(), and finish() at the end. The
/// per-step cost is one pass over the particles and the node contacts (no
/// allocation once warm), plus a critical-time-step estimate of each new shape
/// whenever the particles change.
template <int D>
class StabilityMonitor {
 public:
  /// @param world the world to watch (kept by reference).
  /// @param breakage the world's breakage effect, or nullptr when none.
  /// @param container the closed container (world frame, m); centroids outside count as escaped.
  StabilityMonitor(const dynamics::World<D>& world, const breakage::Breakage<D>* breakage,
                   std::optional<geometry::Box<D>> container);

  /// @brief Checks the state after one step.
  void observe();
  /// @brief Copies the gathered maxima into `result` (steps, breakages, particles too).
  void finish(StabilityResult& result) const;
  /// @brief True when some non-finite value has been seen (a run should stop).
  bool sawNonFinite() const { return out_.nonFinite > 0; }
  /// @brief The results gathered so far.
  const StabilityResult& current() const { return out_; }

 private:
  /// Re-estimates the critical step when the particles changed; true then.
  bool checkTimeStep();

  const dynamics::World<D>& world_;
  const breakage::Breakage<D>* breakage_;
  std::optional<geometry::Box<D>> container_;
  double initialMass_ = 0.0;
  std::size_t eventsSeen_ = 0;
  std::size_t particleCount_ = 0;
  std::uint64_t lastFirstId_ = 0;
  std::uint64_t lastNextId_ = 0;
  double criticalDt_ = std::numeric_limits<double>::infinity();
  // Effective contact stiffness per live shape (N/m), and scratch.
  struct CachedStiffness {
    const geometry::Shape<D>* shape = nullptr;
    std::weak_ptr<const geometry::Shape<D>> alive;
    double stiffness = 0.0;
  };
  std::vector<CachedStiffness> stiffness_;
  std::vector<double> masses_, stiffnesses_;
  StabilityResult out_;
};

/// One case of the suite.
struct StabilityCase {
  std::string name;                                  ///< e.g. "cascade"
  int dimension = 0;                                 ///< 2 or 3
  std::string description;                           ///< one line
  std::function<StabilityResult(CaseLength)> run;    ///< runs it and checks the invariants
};

/// @brief Every case of the suite, 2D and 3D (see docs/stability.md).
std::vector<StabilityCase> stabilityCases();

// ---- the cases (each runs, fills a result and calls checkInvariants) ----

/// @brief The splitter at its limits, without dynamics: fragments a few cells
/// across and slivers thinner than a cell, grazing cuts, cuts that miss, cuts
/// through a surface node and through the centroid, a concave (U, or in 3D a
/// ring) grain cut into many components, and fracture planes from degenerate
/// contact sets (coincident points, three collinear points in 3D, the
/// centroid alone). Checks volumes, finiteness and the nodes of every fragment.
template <int D>
StabilityResult splitLimitsCase(CaseLength length);

/// @brief A cascade: grains in a closed box crushed by a platen with low,
/// Weibull-scattered strengths, the same lineages splitting down to the
/// minimum size (fines below it). Short: >= 100 (2D) / 40 (3D) breakages;
/// long: >= 1000.
template <int D>
StabilityResult cascadeCase(CaseLength length);

/// @brief Splits while the parent is in hard contact with a wall and with its
/// neighbours (grains pressed by a platen, then broken by manual planes):
/// the fragments start overlapping the others.
template <int D>
StabilityResult splitInContactCase(CaseLength length);

/// @brief Mass ratio 10^4: a heavy grain (10^4 x the density) resting on a
/// layer of light ones under gravity in a closed box.
template <int D>
StabilityResult massRatioCase(CaseLength length);

/// @brief A heavy kinematic tool (a box) crushing a dense bed of breakable grains.
template <int D>
StabilityResult toolCrushCase(CaseLength length);

/// @brief High-speed impact: a breakable grain thrown at 10 x the scene's
/// usual speed into a bed in a closed box.
template <int D>
StabilityResult impactCase(CaseLength length);

/// @brief Grid edges and degenerate inertia: small grains sliding past and off
/// the grid of a large one, nodes that land exactly on grid boundaries, and
/// needle and disc shapes (aspect 10) tumbling in a box.
template <int D>
StabilityResult gridEdgeCase(CaseLength length);

/// @brief A settled packing with breakage enabled run for a long time
/// (long: 10^6 steps in 2D; short: 2 x 10^4).
template <int D>
StabilityResult settledCase(CaseLength length);

// ---- reporting ----

/// @brief One row of the table: case, dim, steps, breakages, energy excess %,
/// mass error, max overlap, min dt, wall time, PASS/FAIL.
std::string stabilityTableHeader();
/// @brief The table row of one result (see stabilityTableHeader()).
std::string stabilityTableRow(const StabilityResult& result);
/// @brief Writes the results as CSV (columns in docs/stability.md) to `out`.
void writeStabilityCsv(const std::vector<StabilityResult>& results, std::ostream& out);

extern template class StabilityMonitor<2>;
extern template class StabilityMonitor<3>;

}  // namespace lsdem::study
