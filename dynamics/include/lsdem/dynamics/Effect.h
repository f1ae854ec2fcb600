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
#include "lsdem/geometry/Types.h"

#include <string>

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
  /// force evaluation, when no work is done).
  virtual void applyForces(World<D>& world, double dt) {
    (void)world;
    (void)dt;
  }
  /// @brief Runs between steps, after the integration (removal, breakage,
  /// recorders). May add or remove particles.
  virtual void afterStep(World<D>& world) { (void)world; }
};

/// Uniform gravity: F = m g. Its work is accumulated in the world's energy ledger.
template <int D>
class Gravity final : public Effect<D> {
 public:
  explicit Gravity(const Vec<D>& g) : g_(g) {}
  std::string name() const override { return "gravity"; }
  void applyForces(World<D>& world, double dt) override;
  const Vec<D>& acceleration() const { return g_; }

 private:
  Vec<D> g_;
};

/// Global viscous damping (the paper's C_g, in 1/s): F = -C_g m v and
/// T = -C_g I w (principal frame). The energy it removes is accumulated.
template <int D>
class GlobalDamping final : public Effect<D> {
 public:
  explicit GlobalDamping(double coefficient);
  std::string name() const override { return "global_damping"; }
  void applyForces(World<D>& world, double dt) override;

 private:
  double c_;
};

/// Local non-viscous damping (Cundall): each component of the force and torque
/// is reduced by alpha |F_c| in the direction opposing the velocity component,
/// F_c -= alpha |F_c| sign(v_c). Kills oscillations without slowing free fall.
template <int D>
class LocalDamping final : public Effect<D> {
 public:
  explicit LocalDamping(double alpha);
  std::string name() const override { return "local_damping"; }
  void applyForces(World<D>& world, double dt) override;

 private:
  double alpha_;
};

/// Outflow removal: a particle whose centroid leaves the region `keep` is
/// recorded (id, time, mass, volume, sieve size) and removed.
template <int D>
class Outflow final : public Effect<D> {
 public:
  explicit Outflow(const geometry::Box<D>& keep) : keep_(keep) {}
  std::string name() const override { return "outflow"; }
  void afterStep(World<D>& world) override;

 private:
  geometry::Box<D> keep_;
};

extern template class Gravity<2>;
extern template class Gravity<3>;
extern template class GlobalDamping<2>;
extern template class GlobalDamping<3>;
extern template class LocalDamping<2>;
extern template class LocalDamping<3>;
extern template class Outflow<2>;
extern template class Outflow<3>;

}  // namespace lsdem::dynamics
