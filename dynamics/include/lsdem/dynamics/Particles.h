#pragma once
/// @file Particles.h
/// @brief The particle store: structure of arrays split by how often a field is
/// touched (STYLE 4).
///
/// - hot (read and written every step by the contact loop and the integrator):
///   position, orientation, velocity, angular velocity, force, torque.
///   One hot record is 6 x 8 x D bytes in 2D-vector fields plus the spin fields:
///   2D: 2+1+2+1+2+1 doubles = 72 bytes; 3D: 3+4+3+3+3+3 doubles = 152 bytes.
/// - warm (read every step, written rarely): mass and its inverse, inverse
///   principal inertia, shape, material, strength.
/// - cold (written once, read by output and breakage): global id, parent id,
///   generation, birth time.
///
/// Global ids are 64-bit and never reused (the store hands them out from a
/// counter that only grows), so a fragment can be traced to its ancestors.
/// Removal swaps the last particle into the hole, so indices are dense; the
/// order of particles is a pure function of the sequence of adds and removes,
/// which keeps runs deterministic.

#include "lsdem/dynamics/Rotation.h"
#include "lsdem/dynamics/State.h"
#include "lsdem/geometry/Shape.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace lsdem::dynamics {

using ParticleId = std::uint64_t;
inline constexpr ParticleId kNoParent = ~ParticleId(0);

/// Everything needed to add one particle (STYLE 7: a definition struct with defaults).
template <int D>
struct ParticleDef {
  std::shared_ptr<const geometry::Shape<D>> shape;  ///< required
  double density = 2650.0;                          ///< kg/m^3 (kg/m^2 per unit thickness in 2D)
  /// Factor (> 0) on the mass AND the inertia computed from shape x density:
  /// breakage's exact-mass correction of a fragment (breakage/Split.h,
  /// Fragment::massScale()). 1 for an ordinary particle.
  double massScale = 1.0;
  Vec<D> position = Vec<D>::Zero();                 ///< centroid, world frame, m
  Orientation<D> orientation = Rotation<D>::identity();
  Vec<D> velocity = Vec<D>::Zero();                 ///< m/s
  Spin<D> angularVelocity = Rotation<D>::zeroSpin(); ///< rad/s, world frame
  int material = 0;                                 ///< index into the world's materials
  double strength = 0.0;                            ///< critical stress, Pa (breakage)
  ParticleId parent = kNoParent;
  int generation = 0;
  double birthTime = 0.0;                           ///< s
  /// Its global id; kNoParent (the default): the next free id. A given id
  /// (a particle mirrored from another rank of a distributed run) must not
  /// be in use; ids above it are then the next free ones.
  ParticleId id = kNoParent;
  /// Mass (kg) and principal moments of inertia (kg m^2, body frame) as
  /// given, in place of density x massScale x the shape's: a particle
  /// mirrored from another rank keeps its owner's numbers bit for bit.
  /// 0 (the default): from the density.
  double mass = 0.0;
  Spin<D> inertia = Rotation<D>::zeroSpin();
};

template <int D>
class Particles {
 public:
  // ---- hot ----
  std::vector<Vec<D>> position;              ///< centroid, world, m
  std::vector<Orientation<D>> orientation;   ///< body to world
  std::vector<Vec<D>> velocity;              ///< m/s
  std::vector<Spin<D>> angularVelocity;      ///< rad/s, world frame
  std::vector<Vec<D>> force;                 ///< N, accumulated this step
  std::vector<Spin<D>> torque;               ///< N m about the centroid, world frame
  // ---- warm ----
  std::vector<double> mass;                  ///< kg
  std::vector<double> invMass;               ///< 1/kg
  std::vector<Spin<D>> inertia;              ///< principal moments (body frame), kg m^2
  std::vector<Spin<D>> invInertia;           ///< inverse principal moments, 1/(kg m^2)
  std::vector<std::shared_ptr<const geometry::Shape<D>>> shape;
  std::vector<int> material;
  std::vector<double> strength;              ///< Pa
  // ---- cold ----
  std::vector<ParticleId> id;
  std::vector<ParticleId> parentId;
  std::vector<int> generation;
  std::vector<double> birthTime;             ///< s

  std::size_t size() const { return position.size(); }
  bool empty() const { return position.empty(); }

  /// @brief Adds a particle; returns its index. Mass and inertia come from
  /// the shape's per-unit-density properties times `def.density` times `def.massScale`.
  /// @note Throws std::invalid_argument for a missing shape, a density <= 0 or a massScale <= 0.
  std::size_t add(const ParticleDef<D>& def);
  /// @brief Removes particle `index` by moving the last particle into its slot.
  void remove(std::size_t index);
  /// @brief The definition that adds particle i to another set as it is
  /// here: its id, shape, mass properties, state, strength and lineage.
  ParticleDef<D> definition(std::size_t i) const {
    ParticleDef<D> def;
    def.shape = shape[i];
    def.id = id[i];
    def.mass = mass[i];
    def.inertia = inertia[i];
    def.position = position[i];
    def.orientation = orientation[i];
    def.velocity = velocity[i];
    def.angularVelocity = angularVelocity[i];
    def.material = material[i];
    def.strength = strength[i];
    def.parent = parentId[i];
    def.generation = generation[i];
    def.birthTime = birthTime[i];
    return def;
  }
  /// @brief The next global id that add() will hand out.
  ParticleId nextId() const { return nextId_; }
  /// @brief Sets the id counter (restoring a checkpoint); never lowers it.
  void reserveIdsBelow(ParticleId next) { nextId_ = std::max(nextId_, next); }

  /// @brief Body-to-world rotation matrix of particle i.
  Mat<D> rotation(std::size_t i) const { return Rotation<D>::matrix(orientation[i]); }
  /// @brief Velocity of the material point of particle i at world position x.
  Vec<D> velocityAt(std::size_t i, const Vec<D>& x) const {
    return velocity[i] + Rotation<D>::velocityAt(angularVelocity[i], x - position[i]);
  }
  /// @brief Translational kinetic energy of particle i, J.
  double translationalEnergy(std::size_t i) const { return 0.5 * mass[i] * velocity[i].squaredNorm(); }
  /// @brief Rotational kinetic energy of particle i, J (in 3D 0.5 I w_b^2
  /// with the body-frame spin).
  double rotationalEnergy(std::size_t i) const;
  /// @brief Translational plus rotational kinetic energy of particle i, J.
  double kineticEnergy(std::size_t i) const { return translationalEnergy(i) + rotationalEnergy(i); }

  /// @brief Writes every field and the id counter; each shape as the number
  /// `shapeIndex` gives it (the caller stores the shapes themselves).
  void saveState(StateWriter& out,
                 const std::function<std::uint32_t(const std::shared_ptr<const geometry::Shape<D>>&)>& shapeIndex) const;
  /// @brief Replaces the store by what saveState wrote; `shapeAt` turns the
  /// numbers back into shapes (and throws for an unknown one).
  void loadState(StateReader& in, const std::function<std::shared_ptr<const geometry::Shape<D>>(std::uint32_t)>& shapeAt);

 private:
  ParticleId nextId_ = 0;
};

extern template class Particles<2>;
extern template class Particles<3>;

}  // namespace lsdem::dynamics
