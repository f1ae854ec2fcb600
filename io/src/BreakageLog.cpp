#include "lsdem/io/BreakageLog.h"

#include "NumberText.h"

#include <charconv>
#include <cmath>
#include <string>

namespace lsdem::io {
namespace {

// Values joined by ';' in one CSV cell.
template <class T>
std::string joined(const std::vector<T>& values) {
  std::string s;
  for (std::size_t k = 0; k < values.size(); ++k) {
    if (k) s += ';';
    if constexpr (std::is_floating_point_v<T>) {
      s += numberText(values[k]);
    } else {
      s += std::to_string(values[k]);
    }
  }
  return s;
}

}  // namespace

template <int D>
void writeBreakageLogHeader(std::ostream& out) {
  const std::string unit = D == 2 ? "m2" : "m3";
  out << "time_s,parent_id,child_ids,criterion_value_Pa,strength_Pa,manual,buckling,normal_x,normal_y";
  if (D == 3) out << ",normal_z";
  out << ",plane_offset_m,child_volumes_" << unit << ",fines_volumes_" << unit
      << ",raw_volume_error,parent_mass_kg,fragment_mass_kg,parent_energy_J,fragment_energy_J,energy_gain_J,mode,"
         "chip_depth_m\n";
}

template <int D>
void writeBreakageLogRows(std::span<const breakage::BreakageEvent<D>> events, std::ostream& out) {
  for (const breakage::BreakageEvent<D>& e : events) {
    out << numberText(e.time) << ',' << e.parent << ',' << joined(e.children) << ',' << numberText(e.criterionValue) << ','
        << numberText(e.strength) << ',' << int(e.manual) << ',' << int(e.buckling);
    for (int a = 0; a < D; ++a) out << ',' << numberText(e.planeNormal[a]);
    out << ',' << numberText(e.planeOffset) << ',' << joined(e.childVolumes) << ',' << joined(e.finesVolumes) << ','
        << numberText(e.rawVolumeError) << ',' << numberText(e.parentMass) << ',' << numberText(e.fragmentMass);
    // The energy check (BreakageEvent::energyGain): empty cells when it was not made.
    if (std::isnan(e.parentSpringEnergy)) {
      out << ",,,";
    } else {
      out << ',' << numberText(e.parentKineticEnergy + e.parentSpringEnergy) << ','
          << numberText(e.fragmentKineticEnergy + e.fragmentSpringEnergy) << ',' << numberText(e.energyGain());
    }
    // How it broke, and a chip's depth (empty for the other modes).
    out << ',' << breakage::breakageModeName(e.mode()) << ',';
    if (e.chip) out << numberText(e.chipDepth);
    out << '\n';
  }
}

template void writeBreakageLogHeader<2>(std::ostream&);
template void writeBreakageLogHeader<3>(std::ostream&);
template void writeBreakageLogRows<2>(std::span<const breakage::BreakageEvent<2>>, std::ostream&);
template void writeBreakageLogRows<3>(std::span<const breakage::BreakageEvent<3>>, std::ostream&);

}  // namespace lsdem::io
