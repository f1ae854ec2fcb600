#include "lsdem/geometry/Reinitialize.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::geometry {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

/// Caps on the sweep rounds of fast sweeping (2-3 are typical; the caps only
/// guard against a pathological input cycling in the last bits).
constexpr int kMaxFirstOrderRounds = 1000;
constexpr int kMaxSecondOrderRounds = 50;

/// Second differences (in cells, |u - 2 u1 + u2| / h) up to which the second-order
/// stencil is used in full, and from which only the first-order one is: a smooth
/// distance has h / R, a kink of slope jump s has about s.
constexpr double kSmoothSecondDifference = 0.25;
constexpr double kKinkSecondDifference = 0.5;

/// phi < 0 is inside; phi == 0 counts as outside, like everywhere in lsdem.
inline bool isInside(double phi) { return phi < 0.0; }

/// Linear-offset steps of one node along each axis (x fastest).
template <int D>
std::array<std::ptrdiff_t, D> axisStrides(const Index<D>& dims) {
  std::array<std::ptrdiff_t, D> strides{};
  std::ptrdiff_t s = 1;
  for (int a = 0; a < D; ++a) {
    strides[std::size_t(a)] = s;
    s *= dims[a];
  }
  return strides;
}

/// Copies the grid values to doubles, rejecting non-finite values.
template <int D>
std::vector<double> finiteValues(const Grid<D>& grid) {
  std::vector<double> phi(grid.size());
  for (std::size_t n = 0; n < grid.size(); ++n) {
    phi[n] = grid[n];
    if (!std::isfinite(phi[n])) {
      throw std::invalid_argument("reinitialize: non-finite grid value " + std::to_string(phi[n]) + " at node " +
                                  std::to_string(n));
    }
  }
  return phi;
}

/// The nodes next to the zero level set, with their unsigned subcell distance to it.
struct InterfaceNodes {
  std::vector<std::size_t> nodes;  ///< linear offsets, ascending
  std::vector<double> distance;    ///< unsigned distance to phi = 0, world units
};

/// True when node n (index i) has a face neighbour on the other side of phi = 0.
template <int D>
bool touchesInterface(const std::vector<double>& phi, const Index<D>& dims,
                      const std::array<std::ptrdiff_t, D>& strides, const Index<D>& i, std::size_t n) {
  const bool inside = isInside(phi[n]);
  for (int a = 0; a < D; ++a) {
    const std::ptrdiff_t s = strides[std::size_t(a)];
    if (i[a] > 0 && isInside(phi[std::size_t(std::ptrdiff_t(n) - s)]) != inside) return true;
    if (i[a] < dims[a] - 1 && isInside(phi[std::size_t(std::ptrdiff_t(n) + s)]) != inside) return true;
  }
  return false;
}

