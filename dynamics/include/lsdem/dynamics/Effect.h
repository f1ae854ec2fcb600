#pragma once
/// @file Effect.h
/// @brief Effects a scene declares, plugged into the step (DESIGN "Effects:
/// simulate only what the scene calls for"). A world holds only the effects
/// its scene declared; an absent effect costs nothing per step: no branch in
/// any particle or node loop, no memory. Each effect is called once per step
/// (one virtual call per effect, never per particle or node) and its time is
/// reported per stage.
///
/// Built-in effects: gravity, global viscous damping (C_g, Tables 1-2), local
/// non-viscous damping (Cundall), outflow removal. Contact damping and friction
/// are parts of the contact law (ContactLaw.h), chosen the same way; kinematic
/// drivers are the world's tools; breakage (breakage/) is one more effect.

#include "lsdem/dynamics/Rotation.h"
#include "lsdem/dynamics/State.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/Types.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace lsdem::dynamics {

template <int D>
class World;

template <int D>
class Effect {
 public:
  virtual ~Effect() = default;
  /// @brief Name in the run summary ("gravity", "global_damping", ...).
  virtual std::string name() const = 0;
  /// @brief Adds this effect's forces and torques to the particles, after the
  /// contact forces and before the closing half kick. Velocities are the
  /// half-step ones; `dt` is the step the forces close (0 for the initial
  /// force evaluation, when no work is done). A ghost (World::isGhost) is
  /// left alone: its force, and the work and power of it, are its owner's.
  virtual void applyForces(World<D>& world, double dt) {
    (void)world;
    (void)dt;
  }
  /// @brief Power the forces of the last applyForces() take out of the
  /// particles, W (damping effects; 0 for others). The World books it into
  /// the ledger's damping loss over the half kicks those forces act through.
  virtual double dampingPower() const { return 0.0; }
  /// @brief Runs between steps, after the integration (removal, breakage,
  /// recorders). May add, remove or replace particles (through World).
  virtual void afterStep(World<D>& world) { (void)world; }
  /// @brief True when afterStep reads World::contacts(). The world then
  /// hands it contact records of the particles as they are: where an earlier
  /// effect of the same afterStep changed the particles, it evaluates them
  /// again first (World::refreshContacts), so effects need no declaration order.
  virtual bool readsContacts() const { return false; }
  /// @brief True when afterStep may replace particles (World::replace, at
  /// most once per step: breakage). In a distributed run every world joins
  /// the replacement's collective calls after it, with an empty batch when
  /// it replaced nothing (ParticleSetCoordinator.h).
  virtual bool replacesParticles() const { return false; }
  /// @brief True when afterStep may add or remove particles other than
  /// through World::replace (outflow, feeds). In a distributed run the world
  /// agrees with the others after it (ParticleSetCoordinator.h): such an
  /// effect must change the particle set alike in every world (a decision
  /// taken from the whole run's particles goes through World::anyWorld).
  virtual bool changesParticles() const { return false; }
  /// @brief True when a distributed run (parallel::DistributedWorld) may run
  /// the effect on every rank alike: applyForces acts on each particle a
  /// rank owns from that particle's own state (leaving ghosts alone, as
  /// above), and afterStep changes the particle set only as
  /// replacesParticles and changesParticles declare. False (the default):
  /// a distributed run refuses the effect, since one that reads other
  /// particles, or keeps state of the whole set, would compute something
  /// else on N ranks.
  virtual bool distributable() const { return false; }
  /// @brief Writes the effect's state (a checkpoint); stateless effects write nothing.
  virtual void saveState(StateWriter& out) const { (void)out; }
  /// @brief Reads back what saveState wrote, into an effect built from the same definition.
  virtual void loadState(StateReader& in) { (void)in; }
};

/// Uniform gravity: F = m g. Its work is accumulated in the world's energy ledger.
template <int D>
class Gravity final : public Effect<D> {
 public:
  explicit Gravity(const Vec<D>& g) : g_(g) {}
  std::string name() const override { return "gravity"; }
  bool distributable() const override { return true; }
  void applyForces(World<D>& world, double dt) override;
  const Vec<D>& acceleration() const { return g_; }

 private:
  Vec<D> g_;
};

/// Global viscous damping (the paper's C_g, in 1/s): F = -C_g m v and
/// T = -C_g I w (principal frame). The energy it removes is booked by the World.
template <int D>
class GlobalDamping final : public Effect<D> {
 public:
  explicit GlobalDamping(double coefficient);
  std::string name() const override { return "global_damping"; }
  bool distributable() const override { return true; }
  void applyForces(World<D>& world, double dt) override;
  double dampingPower() const override { return power_; }

