#include "lsdem/parallel/DistributedWorld.h"

#include "lsdem/io/GrainFile.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <variant>

namespace lsdem::parallel {
namespace {

using dynamics::ParticleId;
using dynamics::StateReader;
using dynamics::StateWriter;

void check(int code, const char* what) {
  if (code != MPI_SUCCESS) throw std::runtime_error(std::string("MPI: ") + what + " failed with code " + std::to_string(code));
}

std::uint64_t fnv1a(const std::string& bytes) {
  std::uint64_t h = 14695981039346656037ull;
  for (const char c : bytes) {
    h ^= std::uint8_t(c);
    h *= 1099511628211ull;
  }
  return h;
}

template <int D>
std::string grainBytes(const geometry::Shape<D>& shape) {
  std::ostringstream out(std::ios::binary);
  io::writeGrain(out, shape, io::GrainFormat::Binary);
  return std::move(out).str();
}

// Sends each rank its bytes and returns what each rank sent here (one
// all-to-all of the sizes, one of the bytes).
std::vector<std::vector<char>> allToAll(MPI_Comm comm, const std::vector<StateWriter>& out) {
  const std::size_t ranks = out.size();
  std::vector<long long> sendCount(ranks), recvCount(ranks);
  for (std::size_t r = 0; r < ranks; ++r) sendCount[r] = (long long)out[r].bytes().size();
  check(MPI_Alltoall(sendCount.data(), 1, MPI_LONG_LONG, recvCount.data(), 1, MPI_LONG_LONG, comm), "Alltoall");
  std::vector<int> sc(ranks), sd(ranks), rc(ranks), rd(ranks);
  long long sendTotal = 0, recvTotal = 0;
  for (std::size_t r = 0; r < ranks; ++r) {
    sd[r] = int(sendTotal);
    rd[r] = int(recvTotal);
    sc[r] = int(sendCount[r]);
    rc[r] = int(recvCount[r]);
    sendTotal += sendCount[r];
    recvTotal += recvCount[r];
  }
  if (sendTotal > (1ll << 31) - 1 || recvTotal > (1ll << 31) - 1) {
    throw std::runtime_error("MPI exchange of more than 2 GiB in one step");
  }
  std::vector<char> send(static_cast<std::size_t>(sendTotal)), recv(static_cast<std::size_t>(recvTotal));
  for (std::size_t r = 0; r < ranks; ++r) std::copy(out[r].bytes().begin(), out[r].bytes().end(), send.begin() + sd[r]);
  check(MPI_Alltoallv(send.data(), sc.data(), sd.data(), MPI_CHAR, recv.data(), rc.data(), rd.data(), MPI_CHAR, comm),
        "Alltoallv");
  std::vector<std::vector<char>> in(ranks);
  for (std::size_t r = 0; r < ranks; ++r) in[r].assign(recv.begin() + rd[r], recv.begin() + rd[r] + rc[r]);
  return in;
}

template <class T>
void putRaw(StateWriter& out, const std::vector<T>& v) {
  out.put(std::uint64_t(v.size()));
  for (const T& x : v) out.put(x);
}
template <class T>
void getRaw(StateReader& in, std::vector<T>& v) {
  v.resize(std::size_t(in.get<std::uint64_t>()));
  for (T& x : v) x = in.get<T>();
}

// One particle's record in a message: what a mirror or a view needs to
// hold it as its owner does (the shape travels apart, by hash).
template <int D>
void putParticle(StateWriter& w, const dynamics::World<D>& world, std::size_t i, std::uint64_t shapeHash) {
  const dynamics::Particles<D>& p = world.particles();
  w.put(p.id[i]);
  w.put(shapeHash);
  w.put(p.mass[i]);
  w.put(p.inertia[i]);
  w.put(p.material[i]);
  w.put(p.strength[i]);
  w.put(p.parentId[i]);
  w.put(p.generation[i]);
  w.put(p.birthTime[i]);
  w.put(p.position[i]);
  w.put(p.orientation[i]);
  w.put(p.velocity[i]);
  w.put(p.angularVelocity[i]);
  w.put(world.decidedDensityScale(i));
}
// Reads putParticle's record into a definition without its shape; the
// shape's hash into `shapeHash`, the density scaling its owner decided into
// `densityScale` (World::decidedDensityScale).
template <int D>
dynamics::ParticleDef<D> getParticle(StateReader& r, std::uint64_t& shapeHash, double& densityScale) {
  dynamics::ParticleDef<D> def;
  def.id = r.get<ParticleId>();
  shapeHash = r.get<std::uint64_t>();
  def.mass = r.get<double>();
  def.inertia = r.get<dynamics::Spin<D>>();
  def.material = r.get<int>();
  def.strength = r.get<double>();
  def.parent = r.get<ParticleId>();
  def.generation = r.get<int>();
  def.birthTime = r.get<double>();
  def.position = r.get<Vec<D>>();
  def.orientation = r.get<dynamics::Orientation<D>>();
  def.velocity = r.get<Vec<D>>();
  def.angularVelocity = r.get<dynamics::Spin<D>>();
  densityScale = r.get<double>();
  return def;
}

template <int D>
void putHistory(StateWriter& w, const typename dynamics::ContactSolver<D>::ParticleHistory& history) {
  putRaw(w, history.pairs);
  putRaw(w, history.nodes);
  putRaw(w, history.shear);
  putRaw(w, history.preload);
}
template <int D>
typename dynamics::ContactSolver<D>::ParticleHistory getHistory(StateReader& r) {
  typename dynamics::ContactSolver<D>::ParticleHistory history;
  getRaw(r, history.pairs);
  getRaw(r, history.nodes);
  getRaw(r, history.shear);
  getRaw(r, history.preload);
  return history;
}

}  // namespace

template <int D>
DistributedWorld<D>::DistributedWorld(MPI_Comm comm, dynamics::World<D>& world, const DistributedDef& def)
    : ownComm_(comm), comm_(ownComm_.comm), world_(world), def_(def) {
  check(MPI_Comm_rank(comm_, &rank_), "Comm_rank");
  check(MPI_Comm_size(comm_, &ranks_), "Comm_size");
  // The effects: each must declare that it runs on every rank alike
  // (Effect::distributable); one that changes the particle set makes the
  // world agree with the others through this object.
  for (const auto& effect : world_.effects()) {
    if (!effect->distributable()) {
      throw std::invalid_argument("a distributed run does not support the effect '" + effect->name() +
                                  "' (it does not declare Effect::distributable; docs/parallel.md); run it on one rank");
    }
    coordinated_ = coordinated_ || effect->replacesParticles() || effect->changesParticles();
    breaks_ = breaks_ || effect->replacesParticles();
  }
  for (const auto& tool : world_.tools()) {
    servo_ = servo_ || std::holds_alternative<dynamics::ServoPlaten<D>>(tool.motion);
  }

  const dynamics::Particles<D>& p = world_.particles();
  for (std::size_t i = 0; i < p.size(); ++i) {
    largestRadius_ = std::max(largestRadius_, radius(i));
    coarsestSpacing_ = std::max(coarsestSpacing_, p.shape[i]->grid().spacing());
    shapeHash(p.shape[i]);  // registers the shape under its hash
  }
  updateSkin();
  nextId_ = p.nextId();
  checkSameWorldEverywhere();
  shapesAt_.assign(std::size_t(ranks_), {});
  for (auto& held : shapesAt_) {
    for (const auto& entry : shapes_) held.insert(entry.first);
  }

  // The decomposition of the whole set (the same on every rank), then each
  // rank keeps its own particles and their ghosts.
  // A world restored from a checkpoint holds the forces the run evaluated
  // last: each part opens its first step with them, as the run would have.
  const bool resumed = world_.steps() > 0 && world_.contactsCurrent();
  std::vector<Vec<D>> points(p.position.begin(), p.position.end());
  std::vector<double> weights(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) weights[i] = weight(i);
  decomposition_ = Decomposition<D>::build(points, weights, ranks_);
  if (resumed) world_.keepForces();  // (while its contact records are the whole run's: it books the opening half kick)
  for (std::size_t i = p.size(); i-- > 0;) place(i);
  if (coordinated_) world_.setCoordinator(this);
  // The energy ledger: each rank books its own particles' and pairs' terms
  // (World::setGhost), and the run's is their sum. A world that had run
  // already (resumed) holds the run's ledger so far: rank 0 keeps it, the
  // others start from nothing. (A new run's parts book their initial energy
  // at their first evaluation.)
  if (world_.steps() > 0 && rank_ != 0) world_.resetLedger();
  // The density scaling's counts are summed over the ranks (a view's are the
  // run's): a resumed run's are rank 0's.
  if (rank_ != 0) {
    dynamics::DensityScalingStats stats = world_.densityScaling();
    stats.scaled = 0;
    stats.capped = 0;
    world_.setDensityScalingStats(stats);
  }
  // A checkpoint's loads are the run's; a new run's are summed at its first step.
  loadsReduced_ = resumed;
}

template <int D>
void DistributedWorld<D>::place(std::size_t i) {
  const Vec<D>& x = world_.particles().position[i];
  if (decomposition_.owner(x) == rank_) return;
  if (decomposition_.distance(x, rank_) < reach(i)) {
    world_.setGhost(i, true);
  } else {
    world_.detachParticle(i);
  }
}

template <int D>
DistributedWorld<D>::~DistributedWorld() {
  if (coordinated_) world_.setCoordinator(nullptr);
}

template <int D>
DistributedWorld<D>::OwnComm::OwnComm(MPI_Comm from) {
  check(MPI_Comm_dup(from, &comm), "Comm_dup");
}

template <int D>
DistributedWorld<D>::OwnComm::~OwnComm() {
  int finalized = 0;
  MPI_Finalized(&finalized);  // (a program may end MPI before this object)
  if (!finalized && comm != MPI_COMM_NULL) MPI_Comm_free(&comm);
}

template <int D>
void DistributedWorld<D>::checkSameWorldEverywhere() const {
  // A digest of the particle count, ids and shape hashes, in index order,
  // the skin and the balance settings: equal on every rank.
  const dynamics::Particles<D>& p = world_.particles();
  std::uint64_t digest = p.size() * 1099511628211ull ^ p.nextId();
  digest = digest * 1099511628211ull ^ std::bit_cast<std::uint64_t>(skin_);  // (from the world's broad-phase skin)
  // The balance settings: every rank takes the same rebalances.
  digest = digest * 1099511628211ull ^ std::uint64_t(def_.balance);
  digest = digest * 1099511628211ull ^ std::bit_cast<std::uint64_t>(def_.rebalanceImbalance);
  digest = digest * 1099511628211ull ^ def_.rebalanceEvery;
  for (std::size_t i = 0; i < p.size(); ++i) {
    digest = digest * 1099511628211ull ^ p.id[i];
    digest = digest * 1099511628211ull ^ hashOf_.at(p.shape[i].get()).hash;
  }
  std::uint64_t lo = digest, hi = digest;
  check(MPI_Allreduce(MPI_IN_PLACE, &lo, 1, MPI_UINT64_T, MPI_MIN, comm_), "Allreduce");
  check(MPI_Allreduce(MPI_IN_PLACE, &hi, 1, MPI_UINT64_T, MPI_MAX, comm_), "Allreduce");
  if (lo != hi) {
    throw std::invalid_argument(
        "a distributed run needs the same world on every rank: rank " + std::to_string(rank_) +
        " has other particles, shapes or balance settings (build every rank's world from the same scene, with the same "
        "DistributedDef)");
  }
}

template <int D>
std::uint64_t DistributedWorld<D>::shapeHash(const std::shared_ptr<const geometry::Shape<D>>& shape) {
  // A hit needs the shape alive: a freed fragment's address may now hold another shape.
  const auto it = hashOf_.find(shape.get());
  if (it != hashOf_.end() && !it->second.alive.expired()) return it->second.hash;
  const std::uint64_t h = fnv1a(grainBytes(*shape));
  hashOf_[shape.get()] = {h, shape};
  shapes_.emplace(h, shape);
  return h;
}

template <int D>
void DistributedWorld<D>::putShapes(StateWriter& w, int q, std::span<const std::size_t> list) {
  const dynamics::Particles<D>& p = world_.particles();
  std::vector<std::uint64_t> newShapes;
  for (std::size_t i : list) {
    const std::uint64_t h = shapeHash(p.shape[i]);
    if (shapesAt_[std::size_t(q)].insert(h).second) newShapes.push_back(h);
  }
  w.put(std::uint64_t(newShapes.size()));
  for (std::uint64_t h : newShapes) {
    w.put(h);
    w.putString(grainBytes(*shapes_.at(h)));
  }
  stats_.shapesSent += newShapes.size();
}

template <int D>
void DistributedWorld<D>::getShapes(StateReader& r, int q) {
  for (std::uint64_t k = 0, count = r.get<std::uint64_t>(); k < count; ++k) {
    const std::uint64_t h = r.get<std::uint64_t>();
    const std::string grain = r.getString();
    std::istringstream s(grain, std::ios::binary);
    auto shape = io::readGrain<D>(s, "rank " + std::to_string(q));
    shapes_.emplace(h, shape);
    hashOf_[shape.get()] = {h, shape};    // this copy lives on only when it was new here
    shapesAt_[std::size_t(q)].insert(h);  // the sender holds it
  }
}

template <int D>
std::shared_ptr<const geometry::Shape<D>> DistributedWorld<D>::receivedShape(std::uint64_t hash, ParticleId id,
                                                                            int from) const {
  const auto shape = shapes_.find(hash);
  if (shape == shapes_.end()) {
    throw std::runtime_error("rank " + std::to_string(rank_) + ": particle " + std::to_string(id) + " from rank " +
                             std::to_string(from) + " has a shape this rank never received");
  }
  return shape->second;
}

template <int D>
double DistributedWorld<D>::weight(std::size_t index) const {
  return double(std::max<std::size_t>(1, world_.particles().shape[index]->nodes().size()));
}

template <int D>
double DistributedWorld<D>::radius(std::size_t index) const {
  const geometry::Shape<D>& s = *world_.particles().shape[index];
  return std::max(s.boundingRadius(), s.cubicBoundingRadius());
}

template <int D>
void DistributedWorld<D>::updateSkin() {
  const double user = world_.def().broadPhase.skin;
  skin_ = std::max(skin_, user > 0.0 ? user : 0.1 * largestRadius_);
  // A split looks at the bodies within 4 of its grain's cells
  // (Breakage::clearanceAround): they must be here.
  if (breaks_) skin_ = std::max(skin_, 4.0 * coarsestSpacing_);
}

template <int D>
double DistributedWorld<D>::reach(std::size_t index) const {
  return radius(index) + largestRadius_ + skin_;
}

template <int D>
std::size_t DistributedWorld<D>::ownedCount() const {
  std::size_t n = 0;
  for (std::size_t i = 0; i < world_.particles().size(); ++i) n += !world_.isGhost(i);
  return n;
}

template <int D>
std::uint64_t DistributedWorld<D>::globalCount() const {
  std::uint64_t n = ownedCount();
  check(MPI_Allreduce(MPI_IN_PLACE, &n, 1, MPI_UINT64_T, MPI_SUM, comm_), "Allreduce");
  return n;
}

template <int D>
DistributedWorld<D>::Waiting::Waiting(DistributedWorld& w) : world_(w), start_(std::chrono::steady_clock::now()) {
  ++world_.waitingDepth_;
}

template <int D>
DistributedWorld<D>::Waiting::~Waiting() {
  if (--world_.waitingDepth_ == 0) {
    world_.waitedSeconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
}

template <int D>
void DistributedWorld<D>::step() {
  const auto start = std::chrono::steady_clock::now();
  const double waitedBefore = waitedSeconds_;
  // A servo platen moves by the load of the whole run (boundaryLoads), read
  // at the opening of the step from the contacts of its state.
  if (servo_ && !loadsReduced_) reduceLoads();
  world_.beginStep();
  exchange();
  // The velocities the step evaluates its forces with (half-step ones), for
  // a view (updateView); a step that splits grains evaluates again at its end.
  const dynamics::Particles<D>& p = world_.particles();
  forceVelocity_.assign(p.velocity.begin(), p.velocity.end());
  forceSpin_.assign(p.angularVelocity.begin(), p.angularVelocity.end());
  world_.finishStep();
  if (servo_) reduceLoads();
  ++stats_.steps;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  stats_.stepSeconds += seconds;
  stats_.workSeconds += seconds - (waitedSeconds_ - waitedBefore);
  if (def_.rebalanceImbalance > 0.0 && def_.rebalanceEvery > 0 && stats_.steps % def_.rebalanceEvery == 0) rebalance();
}

template <int D>
void DistributedWorld<D>::run(std::uint64_t n) {
  for (std::uint64_t s = 0; s < n; ++s) step();
}

template <int D>
void DistributedWorld<D>::exchange(std::span<const dynamics::BornParticle> born) {
  const Waiting waiting(*this);
  const auto t0 = std::chrono::steady_clock::now();
  const dynamics::Particles<D>& p = world_.particles();
  const std::size_t n = p.size();
  // The births of the particles just born here, by id (empty but after a split).
  std::vector<dynamics::BornParticle> births;
  for (const dynamics::BornParticle& b : born) {
    if (b.birth) births.push_back(b);
  }
  const auto idLess = [](const dynamics::BornParticle& a, const dynamics::BornParticle& b) { return a.id < b.id; };
  std::sort(births.begin(), births.end(), idLess);

  // What each rank gets: the shapes it lacks, then one record per particle
  // (owner, id, shape, mass and motion, strength), with the contact history
  // of the particles it takes over, then how the contacts of the particles
  // just born start (their births).
  //
  // A particle is tested against the neighbouring subdomains only while
  // every subdomain in its reach is a neighbour: for a point x at distance d
  // from this subdomain A and any other B, dist(x, B) >= dist(A, B) - d, so
  // a subdomain farther than the neighbours' range R is out of reach when
  // d + reach < R. Else (a particle well out of A: after a rebalance, or a
  // fragment born far from its parent's centroid) it is tested against
  // every rank, and when it goes to one that is not a neighbour the whole
  // run exchanges with an all-to-all this time.
  updateNeighbours();
  std::vector<StateWriter> out(static_cast<std::size_t>(ranks_));
  std::vector<std::vector<std::size_t>> sent(static_cast<std::size_t>(ranks_));
  std::vector<int> newOwner(n, rank_);
  bool beyondNeighbours = false;
  for (std::size_t i = 0; i < n; ++i) {
    if (world_.isGhost(i)) continue;
    newOwner[i] = decomposition_.owner(p.position[i]);
    const double r = reach(i);
    const auto consider = [&](int q) {
      if (q == newOwner[i] || decomposition_.distance(p.position[i], q) < r) {
        sent[std::size_t(q)].push_back(i);
        beyondNeighbours = beyondNeighbours || !isNeighbour_[std::size_t(q)];
      }
    };
    if (decomposition_.distance(p.position[i], rank_) + r < neighbourRange_ * (1.0 - 1e-12)) {
      for (const int q : neighbours_) consider(q);
    } else {
      for (int q = 0; q < ranks_; ++q) {
        if (q != rank_) consider(q);
      }
    }
  }
  for (int q = 0; q < ranks_; ++q) {
    StateWriter& w = out[std::size_t(q)];
    const std::vector<std::size_t>& list = sent[std::size_t(q)];
    if (list.empty()) continue;
    // Shapes first, each once per rank.
    putShapes(w, q, list);
    w.put(std::uint64_t(list.size()));
    for (std::size_t i : list) {
      w.put(std::int32_t(newOwner[i]));
      putParticle(w, world_, i, shapeHash(p.shape[i]));
      if (newOwner[i] == q) {
        putHistory<D>(w, world_.contacts().particleHistory(p.id[i]));
        ++stats_.migrations;
      }
    }
    // Births (breakage runs only: the other runs' messages are as before).
    std::uint64_t bornHere = 0;
    if (!births.empty()) {
      for (std::size_t i : list) bornHere += std::binary_search(births.begin(), births.end(), dynamics::BornParticle{p.id[i], nullptr}, idLess);
    }
    if (coordinated_) w.put(bornHere);
    if (bornHere > 0) {
      for (std::size_t i : list) {
        const auto it = std::lower_bound(births.begin(), births.end(), dynamics::BornParticle{p.id[i], nullptr}, idLess);
        if (it == births.end() || it->id != p.id[i]) continue;
        w.put(it->id);
        putRaw(w, it->birth->newFaceNodes);
        w.put(std::uint64_t(it->birth->rests.size()));
        for (const dynamics::ChildBirth::Rest& r : it->birth->rests) {
          w.put(r.key);
          w.put(r.node);
          w.put(r.restOverlap);
          w.put(std::uint8_t(r.childOwns));
        }
      }
    }
    stats_.ghostsSent += list.size();
    stats_.bytesSent += w.bytes().size();
    ++stats_.messagesSent;
  }
  const bool global = ranks_ > 1 && anyRank(beyondNeighbours);
  const std::vector<std::vector<char>> in = global ? allToAll(comm_, out) : neighbourExchange(out);
  ++(global ? stats_.globalExchanges : stats_.neighbourExchanges);

  // What stays: our own particles, and those just given away while in reach
  // of our subdomain (as ghosts); the other ghosts stay if refreshed below.
  std::vector<std::uint8_t> keep(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (world_.isGhost(i)) continue;
    if (newOwner[i] == rank_) {
      keep[i] = 1;
    } else {
      world_.setGhost(i, true);
      keep[i] = decomposition_.distance(p.position[i], rank_) < reach(i);
    }
  }
  // Local index by id.
  std::unordered_map<ParticleId, std::size_t> local;
  local.reserve(n);
  for (std::size_t i = 0; i < n; ++i) local.emplace(p.id[i], i);
  struct Adopted {
    ParticleId id;
    typename dynamics::ContactSolver<D>::ParticleHistory history;
  };
  std::vector<Adopted> adopted;
  for (int q = 0; q < ranks_; ++q) {
    const std::vector<char>& bytes = in[std::size_t(q)];
    if (bytes.empty()) continue;
    StateReader r(bytes.data(), bytes.size());
    getShapes(r, q);
    for (std::uint64_t k = 0, count = r.get<std::uint64_t>(); k < count; ++k) {
      const int owner = r.get<std::int32_t>();
      std::uint64_t h = 0;
      double densityScale = 0.0;
      dynamics::ParticleDef<D> def = getParticle<D>(r, h, densityScale);
      if (owner == rank_) adopted.push_back({def.id, getHistory<D>(r)});
      const auto it = local.find(def.id);
      if (it != local.end()) {
        world_.setMotion(it->second, def.position, def.orientation, def.velocity, def.angularVelocity);
        world_.setStrength(it->second, def.strength);  // its owner's (sampled, or made unbreakable)
        keep[it->second] = 1;
        world_.setGhost(it->second, owner != rank_);
      } else {
        def.shape = receivedShape(h, def.id, q);
        world_.setGhost(world_.addCopy(def, densityScale), owner != rank_);
        keep.push_back(1);
      }
    }
    for (std::uint64_t k = 0, count = coordinated_ ? r.get<std::uint64_t>() : 0; k < count; ++k) {
      const ParticleId id = r.get<ParticleId>();
      dynamics::ChildBirth birth;
      getRaw(r, birth.newFaceNodes);
      birth.rests.resize(std::size_t(r.get<std::uint64_t>()));
      for (dynamics::ChildBirth::Rest& rest : birth.rests) {
        rest.key = r.get<std::uint64_t>();
        rest.node = r.get<std::uint32_t>();
        rest.restOverlap = r.get<double>();
        rest.childOwns = r.get<std::uint8_t>() != 0;
      }
      world_.markBirth(id, birth);
    }
    if (!r.atEnd()) throw std::runtime_error("MPI exchange: message from rank " + std::to_string(q) + " is malformed");
  }
  // Ghosts out of reach leave, highest index first.
  for (std::size_t i = keep.size(); i-- > 0;) {
    if (!keep[i]) {
      world_.detachParticle(i);
      keep[i] = keep.back();
      keep.pop_back();
    }
  }
  for (const Adopted& a : adopted) world_.adoptHistory(a.id, a.history);
  stats_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

template <int D>
void DistributedWorld<D>::updateNeighbours() {
  const double range = 2.0 * (largestRadius_ + skin_);
  if (range == neighbourRange_ && !decompositionChanged_) return;
  neighbourRange_ = range;
  decompositionChanged_ = false;
  neighbours_.clear();
  isNeighbour_.assign(static_cast<std::size_t>(ranks_), 0);
  for (int q = 0; q < ranks_; ++q) {
    if (q == rank_ || !(decomposition_.distance(rank_, q) < range)) continue;
    neighbours_.push_back(q);
    isNeighbour_[std::size_t(q)] = 1;
  }
  stats_.neighbours = neighbours_.size();
}

template <int D>
std::vector<std::vector<char>> DistributedWorld<D>::neighbourExchange(const std::vector<StateWriter>& out) {
  // One message to each neighbour (maybe empty), and one from each: its
  // size from the probe. (Messages between two ranks arrive in order, and a
  // collective separates two exchanges.)
  constexpr int kTag = 7301;
  for (const int q : neighbours_) {
    if (out[std::size_t(q)].bytes().size() > std::size_t(std::numeric_limits<int>::max())) {
      throw std::runtime_error("MPI exchange of more than 2 GiB to one rank in one step");
    }
  }
  std::vector<MPI_Request> sends(neighbours_.size());
  for (std::size_t k = 0; k < neighbours_.size(); ++k) {
    const auto& bytes = out[std::size_t(neighbours_[k])].bytes();
    check(MPI_Isend(bytes.data(), int(bytes.size()), MPI_CHAR, neighbours_[k], kTag, comm_, &sends[k]), "Isend");
  }
  std::vector<std::vector<char>> in(static_cast<std::size_t>(ranks_));
  for (const int q : neighbours_) {
    MPI_Status status;
    check(MPI_Probe(q, kTag, comm_, &status), "Probe");
    int count = 0;
    check(MPI_Get_count(&status, MPI_CHAR, &count), "Get_count");
    std::vector<char>& bytes = in[std::size_t(q)];
    bytes.resize(std::size_t(count));
    check(MPI_Recv(bytes.data(), count, MPI_CHAR, q, kTag, comm_, MPI_STATUS_IGNORE), "Recv");
  }
  check(MPI_Waitall(int(sends.size()), sends.data(), MPI_STATUSES_IGNORE), "Waitall");
  return in;
}

template <int D>
void DistributedWorld<D>::rebalance() {
  const dynamics::Particles<D>& p = world_.particles();
  double nodes = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!world_.isGhost(i)) nodes += weight(i);
  }
  // Balance::Time: a rank's load is its work since the last check, and the
  // cuts give each rank a share of the nodes in proportion to its speed
  // (nodes per second of its own work; a rank that had no nodes or no work
  // keeps its last, one never measured takes the mean of the others, all
  // within a factor 8 of the mean: one slow interval does not starve a rank).
  double own = nodes;
  std::vector<double> capacities;
  if (def_.balance == DistributedDef::Balance::Time) {
    const double work = stats_.workSeconds - workAtCheck_;
    if (nodes > 0.0 && work > 0.0) speed_ = nodes / work;
    own = work;
    capacities.assign(static_cast<std::size_t>(ranks_), 0.0);
    check(MPI_Allgather(&speed_, 1, MPI_DOUBLE, capacities.data(), 1, MPI_DOUBLE, comm_), "Allgather");
    double known = 0.0;
    int measured = 0;
    for (const double c : capacities) {
      if (c > 0.0) {
        known += c;
        ++measured;
      }
    }
    const double mean = measured > 0 ? known / measured : 1.0;
    for (double& c : capacities) c = c > 0.0 ? std::clamp(c, mean / 8.0, 8.0 * mean) : mean;
  }
  workAtCheck_ = stats_.workSeconds;
  double largest = own, total = own;
  check(MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_DOUBLE, MPI_MAX, comm_), "Allreduce");
  check(MPI_Allreduce(MPI_IN_PLACE, &total, 1, MPI_DOUBLE, MPI_SUM, comm_), "Allreduce");
  if (!(total > 0.0) || !(largest > def_.rebalanceImbalance * total / ranks_)) return;
  // Every rank gets every owned centroid and weight, in rank order, and builds the same tree.
  std::vector<double> mine;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (world_.isGhost(i)) continue;
    for (int a = 0; a < D; ++a) mine.push_back(p.position[i][a]);
    mine.push_back(weight(i));
  }
  int count = int(mine.size());
  std::vector<int> counts(static_cast<std::size_t>(ranks_)), offsets(static_cast<std::size_t>(ranks_));
  check(MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_), "Allgather");
  int total_values = 0;
  for (int q = 0; q < ranks_; ++q) {
    offsets[std::size_t(q)] = total_values;
    total_values += counts[std::size_t(q)];
  }
  std::vector<double> all(static_cast<std::size_t>(total_values));
  check(MPI_Allgatherv(mine.data(), count, MPI_DOUBLE, all.data(), counts.data(), offsets.data(), MPI_DOUBLE, comm_),
        "Allgatherv");
  std::vector<Vec<D>> points;
  std::vector<double> weights;
  for (std::size_t k = 0; k < all.size(); k += D + 1) {
    Vec<D> x;
    for (int a = 0; a < D; ++a) x[a] = all[k + std::size_t(a)];
    points.push_back(x);
    weights.push_back(all[k + D]);
  }
  decomposition_ = Decomposition<D>::build(points, weights, ranks_, capacities);
  decompositionChanged_ = true;
  ++stats_.rebalances;
  // The particles move to their new owners at the next exchange.
}

