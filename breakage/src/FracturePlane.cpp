#include "lsdem/breakage/FracturePlane.h"

#include "lsdem/breakage/Weibull.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

namespace lsdem::breakage {

using geometry::HalfSpace;
using geometry::Mat;
using geometry::Shape;

namespace {

// Distance of x from the line through a with unit direction u (3D).
double distanceFromLine(const Vec<3>& x, const Vec<3>& a, const Vec<3>& u) { return (x - a).cross(u).norm(); }

// The plane containing the line through p1 with unit direction u whose normal
// is u x e_k, e_k the world axis least aligned with u (lowest k on ties).
HalfSpace<3> planeContainingLine(const Vec<3>& p1, const Vec<3>& u) {
  int k = 0;
  for (int a = 1; a < 3; ++a) {
    if (std::abs(u[a]) < std::abs(u[k])) k = a;
  }
  HalfSpace<3> h;
  h.normal = u.cross(Vec<3>::Unit(k)).normalized();
  h.offset = h.normal.dot(p1);
  return h;
}

}  // namespace

template <int D>
std::optional<HalfSpace<D>> fracturePlane(const Vec<D>& centroid, std::span<const ContactPoint<D>> strongest,
                                          double lengthScale) {
  if (!(lengthScale > 0.0) || !std::isfinite(lengthScale)) {
    throw std::invalid_argument("fracturePlane: lengthScale must be finite and > 0, got " +
                                std::to_string(lengthScale));
  }
  const double tol = kFracturePlaneTolerance * lengthScale;
  if (strongest.empty()) return std::nullopt;

  // p1: the strongest point; p2: the next strongest one distinct from it.
  const Vec<D> p1 = strongest[0].point;
  std::size_t second = strongest.size();
  for (std::size_t k = 1; k < strongest.size(); ++k) {
    if ((strongest[k].point - p1).norm() > tol) {
      second = k;
      break;
    }
  }

  if constexpr (D == 2) {
    // eq. 18 through the two strongest distinct points, else through p1 and the centroid.
    if (second < strongest.size()) return HalfSpace<2>::throughPoints(p1, strongest[second].point);
    if ((centroid - p1).norm() > tol) return HalfSpace<2>::throughPoints(p1, centroid);
    return std::nullopt;
  } else {
    // One distinct point: the breakage is held until a second one arrives.
    if (second == strongest.size()) return std::nullopt;
    const Vec<3> p2 = strongest[second].point;
    const Vec<3> u = (p2 - p1).normalized();

    // p3: the next strongest point off the line p1 p2 (eq. 19-20).
    for (std::size_t k = second + 1; k < strongest.size(); ++k) {
      if (distanceFromLine(strongest[k].point, p1, u) > tol) {
        return HalfSpace<3>::throughPoints(p1, p2, strongest[k].point);
      }
    }
    // Else the centroid completes the plane; else a world axis fixes its tilt.
    if (distanceFromLine(centroid, p1, u) > tol) return HalfSpace<3>::throughPoints(p1, p2, centroid);
    return planeContainingLine(p1, u);
  }
}

template <int D>
double circumscribedVolumeRatio(const Shape<D>& shape) {
  // Circumscribed radius: the farthest surface node from the centroid (body origin).
  double r2 = 0.0;
  for (const Vec<D>& x : shape.nodes().positions) r2 = std::max(r2, x.squaredNorm());
  const double r = std::sqrt(r2);
  const double ball = D == 2 ? std::numbers::pi * r * r : 4.0 / 3.0 * std::numbers::pi * r * r * r;
  return ball / shape.volume();
}

template <int D>
std::optional<HalfSpace<D>> bucklingPlane(const Shape<D>& shape, const Vec<D>& position, const Mat<D>& rotation,
                                          std::uint64_t seed, std::uint64_t key) {
  // eq. 21: p_min, the surface node closest to the centroid (first on ties).
  const auto& nodes = shape.nodes().positions;
  if (nodes.empty()) return std::nullopt;
  std::size_t closest = 0;
  for (std::size_t k = 1; k < nodes.size(); ++k) {
    if (nodes[k].squaredNorm() < nodes[closest].squaredNorm()) closest = k;
  }
  const Vec<D> arm = rotation * nodes[closest];
  const double tol = kFracturePlaneTolerance * shape.descriptors().equivalentDiameter;
  if (!(arm.norm() > tol)) return std::nullopt;

  if constexpr (D == 2) {
    // 2D: the line through the centroid and p_min.
    return HalfSpace<2>::throughPoints(position, position + arm);
  } else {
    // 3D: plus centroid + r, r a seeded unit direction not along the arm.
    const Vec<3> a = arm.normalized();
    for (std::uint64_t attempt = 0;; ++attempt) {
      const double z = 2.0 * keyedUniform(seed + 2 * attempt, key) - 1.0;
      const double phi = 2.0 * std::numbers::pi * keyedUniform(seed + 2 * attempt + 1, key);
      const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
      const Vec<3> r(s * std::cos(phi), s * std::sin(phi), z);
      const Vec<3> n = a.cross(r);
      if (n.norm() > 1e-3) {
        HalfSpace<3> h;
        h.normal = n.normalized();
        h.offset = h.normal.dot(position);
        return h;
      }
    }
  }
}

template std::optional<HalfSpace<2>> fracturePlane<2>(const Vec<2>&, std::span<const ContactPoint<2>>, double);
template std::optional<HalfSpace<3>> fracturePlane<3>(const Vec<3>&, std::span<const ContactPoint<3>>, double);
template double circumscribedVolumeRatio<2>(const Shape<2>&);
template double circumscribedVolumeRatio<3>(const Shape<3>&);
template std::optional<HalfSpace<2>> bucklingPlane<2>(const Shape<2>&, const Vec<2>&, const Mat<2>&, std::uint64_t,
                                                      std::uint64_t);
template std::optional<HalfSpace<3>> bucklingPlane<3>(const Shape<3>&, const Vec<3>&, const Mat<3>&, std::uint64_t,
                                                      std::uint64_t);

}  // namespace lsdem::breakage