 private:
  double c_;
  double power_ = 0.0;
};

/// Local non-viscous damping (Cundall): each component of the force and torque
/// is reduced by alpha |F_c| in the direction opposing the velocity component,
/// F_c -= alpha |F_c| sign(v_c). Kills oscillations without slowing free fall.
template <int D>
class LocalDamping final : public Effect<D> {
 public:
  explicit LocalDamping(double alpha);
  std::string name() const override { return "local_damping"; }
  bool distributable() const override { return true; }
  void applyForces(World<D>& world, double dt) override;
  double dampingPower() const override { return power_; }

 private:
  double alpha_;
  double power_ = 0.0;
};

/// Outflow removal: a particle whose centroid leaves the region `keep` is
/// recorded (id, time, mass, volume, sieve size) and removed.
template <int D>
class Outflow final : public Effect<D> {
 public:
  /// @param keep particles whose centroid leaves this box are removed.
  /// @param discharge optional: a removed particle whose centroid lies in
  ///   this box left through the discharge (a crusher's product) and is
  ///   recorded with reason "discharge"; the others with reason "outflow".
  explicit Outflow(const geometry::Box<D>& keep, std::optional<geometry::Box<D>> discharge = std::nullopt)
      : keep_(keep), discharge_(std::move(discharge)) {}
  std::string name() const override { return "outflow"; }
  bool distributable() const override { return true; }
  /// Removes in ascending id order (the removal records' order).
  void afterStep(World<D>& world) override;
  bool changesParticles() const override { return true; }

 private:
  geometry::Box<D> keep_;
  std::optional<geometry::Box<D>> discharge_;
};

/// Definition of a feed: grains dropped one at a time from a point (the jaw
/// crusher's feed, paper section 4).
template <int D>
struct FeedDef {
  /// Shapes dropped in this order, cycled (required, non-null).
  std::vector<std::shared_ptr<const geometry::Shape<D>>> shapes;
  Vec<D> point = Vec<D>::Zero();      ///< where each grain's centroid starts, world, m
  Vec<D> velocity = Vec<D>::Zero();   ///< initial velocity, m/s
  double density = 2650.0;            ///< kg/m^3 (kg/m^2 in 2D), > 0
  int material = 0;
  /// > 0: a grain every `interval` seconds. 0: a grain as soon as the last
  /// one has cleared the point (see `clearance`).
  double interval = 0.0;
  /// With interval = 0: the last grain has cleared when its centroid is farther
  /// than this from `point` (m, > 0), or it no longer exists (broken, removed).
  double clearance = 0.0;
  std::uint64_t count = 0;            ///< grains to drop in all; 0 = no limit
  double startTime = 0.0;             ///< no grain before this time, s
};

/// A feed (FeedDef): between steps, adds the next grain when it is due and
/// the drop point is free (no particle's bounding sphere reaches the grain's).
/// The first grain drops at the first step ending at or after startTime.
template <int D>
class Feed final : public Effect<D> {
 public:
  /// @note Throws std::invalid_argument for no shapes, a null shape, density
  /// <= 0, interval < 0, or interval = 0 without a clearance > 0.
  explicit Feed(FeedDef<D> def);
  std::string name() const override { return "feed"; }
  bool distributable() const override { return true; }
  void afterStep(World<D>& world) override;
  bool changesParticles() const override { return true; }
  void saveState(StateWriter& out) const override;
  void loadState(StateReader& in) override;
  /// @brief Grains dropped so far.
  std::uint64_t dropped() const { return dropped_; }
  /// @brief Mass dropped so far, kg.
  double droppedMass() const { return droppedMass_; }

 private:
  bool due(World<D>& world) const;  // collective in a distributed run (World::anyWorld)

  FeedDef<D> def_;
  std::uint64_t dropped_ = 0;
  double lastDropTime_ = 0.0;
  std::uint64_t lastId_ = 0;
  double droppedMass_ = 0.0;
};

extern template class Feed<2>;
extern template class Feed<3>;
extern template class Gravity<2>;
extern template class Gravity<3>;
extern template class GlobalDamping<2>;
extern template class GlobalDamping<3>;
extern template class LocalDamping<2>;
extern template class LocalDamping<3>;
extern template class Outflow<2>;
extern template class Outflow<3>;

}  // namespace lsdem::dynamics
