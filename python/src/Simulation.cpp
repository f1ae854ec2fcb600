/// @file Simulation.cpp
/// @brief `lsdem.Simulation`: a world built from a scene (io::buildWorld, the
/// world `lsdem run` steps), stepped from Python with the GIL released, its
/// state read as numpy arrays, per-step Python callbacks, and the CLI's
/// per-world outputs (particle and contact frames, the breakage log, the
/// summary's world part).

#include "Bindings.h"

#include "lsdem/breakage/Criteria.h"
#include "lsdem/breakage/GrainStress.h"
#include "lsdem/io/BreakageLog.h"
#include "lsdem/io/Run.h"
#include "lsdem/io/Scene.h"
#include "lsdem/io/RunSummary.h"
#include "lsdem/io/Vtk.h"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <Python.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

namespace lsdem::python {

using namespace pybind11::literals;

namespace {

using dynamics::Orientation;
using dynamics::Spin;
using geometry::Vec;

// The particle store's records are read in place: check the layouts numpy is told.
static_assert(sizeof(Vec<2>) == 2 * sizeof(double) && sizeof(Vec<3>) == 3 * sizeof(double));
static_assert(sizeof(Orientation<3>) == 4 * sizeof(double));
static_assert(sizeof(int) == sizeof(std::int32_t));

/// Particle fields read in place (views).
enum class Field { Position, Velocity, AngularVelocity, Orientation, Force, Torque, Mass, Id, ParentId, Generation,
                   Strength, BirthTime };

/// Per-particle quantities of the shapes (copies).
enum class ShapeQuantity { EquivalentDiameter, SieveSize, Volume, BoundingRadius, Nodes };

// A read-only array over `count` records of `stride` bytes at `data`, each
// holding `inner` scalars of type S, kept alive by `owner`.
template <class S>
py::array viewOf(const void* data, std::size_t count, std::size_t stride, std::vector<py::ssize_t> inner,
                 py::handle owner) {
  std::vector<py::ssize_t> shape{py::ssize_t(count)};
  std::vector<py::ssize_t> strides{py::ssize_t(stride)};
  py::ssize_t step = sizeof(S);
  for (auto it = inner.rbegin(); it != inner.rend(); ++it) {
    strides.insert(strides.begin() + 1, step);
    step *= *it;
  }
  shape.insert(shape.end(), inner.begin(), inner.end());
  py::array a = count == 0 ? py::array(py::dtype::of<S>(), shape)
                           : py::array(py::dtype::of<S>(), shape, strides, static_cast<const S*>(data), owner);
  a.attr("setflags")("write"_a = false);
  return a;
}

// Copies: a fresh array of `shape`, filled by the caller through data().
template <class S>
py::array_t<S> fresh(std::vector<py::ssize_t> shape) {
  return py::array_t<S>(shape);
}

template <int D>
void putVec(double* out, const Vec<D>& v) {
  for (int k = 0; k < D; ++k) out[k] = v[k];
}

// A vector as a Python list of its D components.
template <int D>
std::vector<double> listOf(const Vec<D>& v) {
  return std::vector<double>(v.data(), v.data() + D);
}

template <int D>
constexpr int spinSize() {
  return D == 2 ? 1 : 3;
}

template <int D>
void putSpin(double* out, const Spin<D>& s) {
  if constexpr (D == 2) {
    out[0] = s;
  } else {
    for (int k = 0; k < 3; ++k) out[k] = s[k];
  }
}

// Spin arrays: (n,) in 2D, (n, 3) in 3D.
template <int D>
std::vector<py::ssize_t> spinShape(std::size_t n) {
  if constexpr (D == 2) return {py::ssize_t(n)};
  return {py::ssize_t(n), 3};
}

/// The world of one scene, whatever its dimension (the Python class).
class Simulation {
 public:
  struct Callback {
    std::uint64_t handle = 0;
    py::object fn;
    std::uint64_t every = 1;
  };

  virtual ~Simulation() = default;

