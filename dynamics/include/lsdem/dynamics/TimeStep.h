#pragma once
/// @file TimeStep.h
/// @brief The automatic critical time step of the explicit scheme.
///
/// The estimate. Our integrator (Integrator.h, velocity Verlet with the forces
/// seen at the half-step velocities) applied to one oscillator of angular
/// frequency omega = sqrt(k / m) with linear damping of ratio zeta
/// (c = 2 zeta m omega, the contact damping C_res) is the two-step recursion
///     x_{n+1} = x_n + dt u_n,   u_{n+1} = (1 - 2 zeta omega dt) u_n - omega^2 dt x_{n+1}
/// (u the half-step velocity), whose amplification matrix has trace
/// 2 - 2 zeta w - w^2 and determinant 1 - 2 zeta w with w = omega dt. Both roots
/// stay in the unit circle exactly while w^2 + 4 zeta w - 4 < 0, so
///     dt_crit = (2 / omega) (sqrt(1 + zeta^2) - zeta),
/// which is the textbook 2 / omega without damping and 0.677 x 2 / omega at the
/// paper's C_res = 0.4. This is the real stability limit of the integrator,
/// verified by the tests to within 1%.
///
/// The stiffest oscillator of a packing is its lightest particle on its stiffest
/// possible contact. With the per-node law a contact engages every node that
/// overlaps, so a flat face pressed on a wall (or on another flat face)
/// engages all the nodes across it at once, and the particle can also rock and
/// shear on that patch. stiffestContact() takes each candidate contact patch of
/// a shape (the nodes within `maxOverlap` of a supporting plane, for planes
/// normal to every direction the shape's surface normals take), assembles the
/// stiffness of the patch's node springs, normal (k_i) and tangential
/// (ks/kn k_i in each tangent direction), acting at the nodes' lever arms on
/// the rigid body's D + rotational degrees of freedom, and takes the largest
/// generalised eigenvalue omega^2 of that stiffness against the body's mass and
/// principal inertia. That is exact for a body on a rigid wall (the tests check
/// a box on its face: stable at 0.98 dt_crit, unstable at 1.02 dt_crit).
/// Omega^2 scales as 1/density for a given shape, so the result is reported as
/// an effective stiffness k_eff = omega^2 m, a property of the shape and the
/// law alone: omega_max = sqrt(k_eff / m) for any density.
///
/// Two particles on one patch oscillate against each other with their reduced
/// mass; for springs K between bodies a and b, (q_a - q_b)^T K (q_a - q_b)
/// <= 2 (q_a^T K q_a + q_b^T K q_b), so omega_pair^2 <= 2 max(omega_a^2, omega_b^2)
/// (with equal node spacing on both sides, each side of a pair being weighted
/// 1/2 by the narrow phase). `particlePairs` (default) includes that factor 2.
///
/// What the estimate leaves to the safety factor (stableTimeStep, 0.2 by
/// default): a particle held by several contacts at once (a chain of equal
/// masses and springs has omega_max = 2 sqrt(k / m), i.e. dt x 0.5); contact
/// switching: dt_crit is the limit for springs that stay engaged, but a contact
/// that opens and closes within a few steps is not resolved and its impacts can
/// pump energy (a box bouncing on its face under gravity, unilateral per-node
/// law: stable at 0.7 dt_crit, unstable at 0.8 dt_crit in the tests' set-up);
/// contacts with concave partners that engage more nodes than a plane; and
/// overlaps deeper than `maxOverlap`. Hertz contacts are pair-level and do not scale
/// with the node count: pass their tangent stiffness dF/ddelta = 2 E* sqrt(R* delta)
/// at the largest expected overlap directly to criticalTimeStep(masses, stiffnesses).
///
/// For scale: Table 1's dt = 1.8e-6 s and Table 2's 2.2e-7 s.

#include "lsdem/dynamics/Particles.h"
#include "lsdem/geometry/Shape.h"

#include <cstddef>
#include <vector>