/// Subcell distance from interface node n (index i) to phi = 0: the root of the
/// quadratic model of phi along its normal, capped by the nearest linear
/// crossing along an axis (see the file comment of Reinitialize.h).
template <int D>
double subcellDistance(const std::vector<double>& phi, const Index<D>& dims,
                       const std::array<std::ptrdiff_t, D>& strides, double h, const Index<D>& i, std::size_t n) {
  const double p = phi[n];
  const bool inside = isInside(p);
  const std::ptrdiff_t m = std::ptrdiff_t(n);
  Vec<D> grad;
  Mat<D> hess = Mat<D>::Zero();
  double nearestCrossing = kInfinity;

  // Gradient and diagonal of the Hessian by central differences (one-sided at
  // the border), and the linear crossings of phi = 0 along each axis.
  for (int a = 0; a < D; ++a) {
    const std::ptrdiff_t s = strides[std::size_t(a)];
    const bool hasMinus = i[a] > 0, hasPlus = i[a] < dims[a] - 1;
    const double vm = hasMinus ? phi[std::size_t(m - s)] : p;
    const double vp = hasPlus ? phi[std::size_t(m + s)] : p;
    if (hasMinus && hasPlus) {
      grad[a] = (vp - vm) / (2.0 * h);
      hess(a, a) = (vp - 2.0 * p + vm) / (h * h);
    } else {
      grad[a] = (vp - vm) / h;
    }
    for (const double v : {vm, vp}) {
      if (isInside(v) != inside) nearestCrossing = std::min(nearestCrossing, h * p / (p - v));
    }
  }

  // Mixed second derivatives where the four diagonal neighbours exist.
  for (int a = 0; a < D; ++a) {
    for (int b = a + 1; b < D; ++b) {
      if (i[a] <= 0 || i[b] <= 0 || i[a] >= dims[a] - 1 || i[b] >= dims[b] - 1) continue;
      const std::ptrdiff_t sa = strides[std::size_t(a)], sb = strides[std::size_t(b)];
      const double mixed = (phi[std::size_t(m + sa + sb)] - phi[std::size_t(m + sa - sb)] -
                            phi[std::size_t(m - sa + sb)] + phi[std::size_t(m - sa - sb)]) /
                           (4.0 * h * h);
      hess(a, b) = mixed;
      hess(b, a) = mixed;
    }
  }

  // Root of p - |g| t + 1/2 c t^2 = 0 nearest to the node along -n (t has the
  // sign of p), falling back to p / |g| when the quadratic model is unreliable.
  const double gradNorm = grad.norm();
  if (!(gradNorm > 0.0)) return std::abs(nearestCrossing);
  const Vec<D> normal = grad / gradNorm;
  const double curvature = normal.dot(hess * normal);
  const double linear = p / gradNorm;
  const double disc = gradNorm * gradNorm - 2.0 * curvature * p;
  double t = linear;
  if (disc > 0.0) {
    const double quadratic = 2.0 * p / (gradNorm + std::sqrt(disc));
    if (std::abs(quadratic - linear) <= 0.5 * std::abs(linear)) t = quadratic;
  }
  return std::min(std::abs(t), std::abs(nearestCrossing));
}

/// Finds the interface nodes and their subcell distances (eq. 17's fixed band).
template <int D>
InterfaceNodes findInterface(const Grid<D>& grid, const std::vector<double>& phi) {
  const Index<D> dims = grid.dims();
  const auto strides = axisStrides<D>(dims);
  const std::ptrdiff_t count = std::ptrdiff_t(grid.size());

  // Flag the nodes with a face neighbour of the other sign.
  std::vector<unsigned char> flag(grid.size(), 0);
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
  for (std::ptrdiff_t n = 0; n < count; ++n) {
    const std::size_t u = std::size_t(n);
    flag[u] = touchesInterface<D>(phi, dims, strides, grid.unlinear(u), u) ? 1 : 0;
  }

  InterfaceNodes result;
  for (std::size_t n = 0; n < grid.size(); ++n) {
    if (flag[n]) result.nodes.push_back(n);
  }
  if (result.nodes.empty()) {
    throw std::invalid_argument("reinitialize: the grid has no zero crossing (every value is " +
                                std::string(isInside(phi[0]) ? "negative" : "non-negative") + ")");
  }

  // Subcell distance of each interface node (independent per node).
  result.distance.resize(result.nodes.size());
  const std::ptrdiff_t interfaceCount = std::ptrdiff_t(result.nodes.size());
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
  for (std::ptrdiff_t k = 0; k < interfaceCount; ++k) {
    const std::size_t n = result.nodes[std::size_t(k)];
    result.distance[std::size_t(k)] = subcellDistance<D>(phi, dims, strides, grid.spacing(), grid.unlinear(n), n);
  }
  return result;
}

/// Visits every node index once, each axis forwards or backwards as `forward` says.
template <int D, class Visit>
void forEachNode(const Index<D>& dims, const std::array<bool, D>& forward, Visit&& visit) {
  auto first = [&](int a) { return forward[std::size_t(a)] ? 0 : dims[a] - 1; };
  auto step = [&](int a) { return forward[std::size_t(a)] ? 1 : -1; };
  auto inRange = [&](int a, int v) { return v >= 0 && v < dims[a]; };
  Index<D> i;
  if constexpr (D == 2) {
    for (i[1] = first(1); inRange(1, i[1]); i[1] += step(1)) {
      for (i[0] = first(0); inRange(0, i[0]); i[0] += step(0)) visit(i);
    }
  } else {
    for (i[2] = first(2); inRange(2, i[2]); i[2] += step(2)) {
      for (i[1] = first(1); inRange(1, i[1]); i[1] += step(1)) {
        for (i[0] = first(0); inRange(0, i[0]); i[0] += step(0)) visit(i);
      }
    }
  }
}

