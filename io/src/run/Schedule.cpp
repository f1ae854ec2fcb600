/// @file Schedule.cpp
/// @brief Schedule (Schedule.h).

#include "run/Schedule.h"

#include <cmath>
#include <limits>

namespace lsdem::io {

Schedule Schedule::everyStep() {
  Schedule s;
  s.everyStep_ = true;
  return s;
}

Schedule Schedule::every(double interval, double first) {
  Schedule s;
  if (interval > 0.0) {
    s.interval_ = interval;
    s.first_ = first;
    s.next_ = first;
  }
  return s;
}

Schedule Schedule::at(std::vector<double> times) {
  Schedule s;
  s.times_ = std::move(times);
  return s;
}

bool Schedule::due(const Instant& now) const {
  if (everyStep_) return true;
  if (interval_ > 0.0 && now.clock >= next_ - 1e-9 * interval_) return true;
  return nextTime_ < times_.size() && now.time >= times_[nextTime_];
}

void Schedule::advance(const Instant& now) {
  while (nextTime_ < times_.size() && now.time >= times_[nextTime_]) ++nextTime_;
  if (!(interval_ > 0.0)) return;
  const double until = now.clock + 1e-9 * interval_;
  if (next_ > until) return;
  // The first instant first + k interval past the clock, computed rather than
  // summed (a sum drifts by a step over 1e5 fractional intervals); an
  // interval far below the clock's step skips the missed instants at once,
  // and one below the clock's rounding moves to just past the clock.
  const double n = first_ + (std::floor((until - first_) / interval_) + 1.0) * interval_;
  next_ = n > until ? n : std::nextafter(until, std::numeric_limits<double>::infinity());
}

void Schedule::save(dynamics::StateWriter& out) const {
  out.put(next_);
  out.put(std::uint64_t(nextTime_));
}

void Schedule::load(dynamics::StateReader& in) {
  next_ = in.get<double>();
  nextTime_ = std::size_t(in.get<std::uint64_t>());
}

}  // namespace lsdem::io
