#pragma once
/// @file Weibull.h
/// @brief Size-dependent particle strengths from Weibull statistics (eq. 11-13):
/// the failure probability, inverse-transform sampling of a critical stress,
/// a reproducible sampler keyed by (seed, global id), and the strength of a
/// fragment from its parent's.
///
/// The strength is the critical value of the chosen criterion's characteristic
/// stress (Criteria.h), Pa. The size exponent is 3 (volume scaling, as in the
/// paper) in 2D and 3D alike; the diameter is whatever size measure the caller
/// uses consistently (e.g. the equivalent diameter), m.
///
/// Reproducibility: sampleStrength() draws its uniform number from a
/// counter-based hash of (seed, particle id), with no generator state, so a
/// particle's strength does not depend on which thread asks, in what order, or
/// how many other particles were sampled before it.

#include <cstdint>

namespace lsdem::breakage {

/// Weibull parameters of a material (defaults: the paper's jaw crusher, Table 1).
struct WeibullDef {
  double referenceStrength = 56.5e6;  ///< sigma_0, Pa, > 0
  double referenceDiameter = 0.21;    ///< d_0, m, > 0
  double modulus = 3.0;               ///< Weibull modulus m, in [kMinWeibullModulus, kMaxWeibullModulus]
};

/// @brief Checks sigma_0 > 0 and d_0 > 0, finite, and m in
/// [kMinWeibullModulus, kMaxWeibullModulus].
/// @note Throws std::invalid_argument naming the parameter and its value.
void validateWeibull(const WeibullDef& def);

/// The Weibull moduli validateWeibull (and a scene's breakage and chipping)
/// take: rocks and ceramics measure about 1-50; below 0.5 the drawn
/// strengths under- and overflow (0.001 drew a strength of 0).
constexpr double kMinWeibullModulus = 0.5, kMaxWeibullModulus = 100.0;

/// @brief eq. 11: probability that a particle of diameter d (m) has a critical
/// stress of at most `stress` (Pa): 1 - exp(-(d/d0)^3 (stress/sigma0)^m); 0 for stress <= 0.
/// @note Throws std::invalid_argument for invalid parameters or d <= 0.
double failureProbability(const WeibullDef& def, double diameter, double stress);

/// @brief eq. 12: inverse-transform Weibull strength,
/// sigma0 (-(d0/d)^3 ln(1 - Pf))^(1/m), Pa.
/// @param sigma0 reference strength, Pa, > 0.
/// @param d0 reference diameter, m, > 0.
/// @param m Weibull modulus, > 0.
/// @param d particle diameter, m, > 0.
/// @param uniform the failure probability Pf, a U(0,1) sample in the open interval (0, 1).
/// @note Throws std::invalid_argument for a parameter out of range or not finite.
double weibullStrength(double sigma0, double d0, double m, double d, double uniform);

/// @brief eq. 12 with the parameters of `def`.
double weibullStrength(const WeibullDef& def, double diameter, double uniform);

/// @brief Median strength of particles of diameter d (eq. 12 at Pf = 1/2), Pa:
/// sigma0 ((d0/d)^3 ln 2)^(1/m).
double medianStrength(const WeibullDef& def, double diameter);

/// @brief A U(0,1) number in the open interval (0, 1) determined by (seed, key)
/// alone: splitmix64 of the mixed seed xor key x golden ratio, its top 53 bits
/// mapped to (k + 1/2) / 2^53.
double keyedUniform(std::uint64_t seed, std::uint64_t key);

/// @brief eq. 12 with Pf = keyedUniform(seed, particleId): the strength of a
/// particle of diameter `diameter` (m), Pa, reproducible per (seed, id)
/// regardless of thread or call order.
/// @note Throws std::invalid_argument for invalid parameters or diameter <= 0.
double sampleStrength(const WeibullDef& def, std::uint64_t seed, std::uint64_t particleId, double diameter);

/// @brief eq. 13: strength of a child a from its parent b,
/// sigma_a = sigma_b (d_a / d_b)^(-3/m), Pa.
/// @param parentStrength sigma_b, Pa, > 0.
/// @param childDiameter d_a, m, > 0.
/// @param parentDiameter d_b, m, > 0.
/// @param m Weibull modulus, > 0.
/// @note Throws std::invalid_argument for a parameter out of range or not finite.
double childStrength(double parentStrength, double childDiameter, double parentDiameter, double m);

}  // namespace lsdem::breakage