  virtual int dimension() const = 0;
  virtual double time() const = 0;
  virtual double dt() const = 0;
  virtual double criticalDt() const = 0;
  virtual std::uint64_t stepCount() const = 0;
  virtual std::size_t particleCount() const = 0;
  virtual py::array view(Field f, py::handle owner) const = 0;
  virtual py::array rotations() const = 0;
  virtual py::array shapeQuantity(ShapeQuantity q) const = 0;
  virtual py::array trueMasses() const = 0;
  virtual py::array stresses() = 0;
  virtual py::dict contacts() = 0;
  virtual py::list breakageLog() const = 0;
  virtual py::list removed() const = 0;
  virtual py::dict energy() const = 0;
  virtual py::dict boundaries() const = 0;
  virtual std::string summaryJson() const = 0;
  virtual void writeParticles(const std::filesystem::path& path, bool ascii) = 0;
  virtual void writeContacts(const std::filesystem::path& path, bool ascii) = 0;
  virtual void writeBreakageLog(const std::filesystem::path& path) const = 0;
  virtual void refreshContacts() = 0;
  virtual std::string scenePath() const = 0;

  /// Steps `n` times with the GIL released; after each step the callbacks that
  /// are due run with the GIL held. Returns the steps done (fewer when a
  /// callback returned False).
  std::uint64_t step(py::handle self, std::uint64_t n) {
    if (busy_) throw std::runtime_error("this Simulation is already stepping (a callback or another thread called step)");
    Busy busy(busy_);
    std::uint64_t done = 0;
    {
      py::gil_scoped_release release;
      applyThreads();
      const auto start = std::chrono::steady_clock::now();
      struct AddWall {
        double& total;
        std::chrono::steady_clock::time_point start;
        ~AddWall() { total += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); }
      } wall{wallSeconds_, start};
      bool stop = false;
      while (done < n && !stop) {
        worldStep();
        ++done;
        const std::uint64_t s = stepCount();
        bool due = false;
        for (const Callback& c : callbacks_) due = due || s % c.every == 0;
        if (!due && done % kSignalEvery != 0) continue;
        py::gil_scoped_acquire acquire;
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
        // A copy: a callback may add or remove callbacks.
        const std::vector<Callback> calls = callbacks_;
        for (const Callback& c : calls) {
          if (s % c.every != 0) continue;
          const py::object r = c.fn(self);
          if (r.ptr() == Py_False) stop = true;
        }
      }
    }
    return done;
  }

  std::uint64_t addCallback(py::object fn, std::uint64_t every) {
    if (!PyCallable_Check(fn.ptr())) throw py::type_error("add_callback: expected a callable, got " + py::repr(fn).cast<std::string>());
    if (every == 0) throw py::value_error("add_callback: every must be >= 1");
    callbacks_.push_back({++lastHandle_, std::move(fn), every});
    return lastHandle_;
  }
  void removeCallback(std::uint64_t handle) {
    for (auto it = callbacks_.begin(); it != callbacks_.end(); ++it) {
      if (it->handle == handle) {
        callbacks_.erase(it);
        return;
      }
    }
    throw py::key_error("remove_callback: no callback " + std::to_string(handle));
  }
  std::size_t callbackCount() const { return callbacks_.size(); }

  int threads() const { return threads_; }
  void setThreads(const py::object& threads) { threads_ = checkedThreads(threads); }
  double wallSeconds() const { return wallSeconds_; }

 protected:
  virtual void worldStep() = 0;
  void applyThreads() const {
#ifdef LSDEM_HAVE_OPENMP
    omp_set_num_threads(threads_ > 0 ? threads_ : omp_get_num_procs());
#endif
  }
  // A busy check is done every this many steps even without callbacks: Ctrl-C.
  static constexpr std::uint64_t kSignalEvery = 256;
  struct Busy {
    bool& flag;
    explicit Busy(bool& f) : flag(f) { flag = true; }
    ~Busy() { flag = false; }
  };

  int threads_ = 0;
  double wallSeconds_ = 0.0;
  bool busy_ = false;
  std::vector<Callback> callbacks_;
  std::uint64_t lastHandle_ = 0;
};

template <int D>
class SimulationOf final : public Simulation {
 public:
  SimulationOf(io::SceneDef<D> scene, std::string path, int threads, bool check)
      : scene_(std::move(scene)), path_(std::move(path)) {
    threads_ = threads >= 0 ? threads : scene_.threads;
    if (check) scene_.world.checkFinite = true;
    sw_ = io::buildWorld(scene_);
    if (check && sw_.breakage) sw_.breakage->setSplitEnergyLimit(io::kCheckSplitEnergyLimit);
  }

