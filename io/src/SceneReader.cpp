/// @file SceneReader.cpp
/// @brief TOML scene file -> SceneDef (docs/scenes.md lists every key).

#include "lsdem/io/Scene.h"

#include "NumberText.h"
#include "ShapeTable.h"
#include "TomlReader.h"

#include "lsdem/geometry/Components.h"
#include "lsdem/io/GrainFile.h"
#include "lsdem/io/ShapeFile.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <filesystem>
#include <map>
#include <numbers>
#include <optional>
#include <tuple>

namespace lsdem::io {
namespace {

using detail::TomlReader;
using geometry::Box;
using geometry::Vec;

constexpr double kDegree = std::numbers::pi / 180.0;

template <int D>
Vec<D> vec(TomlReader& r, const std::string& key) {
  const std::vector<double> v = r.numbers(key, D);
  Vec<D> out;
  for (int a = 0; a < D; ++a) out[a] = v[std::size_t(a)];
  return out;
}
template <int D>
Vec<D> vec(TomlReader& r, const std::string& key, const Vec<D>& fallback) {
  return r.has(key) ? vec<D>(r, key) : fallback;
}
// A direction: any finite non-zero vector, normalised without overflow or
// underflow (components near the double range, e.g. [1e308, 1e308], give
// their true direction).
template <int D>
Vec<D> unitVec(TomlReader& r, const std::string& key, const Vec<D>& fallback) {
  const Vec<D> v = vec<D>(r, key, fallback);
  if (!(v.cwiseAbs().maxCoeff() > 0.0)) r.fail(key, "must not be the zero vector");
  const Vec<D> u = v.stableNormalized();
  if (!u.allFinite() || !(std::abs(u.norm() - 1.0) < 1e-12)) r.fail(key, "has no direction that can be computed");
  return u;
}

// The extent of `shape` along the line through its centroid on its body
// axis `axis` (its principal axes: 0 the longest), from its level set: from
// the line's first inside point on one side to its last on the other (a
// plate with a slot, or one whose centroid lies outside it, a U, is
// measured across it all); 0 when the line misses it.
template <int D>
double centralChord(const geometry::Shape<D>& shape, int axis) {
  const double h = shape.grid().spacing(), reach = shape.boundingRadius() + 2.0 * h;
  const Vec<D> u = Vec<D>::Unit(axis);
  // In from the far end in steps of a quarter cell to the first point
  // inside, then bisected; `sign` the side.
  const auto edge = [&](double sign) -> std::optional<double> {
    for (double s = reach - 0.25 * h; s > -reach; s -= 0.25 * h) {
      if (!(shape.value(sign * s * u) < 0.0)) continue;
      double inside = s, outside = s + 0.25 * h;
      for (int k = 0; k < 40; ++k) {
        const double mid = 0.5 * (inside + outside);
        (shape.value(sign * mid * u) < 0.0 ? inside : outside) = mid;
      }
      return 0.5 * (inside + outside);
    }
    return std::nullopt;
  };
  const std::optional<double> far = edge(1.0), near = edge(-1.0);
  return far && near ? *far + *near : 0.0;
}

// Names of planes, tools and materials become CSV column names and ParaView
// labels: no control characters (NUL, line breaks), commas or double quotes.
void checkNameText(TomlReader& r, const std::string& key, const std::string& name) {
  if (name.empty()) r.fail(key, "must not be empty");
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f || c == ',' || c == '"') {
      r.fail(key, "must not contain control characters, commas or double quotes (it names CSV columns)");
    }
  }
}

// A region {min = [...], max = [...]}.
template <int D>
Box<D> box(TomlReader& parent, const std::string& key) {
  const toml::table* t = parent.optionalTable(key);
  if (!t) parent.fail("", "missing table '" + key + "' ({ min = [...], max = [...] })");
  TomlReader r(*t, parent.file(), parent.pathOf(key));
  Box<D> b;
  b.lower = vec<D>(r, "min");
  b.upper = vec<D>(r, "max");
  if (!((b.upper.array() > b.lower.array()).all())) r.fail("max", "every component must exceed min's");
  r.finish();
  return b;
}

// Orientation keys: 2D `angle_deg` (counter-clockwise), 3D `rotation_deg` =
// [rx, ry, rz], applied about x, then y, then z (world axes).
template <int D>
geometry::Mat<D> rotation(TomlReader& r) {
  if constexpr (D == 2) {
    const double a = r.number("angle_deg", 0.0) * kDegree;
    return dynamics::Rotation<2>::matrix(a);
  } else {
    const Vec<3> e = vec<3>(r, "rotation_deg", Vec<3>::Zero()) * kDegree;
    return (Eigen::AngleAxisd(e.z(), Vec<3>::UnitZ()) * Eigen::AngleAxisd(e.y(), Vec<3>::UnitY()) *
            Eigen::AngleAxisd(e.x(), Vec<3>::UnitX()))
        .toRotationMatrix();
  }
}

template <int D>
dynamics::Orientation<D> orientationOf(const geometry::Mat<D>& m) {
  if constexpr (D == 2) {
    return std::atan2(m(1, 0), m(0, 0));
  } else {
    return Eigen::Quaterniond(m).normalized();
  }
}

// A body placed by the pose of its shape's build frame: x_world = R x_build + p.
// The motion poses the body frame (centroid, principal axes): compose with the
// shape's fixed body-to-grid map.
template <int D>
void placeBody(const geometry::Shape<D>& shape, const Vec<D>& p, const geometry::Mat<D>& r, Vec<D>& position,
               dynamics::Orientation<D>& orientation) {
  position = p + r * shape.bodyToGrid().translation;
  orientation = orientationOf<D>(r * shape.bodyToGrid().rotation);
}

template <int D>
dynamics::Spin<D> spinDeg(TomlReader& r, const std::string& key) {
  if constexpr (D == 2) {
    return r.number(key, 0.0) * kDegree;
  } else {
    return vec<3>(r, key, Vec<3>::Zero()) * kDegree;
  }
}

template <int D>
class SceneReader {
 public:
  SceneReader(const toml::table& root, const std::string& file) : root_(root), file_(file) {}

  SceneDef<D> read() {
    TomlReader top(root_, file_, "");
    scene_.file = file_;
    readSimulation(top);
    readContact(top);
    readMaterials(top);
    readShapes(top);
    readPlanes(top);
    readTools(top);
    readEffects(top);
    readGroups(top);
    readOutput(top);
    readParallel(top);
    top.finish();
    return std::move(scene_);
  }

 private:
  std::string relative(const std::string& path) const {
    std::filesystem::path p(path);
    if (p.is_relative()) p = std::filesystem::path(file_).parent_path() / p;
    return p.string();
  }

