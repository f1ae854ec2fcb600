#include "lsdem/geometry/Primitives.h"

#include "lsdem/geometry/Reinitialize.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

namespace lsdem::geometry {

namespace {

/// A number as text for error messages (shortest round-trip-ish form).
std::string str(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

/// A vector as "(x, y[, z])" for error messages.
template <int D>
std::string str(const Vec<D>& v) {
  std::string s = "(";
  for (int a = 0; a < D; ++a) s += (a ? ", " : "") + str(v[a]);
  return s + ")";
}

/// Throws unless every component of `v` is positive and finite.
template <int D>
void requirePositive(const Vec<D>& v, const char* what, const char* name) {
  for (int a = 0; a < D; ++a) {
    if (!(v[a] > 0.0) || !std::isfinite(v[a])) {
      throw std::invalid_argument(std::string(what) + ": " + name + " must be positive and finite, got " + str<D>(v));
    }
  }
}

/// Throws unless `v` is positive and finite.
void requirePositive(double v, const char* what, const char* name) {
  if (!(v > 0.0) || !std::isfinite(v)) {
    throw std::invalid_argument(std::string(what) + ": " + name + " must be positive and finite, got " + str(v));
  }
}

/// Throws unless rounding lies in [0, min(halfExtents)].
template <int D>
void requireRounding(const Vec<D>& halfExtents, double rounding, const char* what) {
  requirePositive<D>(halfExtents, what, "halfExtents");
  if (!(rounding >= 0.0) || !(rounding <= halfExtents.minCoeff())) {
    throw std::invalid_argument(std::string(what) + ": rounding must be in [0, min half extent = " +
                                str(halfExtents.minCoeff()) + "], got " + str(rounding));
  }
}

/// z-component of (b - a) x (c - a): > 0 when a, b, c turn counter-clockwise.
double orient(const Vec<2>& a, const Vec<2>& b, const Vec<2>& c) {
  return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

/// Twice the signed area of the polygon (shoelace formula), > 0 counter-clockwise.
double twiceSignedArea(const std::vector<Vec<2>>& v) {
  double sum = 0.0;
  for (std::size_t k = 0, n = v.size(); k < n; ++k) {
    const Vec<2>& a = v[k];
    const Vec<2>& b = v[(k + 1) % n];
    sum += a[0] * b[1] - a[1] * b[0];
  }
  return sum;
}

/// The O(n) checks of a polygon: >= 3 finite vertices and non-zero area
/// (relative to the bounding box).
void checkPolygonBasics(const std::vector<Vec<2>>& v, const char* what) {
  if (v.size() < 3) {
    throw std::invalid_argument(std::string(what) + ": a polygon needs at least 3 vertices, got " +
                                std::to_string(v.size()));
  }
  Vec<2> lo = v[0], hi = v[0];
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (!v[k].allFinite()) {
      throw std::invalid_argument(std::string(what) + ": vertex " + std::to_string(k) +
                                  " is not finite: " + str<2>(v[k]));
    }
    lo = lo.cwiseMin(v[k]);
    hi = hi.cwiseMax(v[k]);
  }
  const double area = 0.5 * std::abs(twiceSignedArea(v));
  if (!(area > 1e-12 * (hi - lo).squaredNorm())) {
    throw std::invalid_argument(std::string(what) + ": the polygon has zero area (" + str(area) + ")");
  }
}

/// True when point q lies on the segment [a, b], given that it is collinear with it.
bool onSegment(const Vec<2>& a, const Vec<2>& b, const Vec<2>& q) {
  return q[0] >= std::min(a[0], b[0]) && q[0] <= std::max(a[0], b[0]) && q[1] >= std::min(a[1], b[1]) &&
         q[1] <= std::max(a[1], b[1]);
}

/// True when the closed segments [p1, p2] and [q1, q2] share a point.
bool segmentsIntersect(const Vec<2>& p1, const Vec<2>& p2, const Vec<2>& q1, const Vec<2>& q2) {
  const double o1 = orient(p1, p2, q1), o2 = orient(p1, p2, q2);
  const double o3 = orient(q1, q2, p1), o4 = orient(q1, q2, p2);
  if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) return true;
  return (o1 == 0 && onSegment(p1, p2, q1)) || (o2 == 0 && onSegment(p1, p2, q2)) ||
         (o3 == 0 && onSegment(q1, q2, p1)) || (o4 == 0 && onSegment(q1, q2, p2));
}

/// Signed distance to a polygon already validated: nearest edge distance, sign
/// from the even-odd crossing rule (a point on an edge gets 0, outside).
double polygonDistance(const Vec<2>& x, const std::vector<Vec<2>>& v) {
  double best = std::numeric_limits<double>::infinity();
  bool inside = false;
  for (std::size_t k = 0, n = v.size(); k < n; ++k) {
    const Vec<2>& a = v[k];
    const Vec<2>& b = v[(k + 1) % n];
    // Distance to the segment [a, b].
    const Vec<2> e = b - a;
    const double t = std::clamp((x - a).dot(e) / e.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (x - (a + t * e)).squaredNorm());
    // Crossing of the horizontal ray from x towards +x.
    if ((a[1] > x[1]) != (b[1] > x[1])) {
      const double xCross = a[0] + (x[1] - a[1]) * e[0] / e[1];
      if (x[0] < xCross) inside = !inside;
    }
  }
  const double d = std::sqrt(best);
  return (inside && d > 0.0) ? -d : d;
}

/// Superellipse "norm" (|u|^n + |v|^n)^(1/n) of non-negative u, v, scaled by
/// their maximum so large exponents neither overflow nor underflow.
double powerNorm(double u, double v, double n) {
  const double m = std::max(u, v);
  if (m == 0.0) return 0.0;
  return m * std::pow(std::pow(u / m, n) + std::pow(v / m, n), 1.0 / n);
}

}  // namespace

// ---- analytic signed distances --------------------------------------------

template <int D>
double sdfSphere(const Vec<D>& x, double radius) {
  requirePositive(radius, "sdfSphere", "radius");
  return x.norm() - radius;
}

template <int D>
double sdfBox(const Vec<D>& x, const Vec<D>& halfExtents, double rounding) {
  requireRounding<D>(halfExtents, rounding, "sdfBox");
  // Distance to the inner box (halfExtents - rounding), then grown by rounding.
  const Vec<D> q = x.cwiseAbs() - (halfExtents.array() - rounding).matrix();
  const double outside = q.cwiseMax(0.0).norm();
  const double inside = std::min(q.maxCoeff(), 0.0);
  return outside + inside - rounding;
}

template <int D>
double sdfEllipsoid(const Vec<D>& x, const Vec<D>& semiAxes) {
  requirePositive<D>(semiAxes, "sdfEllipsoid", "semiAxes");
  // Work in the positive orthant (the ellipsoid is symmetric about every axis).
  const Vec<D> p = x.cwiseAbs();
  const Vec<D>& a = semiAxes;
  const double aMin = a.minCoeff();
  const double aMinSq = aMin * aMin;
  const bool inside = (p.array() / a.array()).matrix().squaredNorm() < 1.0;

  // Largest coordinate along the shortest axes: if it is zero, the multiplier
  // may sit at its lower limit t = -aMin^2 (closest point off the axis).
  double pOnShortest = 0.0;
  for (int i = 0; i < D; ++i) {
    if (a[i] == aMin) pOnShortest = std::max(pOnShortest, p[i]);
  }

  // Denominators a_i^2 + t written with u = t + aMin^2 > 0.
  auto denominator = [&](int i, double u) { return (a[i] * a[i] - aMinSq) + u; };
  auto closestPoint = [&](double u) {
    Vec<D> c;
    for (int i = 0; i < D; ++i) c[i] = (p[i] == 0.0) ? 0.0 : a[i] * a[i] * p[i] / denominator(i, u);
    return c;
  };

  double lo;
  if (pOnShortest == 0.0) {
    // Degenerate case: try t = -aMin^2. The longer axes give x_i directly; if
    // they leave room on the ellipsoid, the rest goes along the shortest axes
    // and that point is the closest one.
    double used = 0.0, distSq = 0.0;
    for (int i = 0; i < D; ++i) {
      if (a[i] == aMin || p[i] == 0.0) continue;
      const double xi = a[i] * a[i] * p[i] / (a[i] * a[i] - aMinSq);
      used += (xi / a[i]) * (xi / a[i]);
      distSq += (xi - p[i]) * (xi - p[i]);
    }
    if (used <= 1.0) {
      const double d = std::sqrt(distSq + aMinSq * (1.0 - used));
      return inside ? -d : d;
    }
    lo = 0.0;
  } else {
    // The shortest-axis term alone equals 1 at u = aMin * p, so F(lo) >= 0.
    lo = aMin * pOnShortest;
  }

  // Bisection on F(u) = sum (a_i p_i / (a_i^2 + t))^2 - 1, decreasing in u;
  // F(hi) <= 0 since every term is at most (a_i p_i / t)^2 with t = aMax |p|.
  auto F = [&](double u) {
    double sum = -1.0;
    for (int i = 0; i < D; ++i) {
      const double term = a[i] * p[i] / denominator(i, u);
      sum += term * term;
    }
    return sum;
  };
  double hi = aMinSq + a.maxCoeff() * p.norm();
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (F(mid) > 0.0 ? lo : hi) = mid;
  }
  const double d = (closestPoint(0.5 * (lo + hi)) - p).norm();
  return inside ? -d : d;
}

