#pragma once
/// @file SummaryRecorder.h
/// @brief summary.json (docs/outputs.md): kept current with the frames and
/// checkpoints, and written once more at the end, with whether the run
/// stopped early and (with breakage) the fragments' density check.

#include "run/Recorder.h"

namespace lsdem::io {

template <int D>
class SummaryRecorder final : public Recorder<D> {
 public:
  using typename Recorder<D>::World;
  SummaryRecorder(Schedule schedule, const RunContext<D>& context);

 private:
  void write(const World& world) override { writeSummary(world, false); }
  void onFinish(const World& world) override { writeSummary(world, true); }
  void writeSummary(const World& world, bool final) const;
};

extern template class SummaryRecorder<2>;
extern template class SummaryRecorder<3>;

}  // namespace lsdem::io
