/// @file test_criteria.cpp
/// @brief Breakage criteria (eq. 7-10) on principal stresses from eq. 5-6:
/// each criterion fires exactly at its analytic threshold (just below: no,
/// just above: yes) for uniaxial compression, uniaxial tension, pure shear and
/// biaxial states in 2D (plane stress) and 3D; Weibull strengths replace the
/// reference limit; the factory by name; bad limits are refused.

#include "lsdem/breakage/Criteria.h"
#include "lsdem/breakage/GrainStress.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

using namespace lsdem::breakage;

namespace {

constexpr double kC = 40e6, kT = 0.4e6, kV = 35e6;  // the paper's Table 2
constexpr double kBelow = 1.0 - 1e-9, kAbove = 1.0 + 1e-9;

CriterionDef paperLimits(CriterionKind kind) { return CriterionDef{kind, kC, kT, kV}; }

// A stress tensor built from the principal values (a, b[, c]) in a rotated frame,
// and its principal triple as the criteria see it (through eq. 6).
template <int D>
Vec<3> triple(const Vec<D>& principal) {
  Mat<D> rotation;
  if constexpr (D == 2) {
    rotation = Eigen::Rotation2Dd(0.37).toRotationMatrix();
  } else {
    rotation = Eigen::AngleAxisd(0.6, Vec<3>(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
  }
  const Mat<D> sigma = rotation * principal.asDiagonal() * rotation.transpose();
  return principalStressTriple<D>(sigma);
}

// The stress state `unit` scaled by `scale` x (1 -+ 1e-9) is safe below and fails above.
template <int D>
void expectThreshold(const Criterion& criterion, const Vec<D>& unit, double scale, const std::string& what) {
  EXPECT_FALSE(criterion.fails(triple<D>(Vec<D>(unit * scale * kBelow)))) << criterion.name() << ": " << what;
  EXPECT_TRUE(criterion.fails(triple<D>(Vec<D>(unit * scale * kAbove)))) << criterion.name() << ": " << what;
  EXPECT_NEAR(criterion.measure(triple<D>(Vec<D>(unit * scale))), 1.0, 1e-12) << criterion.name() << ": " << what;
}

}  // namespace

// eq. 7-8: compression at sigma_C, tension at sigma_T, whichever is reached first.
TEST(Criteria, MaxPrincipalThresholds) {
  const auto c = makeCriterion(paperLimits(CriterionKind::MaxPrincipal));
  EXPECT_EQ(c->name(), "max_principal");
  // Uniaxial compression and tension, 2D and 3D.
  expectThreshold<2>(*c, Vec<2>(0.0, -1.0), kC, "2D uniaxial compression");
  expectThreshold<3>(*c, Vec<3>(0.0, 0.0, -1.0), kC, "3D uniaxial compression");
  expectThreshold<2>(*c, Vec<2>(1.0, 0.0), kT, "2D uniaxial tension");
  expectThreshold<3>(*c, Vec<3>(1.0, 0.0, 0.0), kT, "3D uniaxial tension");
  // Pure shear (s, -s): the tensile limit is reached first.
  expectThreshold<2>(*c, Vec<2>(1.0, -1.0), kT, "2D pure shear");
  expectThreshold<3>(*c, Vec<3>(1.0, 0.0, -1.0), kT, "3D pure shear");
  // Biaxial and triaxial compression: the largest compression decides.
  expectThreshold<2>(*c, Vec<2>(-0.5, -1.0), kC, "2D biaxial compression");
  expectThreshold<3>(*c, Vec<3>(-0.2, -0.7, -1.0), kC, "3D triaxial compression");
  // Compression with a little tension: tension 0.005 kC = 0.2 MPa < kT is safe.
  EXPECT_FALSE(c->fails(triple<2>(Vec<2>(0.005 * kC, -kC * kBelow))));
  EXPECT_NEAR(c->measure(Vec<3>(0.3e6, -20e6, 0.0)), 0.75, 1e-15);
}

// eq. 9: sigma_V = s for uniaxial stress, sqrt(3) s for pure shear, s for equal biaxial.
TEST(Criteria, VonMisesThresholds) {
  const auto c = makeCriterion(paperLimits(CriterionKind::VonMises));
  EXPECT_EQ(c->name(), "von_mises");
  expectThreshold<2>(*c, Vec<2>(0.0, -1.0), kV, "2D uniaxial compression");
  expectThreshold<3>(*c, Vec<3>(0.0, 0.0, -1.0), kV, "3D uniaxial compression");
  expectThreshold<2>(*c, Vec<2>(1.0, 0.0), kV, "2D uniaxial tension");
  expectThreshold<3>(*c, Vec<3>(1.0, 0.0, 0.0), kV, "3D uniaxial tension");
  expectThreshold<2>(*c, Vec<2>(1.0, -1.0), kV / std::sqrt(3.0), "2D pure shear");
  expectThreshold<3>(*c, Vec<3>(1.0, 0.0, -1.0), kV / std::sqrt(3.0), "3D pure shear");
  // Plane stress equal biaxial (s, s, 0): sigma_V = s.
  expectThreshold<2>(*c, Vec<2>(-1.0, -1.0), kV, "2D equal biaxial compression");
  // 3D biaxial (-1, -0.5, 0): sigma_V = sqrt(0.75) s.
  expectThreshold<3>(*c, Vec<3>(-1.0, -0.5, 0.0), kV / std::sqrt(0.75), "3D biaxial compression");
  // Hydrostatic states never fail.
  EXPECT_NEAR(c->measure(Vec<3>(-1e9, -1e9, -1e9)), 0.0, 1e-15);
}

// eq. 10: tau = (max - min) / 2 against sigma_C / 2.
TEST(Criteria, TrescaThresholds) {
  const auto c = makeCriterion(paperLimits(CriterionKind::Tresca));
  EXPECT_EQ(c->name(), "tresca");
  expectThreshold<2>(*c, Vec<2>(0.0, -1.0), kC, "2D uniaxial compression");
  expectThreshold<3>(*c, Vec<3>(0.0, 0.0, -1.0), kC, "3D uniaxial compression");
  expectThreshold<2>(*c, Vec<2>(1.0, 0.0), kC, "2D uniaxial tension");
  expectThreshold<3>(*c, Vec<3>(1.0, 0.0, 0.0), kC, "3D uniaxial tension");
  expectThreshold<2>(*c, Vec<2>(1.0, -1.0), kC / 2.0, "2D pure shear");
  expectThreshold<3>(*c, Vec<3>(1.0, 0.0, -1.0), kC / 2.0, "3D pure shear");
  // Plane stress: (-s, -0.5 s, 0) has tau = s / 2 through the zero out-of-plane stress.
  expectThreshold<2>(*c, Vec<2>(-0.5, -1.0), kC, "2D biaxial compression");
  // 3D (-0.2, -0.7, -1.0): tau = 0.4 s.
  expectThreshold<3>(*c, Vec<3>(-0.2, -0.7, -1.0), kC / 0.8, "3D triaxial compression");
}

// A particle's own critical stress replaces the reference limit.
TEST(Criteria, ParticleStrengthReplacesReference) {
  const auto vm = makeCriterion("von_mises", CriterionDef{});
  const Vec<3> s(0.0, 0.0, -20e6);
  EXPECT_DOUBLE_EQ(vm->characteristicStress(s), 20e6);
  EXPECT_TRUE(vm->fails(s, 20e6 * kBelow));
  EXPECT_FALSE(vm->fails(s, 20e6 * kAbove));
  // Max principal: both limits scale by strength / sigma_C.
  const auto mp = makeCriterion("max_principal", paperLimits(CriterionKind::VonMises));
  EXPECT_EQ(mp->referenceStrength(), kC);
  const double strength = 2.0 * kC;  // tensile limit becomes 2 kT
  EXPECT_FALSE(mp->fails(Vec<3>(2.0 * kT * kBelow, 0.0, 0.0), strength));
  EXPECT_TRUE(mp->fails(Vec<3>(2.0 * kT * kAbove, 0.0, 0.0), strength));
  EXPECT_FALSE(mp->fails(Vec<3>(0.0, 0.0, -2.0 * kC * kBelow), strength));
  EXPECT_TRUE(mp->fails(Vec<3>(0.0, 0.0, -2.0 * kC * kAbove), strength));
  // Tresca's characteristic stress is 2 tau.
  const auto tr = makeCriterion("tresca", CriterionDef{});
  EXPECT_DOUBLE_EQ(tr->characteristicStress(Vec<3>(3e6, 0.0, -5e6)), 8e6);
  EXPECT_THROW(vm->fails(s, 0.0), std::invalid_argument);
  EXPECT_THROW(vm->fails(s, std::nan("")), std::invalid_argument);
}

TEST(Criteria, FactoryAndValidation) {
  for (const CriterionKind kind : {CriterionKind::MaxPrincipal, CriterionKind::VonMises, CriterionKind::Tresca}) {
    EXPECT_EQ(criterionKind(criterionName(kind)), kind);
    EXPECT_EQ(makeCriterion(paperLimits(kind))->name(), criterionName(kind));
  }
  EXPECT_THROW(criterionKind("mohr_coulomb"), std::invalid_argument);
  EXPECT_THROW(makeCriterion("", CriterionDef{}), std::invalid_argument);
  EXPECT_THROW(MaxPrincipalStress(kC, 0.0), std::invalid_argument);
  EXPECT_THROW(MaxPrincipalStress(-1.0, kT), std::invalid_argument);
  EXPECT_THROW(VonMises{std::numeric_limits<double>::infinity()}, std::invalid_argument);
  EXPECT_THROW(Tresca(0.0), std::invalid_argument);
  // Only the limits a criterion uses are checked.
  EXPECT_NO_THROW(makeCriterion(CriterionDef{CriterionKind::VonMises, 0.0, 0.0, kV}));
  EXPECT_THROW(makeCriterion(CriterionDef{CriterionKind::Tresca, 0.0, kT, kV}), std::invalid_argument);
  try {
    makeCriterion(CriterionDef{CriterionKind::MaxPrincipal, kC, -3.0, kV});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tensile"), std::string::npos) << e.what();
  }
}
