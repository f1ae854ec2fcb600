/// @file Specimen.cpp
/// @brief The specimen's measures (Specimen.h).

#include "run/Specimen.h"

#include "lsdem/dynamics/Rotation.h"

#include <algorithm>
#include <limits>

namespace lsdem::io {

namespace {

// The index of the plane of this name, or -1.
template <int D>
std::ptrdiff_t planeIndex(const dynamics::World<D>& w, const std::string& name) {
  const auto& names = w.planeNames();
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : it - names.begin();
}

}  // namespace

template <int D>
double specimenHeight(const SpecimenDef& specimen, const dynamics::World<D>& w) {
  const std::ptrdiff_t b = planeIndex(w, specimen.bottom);
  if (b < 0) return 0.0;
  const dynamics::Plane<D>& bottom = w.planes()[std::size_t(b)];
  const std::ptrdiff_t t = planeIndex(w, specimen.top);
  if (t >= 0) return bottom.signedDistance(w.planes()[std::size_t(t)].point);
  for (std::size_t k = 0; k < w.tools().size(); ++k) {
    if (w.tools()[k].name != specimen.top) continue;
    const dynamics::ToolPose<D>& pose = w.toolPoses()[k];
    const geometry::Mat<D> r = dynamics::Rotation<D>::matrix(pose.orientation);
    double lowest = std::numeric_limits<double>::infinity();
    for (const geometry::Vec<D>& x : pose.shape->nodes().positions) lowest = std::min(lowest, bottom.normal.dot(r * x));
    return bottom.signedDistance(pose.position) + lowest;
  }
  return 0.0;
}

template <int D>
double specimenStress(const SpecimenDef& specimen, const dynamics::World<D>& w) {
  const std::ptrdiff_t b = planeIndex(w, specimen.bottom);
  if (b < 0) return 0.0;
  const geometry::Vec<D> n = w.planes()[std::size_t(b)].normal;
  const auto& loads = w.boundaryLoads();
  geometry::Vec<D> f = geometry::Vec<D>::Zero();
  const std::ptrdiff_t t = planeIndex(w, specimen.top);
  if (t >= 0) {
    if (std::size_t(t) < loads.planeForce.size()) f = loads.planeForce[std::size_t(t)];
  } else {
    for (std::size_t k = 0; k < w.tools().size(); ++k) {
      if (w.tools()[k].name == specimen.top && k < loads.toolForce.size()) f = loads.toolForce[k];
    }
  }
  return f.dot(n) / specimen.width;
}

template <int D>
double solidVolume(const dynamics::World<D>& w) {
  const auto& p = w.particles();
  double v = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) v += p.shape[i]->volume();
  return v;
}

template double specimenHeight<2>(const SpecimenDef&, const dynamics::World<2>&);
template double specimenHeight<3>(const SpecimenDef&, const dynamics::World<3>&);
template double specimenStress<2>(const SpecimenDef&, const dynamics::World<2>&);
template double specimenStress<3>(const SpecimenDef&, const dynamics::World<3>&);
template double solidVolume<2>(const dynamics::World<2>&);
template double solidVolume<3>(const dynamics::World<3>&);

}  // namespace lsdem::io
