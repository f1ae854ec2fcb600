#include "lsdem/breakage/Criteria.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace lsdem::breakage {

namespace {

/// Throws unless a limit is finite and > 0.
double checkedLimit(double value, const char* parameter) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string(parameter) + " must be finite and > 0, got " + std::to_string(value));
  }
  return value;
}

}  // namespace

bool Criterion::fails(const Vec<3>& principal, double strength) const {
  checkedLimit(strength, "Criterion::fails: strength");
  return characteristicStress(principal) >= strength;
}

MaxPrincipalStress::MaxPrincipalStress(double compressive, double tensile)
    : compressive_(checkedLimit(compressive, "MaxPrincipalStress: compressive strength")),
      tensile_(checkedLimit(tensile, "MaxPrincipalStress: tensile strength")) {}

double MaxPrincipalStress::measure(const Vec<3>& principal) const {
  // eq. 7-8 with tension positive: largest compression -min, largest tension max.
  const double compression = -principal.minCoeff();
  const double tension = principal.maxCoeff();
  return std::max(compression / compressive_, tension / tensile_);
}

VonMises::VonMises(double limit) : limit_(checkedLimit(limit, "VonMises: strength")) {}

double VonMises::measure(const Vec<3>& s) const {
  // eq. 9.
  const double a = s[0] - s[1], b = s[1] - s[2], c = s[2] - s[0];
  return std::sqrt(0.5 * (a * a + b * b + c * c)) / limit_;
}

Tresca::Tresca(double compressive) : compressive_(checkedLimit(compressive, "Tresca: compressive strength")) {}

double Tresca::measure(const Vec<3>& s) const {
  // eq. 10: tau / (sigma_C / 2) = (max - min) / sigma_C.
  return (s.maxCoeff() - s.minCoeff()) / compressive_;
}

CriterionKind criterionKind(std::string_view name) {
  if (name == "max_principal") return CriterionKind::MaxPrincipal;
  if (name == "von_mises") return CriterionKind::VonMises;
  if (name == "tresca") return CriterionKind::Tresca;
  throw std::invalid_argument("criterion: unknown name '" + std::string(name) +
                              "' (expected max_principal, von_mises or tresca)");
}

std::string_view criterionName(CriterionKind kind) {
  switch (kind) {
    case CriterionKind::MaxPrincipal: return "max_principal";
    case CriterionKind::VonMises: return "von_mises";
    case CriterionKind::Tresca: return "tresca";
  }
  throw std::invalid_argument("criterion: unknown kind " + std::to_string(static_cast<int>(kind)));
}

std::unique_ptr<Criterion> makeCriterion(const CriterionDef& def) {
  switch (def.kind) {
    case CriterionKind::MaxPrincipal:
      return std::make_unique<MaxPrincipalStress>(def.compressiveStrength, def.tensileStrength);
    case CriterionKind::VonMises: return std::make_unique<VonMises>(def.vonMisesStrength);
    case CriterionKind::Tresca: return std::make_unique<Tresca>(def.compressiveStrength);
  }
  throw std::invalid_argument("makeCriterion: unknown kind " + std::to_string(static_cast<int>(def.kind)));
}

std::unique_ptr<Criterion> makeCriterion(std::string_view name, const CriterionDef& def) {
  CriterionDef named = def;
  named.kind = criterionKind(name);
  return makeCriterion(named);
}

}  // namespace lsdem::breakage
