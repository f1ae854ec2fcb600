#pragma once
/// @file TrackRecorder.h
/// @brief tracks.csv (docs/outputs.md): the trajectory of chosen particles,
/// `[output] track = [ids]`: one row per tracked particle per record with its
/// position, velocity, angular velocity, and the force and torque on it at
/// the end of the step.

#include "run/Recorder.h"

#include "lsdem/dynamics/Particles.h"

#include <vector>

namespace lsdem::io {

template <int D>
class TrackRecorder final : public Recorder<D> {
 public:
  using typename Recorder<D>::World;
  /// Tracks the particles of the scene's `track` ids at the instants of `schedule`.
  TrackRecorder(Schedule schedule, const RunContext<D>& context);

  /// The header of tracks.csv in dimension D.
  static std::string header();

 private:
  void write(const World& world) override;
  // The ids no particle of the run ever had (at or above the next id): said.
  void onFinish(const World& world) override;
  /// Index of particle `id` now, or the particle count when it is not in the
  /// world (not yet fed, broken, removed); `hint` is where it was last.
  static std::size_t indexOf(const dynamics::Particles<D>& p, dynamics::ParticleId id, std::size_t& hint);

  std::size_t file_ = 0;
  std::vector<dynamics::ParticleId> ids_;  // ascending
  std::vector<std::size_t> hints_;         // per id: its index at the last record
};

extern template class TrackRecorder<2>;
extern template class TrackRecorder<3>;

}  // namespace lsdem::io
