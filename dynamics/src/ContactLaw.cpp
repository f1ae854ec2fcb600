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

double effectiveModulus(const ContactLawDef& law) {
  const double nu = law.poissonRatio;
  return law.youngsModulus / (2.0 * (1.0 - nu * nu));
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