  void readSimulation(TomlReader& top) {
    const toml::table* t = top.optionalTable("simulation");
    TomlReader r(*t, file_, "simulation");
    r.skip("dimension");
    if (r.has("duration") == r.has("steps")) {
      r.fail(r.has("steps") ? "steps" : "", "give exactly one of 'duration' (s) and 'steps'");
    }
    if (r.has("duration")) scene_.duration = r.positive("duration");
    for (const char* key : {"duration", "steps", "dt"}) scene_.keyLines[r.pathOf(key)] = r.lineOf(key);
    if (r.has("steps")) {
      const std::int64_t n = r.integer("steps");
      if (n <= 0) r.fail("steps", "must be positive, got " + std::to_string(n));
      scene_.steps = std::uint64_t(n);
    }
    // dt: a number > 0, or "auto" (default).
    if (r.has("dt")) {
      const toml::node* n = root_["simulation"]["dt"].node();
      if (n->is_string()) {
        if (r.string("dt") != "auto") r.fail("dt", "must be a number of seconds or \"auto\"");
      } else {
        scene_.world.dt = r.positive("dt");
      }
    }
    scene_.world.dtSafety = r.inRange("dt_safety", 1e-6, 1.0, 0.2);
    scene_.world.forceDt = r.boolean("force_dt", false);
    const std::int64_t threads = r.integer("threads", 0);
    if (threads < 0 || threads > kMaxThreads) {
      r.fail("threads", "must be in [0, " + std::to_string(kMaxThreads) + "] (0: all cores), got " + std::to_string(threads));
    }
    scene_.threads = int(threads);
    const std::int64_t seed = r.integer("seed", 1);
    if (seed < 0) r.fail("seed", "must be >= 0");
    scene_.seed = std::uint64_t(seed);
    scene_.world.checkFinite = r.boolean("check_finite", false);
    if (r.has("skin")) {
      scene_.world.broadPhase.skin = r.nonNegative("skin", "m");
    }
    if (r.has("domain")) scene_.domain = box<D>(r, "domain");
    // Opt-in density scaling of small fragments.
    if (r.has("density_scaling_max") && !r.has("density_scaling_below")) {
      r.fail("density_scaling_max", "needs `density_scaling_below` (the fragment size it applies below)");
    }
    if (r.has("density_scaling_below")) {
      dynamics::DensityScalingDef ds;
      ds.belowDiameter = r.positive("density_scaling_below");
      ds.maxFactor = r.number("density_scaling_max", ds.maxFactor);
      if (!(ds.maxFactor >= 1.0)) r.fail("density_scaling_max", "must be >= 1, got " + numberText(ds.maxFactor));
      scene_.world.densityScaling = ds;
    }
    r.finish();
  }

  void readContact(TomlReader& top) {
    dynamics::ContactLawDef& law = scene_.world.contact;
    const toml::table* t = top.optionalTable("contact");
    if (!t) top.fail("", "missing table [contact] (at least kn)");
    TomlReader r(*t, file_, "contact");
    scene_.keyLines["contact"] = int(t->source().begin.line);
    const std::string model = r.string("model", "linear");
    if (model == "linear") {
      law.normal = dynamics::NormalModel::Linear;
    } else if (model == "hertz") {
      law.normal = dynamics::NormalModel::Hertz;
    } else {
      r.fail("model", "must be \"linear\" or \"hertz\", got \"" + model + "\"");
    }
    const std::string formulation = r.string("formulation", "per_node");
    if (formulation == "per_node") {
      law.formulation = dynamics::ForceFormulation::PerNode;
    } else if (formulation == "area_weighted") {
      law.formulation = dynamics::ForceFormulation::AreaWeighted;
    } else {
      r.fail("formulation", "must be \"per_node\" or \"area_weighted\", got \"" + formulation + "\"");
    }
    const std::string interpolation = r.string("interpolation", "trilinear");
    if (interpolation == "trilinear") {
      law.interpolation = dynamics::LevelSetInterpolation::Trilinear;
    } else if (interpolation == "tricubic") {
      law.interpolation = dynamics::LevelSetInterpolation::Tricubic;
    } else {
      r.fail("interpolation", "must be \"trilinear\" or \"tricubic\", got \"" + interpolation + "\"");
    }
    if (law.normal == dynamics::NormalModel::Linear) {
      law.kn = r.positive("kn");
    } else {
      law.youngsModulus = r.positive("youngs_modulus");
      law.poissonRatio = r.inRange("poisson_ratio", 0.0, 0.499, 0.25);
      if (r.has("kn")) {
        r.fail("kn", "has no meaning under model = \"hertz\" (its stiffness comes from youngs_modulus and "
                     "poisson_ratio)");
      }
      law.kn = 1.0;  // (unused by the Hertz law; ContactLawDef wants it positive)
    }
    // Friction and damping exist only when declared.
    law.hasFriction = r.has("friction");
    law.friction = r.number("friction", 0.0);
    if (law.friction < 0.0) r.fail("friction", "must be >= 0, got " + numberText(law.friction));
    if (r.has("friction_from") && !law.hasFriction) r.fail("friction_from", "needs `friction`");
    law.frictionFrom = r.number("friction_from", 0.0);
    if (law.frictionFrom < 0.0) {
      r.fail("friction_from", "must be >= 0 s, got " + numberText(law.frictionFrom));
    }
    law.ks = r.number("ks", 0.8 * law.kn);
    if (law.ks < 0.0) r.fail("ks", "must be >= 0 N/m, got " + numberText(law.ks));
    // The friction spring: Hertz without ks takes Mindlin's, from the material.
    const bool hertz = law.normal == dynamics::NormalModel::Hertz;
    const std::string tangential = r.string("tangential", hertz && !r.has("ks") ? "mindlin" : "linear");
    if (tangential == "mindlin") {
      if (!hertz) r.fail("tangential", "\"mindlin\" needs model = \"hertz\" (its stiffness comes from E and nu)");
      if (r.has("ks")) r.fail("ks", "has no meaning with tangential = \"mindlin\" (drop it, or choose \"linear\")");
      law.tangential = dynamics::TangentialModel::Mindlin;
    } else if (tangential == "linear") {
      // (Under Hertz there is no kn to take a default ks from.)
      if (hertz && law.hasFriction && !r.has("ks")) {
        r.fail("tangential", "\"linear\" under model = \"hertz\" needs `ks` (N/m)");
      }
      law.tangential = dynamics::TangentialModel::Linear;
    } else {
      r.fail("tangential", "must be \"linear\" or \"mindlin\", got \"" + tangential + "\"");
    }
    law.hasDamping = r.has("damping_ratio");
    law.dampingRatio = r.number("damping_ratio", 0.0);
    if (law.dampingRatio < 0.0 || law.dampingRatio >= 1.0) {
      r.fail("damping_ratio", "must be in [0, 1), got " + numberText(law.dampingRatio));
    }
    r.finish();
  }

