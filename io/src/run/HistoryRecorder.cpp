/// @file HistoryRecorder.cpp
/// @brief history.csv (HistoryRecorder.h).

#include "run/HistoryRecorder.h"

#include "NumberText.h"
#include "OutputNames.h"
#include "run/Specimen.h"

#include "lsdem/breakage/Breakage.h"
#include "lsdem/io/RunSummary.h"

#include <cmath>

namespace lsdem::io {

namespace {

template <int D>
std::string historyHeader(const dynamics::World<D>& w, bool specimen) {
  std::string header =
      "step,time_s,dt_s,critical_dt_s,dt_limit_id,dt_limit_generation,dt_limit_diameter_m,dt_limit_nodes,"
      "dt_limit_mass_kg,dt_limit_stiffness_N_per_m,dt_limit_patch_nodes,dt_limit_contact,particles,contacts,breakages,"
      "removed_mass_kg,kinetic_J,elastic_J,gravity_work_J,boundary_work_J,damping_loss_J,contact_loss_J,"
      "split_release_J,energy_error_J";
  const char* axes[3] = {"x", "y", "z"};
  for (const std::string& name : w.planeNames()) {
    for (int a = 0; a < D; ++a) header += "," + name + "_force_" + axes[a] + "_N";
  }
  for (const auto& tool : w.tools()) {
    for (int a = 0; a < D; ++a) header += "," + tool.name + "_force_" + axes[a] + "_N";
    header += "," + tool.name + "_power_W";
  }
  if (specimen) header += ",height_m,stress_Pa,strain,void_ratio";
  return header;
}

}  // namespace

template <int D>
HistoryRecorder<D>::HistoryRecorder(Schedule schedule, const RunContext<D>& context)
    : Recorder<D>("history", std::move(schedule), context) {
  file_ = this->addCsv(outputs::kHistory, historyHeader(*context.sw.world, context.scene.specimen.has_value()));
}

template <int D>
void HistoryRecorder<D>::write(const World& w) {
  const auto num = [](double v) { return numberText(v); };
  const dynamics::EnergyLedger& e = w.energy();
  // What set the time step (a grain still to come has no id: -1).
  const dynamics::TimeStepLimit& lim = stepLimit(w);
  // (With no particle left nothing sets a step: the critical step is
  // infinite, an empty cell, as summary.json's null; not a divergence.)
  const double critical = w.criticalDt();
  std::string row = std::to_string(w.steps()) + "," + num(w.time()) + "," + num(w.dt()) + "," +
                    (std::isinf(critical) && critical > 0.0 ? std::string() : num(critical)) + "," +
                    (lim.id == dynamics::kNoParent ? std::string("-1") : std::to_string(lim.id)) + "," +
                    std::to_string(lim.generation) + "," + num(lim.diameter) + "," + std::to_string(lim.nodes) + "," +
                    num(lim.mass) + "," + num(lim.stiffness) + "," + std::to_string(lim.patchNodes) + "," +
                    limitContactName(w, lim.boundary) + "," + std::to_string(w.particles().size()) + "," +
                    std::to_string(w.contacts().pairContacts().size()) + "," +
                    std::to_string(this->context_.sw.breakage ? this->context_.sw.breakage->breakages() : 0) + "," +
                    num(w.removedMass()) + "," + num(e.kineticTranslational + e.kineticRotational) + "," +
                    num(e.elastic);
  // The budget's other terms need the ledger ([effects] energy_ledger): empty cells without it.
  if (w.def().energyLedger) {
    row += "," + num(e.gravityWork) + "," + num(e.boundaryWork) + "," + num(e.dampingLoss) + "," +
           num(e.contactLoss) + "," + num(e.splitRelease) + "," + num(e.balanceError());
  } else {
    row += ",,,,,,";
  }
  const auto& loads = w.boundaryLoads();
  for (std::size_t k = 0; k < w.planes().size(); ++k) {
    for (int a = 0; a < D; ++a) row += "," + num(k < loads.planeForce.size() ? loads.planeForce[k][a] : 0.0);
  }
  for (std::size_t k = 0; k < w.tools().size(); ++k) {
    const bool have = k < loads.toolForce.size();
    for (int a = 0; a < D; ++a) row += "," + num(have ? loads.toolForce[k][a] : 0.0);
    // Power the tool delivers to the particles (drawn from its drive), W.
    double power = 0.0;
    if (have) {
      power = -loads.toolForce[k].dot(w.toolPoses()[k].velocity) -
              dynamics::Rotation<D>::dot(loads.toolTorque[k], w.toolPoses()[k].angularVelocity);
    }
    row += "," + num(power);
  }
  if (const auto& specimen = this->context_.scene.specimen) {
    const double h = specimenHeight(*specimen, w);
    const double solid = solidVolume(w);
    const double total = h * specimen->width;
    row += "," + num(h) + "," + num(specimenStress(*specimen, w)) + "," +
           num(specimenStrain(this->context_.basis.specimenHeight, h)) + "," +
           num(solid > 0.0 ? (total - solid) / solid : 0.0);
  }
  this->csv(file_).row(row);
}

template class HistoryRecorder<2>;
template class HistoryRecorder<3>;

}  // namespace lsdem::io
