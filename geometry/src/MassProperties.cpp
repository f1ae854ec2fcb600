#include "lsdem/geometry/MassProperties.h"

#include <Eigen/Eigenvalues>

#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace lsdem::geometry {

namespace {

/// eq. 24 without argument checks, for the inner loop.
inline double heaviside(double phi, double epsilon) {
  if (phi < -epsilon) return 0.0;
  if (phi >= epsilon) return 1.0;
  return 0.5 * (1.0 + phi / epsilon + std::sin(std::numbers::pi * phi / epsilon) / std::numbers::pi);
}

/// Raw moments of a weight field about a fixed reference point: the sum of w,
/// of w r and of the upper triangle of w r r^T (r relative to the reference,
/// world units). Plain arrays so slices can be stored in a std::vector.
template <int D>
struct RawMoments {
  static constexpr int kPairs = D * (D + 1) / 2;
  double m0 = 0.0;
  std::array<double, D> m1{};
  std::array<double, kPairs> m2{};

  void add(double w, const std::array<double, D>& r) {
    m0 += w;
    int p = 0;
    for (int a = 0; a < D; ++a) {
      const double wr = w * r[a];
      m1[a] += wr;
      for (int b = a; b < D; ++b) m2[p++] += wr * r[b];
    }
  }
  void addScaled(const RawMoments& o, double s) {
    m0 += s * o.m0;
    for (int a = 0; a < D; ++a) m1[a] += s * o.m1[a];
    for (int p = 0; p < kPairs; ++p) m2[p] += s * o.m2[p];
  }
};

/// The partial sums of one slice of the grid (one value of the last index).
/// Nodes deep inside (phi <= -2 eps) weigh 1 for both smoothing widths and go to
/// `core`; nodes in the band (-2 eps, 2 eps) carry H_eps(-phi) in `band1` and
/// H_2eps(-phi) in `band2`; nodes at phi >= 2 eps weigh 0 for both.
template <int D>
struct SliceSums {
  RawMoments<D> core, band1, band2;
  bool sawNaN = false;
};

/// Central properties from raw moments about `reference`, scaled by the cell volume.
template <int D>
MassProperties<D> fromRaw(const RawMoments<D>& raw, double cellVolume, const Vec<D>& reference) {
  MassProperties<D> mp;
  mp.volume = raw.m0 * cellVolume;
  if (!(raw.m0 > 0.0)) {
    mp.centroid = reference;
    return mp;
  }
  // Centroid offset d from the reference, then S = M2 - m0 d d^T (symmetric by construction).
  Vec<D> d;
  for (int a = 0; a < D; ++a) d[a] = raw.m1[a] / raw.m0;
  mp.centroid = reference + d;
  int p = 0;
  for (int a = 0; a < D; ++a) {
    for (int b = a; b < D; ++b) {
      const double s = (raw.m2[p++] - raw.m0 * d[a] * d[b]) * cellVolume;
      mp.secondMoment(a, b) = s;
      mp.secondMoment(b, a) = s;
    }
  }
  return mp;
}

/// True when the volume is positive and S is positive definite.
template <int D>
bool isPhysical(const MassProperties<D>& mp) {
  if (!(mp.volume > 0.0) || !mp.secondMoment.allFinite()) return false;
  Eigen::SelfAdjointEigenSolver<Mat<D>> es(mp.secondMoment, Eigen::EigenvaluesOnly);
  return es.info() == Eigen::Success && es.eigenvalues()[0] > 0.0;
}

}  // namespace

double smoothedHeaviside(double phi, double epsilon) {
  if (!(epsilon > 0.0) || !std::isfinite(epsilon)) {
    throw std::invalid_argument("smoothedHeaviside: epsilon must be positive and finite, got " +
                                std::to_string(epsilon));
  }
  return heaviside(phi, epsilon);
}

template <int D>
Mat<D> MassProperties<D>::inertiaTensor() const {
  return secondMoment.trace() * Mat<D>::Identity() - secondMoment;
}

template <int D>
double MassProperties<D>::polarMoment() const {
  return secondMoment.trace();
}

template <int D>
Vec<D> MassProperties<D>::principalSecondMoments() const {
  Eigen::SelfAdjointEigenSolver<Mat<D>> es(secondMoment, Eigen::EigenvaluesOnly);
  return es.eigenvalues().reverse();
}

template <int D>
Mat<D> MassProperties<D>::principalAxes() const {
  // Eigenvectors in ascending order from Eigen; reverse to descending.
  Eigen::SelfAdjointEigenSolver<Mat<D>> es(secondMoment);
  Mat<D> axes = es.eigenvectors().rowwise().reverse();
  // Fix the signs: largest-magnitude entry positive in all but the last column.
  for (int c = 0; c + 1 < D; ++c) {
    int big = 0;
    for (int r = 1; r < D; ++r) {
      if (std::abs(axes(r, c)) > std::abs(axes(big, c))) big = r;
    }
    if (axes(big, c) < 0.0) axes.col(c) = -axes.col(c);
  }
  // The last column completes a right-handed frame.
  if constexpr (D == 2) {
    axes.col(1) = Vec<2>(-axes(1, 0), axes(0, 0));
  } else {
    axes.col(2) = axes.col(0).cross(axes.col(1));
  }
  return axes;
}