  void readMaterials(TomlReader& top) {
    const toml::table* t = top.optionalTable("materials");
    if (!t) return;
    TomlReader all(*t, file_, "materials");
    for (const auto& [k, v] : *t) {
      const std::string name(k.str());
      checkNameText(all, name, name);
      const toml::table* m = all.optionalTable(name);
      TomlReader r(*m, file_, "materials." + name);
      materialIndex_[name] = scene_.materials.size();
      scene_.materials.push_back(name);
      densities_.push_back(r.positive("density"));
      r.finish();
    }
  }

  void readShapes(TomlReader& top) {
    const toml::table* t = top.optionalTable("shapes");
    if (!t) top.fail("", "missing table [shapes]: a scene needs at least one shape");
    TomlReader all(*t, file_, "shapes");
    // The declared shapes are read here and built together after the
    // table (buildDeclaredShapes: several at a time); their places in
    // scene_.shapes are held meanwhile.
    std::vector<ShapeDecl> declared;
    std::vector<std::size_t> declaredAt;
    for (const auto& [k, v] : *t) {
      const std::string name(k.str());
      const std::string path = "shapes." + name;
      const toml::table* s = all.optionalTable(name);
      const toml::node* kind = s->get("kind");
      const int line = int(s->source().begin.line);
      std::vector<std::size_t>& indices = shapeIndex_[name];
      if (kind && kind->is_string() && (*kind->value<std::string>() == "grain_file" || *kind->value<std::string>() == "grain_folder")) {
        // Grain files written by lsdem (or any grid in the minimal form).
        TomlReader r(*s, file_, path);
        const bool folder = r.string("kind") == "grain_folder";
        const std::string where = relative(r.string("path"));
        const double scale = r.positive("scale", 1.0);
        r.finish();
        // (A missing one at the scene's key: the grain file's own message named no scene line.)
        std::error_code ec;
        if (folder ? !std::filesystem::is_directory(where, ec) : !std::filesystem::is_regular_file(where, ec)) {
          r.fail("path", std::string(folder ? "no folder '" : "no file '") + where + "'");
        }
        std::vector<std::shared_ptr<const geometry::Shape<D>>> shapes;
        if (folder) {
          bool any = false;
          for (const auto& e : std::filesystem::directory_iterator(where, ec)) {
            any = any || (e.is_regular_file() && e.path().extension() == ".lsg");
          }
          if (!any) r.fail("path", "no grain files (*.lsg) in '" + where + "'");
          shapes = readGrainFolder<D>(where);
        } else {
          shapes.push_back(readGrainFile<D>(where));
        }
        for (std::size_t g = 0; g < shapes.size(); ++g) {
          indices.push_back(scene_.shapes.size());
          scene_.shapeNames.push_back(folder ? name + "/" + std::to_string(g) : name);
          scene_.shapes.push_back(scale == 1.0 ? shapes[g] : scaledShape(*shapes[g], scale));
        }
        continue;
      }
      (void)line;
      indices.push_back(scene_.shapes.size());
      scene_.shapeNames.push_back(name);
      declared.push_back(detail::readShapeTable(*s, file_, path, D));
      declaredAt.push_back(scene_.shapes.size());
      scene_.shapes.emplace_back();
    }
    std::vector<std::shared_ptr<const geometry::Shape<D>>> built = buildDeclaredShapes<D>(declared, &scene_.notes);
    for (std::size_t s = 0; s < built.size(); ++s) scene_.shapes[declaredAt[s]] = std::move(built[s]);
  }

  // The shapes a key names ("grain", or a list of names; a folder counts as all its grains).
  std::vector<std::size_t> shapeList(TomlReader& r, const std::string& key) {
    std::vector<std::size_t> out;
    for (const std::string& name : r.strings(key)) {
      const auto it = shapeIndex_.find(name);
      if (it == shapeIndex_.end()) r.fail(key, "no shape named '" + name + "' in [shapes]");
      out.insert(out.end(), it->second.begin(), it->second.end());
    }
    if (out.empty()) r.fail(key.empty() ? "" : key, "names no shape");
    return out;
  }

  void readPlanes(TomlReader& top) {
    for (const toml::table* t : top.tables("planes")) {
      TomlReader r(*t, file_, "planes[" + std::to_string(scene_.planes.size()) + "]");
      dynamics::PlaneDef<D> p;
      p.name = r.string("name", "plane" + std::to_string(scene_.planes.size()));
      p.plane.point = vec<D>(r, "point");
      p.plane.normal = unitVec<D>(r, "normal", Vec<D>::UnitY());
      p.plane.velocity = vec<D>(r, "velocity", Vec<D>::Zero());
      p.material = readBoundaryMaterial(r);
      if (r.has("velocity")) scene_.keyLines[r.pathOf("velocity")] = r.lineOf("velocity");
      r.finish();
      checkName(r, p.name);
      scene_.planes.push_back(p);
    }
  }

  // A boundary's own contact material (`material = { ... }` of a plane or
  // tool), checked against the [contact] law; absent: the grains'.
  std::optional<dynamics::BoundaryMaterial> readBoundaryMaterial(TomlReader& parent) {
    const toml::table* t = parent.optionalTable("material");
    if (!t) return std::nullopt;
    TomlReader r(*t, file_, parent.pathOf("material"));
    const dynamics::ContactLawDef& law = scene_.world.contact;
    const bool hertz = law.normal == dynamics::NormalModel::Hertz;
    dynamics::BoundaryMaterial m;
    m.rigid = r.boolean("rigid", false);
    // Stiffness: none for a rigid wall; E and nu (Hertz) or kn (linear) otherwise.
    const char* hertzKeys[] = {"youngs_modulus", "poisson_ratio"};
    const char* linearKeys[] = {"kn", "ks"};
    for (const char* key : hertz ? linearKeys : hertzKeys) {
      if (r.has(key)) {
        r.fail(key, std::string("is not read by the ") + (hertz ? "hertz" : "linear") + " model of [contact]");
      }
    }
    for (const char* key : hertz ? hertzKeys : linearKeys) {
      if (m.rigid && r.has(key)) r.fail(key, "has no meaning for a rigid wall (rigid = true)");
    }
    if (!m.rigid) {
      if (hertz) {
        m.youngsModulus = r.positive("youngs_modulus");
        m.poissonRatio = r.number("poisson_ratio");
        if (!(m.poissonRatio >= 0.0 && m.poissonRatio <= 0.499)) {
          r.fail("poisson_ratio", "must be in [0, 0.499], got " + numberText(m.poissonRatio));
        }
      } else {
        m.kn = r.positive("kn");
        if (r.has("ks")) {
          m.ks = r.number("ks");
          if (*m.ks < 0.0) r.fail("ks", "must be >= 0 N/m, got " + numberText(*m.ks));
        }
      }
    }
    if (r.has("friction")) {
      if (!law.hasFriction) r.fail("friction", "needs `friction` in [contact] (0 for frictionless grains)");
      m.friction = r.number("friction");
      if (*m.friction < 0.0) r.fail("friction", "must be >= 0, got " + numberText(*m.friction));
    }
    r.finish();
    return m;
  }

