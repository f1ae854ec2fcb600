#pragma once
/// @file DistributionRecorder.h
/// @brief The size and shape distributions (docs/outputs.md): psd.csv (mass
/// passing against sieve size, eq. 21, fines removed so far included),
/// shape_stats.csv and shape_histograms.csv (circularity / sphericity and
/// aspect ratio of the particles resolved on their grids), and at the end
/// product_psd.csv, the sizes that left through the discharge (or outflow).

#include "run/Recorder.h"

namespace lsdem::io {

template <int D>
class DistributionRecorder final : public Recorder<D> {
 public:
  using typename Recorder<D>::World;
  DistributionRecorder(Schedule schedule, const RunContext<D>& context);

 private:
  void write(const World& world) override;
  void onFinish(const World& world) override;
  std::size_t psd_ = 0, stats_ = 0, histograms_ = 0;
};

extern template class DistributionRecorder<2>;
extern template class DistributionRecorder<3>;

}  // namespace lsdem::io