double sdfPolygon(const Vec<2>& x, const std::vector<Vec<2>>& vertices) {
  checkPolygonBasics(vertices, "sdfPolygon");
  return polygonDistance(x, vertices);
}

void validatePolygon(const std::vector<Vec<2>>& v) {
  checkPolygonBasics(v, "validatePolygon");
  const std::size_t n = v.size();
  // No zero-length edge.
  for (std::size_t k = 0; k < n; ++k) {
    if (v[k] == v[(k + 1) % n]) {
      throw std::invalid_argument("validatePolygon: vertices " + std::to_string(k) + " and " +
                                  std::to_string((k + 1) % n) + " coincide at " + str<2>(v[k]));
    }
  }
  // Adjacent edges may only share their vertex: no folding back along a line.
  for (std::size_t k = 0; k < n; ++k) {
    const Vec<2>& prev = v[(k + n - 1) % n];
    const Vec<2>& here = v[k];
    const Vec<2>& next = v[(k + 1) % n];
    if (orient(prev, here, next) == 0.0 && (prev - here).dot(next - here) > 0.0) {
      throw std::invalid_argument("validatePolygon: the edges at vertex " + std::to_string(k) + " " + str<2>(here) +
                                  " fold back onto each other");
    }
  }
  // Non-adjacent edges must not touch.
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;  // adjacent through the closing edge
      if (segmentsIntersect(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n])) {
        throw std::invalid_argument("validatePolygon: the polygon self-intersects: edges " + std::to_string(i) +
                                    " and " + std::to_string(j) + " meet");
      }
    }
  }
}