  void checkName(TomlReader& r, const std::string& name) {
    checkNameText(r, "name", name);
    if (!boundaryNames_.insert(name).second) r.fail("name", "another plane or tool is named '" + name + "'");
  }

  void readTools(TomlReader& top) {
    for (const toml::table* t : top.tables("tools")) {
      const std::string path = "tools[" + std::to_string(scene_.tools.size()) + "]";
      TomlReader r(*t, file_, path);
      dynamics::ToolDef<D> tool;
      tool.name = r.string("name", "tool" + std::to_string(scene_.tools.size()));
      checkName(r, tool.name);
      const std::vector<std::size_t> shapes = shapeList(r, "shape");
      if (shapes.size() != 1) r.fail("shape", "a tool has exactly one shape");
      tool.shape = scene_.shapes[shapes[0]];
      const toml::table* m = r.optionalTable("motion");
      // (For a resume's check of the tools' poses: checkToolPoses.)
      scene_.keyLines[path] = int(t->source().begin.line);
      if (m) scene_.keyLines[r.pathOf("motion")] = int(m->source().begin.line);
      // (Read first: the jaw crusher's motion poses it. No motion table: fixed.)
      const std::string type = m ? TomlReader(*m, file_, r.pathOf("motion")).string("type") : std::string("fixed");
      // Where the shape's build frame sits at the start (not for the jaw crusher,
      // whose motion defines its pose).
      Vec<D> p0 = Vec<D>::Zero();
      dynamics::Orientation<D> q0 = dynamics::Rotation<D>::identity();
      geometry::Mat<D> r0 = geometry::Mat<D>::Identity();
      if (type != "jaw_crusher") {
        r0 = rotation<D>(r);
        placeBody(*tool.shape, vec<D>(r, "position", Vec<D>::Zero()), r0, p0, q0);
      }
      tool.material = readBoundaryMaterial(r);
      r.finish();
      tool.motion = readMotion(m, r.pathOf("motion"), type, *tool.shape, p0, q0);
      // Key frames pose the tool at every time: a pose of its own must be the first frame's.
      if (const auto* k = std::get_if<dynamics::KeyFramed<D>>(&tool.motion)) {
        const dynamics::KeyFrame<D>& first = k->frames.front();
        const char* angleKey = D == 2 ? "angle_deg" : "rotation_deg";
        const geometry::Mat<D> a = dynamics::Rotation<D>::matrix(first.orientation);
        const geometry::Mat<D> b = dynamics::Rotation<D>::matrix(q0);
        if (r.has(angleKey) && !((a - b).norm() <= 1e-12)) {
          r.fail(angleKey, "differs from the first key frame's orientation; a key_frames tool follows its frames "
                           "(remove it or make them agree)");
        }
        if (r.has("position") && !((first.position - p0).norm() <= 1e-12 * (1.0 + first.position.norm()))) {
          r.fail("position", "differs from the first key frame's position; a key_frames tool follows its frames "
                             "(remove `position` or make them agree)");
        }
      }
      scene_.tools.push_back(std::move(tool));
    }
  }

  dynamics::Motion<D> readMotion(const toml::table* t, const std::string& path, const std::string& type,
                                 const geometry::Shape<D>& shape, const Vec<D>& p0, const dynamics::Orientation<D>& q0) {
    if (!t) return dynamics::ConstantVelocity<D>{p0, q0, Vec<D>::Zero(), dynamics::Rotation<D>::zeroSpin()};
    TomlReader r(*t, file_, path);
    r.skip("type");
    dynamics::Motion<D> motion;
    if (type == "fixed") {
      motion = dynamics::ConstantVelocity<D>{p0, q0, Vec<D>::Zero(), dynamics::Rotation<D>::zeroSpin()};
    } else if (type == "constant_velocity") {
      motion = dynamics::ConstantVelocity<D>{p0, q0, vec<D>(r, "velocity", Vec<D>::Zero()),
                                             spinDeg<D>(r, "angular_velocity_deg")};
    } else if (type == "swing") {
      dynamics::Swing<D> s;
      s.pivot = vec<D>(r, "pivot");
      if constexpr (D == 3) s.axis = unitVec<3>(r, "axis", Vec<3>::UnitZ());
      s.position = p0;
      s.orientation = q0;
      s.meanAngle = r.number("mean_angle_deg", 0.0) * kDegree;
      s.amplitude = r.number("amplitude_deg") * kDegree;
      s.frequency = r.positive("frequency");
      s.phase = r.number("phase_deg", 0.0) * kDegree;
      motion = s;
    } else if (type == "jaw_crusher") {
      dynamics::JawCrusher<D> j;
      j.rpm = r.positive("rpm", j.rpm);
      j.eccentricThrow = r.positive("eccentric_throw", j.eccentricThrow);
      j.nipAngleDegrees = r.inRange("nip_angle_deg", 1.0, 60.0, j.nipAngleDegrees);
      j.nipAngleVariationDegrees = r.inRange("nip_angle_variation_deg", 0.0, 10.0, j.nipAngleVariationDegrees);
      j.closedSideSetting = r.positive("closed_side_setting", j.closedSideSetting);
      j.jawLength = r.positive("jaw_length", j.jawLength);
      j.jawThickness = r.positive("jaw_thickness", j.jawThickness);
      // (The plate's principal frame is (length, thickness) in 2D, (length,
      // width, thickness) in 3D: JawCrusher::plateFrame turns the thickness
      // into the motion's face normal.)
      const double length = centralChord(shape, 0), thickness = centralChord(shape, D - 1);
      if constexpr (D == 3) {
        // A 3D plate lies with its longest axis along the face: one wider
        // than long would stand turned in its own plane.
        const double width = centralChord(shape, 1);
        if (std::abs(width - j.jawLength) <= 0.02 * width + shape.grid().spacing() &&
            std::abs(length - j.jawLength) > 0.02 * length + shape.grid().spacing()) {
          r.fail("jaw_length", "is the plate's width (" + roughText(width) + " m, its middle axis), not its length (" +
                                   roughText(length) + " m, its longest): a 3D jaw plate lies with its longest axis "
                                   "along the face; give a plate longer than it is wide");
        }
      }
      // The motion poses the plate by these: a plate of another size floated
      // off the stationary jaw (jaw_length = 3 for a 1 m plate left the
      // chamber open below it). Its chords through its centroid along its
      // longest and shortest principal axes (the level set's: a plate's nodes
      // may be sparse).
      for (const auto& [key, value, size, what] :
           {std::tuple{"jaw_length", j.jawLength, length, "long (its longest axis)"},
            std::tuple{"jaw_thickness", j.jawThickness, thickness, "thick (its shortest axis)"}}) {
        if (std::abs(value - size) > 0.02 * size + shape.grid().spacing()) {
          r.fail(key, "is " + numberText(value) + " m, but the tool's shape is " + roughText(size) + " m " + what +
                          ": the motion poses the jaw plate by it; make them agree");
        }
      }
      j.stationaryBottom = vec<D>(r, "stationary_bottom", Vec<D>::Zero());
      j.stationaryAngleDegrees = r.number("stationary_angle_deg", j.stationaryAngleDegrees);
      j.phase = r.number("phase_deg", 0.0) * kDegree;
      motion = j;
    } else if (type == "key_frames") {
      dynamics::KeyFramed<D> k;
      const std::vector<const toml::table*> frames = r.tables("frames");
      if (frames.empty()) r.fail("frames", "key_frames needs at least one [[...frames]] entry");
      for (std::size_t f = 0; f < frames.size(); ++f) {
        TomlReader fr(*frames[f], file_, path + ".frames[" + std::to_string(f) + "]");
        dynamics::KeyFrame<D> frame;
        frame.time = fr.number("time");
        if (!k.frames.empty() && !(frame.time > k.frames.back().time)) fr.fail("time", "frame times must increase");
        const geometry::Mat<D> rf = rotation<D>(fr);
        placeBody(shape, vec<D>(fr, "position"), rf, frame.position, frame.orientation);
        fr.finish();
        k.frames.push_back(frame);
      }
      motion = k;
    } else if (type == "platen") {
      dynamics::Platen<D> p;
      p.position = p0;
      p.orientation = q0;
      p.direction = unitVec<D>(r, "direction", -Vec<D>::UnitY());
      p.speed = r.nonNegative("speed", "m/s");
      p.travel = r.positive("travel", std::numeric_limits<double>::infinity());
      p.startTime = r.nonNegative("start", 0.0, "s");
      motion = p;
    } else if (type == "servo") {
      dynamics::ServoPlatenDef<D> s;
      s.position = p0;
      s.orientation = q0;
      s.direction = unitVec<D>(r, "direction", -Vec<D>::UnitY());
      s.targetForce = r.nonNegative("target_force", "N");
      s.gain = r.positive("gain");
      s.maxSpeed = r.positive("max_speed");
      motion = dynamics::ServoPlaten<D>(s);
    } else {
      r.fail("type", "unknown motion '" + type +
                         "' (fixed, constant_velocity, swing, jaw_crusher, key_frames, platen, servo)");
    }
    r.finish();
    return motion;
  }

