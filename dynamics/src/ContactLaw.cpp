#include "lsdem/dynamics/ContactLaw.h"

#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

namespace lsdem::dynamics {
namespace {

// Throws "contact law: <name> must be <rule>, got <value>".
[[noreturn]] void reject(const char* name, const char* rule, double value) {
  std::ostringstream msg;
  msg << "contact law: " << name << " must be " << rule << ", got " << value;
  throw std::invalid_argument(msg.str());
}

}  // namespace

void validateContactLaw(const ContactLawDef& law) {
  // Stiffnesses and coefficients every law reads (negated comparisons reject NaN).
  if (!(law.kn > 0.0) || !std::isfinite(law.kn)) reject("kn", "> 0 (N/m)", law.kn);
  if (!(law.ks >= 0.0) || !std::isfinite(law.ks)) reject("ks", ">= 0 (N/m)", law.ks);
  if (!(law.friction >= 0.0) || !std::isfinite(law.friction)) reject("friction", ">= 0", law.friction);
  if (!(law.frictionFrom >= 0.0) || !std::isfinite(law.frictionFrom)) {
    reject("friction_from", ">= 0", law.frictionFrom);
  }
  if (!(law.dampingRatio >= 0.0 && law.dampingRatio < 1.0)) reject("dampingRatio", "in [0, 1)", law.dampingRatio);
  if (law.tangential == TangentialModel::Mindlin && law.normal != NormalModel::Hertz) {
    throw std::invalid_argument("contact law: the Mindlin tangential model needs the Hertz normal model");
  }
  // Material constants of the Hertz law.
  if (law.normal == NormalModel::Hertz) {
    if (!(law.youngsModulus > 0.0) || !std::isfinite(law.youngsModulus)) {
      reject("youngsModulus", "> 0 (Pa) for the Hertz law", law.youngsModulus);
    }
    if (!(law.poissonRatio >= 0.0 && law.poissonRatio < 0.5)) {
      reject("poissonRatio", "in [0, 0.5) for the Hertz law", law.poissonRatio);
    }
  }
}

void validateBoundaryMaterial(const ContactLawDef& law, const BoundaryMaterial& m) {
  // Stiffness: the wall's own, unless rigid.
  if (!m.rigid) {
    if (law.normal == NormalModel::Hertz) {
      if (!(m.youngsModulus > 0.0) || !std::isfinite(m.youngsModulus)) {
        reject("wall youngs_modulus", "> 0 (Pa) for the Hertz law unless the wall is rigid", m.youngsModulus);
      }
      if (!(m.poissonRatio >= 0.0 && m.poissonRatio < 0.5)) {
        reject("wall poisson_ratio", "in [0, 0.5) for the Hertz law", m.poissonRatio);
      }
    } else if (!(m.kn > 0.0) || !std::isfinite(m.kn)) {
      reject("wall kn", "> 0 (N/m) for the linear law unless the wall is rigid", m.kn);
    }
  }
  if (m.ks && (!(*m.ks >= 0.0) || !std::isfinite(*m.ks))) reject("wall ks", ">= 0 (N/m)", *m.ks);
  if (m.ks && law.tangential == TangentialModel::Mindlin) {
    throw std::invalid_argument("contact law: a wall's ks has no meaning with the Mindlin tangential model");
  }
  // Friction: only where the law has a tangential part.
  if (m.friction) {
    if (!law.hasFriction) {
      throw std::invalid_argument("contact law: a wall's friction needs friction in the law (give the grains' mu, "
                                  "0 for frictionless grains)");
    }
    if (!(*m.friction >= 0.0) || !std::isfinite(*m.friction)) reject("wall friction", ">= 0", *m.friction);
  }
}

double effectiveModulus(const ContactLawDef& law) {
  const double nu = law.poissonRatio;
  return law.youngsModulus / (2.0 * (1.0 - nu * nu));
}

double effectiveShearModulus(const ContactLawDef& law) {
  const double nu = law.poissonRatio;
  const double g = law.youngsModulus / (2.0 * (1.0 + nu));
  return g / (2.0 * (2.0 - nu));
}

ContactConstants lawConstants(const ContactLawDef& law) {
  ContactConstants c;
  c.kn = law.kn;
  c.friction = law.friction;
  if (law.normal == NormalModel::Hertz) c.eStar = effectiveModulus(law);
  if (law.tangential == TangentialModel::Mindlin) {
    c.gStar = effectiveShearModulus(law);
  } else {
    c.ks = law.ks;
  }
  return c;
}

ContactConstants boundaryConstants(const ContactLawDef& law, const BoundaryMaterial& m) {
  validateBoundaryMaterial(law, m);
  ContactConstants c = lawConstants(law);
  if (m.friction) c.friction = *m.friction;
  if (law.normal == NormalModel::Hertz) {
    // 1/E* and 1/G* sum the compliances of the grain and the wall (none for a rigid wall).
    const double nu = law.poissonRatio, e = law.youngsModulus, g = e / (2.0 * (1.0 + nu));
    double compliance = (1.0 - nu * nu) / e, shearCompliance = (2.0 - nu) / g;
    if (!m.rigid) {
      const double nw = m.poissonRatio, ew = m.youngsModulus, gw = ew / (2.0 * (1.0 + nw));
      compliance += (1.0 - nw * nw) / ew;
      shearCompliance += (2.0 - nw) / gw;
    }
    c.eStar = 1.0 / compliance;
    if (law.tangential == TangentialModel::Mindlin) c.gStar = 1.0 / shearCompliance;
  } else {
    // Linear: the wall's own springs, or the grain's half of a grain-grain pair (rigid).
    c.kn = m.rigid ? 2.0 * law.kn : m.kn;
    c.ks = m.rigid ? 2.0 * law.ks : m.ks.value_or(m.kn * law.ks / law.kn);
  }
  // A Hertz law with a linear tangential spring keeps the law's ks unless the wall gives its own.
  if (law.normal == NormalModel::Hertz && law.tangential == TangentialModel::Linear && m.ks) c.ks = *m.ks;
  return c;
}

double mindlinStiffness(double effectiveShearModulus, double radius, double overlap) {
  if (!(overlap > 0.0)) return 0.0;
  return 8.0 * effectiveShearModulus * std::sqrt(radius * overlap);
}

template <int D>
double equivalentRadius(double volume) {
  if constexpr (D == 2) {
    return std::sqrt(volume / std::numbers::pi);
  } else {
    return std::cbrt(3.0 * volume / (4.0 * std::numbers::pi));
  }
}

double combinedRadius(double radiusA, double radiusB) {
  return 1.0 / (1.0 / radiusA + 1.0 / radiusB);
}

double hertzForce(double effectiveModulus, double radius, double overlap) {
  if (!(overlap > 0.0)) return 0.0;
  return 4.0 / 3.0 * effectiveModulus * std::sqrt(radius) * overlap * std::sqrt(overlap);
}

double hertzStiffness(double effectiveModulus, double radius, double overlap) {
  if (!(overlap > 0.0)) return 0.0;
  return 2.0 * effectiveModulus * std::sqrt(radius * overlap);
}

double dampingCoefficient(double zeta, double effectiveMass, double stiffness) {
  return 2.0 * zeta * std::sqrt(effectiveMass * stiffness);
}

double restitutionCoefficient(double zeta) {
  return std::exp(-zeta / std::sqrt(1.0 - zeta * zeta) * (std::numbers::pi - 2.0 * std::asin(zeta)));
}

double contactDuration(double zeta, double omega) {
  return (std::numbers::pi - 2.0 * std::asin(zeta)) / (omega * std::sqrt(1.0 - zeta * zeta)) + 2.0 * zeta / omega;
}

double dampingRatioForRestitution(double restitution) {
  if (!(restitution > kMinimumRestitution && restitution <= 1.0)) {
    throw std::invalid_argument("restitution must be in (exp(-2), 1] = (0.1353, 1] (a dashpot that cannot pull "
                                "stops at exp(-2) at critical damping), got " + std::to_string(restitution));
  }
  // e(zeta) falls monotonically from 1 at zeta = 0 to 0 as zeta -> 1: bisection
  // to the last bit (about 60 halvings).
  double lo = 0.0, hi = 1.0;
  while (true) {
    const double mid = 0.5 * (lo + hi);
    if (!(mid > lo && mid < hi)) break;
    (restitutionCoefficient(mid) > restitution ? lo : hi) = mid;
  }
  return restitution == 1.0 ? 0.0 : lo;
}

template <int D>
double referenceNodeWeight(double spacing) {
  if constexpr (D == 2) {
    return spacing;
  } else {
    return kNodeAreaPerCellArea3D * spacing * spacing;
  }
}

template double equivalentRadius<2>(double);
template double equivalentRadius<3>(double);
template double referenceNodeWeight<2>(double);
template double referenceNodeWeight<3>(double);

}  // namespace lsdem::dynamics
