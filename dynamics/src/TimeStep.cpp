#include "lsdem/dynamics/TimeStep.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

namespace lsdem::dynamics {
namespace {

std::string str(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument(message); }

void requireNonNegative(const char* name, double v) {
  if (!(v >= 0.0) || !std::isfinite(v)) fail(std::string(name) + " = " + str(v) + " must be >= 0 and finite");
}

// Rotational degrees of freedom of a rigid body in D dimensions.
template <int D>
constexpr int kRotations = D == 2 ? 1 : 3;

// Direction bins for the candidate patch normals: 1024 angles in 2D; a cube map
// of 16 x 16 cells per face in 3D.
constexpr int kBins2 = 1024;
constexpr int kBins3 = 16;

int binIndex(double u, int bins) { return std::clamp(int(std::floor(0.5 * (u + 1.0) * bins)), 0, bins - 1); }

// Bin of a unit normal.
template <int D>
int directionBin(const Vec<D>& n) {
  if constexpr (D == 2) {
    return binIndex(std::atan2(n[1], n[0]) / std::numbers::pi, kBins2);
  } else {
    int a = 0;
    n.cwiseAbs().maxCoeff(&a);
    const int side = 2 * a + (n[a] < 0.0 ? 1 : 0);
    const double inv = 1.0 / std::abs(n[a]);
    const int iu = binIndex(n[(a + 1) % 3] * inv, kBins3);
    const int iv = binIndex(n[(a + 2) % 3] * inv, kBins3);
    return (side * kBins3 + iu) * kBins3 + iv;
  }
}

// Candidate patch normals (body frame, outward): the mean surface normal of the
// nodes in each occupied direction bin, in bin order (deterministic). A flat
// face's nodes share one normal, so the face's own normal is a candidate.
template <int D>
std::vector<Vec<D>> candidateNormals(const geometry::Shape<D>& shape) {
  const auto& x = shape.nodes().positions;
  std::vector<std::pair<int, Vec<D>>> binned;
  binned.reserve(x.size());
  for (const Vec<D>& p : x) {
    Vec<D> g;
    shape.valueAndGradient(p, g);
    const double norm = g.norm();
    if (!(norm > 0.0) || !std::isfinite(norm)) continue;
    const Vec<D> n = g / norm;
    binned.emplace_back(directionBin<D>(n), n);
  }
  std::stable_sort(binned.begin(), binned.end(), [](const auto& a, const auto& b) { return a.first < b.first; });

  std::vector<Vec<D>> normals;
  for (std::size_t i = 0; i < binned.size();) {
    Vec<D> sum = Vec<D>::Zero();
    std::size_t j = i;
    for (; j < binned.size() && binned[j].first == binned[i].first; ++j) sum += binned[j].second;
    if (sum.norm() > 0.0) normals.push_back(sum.normalized());
    i = j;
  }
  return normals;
}

// Lever-arm row of a unit force direction e applied at body point x: the
// rotational part of the generalised force, x cross e.
template <int D>
Eigen::Matrix<double, kRotations<D>, 1> leverArm(const Vec<D>& x, const Vec<D>& e) {
  if constexpr (D == 2) {
    return Eigen::Matrix<double, 1, 1>(x[0] * e[1] - x[1] * e[0]);
  } else {
    return x.cross(e);
  }
}

// Unit tangent directions of a patch with unit normal n.
template <int D>
std::vector<Vec<D>> tangents(const Vec<D>& n) {
  if constexpr (D == 2) {
    return {Vec<2>(-n[1], n[0])};
  } else {
    const Vec<3> t1 = n.unitOrthogonal();
    return {t1, n.cross(t1)};
  }
}

}  // namespace

template <int D>
StiffestContact<D> stiffestContact(const geometry::Shape<D>& shape, const NodeStiffness& law,
                                   const ContactStiffnessOptions& options) {
  constexpr int Q = D + kRotations<D>;
  using MatQ = Eigen::Matrix<double, Q, Q>;
  using VecQ = Eigen::Matrix<double, Q, 1>;

  // Check the law and the shape.
  requireNonNegative("NodeStiffness perNode", law.perNode);
  requireNonNegative("NodeStiffness perWeight", law.perWeight);
  requireNonNegative("NodeStiffness tangentialRatio", law.tangentialRatio);
  if (!(law.perNode + law.perWeight > 0.0)) fail("NodeStiffness needs perNode > 0 or perWeight > 0, got both 0");
  requireNonNegative("ContactStiffnessOptions maxOverlap", options.maxOverlap);
  const auto& x = shape.nodes().positions;
  const auto& w = shape.nodes().weights;
  if (x.empty()) fail("stiffestContact: the shape has no surface nodes");
  const double depth = options.maxOverlap > 0.0 ? options.maxOverlap : 0.1 * shape.contactSpacing();
  // The per-node part at this shape's own scale (ShapeOptions::nodeStiffnessScale).
  const double perNode = law.perNode * shape.nodeStiffnessScale();

  // Mass matrix per unit density, as the scaling M^(-1/2) of the eigenproblem.
  VecQ scale;
  const auto& mp = shape.mass();
  scale.template head<D>().setConstant(1.0 / std::sqrt(mp.volume));
  if constexpr (D == 2) {
    scale[2] = 1.0 / std::sqrt(mp.polarMoment());
  } else {
    scale.template tail<3>() = mp.principalInertia().cwiseSqrt().cwiseInverse();
  }

  StiffestContact<D> best;
  double bestOmega2 = -1.0;
  for (const Vec<D>& n : candidateNormals(shape)) {
    // The patch: nodes within `depth` of the supporting plane with outward normal n.
    double support = -std::numeric_limits<double>::infinity();
    for (const Vec<D>& p : x) support = std::max(support, n.dot(p));

    // Stiffness of the patch's node springs on the body's generalised coordinates
    // (translation, rotation), normal and tangential.
    const std::vector<Vec<D>> ts = tangents<D>(n);
    MatQ K = MatQ::Zero();
    double kNormal = 0.0;
    std::size_t count = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (n.dot(x[i]) < support - depth) continue;
      const double k = perNode + law.perWeight * w[i];
      VecQ g;
      g << n, leverArm<D>(x[i], n);
      K += k * g * g.transpose();
      for (const Vec<D>& t : ts) {
        g << t, leverArm<D>(x[i], t);
        K += law.tangentialRatio * k * g * g.transpose();
      }
      kNormal += k;
      ++count;
    }

    // Largest omega^2 per unit density: eigenvalue of M^-1/2 K M^-1/2.
    const MatQ A = scale.asDiagonal() * K * scale.asDiagonal();
    const double omega2 = Eigen::SelfAdjointEigenSolver<MatQ>(A, Eigen::EigenvaluesOnly).eigenvalues()[Q - 1];
    if (omega2 > bestOmega2) {
      bestOmega2 = omega2;
      best.normal = n;
      best.nodeCount = count;
      best.normalStiffness = kNormal;
    }
  }