/// Rounds of 2^D sweeps (every axis forwards or backwards, Zhao's orders) of
/// `sweepOnce(forward)`, which returns its largest change, until a whole round
/// changes no value by more than `tolerance` or `maxRounds` rounds have run.
template <int D, class Sweep>
void sweepRounds(int maxRounds, double tolerance, Sweep&& sweepOnce) {
  for (int round = 0; round < maxRounds; ++round) {
    double roundChange = 0.0;
    for (int order = 0; order < (1 << D); ++order) {
      std::array<bool, D> forward;
      for (int a = 0; a < D; ++a) forward[std::size_t(a)] = ((order >> a) & 1) == 0;
      roundChange = std::max(roundChange, sweepOnce(forward));
    }
    if (roundChange <= tolerance) return;
  }
}

/// The flat index of grid node i.
template <int D>
std::size_t flatIndex(const Index<D>& i, const std::array<std::ptrdiff_t, D>& strides) {
  std::size_t n = 0;
  for (int a = 0; a < D; ++a) n += std::size_t(i[a]) * std::size_t(strides[std::size_t(a)]);
  return n;
}

/// Godunov upwind solution of |grad u| = 1 at a node whose smallest neighbour
/// value along each axis is m[a] (unsorted, possibly infinite), spacing h.
template <int D>
double godunovUpdate(std::array<double, D> m, double h) {
  std::sort(m.begin(), m.end());
  double u = m[0] + h;
  if constexpr (D >= 2) {
    if (u > m[1]) {
      const double diff = m[0] - m[1];
      u = 0.5 * (m[0] + m[1] + std::sqrt(2.0 * h * h - diff * diff));
      if constexpr (D == 3) {
        if (u > m[2]) {
          const double sum = m[0] + m[1] + m[2];
          const double sumSq = m[0] * m[0] + m[1] * m[1] + m[2] * m[2];
          u = (sum + std::sqrt(sum * sum - 3.0 * (sumSq - h * h))) / 3.0;
        }
      }
    }
  }
  return u;
}

/// One Gauss-Seidel sweep of the unsigned distance `dist` in the node order
/// given by `forward` per axis; returns the largest decrease of a value.
template <int D>
double sweep(std::vector<double>& dist, const std::vector<unsigned char>& fixed, const Index<D>& dims,
             const std::array<std::ptrdiff_t, D>& strides, double h, const std::array<bool, D>& forward) {
  double maxChange = 0.0;
  // The node visitor: smallest neighbour per axis, upwind update, keep the minimum.
  auto visit = [&](const Index<D>& i) {
    const std::size_t n = flatIndex<D>(i, strides);
    if (fixed[n]) return;
    std::array<double, D> m;
    for (int a = 0; a < D; ++a) {
      const std::ptrdiff_t s = strides[std::size_t(a)];
      double v = kInfinity;
      if (i[a] > 0) v = dist[n - std::size_t(s)];
      if (i[a] < dims[a] - 1) v = std::min(v, dist[n + std::size_t(s)]);
      m[std::size_t(a)] = v;
    }
    if (*std::min_element(m.begin(), m.end()) == kInfinity) return;
    const double u = godunovUpdate<D>(m, h);
    if (u < dist[n]) {
      maxChange = std::max(maxChange, dist[n] - u);
      dist[n] = u;
    }
  };
  forEachNode<D>(dims, forward, visit);
  return maxChange;
}

/// One upwind axis term of the second-order update: the node value u satisfies
/// alpha (u - base) = du/dx_a along that axis.
struct AxisTerm {
  double base;   ///< world units
  double alpha;  ///< 1/h (first order) or 3/(2h) (second order)
};

/// Solves sum_a alpha_a^2 (u - base_a)_+^2 = 1 for u (the root exists and is
/// unique: the left side grows from 0 to infinity past the smallest base).
template <int D>
double weightedGodunov(std::array<AxisTerm, D> terms, int count) {
  std::sort(terms.begin(), terms.begin() + count, [](const AxisTerm& x, const AxisTerm& y) { return x.base < y.base; });
  double A = 0.0, B = 0.0, C = -1.0, u = 0.0;
  for (int k = 0; k < count; ++k) {
    const double w = terms[std::size_t(k)].alpha * terms[std::size_t(k)].alpha;
    const double b = terms[std::size_t(k)].base;
    A += w;
    B += w * b;
    C += w * b * b;
    u = (B + std::sqrt(std::max(0.0, B * B - A * C))) / A;
    if (k + 1 == count || u <= terms[std::size_t(k + 1)].base) break;
  }
  return u;
}