  void readEffects(TomlReader& top) {
    const toml::table* t = top.optionalTable("effects");
    if (!t) return;
    TomlReader r(*t, file_, "effects");
    if (r.has("gravity")) scene_.world.gravity = vec<D>(r, "gravity");
    scene_.keyLines[r.pathOf("gravity")] = r.lineOf("gravity");
    if (r.has("global_damping")) {
      scene_.world.globalDamping = r.nonNegative("global_damping", "1/s");
      scene_.keyLines[r.pathOf("global_damping")] = r.lineOf("global_damping");
    }
    if (r.has("local_damping")) {
      const double alpha = r.number("local_damping");
      if (!(alpha >= 0.0 && alpha < 1.0)) r.fail("local_damping", "must be in [0, 1), got " + numberText(alpha));
      scene_.world.localDamping = alpha;
    }
    if (r.has("outflow")) scene_.world.outflow = box<D>(r, "outflow");
    scene_.world.energyLedger = r.boolean("energy_ledger", true);
    if (r.has("discharge")) {
      if (!scene_.world.outflow) r.fail("discharge", "needs an outflow box (the discharge classifies what leaves it)");
      scene_.world.discharge = box<D>(r, "discharge");
    }
    if (const toml::table* b = r.optionalTable("breakage")) readBreakage(*b);
    r.finish();
  }

