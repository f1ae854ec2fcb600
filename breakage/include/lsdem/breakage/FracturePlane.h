#pragma once
/// @file FracturePlane.h
/// @brief Flat fracture surfaces of a grain (paper section 3.3): the line
/// (2D, eq. 18) or plane (3D, eq. 19-20) through the grain's strongest contact
/// points, with the centroid completing it when too few contacts are at hand,
/// and the "buckling" mode (eq. 21) that cuts a slender grain through its
/// centroid and its closest surface node.
///
/// All points and planes here are in the WORLD frame, metres. The normal of a
/// returned plane is unit length and finite; its sign carries no meaning (the
/// split keeps both sides).
///
/// Degenerate inputs. Two points "coincide" when they are closer than
/// tol = kFracturePlaneTolerance x lengthScale, and a point is "on the line"
/// of two others when its distance from that line is below tol. The points are
/// then taken in this fixed order of fall-backs:
///   - 2D: p1 = the strongest point; p2 = the next strongest point that does
///     not coincide with p1, else the centroid (eq. 18 with the centroid, "for
///     these cases the particle centroid was used"), else no line (a single
///     contact at the centroid defines no line: nullopt).
///   - 3D: p1 = the strongest point; p2 = the next strongest point not
///     coinciding with p1 — none: nullopt (the paper holds the breakage "until a
///     second contact point was encountered"); p3 = the next strongest point
///     off the line p1 p2, else the centroid if it is off that line (eq. 19-20
///     with the centroid), else the plane containing p1 and p2 whose normal is
///     (p2 - p1) x e_k, with e_k the world axis least aligned with p2 - p1
///     (lowest k on ties): all contacts and the centroid on one line leave the
///     plane's tilt about that line free, and a world axis fixes it
///     deterministically.

#include "lsdem/breakage/GrainStress.h"
#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/Types.h"

#include <cstdint>
#include <optional>
#include <span>

namespace lsdem::breakage {

/// Relative tolerance of the degeneracy tests: points closer than this times
/// the length scale coincide (see the file comment).
inline constexpr double kFracturePlaneTolerance = 1e-6;

/// @brief eq. 18 (2D) / eq. 19-20 (3D): the fracture line or plane through the
/// strongest contact points of a grain, completed by its centroid when there
/// are too few distinct points, with the fall-backs of the file comment.
/// @param centroid the grain's centroid, world frame, m.
/// @param strongest the grain's contact points, strongest first (one per
///   contact pair, as GrainContactPoints::of() gives them), world frame, m.
/// @param lengthScale size of the grain (e.g. its equivalent diameter), m,
///   > 0: sets the tolerance of the degeneracy tests.
/// @return the plane (unit normal, world frame), or nullopt when the points
///   define none: no contact; 2D: one contact at the centroid; 3D: fewer than
///   two distinct contact points.
/// @note Throws std::invalid_argument when lengthScale is not finite and > 0.
template <int D>
std::optional<geometry::HalfSpace<D>> fracturePlane(const geometry::Vec<D>& centroid,
                                                    std::span<const ContactPoint<D>> strongest, double lengthScale);

/// @brief eq. 21's trigger: the volume (area) of the circumscribed sphere
/// (circle) about the centroid — radius: the largest distance of a surface
/// node from the centroid — divided by the grain's volume (area), >= 1 for a
/// well-resolved shape.
template <int D>
double circumscribedVolumeRatio(const geometry::Shape<D>& shape);

/// @brief eq. 21: the "buckling" fracture plane of a slender grain: through
/// the centroid and the surface node closest to it, p_min (2D: that line; 3D:
/// plus the point centroid + r, with r a unit direction drawn from (seed, key)
/// by keyedUniform, redrawn while r is within ~1e-3 rad of p_min - centroid).
/// @param shape the grain's shape (nodes in its body frame).
/// @param position the grain's centroid, world frame, m.
/// @param rotation the grain's body -> world rotation.
/// @param seed seed of the random direction (3D only).
/// @param key per-grain key of the random direction (its global id), 3D only.
/// @return the plane in the world frame, unit normal; nullopt only when the
///   closest node lies at the centroid (no line defined).
template <int D>
std::optional<geometry::HalfSpace<D>> bucklingPlane(const geometry::Shape<D>& shape,
                                                    const geometry::Vec<D>& position,
                                                    const geometry::Mat<D>& rotation, std::uint64_t seed,
                                                    std::uint64_t key);

extern template std::optional<geometry::HalfSpace<2>> fracturePlane<2>(const geometry::Vec<2>&,
                                                                       std::span<const ContactPoint<2>>, double);
extern template std::optional<geometry::HalfSpace<3>> fracturePlane<3>(const geometry::Vec<3>&,
                                                                       std::span<const ContactPoint<3>>, double);
extern template double circumscribedVolumeRatio<2>(const geometry::Shape<2>&);
extern template double circumscribedVolumeRatio<3>(const geometry::Shape<3>&);
extern template std::optional<geometry::HalfSpace<2>> bucklingPlane<2>(const geometry::Shape<2>&,
                                                                       const geometry::Vec<2>&,
                                                                       const geometry::Mat<2>&, std::uint64_t,
                                                                       std::uint64_t);
extern template std::optional<geometry::HalfSpace<3>> bucklingPlane<3>(const geometry::Shape<3>&,
                                                                       const geometry::Vec<3>&,
                                                                       const geometry::Mat<3>&, std::uint64_t,
                                                                       std::uint64_t);

}  // namespace lsdem::breakage