template <int D>
dynamics::BoundaryLoads<D> DistributedWorld<D>::boundaryLoads() const {
  // The records of every rank's own particles on planes and tools (a ghost's
  // are its owner's), summed as one world sums them (ContactSolver::
  // accumulate): each boundary's records in the order of their particles,
  // here ascending ids (one world's order while it holds its particles in id
  // order: no splits or removals yet; else the sum differs at round-off).
  struct LoadRecord {
    ParticleId id = 0;
    std::uint32_t boundary = 0;  // a plane's index, or the planes' count + a tool's
    Vec<D> force = Vec<D>::Zero();
    dynamics::Spin<D> torque = dynamics::Rotation<D>::zeroSpin();
  };
  const dynamics::Particles<D>& p = world_.particles();
  const std::size_t planes = world_.planes().size();
  const std::size_t tools = world_.tools().size();
  const auto records = world_.contacts().pairContacts();
  const std::size_t particlePairs = world_.contacts().particleContacts().size();
  const std::size_t planePairs = world_.contacts().planeContacts().size();
  std::vector<LoadRecord> mine;
  for (std::size_t k = particlePairs; k < records.size(); ++k) {
    const auto& rec = records[k];
    if (world_.isGhost(rec.a)) continue;
    const std::size_t boundary = k < particlePairs + planePairs ? rec.b : planes + rec.b;
    mine.push_back({p.id[rec.a], std::uint32_t(boundary), rec.force, rec.torqueB});
  }
  StateWriter w;
  putRaw(w, mine);
  std::vector<LoadRecord> all;
  for (const std::vector<char>& bytes : gatherBytes(w.bytes(), kAllRanks)) {
    StateReader r(bytes.data(), bytes.size());
    std::vector<LoadRecord> part;
    getRaw(r, part);
    all.insert(all.end(), part.begin(), part.end());
  }
  // (A particle's records come from one rank, in its order.)
  std::stable_sort(all.begin(), all.end(), [](const LoadRecord& a, const LoadRecord& b) { return a.id < b.id; });
  dynamics::BoundaryLoads<D> loads;
  loads.planeForce.assign(planes, Vec<D>::Zero());
  loads.planeTorque.assign(planes, dynamics::Rotation<D>::zeroSpin());
  loads.toolForce.assign(tools, Vec<D>::Zero());
  loads.toolTorque.assign(tools, dynamics::Rotation<D>::zeroSpin());
  for (const LoadRecord& rec : all) {
    if (rec.boundary < planes) {
      loads.planeForce[rec.boundary] -= rec.force;
      loads.planeTorque[rec.boundary] += rec.torque;
    } else {
      loads.toolForce[rec.boundary - planes] -= rec.force;
      loads.toolTorque[rec.boundary - planes] += rec.torque;
    }
  }
  return loads;
}

