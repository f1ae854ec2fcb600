#include "lsdem/parallel/Decomposition.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

namespace lsdem::parallel {
namespace {

template <int D>
geometry::Box<D> everywhere() {
  geometry::Box<D> b;
  b.lower.setConstant(-std::numeric_limits<double>::infinity());
  b.upper.setConstant(std::numeric_limits<double>::infinity());
  return b;
}

// The distance between two boxes (0 where they touch or overlap; a point is
// a box of no size). Finite with infinite sides: a gap is only ever a
// finite side minus another, or -inf.
template <int D>
double boxDistance(const geometry::Box<D>& a, const geometry::Box<D>& b) {
  double d2 = 0.0;
  for (int k = 0; k < D; ++k) {
    const double gap = std::max({b.lower[k] - a.upper[k], a.lower[k] - b.upper[k], 0.0});
    d2 += gap * gap;
  }
  return std::sqrt(d2);
}

}  // namespace

template <int D>
Decomposition<D>::Decomposition() : nodes_(1), boxes_{everywhere<D>()} {}

template <int D>
Decomposition<D> Decomposition<D>::build(std::span<const Vec<D>> points, std::span<const double> weights, int parts,
                                         std::span<const double> capacities) {
  if (parts < 1) throw std::invalid_argument("decomposition: parts must be >= 1, got " + std::to_string(parts));
  if (points.size() != weights.size()) {
    throw std::invalid_argument("decomposition: " + std::to_string(points.size()) + " points but " +
                                std::to_string(weights.size()) + " weights");
  }
  if (!capacities.empty() && capacities.size() != std::size_t(parts)) {
    throw std::invalid_argument("decomposition: " + std::to_string(parts) + " parts but " +
                                std::to_string(capacities.size()) + " capacities");
  }
  for (const double c : capacities) {
    if (!(c > 0.0) || !std::isfinite(c)) {
      throw std::invalid_argument("decomposition: a part's capacity must be positive and finite, got " +
                                  std::to_string(c));
    }
  }
  // The capacity of parts [first, first + count).
  const auto capacity = [&](int first, int count) {
    if (capacities.empty()) return double(count);
    double c = 0.0;
    for (int p = first; p < first + count; ++p) c += capacities[std::size_t(p)];
    return c;
  };
  Decomposition d;
  d.parts_ = parts;
  d.nodes_.clear();
  d.boxes_.assign(std::size_t(parts), everywhere<D>());
  std::vector<std::uint32_t> order(points.size());
  std::iota(order.begin(), order.end(), 0u);

  // Splits order[begin, end) into `count` parts numbered from `first`, in box `box`; returns the node.
  const auto split = [&](auto&& self, std::size_t begin, std::size_t end, int first, int count,
                         const geometry::Box<D>& box) -> int {
    const int index = int(d.nodes_.size());
    d.nodes_.emplace_back();
    if (count == 1) {
      d.nodes_[std::size_t(index)].part = first;
      d.boxes_[std::size_t(first)] = box;
      return index;
    }
    // The longest extent of the points (axis 0 when there are none).
    int axis = 0;
    if (end > begin) {
      Vec<D> lo = points[order[begin]], hi = lo;
      for (std::size_t k = begin; k < end; ++k) {
        lo = lo.cwiseMin(points[order[k]]);
        hi = hi.cwiseMax(points[order[k]]);
      }
      (hi - lo).maxCoeff(&axis);
    }
    // Sort along it (ties by index: the same order on every rank).
    std::sort(order.begin() + std::ptrdiff_t(begin), order.begin() + std::ptrdiff_t(end),
              [&](std::uint32_t a, std::uint32_t b) {
                const double xa = points[a][axis], xb = points[b][axis];
                return xa < xb || (xa == xb && a < b);
              });
    const int lowerCount = count / 2;
    double total = 0.0;
    for (std::size_t k = begin; k < end; ++k) total += weights[order[k]];
    const double share = total * capacity(first, lowerCount) / capacity(first, count);
    // The first point whose cumulative weight passes the share starts the upper side.
    std::size_t mid = begin;
    double sum = 0.0;
    while (mid < end && sum + 0.5 * weights[order[mid]] < share) sum += weights[order[mid++]];
    // A cut between two distinct coordinates; points with equal coordinates stay on one side.
    while (mid > begin && mid < end && points[order[mid - 1]][axis] == points[order[mid]][axis]) --mid;
    double cut;
    if (end == begin) {
      cut = 0.5 * (box.lower[axis] + box.upper[axis]);
      if (!std::isfinite(cut)) cut = 0.0;
    } else if (mid == begin) {
      cut = points[order[begin]][axis];
    } else if (mid == end) {
      cut = std::nextafter(points[order[end - 1]][axis], std::numeric_limits<double>::infinity());
    } else {
      cut = 0.5 * (points[order[mid - 1]][axis] + points[order[mid]][axis]);
    }
    geometry::Box<D> lowerBox = box, upperBox = box;
    lowerBox.upper[axis] = cut;
    upperBox.lower[axis] = cut;
    const int lower = self(self, begin, mid, first, lowerCount, lowerBox);
    const int upper = self(self, mid, end, first + lowerCount, count - lowerCount, upperBox);
    Node& n = d.nodes_[std::size_t(index)];
    n.axis = axis;
    n.cut = cut;
    n.lower = lower;
    n.upper = upper;
    return index;
  };
  split(split, 0, points.size(), 0, parts, everywhere<D>());
  return d;
}

template <int D>
int Decomposition<D>::owner(const Vec<D>& x) const {
  int k = 0;
  while (nodes_[std::size_t(k)].axis >= 0) {
    const Node& n = nodes_[std::size_t(k)];
    k = x[n.axis] < n.cut ? n.lower : n.upper;
  }
  return nodes_[std::size_t(k)].part;
}

template <int D>
double Decomposition<D>::distance(const Vec<D>& x, int p) const {
  return boxDistance<D>({x, x}, box(p));
}

template <int D>
double Decomposition<D>::distance(int p, int q) const {
  return boxDistance<D>(box(p), box(q));
}

template class Decomposition<2>;
template class Decomposition<3>;

}  // namespace lsdem::parallel