/// One Gauss-Seidel sweep with second-order upwind differences
/// (3u - 4u1 + u2) / (2h) along each axis (u1, u2 the next two nodes on the
/// upwind side; u2 taken negative across the interface, where the signed
/// distance continues), blended into the first-order (u - u1) / h where the
/// second difference shows a kink. Returns the largest change of a value.
template <int D>
double sweepSecondOrder(std::vector<double>& dist, const std::vector<unsigned char>& fixed,
                        const std::vector<unsigned char>& inside, const Index<D>& dims,
                        const std::array<std::ptrdiff_t, D>& strides, double h, const std::array<bool, D>& forward) {
  double maxChange = 0.0;
  auto visit = [&](const Index<D>& i) {
    const std::size_t n = flatIndex<D>(i, strides);
    if (fixed[n]) return;
    std::array<AxisTerm, D> terms;
    int count = 0;
    for (int a = 0; a < D; ++a) {
      // Upwind side: the face neighbour with the smaller distance.
      const std::ptrdiff_t s = strides[std::size_t(a)];
      int side = 0;
      double v1 = kInfinity;
      if (i[a] > 0 && dist[n - std::size_t(s)] < v1) {
        v1 = dist[n - std::size_t(s)];
        side = -1;
      }
      if (i[a] < dims[a] - 1 && dist[n + std::size_t(s)] < v1) {
        v1 = dist[n + std::size_t(s)];
        side = 1;
      }
      if (side == 0) continue;
      // Second-order stencil where the next node upwind exists and the field is
      // smooth there, blended continuously into the first-order one where the
      // second difference approaches a kink's (so the sweeps cannot cycle
      // between the two stencils).
      AxisTerm term{v1, 1.0 / h};
      const int i2 = i[a] + 2 * side;
      if (i2 >= 0 && i2 < dims[a]) {
        const std::size_t n2 = std::size_t(std::ptrdiff_t(n) + 2 * side * s);
        const double v2 = (inside[n2] == inside[n]) ? dist[n2] : -dist[n2];
        const double kink = std::abs(dist[n] - 2.0 * v1 + v2) / h;
        const double w =
            std::clamp((kKinkSecondDifference - kink) / (kKinkSecondDifference - kSmoothSecondDifference), 0.0, 1.0);
        // w * (3u - 4 v1 + v2) / 2h + (1 - w) (u - v1) / h = alpha (u - base).
        const double alpha = (1.0 + 0.5 * w) / h;
        const double base = (w * 0.5 * (4.0 * v1 - v2) + (1.0 - w) * v1) / (1.0 + 0.5 * w);
        term = AxisTerm{base, alpha};
      }
      terms[std::size_t(count++)] = term;
    }
    if (count == 0) return;
    const double u = weightedGodunov<D>(terms, count);
    maxChange = std::max(maxChange, std::abs(u - dist[n]));
    dist[n] = u;
  };
  forEachNode<D>(dims, forward, visit);
  return maxChange;
}

/// minmod of two second differences: the smaller in magnitude when they agree in sign, else 0.
inline double minmod(double x, double y) {
  if (x * y <= 0.0) return 0.0;
  return std::abs(x) < std::abs(y) ? x : y;
}

/// The right-hand side L(phi) of eq. 17 in pseudo time.
template <int D>
struct PdeOperator {
  const Grid<D>& grid;
  const std::vector<double>& phi0;
  const std::vector<double>& target;      ///< signed subcell distance at interface nodes, NaN elsewhere
  const std::vector<double>& smoothSign;  ///< S(phi0)
  const std::array<std::ptrdiff_t, D>& strides;
  double h;

