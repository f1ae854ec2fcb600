/// @file RemovedLog.cpp
/// @brief removed.csv (RemovedLog.h).

#include "run/RemovedLog.h"

#include "NumberText.h"
#include "OutputNames.h"

namespace lsdem::io {

template <int D>
RemovedLog<D>::RemovedLog(const RunContext<D>& context) : Recorder<D>("removed", Schedule::everyStep(), context) {
  file_ = this->addCsv(outputs::kRemoved, "id,time_s,mass_kg,volume,sieve_size_m,reason");
}

template <int D>
void RemovedLog<D>::write(const World& w) {
  for (; written_ < w.removed().size(); ++written_) {
    const dynamics::RemovedParticle& r = w.removed()[written_];
    this->csv(file_).row(std::to_string(r.id) + "," + numberText(r.time) + "," + numberText(r.mass) + "," +
                         numberText(r.volume) + "," + numberText(r.sieveSize) + "," + r.reason);
  }
}

template class RemovedLog<2>;
template class RemovedLog<3>;

}  // namespace lsdem::io