  void readBreakage(const toml::table& t) {
    TomlReader r(t, file_, "effects.breakage");
    breakage::BreakageDef<D> def;
    const std::string criterion = r.string("criterion", "von_mises");
    if (criterion == "von_mises") {
      def.criterion.kind = breakage::CriterionKind::VonMises;
    } else if (criterion == "max_principal") {
      def.criterion.kind = breakage::CriterionKind::MaxPrincipal;
    } else if (criterion == "tresca") {
      def.criterion.kind = breakage::CriterionKind::Tresca;
    } else {
      r.fail("criterion", "must be \"von_mises\", \"max_principal\" or \"tresca\", got \"" + criterion + "\"");
    }
    def.criterion.compressiveStrength = r.positive("compressive_strength", def.criterion.compressiveStrength);
    def.criterion.tensileStrength = r.positive("tensile_strength", def.criterion.tensileStrength);
    def.criterion.vonMisesStrength = r.positive("von_mises_strength", def.criterion.vonMisesStrength);
    def.weibull.referenceStrength = r.positive("reference_strength", def.weibull.referenceStrength);
    def.weibull.referenceDiameter = r.positive("reference_diameter", def.weibull.referenceDiameter);
    def.weibull.modulus =
        r.inRange("weibull_modulus", breakage::kMinWeibullModulus, breakage::kMaxWeibullModulus, def.weibull.modulus);
    const std::int64_t seed = r.integer("seed", std::int64_t(scene_.seed));
    if (seed < 0) r.fail("seed", "must be >= 0");
    def.seed = std::uint64_t(seed);
    def.minVolume = r.nonNegative("min_volume", 0.0, "");
    const std::int64_t minNodes = r.integer("min_nodes", 0);
    if (minNodes < 0 || minNodes > 1000000) r.fail("min_nodes", "must be in [0, 1e6]");
    def.minNodes = int(minNodes);
    def.haltBelowMinimum = r.boolean("halt_below_minimum", false);
    def.relaxNewContacts = r.boolean("relax_new_contacts", def.relaxNewContacts);
    def.minBreakableVolume = r.nonNegative("min_breakable_volume", 0.0, "");
    // Re-gridding of small fragments (Split.h, docs/breakage.md).
    def.split.regridCells = r.number("regrid_cells", def.split.regridCells);
    if (def.split.regridCells < 0.0 || def.split.regridCells > 1000.0) r.fail("regrid_cells", "must be in [0, 1000] (0 turns re-gridding off)");
    const std::int64_t maxFactor = r.integer("regrid_max_factor", def.split.regridMaxFactor);
    if (maxFactor < 1 || maxFactor > 64) r.fail("regrid_max_factor", "must be in [1, 64]");
    def.split.regridMaxFactor = int(maxFactor);
    const std::int64_t maxValues = r.integer("regrid_max_values", std::int64_t(def.split.regridMaxNodes));
    if (maxValues < 64 || maxValues > (std::int64_t(1) << 27)) r.fail("regrid_max_values", "must be in [64, 2^27]");
    def.split.regridMaxNodes = std::size_t(maxValues);
    const std::int64_t minFragmentNodes = r.integer("min_fragment_nodes", def.split.minFragmentNodes);
    if (minFragmentNodes < 1 || minFragmentNodes > 100000) r.fail("min_fragment_nodes", "must be in [1, 1e5]");
    def.split.minFragmentNodes = int(minFragmentNodes);
    // Re-gridded fragments' nodes: the parent's spacing in metres (default), or
    // the node density per new cell (finer contacts, more nodes: Split.h).
    const std::string regridNodes = r.string("regrid_nodes", "parent_spacing");
    if (regridNodes == "parent_spacing") {
      def.split.regridKeepsNodeSpacing = true;
    } else if (regridNodes == "per_new_cell") {
      def.split.regridKeepsNodeSpacing = false;
    } else {
      r.fail("regrid_nodes", "must be \"parent_spacing\" or \"per_new_cell\", got \"" + regridNodes + "\"");
    }
    // Fragment surfaces moved to enclose their share of the parent (Split.h).
    def.split.matchEnclosedVolume = r.boolean("match_enclosed_volume", def.split.matchEnclosedVolume);
    def.split.maxSurfaceShift = r.number("max_surface_shift", def.split.maxSurfaceShift);
    if (!(def.split.maxSurfaceShift >= 0.0 && def.split.maxSurfaceShift <= 1.0)) {
      r.fail("max_surface_shift", "must be in [0, 1] cells of the parent's grid");
    }
    def.buckling = r.boolean("buckling", false);
    def.bucklingRatio = r.number("buckling_ratio", def.bucklingRatio);
    if (!(def.bucklingRatio > 1.0)) r.fail("buckling_ratio", "must be > 1");
    for (const toml::table* m : r.tables("manual")) {
      TomlReader mr(*m, file_, "effects.breakage.manual[" + std::to_string(def.manual.size()) + "]");
      breakage::ManualBreak<D> b;
      const std::int64_t id = mr.integer("particle");
      if (id < 0) mr.fail("particle", "must be a particle id >= 0");
      b.particle = std::uint64_t(id);
      b.time = mr.nonNegative("time", "s");
      if (mr.has("surface")) {
        // A curved fracture surface: the zero level set of a [shapes] entry, placed in the world.
        const std::vector<std::size_t> shapes = shapeList(mr, "surface");
        if (shapes.size() != 1) mr.fail("surface", "names a shape pool; give one shape");
        b.surface = scene_.shapes[shapes[0]];
        b.surfaceToWorld.rotation = rotation<D>(mr);
        b.surfaceToWorld.translation = vec<D>(mr, "position", Vec<D>::Zero());
      } else {
        b.plane.normal = unitVec<D>(mr, "normal", Vec<D>::UnitX());
        b.plane.offset = b.plane.normal.dot(vec<D>(mr, "point"));
      }
      mr.finish();
      def.manual.push_back(b);
    }
    if (const toml::table* c = r.optionalTable("chipping")) def.chipping = readChipping(*c);
    r.finish();
    scene_.breakage = def;
  }

  // [effects.breakage.chipping]: chipping at single contacts (breakage/Chipping.h).
  breakage::ChippingDef readChipping(const toml::table& t) {
    TomlReader r(t, file_, "effects.breakage.chipping");
    breakage::ChippingDef c;
    c.weibull.referenceStrength = r.positive("reference_strength", c.weibull.referenceStrength);
    c.weibull.referenceDiameter = r.positive("reference_depth", c.weibull.referenceDiameter);
    c.weibull.modulus =
        r.inRange("weibull_modulus", breakage::kMinWeibullModulus, breakage::kMaxWeibullModulus, c.weibull.modulus);
    const std::string depth = r.string("depth", "fraction");
    if (depth == "fraction") {
      c.depth = breakage::ChipDepthMode::Fraction;
    } else if (depth == "hertz") {
      c.depth = breakage::ChipDepthMode::Hertz;
    } else {
      r.fail("depth", "must be \"fraction\" or \"hertz\", got \"" + depth + "\"");
    }
    const auto openUnit = [&](const char* key, double fallback) {
      const double v = r.number(key, fallback);
      if (!(v > 0.0 && v < 1.0)) r.fail(key, "must be in (0, 1), got " + numberText(v));
      return v;
    };
    if (c.depth == breakage::ChipDepthMode::Fraction) {
      c.depthFraction = openUnit("depth_fraction", c.depthFraction);
    } else {
      if (r.has("depth_fraction")) r.fail("depth_fraction", "has no meaning with depth = \"hertz\" (use hertz_factor)");
      c.hertzFactor = r.positive("hertz_factor", c.hertzFactor);
      // The grain's elastic constants: its own, or the Hertz contact law's.
      const dynamics::ContactLawDef& law = scene_.world.contact;
      const bool lawIsHertz = law.normal == dynamics::NormalModel::Hertz;
      if (!r.has("youngs_modulus") && !lawIsHertz) {
        r.fail("", "missing key 'youngs_modulus' (depth = \"hertz\" with a linear contact law)");
      }
      c.youngsModulus = r.positive("youngs_modulus", law.youngsModulus);
      c.poissonRatio = r.inRange("poisson_ratio", 0.0, 0.499, lawIsHertz ? law.poissonRatio : c.poissonRatio);
    }
    if (c.depth == breakage::ChipDepthMode::Fraction) {
      for (const char* key : {"hertz_factor", "youngs_modulus", "poisson_ratio"}) {
        if (r.has(key)) r.fail(key, "has no meaning with depth = \"fraction\" (it is read with depth = \"hertz\")");
      }
    }
    c.maxDepthFraction = openUnit("max_depth_fraction", c.maxDepthFraction);
    if (c.depth == breakage::ChipDepthMode::Fraction && c.depthFraction > c.maxDepthFraction) {
      r.fail(r.has("depth_fraction") ? "depth_fraction" : "max_depth_fraction",
             "depth_fraction = " + numberText(c.depthFraction) + " is above max_depth_fraction = " +
                 numberText(c.maxDepthFraction) + ", which caps every chip's depth: lower the one or raise the other");
    }
    c.minDepthCells = r.number("min_depth_cells", c.minDepthCells);
    if (!(c.minDepthCells >= 0.5 && c.minDepthCells <= 1000.0)) r.fail("min_depth_cells", "must be in [0.5, 1000]");
    c.maxWidthToDepth = r.positive("max_width_to_depth", c.maxWidthToDepth);
    r.finish();
    return c;
  }

