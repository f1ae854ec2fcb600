#include "lsdem/breakage/Chipping.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace lsdem::breakage {

using geometry::Vec;

namespace {

// Purpose key of the chipping strengths: a different stream from the
// grains' strengths (sampleStrength) under the same seed.
constexpr std::uint64_t kChipPurpose = 0x636869702D737472ull;  // "chip-str"

void checkRange(bool ok, const char* field, double value, const char* range) {
  if (!ok || !std::isfinite(value)) {
    throw std::invalid_argument(std::string("ChippingDef ") + field + " must be " + range + ", got " +
                                std::to_string(value));
  }
}

}  // namespace

void validateChipping(const ChippingDef& def) {
  validateWeibull(def.weibull);
  checkRange(def.depthFraction > 0.0 && def.depthFraction < 1.0, "depthFraction", def.depthFraction, "in (0, 1)");
  checkRange(def.hertzFactor > 0.0, "hertzFactor", def.hertzFactor, "> 0");
  checkRange(def.maxDepthFraction > 0.0 && def.maxDepthFraction < 1.0, "maxDepthFraction", def.maxDepthFraction,
             "in (0, 1)");
  checkRange(def.minDepthCells >= 0.5, "minDepthCells", def.minDepthCells, ">= 0.5");
  checkRange(def.maxWidthToDepth > 0.0, "maxWidthToDepth", def.maxWidthToDepth, "> 0");
  if (def.depth == ChipDepthMode::Hertz) {
    checkRange(def.youngsModulus > 0.0, "youngsModulus", def.youngsModulus, "> 0 (Hertz depth)");
    checkRange(def.poissonRatio >= 0.0 && def.poissonRatio < 0.5, "poissonRatio", def.poissonRatio, "in [0, 0.5)");
  }
}

template <int D>
double chipDepth(const ChippingDef& def, double force, double localRadius) {
  if (!(force > 0.0) || !(localRadius > 0.0)) return 0.0;
  double depth = 0.0;
  if (def.depth == ChipDepthMode::Fraction) {
    depth = def.depthFraction * localRadius;
  } else {
    // Hertz contact radius of a body of radius r on a flat of the same material.
    const double eStar = def.youngsModulus / (1.0 - def.poissonRatio * def.poissonRatio);
    const double a = D == 3 ? std::cbrt(3.0 * force * localRadius / (4.0 * eStar))
                            : std::sqrt(4.0 * force * localRadius / (std::numbers::pi * eStar));
    depth = def.hertzFactor * a;
  }
  return std::min(depth, def.maxDepthFraction * localRadius);
}

template <int D>
double capWidth(const geometry::Shape<D>& shape, const geometry::Mat<D>& rotation, const Vec<D>& position,
                const Vec<D>& normal, double offset) {
  // The plane in the body frame; the nodes beyond it, projected across the normal.
  const Vec<D> n = rotation.transpose() * normal;
  const double o = offset - normal.dot(position);
  const auto& nodes = shape.nodes().positions;
  const auto across = [&n](const Vec<D>& x) -> Vec<D> { return x - n.dot(x) * n; };
  Vec<D> sum = Vec<D>::Zero();
  std::size_t count = 0;
  for (const Vec<D>& x : nodes) {
    if (n.dot(x) <= o) continue;
    sum += across(x);
    ++count;
  }
  if (count == 0) return 0.0;
  const Vec<D> mean = sum / double(count);
  // 2D: the extent along the line; 3D: twice the farthest node from the mean.
  double lo = 0.0, hi = 0.0;
  for (const Vec<D>& x : nodes) {
    if (n.dot(x) <= o) continue;
    const Vec<D> y = across(x) - mean;
    if constexpr (D == 2) {
      const double t = n[0] * y[1] - n[1] * y[0];
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    } else {
      hi = std::max(hi, y.norm());
    }
  }
  return D == 2 ? hi - lo : 2.0 * hi;
}

double chipUniform(std::uint64_t seed, std::uint64_t particleId, std::uint64_t partnerKey) {
  // One stream per (seed, partner), keyed by the grain's id within it.
  return keyedUniform(seed ^ kChipPurpose ^ (partnerKey * 0xD1B54A32D192ED03ull), particleId);
}

double chipStrength(const ChippingDef& def, double depth, double uniform) {
  return weibullStrength(def.weibull, depth, uniform);
}

