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

  /// A distributed run whose frames are per-rank pieces (`[output]
  /// frame_pieces = "ranks"`), on `ranks` ranks: record() writes each frame's
  /// indices, after every rank wrote its piece (writePiece). Before create()
  /// or load().
  void usePieces(int ranks) { pieces_ = ranks; }
  /// The number of the frame the next record() writes (the writing process).
  std::size_t nextFrame() const { return writer_ ? writer_->nextFrame() : 0; }
  /// This rank's piece of frame `number`, of the world it steps (every rank
  /// writes its piece of the frame before the writing process's record()).
  void writePiece(const World& part, std::size_t number, int rank);

 private:
  // The grains' stresses and the criterion's measure of `w` into stress_ and stressMeasure_.
  void measure(const World& w);
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
  int pieces_ = 0;               // usePieces
  SurfaceCache<D> pieceCache_;   // the body contours of this rank's pieces
};

extern template class FrameRecorder<2>;
extern template class FrameRecorder<3>;

}  // namespace lsdem::io
