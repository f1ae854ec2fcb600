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

/// Visits every node of a's grid in parallel: `sampleB(n, x)` gives b at node
/// n, world position x, and `store(n, b)` writes the node's results. Nodes are
/// independent, so any thread count gives the same grids. Throws (naming the
/// first node) if b gives a NaN.
template <int D, class SampleB, class Store>
void forEachNode(const char* name, const Grid<D>& a, SampleB sampleB, Store store) {
  const std::int64_t count = std::int64_t(a.size());
  std::int64_t firstNaN = count;
  // By slices of the last axis, the node index stepped within each slice.
  const int slices = a.dims()[D - 1];
  const std::size_t sliceSize = a.size() / std::size_t(slices);
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static) reduction(min : firstNaN) if (count > (1 << 16))
#endif
  for (int slice = 0; slice < slices; ++slice) {
    Index<D> i = Index<D>::Zero();
    i[D - 1] = slice;
    const std::size_t begin = std::size_t(slice) * sliceSize;
    for (std::size_t node = begin; node < begin + sliceSize; ++node, a.advance(i)) {
      const double b = sampleB(node, a.nodePosition(i));
      if (std::isnan(b)) {
        firstNaN = std::min(firstNaN, std::int64_t(node));
        continue;
      }
      store(node, b);
    }
  }
  if (firstNaN < count) {
    throw std::invalid_argument(std::string(name) + ": the second operand is NaN at node " + std::to_string(firstNaN));
  }
}

/// Applies `op` node by node on a's grid; `sampleB(n, x)` gives b at node n,
/// world position x.
template <int D, class SampleB>
Grid<D> apply(Operation op, const Grid<D>& a, SampleB sampleB) {
  Grid<D> out = a;
  forEachNode<D>(operationName(op), a, sampleB,
                 [&](std::size_t n, double b) { out[n] = float(combine(op, a[n], b)); });
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

template <int D>
void csgSplit(const Grid<D>& a, const SignedDistance<D>& b, Grid<D>& negative, Grid<D>& positive) {
  if (a.empty()) throw std::invalid_argument("csgSplit: empty grid operand");
  if (!b) throw std::invalid_argument("csgSplit: empty signed-distance function");
  negative = a;
  positive = a;
  forEachNode<D>("csgSplit", a, [&b](std::size_t, const Vec<D>& x) { return b(x); },
                 [&](std::size_t n, double f) {
                   negative[n] = float(combine(Operation::Intersection, a[n], f));
                   positive[n] = float(combine(Operation::Difference, a[n], f));
                 });
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
template void csgSplit<2>(const Grid<2>&, const SignedDistance<2>&, Grid<2>&, Grid<2>&);
template void csgSplit<3>(const Grid<3>&, const SignedDistance<3>&, Grid<3>&, Grid<3>&);

}  // namespace lsdem::geometry
