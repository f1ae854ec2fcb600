#include "lsdem/geometry/RandomGrain.h"

#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/Reinitialize.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <memory>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::geometry {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kFirstMode = 2;         ///< lowest Fourier mode / SH degree (1 would only shift the grain)
constexpr int kLastFourierMode = 16;  ///< highest Fourier mode in 2D
constexpr int kLastDegree = 8;        ///< highest spherical-harmonic degree in 3D
constexpr double kFloor = 0.3;        ///< r / r0 never goes below this
constexpr double kFloorBlend = 0.1;   ///< half-width of the C1 blend into the floor

std::string str(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

/// Reproducible random numbers: std::mt19937_64 is specified bit for bit by
/// the standard, its distributions are not, so the transforms are our own.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  /// Uniform in [0, 1) from the 53 high bits of one draw.
  double uniform() { return double(engine_() >> 11) * 0x1.0p-53; }
  /// Standard normal by Box-Muller (two uniform draws per value).
  double normal() {
    const double u1 = 1.0 - uniform();  // (0, 1]: log is finite
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }

 private:
  std::mt19937_64 engine_;
};

/// C1 floor: identity above kFloor + kFloorBlend, kFloor below kFloor - kFloorBlend,
/// a quadratic blend in between; never below kFloor.
double smoothFloor(double y) {
  if (y >= kFloor + kFloorBlend) return y;
  if (y <= kFloor - kFloorBlend) return kFloor;
  const double t = y - kFloor + kFloorBlend;
  return kFloor + t * t / (4.0 * kFloorBlend);
}

/// Offset of the coefficient (l, m) in a degree-ordered array of real
/// spherical harmonics, m in [-l, l].
constexpr int shIndex(int l, int m) { return l * l + l + m; }

/// The dimensionless radial profile r / r0 as a function of the direction.
template <int D>
class Profile;

/// 2D: Fourier series in the angle.
template <>
class Profile<2> {
 public:
  Profile(Random& random, double roughness) {
    // Gaussian coefficients with standard deviation n^-2 ...
    double variance = 0.0;
    for (int n = kFirstMode; n <= kLastFourierMode; ++n) {
      const double sigma = 1.0 / double(n * n);
      cosine_[std::size_t(n)] = sigma * random.normal();
      sine_[std::size_t(n)] = sigma * random.normal();
      variance +=
          0.5 * (cosine_[std::size_t(n)] * cosine_[std::size_t(n)] + sine_[std::size_t(n)] * sine_[std::size_t(n)]);
    }
    // ... scaled so the standard deviation over the circle, sqrt(sum (alpha^2 + beta^2) / 2), is the roughness.
    const double scale = (variance > 0.0) ? roughness / std::sqrt(variance) : 0.0;
    for (int n = kFirstMode; n <= kLastFourierMode; ++n) {
      cosine_[std::size_t(n)] *= scale;
      sine_[std::size_t(n)] *= scale;
    }
  }

  /// r / r0 in the unit direction u; cos n theta, sin n theta by the angle-addition recurrence.
  double operator()(const Vec<2>& u) const {
    double c = u[0], s = u[1], sum = 1.0;
    for (int n = kFirstMode; n <= kLastFourierMode; ++n) {
      const double cNext = c * u[0] - s * u[1];
      s = s * u[0] + c * u[1];
      c = cNext;
      sum += cosine_[std::size_t(n)] * c + sine_[std::size_t(n)] * s;
    }
    return smoothFloor(sum);
  }

  /// Directions and weights of the trapezoid rule on the circle: exact for
  /// trigonometric polynomials of degree < 4096 (the unfloored rho^2 has degree
  /// 32), spectrally accurate for the floored one.
  static void quadrature(std::vector<Vec<2>>& dirs, std::vector<double>& weights) {
    const int count = 4096;
    dirs.resize(std::size_t(count));
    weights.assign(std::size_t(count), 2.0 * kPi / count);
    for (int k = 0; k < count; ++k) {
      const double theta = 2.0 * kPi * k / count;
      dirs[std::size_t(k)] = Vec<2>(std::cos(theta), std::sin(theta));
    }
  }

