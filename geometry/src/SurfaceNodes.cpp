#include "lsdem/geometry/SurfaceNodes.h"

#include "CgalMesh.h"
#include "lsdem/geometry/Contours.h"

#include <CGAL/Polygon_mesh_processing/remesh.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

namespace lsdem::geometry {

namespace {

/// Remeshing passes (split / collapse / flip / relax) in 3D.
constexpr unsigned kRemeshIterations = 3;
/// Most nodes one call may create: a guard against absurd densities.
constexpr double kMaxNodes = 1e8;

void checkDensity(double nodesPerCell) {
  if (!std::isfinite(nodesPerCell) || !(nodesPerCell > 0.0)) {
    throw std::invalid_argument("surface node density (nodes per cell) must be positive and finite, got " +
                                std::to_string(nodesPerCell));
  }
}


}  // namespace

NodeSet<2> surfaceNodes(const Grid<2>& grid, double nodesPerCell, const SurfaceProjector<2>& onSurface) {
  checkDensity(nodesPerCell);
  const double target = grid.spacing() / nodesPerCell;
  NodeSet<2> nodes;
  for (const std::vector<Vec<2>>& loop : marchingSquares(grid)) {
    // Length of the closed polyline and the node count for it.
    const std::size_t m = loop.size();
    double length = 0.0;
    for (std::size_t q = 0; q < m; ++q) length += (loop[(q + 1) % m] - loop[q]).norm();
    if (length / target > kMaxNodes) {
      throw std::invalid_argument("surface node density " + std::to_string(nodesPerCell) + " would give " +
                                  std::to_string(length / target) + " nodes on one contour");
    }
    const int n = std::max(3, int(std::lround(length / target)));

    // Nodes at equal arc-length steps along the polyline, projected onto phi = 0.
    const std::size_t first = nodes.positions.size();
    std::size_t segment = 0;
    double segmentStart = 0.0;
    double segmentLength = (loop[1 % m] - loop[0]).norm();
    for (int k = 0; k < n; ++k) {
      const double s = length * double(k) / double(n);
      while (segment + 1 < m && segmentStart + segmentLength < s) {
        segmentStart += segmentLength;
        ++segment;
        segmentLength = (loop[(segment + 1) % m] - loop[segment]).norm();
      }
      const double u = segmentLength > 0.0 ? std::clamp((s - segmentStart) / segmentLength, 0.0, 1.0) : 0.0;
      const Vec<2> x = loop[segment] + u * (loop[(segment + 1) % m] - loop[segment]);
      nodes.positions.push_back(projectOntoZero(grid, x));
    }
    // Onto the true surface, where the shape has one.
    if (onSurface) {
      for (std::size_t k = first; k < nodes.positions.size(); ++k) nodes.positions[k] = onSurface(nodes.positions[k]);
    }

    // Weights: half the distance to each neighbour along the contour.
    for (int k = 0; k < n; ++k) {
      const Vec<2>& x = nodes.positions[first + std::size_t(k)];
      const Vec<2>& previous = nodes.positions[first + std::size_t((k + n - 1) % n)];
      const Vec<2>& following = nodes.positions[first + std::size_t((k + 1) % n)];
      nodes.weights.push_back(0.5 * ((x - previous).norm() + (following - x).norm()));
    }
  }
  return nodes;
}

NodeSet<3> surfaceNodes(const Grid<3>& grid, double nodesPerCell, TriangleMesh* meshOut,
                        const SurfaceProjector<3>& onSurface) {
  checkDensity(nodesPerCell);
  const double target = grid.spacing() / nodesPerCell;
  NodeSet<3> nodes;
  if (meshOut) *meshOut = TriangleMesh{};

  // Zero level set as a closed mesh; nothing to do when it is empty.
  const TriangleMesh contour = marchingCubes(grid);
  if (contour.empty()) return nodes;
  const double estimatedNodes = contour.area() / (0.433 * target * target);
  if (estimatedNodes > kMaxNodes) {
    std::ostringstream what;
    what << "surface node density " << nodesPerCell << " would give about " << std::setprecision(2) << estimatedNodes
         << " nodes (at most " << kMaxNodes << ")";
    throw std::invalid_argument(what.str());
  }

  // Isotropic remeshing to the target edge length.
  cgal::SurfaceMesh surface = cgal::toSurfaceMesh(contour);
  CGAL::Polygon_mesh_processing::isotropic_remeshing(faces(surface), target, surface,
                                                     CGAL::parameters::number_of_iterations(kRemeshIterations));
  surface.collect_garbage();
  TriangleMesh mesh = cgal::toTriangleMesh(surface);

  // Vertices onto phi = 0, then onto the true surface where the shape has
  // one (independent per vertex).
  const int vertexCount = int(mesh.vertices.size());
#pragma omp parallel for schedule(static)
  for (int v = 0; v < vertexCount; ++v) {
    Vec<3>& x = mesh.vertices[std::size_t(v)];
    x = projectOntoZero(grid, x);
    if (onSurface) x = onSurface(x);
  }

  // Nodes are the vertices; each face gives a third of its area to each corner
  // (serial, in face order, so sums do not depend on the thread count).
  nodes.positions = mesh.vertices;
  nodes.weights.assign(mesh.vertices.size(), 0.0);
  for (const std::array<int, 3>& f : mesh.faces) {
    const Vec<3>& a = mesh.vertices[std::size_t(f[0])];
    const Vec<3>& b = mesh.vertices[std::size_t(f[1])];
    const Vec<3>& c = mesh.vertices[std::size_t(f[2])];
    const double third = (b - a).cross(c - a).norm() / 6.0;
    for (const int v : f) nodes.weights[std::size_t(v)] += third;
  }
  if (meshOut) *meshOut = std::move(mesh);
  return nodes;
}

template <int D>
double interpolantValue(const Grid<D>& grid, const Vec<D>& x, GridInterpolant interpolant, Vec<D>* grad) {
  if (interpolant == GridInterpolant::Multilinear) {
    if (grad) return grid.valueAndGradient(x, *grad);
    return grid.value(x);
  }
  // Catmull-Rom in the node box; outside, the value at the box's closest
  // point plus the distance to it (as Grid::value extends the multilinear one).
  const Vec<D> g = grid.toGrid(x);
  const Vec<D> gc = g.cwiseMax(Vec<D>::Zero()).cwiseMin((grid.dims() - 1).template cast<double>().matrix());
  Vec<D> gradCells;
  const double inside = grid.cubicValueAndGradientAtCells(gc, gradCells);
  const Vec<D> offset = grid.spacing() * (g - gc);
  const double distance = offset.norm();
  if (grad) {
    for (int a = 0; a < D; ++a) (*grad)[a] = g[a] != gc[a] ? offset[a] / distance : gradCells[a] / grid.spacing();
  }
  return inside + distance;
}

template <int D>
Vec<D> projectOntoLevel(const Grid<D>& grid, Vec<D> x, double level, GridInterpolant interpolant,
                        double toleranceCells, int maxIterations) {
  const double h = grid.spacing();
  // phi here is the interpolant minus the level.
  const auto valueAndGradient = [&](const Vec<D>& y, Vec<D>& gradient) {
    return interpolantValue(grid, y, interpolant, &gradient) - level;
  };
  Vec<D> grad;
  double phi = valueAndGradient(x, grad);
  for (int iteration = 0; iteration < maxIterations && std::abs(phi) > toleranceCells * h; ++iteration) {
    // Full Newton step, capped.
    const double gradSquared = grad.squaredNorm();
    if (gradSquared < 1e-12) break;
    Vec<D> step = (phi / gradSquared) * grad;
    const double length = step.norm();
    if (length > 0.5 * h) step *= 0.5 * h / length;
    // Backtracking: accept the first of 1, 1/2, 1/4, ... of it that lowers |phi|.
    bool accepted = false;
    for (double t = 1.0; t > 1.0 / 64.0 && !accepted; t *= 0.5) {
      Vec<D> trialGrad;
      const Vec<D> trial = x - t * step;
      const double trialPhi = valueAndGradient(trial, trialGrad);
      if (std::abs(trialPhi) < std::abs(phi)) {
        x = trial;
        phi = trialPhi;
        grad = trialGrad;
        accepted = true;
      }
    }
    if (!accepted) break;
  }
  if (std::abs(phi) <= toleranceCells * h || !std::isfinite(phi)) return x;

  // Newton stalled short of the level: at a kink of the interpolant (the max()
  // of a level-set cut, eq. 14-15) the gradient jumps and the damped steps
  // zig-zag or stop with |phi| up to ~h/4 left. A node left there is outside
  // its own body and can be inside a neighbour (a fragment's sibling), so
  // bracket the zero instead: the closest grid node of the opposite sign, or
  // zero, within two cells, then bisection on the segment to it (the
  // interpolant is continuous along it and equals the node's value at its
  // end). Zero-valued nodes count: a flat cut through a row of grid nodes
  // gives max(phi, phi_f) = 0 there, and a node beside the rim may see no
  // negative node within reach (fuzz_split found nodes left 0.008 cells out).
  const Vec<D> g = grid.toGrid(x);
  Index<D> base;
  for (int a = 0; a < D; ++a) base[a] = int(std::floor(g[a]));
  Vec<D> target = x;
  double best = std::numeric_limits<double>::infinity();
  const int reach = 2, width = 2 * reach + 2;
  int count = 1;
  for (int a = 0; a < D; ++a) count *= width;
  for (int q = 0; q < count; ++q) {
    Index<D> i = base;
    int rest = q;
    for (int a = 0; a < D; ++a) {
      i[a] += rest % width - reach;
      rest /= width;
    }
    if (!grid.inBounds(i)) continue;
    const double v = grid.at(i) - level;  // either interpolant's value at a node
    if (!(phi > 0.0 ? v <= 0.0 : v >= 0.0)) continue;
    const Vec<D> y = grid.nodePosition(i);
    const double d = (y - x).squaredNorm();
    if (d < best) {
      best = d;
      target = y;
    }
  }
  if (!std::isfinite(best)) return x;
  Vec<D> a = x, b = target;  // phi(a) has phi's sign, phi(b) the opposite
  Vec<D> closest = x;
  double closestPhi = phi;
  for (int iteration = 0; iteration < 60; ++iteration) {
    const Vec<D> m = 0.5 * (a + b);
    const double vm = interpolantValue(grid, m, interpolant) - level;
    if (std::abs(vm) < std::abs(closestPhi)) {
      closest = m;
      closestPhi = vm;
    }
    if (std::abs(vm) <= toleranceCells * h) break;
    if ((vm > 0.0) == (phi > 0.0)) {
      a = m;
    } else {
      b = m;
    }
  }
  return closest;
}

template <int D>
Vec<D> projectOntoZero(const Grid<D>& grid, Vec<D> x, double toleranceCells, int maxIterations) {
  return projectOntoLevel(grid, x, 0.0, GridInterpolant::Multilinear, toleranceCells, maxIterations);
}

template <int D>
Vec<D> projectOntoSurface(const SurfaceFunction<D>& surface, const Vec<D>& start, double spacing) {
  const double tolerance = 1e-10 * spacing, delta = 1e-6 * spacing;
  Vec<D> x = start;
  double f = surface(x);
  for (int iteration = 0; iteration < 30 && std::abs(f) > tolerance; ++iteration) {
    // Gradient by central differences.
    Vec<D> grad;
    for (int a = 0; a < D; ++a) {
      Vec<D> e = Vec<D>::Zero();
      e[a] = delta;
      grad[a] = (surface(x + e) - surface(x - e)) / (2.0 * delta);
    }
    const double gradSquared = grad.squaredNorm();
    if (!(gradSquared > 1e-12)) break;
    // Newton step, capped at half a cell, halved until |f| decreases.
    Vec<D> step = (f / gradSquared) * grad;
    const double length = step.norm();
    if (length > 0.5 * spacing) step *= 0.5 * spacing / length;
    bool accepted = false;
    for (double t = 1.0; t > 1.0 / 64.0 && !accepted; t *= 0.5) {
      const Vec<D> trial = x - t * step;
      const double trialF = surface(trial);
      if (std::abs(trialF) < std::abs(f)) {
        x = trial;
        f = trialF;
        accepted = true;
      }
    }
    if (!accepted) break;
  }
  if (!(std::abs(f) <= 1e3 * tolerance) || !((x - start).norm() <= spacing)) return start;
  return x;
}

template <int D>
SurfaceProjector<D> projectorOnto(SurfaceFunction<D> surface, double spacing) {
  if (!surface) return {};
  return [surface = std::move(surface), spacing](const Vec<D>& x) { return projectOntoSurface(surface, x, spacing); };
}

template SurfaceProjector<2> projectorOnto<2>(SurfaceFunction<2>, double);
template SurfaceProjector<3> projectorOnto<3>(SurfaceFunction<3>, double);
template Vec<2> projectOntoSurface<2>(const SurfaceFunction<2>&, const Vec<2>&, double);
template Vec<3> projectOntoSurface<3>(const SurfaceFunction<3>&, const Vec<3>&, double);
template double interpolantValue<2>(const Grid<2>&, const Vec<2>&, GridInterpolant, Vec<2>*);
template double interpolantValue<3>(const Grid<3>&, const Vec<3>&, GridInterpolant, Vec<3>*);
template Vec<2> projectOntoLevel<2>(const Grid<2>&, Vec<2>, double, GridInterpolant, double, int);
template Vec<3> projectOntoLevel<3>(const Grid<3>&, Vec<3>, double, GridInterpolant, double, int);
template Vec<2> projectOntoZero<2>(const Grid<2>&, Vec<2>, double, int);
template Vec<3> projectOntoZero<3>(const Grid<3>&, Vec<3>, double, int);

}  // namespace lsdem::geometry