namespace lsdem::dynamics {

/// The contact law as the time-step estimate sees it, in plain numbers (so
/// this header needs no contact-solver header): the normal stiffness of one
/// node contact is k_i = perNode s + perWeight w_i, with s the shape's
/// nodeStiffnessScale (ShapeOptions; 1 except for re-gridded fragments) and
/// w_i the node's length (2D) or area (3D) weight, and its tangential stiffness is
/// tangentialRatio k_i in each tangent direction.
/// - Linear, PerNode law (the paper): perNode = kn, perWeight = 0.
/// - Linear, AreaWeighted law: perNode = 0, perWeight = kn / w_ref, with
///   w_ref = referenceNodeWeight<D>(h) of ContactLaw.h for the shape's grid
///   spacing h, so the values depend on the shape: compute them per shape and
///   use the (masses, stiffnesses) overload of criticalTimeStep when shapes of
///   different spacings are present.
/// Defaults: Table 1 (kn = 3e7 N/m per node, ks = 0.8 kn).
struct NodeStiffness {
  double perNode = 3e7;         ///< N/m added by each node contact (>= 0)
  double perWeight = 0.0;       ///< N/m per unit node weight, N/m^D in D dimensions (>= 0)
  double tangentialRatio = 0.8; ///< ks / kn (>= 0); 0 without friction
};

/// How stiffestContact() looks for the stiffest patch.
struct ContactStiffnessOptions {
  /// Depth below the supporting plane within which a node counts as touching,
  /// m; 0: 0.1 x the shape's grid spacing (about 1% of the diameter of a grain
  /// 10 cells across, a large DEM overlap). A flat face engages all its nodes
  /// for any depth; curved surfaces engage more nodes the deeper the overlap.
  double maxOverlap = 0.0;
  /// Particles of this shape touch other particles, not only walls: include the
  /// factor 2 of the pair's reduced mass (see the file comment).
  bool particlePairs = true;
};

/// The stiffest contact patch of a shape and its effective stiffness.
template <int D>
struct StiffestContact {
  double stiffness = 0.0;         ///< k_eff, N/m: omega_max^2 = k_eff / m for a particle of this shape (any density)
  double normalStiffness = 0.0;   ///< sum of the patch's normal node stiffnesses k_i, N/m
  std::size_t nodeCount = 0;      ///< nodes in the patch
  Vec<D> normal = Vec<D>::Zero(); ///< outward unit normal of the patch, body frame
};

/// @brief The stiffest contact patch of a shape against a flat surface and the
/// effective stiffness k_eff it gives (see the file comment).
/// @param shape the particle's shape (nodes and mass properties in its body frame).
/// @param law per-node stiffness of the contact law.
/// @param options patch depth and the particle-pair factor.
/// @note Cost O(candidate directions x nodes), at most ~1000 (2D) or 1536 (3D)
/// directions; once per shape. Throws std::invalid_argument for a shape
/// without nodes, negative or NaN stiffness parameters, all-zero normal
/// stiffness, or a negative or NaN maxOverlap.
template <int D>
StiffestContact<D> stiffestContact(const geometry::Shape<D>& shape, const NodeStiffness& law,
                                   const ContactStiffnessOptions& options = {});

/// @brief Critical time step of the explicit scheme,
/// dt_crit = min_i (2 / omega_i) (sqrt(1 + zeta^2) - zeta), omega_i = sqrt(k_i / m_i).
/// @param masses particle masses, kg.
/// @param stiffnesses effective stiffness of each particle's stiffest contact, N/m
///   (StiffestContact::stiffness, or a Hertz tangent stiffness); 0: no contact.
/// @param dampingRatio contact damping ratio zeta (C_res, >= 0).
/// @return seconds; +infinity when no particle has a positive stiffness.
/// @note Throws std::invalid_argument for mismatched sizes, masses <= 0,
/// stiffnesses < 0, zeta < 0 or NaN values.
double criticalTimeStep(const std::vector<double>& masses, const std::vector<double>& stiffnesses,
                        double dampingRatio = 0.0);

/// @brief Critical time step of a set of particles under a contact law: the
/// stiffest contact of each distinct shape (computed once per shape in this
/// call) and each particle's mass.
/// @note One `law` for every shape: right for the PerNode law; see
/// NodeStiffness for AreaWeighted. A world that adds particles one at a time
/// (breakage) can keep StiffestContact::stiffness per particle and call the
/// (masses, stiffnesses) overload instead.
template <int D>
double criticalTimeStep(const Particles<D>& particles, const NodeStiffness& law, double dampingRatio = 0.0,
                        const ContactStiffnessOptions& options = {});

/// @brief The time step to run with: safety x dtCritical, s.
/// @param dtCritical critical time step, s (> 0; +infinity gives +infinity).
/// @param safety fraction of the critical step, 0 < safety <= 1 (0.2 covers
///   several contacts per particle, see the file comment).
double stableTimeStep(double dtCritical, double safety = 0.2);

/// @brief Checks a user-chosen time step against the critical one.
/// @param dtUser the scene's time step, s (> 0).
/// @param dtCritical critical time step, s.
/// @param force accept any dtUser (the scene's force_dt = true).
/// @param safety fraction of the critical step allowed.
/// @note Throws std::invalid_argument "dt = X s exceeds the critical time step
/// Y s (safety 0.2 of the stability limit Z s); lower it or set force_dt = true"
/// when dtUser > safety x dtCritical and not forced; also for dtUser <= 0 or NaN.
void checkUserTimeStep(double dtUser, double dtCritical, bool force, double safety = 0.2);

extern template StiffestContact<2> stiffestContact<2>(const geometry::Shape<2>&, const NodeStiffness&,
                                                      const ContactStiffnessOptions&);
extern template StiffestContact<3> stiffestContact<3>(const geometry::Shape<3>&, const NodeStiffness&,
                                                      const ContactStiffnessOptions&);
extern template double criticalTimeStep<2>(const Particles<2>&, const NodeStiffness&, double,
                                           const ContactStiffnessOptions&);
extern template double criticalTimeStep<3>(const Particles<3>&, const NodeStiffness&, double,
                                           const ContactStiffnessOptions&);

}  // namespace lsdem::dynamics