template <int D>
void DistributedWorld<D>::refreshStaleContacts() {
  if (world_.contactsCurrent()) return;
  world_.refreshContacts();
  // (They were evaluated again, at the velocities of now.)
  forceVelocity_.clear();
  forceSpin_.clear();
}

template <int D>
void DistributedWorld<D>::reduceLoads() {
  // The loads are those of the contacts now.
  refreshStaleContacts();
  const Waiting waiting(*this);
  world_.setBoundaryLoads(boundaryLoads());
  loadsReduced_ = true;
}

template <int D>
std::vector<typename DistributedWorld<D>::ParticleState> DistributedWorld<D>::gather(int root) const {
  const dynamics::Particles<D>& p = world_.particles();
  StateWriter w;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (world_.isGhost(i)) continue;
    w.put(p.id[i]);
    w.put(p.position[i]);
    w.put(p.orientation[i]);
    w.put(p.velocity[i]);
    w.put(p.angularVelocity[i]);
  }
  std::vector<ParticleState> states;
  for (const std::vector<char>& bytes : gatherBytes(w.bytes(), root)) {
    StateReader r(bytes.data(), bytes.size());
    while (!r.atEnd()) {
      ParticleState s;
      s.id = r.get<ParticleId>();
      s.position = r.get<Vec<D>>();
      s.orientation = r.get<dynamics::Orientation<D>>();
      s.velocity = r.get<Vec<D>>();
      s.angularVelocity = r.get<dynamics::Spin<D>>();
      states.push_back(s);
    }
  }
  std::sort(states.begin(), states.end(), [](const ParticleState& a, const ParticleState& b) { return a.id < b.id; });
  return states;
}