 private:
  std::array<double, kLastFourierMode + 1> cosine_{};
  std::array<double, kLastFourierMode + 1> sine_{};
};

/// 3D: real spherical harmonics up to degree kLastDegree.
template <>
class Profile<3> {
 public:
  static constexpr int kCount = (kLastDegree + 1) * (kLastDegree + 1);

  Profile(Random& random, double roughness) {
    // Gaussian c_lm with standard deviation l^-2 ...
    double sumSq = 0.0;
    for (int l = kFirstMode; l <= kLastDegree; ++l) {
      for (int m = -l; m <= l; ++m) {
        const double c = random.normal() / double(l * l);
        coeff_[std::size_t(shIndex(l, m))] = c;
        sumSq += c * c;
      }
    }
    // ... scaled so the standard deviation over the sphere, sqrt(sum c^2 / 4 pi)
    // for orthonormal harmonics, is the roughness.
    const double scale = (sumSq > 0.0) ? roughness / std::sqrt(sumSq / (4.0 * kPi)) : 0.0;
    for (double& c : coeff_) c *= scale;
    // Recurrence factors, computed once rather than per evaluation.
    for (int m = 0; m <= kLastDegree; ++m) {
      diagonal_[std::size_t(m)] = (m == 0) ? 1.0 / std::sqrt(4.0 * kPi) : std::sqrt((2.0 * m + 1.0) / (2.0 * m));
      for (int l = m + 2; l <= kLastDegree; ++l) {
        recurrenceA_[std::size_t(shIndex(l, m))] = std::sqrt((4.0 * l * l - 1.0) / (double(l * l) - double(m * m)));
        recurrenceB_[std::size_t(shIndex(l, m))] =
            std::sqrt((double((l - 1) * (l - 1)) - double(m * m)) / (4.0 * (l - 1) * (l - 1) - 1.0));
      }
    }
  }

  /// r / r0 in the unit direction u.
  double operator()(const Vec<3>& u) const { return smoothFloor(1.0 + series(u)); }

  /// sum c_lm Y_lm(u) with orthonormal real harmonics (no Condon-Shortley phase):
  /// Y_l0 = P_l^0, Y_lm = sqrt(2) P_l^m cos(m phi), Y_l,-m = sqrt(2) P_l^m sin(m phi),
  /// P_l^m the associated Legendre functions normalised to include
  /// sqrt((2l+1)/(4 pi) (l-m)!/(l+m)!), by the stable recurrences in l.
  double series(const Vec<3>& u) const {
    const double mu = u[2];
    const double sinTheta = std::sqrt(std::max(0.0, u[0] * u[0] + u[1] * u[1]));
    // cos(phi), sin(phi) of the azimuth (any value on the pole, where sin theta = 0).
    const double cosPhi = sinTheta > 0.0 ? u[0] / sinTheta : 1.0;
    const double sinPhi = sinTheta > 0.0 ? u[1] / sinTheta : 0.0;
    double sum = 0.0;
    double pmm = diagonal_[0];  // P_m^m, starting at m = 0
    double cm = 1.0, sm = 0.0;  // cos(m phi), sin(m phi)
    for (int m = 0; m <= kLastDegree; ++m) {
      if (m > 0) {
        // Next diagonal term and azimuthal harmonic.
        pmm *= diagonal_[std::size_t(m)] * sinTheta;
        const double cNext = cm * cosPhi - sm * sinPhi;
        sm = sm * cosPhi + cm * sinPhi;
        cm = cNext;
      }
      // Climb in l at fixed m: P_{m+1}^m, then the three-term recurrence.
      double pPrev = 0.0, p = pmm;
      for (int l = m; l <= kLastDegree; ++l) {
        if (l == m + 1) {
          pPrev = p;
          p = std::sqrt(2.0 * m + 3.0) * mu * pmm;
        } else if (l > m + 1) {
          const std::size_t k = std::size_t(shIndex(l, m));
          const double pNext = recurrenceA_[k] * (mu * p - recurrenceB_[k] * pPrev);
          pPrev = p;
          p = pNext;
        }
        if (l < kFirstMode) continue;
        if (m == 0) {
          sum += coeff_[std::size_t(shIndex(l, 0))] * p;
        } else {
          sum += std::numbers::sqrt2 * p *
                 (coeff_[std::size_t(shIndex(l, m))] * cm + coeff_[std::size_t(shIndex(l, -m))] * sm);
        }
      }
    }
    return sum;
  }

