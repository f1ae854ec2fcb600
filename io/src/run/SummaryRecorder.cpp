/// @file SummaryRecorder.cpp
/// @brief summary.json (SummaryRecorder.h).

#include "run/SummaryRecorder.h"

#include "OutputNames.h"

#include "lsdem/breakage/Breakage.h"
#include "lsdem/geometry/Contours.h"
#include "lsdem/io/RunSummary.h"
#include "lsdem/io/Vtk.h"

#include <sstream>

namespace lsdem::io {

namespace {

/// Fragments against their own surfaces (docs/breakage.md): for every
/// fragment (generation > 0) at least [output] shape_min_cells cells of its
/// own grid across, its mass over the material density times the volume
/// its zero level set encloses (as the surfaces output draws it) minus 1;
/// the largest |deviation|, the mean and how many were checked.
template <int D>
void writeFragmentDensity(const dynamics::World<D>& w, double shapeMinCells, JsonWriter& j) {
  const auto& p = w.particles();
  double worst = 0.0, sum = 0.0;
  std::size_t checked = 0, regridded = 0, over3 = 0, worstIndex = 0;
  // On a grid of its own finer than the one it was cut from.
  const auto isRegridded = [](const geometry::Shape<D>& shape) {
    return shape.grid().spacing() < 0.999 * shape.contactSpacing();
  };
  for (std::size_t i = 0; i < p.size(); ++i) {
    const geometry::Shape<D>& shape = *p.shape[i];
    if (isRegridded(shape)) ++regridded;
    if (p.generation[i] == 0) continue;
    if (shape.descriptors().equivalentDiameter < shapeMinCells * shape.grid().spacing()) continue;
    const double enclosed = geometry::enclosedVolume<D>(shape.grid());
    if (!(enclosed > 0.0)) continue;
    // mass = density x the shape's volume (its share of the parent's), so
    // mass / (density x enclosed) - 1 = volume / enclosed - 1.
    const double deviation = shape.volume() / enclosed - 1.0;
    if (std::abs(deviation) >= worst) {
      worst = std::abs(deviation);
      worstIndex = i;
    }
    over3 += std::abs(deviation) > 0.03;
    sum += deviation;
    ++checked;
  }
  j.key("fragments").beginObject()
      .field("regridded", regridded)
      .field("density_checked", checked)
      .field("density_max_abs_deviation", worst)
      .field("density_mean_deviation", checked ? sum / double(checked) : 0.0)
      .field("density_over_3_percent", over3);
  if (checked > 0) {
    // The fragment with the largest deviation: which one, how old, how big.
    const geometry::Shape<D>& shape = *p.shape[worstIndex];
    j.key("density_worst").beginObject()
        .field("id", p.id[worstIndex])
        .field("generation", p.generation[worstIndex])
        .field("diameter", shape.descriptors().equivalentDiameter)
        .field("parent_cells_across", shape.descriptors().equivalentDiameter / shape.contactSpacing())
        .field("regridded", isRegridded(shape))
        .endObject();
  }
  j.endObject();
}

}  // namespace

template <int D>
SummaryRecorder<D>::SummaryRecorder(Schedule schedule, const RunContext<D>& context)
    : Recorder<D>("summary", std::move(schedule), context) {}

template <int D>
void SummaryRecorder<D>::writeSummary(const World& w, bool final) const {
  const RunContext<D>& c = this->context_;
  std::ostringstream s;
  writeRunSummary<D>(w, c.wallSeconds(), s, [&](JsonWriter& j) {
    const double in = c.massIn(), outMass = w.particleMass() + w.removedMass();
    j.field("scene", c.scene.file);
    j.field("stopped_early", (final && c.stopped) || !c.failure.empty());
    // A run that failed (Run.cpp): what stopped it, and where.
    if (!c.failure.empty()) j.field("error", c.failure);
    j.key("mass_balance").beginObject()
        .field("initial", c.basis.initialMass)
        .field("fed", in - c.basis.initialMass)
        .field("particles", w.particleMass())
        .field("removed", w.removedMass())
        .field("relative_error", in > 0.0 ? (outMass - in) / in : 0.0)
        .endObject();
    if (const breakage::Breakage<D>* b = c.sw.breakage) {
      j.key("breakage").beginObject()
          .field("breakages", b->breakages())
          .field("fines_mass", b->finesMass())
          .field("fines_percent", in > 0.0 ? 100.0 * b->finesMass() / in : 0.0)
          .field("raw_volume_error", b->rawVolumeError())
          .field("unsplit_failures", b->unsplitFailures())
          .field("unsplittable", b->unsplittable())
          .field("largest_split_energy_gain", b->largestEnergyGain())
          .field("largest_split_energy_gain_J", b->largestEnergyGainJoules())
          .field("unchecked_splits", b->uncheckedSplits());
      j.key("manual_not_applied").beginArray();
      for (const breakage::ManualBreakNotApplied& n : b->manualNotApplied()) {
        j.beginObject().field("time", n.time).field("particle", n.particle).field("reason", n.reason).endObject();
      }
      j.endArray().endObject();
      if (final) writeFragmentDensity(w, c.scene.output.shapeMinCells, j);
    }
    if (c.ranks.ranks > 1) {
      const RanksSummary& r = c.ranks;
      j.key("parallel").beginObject()
          .field("ranks", r.ranks)
          .field("balance", std::string(r.balanceByTime ? "time" : "nodes"))
          .field("rebalances", static_cast<long long>(r.rebalances))
          .field("migrations", static_cast<long long>(r.migrations))
          .field("all_to_all_exchanges", static_cast<long long>(r.allToAllExchanges))
          .field("bytes_sent_per_step", r.bytesPerStep)
          .field("owned_min", static_cast<long long>(r.ownedMin))
          .field("owned_max", static_cast<long long>(r.ownedMax))
          .field("work_imbalance", r.workImbalance)
          .field("largest_wait_share", r.largestWaitShare)
          .endObject();
    }
  });
  writeFileAtomically(c.out / outputs::kSummary, s.str());
}

template class SummaryRecorder<2>;
template class SummaryRecorder<3>;

}  // namespace lsdem::io