template <int D>
std::uint64_t DistributedWorld<D>::allocateIds(std::span<const dynamics::SplitRequest> batch,
                                               std::vector<dynamics::SplitIds>& ids) {
  // The run's split count (every step: one all-reduce), then, when some
  // rank split, every rank's count and every split.
  const Waiting waiting(*this);
  ids.clear();
  const int mine = int(batch.size());
  int splits = mine;
  check(MPI_Allreduce(MPI_IN_PLACE, &splits, 1, MPI_INT, MPI_SUM, comm_), "Allreduce");
  if (splits == 0) return 0;
  ++particleSetChanges_;
  std::vector<int> counts(static_cast<std::size_t>(ranks_)), offsets(static_cast<std::size_t>(ranks_));
  check(MPI_Allgather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_), "Allgather");
  int total = 0;
  for (int q = 0; q < ranks_; ++q) {
    offsets[std::size_t(q)] = 3 * total;
    total += counts[std::size_t(q)];
    counts[std::size_t(q)] *= 3;
  }
  std::vector<std::uint64_t> send;
  send.reserve(3 * batch.size());
  for (const dynamics::SplitRequest& r : batch) send.insert(send.end(), {r.parent, r.fines, r.children});
  std::vector<std::uint64_t> all(3 * std::size_t(total));
  check(MPI_Allgatherv(send.data(), 3 * mine, MPI_UINT64_T, all.data(), counts.data(), offsets.data(), MPI_UINT64_T,
                       comm_),
        "Allgatherv");
  // The run's batch in ascending parent id, numbered as one world numbers it
  // (World::replace): every fine first, then every child.
  std::vector<dynamics::SplitRequest> runBatch(static_cast<std::size_t>(total));
  std::uint64_t fines = 0;
  for (std::size_t k = 0; k < runBatch.size(); ++k) {
    runBatch[k] = {all[3 * k], all[3 * k + 1], all[3 * k + 2]};
    fines += runBatch[k].fines;
  }
  const auto byParent = [](const dynamics::SplitRequest& a, const dynamics::SplitRequest& b) { return a.parent < b.parent; };
  std::sort(runBatch.begin(), runBatch.end(), byParent);
  std::vector<dynamics::SplitIds> first(runBatch.size());
  std::uint64_t fine = nextId_, child = nextId_ + fines;
  for (std::size_t k = 0; k < runBatch.size(); ++k) {
    if (k > 0 && runBatch[k].parent == runBatch[k - 1].parent) {
      throw std::logic_error("distributed breakage: particle " + std::to_string(runBatch[k].parent) +
                             " was split on two ranks");
    }
    first[k] = {fine, child};
    fine += runBatch[k].fines;
    child += runBatch[k].children;
  }
  nextId_ = child;
  for (const dynamics::SplitRequest& r : batch) {
    const auto it = std::lower_bound(runBatch.begin(), runBatch.end(), r, byParent);
    ids.push_back(first[std::size_t(it - runBatch.begin())]);
  }
  // (Whose fragments are whose, for particlesReplaced.)
  batchParents_.clear();
  batchFirstChild_.clear();
  for (std::size_t k = 0; k < runBatch.size(); ++k) {
    batchParents_.push_back(runBatch[k].parent);
    batchFirstChild_.push_back(first[k].firstChild);
  }
  batchEnd_ = child;
  return std::uint64_t(total);
}