  void readGroups(TomlReader& top) {
    std::size_t g = 0;
    for (const toml::table* t : top.tables("particles")) {
      TomlReader r(*t, file_, "particles[" + std::to_string(g++) + "]");
      ParticleGroupDef<D> group;
      group.line = int(t->source().begin.line);
      const std::string shapeKey = r.has("shapes") ? "shapes" : "shape";
      group.shapes = shapeList(r, shapeKey);
      for (const std::size_t s : group.shapes) checkOneBody(r, shapeKey, s);
      // Density: a named material's, or the group's own.
      if (r.has("material")) {
        const std::string name = r.string("material");
        const auto it = materialIndex_.find(name);
        if (it == materialIndex_.end()) r.fail("material", "no material named '" + name + "' in [materials]");
        group.material = int(it->second);
        group.density = densities_[it->second];
      }
      if (r.has("density")) group.density = r.positive("density");
      if (!r.has("material") && !r.has("density")) r.fail("", "give 'material' or 'density'");
      group.velocity = vec<D>(r, "velocity", Vec<D>::Zero());
      scene_.keyLines[r.pathOf("velocity")] = r.lineOf("velocity");
      const std::int64_t seed = r.integer("seed", std::int64_t(scene_.seed + g));
      if (seed < 0) r.fail("seed", "must be >= 0");
      group.seed = std::uint64_t(seed);
      if (r.has("diameter_range")) {
        const std::vector<double> d = r.numbers("diameter_range", 2);
        if (!(d[0] > 0.0 && d[1] >= d[0])) r.fail("diameter_range", "needs 0 < min <= max");
        group.diameterMin = d[0];
        group.diameterMax = d[1];
      }
      const std::string placement = r.string("placement", "list");
      if (placement == "list") {
        group.placement = Placement::List;
        for (const std::vector<double>& row : r.numberRows("positions", D)) {
          Vec<D> x;
          for (int a = 0; a < D; ++a) x[a] = row[std::size_t(a)];
          group.positions.push_back(x);
        }
        if constexpr (D == 2) {
          if (r.has("angles_deg")) {
            group.angles = r.numbers("angles_deg", int(group.positions.size()));
            for (double& a : group.angles) a *= kDegree;
          }
        } else {
          if (r.has("rotations_deg")) {
            const auto rows = r.numberRows("rotations_deg", 3);
            if (rows.size() != group.positions.size()) {
              r.fail("rotations_deg", "needs one [rx, ry, rz] per position (" + std::to_string(group.positions.size()) +
                                          "), got " + std::to_string(rows.size()));
            }
            for (const auto& e : rows) {
              const geometry::Mat<3> m = (Eigen::AngleAxisd(e[2] * kDegree, Vec<3>::UnitZ()) *
                                          Eigen::AngleAxisd(e[1] * kDegree, Vec<3>::UnitY()) *
                                          Eigen::AngleAxisd(e[0] * kDegree, Vec<3>::UnitX()))
                                             .toRotationMatrix();
              group.rotations.push_back(m);
            }
          }
        }
      } else if (placement == "cloud" || placement == "grid") {
        group.placement = placement == "cloud" ? Placement::Cloud : Placement::Grid;
        group.region = box<D>(r, "region");
        const std::int64_t count = placement == "grid" ? r.integer("count", 0) : r.integer("count");
        if (count < 0 || count > 10000000) r.fail("count", "must be in [1, 1e7] (grid: 0 fills the region)");
        if (placement == "cloud" && count == 0) r.fail("count", "must be positive");
        group.count = std::uint64_t(count);
        group.randomOrientation = r.boolean("random_orientation", false);
        if (placement == "grid") {
          group.gridSpacing = r.number("spacing", 0.0);
          if (group.gridSpacing < 0.0) {
            r.fail("spacing", "must be >= 0 m (0 or absent: the largest bounding diameter), got " +
                                  numberText(group.gridSpacing));
          }
        }
      } else if (placement == "feed") {
        group.placement = Placement::Feed;
        group.feedPoint = vec<D>(r, "point");
        group.feedInterval = r.nonNegative("interval", 0.0, "s");
        group.feedClearance = r.number("clearance", 0.0);
        if (group.feedInterval > 0.0 && r.has("clearance")) {
          r.fail("clearance", "has no meaning with an interval (a grain drops every interval, once the point is "
                              "free): give one of them");
        }
        if (group.feedInterval == 0.0 && !(group.feedClearance > 0.0)) {
          r.fail("clearance", "a feed needs an interval > 0 s or a clearance > 0 m");
        }
        const std::int64_t count = r.integer("count", 0);
        if (count < 0) r.fail("count", "must be >= 0 (0: no limit)");
        group.count = std::uint64_t(count);
        group.feedStart = r.nonNegative("start", 0.0, "s");
        if (group.diameterMax > 0.0) r.fail("diameter_range", "is not available for feeds (scale the shapes instead)");
      } else {
        r.fail("placement", "must be \"list\", \"cloud\", \"grid\" or \"feed\", got \"" + placement + "\"");
      }
      r.finish();
      scene_.groups.push_back(std::move(group));
    }
    if (scene_.groups.empty()) top.fail("", "a scene needs at least one [[particles]] group");
  }

  // A particle is one body: a shape whose level set holds separate pieces (a
  // mesh or grain file with two closed bodies side by side) is refused. (A
  // tool may be several bodies: it only pushes.)
  void checkOneBody(TomlReader& r, const std::string& key, std::size_t s) {
    if (!oneBody_.insert(s).second) return;
    std::vector<int> labels;
    const int bodies = geometry::labelComponents<D>(scene_.shapes[s]->grid(), labels);
    if (bodies > 1) {
      r.fail(key, "shape '" + scene_.shapeNames[s] + "' is " + std::to_string(bodies) +
                      " separate bodies; a particle must be one (give each body its own mesh or grain file)");
    }
  }

  void readParallel(TomlReader& top) {
    const toml::table* t = top.optionalTable("parallel");
    if (!t) return;
    TomlReader r(*t, file_, "parallel");
    ParallelDef& p = scene_.parallel;
    p.balanceByTime = r.choice("balance", {"nodes", "time"}, p.balanceByTime ? "time" : "nodes") == "time";
    p.rebalanceImbalance = r.number("rebalance_imbalance", p.rebalanceImbalance);
    if (!(p.rebalanceImbalance == 0.0 || p.rebalanceImbalance >= 1.0) || !std::isfinite(p.rebalanceImbalance)) {
      r.fail("rebalance_imbalance", "must be >= 1 (or 0: never rebalance), got " + numberText(p.rebalanceImbalance));
    }
    const std::int64_t every = r.integer("rebalance_every", std::int64_t(p.rebalanceEvery));
    if (every < 1) r.fail("rebalance_every", "must be >= 1 step, got " + std::to_string(every));
    p.rebalanceEvery = std::uint64_t(every);
    r.finish();
  }