  int dimension() const override { return D; }
  double time() const override { return world().time(); }
  double dt() const override { return world().dt(); }
  double criticalDt() const override { return world().criticalDt(); }
  std::uint64_t stepCount() const override { return world().steps(); }
  std::size_t particleCount() const override { return particles().size(); }
  std::string scenePath() const override { return path_; }

  py::array view(Field f, py::handle owner) const override {
    const dynamics::Particles<D>& p = particles();
    const std::size_t n = p.size();
    switch (f) {
      case Field::Position: return viewOf<double>(p.position.data(), n, sizeof(Vec<D>), {D}, owner);
      case Field::Velocity: return viewOf<double>(p.velocity.data(), n, sizeof(Vec<D>), {D}, owner);
      case Field::Force: return viewOf<double>(p.force.data(), n, sizeof(Vec<D>), {D}, owner);
      case Field::AngularVelocity:
      case Field::Torque: {
        const auto& v = f == Field::Torque ? p.torque : p.angularVelocity;
        if constexpr (D == 2) return viewOf<double>(v.data(), n, sizeof(double), {}, owner);
        else return viewOf<double>(v.data(), n, sizeof(Vec<3>), {3}, owner);
      }
      case Field::Orientation:
        if constexpr (D == 2) {
          return viewOf<double>(p.orientation.data(), n, sizeof(double), {}, owner);
        } else {
          // Eigen keeps a quaternion's coefficients as x, y, z, w.
          return viewOf<double>(n ? p.orientation[0].coeffs().data() : nullptr, n, sizeof(Orientation<3>), {4}, owner);
        }
      case Field::Mass: return viewOf<double>(p.mass.data(), n, sizeof(double), {}, owner);
      case Field::Strength: return viewOf<double>(p.strength.data(), n, sizeof(double), {}, owner);
      case Field::BirthTime: return viewOf<double>(p.birthTime.data(), n, sizeof(double), {}, owner);
      case Field::Id: return viewOf<std::uint64_t>(p.id.data(), n, sizeof(std::uint64_t), {}, owner);
      case Field::ParentId: return viewOf<std::uint64_t>(p.parentId.data(), n, sizeof(std::uint64_t), {}, owner);
      case Field::Generation: return viewOf<std::int32_t>(p.generation.data(), n, sizeof(int), {}, owner);
    }
    throw std::logic_error("unknown field");
  }

  py::array rotations() const override {
    const auto& p = particles();
    auto a = fresh<double>({py::ssize_t(p.size()), D, D});
    double* out = a.mutable_data();
    for (std::size_t i = 0; i < p.size(); ++i) {
      const geometry::Mat<D> r = p.rotation(i);
      for (int row = 0; row < D; ++row)
        for (int col = 0; col < D; ++col) *out++ = r(row, col);
    }
    return a;
  }

  py::array shapeQuantity(ShapeQuantity q) const override {
    const auto& p = particles();
    auto a = fresh<double>({py::ssize_t(p.size())});
    double* out = a.mutable_data();
    for (std::size_t i = 0; i < p.size(); ++i) {
      const geometry::Shape<D>& s = *p.shape[i];
      switch (q) {
        case ShapeQuantity::EquivalentDiameter: out[i] = s.descriptors().equivalentDiameter; break;
        case ShapeQuantity::SieveSize: out[i] = s.descriptors().sieveSize; break;
        case ShapeQuantity::Volume: out[i] = s.volume(); break;
        case ShapeQuantity::BoundingRadius: out[i] = s.boundingRadius(); break;
        case ShapeQuantity::Nodes: out[i] = double(s.nodes().size()); break;
      }
    }
    return a;
  }

  py::array trueMasses() const override {
    const auto& w = world();
    auto a = fresh<double>({py::ssize_t(w.particles().size())});
    double* out = a.mutable_data();
    for (std::size_t i = 0; i < w.particles().size(); ++i) out[i] = w.unscaledMass(i);
    return a;
  }