template <int D>
double DistributedWorld<D>::agreeTimeStep(double dt, dynamics::TimeStepLimit& limit) {
  // The smallest step, and the largest radius: a fragment can reach farther
  // from its own centroid than its parent did, and r_max bounds every radius.
  const Waiting waiting(*this);
  const dynamics::Particles<D>& p = world_.particles();
  double largest = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!world_.isGhost(i)) largest = std::max(largest, radius(i));
  }
  double v[2] = {dt, -largest};
  check(MPI_Allreduce(MPI_IN_PLACE, v, 2, MPI_DOUBLE, MPI_MIN, comm_), "Allreduce");
  largestRadius_ = std::max(largestRadius_, -v[1]);
  updateSkin();
  // What sets the run's step: the rank's limit that sets it first in one
  // world's order (the largest omega^2, of equals the lowest id:
  // dynamics::setsStepBefore), as every rank sees it.
  struct Offer {
    double omega2;
    std::uint64_t id;
  };
  const Offer mine{limit.omega2(), limit.id};
  std::vector<Offer> offers(static_cast<std::size_t>(ranks_));
  check(MPI_Allgather(&mine, int(sizeof mine), MPI_BYTE, offers.data(), int(sizeof mine), MPI_BYTE, comm_),
        "Allgather");
  int setter = 0;
  for (int r = 1; r < ranks_; ++r) {
    const Offer& o = offers[std::size_t(r)];
    const Offer& best = offers[std::size_t(setter)];
    if (dynamics::setsStepBefore(o.omega2, o.id, best.omega2, best.id)) setter = r;
  }
  static_assert(std::is_trivially_copyable_v<dynamics::TimeStepLimit>);
  check(MPI_Bcast(&limit, int(sizeof limit), MPI_BYTE, setter, comm_), "Bcast");
  return v[0];
}