  /// Writes L(phi) for every node to `out`.
  void rate(const std::vector<double>& phi, std::vector<double>& out) const {
    const Index<D> dims = grid.dims();
    const std::ptrdiff_t count = std::ptrdiff_t(grid.size());
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (std::ptrdiff_t n = 0; n < count; ++n) {
      const std::size_t u = std::size_t(n);
      const double c = phi[u];
      const bool inside = isInside(phi0[u]);
      // Interface node: relax towards the subcell distance (Russo-Smereka).
      if (!std::isnan(target[u])) {
        out[u] = -((inside ? -std::abs(c) : std::abs(c)) - target[u]) / h;
        continue;
      }
      // Other nodes: Godunov |grad phi| from second-order ENO one-sided
      // differences (first order where the stencil leaves the grid).
      const Index<D> i = grid.unlinear(u);
      double gradSq = 0.0;
      for (int a = 0; a < D; ++a) {
        const std::ptrdiff_t s = strides[std::size_t(a)];
        auto at = [&](int k) { return phi[std::size_t(n + k * s)]; };
        const bool m1 = i[a] >= 1, m2 = i[a] >= 2, p1 = i[a] <= dims[a] - 2, p2 = i[a] <= dims[a] - 3;
        double term = 0.0;
        if (m1) {
          double backward = (c - at(-1)) / h;
          if (m2 && p1) backward += minmod(at(-2) - 2.0 * at(-1) + c, at(-1) - 2.0 * c + at(1)) / (2.0 * h);
          if (inside ? backward < 0.0 : backward > 0.0) term = backward * backward;
        }
        if (p1) {
          double forwardDiff = (at(1) - c) / h;
          if (p2 && m1) forwardDiff -= minmod(at(-1) - 2.0 * c + at(1), c - 2.0 * at(1) + at(2)) / (2.0 * h);
          if (inside ? forwardDiff > 0.0 : forwardDiff < 0.0) term = std::max(term, forwardDiff * forwardDiff);
        }
        gradSq += term;
      }
      out[u] = -smoothSign[u] * (std::sqrt(gradSq) - 1.0);
    }
  }
};

/// Writes sign(phi0) * distance back to the float grid.
template <int D>
void writeSigned(Grid<D>& grid, const std::vector<double>& phi0, const std::vector<double>& distance) {
  for (std::size_t n = 0; n < grid.size(); ++n) {
    grid[n] = float(isInside(phi0[n]) ? -distance[n] : distance[n]);
  }
}

}  // namespace

template <int D>
void reinitializeFastSweeping(Grid<D>& grid) {
  const std::vector<double> phi0 = finiteValues(grid);
  const InterfaceNodes band = findInterface(grid, phi0);
  const Index<D> dims = grid.dims();
  const auto strides = axisStrides<D>(dims);
  const double h = grid.spacing();

  // Unsigned distances: interface nodes fixed at their subcell value, the rest unknown.
  std::vector<double> dist(grid.size(), kInfinity);
  std::vector<unsigned char> fixed(grid.size(), 0);
  for (std::size_t k = 0; k < band.nodes.size(); ++k) {
    dist[band.nodes[k]] = band.distance[k];
    fixed[band.nodes[k]] = 1;
  }

  // First-order Godunov sweeps to convergence (values only decrease; 2-3
  // rounds are typical). Faces of one sign only ever meet nodes of that sign or
  // fixed nodes, so unsigned values can be swept together.
  const double tolerance = 1e-6 * h;
  sweepRounds<D>(kMaxFirstOrderRounds, tolerance,
                 [&](const std::array<bool, D>& forward) { return sweep<D>(dist, fixed, dims, strides, h, forward); });

  // Second-order upwind sweeps from the first-order solution.
  std::vector<unsigned char> inside(grid.size());
  for (std::size_t n = 0; n < grid.size(); ++n) inside[n] = isInside(phi0[n]) ? 1 : 0;
  sweepRounds<D>(kMaxSecondOrderRounds, tolerance, [&](const std::array<bool, D>& forward) {
    return sweepSecondOrder<D>(dist, fixed, inside, dims, strides, h, forward);
  });

  // Restore the sign of the input.
  writeSigned(grid, phi0, dist);
}