  /// Gauss-Legendre in cos(theta) x trapezoid in phi on the sphere; weights sum to 4 pi.
  static void quadrature(std::vector<Vec<3>>& dirs, std::vector<double>& weights) {
    const int nMu = 64, nPhi = 128;
    std::vector<double> mu(static_cast<std::size_t>(nMu)), w(static_cast<std::size_t>(nMu));
    // Gauss-Legendre nodes by Newton's method on P_n from the usual cosine guesses.
    for (int k = 0; k < nMu; ++k) {
      double x = std::cos(kPi * (k + 0.75) / (nMu + 0.5));
      double derivative = 1.0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1.0, p1 = x;
        for (int n = 2; n <= nMu; ++n) {
          const double p2 = ((2.0 * n - 1.0) * x * p1 - (n - 1.0) * p0) / n;
          p0 = p1;
          p1 = p2;
        }
        derivative = nMu * (x * p1 - p0) / (x * x - 1.0);
        const double dx = p1 / derivative;
        x -= dx;
        if (std::abs(dx) < 1e-16) break;
      }
      mu[std::size_t(k)] = x;
      w[std::size_t(k)] = 2.0 / ((1.0 - x * x) * derivative * derivative);
    }
    dirs.clear();
    weights.clear();
    for (int k = 0; k < nMu; ++k) {
      const double s = std::sqrt(std::max(0.0, 1.0 - mu[std::size_t(k)] * mu[std::size_t(k)]));
      for (int j = 0; j < nPhi; ++j) {
        const double phi = 2.0 * kPi * j / nPhi;
        dirs.emplace_back(s * std::cos(phi), s * std::sin(phi), mu[std::size_t(k)]);
        weights.push_back(w[std::size_t(k)] * 2.0 * kPi / nPhi);
      }
    }
  }

 private:
  std::array<double, kCount> coeff_{};              ///< c_lm at shIndex(l, m)
  std::array<double, kCount> recurrenceA_{};        ///< sqrt((4l^2 - 1) / (l^2 - m^2)) at shIndex(l, m)
  std::array<double, kCount> recurrenceB_{};        ///< sqrt(((l-1)^2 - m^2) / (4(l-1)^2 - 1)) at shIndex(l, m)
  std::array<double, kLastDegree + 1> diagonal_{};  ///< P_0^0 = 1/sqrt(4 pi), then sqrt((2m+1) / 2m)
};

/// Per-axis stretch of the elongation e (area / volume preserving, x longest).
template <int D>
Vec<D> stretchFactors(double e) {
  Vec<D> s;
  if constexpr (D == 2) {
    s << std::sqrt(e), 1.0 / std::sqrt(e);
  } else {
    s << std::cbrt(e * e), 1.0 / std::cbrt(e), 1.0 / std::cbrt(e);
  }
  return s;
}