template <int D>
void DistributedWorld<D>::particlesReplaced(std::span<const dynamics::BornParticle> born) {
  forceVelocity_.clear();  // the contacts are evaluated again now, at the velocities then
  forceSpin_.clear();
  exchange(born);
  // Every rank evaluates its contacts on the new set now, as one world does
  // after a batch (Breakage's energy check), and the split's energy is
  // checked against the run's energy scale.
  refreshStaleContacts();
  {
    const Waiting waiting(*this);
    world_.setRunEnergyScale(energy().scale());
  }
  // The springs of each split's fragments on the new set (the energy check's
  // fragmentSpringEnergy), summed over the ranks: each counts the pairs whose
  // lower-id particle it owns, a pair once for each split it touches, as one
  // world counts them (Breakage).
  const dynamics::Particles<D>& p = world_.particles();
  std::vector<std::int64_t> splitOf(p.size(), -1);
  std::vector<std::uint8_t> ghost(p.size(), 0);
  for (std::size_t i = 0; i < p.size(); ++i) {
    ghost[i] = world_.isGhost(i);
    if (!batchFirstChild_.empty() && p.id[i] >= batchFirstChild_.front() && p.id[i] < batchEnd_) {
      splitOf[i] = std::upper_bound(batchFirstChild_.begin(), batchFirstChild_.end(), p.id[i]) -
                   batchFirstChild_.begin() - 1;
    }
  }
  std::vector<double> springs(batchParents_.size(), 0.0);
  world_.contacts().addSpringsByGroup(splitOf, ghost, springs);
  {
    const Waiting waiting(*this);
    check(MPI_Allreduce(MPI_IN_PLACE, springs.data(), int(springs.size()), MPI_DOUBLE, MPI_SUM, comm_), "Allreduce");
  }
  std::vector<std::pair<ParticleId, double>> byParent;
  for (std::size_t k = 0; k < springs.size(); ++k) byParent.emplace_back(batchParents_[k], springs[k]);
  world_.setRunFragmentSprings(std::move(byParent));
}

