#pragma once
/// @file GrainStress.h
/// @brief Average stress inside a grain from its contact forces (eq. 5), its
/// principal stresses (eq. 6), and the per-particle gathering of both from the
/// contact solver's records of one step, together with the strongest contact
/// points the fracture-plane rule (eq. 18-20) needs.
///
/// Sign convention: tension positive. With the branch vector x_c pointing from
/// the grain's centroid to the contact point and F_c the force ON the grain, a
/// grain squeezed by two equal and opposite forces F along a diameter d gets
/// sigma = -F d / V along that axis (negative: compression).
///
/// Units: forces in N, lengths in m, volume in m^3, stress in Pa. In 2D the
/// forces are per unit thickness (N/m) and the "volume" is the area (m^2), so
/// the in-plane stress is again in Pa.

#include "lsdem/dynamics/NarrowPhase.h"
#include "lsdem/dynamics/Particles.h"
#include "lsdem/geometry/Types.h"

#include <cstdint>
#include <span>
#include <vector>

namespace lsdem::breakage {

using geometry::Mat;
using geometry::Vec;

/// @brief eq. 5: average stress of a grain, (1/V) sum_c x_c (outer) F_c,
/// returned as its symmetric part (the antisymmetric part is the net moment of
/// the contact forces about the centroid divided by V; it is not a stress).
/// @param branches branch vectors x_c from the grain's centroid to each contact
///   point, world frame, m.
/// @param forces contact forces F_c on the grain, world frame, N (2D: N/m),
///   aligned with `branches`.
/// @param volume grain volume V, m^3 (2D: area, m^2), > 0.
/// @return symmetric D x D stress tensor, world frame, Pa, tension positive.
/// @note Throws std::invalid_argument when the spans differ in length or the
/// volume is not finite and positive.
template <int D>
Mat<D> averageStress(std::span<const Vec<D>> branches, std::span<const Vec<D>> forces, double volume);

/// @brief eq. 6: principal stresses, the eigenvalues of the symmetric stress
/// tensor `sigma` (Pa), in descending order (s1 >= s2 [>= s3]); tension positive.
/// @note Only the lower triangle of `sigma` is read (it is assumed symmetric).
template <int D>
Vec<D> principalStresses(const Mat<D>& sigma);

/// @brief Principal stresses in the form the criteria (Criteria.h) take:
/// 3D: (s1, s2, s3) descending; 2D plane stress: (s1, s2, 0) with s1 >= s2 (the
/// out-of-plane principal stress is zero, so the triple is not sorted in general).
template <int D>
Vec<3> principalStressTriple(const Mat<D>& sigma);

/// One contact point of a grain for the fracture-plane rule (eq. 18-20).
template <int D>
struct ContactPoint {
  Vec<D> point = Vec<D>::Zero();  ///< contact point (the node's world position), world frame, m
  double force = 0.0;             ///< magnitude of the node contact's force, N (2D: N/m)
};

/// @brief Contact points of every particle, in compressed rows: the points of
/// particle i are points[offset[i] .. offset[i + 1]), sorted by force descending
/// (ties keep the contact records' order). One entry per contact pair (particle,
/// plane or tool pair): the node contact of that pair with the largest force.
template <int D>
struct GrainContactPoints {
  std::vector<std::uint32_t> offset;      ///< particles + 1 row starts
  std::vector<ContactPoint<D>> points;    ///< all rows, concatenated

  /// @brief The contact points of particle i, strongest first.
  std::span<const ContactPoint<D>> of(std::size_t i) const {
    return {points.data() + offset[i], points.data() + offset[i + 1]};
  }
};

/// @brief eq. 5 for every particle from the contact records of the solver's
/// last compute(): sums x_c (outer) F_c over each particle's node contacts in
/// the particle-particle, particle-plane and particle-tool records (particle a
/// receives NodeContact::force, particle b of a particle pair the opposite; the
/// branch vector is the node's world position minus the particle's centroid),
/// divides by the shape's volume and keeps the symmetric part.
/// @param particles the particles the solver's last compute() saw.
/// @param contacts the contact solver after compute().
/// @param out resized to particles.size(); out[i] is the stress of particle i,
///   world frame, Pa, tension positive (zero for a particle without contacts).
/// @note Records are visited in the solver's output order, so the sums are the
///   same for any thread count. Throws std::invalid_argument when a record
///   names a particle index outside `particles`.
template <int D>
void grainStresses(const dynamics::Particles<D>& particles, const dynamics::ContactSolver<D>& contacts,
                   std::vector<Mat<D>>& out);

/// @brief The fracture-plane rule's contact points (eq. 18-20) for every
/// particle: per contact pair, the node contact with the largest force
/// magnitude ("if there are multiple points of contact for a single contact
/// pair only the point contributing the highest force will be used"), each
/// particle's list sorted by force descending.
/// @param particles the particles the solver's last compute() saw.
/// @param contacts the contact solver after compute().
/// @param out filled in place (its buffers are reused between calls).
/// @note Throws std::invalid_argument when a record names a particle index
///   outside `particles`.
template <int D>
void strongestContacts(const dynamics::Particles<D>& particles, const dynamics::ContactSolver<D>& contacts,
                       GrainContactPoints<D>& out);

extern template Mat<2> averageStress<2>(std::span<const Vec<2>>, std::span<const Vec<2>>, double);
extern template Mat<3> averageStress<3>(std::span<const Vec<3>>, std::span<const Vec<3>>, double);
extern template Vec<2> principalStresses<2>(const Mat<2>&);
extern template Vec<3> principalStresses<3>(const Mat<3>&);
extern template Vec<3> principalStressTriple<2>(const Mat<2>&);
extern template Vec<3> principalStressTriple<3>(const Mat<3>&);
extern template void grainStresses<2>(const dynamics::Particles<2>&, const dynamics::ContactSolver<2>&,
                                      std::vector<Mat<2>>&);
extern template void grainStresses<3>(const dynamics::Particles<3>&, const dynamics::ContactSolver<3>&,
                                      std::vector<Mat<3>>&);
extern template void strongestContacts<2>(const dynamics::Particles<2>&, const dynamics::ContactSolver<2>&,
                                          GrainContactPoints<2>&);
extern template void strongestContacts<3>(const dynamics::Particles<3>&, const dynamics::ContactSolver<3>&,
                                          GrainContactPoints<3>&);

}  // namespace lsdem::breakage