void validate(const RandomGrainDef& def, double spacing) {
  if (!(def.equivalentDiameter > 0.0) || !std::isfinite(def.equivalentDiameter)) {
    throw std::invalid_argument("randomGrainGrid: equivalentDiameter must be positive and finite, got " +
                                str(def.equivalentDiameter));
  }
  if (!(def.elongation >= 1.0) || !std::isfinite(def.elongation)) {
    throw std::invalid_argument("randomGrainGrid: elongation must be >= 1 and finite, got " + str(def.elongation));
  }
  if (!(def.roughness >= 0.0) || !(def.roughness <= 0.5)) {
    throw std::invalid_argument("randomGrainGrid: roughness must be in [0, 0.5], got " + str(def.roughness));
  }
  if (!(spacing > 0.0) || !std::isfinite(spacing)) {
    throw std::invalid_argument("randomGrainGrid: spacing must be positive and finite, got " + str(spacing));
  }
}

}  // namespace

namespace {

/// A grain's profile and its placement: r0, the stretch and the bounding box.
template <int D>
struct GrainModel {
  Profile<D> profile;
  double r0 = 0.0;
  Vec<D> stretch;
  Box<D> box;
  double centreValue = 0.0;

  explicit GrainModel(const RandomGrainDef& def, Random&& random)
      : profile(random, def.roughness) {
    // r0 from the area 1/2 int rho^2 dtheta (2D) or volume 1/3 int rho^3 dOmega
    // (3D) of the profile, by quadrature, and the largest rho for the bounding box.
    std::vector<Vec<D>> dirs;
    std::vector<double> weights;
    Profile<D>::quadrature(dirs, weights);
    double moment = 0.0, rhoMax = 0.0;
    for (std::size_t k = 0; k < dirs.size(); ++k) {
      const double rho = profile(dirs[k]);
      moment += weights[k] * std::pow(rho, D) / D;
      rhoMax = std::max(rhoMax, rho);
    }
    const double d = def.equivalentDiameter;
    const double target = (D == 2) ? kPi * d * d / 4.0 : kPi * d * d * d / 6.0;
    r0 = std::pow(target / moment, 1.0 / D);

    // Bounding box of the stretched grain, 2% beyond the sampled maximum radius.
    stretch = stretchFactors<D>(def.elongation);
    const Vec<D> half = 1.02 * r0 * rhoMax * stretch;
    box = Box<D>{-half, half};
    centreValue = -kFloor * r0 * stretch.minCoeff();
  }

  // Signed distance along the ray from the centre: the ray through x meets the
  // surface at x r(dir x') / |x'|, with x' = x / stretch the unstretched point.
  double radialDistance(const Vec<D>& x) const {
    const Vec<D> xu = (x.array() / stretch.array()).matrix();
    const double radius = xu.norm();
    if (radius == 0.0) return centreValue;
    return x.norm() * (1.0 - r0 * profile(xu / radius) / radius);
  }
};

}  // namespace

template <int D>
Grid<D> randomGrainGrid(const RandomGrainDef& def, double spacing, int paddingCells) {
  validate(def, spacing);
  const GrainModel<D> grain(def, Random(def.seed));
  Grid<D> grid = sampleGrid<D>(grain.box, spacing, paddingCells,
                               [&](const Vec<D>& x) { return grain.radialDistance(x); });

  // Signed distance everywhere (eq. 17).
  reinitializeFastSweeping(grid);
  return grid;
}

template <int D>
std::function<double(const Vec<D>&)> randomGrainSurface(const RandomGrainDef& def) {
  validate(def, 1.0);
  auto grain = std::make_shared<const GrainModel<D>>(def, Random(def.seed));
  return [grain](const Vec<D>& x) { return grain->radialDistance(x); };
}

template Grid<2> randomGrainGrid<2>(const RandomGrainDef&, double, int);
template Grid<3> randomGrainGrid<3>(const RandomGrainDef&, double, int);
template std::function<double(const Vec<2>&)> randomGrainSurface<2>(const RandomGrainDef&);
template std::function<double(const Vec<3>&)> randomGrainSurface<3>(const RandomGrainDef&);

}  // namespace lsdem::geometry
