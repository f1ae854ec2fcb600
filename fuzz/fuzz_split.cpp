/// @file fuzz_split.cpp
/// @brief libFuzzer target: random planes (finite, degenerate and invalid),
/// shapes and contact sets thrown at the splitter (splitShape, fragmentState)
/// and at the fracture-plane construction (fracturePlane).
///
/// Invariants (a violation aborts, which libFuzzer reports as a crash):
///   - splitShape throws only std::invalid_argument, and only for an invalid
///     plane (zero or non-finite normal, non-finite offset) or invalid options;
///   - a split gives 0 or >= 2 fragments; their corrected volumes sum to the
///     parent's to 1e-12 relative; their volume-weighted centroid is the
///     reported centroidShift to 1e-12 of the parent's radius, and within two
///     cells of the parent's centroid (fragments stay where the material was;
///     0.9 cells seen for four fragments of a grain at the resolution limit
///     with a 5.5 % raw volume error); no fragment node lies outside the
///     parent by more than 1e-3 cells;
///   - every value of every fragment is finite: volumes > 0, mass scales > 0,
///     inertia, nodes and node weights > 0, poses, and the fragment state of a
///     moving, spinning parent; every fragment has surface nodes;
///   - fracturePlane gives nothing or a finite unit normal and finite offset.

#include "FuzzInput.h"
#include "FuzzShapes.h"

#include "lsdem/breakage/FracturePlane.h"
#include "lsdem/breakage/Split.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace {

using namespace lsdem;
using geometry::HalfSpace;
using geometry::Vec;

[[noreturn]] void violation(const char* what, double value = 0.0) {
  std::fprintf(stderr, "fuzz_split: invariant violated: %s (%.17g)\n", what, value);
  std::abort();
}

template <int D>
Vec<D> unitFrom(fuzz::FuzzInput& in) {
  Vec<D> n;
  for (int a = 0; a < D; ++a) n[a] = in.uniform(-1.0, 1.0);
  if (in.chance(40)) {
    // An axis or a diagonal: planes through rows of grid nodes.
    n.setZero();
    n[in.integer(0, D - 1)] = in.chance(128) ? 1.0 : -1.0;
    if (in.chance(100)) n[in.integer(0, D - 1)] += 1.0;
  }
  return n;
}

template <int D>
bool finiteShape(const geometry::Shape<D>& s) {
  if (!(std::isfinite(s.volume()) && s.volume() > 0.0)) return false;
  if (!s.mass().inertiaTensor().allFinite() || !std::isfinite(s.boundingRadius())) return false;
  if (!s.bodyToGrid().rotation.allFinite() || !s.bodyToGrid().translation.allFinite()) return false;
  for (std::size_t i = 0; i < s.nodes().size(); ++i) {
    if (!s.nodes().positions[i].allFinite() || !(s.nodes().weights[i] > 0.0) || !std::isfinite(s.nodes().weights[i])) {
      return false;
    }
  }
  return true;
}

