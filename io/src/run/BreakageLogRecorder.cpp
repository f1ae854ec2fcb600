/// @file BreakageLogRecorder.cpp
/// @brief breakage_log.csv (BreakageLogRecorder.h).

#include "run/BreakageLogRecorder.h"

#include "OutputNames.h"

#include "lsdem/breakage/Breakage.h"
#include "lsdem/io/BreakageLog.h"

#include <sstream>

namespace lsdem::io {

namespace {

template <int D>
std::string breakageLogHeader() {
  std::ostringstream h;
  writeBreakageLogHeader<D>(h);
  std::string s = h.str();
  if (!s.empty() && s.back() == '\n') s.pop_back();
  return s;
}

}  // namespace

template <int D>
BreakageLogRecorder<D>::BreakageLogRecorder(const RunContext<D>& context)
    : Recorder<D>("breakage_log", Schedule::everyStep(), context) {
  file_ = this->addCsv(outputs::kBreakageLog, breakageLogHeader<D>());
}

template <int D>
void BreakageLogRecorder<D>::write(const World&) {
  const breakage::Breakage<D>* b = this->context_.sw.breakage;
  if (!b || written_ >= b->events().size()) return;
  std::ostringstream rows;
  writeBreakageLogRows<D>(std::span(b->events()).subspan(written_), rows);
  this->csv(file_).write(rows.str());
  written_ = b->events().size();
}

template class BreakageLogRecorder<2>;
template class BreakageLogRecorder<3>;

}  // namespace lsdem::io