  void readOutput(TomlReader& top) {
    const toml::table* t = top.optionalTable("output");
    if (!t) return;
    TomlReader r(*t, file_, "output");
    OutputDef& o = scene_.output;
    o.dir = r.string("dir", o.dir);
    const auto count = [&](const std::string& key, std::uint64_t fallback) {
      const std::int64_t v = r.integer(key, std::int64_t(fallback));
      if (v < 0 || v > 100000000) r.fail(key, "must be in [0, 1e8], got " + std::to_string(v));
      return std::uint64_t(v);
    };
    o.frames = count("frames", o.frames);
    if (r.has("vtk")) {
      o.particles = o.surfaces = o.boundaries = o.contacts = false;
      for (const std::string& s : r.strings("vtk")) {
        if (s == "particles") o.particles = true;
        else if (s == "surfaces") o.surfaces = true;
        else if (s == "boundaries") o.boundaries = true;
        else if (s == "contacts") o.contacts = true;
        else r.fail("vtk", "unknown series '" + s + "' (particles, surfaces, boundaries, contacts)");
      }
    }
    if (r.has("vtk_format")) {
      const std::string name = r.string("vtk_format");
      const std::optional<VtkEncoding> e = encodingNamed(name);
      if (!e) r.fail("vtk_format", "unknown format '" + name + "' (compressed, appended, binary, ascii)");
      o.vtkFormat = *e;
      if (r.has("ascii")) r.fail("ascii", "give vtk_format or ascii, not both");
    } else if (r.boolean("ascii", false)) {
      o.vtkFormat = VtkEncoding::Ascii;  // the older key
    }
    o.framePiecesPerRank =
        r.choice("frame_pieces", {"gathered", "ranks"}, o.framePiecesPerRank ? "ranks" : "gathered") == "ranks";
    o.historyRows = count("history_rows", o.historyRows);
    o.distributions = count("distributions", o.distributions);
    if (r.has("distribution_times")) {
      o.distributionTimes = r.numbers("distribution_times", -1);
      for (std::size_t k = 0; k < o.distributionTimes.size(); ++k) {
        if (o.distributionTimes[k] < 0.0 || (k > 0 && !(o.distributionTimes[k] > o.distributionTimes[k - 1]))) {
          r.fail("distribution_times", "times must be >= 0 s and increase");
        }
      }
      // Times past the scene's end are not reached by a run to its end:
      // said (kept: a resume with --steps past the end records them).
      const std::vector<double>& times = o.distributionTimes;
      const auto past = std::count_if(times.begin(), times.end(), [&](double t) { return t > scene_.duration; });
      if (scene_.duration > 0.0 && past > 0) {
        scene_.notes.push_back(InputError(file_, r.lineOf("distribution_times"), r.pathOf("distribution_times"),
                                          std::to_string(past) + " of its " + std::to_string(times.size()) +
                                              " times come after the scene's end (duration = " +
                                              numberText(scene_.duration) +
                                              " s): a run to its end does not record them")
                                   .what());
      }
    }
    o.shapeMinCells = r.nonNegative("shape_min_cells", o.shapeMinCells, "cells");
    o.checkpointEvery = r.nonNegative("checkpoint_every", 0.0, "s");
    scene_.keyLines[r.pathOf("checkpoint_every")] = r.lineOf("checkpoint_every");
    o.progressSeconds = r.positive("progress_seconds", o.progressSeconds);
    if (r.has("track")) {
      // Global ids: whole numbers >= 0, each once (fragments and fed grains
      // get theirs later, so an id need not exist at the start).
      for (const double v : r.numbers("track", -1)) {
        if (!(v >= 0.0 && v <= 9007199254740992.0 && v == std::floor(v))) {
          r.fail("track", "particle ids are whole numbers >= 0, got " + numberText(v));
        }
        const std::uint64_t id = std::uint64_t(v);
        if (std::find(o.track.begin(), o.track.end(), id) != o.track.end()) {
          r.fail("track", "particle " + std::to_string(id) + " is listed twice");
        }
        o.track.push_back(id);
      }
    }
    o.trackEvery = r.nonNegative("track_every", 0.0, "s");
    if (o.trackEvery > 0.0 && o.track.empty()) r.fail("track_every", "needs `track` (the particle ids to track)");
    if (const toml::table* s = r.optionalTable("specimen")) {
      TomlReader sr(*s, file_, "output.specimen");
      SpecimenDef spec;
      spec.top = sr.string("top");
      spec.bottom = sr.string("bottom");
      // (The other dimension's key named as such, not as an unknown key.)
      if (sr.has(D == 2 ? "area" : "width")) {
        sr.fail(D == 2 ? "area" : "width", D == 2 ? "is the 3D key: a 2D specimen takes `width` (m)"
                                                  : "is the 2D key: a 3D specimen takes `area` (m^2)");
      }
      spec.width = sr.positive(D == 2 ? "width" : "area");
      if (!boundaryNames_.count(spec.top)) sr.fail("top", "no plane or tool named '" + spec.top + "'");
      if (spec.top == spec.bottom) sr.fail("bottom", "is the top too: a specimen lies between two boundaries");
      // (The height and the stress are measured along the bottom plane's normal.)
      if (std::none_of(scene_.planes.begin(), scene_.planes.end(),
                       [&](const dynamics::PlaneDef<D>& p) { return p.name == spec.bottom; })) {
        sr.fail("bottom", "no plane named '" + spec.bottom + "'" +
                              (boundaryNames_.count(spec.bottom) ? " (a tool cannot be the bottom)" : ""));
      }
      sr.finish();
      scene_.specimen = spec;
    }
    r.finish();
  }

  const toml::table& root_;
  std::string file_;
  SceneDef<D> scene_;
  std::map<std::string, std::vector<std::size_t>> shapeIndex_;
  std::map<std::string, std::size_t> materialIndex_;
  std::vector<double> densities_;
  std::set<std::string> boundaryNames_;
  std::set<std::size_t> oneBody_;  // shapes found to be one body
};

}  // namespace

AnySceneDef readScene(const std::string& path) {
  const toml::table root = detail::parseTomlFile(path);
  const toml::table* sim = root["simulation"].as_table();
  if (!sim) throw InputError(path, 0, "simulation", "missing table [simulation] (dimension, duration or steps)");
  detail::TomlReader r(*sim, path, "simulation");
  const std::int64_t dimension = r.integer("dimension");
  try {
    if (dimension == 2) return SceneReader<2>(root, path).read();
    if (dimension == 3) return SceneReader<3>(root, path).read();
  } catch (const std::invalid_argument& e) {
    // A definition the layers refuse (contact law, motion, breakage parameters).
    throw InputError(path, 0, "", e.what());
  }
  r.fail("dimension", "must be 2 or 3, got " + std::to_string(dimension));
}

}  // namespace lsdem::io
