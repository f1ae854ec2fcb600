/// @file test_weibull.cpp
/// @brief Weibull strengths (eq. 11-13): the sampler's distribution passes a
/// Kolmogorov-Smirnov test against eq. 11, the median scales like d^(-3/m),
/// samples are reproducible per (seed, id) in any call order, the child
/// scaling of eq. 13 is exact and consistent with eq. 12, and bad parameters
/// are refused.

#include "lsdem/breakage/Weibull.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <vector>

using namespace lsdem::breakage;

namespace {

constexpr std::size_t kSamples = 10000;

// Kolmogorov-Smirnov statistic D_n of `samples` against the distribution function `cdf`.
double ksStatistic(std::vector<double> samples, const std::function<double(double)>& cdf) {
  std::sort(samples.begin(), samples.end());
  const double n = static_cast<double>(samples.size());
  double d = 0.0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double f = cdf(samples[i]);
    d = std::max({d, f - static_cast<double>(i) / n, static_cast<double>(i + 1) / n - f});
  }
  return d;
}

// Strengths of particles firstId .. firstId + count - 1 at one diameter.
std::vector<double> sample(const WeibullDef& def, std::uint64_t seed, std::uint64_t firstId, double diameter,
                           std::size_t count = kSamples) {
  std::vector<double> s(count);
  for (std::size_t i = 0; i < count; ++i) s[i] = sampleStrength(def, seed, firstId + i, diameter);
  return s;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

// eq. 12 at chosen Pf against the closed form, and eq. 11 inverts it.
TEST(Weibull, InverseTransformMatchesClosedForm) {
  const WeibullDef def;  // 56.5 MPa, 0.21 m, m = 3
  // At d = d0 and Pf = 1 - 1/e the strength is exactly sigma0.
  EXPECT_NEAR(weibullStrength(def, 0.21, 1.0 - std::exp(-1.0)), 56.5e6, 56.5e6 * 1e-14);
  // Half the diameter, Pf = 1 - exp(-8): (8 x 8)^(1/3) = 4 times sigma0.
  EXPECT_NEAR(weibullStrength(56.5e6, 0.21, 3.0, 0.105, -std::expm1(-8.0)), 4.0 * 56.5e6, 56.5e6 * 1e-12);
  for (const double pf : {1e-6, 0.1, 0.5, 0.9, 0.999999}) {
    const double s = weibullStrength(def, 0.07, pf);
    EXPECT_NEAR(failureProbability(def, 0.07, s), pf, 1e-12);
  }
  EXPECT_NEAR(medianStrength(def, 0.21), 56.5e6 * std::cbrt(std::log(2.0)), 1e-6);
  EXPECT_EQ(failureProbability(def, 0.1, 0.0), 0.0);
}

// 10^4 samples at one diameter against P_s = exp(-(d/d0)^3 (s/s0)^m): D_n below
// the 1 % critical value 1.63 / sqrt(n).
TEST(Weibull, SamplesPassKolmogorovSmirnov) {
  const double critical = 1.63 / std::sqrt(static_cast<double>(kSamples));
  for (const double m : {3.0, 10.0}) {
    const WeibullDef def{40e6, 2e-3, m};
    const double d = 1.3e-3;
    const std::vector<double> s = sample(def, 20200917 + static_cast<std::uint64_t>(m), 0, d);
    const double dn = ksStatistic(s, [&](double x) { return failureProbability(def, d, x); });
    RecordProperty("ks_m" + std::to_string(static_cast<int>(m)), std::to_string(dn));
    EXPECT_LT(dn, critical) << "m = " << m;
    // The test has power: the same samples against a 5 % stronger material fail it.
    WeibullDef wrong = def;
    wrong.referenceStrength *= 1.05;
    EXPECT_GT(ksStatistic(s, [&](double x) { return failureProbability(wrong, d, x); }), critical) << "m = " << m;
  }
}

// eq. 12: the median scales like d^(-3/m); rescaled samples follow the d0 law.
TEST(Weibull, MedianScalesWithSize) {
  const WeibullDef def{56.5e6, 0.21, 3.0};
  const double critical = 1.63 / std::sqrt(static_cast<double>(kSamples));
  const double d0 = 0.05;
  const double m0 = median(sample(def, 7, 0, d0));
  std::uint64_t firstId = kSamples;
  for (const double d : {0.0125, 0.025, 0.1, 0.4}) {
    const std::vector<double> s = sample(def, 7, firstId, d);
    firstId += kSamples;
    // Empirical median ratio against (d/d0)^(-3/m), and against the closed form.
    EXPECT_NEAR(median(s) / m0, std::pow(d / d0, -3.0 / def.modulus), 0.03 * std::pow(d / d0, -3.0 / def.modulus))
        << "d = " << d;
    EXPECT_NEAR(median(s), medianStrength(def, d), 0.02 * medianStrength(def, d)) << "d = " << d;
    RecordProperty("median_ratio_error_d" + std::to_string(d),
                   std::to_string(median(s) / m0 * std::pow(d / d0, 3.0 / def.modulus) - 1.0));
    // Samples rescaled to the reference diameter follow eq. 11 at d0.
    std::vector<double> scaled(s);
    for (double& x : scaled) x *= std::pow(d / def.referenceDiameter, 3.0 / def.modulus);
    EXPECT_LT(ksStatistic(scaled, [&](double x) { return failureProbability(def, def.referenceDiameter, x); }),
              critical)
        << "d = " << d;
  }
}

// Counter-based sampling: a particle's strength depends on (seed, id) alone.
TEST(Weibull, ReproduciblePerIdInAnyOrder) {
  const WeibullDef def;
  const std::size_t n = 1000;
  std::vector<double> forward(n), backward(n), strided(n);
  for (std::size_t i = 0; i < n; ++i) forward[i] = sampleStrength(def, 42, 1000 + i, 0.1);
  for (std::size_t i = n; i-- > 0;) backward[i] = sampleStrength(def, 42, 1000 + i, 0.1);
  for (std::size_t start = 0; start < 7; ++start) {
    for (std::size_t i = start; i < n; i += 7) strided[i] = sampleStrength(def, 42, 1000 + i, 0.1);
  }
  EXPECT_EQ(forward, backward);
  EXPECT_EQ(forward, strided);
  // Another seed changes every strength; distinct ids give distinct strengths.
  std::size_t same = 0;
  for (std::size_t i = 0; i < n; ++i) same += sampleStrength(def, 43, 1000 + i, 0.1) == forward[i];
  EXPECT_EQ(same, 0u);
  std::vector<double> sorted(forward);
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
  // The uniform numbers lie strictly inside (0, 1), including for extreme keys.
  for (const std::uint64_t key : {std::uint64_t(0), std::uint64_t(1), ~std::uint64_t(0)}) {
    const double u = keyedUniform(0, key);
    EXPECT_GT(u, 0.0);
    EXPECT_LT(u, 1.0);
  }
  // Their mean and variance are those of U(0,1) to sampling accuracy.
  double sum = 0.0, sumSq = 0.0;
  for (std::uint64_t k = 0; k < kSamples; ++k) {
    const double u = keyedUniform(99, k);
    sum += u;
    sumSq += u * u;
  }
  const double mean = sum / kSamples;
  EXPECT_NEAR(mean, 0.5, 4.0 * std::sqrt(1.0 / 12.0 / kSamples));
  EXPECT_NEAR(sumSq / kSamples - mean * mean, 1.0 / 12.0, 0.005);
}

// eq. 13: exact for simple ratios, and equal to eq. 12 evaluated at the same Pf.
TEST(Weibull, ChildScaling) {
  EXPECT_EQ(childStrength(10e6, 0.05, 0.1, 3.0), 20e6);        // (1/2)^(-1) = 2
  EXPECT_EQ(childStrength(10e6, 0.1, 0.1, 3.0), 10e6);
  EXPECT_DOUBLE_EQ(childStrength(10e6, 0.025, 0.1, 6.0), 20e6); // (1/4)^(-1/2) = 2
  const WeibullDef def{56.5e6, 0.21, 2.5};
  for (const double pf : {0.01, 0.3, 0.77}) {
    const double parent = weibullStrength(def, 0.3, pf);
    const double child = weibullStrength(def, 0.11, pf);
    EXPECT_NEAR(childStrength(parent, 0.11, 0.3, def.modulus), child, child * 1e-13);
  }
}

TEST(Weibull, RejectsBadParameters) {
  EXPECT_THROW(weibullStrength(0.0, 0.2, 3.0, 0.1, 0.5), std::invalid_argument);
  EXPECT_THROW(weibullStrength(1e6, -0.2, 3.0, 0.1, 0.5), std::invalid_argument);
  EXPECT_THROW(weibullStrength(1e6, 0.2, 0.0, 0.1, 0.5), std::invalid_argument);
  EXPECT_THROW(weibullStrength(1e6, 0.2, 3.0, 0.0, 0.5), std::invalid_argument);
  EXPECT_THROW(weibullStrength(1e6, 0.2, 3.0, 0.1, 0.0), std::invalid_argument);
  EXPECT_THROW(weibullStrength(1e6, 0.2, 3.0, 0.1, 1.0), std::invalid_argument);
  EXPECT_THROW(weibullStrength(1e6, 0.2, 3.0, 0.1, std::nan("")), std::invalid_argument);
  EXPECT_THROW(weibullStrength(INFINITY, 0.2, 3.0, 0.1, 0.5), std::invalid_argument);
  EXPECT_THROW(sampleStrength(WeibullDef{1e6, 0.2, -1.0}, 1, 1, 0.1), std::invalid_argument);
  EXPECT_THROW(sampleStrength(WeibullDef{}, 1, 1, 0.0), std::invalid_argument);
  EXPECT_THROW(childStrength(0.0, 0.1, 0.2, 3.0), std::invalid_argument);
  EXPECT_THROW(childStrength(1e6, 0.0, 0.2, 3.0), std::invalid_argument);
  EXPECT_THROW(childStrength(1e6, 0.1, 0.0, 3.0), std::invalid_argument);
  EXPECT_THROW(childStrength(1e6, 0.1, 0.2, 0.0), std::invalid_argument);
  EXPECT_THROW(failureProbability(WeibullDef{}, -1.0, 1e6), std::invalid_argument);
  try {
    validateWeibull(WeibullDef{1e6, 0.2, -2.0});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("modulus"), std::string::npos) << e.what();
  }
  // Moduli whose strengths under- or overflow (0.001 drew 0), and past any material's.
  for (const double m : {0.001, 0.49, 101.0}) {
    EXPECT_THROW(validateWeibull(WeibullDef{1e6, 0.2, m}), std::invalid_argument) << m;
  }
  EXPECT_NO_THROW(validateWeibull(WeibullDef{1e6, 0.2, 0.5}));
  EXPECT_NO_THROW(validateWeibull(WeibullDef{1e6, 0.2, 100.0}));
}