  // As the frames of `lsdem run` compute them: the criterion's characteristic
  // stress of each particle from the current contacts.
  py::array stresses() override {
    current();
    const auto& p = particles();
    if (!criterion_) {
      breakage::CriterionDef def;
      if (scene_.breakage) def = scene_.breakage->criterion;
      criterion_ = breakage::makeCriterion(def);
    }
    breakage::grainStresses(p, world().contacts(), stress_);
    stressMeasure_.assign(p.size(), 0.0);
    for (std::size_t i = 0; i < p.size() && i < stress_.size(); ++i) {
      stressMeasure_[i] = criterion_->characteristicStress(breakage::principalStressTriple<D>(stress_[i]));
    }
    auto a = fresh<double>({py::ssize_t(p.size())});
    std::copy(stressMeasure_.begin(), stressMeasure_.end(), a.mutable_data());
    return a;
  }

  py::dict contacts() override {
    current();
    const auto& p = particles();
    const dynamics::ContactSolver<D>& c = world().contacts();
    const auto pairs = c.pairContacts();
    const auto nodes = c.nodeContacts();
    const std::size_t m = pairs.size(), k = nodes.size();
    const std::size_t particlePairs = c.particleContacts().size(), planePairs = c.planeContacts().size();

    auto kind = fresh<std::int8_t>({py::ssize_t(m)});
    auto a = fresh<std::int64_t>({py::ssize_t(m)}), b = fresh<std::int64_t>({py::ssize_t(m)});
    auto idA = fresh<std::uint64_t>({py::ssize_t(m)}), idB = fresh<std::uint64_t>({py::ssize_t(m)});
    auto force = fresh<double>({py::ssize_t(m), D});
    auto torqueA = fresh<double>(spinShape<D>(m)), torqueB = fresh<double>(spinShape<D>(m));
    auto nodeCount = fresh<std::int64_t>({py::ssize_t(m)}), firstNode = fresh<std::int64_t>({py::ssize_t(m)});
    auto elastic = fresh<double>({py::ssize_t(m)}), dissipated = fresh<double>({py::ssize_t(m)});
    auto pairOfNode = fresh<std::int64_t>({py::ssize_t(k)});
    for (std::size_t j = 0; j < m; ++j) {
      const dynamics::PairContact<D>& r = pairs[j];
      const int kd = j < particlePairs ? 0 : (j < particlePairs + planePairs ? 1 : 2);
      kind.mutable_data()[j] = std::int8_t(kd);
      a.mutable_data()[j] = r.a;
      b.mutable_data()[j] = r.b;
      idA.mutable_data()[j] = p.id.at(r.a);
      idB.mutable_data()[j] = kd == 0 ? p.id.at(r.b) : dynamics::kNoParent;
      putVec<D>(force.mutable_data() + D * j, r.force);
      putSpin<D>(torqueA.mutable_data() + spinSize<D>() * j, r.torqueA);
      putSpin<D>(torqueB.mutable_data() + spinSize<D>() * j, r.torqueB);
      nodeCount.mutable_data()[j] = r.nodeCount;
      firstNode.mutable_data()[j] = r.firstNode;
      elastic.mutable_data()[j] = r.elasticEnergy;
      dissipated.mutable_data()[j] = r.dissipatedPower;
      for (std::uint32_t q = 0; q < r.nodeCount; ++q) pairOfNode.mutable_data()[r.firstNode + q] = std::int64_t(j);
    }
    auto point = fresh<double>({py::ssize_t(k), D}), normal = fresh<double>({py::ssize_t(k), D});
    auto nodeForce = fresh<double>({py::ssize_t(k), D});
    auto overlap = fresh<double>({py::ssize_t(k)});
    auto node = fresh<std::int64_t>({py::ssize_t(k)});
    auto ownerIsB = fresh<bool>({py::ssize_t(k)});
    for (std::size_t j = 0; j < k; ++j) {
      const dynamics::NodeContact<D>& r = nodes[j];
      putVec<D>(point.mutable_data() + D * j, r.point);
      putVec<D>(normal.mutable_data() + D * j, r.normal);
      putVec<D>(nodeForce.mutable_data() + D * j, r.force);
      overlap.mutable_data()[j] = r.overlap;
      node.mutable_data()[j] = r.node;
      ownerIsB.mutable_data()[j] = r.ownerIsB != 0;
    }
    py::dict pd;
    pd["kind"] = kind;
    pd["a"] = a;
    pd["b"] = b;
    pd["id_a"] = idA;
    pd["id_b"] = idB;
    pd["force"] = force;
    pd["torque_a"] = torqueA;
    pd["torque_b"] = torqueB;
    pd["node_count"] = nodeCount;
    pd["first_node"] = firstNode;
    pd["elastic_energy"] = elastic;
    pd["dissipated_power"] = dissipated;
    py::dict nd;
    nd["pair"] = pairOfNode;
    nd["point"] = point;
    nd["normal"] = normal;
    nd["force"] = nodeForce;
    nd["overlap"] = overlap;
    nd["node"] = node;
    nd["owner_is_b"] = ownerIsB;
    py::dict out;
    out["pairs"] = pd;
    out["nodes"] = nd;
    return out;
  }

