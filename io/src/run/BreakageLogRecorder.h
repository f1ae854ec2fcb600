#pragma once
/// @file BreakageLogRecorder.h
/// @brief breakage_log.csv (docs/outputs.md, io/BreakageLog.h): a row for
/// every breakage, appended after the step it happened in. Without breakage
/// in the scene the file holds its header only.

#include "run/Recorder.h"

namespace lsdem::io {

template <int D>
class BreakageLogRecorder final : public Recorder<D> {
 public:
  using typename Recorder<D>::World;
  explicit BreakageLogRecorder(const RunContext<D>& context);
  bool recordsChangesOnly() const override { return true; }

 private:
  void write(const World& world) override;
  void onLoad(dynamics::StateReader& in) override { written_ = std::size_t(in.get<std::uint64_t>()); }
  void onSave(dynamics::StateWriter& out) override { out.put(std::uint64_t(written_)); }
  std::size_t file_ = 0;
  std::size_t written_ = 0;  // events of the breakage effect in the file
};

extern template class BreakageLogRecorder<2>;
extern template class BreakageLogRecorder<3>;

}  // namespace lsdem::io