template <int D>
void contactLoads(const dynamics::Particles<D>& particles, const dynamics::ContactSolver<D>& contacts,
                  GrainContactLoads<D>& out) {
  const std::size_t n = particles.size();
  const std::span<const dynamics::NodeContact<D>> nodes = contacts.nodeContacts();
  const std::size_t particlePairs = contacts.particleContacts().size();
  const std::size_t planePairs = contacts.planeContacts().size();
  const std::span<const dynamics::PairContact<D>> all = contacts.pairContacts();
  const auto check = [n](std::uint32_t i) {
    if (i >= n) throw std::invalid_argument("contactLoads: a contact record names particle " + std::to_string(i) +
                                            " of " + std::to_string(n));
  };

  // Row sizes: one entry per touching pair and particle side.
  out.offset.assign(n + 1, 0);
  for (std::size_t r = 0; r < all.size(); ++r) {
    if (all[r].nodeCount == 0) continue;
    check(all[r].a);
    ++out.offset[all[r].a + 1];
    if (r < particlePairs) {
      check(all[r].b);
      ++out.offset[all[r].b + 1];
    }
  }
  for (std::size_t i = 0; i < n; ++i) out.offset[i + 1] += out.offset[i];
  out.loads.assign(out.offset[n], ContactLoad<D>{});

  // One load per side of each touching pair, in record order. (offset[i]
  // serves as row i's write cursor and ends at row i + 1's start; shifting
  // the array by one afterwards restores the row starts.)
  std::vector<std::uint32_t>& cursor = out.offset;
  for (std::size_t r = 0; r < all.size(); ++r) {
    const dynamics::PairContact<D>& pair = all[r];
    if (pair.nodeCount == 0) continue;
    const bool particlePair = r < particlePairs;
    const std::span<const dynamics::NodeContact<D>> pairNodes = nodes.subspan(pair.firstNode, pair.nodeCount);
    // The normal force (the same on both sides) and the node patch: the nodes
    // of a inside b and of b inside a, each with its owner's weight.
    double force = 0.0;
    double patch[2] = {0.0, 0.0};
    Vec<D> towardsA = Vec<D>::Zero();  // force-weighted node normals, from b towards a
    for (const dynamics::NodeContact<D>& c : pairNodes) {
      const double fn = std::max(c.force.dot(c.normal), 0.0);
      force += fn;
      towardsA += fn * c.normal;
      const std::uint32_t owner = c.ownerIsB && particlePair ? pair.b : pair.a;
      patch[c.ownerIsB ? 1 : 0] += particles.shape[owner]->nodes().weights[c.node];
    }
    if (!(force > 0.0) || !(towardsA.norm() > 0.0)) {
      // No compressive force: an empty load keeps the rows aligned; it never chips.
      ++cursor[pair.a];
      if (particlePair) ++cursor[pair.b];
      continue;
    }
    const int directions = int(patch[0] > 0.0) + int(patch[1] > 0.0);
    const double area = (patch[0] + patch[1]) / double(directions);
    towardsA.normalize();
    // Each side: its outward normal, local radius and partner.
    const auto side = [&](std::uint32_t i, const Vec<D>& outward, std::uint64_t partner) {
      double radius = 0.0;
      for (const dynamics::NodeContact<D>& c : pairNodes) {
        radius = std::max(radius, outward.dot(c.point - particles.position[i]));
      }
      out.loads[cursor[i]++] = ContactLoad<D>{outward, force, area, radius, partner};
    };
    if (particlePair) {
      side(pair.a, -towardsA, contactPartnerKey(PartnerKind::Particle, particles.id[pair.b]));
      side(pair.b, towardsA, contactPartnerKey(PartnerKind::Particle, particles.id[pair.a]));
    } else if (r < particlePairs + planePairs) {
      side(pair.a, -towardsA, contactPartnerKey(PartnerKind::Plane, pair.b));
    } else {
      side(pair.a, -towardsA, contactPartnerKey(PartnerKind::Tool, pair.b));
    }
  }
  for (std::size_t i = n; i > 0; --i) out.offset[i] = out.offset[i - 1];
  out.offset[0] = 0;
}

template double capWidth<2>(const geometry::Shape<2>&, const geometry::Mat<2>&, const Vec<2>&, const Vec<2>&, double);
template double capWidth<3>(const geometry::Shape<3>&, const geometry::Mat<3>&, const Vec<3>&, const Vec<3>&, double);
template double chipDepth<2>(const ChippingDef&, double, double);
template double chipDepth<3>(const ChippingDef&, double, double);
template void contactLoads<2>(const dynamics::Particles<2>&, const dynamics::ContactSolver<2>&,
                              GrainContactLoads<2>&);
template void contactLoads<3>(const dynamics::Particles<3>&, const dynamics::ContactSolver<3>&,
                              GrainContactLoads<3>&);

}  // namespace lsdem::breakage