/// One split with its checks; returns a fragment shape to split next (or null).
template <int D>
std::shared_ptr<const geometry::Shape<D>> splitOnce(const geometry::Shape<D>& parent, fuzz::FuzzInput& in) {
  // The plane: random, through a node, through the centroid, grazing, or raw bytes.
  HalfSpace<D> plane;
  plane.normal = unitFrom<D>(in);
  const double R = parent.boundingRadius();
  const int mode = in.integer(0, 5);
  const double nn = plane.normal.norm();
  switch (mode) {
    case 0: plane.offset = in.uniform(-1.2, 1.2) * R * nn; break;
    case 1: {
      const auto& nodes = parent.nodes();
      const Vec<D> x = nodes.positions[std::size_t(in.integer(0, int(nodes.size()) - 1))];
      plane.offset = plane.normal.dot(x);
      break;
    }
    case 2: plane.offset = 0.0; break;
    case 3: {
      // Grazing: at the supporting distance of the nodes along n, minus a sliver.
      double support = -1e300;
      for (const Vec<D>& x : parent.nodes().positions) support = std::max(support, plane.normal.dot(x));
      plane.offset = support - in.uniform(-0.5, 1.0) * parent.grid().spacing() * nn * std::pow(10.0, -in.integer(0, 6));
      break;
    }
    case 4:
      for (int a = 0; a < D; ++a) plane.normal[a] = in.raw();
      plane.offset = in.raw();
      break;
    default: plane.offset = in.uniform(-0.3, 0.3) * R * nn; break;
  }
  breakage::SplitOptions options;
  if (in.chance(30)) options.nodesPerCell = in.chance(20) ? -in.uniform(0.0, 1.0) : in.uniform(0.25, 3.0);
  if (in.chance(10)) options.paddingCells = in.integer(0, 6);

  const double norm = plane.normal.norm();
  const bool validPlane = std::isfinite(norm) && norm > 0.0 && std::isfinite(plane.offset);
  const bool validOptions = options.nodesPerCell >= 0.0 && options.paddingCells >= 3;
  breakage::FractureSurface<D> surface;
  surface.plane = plane;
  breakage::SplitResult<D> split;
  try {
    split = breakage::splitShape(parent, surface, options);
  } catch (const std::invalid_argument&) {
    if (validPlane && validOptions) violation("splitShape rejected a valid plane", plane.offset);
    return nullptr;
  }
  if (!(validPlane && validOptions)) violation("splitShape accepted an invalid plane or options", plane.offset);

  // Outcome: no fragments, or >= 2 with exact volume and centroid.
  if (!split.isSplit) {
    if (!split.fragments.empty()) violation("an unsplit result with fragments");
    return nullptr;
  }
  if (split.fragments.size() < 2) violation("a split with fewer than two fragments");
  double sum = 0.0;
  Vec<D> moment = Vec<D>::Zero();
  dynamics::Spin<D> spin = dynamics::Rotation<D>::zeroSpin();
  if constexpr (D == 2) {
    spin = 7.0;
  } else {
    spin = Vec<3>(1.0, -7.0, 3.0);
  }
  const Vec<D> x0 = Vec<D>::Constant(0.5), v0 = Vec<D>::Constant(-2.0);
  const geometry::Mat<D> rot = geometry::Mat<D>::Identity();
  for (const auto& f : split.fragments) {
    if (!f.shape || !finiteShape(*f.shape)) violation("a fragment with non-finite or non-positive values");
    if (f.shape->nodes().size() == 0) violation("a fragment without surface nodes");
    if (!(f.volume > 0.0) || !std::isfinite(f.volume)) violation("fragment volume", f.volume);
    if (!(f.massScale() > 0.0) || !std::isfinite(f.massScale())) violation("fragment mass scale", f.massScale());
    if (!f.childToParent.translation.allFinite() || !f.childToParent.rotation.allFinite()) violation("fragment pose");
    const auto st = breakage::fragmentState<D>(f, x0, rot, v0, spin);
    if (!st.position.allFinite() || !st.velocity.allFinite() || !st.rotation.allFinite()) violation("fragment state");
    sum += f.volume;
    moment += f.volume * f.childToParent.translation;
  }
  const double volumeError = std::abs(sum - split.parentVolume) / split.parentVolume;
  if (!(volumeError <= 1e-12)) violation("fragment volumes do not sum to the parent's", volumeError);
  const double lever = (moment - split.parentVolume * split.centroidShift).norm() / (split.parentVolume * R);
  if (!(lever <= 1e-12)) violation("fragments' centroid is not the reported centroidShift", lever);
  const double h = parent.grid().spacing();
  if (!(split.centroidShift.norm() < 2.0 * h)) violation("fragments' centroid off the parent's (cells)", split.centroidShift.norm() / h);
  for (const auto& f : split.fragments) {
    for (const Vec<D>& x : f.shape->nodes().positions) {
      const double outside = parent.value(f.childToParent.apply(x));
      if (!(outside <= (1e-3 + split.largestSurfaceShift) * h)) {
        violation("a fragment node outside the parent beyond the surface shift (cells)", outside / h);
      }
    }
  }
  if (!std::isfinite(split.rawRelativeError) || !std::isfinite(split.inertiaRelativeError)) {
    violation("non-finite split errors");
  }
  return split.fragments[std::size_t(in.integer(0, int(split.fragments.size()) - 1))].shape;
}

/// A fracture plane from a random (often degenerate) contact set, then a split by it.
template <int D>
void planeFromContacts(const geometry::Shape<D>& shape, fuzz::FuzzInput& in) {
  const double R = shape.boundingRadius();
  const Vec<D> centroid = Vec<D>::Constant(in.uniform(-1.0, 1.0));
  std::vector<breakage::ContactPoint<D>> points;
  const int count = in.integer(0, 5);
  for (int k = 0; k < count; ++k) {
    breakage::ContactPoint<D> p;
    const int kind = in.integer(0, 3);
    if (kind == 0 && !points.empty()) {
      p.point = points[std::size_t(in.integer(0, int(points.size()) - 1))].point;  // coincident
    } else if (kind == 1 && points.size() >= 2) {
      const double s = in.uniform(-2.0, 2.0);  // collinear with the first two
      p.point = points[0].point + s * (points[1].point - points[0].point);
    } else if (kind == 2) {
      p.point = centroid;
    } else {
      for (int a = 0; a < D; ++a) p.point[a] = centroid[a] + in.uniform(-1.0, 1.0) * R;
    }
    p.force = in.uniform(0.0, 10.0);
    points.push_back(p);
  }
  std::sort(points.begin(), points.end(), [](const auto& a, const auto& b) { return a.force > b.force; });
  const auto plane = breakage::fracturePlane<D>(centroid, points, 2.0 * R);
  if (!plane) return;
  if (!plane->normal.allFinite() || !std::isfinite(plane->offset)) violation("fracturePlane: non-finite plane");
  if (std::abs(plane->normal.norm() - 1.0) > 1e-12) violation("fracturePlane: normal not unit", plane->normal.norm());
  breakage::FractureSurface<D> surface;
  surface.plane = HalfSpace<D>{plane->normal, plane->offset - plane->normal.dot(centroid)};
  const auto split = breakage::splitShape(shape, surface);
  double sum = 0.0;
  for (const auto& f : split.fragments) sum += f.volume;
  if (split.isSplit && !(std::abs(sum - split.parentVolume) <= 1e-12 * split.parentVolume)) {
    violation("fracture-plane split: volumes", sum / split.parentVolume - 1.0);
  }
}

template <int D>
void run(fuzz::FuzzInput& in) {
  const auto& library = fuzz::shapeLibrary<D>();
  std::shared_ptr<const geometry::Shape<D>> shape = library[std::size_t(in.integer(0, int(library.size()) - 1))];
  if (in.chance(60)) {
    planeFromContacts<D>(*shape, in);
    return;
  }
  // A lineage: split, then split one of the fragments again, up to three times.
  const int generations = in.integer(1, 3);
  for (int g = 0; g < generations && shape; ++g) shape = splitOnce<D>(*shape, in);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::FuzzInput in(data, size);
  if (in.byte() & 1) {
    run<3>(in);
  } else {
    run<2>(in);
  }
  return 0;
}
