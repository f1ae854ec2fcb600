#include "lsdem/geometry/Csg.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace lsdem::geometry {

namespace {

enum class Operation { Difference, Intersection, Union };

/// eq. 14-16 on two values (world units).
inline double combine(Operation op, double a, double b) {
  switch (op) {
    case Operation::Difference: return std::max(a, -b);
    case Operation::Intersection: return std::max(a, b);
    case Operation::Union: return std::min(a, b);
  }
  return a;
}

const char* operationName(Operation op) {
  switch (op) {
    case Operation::Difference: return "csgDifference";
    case Operation::Intersection: return "csgIntersection";
    case Operation::Union: return "csgUnion";
  }
  return "csg";
}

/// Applies `op` node by node on a's grid; `sampleB(n, x)` gives b at node n,
/// world position x. Throws if b gives a NaN.
template <int D, class SampleB>
Grid<D> apply(Operation op, const Grid<D>& a, SampleB sampleB) {
  Grid<D> out = a;
  const std::int64_t count = std::int64_t(a.size());
  std::int64_t firstNaN = count;
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static) reduction(min : firstNaN)
#endif
  for (std::int64_t n = 0; n < count; ++n) {
    const std::size_t node = std::size_t(n);
    const double b = sampleB(node, a.nodePosition(a.unlinear(node)));
    if (std::isnan(b)) {
      firstNaN = std::min(firstNaN, n);
      continue;
    }
    out[node] = float(combine(op, a[node], b));
  }
  if (firstNaN < count) {
    throw std::invalid_argument(std::string(operationName(op)) + ": the second operand is NaN at node " +
                                std::to_string(firstNaN));
  }
  return out;
}

template <int D>
Grid<D> gridOperation(Operation op, const Grid<D>& a, const Grid<D>& b) {
  if (a.empty() || b.empty()) {
    throw std::invalid_argument(std::string(operationName(op)) + ": empty grid operand (" +
                                (a.empty() ? "first" : "second") + ")");
  }
  // Same layout: b's node values directly; otherwise b's multilinear look-up at a's nodes.
  const bool sameLayout = (a.dims() == b.dims()).all() && a.origin() == b.origin() && a.spacing() == b.spacing();
  if (sameLayout) {
    return apply<D>(op, a, [&b](std::size_t n, const Vec<D>&) { return double(b[n]); });
  }
  return apply<D>(op, a, [&b](std::size_t, const Vec<D>& x) { return b.value(x); });
}

template <int D>
Grid<D> functionOperation(Operation op, const Grid<D>& a, const SignedDistance<D>& b) {
  if (a.empty()) throw std::invalid_argument(std::string(operationName(op)) + ": empty grid operand");
  if (!b) throw std::invalid_argument(std::string(operationName(op)) + ": empty signed-distance function");
  return apply<D>(op, a, [&b](std::size_t, const Vec<D>& x) { return b(x); });
}

}  // namespace

template <int D>
Grid<D> csgDifference(const Grid<D>& a, const Grid<D>& b) {
  return gridOperation<D>(Operation::Difference, a, b);
}

template <int D>
Grid<D> csgIntersection(const Grid<D>& a, const Grid<D>& b) {
  return gridOperation<D>(Operation::Intersection, a, b);
}

template <int D>
Grid<D> csgUnion(const Grid<D>& a, const Grid<D>& b) {
  return gridOperation<D>(Operation::Union, a, b);
}

template <int D>
Grid<D> csgDifference(const Grid<D>& a, const SignedDistance<D>& b) {
  return functionOperation<D>(Operation::Difference, a, b);
}

template <int D>
Grid<D> csgIntersection(const Grid<D>& a, const SignedDistance<D>& b) {
  return functionOperation<D>(Operation::Intersection, a, b);
}

template <int D>
Grid<D> csgUnion(const Grid<D>& a, const SignedDistance<D>& b) {
  return functionOperation<D>(Operation::Union, a, b);
}

template Grid<2> csgDifference<2>(const Grid<2>&, const Grid<2>&);
template Grid<3> csgDifference<3>(const Grid<3>&, const Grid<3>&);
template Grid<2> csgIntersection<2>(const Grid<2>&, const Grid<2>&);
template Grid<3> csgIntersection<3>(const Grid<3>&, const Grid<3>&);
template Grid<2> csgUnion<2>(const Grid<2>&, const Grid<2>&);
template Grid<3> csgUnion<3>(const Grid<3>&, const Grid<3>&);
template Grid<2> csgDifference<2>(const Grid<2>&, const SignedDistance<2>&);
template Grid<3> csgDifference<3>(const Grid<3>&, const SignedDistance<3>&);
template Grid<2> csgIntersection<2>(const Grid<2>&, const SignedDistance<2>&);
template Grid<3> csgIntersection<3>(const Grid<3>&, const SignedDistance<3>&);
template Grid<2> csgUnion<2>(const Grid<2>&, const SignedDistance<2>&);
template Grid<3> csgUnion<3>(const Grid<3>&, const SignedDistance<3>&);

}  // namespace lsdem::geometry
