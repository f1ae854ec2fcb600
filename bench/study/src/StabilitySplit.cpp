// The splitter at its limits (splitLimitsCase): no dynamics, only splits and
// fracture planes, each fragment checked for exact volume, finite values and
// usable nodes.

#include "lsdem/study/Stability.h"

#include "lsdem/breakage/FracturePlane.h"
#include "lsdem/breakage/Split.h"
#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/ShapeDef.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

namespace lsdem::study {

using breakage::FractureSurface;
using breakage::SplitResult;
using geometry::HalfSpace;
using geometry::Shape;
using geometry::Vec;

namespace {

template <int D>
std::shared_ptr<const Shape<D>> sphere(double radius, double cells) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::Sphere;
  def.radius = radius;
  def.cellsAcross = cells;
  def.options.nodesPerCell = 1.0;
  return geometry::buildShape(def);
}

template <int D>
std::shared_ptr<const Shape<D>> ellipsoid(const Vec<D>& semiAxes, double cells) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::Ellipsoid;
  def.semiAxes = semiAxes;
  def.cellsAcross = cells;
  def.options.nodesPerCell = 1.0;
  return geometry::buildShape(def);
}

/// A comb: a back bar along x with `teeth` teeth along +y (2D), extruded in z
/// (3D); concave, so a cut across the teeth leaves teeth + 1 pieces.
template <int D>
std::shared_ptr<const Shape<D>> comb(int teeth, double tooth, double spacing) {
  const double gap = 2.0 * tooth;
  const double width = teeth * tooth + (teeth - 1) * gap;
  Vec<D> backHalf = Vec<D>::Constant(tooth);
  backHalf[0] = 0.5 * width;
  backHalf[1] = 0.5 * tooth;
  Vec<D> toothHalf = Vec<D>::Constant(tooth);
  toothHalf[0] = 0.5 * tooth;
  toothHalf[1] = 2.25 * tooth;  // from y = 0 (inside the back bar: no internal face) to 4.5 tooth
  geometry::Box<D> box;
  box.lower = -Vec<D>::Constant(tooth);
  box.lower[0] = -0.5 * width;
  box.upper = Vec<D>::Constant(tooth);
  box.upper[0] = 0.5 * width;
  box.upper[1] = 4.0 * tooth + tooth;
  auto sdf = [&](const Vec<D>& x) {
    double phi = geometry::sdfBox<D>(x, backHalf);
    for (int k = 0; k < teeth; ++k) {
      Vec<D> c = Vec<D>::Zero();
      c[0] = -0.5 * width + 0.5 * tooth + k * (tooth + gap);
      c[1] = 2.25 * tooth;
      phi = std::min(phi, geometry::sdfBox<D>(x - c, toothHalf));
    }
    return phi;
  };
  geometry::ShapeOptions options;
  options.nodesPerCell = 1.0;
  return Shape<D>::fromGrid(geometry::sampleGrid<D>(box, spacing, geometry::kDefaultPaddingCells, sdf), options);
}

template <int D>
bool finiteShape(const Shape<D>& s) {
  if (!(std::isfinite(s.volume()) && s.volume() > 0.0)) return false;
  if (!s.mass().inertiaTensor().allFinite() || !s.mass().centroid.allFinite()) return false;
  if (!std::isfinite(s.boundingRadius())) return false;
  for (std::size_t i = 0; i < s.nodes().size(); ++i) {
    if (!s.nodes().positions[i].allFinite() || !(s.nodes().weights[i] > 0.0) ||
        !std::isfinite(s.nodes().weights[i])) {
      return false;
    }
  }
  return true;
}