// ---- half-spaces (eq. 18-20) ------------------------------------------------

template <int D>
HalfSpace<D> HalfSpace<D>::throughPoints(const Vec<2>& p1, const Vec<2>& p2) requires(D == 2) {
  if (!p1.allFinite() || !p2.allFinite()) {
    throw std::invalid_argument("HalfSpace::throughPoints: points must be finite, got " + str<2>(p1) + " and " +
                                str<2>(p2));
  }
  // eq. 18: unit normal (y2 - y1, -(x2 - x1)) / |p2 - p1|, offset n . p1.
  const Vec<2> d = p2 - p1;
  const double length = d.norm();
  if (!(length > 1e-12 * std::max(p1.norm(), p2.norm()))) {
    throw std::invalid_argument("HalfSpace::throughPoints: the two points coincide: " + str<2>(p1) + " and " +
                                str<2>(p2));
  }
  HalfSpace h;
  h.normal = Vec<2>(d[1], -d[0]) / length;
  h.offset = h.normal.dot(p1);
  return h;
}

template <int D>
HalfSpace<D> HalfSpace<D>::throughPoints(const Vec<3>& p1, const Vec<3>& p2, const Vec<3>& p3) requires(D == 3) {
  if (!p1.allFinite() || !p2.allFinite() || !p3.allFinite()) {
    throw std::invalid_argument("HalfSpace::throughPoints: points must be finite, got " + str<3>(p1) + ", " +
                                str<3>(p2) + ", " + str<3>(p3));
  }
  // Coincident pairs, relative to the size of the coordinates.
  const double scale = std::max({p1.norm(), p2.norm(), p3.norm()});
  const Vec<3> e1 = p2 - p1, e2 = p3 - p1;
  if (!(e1.norm() > 1e-12 * scale) || !(e2.norm() > 1e-12 * scale) || !((p3 - p2).norm() > 1e-12 * scale)) {
    throw std::invalid_argument("HalfSpace::throughPoints: two of the points coincide: " + str<3>(p1) + ", " +
                                str<3>(p2) + ", " + str<3>(p3));
  }
  // eq. 20: n = (p2 - p1) x (p3 - p1); collinear when the sine of the angle at p1 vanishes.
  const Vec<3> n = e1.cross(e2);
  if (!(n.norm() > 1e-12 * e1.norm() * e2.norm())) {
    throw std::invalid_argument("HalfSpace::throughPoints: the three points are collinear: " + str<3>(p1) + ", " +
                                str<3>(p2) + ", " + str<3>(p3));
  }
  // eq. 19: phi = (n . x - n . p1) / |n|.
  HalfSpace h;
  h.normal = n / n.norm();
  h.offset = h.normal.dot(p1);
  return h;
}

