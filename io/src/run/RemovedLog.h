#pragma once
/// @file RemovedLog.h
/// @brief removed.csv (docs/outputs.md): a row for every particle that left
/// the run (outflow, discharge, fines), appended after the step it left in.

#include "run/Recorder.h"

namespace lsdem::io {

template <int D>
class RemovedLog final : public Recorder<D> {
 public:
  using typename Recorder<D>::World;
  explicit RemovedLog(const RunContext<D>& context);
  bool recordsChangesOnly() const override { return true; }

 private:
  void write(const World& world) override;
  void onLoad(dynamics::StateReader& in) override { written_ = std::size_t(in.get<std::uint64_t>()); }
  void onSave(dynamics::StateWriter& out) override { out.put(std::uint64_t(written_)); }
  std::size_t file_ = 0;
  std::size_t written_ = 0;  // records of World::removed() in the file
};

extern template class RemovedLog<2>;
extern template class RemovedLog<3>;

}  // namespace lsdem::io
