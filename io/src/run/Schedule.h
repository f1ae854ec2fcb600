#pragma once
/// @file Schedule.h
/// @brief When a run records (internal to io): the run's clock at an instant,
/// and one Schedule type for every recorder and for the checkpoints.

#include "lsdem/dynamics/State.h"

#include <cstdint>
#include <vector>

namespace lsdem::io {

/// @brief The run's clock after a step: simulated time, the step count, and
/// `clock`, the one of the two the run counts its end and intervals in
/// (time for a run to a duration, steps for one of a number of steps).
struct Instant {
  double time = 0.0;
  std::uint64_t steps = 0;
  double clock = 0.0;
};

/// @brief The instants a recorder (or the checkpoints) is due at, besides the
/// first and last of a run, which every recorder records: never, every step,
/// every `interval` of the clock, or at listed simulated times.
///
/// A schedule moves past an instant once it has been served (advance), in
/// bounded time however short its interval. Its position (not its interval,
/// which a run computes from its scene) is saved in checkpoints, so a resumed
/// run serves exactly the instants the uninterrupted run serves.
class Schedule {
 public:
  /// Never due.
  Schedule() = default;
  /// Due after every step.
  static Schedule everyStep();
  /// Due every `interval` of the clock (<= 0: never), first at `first`.
  static Schedule every(double interval, double first = 0.0);
  /// Due at these simulated times (ascending), each once.
  static Schedule at(std::vector<double> times);

  /// @brief Whether an instant is due at `now`.
  bool due(const Instant& now) const;
  /// @brief Moves past `now`: the next instant due is after it.
  void advance(const Instant& now);
  /// @brief The interval of the clock (0: not an interval schedule).
  double interval() const { return interval_; }

  void save(dynamics::StateWriter& out) const;
  void load(dynamics::StateReader& in);
  /// @brief Takes the position of `saved` (a schedule load() read from a
  /// checkpoint): the next instant due, not the interval or times.
  void continueFrom(const Schedule& saved) {
    next_ = saved.next_;
    nextTime_ = saved.nextTime_;
  }

 private:
  bool everyStep_ = false;
  double interval_ = 0.0;  // > 0: every this much of the clock
  double first_ = 0.0;     // the first instant; the k-th is first_ + k interval_
  double next_ = 0.0;      // the next clock value due
  std::vector<double> times_;
  std::size_t nextTime_ = 0;  // index into times_
};

}  // namespace lsdem::io