/// Runs one split and checks every fragment; returns the split.
template <int D>
SplitResult<D> checkedSplit(const Shape<D>& parent, const HalfSpace<D>& plane, const char* what,
                            StabilityResult& out) {
  FractureSurface<D> surface;
  surface.plane = plane;
  SplitResult<D> split;
  ++out.steps;
  // Every other split re-grids small fragments (regridCells 10, the measured
  // choice), so both ways of making a fragment meet every case.
  breakage::SplitOptions options;
  options.regridCells = out.steps % 2 == 0 ? 10.0 : 0.0;
  try {
    split = breakage::splitShape(parent, surface, options);
  } catch (const std::exception& e) {
    out.violations.push_back(std::string(what) + ": splitShape threw: " + e.what());
    return split;
  }
  if (!split.isSplit) return split;
  ++out.breakages;

  // Volumes: the corrected volumes sum to the parent's to round-off.
  double sum = 0.0;
  Vec<D> moment = Vec<D>::Zero();
  bool finite = std::isfinite(split.rawRelativeError) && std::isfinite(split.inertiaRelativeError);
  for (const auto& f : split.fragments) {
    sum += f.volume;
    moment += f.volume * f.childToParent.translation;
    finite = finite && finiteShape(*f.shape) && std::isfinite(f.volume) && f.volume > 0.0 &&
             std::isfinite(f.massScale()) && f.massScale() > 0.0 && f.childToParent.translation.allFinite() &&
             f.childToParent.rotation.allFinite();
    if (f.shape->nodes().size() == 0) {
      out.violations.push_back(std::string(what) + ": a fragment without surface nodes");
    }
    // The fragment's state from a moving, spinning parent is finite.
    dynamics::Spin<D> spin = dynamics::Rotation<D>::zeroSpin();
    if constexpr (D == 2) {
      spin = 3.0;
    } else {
      spin = Vec<3>(1.0, -2.0, 3.0);
    }
    const Vec<D> ones = Vec<D>::Ones();
    const geometry::Mat<D> identity = geometry::Mat<D>::Identity();
    const auto st = breakage::fragmentState<D>(f, ones, identity, ones, spin);
    finite = finite && st.position.allFinite() && st.velocity.allFinite() && st.rotation.allFinite();
  }
  if (!finite) ++out.nonFinite;

  // Siblings do not overlap: no node of one fragment lies inside another
  // (beyond a small fraction of a cell), or the split would start with
  // contact springs the parent did not have (energy from nothing).
  const double h = parent.grid().spacing();
  double deepest = 0.0;
  for (std::size_t a = 0; a < split.fragments.size(); ++a) {
    for (std::size_t b = 0; b < split.fragments.size(); ++b) {
      if (a == b) continue;
      const auto& fa = split.fragments[a];
      const auto& fb = split.fragments[b];
      for (const Vec<D>& x : fa.shape->nodes().positions) {
        const Vec<D> xb = fb.childToParent.applyInverse(fa.childToParent.apply(x));
        deepest = std::max(deepest, -fb.shape->value(xb));
      }
    }
  }
  // No node of a fragment lies outside the parent beyond a small fraction of
  // a cell, the surface shift the split reports (SplitOptions::
  // matchEnclosedVolume, which moves only free surface; here nothing is
  // around) and the parent's own nodes' offset outside its interpolated
  // surface (nodes on the true surface, which its fragments keep): a
  // fragment's surface where the parent had none would start inside
  // whatever the parent touched.
  double outside = 0.0, parentOffset = 0.0;
  for (const auto& f : split.fragments) {
    for (const Vec<D>& x : f.shape->nodes().positions) outside = std::max(outside, parent.value(f.childToParent.apply(x)));
  }
  for (const Vec<D>& x : parent.nodes().positions) parentOffset = std::max(parentOffset, parent.value(x));
  if (!(outside <= (1e-3 + split.largestSurfaceShift) * h + parentOffset)) {
    char buffer[160];
    std::snprintf(buffer, sizeof buffer, "%s: a fragment's node %.3g cells outside the parent", what, outside / h);
    out.violations.push_back(buffer);
  }
  out.maxOverlapFraction = std::max(out.maxOverlapFraction, deepest / h);
  // A re-gridded fragment's level set samples the parent's at its finer
  // nodes: a sibling's node on the shared surface can read up to a few
  // hundredths of a parent cell inside it (measured <= 0.063 cells in the
  // lineage case, where parents are themselves re-gridded).
  bool anyRegridded = false;
  for (const auto& f : split.fragments) anyRegridded = anyRegridded || f.regridded;
  const double siblingTolerance = anyRegridded ? 0.1 * h : 1e-3 * h;
  if (!(deepest <= siblingTolerance)) {
    char buffer[160];
    std::snprintf(buffer, sizeof buffer, "%s: a fragment's node %.3g cells inside its sibling", what, deepest / h);
    out.violations.push_back(buffer);
  }
  out.maxSplitMassError = std::max(out.maxSplitMassError, std::abs(sum - split.parentVolume) / split.parentVolume);
  // The fragments' centre of volume is the reported centroidShift, and that
  // is within two cells of the parent's centroid (the fragments stay where
  // the parent's material was, Split.h; at the resolution limit the raw
  // volume error reaches a few per cent and the centroid nearly a cell).
  const double lever = (moment - split.parentVolume * split.centroidShift).norm() /
                       (split.parentVolume * parent.boundingRadius());
  if (!(lever < 1e-12) || !(split.centroidShift.norm() < 2.0 * h)) {
    char buffer[160];
    std::snprintf(buffer, sizeof buffer, "%s: fragments' centroid %.3g cells off the parent's (reported with error %.3g radii)",
                  what, split.centroidShift.norm() / h, lever);
    out.violations.push_back(buffer);
  }
  return split;
}