  py::list breakageLog() const override {
    py::list out;
    if (!sw_.breakage) return out;
    for (const breakage::BreakageEvent<D>& e : sw_.breakage->events()) {
      py::dict d;
      d["time"] = e.time;
      d["parent"] = e.parent;
      d["children"] = e.children;
      d["criterion_value"] = e.criterionValue;
      d["strength"] = e.strength;
      d["manual"] = e.manual;
      d["buckling"] = e.buckling;
      d["mode"] = breakage::breakageModeName(e.mode());
      d["chip_depth"] = e.chipDepth;
      d["plane_normal"] = listOf<D>(e.planeNormal);
      d["plane_offset"] = e.planeOffset;
      d["child_volumes"] = e.childVolumes;
      d["fines_volumes"] = e.finesVolumes;
      d["parent_mass"] = e.parentMass;
      d["fragment_mass"] = e.fragmentMass;
      d["parent_momentum"] = listOf<D>(e.parentMomentum);
      d["fragment_momentum"] = listOf<D>(e.fragmentMomentum);
      d["parent_kinetic_energy"] = e.parentKineticEnergy;
      d["fragment_kinetic_energy"] = e.fragmentKineticEnergy;
      d["parent_spring_energy"] = e.parentSpringEnergy;
      d["fragment_spring_energy"] = e.fragmentSpringEnergy;
      d["inertia_energy_bound"] = e.inertiaEnergyBound;
      d["energy_gain"] = e.energyGain();
      d["raw_volume_error"] = e.rawVolumeError;
      d["inertia_relative_error"] = e.inertiaRelativeError;
      out.append(d);
    }
    return out;
  }

  py::list removed() const override {
    py::list out;
    for (const dynamics::RemovedParticle& r : world().removed()) {
      py::dict d;
      d["id"] = r.id;
      d["time"] = r.time;
      d["mass"] = r.mass;
      d["volume"] = r.volume;
      d["sieve_size"] = r.sieveSize;
      d["reason"] = r.reason;
      out.append(d);
    }
    return out;
  }

  py::dict energy() const override {
    const dynamics::EnergyLedger& e = world().energy();
    py::dict d;
    d["kinetic_translational"] = e.kineticTranslational;
    d["kinetic_rotational"] = e.kineticRotational;
    d["elastic"] = e.elastic;
    d["gravity_work"] = e.gravityWork;
    d["boundary_work"] = e.boundaryWork;
    d["damping_loss"] = e.dampingLoss;
    d["contact_loss"] = e.contactLoss;
    d["removed"] = e.removedEnergy;
    d["added"] = e.addedEnergy;
    d["split_release"] = e.splitRelease;
    d["initial"] = e.initial;
    d["total"] = e.total();
    d["balance_error"] = e.balanceError();
    d["relative_balance_error"] = e.relativeBalanceError();
    return d;
  }

