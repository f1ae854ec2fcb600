#include "lsdem/breakage/Weibull.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace lsdem::breakage {

namespace {

constexpr std::uint64_t kGolden = 0x9E3779B97F4A7C15ull;

/// Throws unless value is finite and > 0.
void checkPositive(double value, const char* function, const char* parameter) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string(function) + ": " + parameter + " must be finite and > 0, got " +
                                std::to_string(value));
  }
}

/// splitmix64 finaliser: a bijective 64-bit mix.
std::uint64_t splitmix64(std::uint64_t x) {
  x += kGolden;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

}  // namespace

void validateWeibull(const WeibullDef& def) {
  checkPositive(def.referenceStrength, "WeibullDef", "referenceStrength");
  checkPositive(def.referenceDiameter, "WeibullDef", "referenceDiameter");
  checkPositive(def.modulus, "WeibullDef", "modulus");
  if (!(def.modulus >= kMinWeibullModulus && def.modulus <= kMaxWeibullModulus)) {
    throw std::invalid_argument("WeibullDef: modulus must be in [0.5, 100], got " + std::to_string(def.modulus));
  }
}

double failureProbability(const WeibullDef& def, double diameter, double stress) {
  validateWeibull(def);
  checkPositive(diameter, "failureProbability", "diameter");
  if (!(stress > 0.0)) return 0.0;
  // eq. 11.
  const double size = std::pow(diameter / def.referenceDiameter, 3);
  return -std::expm1(-size * std::pow(stress / def.referenceStrength, def.modulus));
}

double weibullStrength(double sigma0, double d0, double m, double d, double uniform) {
  // Check the input.
  checkPositive(sigma0, "weibullStrength", "sigma0");
  checkPositive(d0, "weibullStrength", "d0");
  checkPositive(m, "weibullStrength", "m");
  checkPositive(d, "weibullStrength", "d");
  if (!(uniform > 0.0 && uniform < 1.0)) {
    throw std::invalid_argument("weibullStrength: uniform must lie in (0, 1), got " + std::to_string(uniform));
  }
  // eq. 12: sigma0 (-(d0/d)^3 ln(1 - Pf))^(1/m).
  return sigma0 * std::pow(-std::pow(d0 / d, 3) * std::log1p(-uniform), 1.0 / m);
}

double weibullStrength(const WeibullDef& def, double diameter, double uniform) {
  return weibullStrength(def.referenceStrength, def.referenceDiameter, def.modulus, diameter, uniform);
}

double medianStrength(const WeibullDef& def, double diameter) { return weibullStrength(def, diameter, 0.5); }

double keyedUniform(std::uint64_t seed, std::uint64_t key) {
  // Counter-based: hash (seed, key) to 64 bits, keep the top 53 as a mantissa.
  const std::uint64_t h = splitmix64(splitmix64(seed) ^ (key * kGolden));
  return (static_cast<double>(h >> 11) + 0.5) * 0x1.0p-53;
}

double sampleStrength(const WeibullDef& def, std::uint64_t seed, std::uint64_t particleId, double diameter) {
  validateWeibull(def);
  return weibullStrength(def, diameter, keyedUniform(seed, particleId));
}

double childStrength(double parentStrength, double childDiameter, double parentDiameter, double m) {
  checkPositive(parentStrength, "childStrength", "parentStrength");
  checkPositive(childDiameter, "childStrength", "childDiameter");
  checkPositive(parentDiameter, "childStrength", "parentDiameter");
  checkPositive(m, "childStrength", "m");
  // eq. 13: sigma_a = sigma_b (d_a / d_b)^(-3/m).
  return parentStrength * std::pow(childDiameter / parentDiameter, -3.0 / m);
}

}  // namespace lsdem::breakage