template <int D>
double DistributedWorld<D>::largest(double here) {
  const Waiting waiting(*this);
  check(MPI_Allreduce(MPI_IN_PLACE, &here, 1, MPI_DOUBLE, MPI_MAX, comm_), "Allreduce");
  return here;
}

template <int D>
bool DistributedWorld<D>::anyRank(bool here) {
  return largest(here ? 1.0 : 0.0) > 0.0;
}

template <int D>
std::uint64_t DistributedWorld<D>::takeId() {
  return nextId_++;
}

template <int D>
bool DistributedWorld<D>::effectChangedParticles(bool changed, std::span<const std::uint64_t> added) {
  // Every rank added the same particles (a feed's grains), as owned: each
  // stays with its owner, as a mirror where it is in reach, and leaves the
  // other ranks. Its shape is one every rank built from the scene; its
  // radius may be the run's largest so far (every rank sees it).
  const dynamics::Particles<D>& p = world_.particles();
  for (const std::uint64_t id : added) {
    const std::size_t i = std::size_t(std::find(p.id.begin(), p.id.end(), id) - p.id.begin());
    if (i == p.size()) throw std::logic_error("distributed run: particle " + std::to_string(id) + " was added and lost");
    const std::uint64_t h = shapeHash(p.shape[i]);
    for (auto& held : shapesAt_) held.insert(h);
    largestRadius_ = std::max(largestRadius_, radius(i));
    coarsestSpacing_ = std::max(coarsestSpacing_, p.shape[i]->grid().spacing());
    updateSkin();
    place(i);
  }
  // A change anywhere: the mirrors follow at once (particles that left are
  // gone from every rank already, each removed by the same test), and every
  // rank evaluates its contacts again, as one world does.
  if (!anyRank(changed)) return false;
  ++particleSetChanges_;
  forceVelocity_.clear();
  forceSpin_.clear();
  exchange();
  return true;
}

template <int D>
std::vector<std::vector<char>> DistributedWorld<D>::gatherBytes(const std::vector<char>& bytes, int root) const {
  const bool everyRank = root == kAllRanks;
  int count = int(bytes.size());
  std::vector<int> counts(static_cast<std::size_t>(ranks_)), offsets(static_cast<std::size_t>(ranks_));
  if (everyRank) {
    check(MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_), "Allgather");
  } else {
    check(MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, root, comm_), "Gather");
  }
  int total = 0;
  for (int q = 0; q < ranks_; ++q) {
    offsets[std::size_t(q)] = total;
    total += counts[std::size_t(q)];
  }
  std::vector<char> all(everyRank || rank_ == root ? std::size_t(total) : 0);
  if (everyRank) {
    check(MPI_Allgatherv(bytes.data(), count, MPI_CHAR, all.data(), counts.data(), offsets.data(), MPI_CHAR, comm_),
          "Allgatherv");
  } else {
    check(MPI_Gatherv(bytes.data(), count, MPI_CHAR, all.data(), counts.data(), offsets.data(), MPI_CHAR, root,
                      comm_),
          "Gatherv");
  }
  std::vector<std::vector<char>> parts;
  if (!everyRank && rank_ != root) return parts;
  for (int q = 0; q < ranks_; ++q) {
    const auto at = all.begin() + offsets[std::size_t(q)];
    parts.emplace_back(at, at + counts[std::size_t(q)]);
  }
  return parts;
}

template <int D>
std::vector<dynamics::RemovedParticle> DistributedWorld<D>::gatherRemoved(int root, std::size_t from) const {
  StateWriter w;
  const auto& mine = world_.removed();
  for (std::size_t k = std::min(from, mine.size()); k < mine.size(); ++k) {
    const dynamics::RemovedParticle& r = mine[k];
    w.put(r.id);
    w.put(r.time);
    w.put(r.mass);
    w.put(r.volume);
    w.put(r.sieveSize);
    w.putString(r.reason);
  }
  std::vector<dynamics::RemovedParticle> removed;
  for (const std::vector<char>& bytes : gatherBytes(w.bytes(), root)) {
    StateReader r(bytes.data(), bytes.size());
    while (!r.atEnd()) {
      dynamics::RemovedParticle x;
      x.id = r.get<std::uint64_t>();
      x.time = r.get<double>();
      x.mass = r.get<double>();
      x.volume = r.get<double>();
      x.sieveSize = r.get<double>();
      x.reason = r.getString();
      removed.push_back(std::move(x));
    }
  }
  std::sort(removed.begin(), removed.end(), [](const auto& a, const auto& b) {
    return a.time < b.time || (a.time == b.time && a.id < b.id);
  });
  return removed;
}

template <int D>
dynamics::EnergyLedger DistributedWorld<D>::energy() const {
  StateWriter w;
  w.put(world_.energy());
  dynamics::EnergyLedger run;
  for (const std::vector<char>& bytes : gatherBytes(w.bytes(), kAllRanks)) {
    StateReader r(bytes.data(), bytes.size());
    run.add(r.get<dynamics::EnergyLedger>());
  }
  return run;
}

template <int D>
double DistributedWorld<D>::particleMass() const {
  double m = 0.0;
  for (std::size_t i = 0; i < world_.particles().size(); ++i) {
    if (!world_.isGhost(i)) m += world_.unscaledMass(i);
  }
  check(MPI_Allreduce(MPI_IN_PLACE, &m, 1, MPI_DOUBLE, MPI_SUM, comm_), "Allreduce");
  return m;
}

template <int D>
std::vector<breakage::BreakageEvent<D>> DistributedWorld<D>::gatherBreakageEvents(const breakage::Breakage<D>& effect,
                                                                                  int root) const {
  breakage::Breakage<D> run(effect.def());
  gatherBreakage(effect, breakage::Breakage<D>(effect.def()), run, root);
  return rank_ == root ? run.events() : std::vector<breakage::BreakageEvent<D>>();
}

template <int D>
void DistributedWorld<D>::gatherBreakage(const breakage::Breakage<D>& effect, const breakage::Breakage<D>& base,
                                         breakage::Breakage<D>& into, int root) const {
  // Each rank's log through the effect's own state (saveState / loadState).
  StateWriter w;
  effect.saveState(w);
  std::vector<std::unique_ptr<breakage::Breakage<D>>> parts;
  for (const std::vector<char>& bytes : gatherBytes(w.bytes(), root)) {
    parts.push_back(std::make_unique<breakage::Breakage<D>>(effect.def()));
    StateReader r(bytes.data(), bytes.size());
    parts.back()->loadState(r);
  }
  if (rank_ != root) return;
  std::vector<const breakage::Breakage<D>*> views;
  for (const auto& part : parts) views.push_back(part.get());
  into.mergeLogs(base, views);
}

