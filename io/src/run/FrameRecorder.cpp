/// @file FrameRecorder.cpp
/// @brief The ParaView series (FrameRecorder.h).

#include "run/FrameRecorder.h"

#include "lsdem/breakage/GrainStress.h"

namespace lsdem::io {

template <int D>
FrameRecorder<D>::FrameRecorder(Schedule schedule, const RunContext<D>& context)
    : Recorder<D>("frames", std::move(schedule), context) {
  breakage::CriterionDef def;
  if (context.scene.breakage) def = context.scene.breakage->criterion;
  criterion_ = breakage::makeCriterion(def);
}

template <int D>
FrameWriterDef<D> FrameRecorder<D>::writerDef(bool resume) const {
  const SceneDef<D>& scene = this->context_.scene;
  FrameWriterDef<D> def;
  def.directory = this->context_.out;
  def.encoding = scene.output.vtkFormat;
  def.particles = scene.output.particles;
  def.surfaces = scene.output.surfaces;
  def.boundaries = scene.output.boundaries;
  def.contacts = scene.output.contacts;
  if (scene.domain) def.extent = *scene.domain;
  def.resume = resume;
  def.pieces = pieces_;
  return def;
}

template <int D>
void FrameRecorder<D>::onCreate() {
  writer_.emplace(writerDef(false));
}

// The series are read (and refused when damaged) now; the frames after the
// checkpoint are dropped in onReopen.
template <int D>
void FrameRecorder<D>::onLoad(dynamics::StateReader& in) {
  lastFrameTime_ = in.get<double>();
  writer_.emplace(writerDef(true));
}

template <int D>
void FrameRecorder<D>::onReopen() {
  writer_->truncateAfter(lastFrameTime_);
}

template <int D>
void FrameRecorder<D>::onSave(dynamics::StateWriter& out) {
  out.put(lastFrameTime_);
}

template <int D>
void FrameRecorder<D>::write(const World& w) {
  // Like the CSV rows, a frame holds finite numbers only.
  const auto& p = w.particles();
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!p.position[i].allFinite() || !p.velocity[i].allFinite()) {
      throw std::runtime_error("frame at step " + std::to_string(w.steps()) + ": particle " + std::to_string(p.id[i]) +
                               " has a non-finite position or velocity: the simulation diverged; the run stops here");
    }
  }
  // (In pieces, the ranks' pieces hold the particles: this writes their index.)
  if (pieces_ > 0) {
    writer_->write(w);
  } else {
    measure(w);
    writer_->write(w, stressMeasure_, stress_);
  }
  lastFrameTime_ = w.time();
}

template <int D>
void FrameRecorder<D>::measure(const World& w) {
  // Contacts are read only while they describe the particles: not right
  // after a breakage or removal, when the frame shows zero stresses.
  const auto& p = w.particles();
  frameStresses(w, stress_);
  stressMeasure_.assign(p.size(), 0.0);
  for (std::size_t i = 0; w.contactsCurrent() && i < p.size(); ++i) {
    stressMeasure_[i] = criterion_->characteristicStress(breakage::principalStressTriple<D>(stress_[i]));
  }
}

template <int D>
void FrameRecorder<D>::writePiece(const World& part, std::size_t number, int rank) {
  measure(part);
  const auto layouts = writeFramePieces<D>(writerDef(false), number, rank, part, pieceCache_, stressMeasure_, stress_);
  if (writer_) writer_->setPieceLayouts(layouts);
}

template class FrameRecorder<2>;
template class FrameRecorder<3>;

}  // namespace lsdem::io
