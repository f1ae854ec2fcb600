#include "lsdem/io/RunSummary.h"

#include "lsdem/io/JsonWriter.h"

namespace lsdem::io {
namespace {

// The most recent time-step changes the summary lists (the first is always kept).
constexpr std::size_t kListedStepChanges = 200;

template <int D>
void writeLimit(JsonWriter& w, const dynamics::World<D>& world, const dynamics::TimeStepLimit& l) {
  w.beginObject()
      .field("particle", l.id == dynamics::kNoParent ? -1LL : static_cast<long long>(l.id))
      .field("generation", int(l.generation))
      .field("diameter", l.diameter)
      .field("grid_spacing", l.spacing)
      .field("nodes", static_cast<long long>(l.nodes))
      .field("mass", l.mass)
      .field("density_scale", l.densityScale)
      .field("stiffness", l.stiffness)
      .field("patch_nodes", static_cast<long long>(l.patchNodes))
      .field("contact", limitContactName(world, l.boundary))
      .field("critical_dt", l.criticalDt)
      .endObject();
}

}  // namespace

template <int D>
std::string limitContactName(const dynamics::World<D>& world, std::int32_t boundary) {
  if (boundary < 0) return "particles";
  const std::size_t b = std::size_t(boundary);
  if (b < world.planeNames().size()) return world.planeNames()[b];
  const std::size_t t = b - world.planeNames().size();
  return t < world.tools().size() ? world.tools()[t].name : "?";
}

template <int D>
const dynamics::TimeStepLimit& stepLimit(const dynamics::World<D>& world) {
  const auto& changes = world.timeStepChanges();
  return world.def().dt > 0.0 || changes.empty() ? world.timeStepLimit() : changes.back().limit;
}

template <int D>
void writeRunSummary(const dynamics::World<D>& world, double wallSeconds, std::ostream& out,
                     const std::function<void(JsonWriter&)>& extra) {
  using dynamics::Stage;
  JsonWriter w(out);
  const auto& contacts = world.contacts();
  w.beginObject()
      .field("lsdem_version", std::string(LSDEM_VERSION))
      .field("dimension", D)
      .field("steps", static_cast<long long>(world.steps()))
      .field("simulated_time", world.time())
      .field("dt", world.dt())
      .field("critical_dt", world.criticalDt())
      .field("wall_time", wallSeconds)
      .field("steps_per_second", wallSeconds > 0.0 ? double(world.steps()) / wallSeconds : 0.0)
      .field("particles", world.particles().size())
      .field("contacts", contacts.pairContacts().size())
      .field("node_contacts", contacts.nodeContacts().size())
      .field("node_checks_last_step", static_cast<long long>(contacts.nodeChecks()))
      .field("cell_checks_last_step", static_cast<long long>(contacts.cellChecks()))
      .field("certified_walks_last_step", static_cast<long long>(contacts.certifiedWalks()))
      .field("leaf_walks_last_step", static_cast<long long>(contacts.leafWalks()))
      .field("frontier_walks_last_step", static_cast<long long>(contacts.frontierWalks()));

  // Mass: what is in the world and what left it.
  w.key("mass").beginObject()
      .field("particles", world.particleMass())
      .field("removed", world.removedMass())
      .field("removed_count", world.removed().size())
      .endObject();

  // Energy budget, J.
  // Without the ledger ([effects] energy_ledger = false) only the energy now.
  const dynamics::EnergyLedger& e = world.energy();
  w.key("energy").beginObject()
      .field("kinetic_translational", e.kineticTranslational)
      .field("kinetic_rotational", e.kineticRotational)
      .field("elastic", e.elastic);
  if (world.def().energyLedger) {
    w.field("gravity_work", e.gravityWork)
        .field("boundary_work", e.boundaryWork)
        .field("damping_loss", e.dampingLoss)
        .field("contact_loss", e.contactLoss)
        .field("removed", e.removedEnergy)
        .field("added", e.addedEnergy)
        .field("split_release", e.splitRelease)
        .field("initial", e.initial)
        .field("balance_error", e.balanceError())
        .field("relative_balance_error", e.relativeBalanceError());
  }
  w.endObject();

  // The time step over the run and what limited it.
  const auto& changes = world.timeStepChanges();
  // The step the first step took: the last of the changes made before it
  // (the set-up may change it several times at the start, as grains are
  // placed).
  double first = world.dt();
  for (const dynamics::TimeStepChange& c : changes) {
    if (c.time > changes.front().time) break;
    first = c.dt;
  }
  w.key("time_step").beginObject()
      .field("automatic", !(world.def().dt > 0.0))
      .field("safety", world.def().dtSafety)
      .field("first", first)
      .field("now", world.dt())
      .field("changes", changes.size());
  w.key("limit");
  writeLimit(w, world, stepLimit(world));
  w.key("history").beginArray();
  const std::size_t from = changes.size() > kListedStepChanges ? changes.size() - kListedStepChanges : 0;
  for (std::size_t k = 0; k < changes.size(); ++k) {
    if (k != 0 && k < from) continue;
    w.beginObject().field("time", changes[k].time).field("dt", changes[k].dt).key("limit");
    writeLimit(w, world, changes[k].limit);
    w.endObject();
  }
  w.endArray();
  w.endObject();

  // Density scaling of small fragments, when the scene asked for it.
  if (const auto& ds = world.def().densityScaling) {
    double extra = 0.0, truth = 0.0;
    std::size_t scaledNow = 0;
    for (std::size_t i = 0; i < world.particles().size(); ++i) {
      const double m = world.unscaledMass(i);
      truth += m;
      extra += world.particles().mass[i] - m;
      scaledNow += world.densityScale(i) > 1.0;
    }
    const dynamics::DensityScalingStats& st = world.densityScaling();
    w.key("density_scaling").beginObject()
        .field("below_diameter", ds->belowDiameter)
        .field("max_factor", ds->maxFactor)
        .field("fragments_scaled", static_cast<long long>(st.scaled))
        .field("fragments_capped", static_cast<long long>(st.capped))
        .field("largest_factor", st.largestFactor)
        .field("particles_scaled_now", scaledNow)
        .field("added_mass_now", extra)
        .field("added_mass_fraction_now", truth > 0.0 ? extra / truth : 0.0)
        .endObject();
  }

  // Effects that ran and where the time went.
  w.key("effects").beginArray();
  const std::vector<std::string> names = world.effectNames();
  for (std::size_t k = 0; k < names.size(); ++k) {
    w.beginObject().field("name", names[k]).field("seconds", world.effectSeconds()[k]).endObject();
  }
  w.endArray();
  w.key("stage_seconds").beginObject();
  for (std::size_t s = 0; s < std::size_t(Stage::Count); ++s) {
    w.field(dynamics::stageName(Stage(s)), world.stageSeconds()[s]);
  }
  w.endObject();
  if (extra) extra(w);
  w.endObject();
}

template std::string limitContactName<2>(const dynamics::World<2>&, std::int32_t);
template std::string limitContactName<3>(const dynamics::World<3>&, std::int32_t);
template const dynamics::TimeStepLimit& stepLimit<2>(const dynamics::World<2>&);
template const dynamics::TimeStepLimit& stepLimit<3>(const dynamics::World<3>&);
template void writeRunSummary<2>(const dynamics::World<2>&, double, std::ostream&,
                                 const std::function<void(JsonWriter&)>&);
template void writeRunSummary<3>(const dynamics::World<3>&, double, std::ostream&,
                                 const std::function<void(JsonWriter&)>&);

}  // namespace lsdem::io