template <int D>
void DistributedWorld<D>::updateView(dynamics::World<D>& view, int root) {
  // After a split on another rank, this rank evaluates its contacts at its
  // next step; one world did at once (Breakage's energy check). Done now, on
  // the same state, it changes nothing that follows, and the view gets the
  // run's contacts of now: the fragments' springs with their rest overlaps.
  refreshStaleContacts();
  // Every rank's own particles with their contact history, and the shapes
  // the root has not got yet.
  const dynamics::Particles<D>& p = world_.particles();
  std::vector<std::size_t> own;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!world_.isGhost(i)) own.push_back(i);
  }
  // By id: their histories are read in one pass.
  std::sort(own.begin(), own.end(), [&](std::size_t a, std::size_t b) { return p.id[a] < p.id[b]; });
  std::vector<std::uint64_t> ownIds;
  for (std::size_t i : own) ownIds.push_back(p.id[i]);
  const auto ownHistories = world_.contacts().particleHistories(ownIds);
  StateWriter w;
  if (rank_ != root) {
    putShapes(w, root, own);
  } else {
    w.put(std::uint64_t(0));
  }
  // The velocities the run's last force evaluation saw: the step's half-step
  // ones, or those now when the particles changed since (or never stepped).
  const bool halfStep = forceVelocity_.size() == p.size();
  w.put(std::uint64_t(own.size()));
  for (std::size_t k = 0; k < own.size(); ++k) {
    const std::size_t i = own[k];
    putParticle(w, world_, i, shapeHash(p.shape[i]));
    putHistory<D>(w, ownHistories[k]);
    w.put(halfStep ? forceVelocity_[i] : p.velocity[i]);
    w.put(halfStep ? forceSpin_[i] : p.angularVelocity[i]);
    w.put(p.force[i]);
    w.put(p.torque[i]);
  }
  // The particle pairs in contact: the view evaluates only those (a pair
  // with a ghost is computed, and sent, by both ranks).
  std::vector<std::array<ParticleId, 2>> touching, touchingTools;
  for (const auto& c : world_.contacts().particleContacts()) {
    touching.push_back({std::min(p.id[c.a], p.id[c.b]), std::max(p.id[c.a], p.id[c.b])});
  }
  for (const auto& c : world_.contacts().toolContacts()) touchingTools.push_back({p.id[c.a], c.b});
  putRaw(w, touching);
  putRaw(w, touchingTools);
  w.put(world_.densityScaling());  // this rank's decisions
  w.put(world_.bookedEnergy());    // this rank's share of the ledger
  const std::vector<std::vector<char>> parts = gatherBytes(w.bytes(), root);
  if (rank_ != root) return;

  struct Entry {
    dynamics::ParticleDef<D> def;
    std::uint64_t hash = 0;
    double densityScale = 0.0;
    int from = 0;
    typename dynamics::ContactSolver<D>::ParticleHistory history;
    Vec<D> forceVelocity;
    dynamics::Spin<D> forceSpin;
    Vec<D> force;
    dynamics::Spin<D> torque;
  };
  std::vector<Entry> run;
  dynamics::DensityScalingStats scaling;
  dynamics::EnergyLedger booked;
  touching.clear();  // (root's own are in its part)
  touchingTools.clear();
  for (int q = 0; q < ranks_; ++q) {
    const std::vector<char>& bytes = parts[std::size_t(q)];
    StateReader r(bytes.data(), bytes.size());
    getShapes(r, q);
    for (std::uint64_t k = 0, count = r.get<std::uint64_t>(); k < count; ++k) {
      Entry e;
      e.def = getParticle<D>(r, e.hash, e.densityScale);
      e.from = q;
      e.history = getHistory<D>(r);
      e.forceVelocity = r.get<Vec<D>>();
      e.forceSpin = r.get<dynamics::Spin<D>>();
      e.force = r.get<Vec<D>>();
      e.torque = r.get<dynamics::Spin<D>>();
      run.push_back(std::move(e));
    }
    std::vector<std::array<ParticleId, 2>> part;
    getRaw(r, part);
    touching.insert(touching.end(), part.begin(), part.end());
    getRaw(r, part);
    touchingTools.insert(touchingTools.end(), part.begin(), part.end());
    // The run's density scaling: every rank's decisions, one reference.
    const auto stats = r.get<dynamics::DensityScalingStats>();
    scaling.scaled += stats.scaled;
    scaling.capped += stats.capped;
    scaling.largestFactor = std::max(scaling.largestFactor, stats.largestFactor);
    scaling.referenceOmega2 = std::max(scaling.referenceOmega2, stats.referenceOmega2);
    booked.add(r.get<dynamics::EnergyLedger>());  // (in rank order)
    if (!r.atEnd()) throw std::runtime_error("MPI view: message from rank " + std::to_string(q) + " is malformed");
  }
  std::sort(run.begin(), run.end(), [](const Entry& a, const Entry& b) { return a.def.id < b.def.id; });

  // The view's particles that left the run go (highest index first), those
  // that remain take the run's state, the new ones enter in ascending id.
  const dynamics::Particles<D>& v = view.particles();
  const auto byId = [&](ParticleId id) {
    const auto it = std::lower_bound(run.begin(), run.end(), id, [](const Entry& e, ParticleId x) { return e.def.id < x; });
    return it != run.end() && it->def.id == id ? it : run.end();
  };
  for (std::size_t i = v.size(); i-- > 0;) {
    if (byId(v.id[i]) == run.end()) view.detachParticle(i);
  }
  std::unordered_map<ParticleId, std::size_t> index;
  for (std::size_t i = 0; i < v.size(); ++i) index.emplace(v.id[i], i);
  for (Entry& e : run) {
    const auto it = index.find(e.def.id);
    if (it != index.end()) {
      view.setMotion(it->second, e.def.position, e.def.orientation, e.def.velocity, e.def.angularVelocity);
      view.setStrength(it->second, e.def.strength);
    } else {
      e.def.shape = receivedShape(e.hash, e.def.id, e.from);
      view.addCopy(e.def, e.densityScale);
    }
  }
  std::vector<ParticleId> ids;
  std::vector<const typename dynamics::ContactSolver<D>::ParticleHistory*> histories;
  for (const Entry& e : run) {
    ids.push_back(e.def.id);
    histories.push_back(&e.history);
  }
  view.adoptHistories(ids, histories);
  std::vector<typename dynamics::World<D>::ShownParticle> shown(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    const auto e = byId(v.id[i]);
    shown[i] = {e->forceVelocity, e->forceSpin, e->force, e->torque, &e->history};
  }
  for (auto* list : {&touching, &touchingTools}) {
    std::sort(list->begin(), list->end());
    list->erase(std::unique(list->begin(), list->end()), list->end());
  }
  view.showRunOf(world_, shown, touching, touchingTools);
  view.setDensityScalingStats(scaling);
  // The run's ledger: its booked terms summed over the ranks; the kinetic
  // and elastic energy the view works out from the run's state.
  view.setBookedEnergy(booked);
  // The run's next free id (past particles the view never held: a fragment
  // gone before this view, a split into fines only), for its checkpoint.
  view.reserveIdsBelow(nextId_);
}

template class DistributedWorld<2>;
template class DistributedWorld<3>;

}  // namespace lsdem::parallel