// ---- grids -------------------------------------------------------------------

namespace detail {
template <int D>
void checkSampling(const Box<D>& box, double spacing, int paddingCells) {
  if (!box.lower.allFinite() || !box.upper.allFinite() || !(box.lower.array() <= box.upper.array()).all()) {
    throw std::invalid_argument("sampleGrid: box must be finite with lower <= upper, got lower " + str<D>(box.lower) +
                                ", upper " + str<D>(box.upper));
  }
  requirePositive(spacing, "sampleGrid", "spacing");
  if (paddingCells < 0) {
    throw std::invalid_argument("sampleGrid: paddingCells must be >= 0, got " + std::to_string(paddingCells));
  }
  // Guard the int arithmetic of Grid::covering, and memory, against absurd sizes.
  double total = 1.0;
  for (int a = 0; a < D; ++a) {
    const double nodes = (box.upper[a] - box.lower[a]) / spacing + 2.0 * paddingCells + 3.0;
    if (!(nodes < double(1 << 24))) {
      throw std::invalid_argument("sampleGrid: spacing " + str(spacing) + " gives " + str(nodes) +
                                  " nodes along axis " + std::to_string(a) + " (limit 2^24)");
    }
    total *= nodes;
  }
  if (!(total < 0x1.0p31)) {
    throw std::invalid_argument("sampleGrid: spacing " + str(spacing) + " gives " + str(total) +
                                " nodes (limit 2^31)");
  }
}
}  // namespace detail

template <int D>
Grid<D> sphereGrid(double radius, double spacing, int paddingCells) {
  requirePositive(radius, "sphereGrid", "radius");
  const Box<D> box{Vec<D>::Constant(-radius), Vec<D>::Constant(radius)};
  return sampleGrid<D>(box, spacing, paddingCells, [radius](const Vec<D>& x) { return x.norm() - radius; });
}

template <int D>
Grid<D> boxGrid(const Vec<D>& halfExtents, double rounding, double spacing, int paddingCells) {
  requireRounding<D>(halfExtents, rounding, "boxGrid");
  const Box<D> box{-halfExtents, halfExtents};
  return sampleGrid<D>(box, spacing, paddingCells,
                       [&](const Vec<D>& x) { return sdfBox<D>(x, halfExtents, rounding); });
}

template <int D>
Grid<D> ellipsoidGrid(const Vec<D>& semiAxes, double spacing, int paddingCells) {
  requirePositive<D>(semiAxes, "ellipsoidGrid", "semiAxes");
  const Box<D> box{-semiAxes, semiAxes};
  return sampleGrid<D>(box, spacing, paddingCells, [&](const Vec<D>& x) { return sdfEllipsoid<D>(x, semiAxes); });
}

