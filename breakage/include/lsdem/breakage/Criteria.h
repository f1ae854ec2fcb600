#pragma once
/// @file Criteria.h
/// @brief Pluggable breakage criteria on a grain's principal stresses (eq. 7-10):
/// maximum principal stress (compressive and tensile limits), von Mises and
/// Tresca, chosen by name.
///
/// Sign convention: tension positive (as in GrainStress.h), so the largest
/// compression of a stress state is -min(s_i) and the largest tension max(s_i).
/// Principal stresses come as a triple: 3D (s1, s2, s3); 2D plane stress
/// (s1, s2, 0). Every criterion here is symmetric in the three values, so their
/// order does not matter.
///
/// Strength scaling. Each criterion has a reference limit (its
/// referenceStrength(), Pa) and reports the characteristic stress sigma^c of a
/// state (eq. 11: the stress that a Weibull-sampled strength is compared with),
/// in the same units as that limit. A particle's own critical stress (a Weibull
/// strength, Weibull.h) replaces the reference value: the particle fails when
/// sigma^c >= its strength. For the maximum principal stress criterion, whose
/// reference limit is the compressive one, both limits scale by the same factor
/// strength / sigma_C^max, so the tensile limit of that particle is
/// sigma_T^max x strength / sigma_C^max.
///
/// Failure is "the limit is no longer greater than the stress" (eq. 7-10 state
/// the safe side with a strict >): a state exactly on the limit fails.

#include "lsdem/geometry/Types.h"

#include <memory>
#include <string_view>

namespace lsdem::breakage {

using geometry::Vec;

/// The criteria lsdem provides.
enum class CriterionKind {
  MaxPrincipal,  ///< eq. 7-8, name "max_principal"
  VonMises,      ///< eq. 9, name "von_mises"
  Tresca,        ///< eq. 10, name "tresca"
};

/// Limits of a criterion (defaults: the paper's oedometer values, Table 2).
struct CriterionDef {
  CriterionKind kind = CriterionKind::VonMises;
  double compressiveStrength = 40e6;  ///< sigma_C^max, Pa, > 0: max principal (eq. 7) and Tresca (eq. 10)
  double tensileStrength = 0.4e6;     ///< sigma_T^max, Pa, > 0: max principal (eq. 8)
  double vonMisesStrength = 35e6;     ///< sigma_Vmax, Pa, > 0: von Mises (eq. 9)
};

/// @brief A breakage criterion: maps principal stresses to a characteristic
/// stress and decides failure against a critical stress.
class Criterion {
 public:
  virtual ~Criterion() = default;

  /// @brief The criterion's name ("max_principal", "von_mises", "tresca").
  virtual std::string_view name() const = 0;
  /// @brief The reference critical stress the characteristic stress is compared
  /// with when a particle has no strength of its own, Pa.
  virtual double referenceStrength() const = 0;
  /// @brief Utilisation of the reference limits, dimensionless: the state lies
  /// on the reference failure surface at 1 and fails at >= 1.
  /// @param principal principal stresses, Pa, tension positive (3D: (s1, s2, s3);
  ///   2D plane stress: (s1, s2, 0)); any order.
  virtual double measure(const Vec<3>& principal) const = 0;

  /// @brief Characteristic stress sigma^c of the state (eq. 11), Pa:
  /// measure(principal) x referenceStrength().
  double characteristicStress(const Vec<3>& principal) const { return measure(principal) * referenceStrength(); }
  /// @brief True when a particle of critical stress `strength` (Pa, > 0; it
  /// replaces referenceStrength()) fails under `principal`: sigma^c >= strength.
  /// @note Throws std::invalid_argument when strength is not finite and > 0.
  bool fails(const Vec<3>& principal, double strength) const;
  /// @brief True when the state fails against the reference limits: measure >= 1.
  bool fails(const Vec<3>& principal) const { return measure(principal) >= 1.0; }
};

/// @brief eq. 7-8: maximum principal stress with separate compressive and
/// tensile limits. With tension positive the state fails when
/// -min(s) >= sigma_C^max or max(s) >= sigma_T^max; measure =
/// max(-min(s) / sigma_C^max, max(s) / sigma_T^max). Reference strength:
/// sigma_C^max (see the file comment for the scaling of both limits).
class MaxPrincipalStress final : public Criterion {
 public:
  /// @param compressive sigma_C^max, Pa, > 0. @param tensile sigma_T^max, Pa, > 0.
  /// @note Throws std::invalid_argument for a limit that is not finite and > 0.
  MaxPrincipalStress(double compressive, double tensile);
  std::string_view name() const override { return "max_principal"; }
  double referenceStrength() const override { return compressive_; }
  double measure(const Vec<3>& principal) const override;

 private:
  double compressive_, tensile_;
};

/// @brief eq. 9: von Mises, sigma_V = sqrt(((s1-s2)^2 + (s2-s3)^2 + (s3-s1)^2) / 2)
/// against sigma_Vmax; measure = sigma_V / sigma_Vmax.
class VonMises final : public Criterion {
 public:
  /// @param limit sigma_Vmax, Pa, > 0.
  /// @note Throws std::invalid_argument for a limit that is not finite and > 0.
  explicit VonMises(double limit);
  std::string_view name() const override { return "von_mises"; }
  double referenceStrength() const override { return limit_; }
  double measure(const Vec<3>& principal) const override;

 private:
  double limit_;
};

/// @brief eq. 10: Tresca, tau = max|s_i - s_j| / 2 against sigma_C^max / 2;
/// measure = max|s_i - s_j| / sigma_C^max. Reference strength: sigma_C^max
/// (so the characteristic stress is 2 tau).
class Tresca final : public Criterion {
 public:
  /// @param compressive sigma_C^max, Pa, > 0.
  /// @note Throws std::invalid_argument for a limit that is not finite and > 0.
  explicit Tresca(double compressive);
  std::string_view name() const override { return "tresca"; }
  double referenceStrength() const override { return compressive_; }
  double measure(const Vec<3>& principal) const override;

 private:
  double compressive_;
};

/// @brief The kind named "max_principal", "von_mises" or "tresca".
/// @note Throws std::invalid_argument for any other name.
CriterionKind criterionKind(std::string_view name);
/// @brief The name of a kind (the inverse of criterionKind(name)).
std::string_view criterionName(CriterionKind kind);

/// @brief Makes the criterion `def.kind` with the limits it uses from `def`.
/// @note Throws std::invalid_argument for a used limit that is not finite and > 0.
std::unique_ptr<Criterion> makeCriterion(const CriterionDef& def);
/// @brief Makes the criterion called `name` with the limits it uses from `def`
/// (def.kind is ignored).
/// @note Throws std::invalid_argument for an unknown name or a bad limit.
std::unique_ptr<Criterion> makeCriterion(std::string_view name, const CriterionDef& def);

}  // namespace lsdem::breakage