template <int D>
Vec<D> MassProperties<D>::principalInertia() const {
  return Vec<D>::Constant(secondMoment.trace()) - principalSecondMoments();
}

template <int D>
MassProperties<D> massProperties(const Grid<D>& grid, MassMethod method, double epsilonCells) {
  if (grid.empty()) throw std::invalid_argument("massProperties: the grid is empty");
  if (!(epsilonCells > 0.0) || !std::isfinite(epsilonCells)) {
    throw std::invalid_argument("massProperties: epsilonCells must be positive and finite, got " +
                                std::to_string(epsilonCells));
  }
  const double h = grid.spacing();
  const double eps = epsilonCells * h;
  const double eps2 = 2.0 * eps;
  const Index<D>& dims = grid.dims();
  const std::vector<float>& phi = grid.values();

  // Reference point: the centre of the grid's box; r = node position - reference.
  Vec<D> centreCells;
  for (int a = 0; a < D; ++a) centreCells[a] = 0.5 * double(dims[a] - 1);
  const Vec<D> reference = grid.toWorld(centreCells);

  // One partial sum per slice of the last axis, filled independently.
  const int slices = dims[D - 1];
  std::vector<SliceSums<D>> partial(static_cast<std::size_t>(slices));
  const std::size_t rowLength = std::size_t(dims[0]);
  const std::size_t rowsPerSlice = (D == 2) ? 1 : std::size_t(dims[1]);
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
  for (int s = 0; s < slices; ++s) {
    SliceSums<D>& out = partial[std::size_t(s)];
    std::array<double, D> r{};
    r[D - 1] = h * (double(s) - centreCells[D - 1]);
    for (std::size_t row = 0; row < rowsPerSlice; ++row) {
      if constexpr (D == 3) r[1] = h * (double(row) - centreCells[1]);
      const std::size_t n0 = (std::size_t(s) * rowsPerSlice + row) * rowLength;
      for (std::size_t i = 0; i < rowLength; ++i) {
        const double p = phi[n0 + i];
        // Outside both bands: no weight.
        if (p >= eps2) continue;
        r[0] = h * (double(i) - centreCells[0]);
        // Deep inside: weight 1 for both widths.
        if (p <= -eps2) {
          out.core.add(1.0, r);
          continue;
        }
        // In the band (NaN lands here too): both smoothed weights.
        if (std::isnan(p)) {
          out.sawNaN = true;
          continue;
        }
        const double w1 = heaviside(-p, eps);
        if (w1 > 0.0) out.band1.add(w1, r);
        out.band2.add(heaviside(-p, eps2), r);
      }
    }
  }

  // Add the slices in slice order (deterministic for any thread count).
  RawMoments<D> core, band1, band2;
  for (int s = 0; s < slices; ++s) {
    const SliceSums<D>& part = partial[std::size_t(s)];
    if (part.sawNaN) {
      throw std::invalid_argument("massProperties: the grid holds NaN values (slice " + std::to_string(s) + ")");
    }
    core.addScaled(part.core, 1.0);
    band1.addScaled(part.band1, 1.0);
    band2.addScaled(part.band2, 1.0);
  }
  const double cellVolume = std::pow(h, D);

  // Paper (eq. 25-30): the raw moments with eps.
  RawMoments<D> withEps = core;
  withEps.addScaled(band1, 1.0);
  const MassProperties<D> paper = fromRaw<D>(withEps, cellVolume, reference);
  if (!(paper.volume > 0.0)) {
    throw std::invalid_argument("massProperties: the shape has no volume (no node with phi < eps; volume " +
                                std::to_string(paper.volume) + ")");
  }
  if (method == MassMethod::Paper) return paper;

  // Extrapolated: (4 M_eps - M_2eps) / 3 for every raw moment; the core cancels to itself.
  RawMoments<D> extrapolated = core;
  extrapolated.addScaled(band1, 4.0 / 3.0);
  extrapolated.addScaled(band2, -1.0 / 3.0);
  const MassProperties<D> result = fromRaw<D>(extrapolated, cellVolume, reference);
  // A shape thinner than the band: the expansion is not valid; keep the paper's estimate.
  return isPhysical(result) ? result : paper;
}

template struct MassProperties<2>;
template struct MassProperties<3>;
template MassProperties<2> massProperties<2>(const Grid<2>&, MassMethod, double);
template MassProperties<3> massProperties<3>(const Grid<3>&, MassMethod, double);

}  // namespace lsdem::geometry