template <int D>
double superellipsoidRadialDistance(const Vec<D>& x, const Vec<D>& semiAxes, const std::vector<double>& exponents) {
  // The inside-outside function F = N^n1 is homogeneous, so its "norm" N is of
  // degree 1: the surface point on the ray through x is x / N, and
  // |x| (1 - 1/N) is the signed distance along that ray (exact on the surface).
  const Vec<D> u = (x.array() / semiAxes.array()).abs().matrix();
  double norm;
  if constexpr (D == 2) {
    norm = powerNorm(u[0], u[1], exponents[0]);
  } else {
    norm = powerNorm(powerNorm(u[0], u[1], exponents[1]), u[2], exponents[0]);
  }
  // The centre is inside; any negative value does (sweeping replaces it).
  if (norm == 0.0) return -semiAxes.minCoeff();
  return x.norm() * (1.0 - 1.0 / norm);
}

template <int D>
Grid<D> superellipsoidGrid(const Vec<D>& semiAxes, const std::vector<double>& exponents, double spacing,
                           int paddingCells) {
  requirePositive<D>(semiAxes, "superellipsoidGrid", "semiAxes");
  const std::size_t expected = (D == 2) ? 1 : 2;
  if (exponents.size() != expected) {
    throw std::invalid_argument("superellipsoidGrid: expected " + std::to_string(expected) + " exponent(s) in " +
                                std::to_string(D) + "D, got " + std::to_string(exponents.size()));
  }
  for (const double e : exponents) requirePositive(e, "superellipsoidGrid", "exponent");

  const Box<D> box{-semiAxes, semiAxes};
  Grid<D> grid = sampleGrid<D>(box, spacing, paddingCells, [&](const Vec<D>& x) {
    return superellipsoidRadialDistance<D>(x, semiAxes, exponents);
  });

  // Signed distance everywhere (eq. 17), nodes next to the surface subcell-accurate.
  reinitializeFastSweeping(grid);
  return grid;
}

Grid<2> polygonGrid(const std::vector<Vec<2>>& vertices, double spacing, int paddingCells) {
  validatePolygon(vertices);
  Box<2> box{vertices[0], vertices[0]};
  for (const Vec<2>& v : vertices) {
    box.lower = box.lower.cwiseMin(v);
    box.upper = box.upper.cwiseMax(v);
  }
  return sampleGrid<2>(box, spacing, paddingCells, [&](const Vec<2>& x) { return polygonDistance(x, vertices); });
}

template double sdfSphere<2>(const Vec<2>&, double);
template double sdfSphere<3>(const Vec<3>&, double);
template double sdfBox<2>(const Vec<2>&, const Vec<2>&, double);
template double sdfBox<3>(const Vec<3>&, const Vec<3>&, double);
template double sdfEllipsoid<2>(const Vec<2>&, const Vec<2>&);
template double sdfEllipsoid<3>(const Vec<3>&, const Vec<3>&);
template struct HalfSpace<2>;
template struct HalfSpace<3>;
template void detail::checkSampling<2>(const Box<2>&, double, int);
template void detail::checkSampling<3>(const Box<3>&, double, int);
template Grid<2> sphereGrid<2>(double, double, int);
template Grid<3> sphereGrid<3>(double, double, int);
template Grid<2> boxGrid<2>(const Vec<2>&, double, double, int);
template Grid<3> boxGrid<3>(const Vec<3>&, double, double, int);
template Grid<2> ellipsoidGrid<2>(const Vec<2>&, double, int);
template Grid<3> ellipsoidGrid<3>(const Vec<3>&, double, int);
template double superellipsoidRadialDistance<2>(const Vec<2>&, const Vec<2>&, const std::vector<double>&);
template double superellipsoidRadialDistance<3>(const Vec<3>&, const Vec<3>&, const std::vector<double>&);
template Grid<2> superellipsoidGrid<2>(const Vec<2>&, const std::vector<double>&, double, int);
template Grid<3> superellipsoidGrid<3>(const Vec<3>&, const std::vector<double>&, double, int);

}  // namespace lsdem::geometry