  py::dict boundaries() const override {
    const auto& w = world();
    const dynamics::BoundaryLoads<D>& loads = w.boundaryLoads();
    py::list planes, tools;
    for (std::size_t j = 0; j < w.planes().size(); ++j) {
      const dynamics::Plane<D>& pl = w.planes()[j];
      py::dict d;
      d["name"] = j < w.planeNames().size() ? w.planeNames()[j] : std::string();
      d["point"] = vecArray(pl.point);
      d["normal"] = vecArray(pl.normal);
      d["velocity"] = vecArray(pl.velocity);
      d["force"] = vecArray(j < loads.planeForce.size() ? loads.planeForce[j] : Vec<D>::Zero().eval());
      planes.append(d);
    }
    for (std::size_t j = 0; j < w.tools().size(); ++j) {
      const dynamics::ToolPose<D>& pose = w.toolPoses().at(j);
      py::dict d;
      d["name"] = w.tools()[j].name;
      d["position"] = vecArray(pose.position);
      d["velocity"] = vecArray(pose.velocity);
      d["force"] = vecArray(j < loads.toolForce.size() ? loads.toolForce[j] : Vec<D>::Zero().eval());
      tools.append(d);
    }
    py::dict out;
    out["planes"] = planes;
    out["tools"] = tools;
    return out;
  }

  std::string summaryJson() const override {
    std::ostringstream s;
    io::writeRunSummary<D>(world(), wallSeconds_, s);
    return s.str();
  }

  void writeParticles(const std::filesystem::path& path, bool ascii) override {
    stresses();  // into stressMeasure_ and stress_
    io::writeParticleFrame<D>(path, world(), stressMeasure_, ascii ? io::VtkEncoding::Ascii : io::VtkEncoding::Binary,
                              stress_);
  }
  void writeContacts(const std::filesystem::path& path, bool ascii) override {
    current();
    io::writeContactFrame<D>(path, world(), ascii ? io::VtkEncoding::Ascii : io::VtkEncoding::Binary);
  }
  void writeBreakageLog(const std::filesystem::path& path) const override {
    std::ostringstream s;
    io::writeBreakageLogHeader<D>(s);
    if (sw_.breakage) io::writeBreakageLogRows<D>(sw_.breakage->events(), s);
    io::writeFileAtomically(path, s.str());
  }
  void refreshContacts() override { world().refreshContacts(); }

 protected:
  void worldStep() override { world().step(); }

 private:
  dynamics::World<D>& world() { return *sw_.world; }
  const dynamics::World<D>& world() const { return *sw_.world; }
  const dynamics::Particles<D>& particles() const { return sw_.world->particles(); }
  // Contacts describe the particles as they are: evaluated again if the set
  // changed since (what the next step does first anyway).
  void current() {
    if (!world().contactsCurrent()) {
      py::gil_scoped_release release;
      applyThreads();
      world().refreshContacts();
    }
  }
  static py::array vecArray(const Vec<D>& v) {
    auto a = fresh<double>({D});
    putVec<D>(a.mutable_data(), v);
    return a;
  }

  io::SceneDef<D> scene_;
  std::string path_;
  io::SceneWorld<D> sw_;
  std::unique_ptr<breakage::Criterion> criterion_;
  std::vector<geometry::Mat<D>> stress_;
  std::vector<double> stressMeasure_;
};

std::unique_ptr<Simulation> makeSimulation(const py::handle& scene, int threads, bool check) {
  const std::shared_ptr<SceneHandle> s = sceneOf(scene);
  if (const auto* d2 = std::get_if<io::SceneDef<2>>(s->def.get())) {
    return std::make_unique<SimulationOf<2>>(*d2, s->path, threads, check);
  }
  return std::make_unique<SimulationOf<3>>(std::get<io::SceneDef<3>>(*s->def), s->path, threads, check);
}

}  // namespace

