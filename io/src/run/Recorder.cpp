/// @file Recorder.cpp
/// @brief The recorders' common part: files, schedule, state (Recorder.h).

#include "run/Recorder.h"

#include "lsdem/io/InputError.h"

namespace lsdem::io {

template <int D>
double RunContext<D>::massIn() const {
  double fed = 0.0;
  for (const auto* f : sw.feeds) fed += f->droppedMass();
  return basis.initialMass + fed;
}

template <int D>
double RunContext<D>::wallSeconds() const {
  return wallBefore + std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
}

template <int D>
Recorder<D>::Recorder(std::string name, Schedule schedule, const RunContext<D>& context)
    : context_(context), name_(std::move(name)), schedule_(std::move(schedule)) {}

template <int D>
std::size_t Recorder<D>::addCsv(std::string file, std::string header) {
  csv_.push_back(Csv{std::move(file), std::move(header), 0, {}});
  return csv_.size() - 1;
}

template <int D>
void Recorder<D>::create() {
  for (Csv& c : csv_) c.file.create(context_.out / c.name, c.header);
  onCreate();
}

template <int D>
void Recorder<D>::loadSchedule(dynamics::StateReader& in) {
  schedule_.load(in);
}

template <int D>
void Recorder<D>::load(dynamics::StateReader& in) {
  schedule_.load(in);
  lastClock_ = in.get<double>();
  const std::uint64_t files = in.get<std::uint64_t>();
  if (files != csv_.size()) {
    throw std::runtime_error("recorder '" + name_ + "' saved " + std::to_string(files) + " files, writes " +
                             std::to_string(csv_.size()));
  }
  for (Csv& c : csv_) {
    const std::string saved = in.getString();
    if (saved != c.name) throw std::runtime_error("recorder '" + name_ + "' saved " + saved + ", writes " + c.name);
    const std::uint64_t size = in.get<std::uint64_t>();
    c.kept = keptCsvSize(context_.out / c.name, size, c.header);
    if (c.kept < size && context_.note) {
      context_.note((context_.out / c.name).string() + ": cut short of the " + std::to_string(size) +
                    " bytes the checkpoint saw (a kill, a full disk or a crash): continued after its last whole "
                    "row, at byte " + std::to_string(c.kept) + "; the rows between are missing");
    }
  }
  onLoad(in);
}

template <int D>
void Recorder<D>::reopen() {
  for (Csv& c : csv_) c.file.resume(context_.out / c.name, c.header, c.kept);
  onReopen();
}

template <int D>
void Recorder<D>::save(dynamics::StateWriter& out) {
  schedule_.save(out);
  out.put(lastClock_);
  out.put(std::uint64_t(csv_.size()));
  for (Csv& c : csv_) {
    out.putString(c.name);
    out.put(c.file.size());
  }
  onSave(out);
}

template <int D>
void Recorder<D>::record(const World& world, const Instant& now) {
  write(world);
  lastClock_ = now.clock;
}

template <int D>
void Recorder<D>::finish(const World& world, const Instant& now) {
  if (lastClock_ != now.clock) record(world, now);
  onFinish(world);
}

template struct RunContext<2>;
template struct RunContext<3>;
template class Recorder<2>;
template class Recorder<3>;

}  // namespace lsdem::io
