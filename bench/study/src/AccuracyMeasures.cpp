/// @file AccuracyMeasures.cpp
/// @brief The measurements of the accuracy study (Accuracy.h): mass
/// properties, contact forces, restitution, spherical caps and the packing,
/// each against its exact answer.

#include "lsdem/study/Accuracy.h"

#include "lsdem/breakage/Split.h"
#include "lsdem/dynamics/NarrowPhase.h"
#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/MassProperties.h"
#include "lsdem/geometry/ShapeDef.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <ctime>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#ifdef LSDEM_HAVE_OPENMP
#include <omp.h>
#endif

namespace lsdem::study {

using geometry::Vec;
namespace {

constexpr double kPi = std::numbers::pi;

// A relative-error metric (absolute when the reference is 0).
MetricValue metricOf(const std::string& name, double value, double reference) {
  const double scale = std::abs(reference) > 0.0 ? std::abs(reference) : 1.0;
  return {name, value, reference, std::abs(value - reference) / scale};
}

double medianOf(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// Seconds of a POSIX clock.
double clockSeconds(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// A circle (2D) or sphere (3D) of `radius`, `cells` cells across its diameter.
// Shapes are cached by (radius, cells, nodes per cell): several measurements
// and settings share one sphere, and 3D surface nodes are costly to make.
template <int D>
std::shared_ptr<const geometry::Shape<D>> sphereShape(double radius, double cells, double nodesPerCell,
                                                      bool exactNodes) {
  static std::mutex cacheMutex;
  static std::map<std::array<double, 4>, std::shared_ptr<const geometry::Shape<D>>> cache;
  std::lock_guard<std::mutex> lock(cacheMutex);
  auto& slot = cache[{radius, cells, nodesPerCell, exactNodes ? 1.0 : 0.0}];
  if (!slot) {
    geometry::ShapeDef<D> def;
    def.kind = geometry::ShapeKind::Sphere;
    def.radius = radius;
    def.cellsAcross = cells;
    def.options.nodesPerCell = nodesPerCell;
    def.exactNodes = exactNodes;
    slot = geometry::buildShape(def);
  }
  return slot;
}

// A square (2D) or cube (3D) of side `side`, `cells` cells across a side,
// cached like the spheres.
template <int D>
std::shared_ptr<const geometry::Shape<D>> cubeShape(double side, double cells, double nodesPerCell, bool exactNodes) {
  static std::mutex cacheMutex;
  static std::map<std::array<double, 4>, std::shared_ptr<const geometry::Shape<D>>> cache;
  std::lock_guard<std::mutex> lock(cacheMutex);
  auto& slot = cache[{side, cells, nodesPerCell, exactNodes ? 1.0 : 0.0}];
  if (!slot) {
    geometry::ShapeDef<D> def;
    def.kind = geometry::ShapeKind::Box;
    def.halfExtents = Vec<D>::Constant(0.5 * side);
    def.cellsAcross = cells;
    def.options.nodesPerCell = nodesPerCell;
    def.exactNodes = exactNodes;
    slot = geometry::buildShape(def);
  }
  return slot;
}

// Orientation number k of a fixed low-discrepancy sequence: 2D angles by the
// golden ratio; 3D uniform rotations (Shoemake) from the R3 additive sequence.
template <int D>
dynamics::Orientation<D> orientationNumber(int k) {
  auto frac = [](double x) { return x - std::floor(x); };
  if constexpr (D == 2) {
    return 2.0 * kPi * frac(0.5 + 0.6180339887498949 * k);
  } else {
    const double u1 = frac(0.5 + 0.8191725133961645 * k);
    const double u2 = frac(0.5 + 0.6710436067037893 * k);
    const double u3 = frac(0.5 + 0.5497004779019703 * k);
    const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
    Eigen::Quaterniond q(b * std::cos(2 * kPi * u3), a * std::sin(2 * kPi * u2), a * std::cos(2 * kPi * u2),
                         b * std::sin(2 * kPi * u3));
    return q.normalized();
  }
}

// Simpson's rule of f over [a, b] with n (even) intervals.
template <class F>
double simpson(F&& f, double a, double b, int n = 4000) {
  const double step = (b - a) / n;
  double sum = f(a) + f(b);
  for (int i = 1; i < n; ++i) sum += (i % 2 ? 4.0 : 2.0) * f(a + i * step);
  return sum * step / 3.0;
}

// int delta (n . e) dA over the surface of a sphere (circle) of radius R whose
// centre is R - delta above a plane: pi R delta^2 in 3D, 2R (R sin t0 - (R - delta) t0) in 2D.
template <int D>
double planeOverlapIntegral(double R, double delta) {
  if constexpr (D == 3) {
    return kPi * R * delta * delta;
  } else {
    const double t0 = std::acos(1.0 - delta / R);
    return 2.0 * R * (R * std::sin(t0) - (R - delta) * t0);
  }
}

// int delta_b (n_b . e) dA over the part of sphere a's surface inside sphere b
// (equal radii R, centres 2R - delta apart), delta_b = R - |x - c_b| and n_b
// the unit normal of b's level set, projected on the line of centres.
template <int D>
double pairOverlapIntegral(double R, double delta) {
  const double L = 2.0 * R - delta;
  const double t0 = std::acos(L / (2.0 * R));
  auto integrand = [&](double t) {
    const double rho = std::sqrt(R * R - 2.0 * R * L * std::cos(t) + L * L);
    const double overlap = std::max(0.0, R - rho);
    const double axial = (L - R * std::cos(t)) / rho;
    return overlap * axial * (D == 3 ? 2.0 * kPi * R * R * std::sin(t) : 2.0 * R);
  };
  return simpson(integrand, 0.0, t0);
}

// Stiffness per unit node weight of the study's contacts (kn / w_ref), N/m^(D+1)
// ... per metre of thickness in 2D: chosen so a 1 cm grain striking a plane at
// 1 m/s overlaps by about 5% of its radius.
template <int D>
double stiffnessPerArea() {
  return D == 3 ? 8.4e9 : 2.0e9;
}

// The packing's contacts are this much softer than the impact's: overlaps of
// about 1% of a diameter under the pile's weight, and 5x fewer steps.
constexpr double kPackingSoftening = 1.0 / 25.0;

// Bytes of the particle store per particle (every hot, warm and cold field).
template <int D>
std::size_t storeBytesPerParticle() {
  using dynamics::Orientation;
  using dynamics::Spin;
  return 3 * sizeof(Vec<D>) + sizeof(Orientation<D>) + 2 * sizeof(Spin<D>) + 2 * sizeof(double) +
         2 * sizeof(Spin<D>) + sizeof(std::shared_ptr<const geometry::Shape<D>>) + sizeof(int) + sizeof(double) +
         2 * sizeof(dynamics::ParticleId) + sizeof(int) + sizeof(double);
}

// The random grain of the mass study (equivalent diameter 1 m).
template <int D>
geometry::ShapeDef<D> grainDef(double cells) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::RandomGrain;
  def.grain.equivalentDiameter = 1.0;
  def.grain.elongation = 1.3;
  def.grain.roughness = 0.1;
  def.grain.seed = 7;
  def.cellsAcross = cells;
  return def;
}

// Principal inertia per unit density, for comparison: the polar moment in 2D,
// tr(S) - S_i by descending second moment in 3D.
template <int D>
std::vector<double> inertiaOf(const geometry::MassProperties<D>& m) {
  if constexpr (D == 2) {
    return {m.polarMoment()};
  } else {
    const Vec<3> p = m.principalInertia();
    return {p[0], p[1], p[2]};
  }
}

// Inertia metric: value and reference of the first entry, error the largest
// relative deviation of any entry (relative to the largest reference).
MetricValue inertiaMetric(const std::string& name, const std::vector<double>& value, const std::vector<double>& ref) {
  double scale = 0.0, worst = 0.0;
  for (double r : ref) scale = std::max(scale, std::abs(r));
  for (std::size_t i = 0; i < ref.size(); ++i) worst = std::max(worst, std::abs(value[i] - ref[i]) / scale);
  return {name, value[0], ref[0], worst};
}

}  // namespace

double threadCpuSeconds() { return clockSeconds(CLOCK_THREAD_CPUTIME_ID); }

double processCpuSeconds() { return clockSeconds(CLOCK_PROCESS_CPUTIME_ID); }

#ifdef LSDEM_HAVE_OPENMP
SingleThreadScope::SingleThreadScope() : previousThreads_(omp_get_max_threads()) { omp_set_num_threads(1); }
SingleThreadScope::~SingleThreadScope() { omp_set_num_threads(previousThreads_); }
#else
SingleThreadScope::SingleThreadScope() = default;
SingleThreadScope::~SingleThreadScope() = default;
#endif

const char* formulationName(dynamics::ForceFormulation formulation) {
  return formulation == dynamics::ForceFormulation::PerNode ? "per_node" : "area_weighted";
}

const char* interpolationName(dynamics::LevelSetInterpolation interpolation) {
  return interpolation == dynamics::LevelSetInterpolation::Tricubic ? "tricubic" : "trilinear";
}

// ---- mass properties ----

template <int D>
std::vector<MetricValue> massMetrics(double cellsAcross, double referenceCells) {
  if (!(cellsAcross > 2.0) || !(referenceCells > 2.0)) {
    throw std::invalid_argument("massMetrics: cells across must be > 2, got " + std::to_string(cellsAcross));
  }
  // Results depend on the two resolutions only: cached.
  static std::mutex resultMutex;
  static std::map<std::array<double, 2>, std::vector<MetricValue>> results;
  {
    std::lock_guard<std::mutex> lock(resultMutex);
    const auto it = results.find({cellsAcross, referenceCells});
    if (it != results.end()) return it->second;
  }
  std::vector<MetricValue> out;
  // Sphere (circle) of diameter 1 m: exact volume and inertia, centroid at 0.
  const double R = 0.5;
  geometry::ShapeDef<D> sphere;
  sphere.kind = geometry::ShapeKind::Sphere;
  sphere.radius = R;
  sphere.cellsAcross = cellsAcross;
  const auto ms = geometry::massProperties(geometry::buildGrid(sphere));
  const double Vs = D == 2 ? kPi * R * R : 4.0 / 3.0 * kPi * R * R * R;
  out.push_back(metricOf("volume_sphere", ms.volume, Vs));
  out.push_back(metricOf("centroid_sphere", ms.centroid.norm() / (2 * R), 0.0));
  const double Is = D == 2 ? Vs * R * R / 2.0 : 0.4 * Vs * R * R;
  out.push_back(inertiaMetric("inertia_sphere", inertiaOf<D>(ms), std::vector<double>(D == 2 ? 1 : 3, Is)));

  // Ellipsoid (ellipse) of semi-axes 0.5, 0.35[, 0.25] m.
  Vec<D> axes;
  if constexpr (D == 2) {
    axes << 0.5, 0.35;
  } else {
    axes << 0.5, 0.35, 0.25;
  }
  geometry::ShapeDef<D> ellipsoid;
  ellipsoid.kind = geometry::ShapeKind::Ellipsoid;
  ellipsoid.semiAxes = axes;
  ellipsoid.cellsAcross = cellsAcross;
  const auto me = geometry::massProperties(geometry::buildGrid(ellipsoid));
  const double Ve = D == 2 ? kPi * axes.prod() : 4.0 / 3.0 * kPi * axes.prod();
  std::vector<double> Ie;
  if constexpr (D == 2) {
    Ie = {Ve * axes.squaredNorm() / 4.0};
  } else {
    const Vec<3> a2 = axes.cwiseProduct(axes);
    Ie = {Ve * (a2[1] + a2[2]) / 5.0, Ve * (a2[0] + a2[2]) / 5.0, Ve * (a2[0] + a2[1]) / 5.0};
  }
  out.push_back(metricOf("volume_ellipsoid", me.volume, Ve));
  out.push_back(metricOf("centroid_ellipsoid", me.centroid.norm() / (2 * axes.minCoeff()), 0.0));
  out.push_back(inertiaMetric("inertia_ellipsoid", inertiaOf<D>(me), Ie));

  // Random grain against its own fine grid (cached per reference resolution).
  static std::mutex cacheMutex;
  static std::map<double, geometry::MassProperties<D>> cache;
  geometry::MassProperties<D> ref;
  {
    std::lock_guard<std::mutex> lock(cacheMutex);
    auto it = cache.find(referenceCells);
    if (it == cache.end()) {
      it = cache.emplace(referenceCells, geometry::massProperties(geometry::buildGrid(grainDef<D>(referenceCells)))).first;
    }
    ref = it->second;
  }
  const auto mg = geometry::massProperties(geometry::buildGrid(grainDef<D>(cellsAcross)));
  out.push_back(metricOf("volume_grain", mg.volume, ref.volume));
  out.push_back({"centroid_grain", (mg.centroid - ref.centroid).norm(), 0.0, (mg.centroid - ref.centroid).norm()});
  out.push_back(inertiaMetric("inertia_grain", inertiaOf<D>(mg), inertiaOf<D>(ref)));
  std::lock_guard<std::mutex> lock(resultMutex);
  results[{cellsAcross, referenceCells}] = out;
  return out;
}

// ---- contact forces ----

template <int D>
std::vector<MetricValue> contactMetrics(const AccuracySetting& setting) {
  const double R = 0.5, delta = 0.02 * R;
  const auto shape = sphereShape<D>(R, setting.cellsAcross, setting.nodesPerCell, setting.exactNodes);
  const double wRef = dynamics::referenceNodeWeight<D>(shape->grid().spacing());
  const double wMean = shape->nodes().totalWeight() / double(shape->nodes().size());
  // kn per reference weight, the same for both formulations.
  dynamics::ContactLawDef law;
  law.formulation = setting.formulation;
  law.kn = 1e6;
  law.hasFriction = false;
  law.hasDamping = false;
  law.interpolation = setting.interpolation;
  dynamics::ContactSolver<D> solver(law);
  const double perArea = law.kn / wRef;
  const double lawPerArea = setting.formulation == dynamics::ForceFormulation::PerNode ? law.kn / wMean : perArea;

  // Sphere on the plane y = 0 and two spheres along x, over 32 orientations.
  dynamics::Plane<D> floor;
  floor.point = Vec<D>::Zero();
  floor.normal = Vec<D>::Unit(1);
  const std::vector<dynamics::Plane<D>> planes{floor};
  const std::vector<typename dynamics::ContactSolver<D>::Pair> noPairs, onePair{{0u, 1u}};
  const int samples = 32;
  std::vector<double> planeForce, pairForce;
  for (int k = 0; k < samples; ++k) {
    // Plane: centre at height R - delta.
    dynamics::Particles<D> single;
    dynamics::ParticleDef<D> def;
    def.shape = shape;
    def.position = (R - delta) * Vec<D>::Unit(1);
    def.orientation = orientationNumber<D>(k);
    single.add(def);
    solver.compute(single, noPairs, planes, {}, 1e-6);
    double f = 0.0;
    for (const auto& c : solver.planeContacts()) f += c.force.dot(floor.normal);
    planeForce.push_back(f);

    // Pair: a at the origin, b at (2R - delta) e_x; the force on a points along -x.
    dynamics::Particles<D> two;
    def.position = Vec<D>::Zero();
    def.orientation = orientationNumber<D>(2 * k + 100);
    two.add(def);
    def.position = (2 * R - delta) * Vec<D>::Unit(0);
    def.orientation = orientationNumber<D>(2 * k + 101);
    two.add(def);
    solver.compute(two, onePair, {}, {}, 1e-6);
    double g = 0.0;
    for (const auto& c : solver.particleContacts()) g -= c.force.dot(Vec<D>::Unit(0));
    pairForce.push_back(g);
  }

  // Mean, ripple and stiffness ratio of each case against the surface integrals.
  std::vector<MetricValue> out;
  auto summarise = [&](const std::string& name, const std::vector<double>& f, double integral) {
    double mean = 0.0;
    for (double v : f) mean += v / double(f.size());
    const auto [lo, hi] = std::minmax_element(f.begin(), f.end());
    out.push_back(metricOf("force_" + name, mean, lawPerArea * integral));
    // No force at all (no node reaches the other body) counts as a 100% ripple.
    const double ripple = mean > 0.0 ? (*hi - *lo) / mean : 1.0;
    out.push_back({"ripple_" + name, ripple, 0.0, ripple});
    out.push_back(metricOf("stiffness_" + name, mean / (perArea * integral), 1.0));
  };
  summarise("plane", planeForce, planeOverlapIntegral<D>(R, delta));
  summarise("pair", pairForce, pairOverlapIntegral<D>(R, delta));

  // A flat face on the plane: a cube (square) of side 1 m, a face parallel to
  // the plane y = 0 and pressed into it by 1% of the side, turned about the
  // plane's normal (3D: 8 angles). The independent reference is the exact
  // overlap volume (area in 2D) delta L^(D-1): the law's continuum force on a
  // plane is its stiffness per area times int delta dA, which is the overlap
  // volume on the face plus the strips of the side faces in the plane, a
  // further 2 (D - 1) delta / L (2% in 3D, 1% in 2D): part of the error.
  const double side = 1.0, faceDelta = 0.01 * side;
  const auto cube = cubeShape<D>(side, setting.cellsAcross, setting.nodesPerCell, setting.exactNodes);
  const double cubeWMean = cube->nodes().totalWeight() / double(cube->nodes().size());
  const double cubeLawPerArea = setting.formulation == dynamics::ForceFormulation::PerNode
                                    ? law.kn / cubeWMean
                                    : law.kn / dynamics::referenceNodeWeight<D>(cube->grid().spacing());
  // The body frame is the principal frame; the box's own axes are its grid's.
  const geometry::Rigid<D>& bodyToGrid = cube->bodyToGrid();
  const int faceSamples = D == 3 ? 8 : 1;
  std::vector<double> faceForce;
  for (int k = 0; k < faceSamples; ++k) {
    dynamics::Particles<D> single;
    dynamics::ParticleDef<D> def;
    def.shape = cube;
    // World = turn about y of the grid frame; the lowest face (grid y = -L/2) at y = -delta.
    def.position = (0.5 * side + bodyToGrid.translation(1) - faceDelta) * Vec<D>::Unit(1);
    if constexpr (D == 2) {
      def.orientation = std::atan2(bodyToGrid.rotation(1, 0), bodyToGrid.rotation(0, 0));
    } else {
      const double angle = 2.0 * kPi * 0.6180339887498949 * k;
      const Eigen::Matrix3d turn = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
      def.orientation = Eigen::Quaterniond(turn * bodyToGrid.rotation).normalized();
      def.position -= turn * bodyToGrid.translation - bodyToGrid.translation(1) * Vec<D>::Unit(1);
    }
    single.add(def);
    solver.compute(single, noPairs, planes, {}, 1e-6);
    double f = 0.0;
    for (const auto& c : solver.planeContacts()) f += c.force.dot(floor.normal);
    faceForce.push_back(f);
  }
  {
    double mean = 0.0;
    for (double v : faceForce) mean += v / double(faceForce.size());
    const auto [lo, hi] = std::minmax_element(faceForce.begin(), faceForce.end());
    out.push_back(metricOf("force_face", mean, cubeLawPerArea * faceDelta * std::pow(side, D - 1)));
    const double ripple = mean > 0.0 ? (*hi - *lo) / mean : 1.0;
    out.push_back({"ripple_face", ripple, 0.0, ripple});
  }
  return out;
}

// ---- restitution ----

template <int D>
std::vector<MetricValue> restitutionMetrics(const AccuracySetting& setting) {
  const double R = 0.005, speed = 1.0, target = 0.5;
  const auto shape = sphereShape<D>(R, setting.cellsAcross, setting.nodesPerCell, setting.exactNodes);
  dynamics::WorldDef<D> def;
  def.contact.formulation = setting.formulation;
  def.contact.interpolation = setting.interpolation;
  def.contact.kn = stiffnessPerArea<D>() * dynamics::referenceNodeWeight<D>(shape->grid().spacing());
  def.contact.hasFriction = false;
  def.contact.hasDamping = true;
  def.contact.dampingRatio = dynamics::dampingRatioForRestitution(target);
  def.dtSafety = setting.dtFraction;
  dynamics::World<D> world(def);
  dynamics::PlaneDef<D> floor;
  floor.plane.point = Vec<D>::Zero();
  floor.plane.normal = Vec<D>::Unit(1);
  world.addPlane(floor);
  dynamics::ParticleDef<D> p;
  p.shape = shape;
  p.position = (R * 1.02) * Vec<D>::Unit(1);
  p.orientation = orientationNumber<D>(3);
  p.velocity = -speed * Vec<D>::Unit(1);
  world.addParticle(p);

  // Run until the sphere has touched, left the plane and moves up.
  bool touched = false;
  const std::uint64_t limit = 10'000'000;
  for (std::uint64_t n = 0; n < limit; ++n) {
    world.step();
    const bool touching = !world.contacts().planeContacts().empty();
    touched = touched || touching;
    if (touched && !touching && world.particles().velocity[0][1] > 0.0) break;
  }
  const double e = world.particles().velocity[0][1] / speed;
  return {metricOf("restitution", e, target)};
}

// ---- spherical caps ----

template <int D>
std::vector<MetricValue> splitMetrics(const AccuracySetting& setting, double& splitSeconds) {
  const double R = 0.5, d = 0.15;
  const auto shape = sphereShape<D>(R, setting.cellsAcross, setting.nodesPerCell, setting.exactNodes);
  breakage::FractureSurface<D> surface;
  surface.plane = geometry::HalfSpace<D>{Vec<D>::Unit(1), d};
  // Median of five splits timed in CPU seconds on one thread.
  std::vector<double> times;
  breakage::SplitResult<D> result;
  {
    const SingleThreadScope oneThread;
    for (int r = 0; r < 5; ++r) {
      const double t0 = threadCpuSeconds();
      result = breakage::splitShape(*shape, surface);
      times.push_back(threadCpuSeconds() - t0);
    }
  }
  splitSeconds = medianOf(times);
  if (!result.isSplit || result.fragments.size() != 2) {
    throw std::runtime_error("the sphere split by y = 0.15 gave " + std::to_string(result.fragments.size()) +
                             " fragments, expected 2");
  }
  // Exact caps: height h = R - d (side +1) and R + d (side -1).
  auto capVolume = [&](double h) {
    if constexpr (D == 3) {
      return kPi * h * h * (3 * R - h) / 3.0;
    } else {
      return R * R * std::acos((R - h) / R) - (R - h) * std::sqrt(2 * R * h - h * h);
    }
  };
  auto capCentroid = [&](double h) {
    if constexpr (D == 3) {
      return 3.0 * (2 * R - h) * (2 * R - h) / (4.0 * (3 * R - h));
    } else {
      return 2.0 * std::pow(2 * R * h - h * h, 1.5) / (3.0 * capVolume(h));
    }
  };
  double volumeError = 0.0, centroidError = 0.0, smallVolume = 0.0;
  for (const auto& f : result.fragments) {
    const double h = f.side > 0 ? R - d : R + d;
    const double exact = capVolume(h);
    volumeError = std::max(volumeError, std::abs(f.volume - exact) / exact);
    const Vec<D> c = double(f.side) * capCentroid(h) * Vec<D>::Unit(1);
    centroidError = std::max(centroidError, (f.childToParent.translation - c).norm() / R);
    if (f.side > 0) smallVolume = f.volume;
  }
  const double exactSmall = capVolume(R - d);
  return {{"cap_volume", smallVolume, exactSmall, volumeError},
          {"cap_centroid", centroidError, 0.0, centroidError},
          {"split_mass", result.rawRelativeError, 0.0, std::abs(result.rawRelativeError)}};
}

// ---- the packing ----

template <int D>
PackingResult packingRun(const AccuracySetting& setting, int grains, double settleSeconds) {
  if (grains < 1) throw std::invalid_argument("packingRun: grains must be >= 1, got " + std::to_string(grains));
  if (!(settleSeconds >= 0.0)) {
    throw std::invalid_argument("packingRun: settling time must be >= 0 s, got " + std::to_string(settleSeconds));
  }
  const double diameter = 0.01, spacing = diameter / setting.cellsAcross;
  // Eight grain shapes, equivalent diameters 0.8-1.2 cm, one grid spacing.
  std::vector<std::shared_ptr<const geometry::Shape<D>>> shapes;
  double shapeBytes = 0.0;
  for (int k = 0; k < 8; ++k) {
    geometry::ShapeDef<D> def;
    def.kind = geometry::ShapeKind::RandomGrain;
    def.grain.equivalentDiameter = diameter * (0.8 + 0.4 * k / 7.0);
    def.grain.elongation = 1.2;
    def.grain.roughness = 0.08;
    def.grain.seed = 11 + std::uint64_t(k);
    def.spacing = spacing;
    def.options.nodesPerCell = setting.nodesPerCell;
    def.exactNodes = setting.exactNodes;
    shapes.push_back(geometry::buildShape(def));
    shapeBytes += double(shapes.back()->bytes()) / 8.0;
  }

  // World: linear law with friction and damping for e = 0.5, local damping, gravity.
  dynamics::WorldDef<D> def;
  def.contact.formulation = setting.formulation;
  def.contact.interpolation = setting.interpolation;
  def.contact.kn = kPackingSoftening * stiffnessPerArea<D>() * dynamics::referenceNodeWeight<D>(spacing);
  def.contact.ks = 0.8 * def.contact.kn;
  def.contact.friction = 0.5;
  def.contact.dampingRatio = dynamics::dampingRatioForRestitution(0.5);
  def.dtSafety = setting.dtFraction;
  def.gravity = -9.81 * Vec<D>::Unit(1);
  def.localDamping = 0.3;
  dynamics::World<D> world(def);

  // Box of planes: floor y = 0, side walls at 0 and `width` on the other axes.
  const double pitch = 1.5 * diameter;
  const int columns = D == 2 ? 10 : 4;
  const double width = columns * pitch;
  dynamics::PlaneDef<D> floor;
  floor.name = "floor";
  floor.plane.point = Vec<D>::Zero();
  floor.plane.normal = Vec<D>::Unit(1);
  world.addPlane(floor);
  for (int a = 0; a < D; ++a) {
    if (a == 1) continue;
    dynamics::PlaneDef<D> lo, hi;
    lo.plane.point = Vec<D>::Zero();
    lo.plane.normal = Vec<D>::Unit(a);
    hi.plane.point = width * Vec<D>::Unit(a);
    hi.plane.normal = -Vec<D>::Unit(a);
    world.addPlane(lo);
    world.addPlane(hi);
  }

  // Grains on a loose lattice, columns x (columns) per layer, fixed orientations.
  const int perLayer = D == 2 ? columns : columns * columns;
  for (int n = 0; n < grains; ++n) {
    const int layer = n / perLayer, slot = n % perLayer;
    dynamics::ParticleDef<D> p;
    p.shape = shapes[std::size_t(n % 8)];
    p.position = Vec<D>::Zero();
    p.position[0] = (slot % columns + 0.5) * pitch;
    p.position[1] = (layer + 0.5) * pitch + 0.25 * diameter * (layer % 2);
    if constexpr (D == 3) p.position[2] = (slot / columns + 0.5) * pitch;
    p.orientation = orientationNumber<D>(n);
    world.addParticle(p);
  }
  double potential0 = 0.0, weight = 0.0;
  for (std::size_t i = 0; i < world.particles().size(); ++i) {
    potential0 += world.particles().mass[i] * 9.81 * world.particles().position[i][1];
    weight += world.particles().mass[i] * 9.81;
  }

  // A fixed simulated time: the fall of the top layer plus settling, run on
  // one thread and timed in blocks of 50 steps by the thread's CPU clock.
  const double layers = std::ceil(double(grains) / perLayer);
  const double simulated = 2.0 * std::sqrt(2.0 * layers * pitch / 9.81) + settleSeconds;
  const auto steps = std::uint64_t(std::ceil(simulated / world.dt()));
  const std::uint64_t block = 50;
  std::vector<double> blockSeconds;
  double nodeChecks = 0.0;
  {
    const SingleThreadScope oneThread;
    for (std::uint64_t done = 0; done < steps;) {
      const std::uint64_t n = std::min(block, steps - done);
      const double t0 = threadCpuSeconds();
      for (std::uint64_t s = 0; s < n; ++s) {
        world.step();
        nodeChecks += double(world.contacts().nodeChecks());
      }
      if (n == block) blockSeconds.push_back((threadCpuSeconds() - t0) / double(n));
      done += n;
    }
  }

  // Final state: floor stress, coordination, vertical load balance, kinetic energy.
  PackingResult r;
  const auto& loads = world.boundaryLoads();
  double vertical = 0.0;
  for (const auto& f : loads.planeForce) vertical -= f[1];
  r.floorStress = -loads.planeForce[0][1] / std::pow(width, D - 1);
  std::size_t touching = 0;
  for (const auto& c : world.contacts().particleContacts()) touching += c.nodeCount > 0 ? 1 : 0;
  r.coordination = 2.0 * double(touching) / double(world.particles().size());
  r.loadBalance = std::abs(vertical - weight) / weight;
  double kinetic = 0.0, potential = 0.0;
  for (std::size_t i = 0; i < world.particles().size(); ++i) {
    kinetic += world.particles().kineticEnergy(i);
    potential += world.particles().mass[i] * 9.81 * world.particles().position[i][1];
  }
  r.kineticRatio = kinetic / std::max(potential0 - potential, 1e-300);
  r.cost.steps = double(steps);
  r.cost.stepSeconds = blockSeconds.empty() ? 0.0 : medianOf(blockSeconds);
  r.cost.runSeconds = r.cost.stepSeconds * double(steps);
  r.cost.nodeChecksPerStep = nodeChecks / double(steps);
  r.cost.bytesPerParticle = shapeBytes + double(storeBytesPerParticle<D>());
  return r;
}

template std::vector<MetricValue> massMetrics<2>(double, double);
template std::vector<MetricValue> massMetrics<3>(double, double);
template std::vector<MetricValue> contactMetrics<2>(const AccuracySetting&);
template std::vector<MetricValue> contactMetrics<3>(const AccuracySetting&);
template std::vector<MetricValue> restitutionMetrics<2>(const AccuracySetting&);
template std::vector<MetricValue> restitutionMetrics<3>(const AccuracySetting&);
template std::vector<MetricValue> splitMetrics<2>(const AccuracySetting&, double&);
template std::vector<MetricValue> splitMetrics<3>(const AccuracySetting&, double&);
template PackingResult packingRun<2>(const AccuracySetting&, int, double);
template PackingResult packingRun<3>(const AccuracySetting&, int, double);

}  // namespace lsdem::study
