#include "lsdem/parallel/DistributedRun.h"

#include "lsdem/io/Scene.h"

#include <stdexcept>
#include <string>

namespace lsdem::parallel {
namespace {

constexpr int kRoot = 0;

// Gives `to` the state of `from` (an effect built from the same definition).
template <class Effect>
void copyState(const Effect& from, Effect& to) {
  dynamics::StateWriter w;
  from.saveState(w);
  dynamics::StateReader r(w.bytes().data(), w.bytes().size());
  to.loadState(r);
}

DistributedDef distributedDef(const io::ParallelDef& p) {
  DistributedDef def;
  def.balance = p.balanceByTime ? DistributedDef::Balance::Time : DistributedDef::Balance::Nodes;
  def.rebalanceImbalance = p.rebalanceImbalance;
  def.rebalanceEvery = p.rebalanceEvery;
  return def;
}

template <int D>
class DistributedEngine final : public io::RunEngine<D> {
 public:
  DistributedEngine(MPI_Comm comm, io::SceneWorld<D>& part, const DistributedDef& def)
      : part_(part), world_(comm, *part.world, def), comm_(comm) {
    // What every rank held at the start (a resumed run: the checkpoint's
    // log and removals): the view has it already; the ranks send what follows.
    removedFrom_ = part.world->removed().size();
    if (part.breakage) {
      base_ = std::make_unique<breakage::Breakage<D>>(part.breakage->def());
      copyState(*part.breakage, *base_);
    }
  }

  void step() override { world_.step(); }

  void updateView(io::SceneWorld<D>& view) override {
    world_.updateView(*view.world, kRoot);
    if (part_.breakage) {
      world_.gatherBreakage(*part_.breakage, *base_, world_.rank() == kRoot ? *view.breakage : *part_.breakage, kRoot);
    }
    const std::vector<dynamics::RemovedParticle> removed = world_.gatherRemoved(kRoot, removedFrom_);
    if (world_.rank() != kRoot) return;
    // Every rank's feeds drop alike: the view's take this rank's state.
    for (std::size_t k = 0; k < part_.feeds.size(); ++k) copyState(*part_.feeds[k], *view.feeds[k]);
    // The view holds the records it was given before (and the checkpoint's); these are in (time, id) order.
    for (std::size_t k = viewRemoved_; k < removed.size(); ++k) view.world->recordRemoval(removed[k], 0.0);
    viewRemoved_ = removed.size();
  }

  io::RanksSummary ranksSummary() override {
    const ExchangeStats& s = world_.stats();
    const double owned = double(world_.ownedCount());
    const double wait = s.stepSeconds > 0.0 ? (s.stepSeconds - s.workSeconds) / s.stepSeconds : 0.0;
    // Sums, then maxima (of -owned: the least; the counts every rank keeps alike).
    double sums[3] = {double(s.migrations), double(s.bytesSent), s.workSeconds};
    double maxima[6] = {owned, -owned, s.workSeconds, wait, double(s.rebalances), double(s.globalExchanges)};
    if (MPI_Allreduce(MPI_IN_PLACE, sums, 3, MPI_DOUBLE, MPI_SUM, comm_) != MPI_SUCCESS ||
        MPI_Allreduce(MPI_IN_PLACE, maxima, 6, MPI_DOUBLE, MPI_MAX, comm_) != MPI_SUCCESS) {
      throw std::runtime_error("MPI: Allreduce failed");
    }
    io::RanksSummary r;
    r.ranks = world_.ranks();
    r.balanceByTime = world_.def().balance == DistributedDef::Balance::Time;
    r.rebalances = std::uint64_t(maxima[4]);
    r.migrations = std::uint64_t(sums[0]);
    r.allToAllExchanges = std::uint64_t(maxima[5]);
    r.bytesPerStep = s.steps > 0 ? sums[1] / double(s.steps) : 0.0;
    r.ownedMax = std::uint64_t(maxima[0]);
    r.ownedMin = std::uint64_t(-maxima[1]);
    const double meanWork = sums[2] / r.ranks;
    r.workImbalance = meanWork > 0.0 ? maxima[2] / meanWork : 1.0;
    r.largestWaitShare = maxima[3];
    return r;
  }

  bool anyStop(bool stop) override { return any(stop); }
  std::uint64_t particleSetChanges() override { return world_.particleSetChanges(); }

  bool any(bool here) override {
    int flag = here ? 1 : 0;
    if (MPI_Allreduce(MPI_IN_PLACE, &flag, 1, MPI_INT, MPI_MAX, comm_) != MPI_SUCCESS) {
      throw std::runtime_error("MPI: Allreduce failed");
    }
    return flag != 0;
  }

  std::uint64_t fromWriter(std::uint64_t value) override {
    if (MPI_Bcast(&value, 1, MPI_UINT64_T, kRoot, comm_) != MPI_SUCCESS) throw std::runtime_error("MPI: Bcast failed");
    return value;
  }

 private:
  io::SceneWorld<D>& part_;
  DistributedWorld<D> world_;
  MPI_Comm comm_;
  std::size_t removedFrom_ = 0;  // removal records every rank held at the start
  std::size_t viewRemoved_ = 0;  // records since then the view holds
  std::unique_ptr<breakage::Breakage<D>> base_;  // the breakage log at the start
};

}  // namespace

std::shared_ptr<const io::RunEngineFactory> distributedRun(MPI_Comm comm) {
  int rank = 0, ranks = 1;
  if (MPI_Comm_rank(comm, &rank) != MPI_SUCCESS) throw std::runtime_error("MPI: Comm_rank failed");
  if (MPI_Comm_size(comm, &ranks) != MPI_SUCCESS) throw std::runtime_error("MPI: Comm_size failed");
  auto factory = std::make_shared<io::RunEngineFactory>();
  factory->writesOutputs = rank == kRoot;
  factory->rank = rank;
  factory->ranks = ranks;
  factory->make2 = [comm](io::SceneWorld<2>& part, const io::ParallelDef& p) -> std::unique_ptr<io::RunEngine<2>> {
    return std::make_unique<DistributedEngine<2>>(comm, part, distributedDef(p));
  };
  factory->make3 = [comm](io::SceneWorld<3>& part, const io::ParallelDef& p) -> std::unique_ptr<io::RunEngine<3>> {
    return std::make_unique<DistributedEngine<3>>(comm, part, distributedDef(p));
  };
  return factory;
}

}  // namespace lsdem::parallel
