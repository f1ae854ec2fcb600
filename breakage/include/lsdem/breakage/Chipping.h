#pragma once
/// @file Chipping.h
/// @brief Chipping: a small breakage at one contact that shaves the grain
/// where it is pressed (paper section 5.2, discussion of Fig. 14: "very small
/// breakages focused around a single contact point", the dominant mode at
/// low stress, which the paper's splitting alone cannot reproduce).
///
/// A chip is a split by a plane (Split.h, the same cutter and exact-mass
/// bookkeeping): the plane is normal to the contact's normal, at a depth
/// delta below the grain's surface point of that contact; the side beyond
/// the plane, towards the contact, is the chip.
///
/// Per contact of a grain (one per touching pair: another particle, a plane
/// or a tool), from the contact records of the step (contactLoads()):
///   - F, the normal force on the grain, N (2D: N/m): the sum over the
///     contact's node forces of their components along the node normals;
///   - n, the contact's outward normal (world frame, unit): the node normals,
///     turned outward of the grain, weighted by their normal forces;
///   - A, the node patch, m^(D-1): the summed length (2D) / area (3D)
///     weights of the nodes in contact (for a particle pair, the mean of the
///     two directions' patches that found nodes);
///   - p = F / A, the contact pressure over the node patch, Pa;
///   - r, the local radius, m: n . (x - X), the largest over the contact's
///     node points x, X the grain's centroid (the distance from the centroid
///     to the plane tangent at the contact's tip).
/// The chip depth delta (chipDepth) is
///   - `Fraction`: delta = depthFraction r;
///   - `Hertz`: delta = hertzFactor a, with a the Hertz contact radius of the
///     force F on a body of radius r against a flat of the grain's material,
///     3D a = (3 F r / (4 E*))^(1/3), 2D (line contact, F per unit
///     thickness) a = (4 F r / (pi E*))^(1/2), E* = E / (1 - nu^2);
/// capped at maxDepthFraction r. A chip is a corner's or an asperity's: the
/// grain's surface nodes beyond the chip plane must span at most
/// maxWidthToDepth x delta across the normal (capWidth); a flat face pressed
/// evenly would otherwise lose a slab as wide as the face (a 2D corner of
/// 127 degrees has width / depth 4, a cube's corner 2.8; a sphere cut at a
/// tenth of its radius 8.9: smooth grains do not chip at that depth).
/// The contact chips when p >= its chipping
/// strength, the Weibull strength (eq. 12) of a chip of size delta:
///     sigma_chip = sigma_0c ((d_0c / delta)^3 (-ln(1 - U)))^(1/m_c),
/// U = chipUniform(seed, grain id, partner): one fixed number per grain and
/// contact partner, so a contact's strength depends on the chip's size alone
/// and a run is the same for any thread count (as sampleStrength keys a
/// grain's strength by its global id). A chip shallower than minDepthCells
/// cells of the grain's grid is not resolved and is not tried.
///
/// Cost: nothing when a scene does not declare chipping (BreakageDef::
/// chipping is empty: the breakage effect does not look at it). Declared,
/// one pass over the node contacts per step.

#include "lsdem/breakage/Weibull.h"
#include "lsdem/dynamics/NarrowPhase.h"
#include "lsdem/dynamics/Particles.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/Types.h"

#include <cstdint>
#include <span>
#include <vector>

