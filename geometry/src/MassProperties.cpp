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
  const Index<D>& dims = grid.dims();
  const std::vector<float>& phi = grid.values();

  // Reference point: the centre of the grid's box; r = node position - reference.
  Vec<D> centreCells;
  for (int a = 0; a < D; ++a) centreCells[a] = 0.5 * double(dims[a] - 1);
  const Vec<D> reference = grid.toWorld(centreCells);

  // One partial sum per slice of the last axis, filled independently.
  const int slices = dims[D - 1];
  std::vector<MassSums<D>> partial(static_cast<std::size_t>(slices), MassSums<D>(eps));
  const std::size_t rowLength = std::size_t(dims[0]);
  const std::size_t rowsPerSlice = (D == 2) ? 1 : std::size_t(dims[1]);
#ifdef LSDEM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
  for (int s = 0; s < slices; ++s) {
    MassSums<D>& out = partial[std::size_t(s)];
    Vec<D> r = Vec<D>::Zero();
    r[D - 1] = h * (double(s) - centreCells[D - 1]);
    for (std::size_t row = 0; row < rowsPerSlice; ++row) {
      if constexpr (D == 3) r[1] = h * (double(row) - centreCells[1]);
      const std::size_t n0 = (std::size_t(s) * rowsPerSlice + row) * rowLength;
      for (std::size_t i = 0; i < rowLength; ++i) {
        r[0] = h * (double(i) - centreCells[0]);
        out.add(phi[n0 + i], r);
      }
    }
  }

  // Add the slices in slice order (deterministic for any thread count).
  MassSums<D> sums(eps);
  for (int s = 0; s < slices; ++s) {
    if (partial[std::size_t(s)].sawNaN()) {
      throw std::invalid_argument("massProperties: the grid holds NaN values (slice " + std::to_string(s) + ")");
    }
    sums.add(partial[std::size_t(s)]);
  }
  const double cellVolume = std::pow(h, D);
  const MassProperties<D> paper = sums.properties(MassMethod::Paper, cellVolume, reference);
  if (!(paper.volume > 0.0)) {
    throw std::invalid_argument("massProperties: the shape has no volume (no node with phi < eps; volume " +
                                std::to_string(paper.volume) + ")");
  }
  return method == MassMethod::Paper ? paper : sums.properties(method, cellVolume, reference);
}

template <int D>
void MassSums<D>::Raw::add(double w, const Vec<D>& r) {
  m0 += w;
  for (int a = 0; a < D; ++a) {
    const double wr = w * r[a];
    m1[a] += wr;
    for (int b = a; b < D; ++b) m2(a, b) += wr * r[b];
  }
}

template <int D>
void MassSums<D>::Raw::addScaled(const Raw& o, double s) {
  m0 += s * o.m0;
  for (int a = 0; a < D; ++a) m1[a] += s * o.m1[a];
  for (int a = 0; a < D; ++a) {
    for (int b = a; b < D; ++b) m2(a, b) += s * o.m2(a, b);
  }
}

template <int D>
void MassSums<D>::add(double phi, const Vec<D>& r, double cells) {
  const double eps2 = 2.0 * eps_;
  // Outside both bands: no weight.
  if (phi >= eps2) return;
  // Deep inside: weight 1 for both widths.
  if (phi <= -eps2) {
    core_.add(cells, r);
    return;
  }
  // In the band (NaN lands here too): both smoothed weights.
  if (std::isnan(phi)) {
    sawNaN_ = true;
    return;
  }
  const double w1 = heaviside(-phi, eps_);
  if (w1 > 0.0) band1_.add(cells * w1, r);
  band2_.add(cells * heaviside(-phi, eps2), r);
}

template <int D>
void MassSums<D>::add(const MassSums& other) {
  core_.addScaled(other.core_, 1.0);
  band1_.addScaled(other.band1_, 1.0);
  band2_.addScaled(other.band2_, 1.0);
  sawNaN_ = sawNaN_ || other.sawNaN_;
}

template <int D>
MassProperties<D> MassSums<D>::fromRaw(const Raw& raw, double cellVolume, const Vec<D>& reference) {
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
  for (int a = 0; a < D; ++a) {
    for (int b = a; b < D; ++b) {
      const double s = (raw.m2(a, b) - raw.m0 * d[a] * d[b]) * cellVolume;
      mp.secondMoment(a, b) = s;
      mp.secondMoment(b, a) = s;
    }
  }
  return mp;
}

template <int D>
MassProperties<D> MassSums<D>::properties(MassMethod method, double cellVolume, const Vec<D>& reference) const {
  // Paper (eq. 25-30): the raw moments with eps.
  Raw withEps = core_;
  withEps.addScaled(band1_, 1.0);
  const MassProperties<D> paper = fromRaw(withEps, cellVolume, reference);
  if (method == MassMethod::Paper) return paper;

  // Extrapolated: (4 M_eps - M_2eps) / 3 for every raw moment; the core cancels to itself.
  Raw extrapolated = core_;
  extrapolated.addScaled(band1_, 4.0 / 3.0);
  extrapolated.addScaled(band2_, -1.0 / 3.0);
  const MassProperties<D> result = fromRaw(extrapolated, cellVolume, reference);
  // A shape thinner than the band: the expansion is not valid; keep the paper's estimate.
  return isPhysical(result) ? result : paper;
}

template class MassSums<2>;
template class MassSums<3>;
template struct MassProperties<2>;
template struct MassProperties<3>;
template MassProperties<2> massProperties<2>(const Grid<2>&, MassMethod, double);
template MassProperties<3> massProperties<3>(const Grid<3>&, MassMethod, double);

}  // namespace lsdem::geometry
