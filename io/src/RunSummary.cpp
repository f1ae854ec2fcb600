#include "lsdem/io/RunSummary.h"

#include "lsdem/io/JsonWriter.h"

namespace lsdem::io {

template <int D>
void writeRunSummary(const dynamics::World<D>& world, double wallSeconds, std::ostream& out,
                     const std::function<void(JsonWriter&)>& extra) {
  using dynamics::Stage;
  JsonWriter w(out);
  const auto& contacts = world.contacts();
  w.beginObject()
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
      .field("node_checks_last_step", static_cast<long long>(contacts.nodeChecks()));

  // What limits the time step: the particle with the smallest sqrt(m / k).
  {
    const std::size_t i = world.stepLimitingParticle();
    const auto& p = world.particles();
    w.key("dt_limit").beginObject();
    if (i < p.size()) {
      const geometry::Shape<D>& shape = *p.shape[i];
      w.field("particle", static_cast<long long>(p.id[i]))
          .field("generation", static_cast<long long>(p.generation[i]))
          .field("mass", p.mass[i])
          .field("stiffness", world.particleStiffness(i))
          .field("equivalent_diameter", shape.descriptors().equivalentDiameter)
          .field("cells_across", shape.descriptors().equivalentDiameter / shape.grid().spacing())
          .field("surface_nodes", shape.nodes().size());
    }
    w.endObject();
  }

  // Mass: what is in the world and what left it.
  w.key("mass").beginObject()
      .field("particles", world.particleMass())
      .field("removed", world.removedMass())
      .field("removed_count", world.removed().size())
      .endObject();

  // Energy budget, J.
  const dynamics::EnergyLedger& e = world.energy();
  w.key("energy").beginObject()
      .field("kinetic_translational", e.kineticTranslational)
      .field("kinetic_rotational", e.kineticRotational)
      .field("elastic", e.elastic)
      .field("gravity_work", e.gravityWork)
      .field("boundary_work", e.boundaryWork)
      .field("damping_loss", e.dampingLoss)
      .field("contact_loss", e.contactLoss)
      .field("removed", e.removedEnergy)
      .field("added", e.addedEnergy)
      .field("split_release", e.splitRelease)
      .field("initial", e.initial)
      .field("balance_error", e.balanceError())
      .field("relative_balance_error", e.relativeBalanceError())
      .endObject();

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

template void writeRunSummary<2>(const dynamics::World<2>&, double, std::ostream&,
                                 const std::function<void(JsonWriter&)>&);
template void writeRunSummary<3>(const dynamics::World<3>&, double, std::ostream&,
                                 const std::function<void(JsonWriter&)>&);

}  // namespace lsdem::io
