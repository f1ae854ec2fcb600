#pragma once
/// @file FrameRecorder.h
/// @brief The ParaView series (docs/outputs.md, docs/paraview.md): a frame of
/// every series the scene's `[output] vtk` names, with each particle's stress
/// measure (the breakage criterion's characteristic stress; von Mises without
/// breakage).

#include "run/Recorder.h"

#include "lsdem/breakage/Criteria.h"
#include "lsdem/io/Vtk.h"

#include <memory>
#include <optional>

namespace lsdem::io {

template <int D>
class FrameRecorder final : public Recorder<D> {
 public:
  using typename Recorder<D>::World;
  FrameRecorder(Schedule schedule, const RunContext<D>& context);

 private:
  void write(const World& world) override;
  void onCreate() override;
  void onLoad(dynamics::StateReader& in) override;
  void onReopen() override;
  void onSave(dynamics::StateWriter& out) override;
  FrameWriterDef<D> writerDef(bool resume) const;

  std::optional<FrameWriter<D>> writer_;
  std::unique_ptr<breakage::Criterion> criterion_;
  std::vector<geometry::Mat<D>> stress_;
  std::vector<double> stressMeasure_;
  double lastFrameTime_ = -1.0;  // simulated time of the last frame, s
};

extern template class FrameRecorder<2>;
extern template class FrameRecorder<3>;

}  // namespace lsdem::io