void bindSimulation(py::module_& m) {
  py::class_<Simulation> c(m, "Simulation", R"doc(
The world of a scene, built as `lsdem run` builds it (particles placed, planes,
tools and the declared effects), stepped from Python.

Simulation(scene, threads=None, check=False): scene is an lsdem.Scene, a dict (as
Scene.from_dict takes) or a path.
threads: OpenMP threads for step() (None: the scene's; 0: all cores). check:
the checks of `lsdem run --check`.

Particle arrays (positions, velocities, ...) are copies of the world's
storage as it is when read, in store order: read them again after stepping.
Methods (rotations(), contacts(), ...) return fresh copies too.
)doc");
  c.def(py::init([](const py::object& scene, const py::object& threads, bool check) {
          return makeSimulation(scene, threads.is_none() ? -1 : checkedThreads(threads), check);
        }),
        py::arg("scene"), py::arg("threads") = py::none(), py::arg("check") = false)
      .def(
          "step",
          [](py::object self, std::uint64_t n) { return self.cast<Simulation&>().step(self, n); }, py::arg("n") = 1,
          R"doc(Advances n steps (the GIL is released while the world steps; callbacks
run with it held after the steps they are due at). Returns the steps done:
fewer than n when a callback returned False. Ctrl-C raises KeyboardInterrupt
between steps.)doc")
      .def("add_callback", &Simulation::addCallback, py::arg("fn"), py::arg("every") = 1,
           R"doc(Calls fn(sim) after every step whose step count is a multiple of `every`,
during step(). fn returning False stops step() after that step. Returns a
handle for remove_callback.)doc")
      .def("remove_callback", &Simulation::removeCallback, py::arg("handle"), "Removes a callback add_callback returned.")
      .def_property_readonly("callbacks", &Simulation::callbackCount, "Number of callbacks.")
      .def_property("threads", &Simulation::threads, &Simulation::setThreads,
                    "OpenMP threads step() uses (0: all cores).")
      .def_property_readonly("dimension", &Simulation::dimension, "2 or 3.")
      .def_property_readonly("time", &Simulation::time, "Simulated time, s.")
      .def_property_readonly("dt", &Simulation::dt, "The time step, s.")
      .def_property_readonly("critical_dt", &Simulation::criticalDt, "The critical time step of the particles now, s.")
      .def_property_readonly("steps", &Simulation::stepCount, "Steps done.")
      .def_property_readonly("wall_seconds", &Simulation::wallSeconds, "Wall-clock seconds spent in step().")
      .def_property_readonly("scene_path", &Simulation::scenePath, "The scene file the world was built from.")
      .def("__len__", &Simulation::particleCount, "Number of particles.");

  // Copies: a view of the world's storage would read freed memory once a
  // breakage, removal or insertion moved it (silently wrong numbers).
  const auto field = [&](const char* name, Field f, const char* doc) {
    c.def_property_readonly(
        name, [f](py::object self) { return self.cast<const Simulation&>().view(f, self).attr("copy")(); }, doc);
  };
  field("positions", Field::Position, "(n, D) float64: centroids, world frame, m.");
  field("velocities", Field::Velocity, "(n, D) float64: centroid velocities, m/s.");
  field("angular_velocities", Field::AngularVelocity,
        "float64: angular velocities, world frame, rad/s; (n,) in 2D (about z), (n, 3) in 3D.");
  field("orientations", Field::Orientation,
        "float64, body to world: 2D (n,) angles about z, rad; 3D (n, 4) unit quaternions, scalar last "
        "(x, y, z, w) as scipy.spatial.transform.Rotation.from_quat takes them.");
  field("forces", Field::Force, "(n, D) float64: total force of the last evaluation (contacts and effects), N.");
  field("torques", Field::Torque, "float64: total torque about the centroid, N m; (n,) in 2D, (n, 3) in 3D.");
  field("masses", Field::Mass, "(n,) float64: masses as the dynamics see them (density scaling included), kg.");
  field("ids", Field::Id, "(n,) uint64: global ids (never reused).");
  field("parent_ids", Field::ParentId, "(n,) uint64: the parent's id, 2**64 - 1 for none.");
  field("generations", Field::Generation, "(n,) int32: 0 for an original particle, parent's + 1 for a fragment.");
  field("strengths", Field::Strength, "(n,) float64: breakage strengths, Pa (0: not yet drawn, inf: unbreakable).");
  field("birth_times", Field::BirthTime, "(n,) float64: simulated time each particle entered, s.");

  c.def(
      "state",
      [](py::object self) {
        const auto& sim = self.cast<const Simulation&>();
        py::dict d;
        const std::pair<const char*, Field> fields[] = {
            {"positions", Field::Position},   {"velocities", Field::Velocity}, {"angular_velocities", Field::AngularVelocity},
            {"orientations", Field::Orientation}, {"forces", Field::Force},  {"torques", Field::Torque},
            {"masses", Field::Mass},           {"ids", Field::Id},            {"parent_ids", Field::ParentId},
            {"generations", Field::Generation}, {"strengths", Field::Strength}, {"birth_times", Field::BirthTime}};
        for (const auto& [name, f] : fields) d[name] = sim.view(f, self).attr("copy")();
        d["rotations"] = sim.rotations();
        d["time"] = sim.time();
        d["steps"] = sim.stepCount();
        return d;
      },
      "Copies of every particle array (the views' names, writable, owned), with rotations, time and steps: "
      "values that stay as they are while the world goes on.");
  c.def("rotations", &Simulation::rotations, "(n, D, D) float64 copy: body-to-world rotation matrices.")
      .def("true_masses", &Simulation::trueMasses, "(n,) float64 copy: masses without density scaling, kg.")
      .def(
          "equivalent_diameters",
          [](const Simulation& s) { return s.shapeQuantity(ShapeQuantity::EquivalentDiameter); },
          "(n,) float64 copy: diameter of the circle (sphere) of the particle's area (volume), m.")
      .def(
          "sieve_sizes", [](const Simulation& s) { return s.shapeQuantity(ShapeQuantity::SieveSize); },
          "(n,) float64 copy: sieve sizes (eq. 21), m, as psd.csv uses them.")
      .def(
          "volumes", [](const Simulation& s) { return s.shapeQuantity(ShapeQuantity::Volume); },
          "(n,) float64 copy: shape volumes (areas in 2D), m^D.")
      .def(
          "bounding_radii", [](const Simulation& s) { return s.shapeQuantity(ShapeQuantity::BoundingRadius); },
          "(n,) float64 copy: bounding-sphere radii, m.")
      .def(
          "node_counts", [](const Simulation& s) { return s.shapeQuantity(ShapeQuantity::Nodes).attr("astype")("int64"); },
          "(n,) int64 copy: surface nodes per particle.")
      .def("stresses", &Simulation::stresses,
           "(n,) float64 copy: each particle's breakage-criterion stress from the current contacts, Pa (the "
           "frames' `stress`).")
      .def("contacts", &Simulation::contacts,
           "The contacts of the last evaluation (evaluated first if the particles changed since), copies: "
           "{'pairs': {...}, 'nodes': {...}} (docs/python.md).")
      .def("refresh_contacts", &Simulation::refreshContacts,
           "Evaluates the contacts of the particles as they are, if they changed since the last evaluation.")
      .def("breakage_log", &Simulation::breakageLog, "Every breakage so far, one dict each, in order.")
      .def("removed", &Simulation::removed, "Every particle removed so far (outflow, fines), one dict each.")
      .def("energy", &Simulation::energy, "The energy ledger, J.")
      .def("boundaries", &Simulation::boundaries,
           "Planes and tools now, with the particles' force on each from the last step.")
      .def(
          "summary",
          [](const Simulation& s) { return py::module_::import("json").attr("loads")(s.summaryJson()); },
          "summary.json's world part as a dict (what `lsdem run` writes before its run's own keys).")
      .def("write_particles_vtp", &Simulation::writeParticles, py::arg("path"), py::arg("ascii") = false,
           "Writes the particle frame `lsdem run` writes (frames/particles_*.vtp) to `path`.")
      .def("write_contacts_vtp", &Simulation::writeContacts, py::arg("path"), py::arg("ascii") = false,
           "Writes the contact force-chain frame (frames/contacts_*.vtp) to `path`.")
      .def("write_breakage_log", &Simulation::writeBreakageLog, py::arg("path"),
           "Writes breakage_log.csv as `lsdem run` writes it.")
      .def("__repr__", [](const Simulation& s) {
        return "<lsdem.Simulation " + std::to_string(s.dimension()) + "D, " + std::to_string(s.particleCount()) +
               " particles, step " + std::to_string(s.stepCount()) + ">";
      });
}

}  // namespace lsdem::python
