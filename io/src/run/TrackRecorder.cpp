/// @file TrackRecorder.cpp
/// @brief tracks.csv (TrackRecorder.h).

#include "run/TrackRecorder.h"

#include "NumberText.h"
#include "OutputNames.h"

#include <algorithm>

namespace lsdem::io {

namespace {

// Appends ",v" for every component of a vector (D values) or a spin (1 in 2D, 3 in 3D).
template <int D>
void appendComponents(std::string& row, const dynamics::Vec<D>& v) {
  for (int k = 0; k < D; ++k) {
    row += ',';
    appendNumber(row, v[k]);
  }
}

void appendComponents(std::string& row, double spin) {
  row += ',';
  appendNumber(row, spin);
}

}  // namespace

template <int D>
std::string TrackRecorder<D>::header() {
  // Vector columns x, y (, z); spin columns z in 2D, x, y, z in 3D.
  const auto columns = [](const std::string& prefix, const std::string& unit, bool spin) {
    std::string s;
    const char* axes = (spin && D == 2) ? "z" : (D == 2 ? "xy" : "xyz");
    for (const char* a = axes; *a; ++a) s += "," + prefix + *a + "_" + unit;
    return s;
  };
  return "step,time_s,id" + columns("", "m", false) + columns("v", "m_per_s", false) +
         columns("w", "rad_per_s", true) + columns("f", "N", false) + columns("t", "N_m", true);
}

template <int D>
TrackRecorder<D>::TrackRecorder(Schedule schedule, const RunContext<D>& context)
    : Recorder<D>("tracks", std::move(schedule), context),
      ids_(context.scene.output.track.begin(), context.scene.output.track.end()) {
  std::sort(ids_.begin(), ids_.end());
  ids_.erase(std::unique(ids_.begin(), ids_.end()), ids_.end());
  hints_.assign(ids_.size(), 0);
  file_ = this->addCsv(outputs::kTracks, header());
}

template <int D>
std::size_t TrackRecorder<D>::indexOf(const dynamics::Particles<D>& p, dynamics::ParticleId id, std::size_t& hint) {
  // Particles move in the store only when one is removed (the last fills the
  // hole), so the index of the last record is nearly always still right.
  const std::size_t n = p.id.size();
  if (hint < n && p.id[hint] == id) return hint;
  for (std::size_t i = 0; i < n; ++i) {
    if (p.id[i] == id) return hint = i;
  }
  return n;
}

template <int D>
void TrackRecorder<D>::onFinish(const World& w) {
  const dynamics::ParticleId next = w.particles().nextId();
  std::string never;
  for (const dynamics::ParticleId id : ids_) {
    if (id >= next) never += (never.empty() ? "" : ", ") + std::to_string(id);
  }
  if (!never.empty() && this->context_.note) {
    const std::string given = next > 0 ? "ids given so far: 0 to " + std::to_string(next - 1) : "no ids given";
    this->context_.note("output.track: no particle of this run had the id " + never + " (" + given +
                        "); tracks.csv has no rows for it");
  }
}

template <int D>
void TrackRecorder<D>::write(const World& w) {
  const dynamics::Particles<D>& p = w.particles();
  std::string rows;
  for (std::size_t k = 0; k < ids_.size(); ++k) {
    const std::size_t i = indexOf(p, ids_[k], hints_[k]);
    if (i == p.id.size()) continue;  // not in the world at this instant
    rows += std::to_string(w.steps()) + ",";
    appendNumber(rows, w.time());
    rows += "," + std::to_string(ids_[k]);
    appendComponents<D>(rows, p.position[i]);
    appendComponents<D>(rows, p.velocity[i]);
    if constexpr (D == 2) appendComponents(rows, p.angularVelocity[i]);
    else appendComponents<3>(rows, p.angularVelocity[i]);
    appendComponents<D>(rows, p.force[i]);
    if constexpr (D == 2) appendComponents(rows, p.torque[i]);
    else appendComponents<3>(rows, p.torque[i]);
    rows += '\n';
  }
  if (!rows.empty()) this->csv(file_).write(rows);
}

template class TrackRecorder<2>;
template class TrackRecorder<3>;

}  // namespace lsdem::io