namespace lsdem::breakage {

/// How the depth of a chip is set (file comment).
enum class ChipDepthMode {
  Fraction,  ///< a fixed fraction of the local radius
  Hertz,     ///< a multiple of the Hertz contact radius of the contact's force
};

/// Everything that configures chipping (STYLE 7); defaults are a sketch of a
/// brittle rock's chipping, not measured values.
struct ChippingDef {
  /// Weibull parameters of the chipping strength: sigma_0c, Pa (a contact
  /// pressure); d_0c, m (a chip depth); m_c.
  WeibullDef weibull{2e8, 1e-3, 3.0};
  ChipDepthMode depth = ChipDepthMode::Fraction;
  double depthFraction = 0.1;     ///< Fraction: delta / r, in (0, 1)
  double hertzFactor = 1.0;       ///< Hertz: delta / a, > 0
  double youngsModulus = 0.0;     ///< Hertz: the grain's E, Pa, > 0
  double poissonRatio = 0.25;     ///< Hertz: the grain's nu, in [0, 0.5)
  double maxDepthFraction = 0.3;  ///< delta <= this x r, in (0, 1)
  double minDepthCells = 1.5;     ///< chips shallower than this many grid cells are not tried, >= 0.5
  double maxWidthToDepth = 4.0;   ///< a chip's width (capWidth) is at most this x its depth, > 0
};

/// @brief Checks ChippingDef (ranges in its field comments; Weibull by validateWeibull).
/// @note Throws std::invalid_argument naming the field and its value.
void validateChipping(const ChippingDef& def);

/// @brief The chip depth delta, m, for normal force `force` (N; 2D: N/m) at a
/// contact of local radius `localRadius` (m), capped at maxDepthFraction x
/// localRadius (file comment). 0 for force <= 0 or localRadius <= 0.
template <int D>
double chipDepth(const ChippingDef& def, double force, double localRadius);

/// @brief The width of the cap that `plane` cuts off a grain, m: the
/// largest distance across the plane's normal of the grain's surface nodes
/// beyond the plane (normal . x > offset) from their mean, doubled (2D: the
/// extent of their projections on the plane's line). 0 when no node is beyond.
/// @param shape the grain's shape (nodes in its body frame).
/// @param rotation body -> world rotation of the grain.
/// @param position the grain's centroid, world frame, m.
/// @param normal the plane's unit normal, world frame (pointing into the cap).
/// @param offset normal . x on the plane, world frame, m.
template <int D>
double capWidth(const geometry::Shape<D>& shape, const geometry::Mat<D>& rotation, const geometry::Vec<D>& position,
                const geometry::Vec<D>& normal, double offset);

/// @brief The U(0,1) number of the chipping strength of grain `particleId` at
/// its contact with `partnerKey` (contactPartnerKey), fixed per (seed, grain, partner).
double chipUniform(std::uint64_t seed, std::uint64_t particleId, std::uint64_t partnerKey);

/// @brief The chipping strength of a chip of depth `depth` (m) at a contact
/// whose keyed number is `uniform` (chipUniform): eq. 12 with the chipping
/// Weibull parameters and the depth as the size, Pa.
double chipStrength(const ChippingDef& def, double depth, double uniform);

/// Kind of body at the other side of a contact.
enum class PartnerKind : std::uint8_t { Particle = 0, Plane = 1, Tool = 2 };

/// @brief A contact partner as one key: a particle's global id, or a plane's
/// or tool's index tagged in the top two bits.
inline std::uint64_t contactPartnerKey(PartnerKind kind, std::uint64_t idOrIndex) {
  return (std::uint64_t(kind) << 62) | (idOrIndex & ((std::uint64_t(1) << 62) - 1));
}

/// One contact of a grain as chipping sees it (file comment), world frame.
template <int D>
struct ContactLoad {
  geometry::Vec<D> normal = geometry::Vec<D>::Zero();  ///< outward of the grain, unit
  double force = 0.0;        ///< normal force F on the grain, N (2D: N/m), > 0
  double patch = 0.0;        ///< node patch A, m^(D-1), > 0
  double localRadius = 0.0;  ///< r, m
  std::uint64_t partner = 0; ///< contactPartnerKey
  /// @brief The contact pressure p = F / A, Pa.
  double pressure() const { return force / patch; }
};

/// @brief Contact loads of every particle, in compressed rows: the loads of
/// particle i are loads[offset[i] .. offset[i + 1]), in the order of the
/// contact records (a fixed order: the same for any thread count).
template <int D>
struct GrainContactLoads {
  std::vector<std::uint32_t> offset;   ///< particles + 1 row starts
  std::vector<ContactLoad<D>> loads;   ///< all rows, concatenated
  std::span<const ContactLoad<D>> of(std::size_t i) const {
    return {loads.data() + offset[i], loads.data() + offset[i + 1]};
  }
};

/// @brief The contact loads of every particle from the solver's last compute()
/// (file comment). Contacts with no compressive normal force are left out.
/// @param particles the particles the solver's last compute() saw.
/// @param contacts the contact solver after compute().
/// @param out filled in place (its buffers are reused between calls).
template <int D>
void contactLoads(const dynamics::Particles<D>& particles, const dynamics::ContactSolver<D>& contacts,
                  GrainContactLoads<D>& out);

extern template double capWidth<2>(const geometry::Shape<2>&, const geometry::Mat<2>&, const geometry::Vec<2>&,
                                   const geometry::Vec<2>&, double);
extern template double capWidth<3>(const geometry::Shape<3>&, const geometry::Mat<3>&, const geometry::Vec<3>&,
                                   const geometry::Vec<3>&, double);
extern template double chipDepth<2>(const ChippingDef&, double, double);
extern template double chipDepth<3>(const ChippingDef&, double, double);
extern template void contactLoads<2>(const dynamics::Particles<2>&, const dynamics::ContactSolver<2>&,
                                     GrainContactLoads<2>&);
extern template void contactLoads<3>(const dynamics::Particles<3>&, const dynamics::ContactSolver<3>&,
                                     GrainContactLoads<3>&);

}  // namespace lsdem::breakage
