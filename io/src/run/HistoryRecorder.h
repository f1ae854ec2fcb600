#pragma once
/// @file HistoryRecorder.h
/// @brief history.csv (docs/outputs.md): one row per record of the step, time
/// step and its limit, counts, energy budget, the loads on every plane and
/// tool, and the specimen's height, stress, strain and void ratio.

#include "run/Recorder.h"

namespace lsdem::io {

template <int D>
class HistoryRecorder final : public Recorder<D> {
 public:
  using typename Recorder<D>::World;
  /// `rows` of the scene's `history_rows` spread over the run by `schedule`.
  HistoryRecorder(Schedule schedule, const RunContext<D>& context);

 private:
  void write(const World& world) override;
  std::size_t file_ = 0;
};

extern template class HistoryRecorder<2>;
extern template class HistoryRecorder<3>;

}  // namespace lsdem::io