template <int D>
void reinitializePde(Grid<D>& grid, int iterations, double cfl) {
  if (iterations < 0) {
    throw std::invalid_argument("reinitializePde: iterations must be >= 0, got " + std::to_string(iterations));
  }
  if (!(cfl > 0.0) || cfl > 1.0 / std::sqrt(double(D)) + 1e-12) {
    throw std::invalid_argument("reinitializePde: cfl must be in (0, 1/sqrt(D)], got " + std::to_string(cfl));
  }
  const std::vector<double> phi0 = finiteValues(grid);
  const InterfaceNodes band = findInterface(grid, phi0);
  const Index<D> dims = grid.dims();
  const auto strides = axisStrides<D>(dims);
  const double h = grid.spacing();
  const std::ptrdiff_t count = std::ptrdiff_t(grid.size());

  // Russo-Smereka targets: the signed subcell distance of each interface node
  // (NaN marks the other nodes).
  std::vector<double> target(grid.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < band.nodes.size(); ++k) {
    const std::size_t n = band.nodes[k];
    target[n] = isInside(phi0[n]) ? -band.distance[k] : band.distance[k];
  }

  // Smoothed sign S = phi0 / sqrt(phi0^2 + |grad phi0|^2 h^2) (central
  // differences, one-sided at the border), scale-free for any phi0.
  std::vector<double> smoothSign(grid.size());
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
  for (std::ptrdiff_t n = 0; n < count; ++n) {
    const Index<D> i = grid.unlinear(std::size_t(n));
    double gradSq = 0.0;
    for (int a = 0; a < D; ++a) {
      const std::ptrdiff_t s = strides[std::size_t(a)];
      const bool hasMinus = i[a] > 0, hasPlus = i[a] < dims[a] - 1;
      const double vm = hasMinus ? phi0[std::size_t(n - s)] : phi0[std::size_t(n)];
      const double vp = hasPlus ? phi0[std::size_t(n + s)] : phi0[std::size_t(n)];
      const double g = (vp - vm) / (h * double(int(hasMinus) + int(hasPlus)));
      gradSq += g * g;
    }
    const double p = phi0[std::size_t(n)];
    smoothSign[std::size_t(n)] = (p == 0.0) ? 0.0 : p / std::sqrt(p * p + gradSq * h * h);
  }

  // Default step count: enough pseudo time for the front to cross half the
  // grid's diagonal, plus a margin for the interface relaxation.
  if (iterations == 0) {
    const double halfDiagonal = 0.5 * h * (dims - 1).template cast<double>().matrix().norm();
    iterations = int(std::ceil(halfDiagonal / (cfl * h))) + 20;
  }

  // TVD Runge-Kutta 2 (Heun) in pseudo time: phi1 = phi + dt L(phi),
  // phi <- (phi + phi1 + dt L(phi1)) / 2, every stage a Jacobi update.
  const PdeOperator<D> op{grid, phi0, target, smoothSign, strides, h};
  std::vector<double> phi = phi0, stage(grid.size()), rate(grid.size());
  const double dt = cfl * h;
  const double tolerance = 1e-7 * h;
  for (int it = 0; it < iterations; ++it) {
    op.rate(phi, rate);
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (std::ptrdiff_t n = 0; n < count; ++n) stage[std::size_t(n)] = phi[std::size_t(n)] + dt * rate[std::size_t(n)];
    op.rate(stage, rate);
    double maxChange = 0.0;
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static) reduction(max : maxChange)
#endif
    for (std::ptrdiff_t n = 0; n < count; ++n) {
      const std::size_t u = std::size_t(n);
      const double updated = 0.5 * (phi[u] + stage[u] + dt * rate[u]);
      maxChange = std::max(maxChange, std::abs(updated - phi[u]));
      phi[u] = updated;
    }
    if (maxChange <= tolerance) break;
  }

  // Back to floats.
  for (std::size_t n = 0; n < grid.size(); ++n) grid[n] = float(phi[n]);
}

template <int D>
void reinitialize(Grid<D>& grid, ReinitMethod method) {
  switch (method) {
    case ReinitMethod::FastSweeping:
      reinitializeFastSweeping(grid);
      return;
    case ReinitMethod::Pde:
      reinitializePde(grid);
      return;
  }
  throw std::invalid_argument("reinitialize: unknown method " + std::to_string(int(method)));
}

template void reinitialize<2>(Grid<2>&, ReinitMethod);
template void reinitialize<3>(Grid<3>&, ReinitMethod);
template void reinitializeFastSweeping<2>(Grid<2>&);
template void reinitializeFastSweeping<3>(Grid<3>&);
template void reinitializePde<2>(Grid<2>&, int, double);
template void reinitializePde<3>(Grid<3>&, int, double);

}  // namespace lsdem::geometry