/// A unit vector from two or three angles (deterministic).
template <int D>
Vec<D> direction(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Vec<D> n;
  do {
    for (int a = 0; a < D; ++a) n[a] = g(rng);
  } while (n.norm() < 1e-3);
  return n.normalized();
}

}  // namespace

template <int D>
StabilityResult splitLimitsCase(CaseLength length) {
  const auto t0 = std::chrono::steady_clock::now();
  StabilityResult out;
  out.name = "split_limits";
  out.dimension = D;
  out.note = "splitter only: resolution limit, slivers, grazing, misses, nodes, centroid, concave, degenerate planes";
  const bool isLong = length == CaseLength::Long;
  std::mt19937_64 rng(12345 + D);
  const double r = 0.01;

  // Grains at the resolution limit: 4 to 8 cells across, cut anywhere
  // (children a few cells across, with few or no nodes of their own).
  for (double cells : {4.0, 5.0, 6.0, 8.0}) {
    const auto s = sphere<D>(r, cells);
    const double h = s->grid().spacing();
    const int cuts = isLong ? 60 : (D == 2 ? 16 : 6);
    std::uniform_real_distribution<double> offset(-r, r);
    for (int k = 0; k < cuts; ++k) checkedSplit<D>(*s, {direction<D>(rng), offset(rng)}, "resolution limit", out);
    // Slivers thinner than a cell, and cuts grazing or missing the surface.
    for (double depth : {0.9, 0.5, 0.25, 0.1, 1e-3, 0.0, -1e-6, -0.5, -3.0}) {
      const Vec<D> n = direction<D>(rng);
      checkedSplit<D>(*s, {n, r - depth * h}, "sliver/graze/miss", out);
    }
  }

  // Cuts through a surface node (in every tangent direction) and through the centroid.
  {
    const auto s = sphere<D>(r, 12);
    const std::size_t count = std::min<std::size_t>(s->nodes().size(), isLong ? 200 : (D == 2 ? 24 : 8));
    for (std::size_t i = 0; i < count; ++i) {
      const Vec<D> x = s->nodes().positions[i * s->nodes().size() / count];
      const Vec<D> n = direction<D>(rng);
      checkedSplit<D>(*s, {n, n.dot(x)}, "through a node", out);
      checkedSplit<D>(*s, {n, 0.0}, "through the centroid", out);
    }
  }

  // Degenerate inertia: needle and (3D) disc, cut along and across.
  {
    Vec<D> needleAxes = Vec<D>::Constant(0.1 * r);
    needleAxes[0] = r;
    std::vector<std::shared_ptr<const Shape<D>>> shapes{ellipsoid<D>(needleAxes, 5)};
    if constexpr (D == 3) shapes.push_back(ellipsoid<D>(Vec<D>(r, r, 0.1 * r), 5));
    for (const auto& s : shapes) {
      for (int a = 0; a < D; ++a) checkedSplit<D>(*s, {Vec<D>::Unit(a), 0.0}, "needle/disc", out);
      for (int k = 0; k < 6; ++k) checkedSplit<D>(*s, {direction<D>(rng), 0.0}, "needle/disc", out);
    }
  }

  // Concave grains: a comb cut across its teeth falls into many components.
  {
    const double tooth = 0.004;
    for (int teeth : {2, 4}) {
      const auto s = comb<D>(teeth, tooth, tooth / 4.0);
      // The comb's body frame is its principal frame: find the teeth direction
      // as the body image of the grid's +y, and cut across it at tooth height.
      const geometry::Mat<D> gridToBody = s->bodyToGrid().rotation.transpose();
      const Vec<D> up = gridToBody * Vec<D>::UnitY();
      const Vec<D> c = s->bodyToGrid().applyInverse(Vec<D>::UnitY() * 3.0 * tooth);
      const SplitResult<D> split = checkedSplit<D>(*s, {up, up.dot(c)}, "concave", out);
      if (int(split.fragments.size()) != teeth + 1) {
        out.violations.push_back("concave: a cut across " + std::to_string(teeth) + " teeth gave " +
                                 std::to_string(split.fragments.size()) + " fragments");
      }
    }
  }

  // A lineage split again and again through its centroid, keeping the larger
  // child, down to the minimum size (until a split no longer splits).
  {
    auto s = sphere<D>(r, isLong ? 24 : 12);
    for (int generation = 0; generation < 40; ++generation) {
      const SplitResult<D> split = checkedSplit<D>(*s, {direction<D>(rng), 0.0}, "lineage", out);
      if (!split.isSplit) break;
      const auto largest = std::max_element(split.fragments.begin(), split.fragments.end(),
                                            [](const auto& a, const auto& b) { return a.volume < b.volume; });
      s = largest->shape;
    }
  }

  // Fracture planes from degenerate contact sets, then split by them.
  {
    const auto s = sphere<D>(r, 10);
    const Vec<D> centre = Vec<D>::Constant(0.3);
    auto at = [&](const Vec<D>& body) { return centre + body; };
    std::vector<std::vector<breakage::ContactPoint<D>>> sets;
    Vec<D> e0 = Vec<D>::Unit(0) * r, e1 = Vec<D>::Unit(1) * r;
    sets.push_back({});                                                   // no contact
    sets.push_back({{centre, 1.0}});                                      // the centroid only
    sets.push_back({{at(e0), 2.0}, {at(e0), 1.0}});                       // two at the same place
    sets.push_back({{at(e0), 2.0}, {at(e0 * (1.0 + 1e-9)), 1.0}});       // two almost at the same place
    sets.push_back({{at(e0), 3.0}, {at(-e0), 2.0}, {at(0.5 * e0), 1.0}}); // three collinear, through the centroid
    sets.push_back({{at(e0 + e1), 3.0}, {at(-e0 + e1), 2.0}, {at(e1), 1.0}});  // three collinear, off it
    sets.push_back({{at(e1), 1.0}, {at(e1), 1.0}, {at(e1), 1.0}});       // three identical
    for (const auto& set : sets) {
      ++out.steps;
      std::optional<HalfSpace<D>> plane;
      try {
        plane = breakage::fracturePlane<D>(centre, set, 2.0 * r);
      } catch (const std::exception& e) {
        out.violations.push_back(std::string("degenerate contacts: fracturePlane threw: ") + e.what());
        continue;
      }
      if (!plane) continue;
      if (!plane->normal.allFinite() || !std::isfinite(plane->offset) || std::abs(plane->normal.norm() - 1.0) > 1e-12) {
        ++out.nonFinite;
        continue;
      }
      // World plane to the body frame of a grain at `centre` with identity rotation.
      checkedSplit<D>(*s, {plane->normal, plane->offset - plane->normal.dot(centre)}, "degenerate contacts", out);
    }
  }

  out.particles = 0;
  out.minBreakages = isLong ? 200 : (D == 2 ? 60 : 30);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  checkInvariants(out);
  return out;
}

template StabilityResult splitLimitsCase<2>(CaseLength);
template StabilityResult splitLimitsCase<3>(CaseLength);

}  // namespace lsdem::study