  // k_eff = omega^2 m (density cancels), doubled for particle pairs.
  best.stiffness = std::max(bestOmega2, 0.0) * mp.volume * (options.particlePairs ? 2.0 : 1.0);
  return best;
}

double criticalTimeStep(const std::vector<double>& masses, const std::vector<double>& stiffnesses,
                        double dampingRatio) {
  if (masses.size() != stiffnesses.size()) {
    fail("criticalTimeStep: " + std::to_string(masses.size()) + " masses but " + std::to_string(stiffnesses.size()) +
         " stiffnesses");
  }
  requireNonNegative("dampingRatio", dampingRatio);
  // The largest omega^2 = k / m over the particles.
  double omega2 = 0.0;
  for (std::size_t i = 0; i < masses.size(); ++i) {
    if (!(masses[i] > 0.0) || !std::isfinite(masses[i])) {
      fail("particle mass = " + str(masses[i]) + " kg must be > 0 and finite (particle " + std::to_string(i) + ")");
    }
    if (!(stiffnesses[i] >= 0.0) || !std::isfinite(stiffnesses[i])) {
      fail("contact stiffness = " + str(stiffnesses[i]) + " N/m must be >= 0 and finite (particle " +
           std::to_string(i) + ")");
    }
    const double w2 = stiffnesses[i] / masses[i];
    if (!std::isfinite(w2)) {
      // (A stiffness near the largest double, or a mass near the smallest:
      // the step would be 0.)
      fail("contact stiffness = " + str(stiffnesses[i]) + " N/m over particle mass = " + str(masses[i]) +
           " kg overflows: the time step would be 0 s (particle " + std::to_string(i) +
           "; check the stiffness, kn or youngs_modulus, and the density)");
    }
    omega2 = std::max(omega2, w2);
  }
  if (omega2 == 0.0) return std::numeric_limits<double>::infinity();
  // Stability limit of velocity Verlet with damping ratio zeta (see TimeStep.h).
  return 2.0 / std::sqrt(omega2) * (std::sqrt(1.0 + dampingRatio * dampingRatio) - dampingRatio);
}

template <int D>
double criticalTimeStep(const Particles<D>& particles, const NodeStiffness& law, double dampingRatio,
                        const ContactStiffnessOptions& options) {
  // Each distinct shape once, then every particle's mass.
  std::unordered_map<const geometry::Shape<D>*, double> perShape;
  std::vector<double> stiffness(particles.size());
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const geometry::Shape<D>* shape = particles.shape[i].get();
    auto it = perShape.find(shape);
    if (it == perShape.end()) it = perShape.emplace(shape, stiffestContact(*shape, law, options).stiffness).first;
    stiffness[i] = it->second;
  }
  return criticalTimeStep(particles.mass, stiffness, dampingRatio);
}

double stableTimeStep(double dtCritical, double safety) {
  if (!(dtCritical > 0.0)) fail("critical time step = " + str(dtCritical) + " s must be > 0");
  if (!(safety > 0.0 && safety <= 1.0)) fail("time-step safety = " + str(safety) + " must be in (0, 1]");
  return safety * dtCritical;
}

void checkUserTimeStep(double dtUser, double dtCritical, bool force, double safety) {
  if (!(dtUser > 0.0) || !std::isfinite(dtUser)) fail("dt = " + str(dtUser) + " s must be > 0 and finite");
  const double limit = stableTimeStep(dtCritical, safety);
  if (dtUser > limit && !force) {
    fail("dt = " + str(dtUser) + " s exceeds the critical time step " + str(limit) + " s (safety " + str(safety) +
         " of the stability limit " + str(dtCritical) + " s); lower it or set force_dt = true");
  }
}

template StiffestContact<2> stiffestContact<2>(const geometry::Shape<2>&, const NodeStiffness&,
                                               const ContactStiffnessOptions&);
template StiffestContact<3> stiffestContact<3>(const geometry::Shape<3>&, const NodeStiffness&,
                                               const ContactStiffnessOptions&);
template double criticalTimeStep<2>(const Particles<2>&, const NodeStiffness&, double, const ContactStiffnessOptions&);
template double criticalTimeStep<3>(const Particles<3>&, const NodeStiffness&, double, const ContactStiffnessOptions&);

}  // namespace lsdem::dynamics
