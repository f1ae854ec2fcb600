#include "support/Files.h"
#include "support/Shapes.h"
#include "support/VtpReader.h"
#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/Contours.h"
#include "lsdem/geometry/ShapeDef.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/Vtk.h"
#include "lsdem/io/VtpRead.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <unistd.h>

using namespace lsdem;
using namespace lsdem::dynamics;
namespace fs = std::filesystem;
using io::VtkEncoding;

namespace {

// A fresh scratch directory per test, removed afterwards.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name)
      : path_(lsdem::test::tempPath("lsdem_test_vtk_" + std::to_string(::getpid()) + "_" + name)) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }
  std::string operator/(const std::string& f) const { return (path_ / f).string(); }

 private:
  fs::path path_;
};

// An ellipse (2D) / ellipsoid (3D): rotation changes where its surface is.
template <int D>
std::shared_ptr<const geometry::Shape<D>> ellipsoid(double a) {
  geometry::ShapeDef<D> def;
  def.kind = geometry::ShapeKind::Ellipsoid;
  def.semiAxes = Vec<D>::Constant(0.6 * a);
  def.semiAxes[0] = a;
  def.cellsAcross = 10;
  def.options.nodesPerCell = 1.0;
  return geometry::buildShape(def);
}

template <int D>
Orientation<D> someRotation(double angle) {
  if constexpr (D == 2) {
    return angle;
  } else {
    return Eigen::Quaterniond(Eigen::AngleAxisd(angle, Vec<3>(1.0, 2.0, 3.0).normalized()));
  }
}

// Three separated grains (two shapes) with distinct poses and motions, and a floor.
template <int D>
// `moved`: the first particle shifted by 0.01 m along every axis and turned.
World<D> smallWorld(bool moved = false) {
  WorldDef<D> def;
  def.contact.kn = 1e5;
  def.contact.ks = 0.8e5;
  World<D> w(def);
  PlaneDef<D> floor;
  floor.plane.point = Vec<D>::Zero();
  floor.plane.normal = Vec<D>::Unit(1);
  w.addPlane(floor);
  const auto e = ellipsoid<D>(0.05);
  const auto s = test::sphereShape<D>(0.03);
  for (int k = 0; k < 3; ++k) {
    ParticleDef<D> p;
    p.shape = k == 1 ? s : e;
    p.position = Vec<D>::Constant(0.2 + 0.01 * k);
    p.position[0] = 0.15 * k + 0.1;
    p.orientation = someRotation<D>(0.4 + 0.9 * k);
    p.velocity = Vec<D>::Constant(0.1 * k - 0.3);
    p.velocity[0] = 1.0 / 3.0 + k;
    if constexpr (D == 2) {
      p.angularVelocity = 2.5 - k;
    } else {
      p.angularVelocity = Vec<3>(1.0 + k, -2.0, 0.1 * k);
    }
    p.strength = 1e6 * (k + 1);
    p.generation = k;
    if (k == 2) p.parent = 7;
    if (k == 0 && moved) {
      p.position += Vec<D>::Constant(0.01);
      p.orientation = someRotation<D>(2.0);
    }
    w.addParticle(p);
  }
  return w;
}

// The world position of every point of the file, as D-vectors.
template <int D>
Vec<D> pointOf(const test::VtpFile& f, std::int64_t i) {
  Vec<D> x;
  for (int a = 0; a < D; ++a) x[a] = f.coordinates[3 * std::size_t(i) + std::size_t(a)];
  return x;
}

}  // namespace

// The base64 stream is the UInt64 byte count followed by the data: an Int32 {1}
// is bytes 04 00 00 00 00 00 00 00 01 00 00 00, "BAAAAAAAAAABAAAA" in base64.
TEST(Vtk, BinaryArrayIsHeaderAndDataInOneBase64Stream) {
  ScratchDir dir("b64");
  io::VtpPiece piece;
  piece.points = {0.0, 0.0, 0.0};
  piece.verts.add(std::vector<std::int64_t>{0});
  piece.pointData.push_back({"one", 1, std::vector<std::int32_t>{1}});
  io::writeVtp(dir / "one.vtp", piece, VtkEncoding::Binary);
  const std::string text = test::readText(dir / "one.vtp");
  EXPECT_NE(text.find(">\n          BAAAAAAAAAABAAAA\n"), std::string::npos) << text;
  EXPECT_NE(text.find("header_type=\"UInt64\""), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "one.vtp.tmp"));
}

// Every value type reads back bit for bit in both encodings, including
// extremes and values with no short decimal form.
TEST(Vtk, ArraysRoundTripExactlyInBothEncodings) {
  ScratchDir dir("roundtrip");
  io::VtpPiece piece;
  const std::vector<double> f{0.1, -0.0, 1e-300, std::numeric_limits<double>::max(), 1.0 / 3.0, -2.5};
  const std::vector<std::int64_t> i{-1, std::numeric_limits<std::int64_t>::min(), 42, 0, 7, -9};
  const std::vector<std::uint64_t> u{std::numeric_limits<std::uint64_t>::max(), 0, 1, 2, 3, 1ull << 63};
  const std::vector<std::int32_t> n{std::numeric_limits<std::int32_t>::min(), -1, 0, 1, 2, 2147483647};
  for (int k = 0; k < 6; ++k) piece.points.insert(piece.points.end(), {0.1 * k, -0.2 * k, 1.0 / (k + 1)});
  piece.lines.add(std::vector<std::int64_t>{0, 1, 2});
  piece.polys.add(std::vector<std::int64_t>{3, 4, 5});
  piece.pointData.push_back({"f", 1, f});
  piece.pointData.push_back({"i", 1, i});
  // Two components per point: the extremes, then small values.
  piece.pointData.push_back({"u", 2, std::vector<std::uint64_t>{u[0], u[1], u[2], u[3], u[4], u[5], 5, 6, 7, 8, 9, 10}});
  piece.cellData.push_back({"n", 3, n});
  for (VtkEncoding e : {VtkEncoding::Binary, VtkEncoding::Ascii}) {
    const std::string file = dir / (e == VtkEncoding::Binary ? "b.vtp" : "a.vtp");
    io::writeVtp(file, piece, e);
    const test::VtpFile r = test::readVtp(file);
    EXPECT_EQ(r.points, 6u);
    EXPECT_EQ(r.lines, 1u);
    EXPECT_EQ(r.polys, 1u);
    EXPECT_EQ(r.coordinates, piece.points);
    EXPECT_EQ(r.lineCells.cell(0), (std::vector<std::int64_t>{0, 1, 2}));
    EXPECT_EQ(r.polyCells.cell(0), (std::vector<std::int64_t>{3, 4, 5}));
    ASSERT_EQ(r.pointArray("f").f64.size(), f.size());
    for (std::size_t k = 0; k < f.size(); ++k) {
      EXPECT_EQ(std::signbit(r.pointArray("f").f64[k]), std::signbit(f[k]));
      EXPECT_EQ(r.pointArray("f").f64[k], f[k]);
    }
    EXPECT_EQ(r.pointArray("i").i64, i);
    EXPECT_EQ(r.pointArray("u").components, 2);
    EXPECT_EQ(r.pointArray("u").u64[0], u[0]);
    EXPECT_EQ(r.pointArray("u").u64[5], u[5]);
    EXPECT_EQ(r.cellArray("n").i32, n);
    EXPECT_EQ(r.cellArray("n").format, e == VtkEncoding::Binary ? "binary" : "ascii");
  }
}

// Inconsistent pieces are refused before anything is written.
TEST(Vtk, InconsistentPiecesAreRefused) {
  ScratchDir dir("refused");
  io::VtpPiece piece;
  piece.points = {0, 0, 0, 1, 0, 0};
  piece.lines.add(std::vector<std::int64_t>{0, 2});
  EXPECT_THROW(io::writeVtp(dir / "bad.vtp", piece, VtkEncoding::Binary), std::invalid_argument);
  piece.lines = {};
  piece.lines.add(std::vector<std::int64_t>{0, 1});
  piece.pointData.push_back({"v", 3, std::vector<double>{1, 2, 3}});
  try {
    io::writeVtp(dir / "bad.vtp", piece, VtkEncoding::Binary);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'v'"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "bad.vtp"));
}

// A missing directory or a file standing where a directory should be: a
// std::runtime_error that names the path.
TEST(Vtk, UnwritablePathGivesClearError) {
  ScratchDir dir("unwritable");
  io::VtpPiece piece;
  const std::string missing = dir / "no_such_dir/frame.vtp";
  try {
    io::writeVtp(missing, piece, VtkEncoding::Binary);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  std::ofstream(dir / "plain_file") << "x";
  io::FrameWriterDef<2> def;
  def.directory = dir.path() / "plain_file" / "out";
  try {
    io::FrameWriter<2> writer(def);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("plain_file"), std::string::npos) << e.what();
  }
}

namespace {

// Particle frame: counts and every field against the particle store.
template <int D>
void checkParticleFrame() {
  ScratchDir dir("particles" + std::to_string(D));
  World<D> w = smallWorld<D>();
  const Particles<D>& p = w.particles();
  const std::vector<double> stress{1.5e5, 0.0, 3.25e6};
  io::writeParticleFrame<D>(dir / "b.vtp", w, stress, VtkEncoding::Binary);
  io::writeParticleFrame<D>(dir / "a.vtp", w, stress, VtkEncoding::Ascii);
  io::writeParticleFrame<D>(dir / "nostress.vtp", w, {}, VtkEncoding::Binary);
  EXPECT_THROW(io::writeParticleFrame<D>(dir / "x.vtp", w, std::vector<double>{1.0}, VtkEncoding::Binary),
               std::invalid_argument);
  const test::VtpFile b = test::readVtp(dir / "b.vtp");
  const test::VtpFile a = test::readVtp(dir / "a.vtp");
  // The frame's simulated time, as field data.
  EXPECT_EQ(io::readVtp(dir / "b.vtp").time, std::optional<double>(w.time()));
  EXPECT_EQ(io::readVtp(dir / "a.vtp").time, std::optional<double>(w.time()));
  ASSERT_EQ(b.points, p.size());
  ASSERT_EQ(b.verts, p.size());
  EXPECT_EQ(b.lines + b.polys, 0u);
  for (const test::VtpFile* f : {&b, &a}) {
    for (std::size_t i = 0; i < p.size(); ++i) {
      // Position (z = 0 in 2D), ids, velocity and spin: exact.
      for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(f->coordinates[3 * i + c], c < D ? p.position[i][c] : 0.0);
        EXPECT_EQ(f->pointArray("velocity").f64[3 * i + c], c < D ? p.velocity[i][c] : 0.0);
      }
      EXPECT_EQ(f->pointArray("id").u64[i], p.id[i]);
      EXPECT_EQ(f->pointArray("parent_id").i64[i], i == 2 ? 7 : -1);
      EXPECT_EQ(f->pointArray("generation").i32[i], int(i));
      EXPECT_EQ(f->pointArray("radius").f64[i], p.shape[i]->boundingRadius());
      EXPECT_EQ(f->pointArray("equivalent_diameter").f64[i], p.shape[i]->descriptors().equivalentDiameter);
      EXPECT_EQ(f->pointArray("mass").f64[i], p.mass[i]);
      EXPECT_EQ(f->pointArray("stress").f64[i], stress[i]);
      EXPECT_EQ(f->pointArray("strength").f64[i], p.strength[i]);
      // Strengths 1, 2, 3 MPa: the ratios 0.15, 0, 1.083.
      EXPECT_DOUBLE_EQ(f->pointArray("criterion_ratio").f64[i], stress[i] / (1e6 * double(i + 1)));
      const auto& spin = f->pointArray("angular_velocity").f64;
      if constexpr (D == 2) {
        EXPECT_EQ(spin[3 * i + 2], p.angularVelocity[i]);
        EXPECT_EQ(spin[3 * i], 0.0);
      } else {
        for (int c = 0; c < 3; ++c) EXPECT_EQ(spin[3 * i + c], p.angularVelocity[i][c]);
      }
      // The quaternion rotates like the particle's rotation matrix.
      const auto& q = f->pointArray("orientation").f64;
      const Eigen::Quaterniond quat(q[4 * i], q[4 * i + 1], q[4 * i + 2], q[4 * i + 3]);
      const Mat<3> r3 = quat.toRotationMatrix();
      EXPECT_NEAR(quat.norm(), 1.0, 1e-14);
      EXPECT_LT((r3.template topLeftCorner<D, D>() - p.rotation(i)).norm(), 1e-14);
      // The body axes in the world are the rotation's columns (z in 2D).
      for (int a = 0; a < 3; ++a) {
        const auto& axis = f->pointArray(std::string("axis_") + "xyz"[a]).f64;
        const Vec<3> expected = a < D ? Vec<3>(r3.col(a)) : Vec<3>::UnitZ();
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(axis[3 * i + std::size_t(c)], expected[c], 1e-14) << a << c;
      }
    }
  }
  // Without a stress measure the column holds zeros.
  const test::VtpFile n = test::readVtp(dir / "nostress.vtp");
  for (double s : n.pointArray("stress").f64) EXPECT_EQ(s, 0.0);
}

// Surface frame: cell counts are the shapes' contours; every point lies on its
// particle's surface once mapped back through the particle's pose, and back in
// the grid frame it is the contour's own vertex. |phi| tolerance: 2D vertices
// sit on grid edges (linear along them, clamped by 1e-3 cells); 3D marching
// tetrahedra also cut face and cube diagonals, where the trilinear value is
// not linear, which leaves up to ~0.06 cells.
template <int D>
constexpr double surfaceTolerance() {
  return D == 2 ? 3e-3 : 0.1;
}
template <int D>
void checkSurfaceFrame() {
  ScratchDir dir("surfaces" + std::to_string(D));
  World<D> w = smallWorld<D>();
  const Particles<D>& p = w.particles();
  io::SurfaceCache<D> cache;
  const std::vector<double> stress{1.5e5, 0.0, 3.25e6};
  io::writeSurfaceFrame<D>(dir / "b.vtp", w, cache, VtkEncoding::Binary, stress);
  io::writeSurfaceFrame<D>(dir / "a.vtp", w, cache, VtkEncoding::Ascii, stress);
  EXPECT_THROW(io::writeSurfaceFrame<D>(dir / "x.vtp", w, cache, VtkEncoding::Binary, std::vector<double>{1.0}),
               std::invalid_argument);
  EXPECT_EQ(cache.size(), 2u);  // two shapes for three particles
  const test::VtpFile b = test::readVtp(dir / "b.vtp");
  const test::VtpFile a = test::readVtp(dir / "a.vtp");
  // Counts: loops (2D, with their edges) or triangles (3D), summed over particles.
  std::size_t cells = 0, pieces = 0, vertices = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const io::BodyContour<D> c = io::bodyContour(*p.shape[i]);
    cells += c.cellCount();
    pieces += c.pieceCount();
    vertices += c.vertices.size();
  }
  // Polygons in both dimensions (2D: one closed loop each, filled in ParaView).
  const test::VtpCells& cellList = b.polyCells;
  EXPECT_EQ(b.polys, cells);
  EXPECT_EQ(b.lines, 0u);
  EXPECT_EQ(b.points, vertices);
  std::size_t counted = 0;
  for (std::size_t c = 0; c < cells; ++c) counted += cellList.cell(c).size();
  EXPECT_EQ(counted, D == 2 ? pieces : 3 * pieces);
  if constexpr (D == 2) {
    EXPECT_EQ(cells, 3u);  // one loop per grain
    // Each loop's vertices are distinct (a polygon does not repeat its first
    // point) and run counter-clockwise: positive shoelace area, near the
    // grain's own area.
    for (std::size_t c = 0; c < cells; ++c) {
      const std::vector<std::int64_t> loop = cellList.cell(c);
      EXPECT_NE(loop.front(), loop.back());
      double area = 0.0;
      for (std::size_t k = 0; k < loop.size(); ++k) {
        const Vec<2> x = pointOf<2>(b, loop[k]), y = pointOf<2>(b, loop[(k + 1) % loop.size()]);
        area += 0.5 * (x[0] * y[1] - y[0] * x[1]);
      }
      const std::size_t i = std::size_t(b.cellArray("id").u64[c]) == p.id[0] ? 0 : std::size_t(b.cellArray("id").u64[c]) == p.id[1] ? 1 : 2;
      EXPECT_NEAR(area, p.shape[i]->volume(), 0.03 * p.shape[i]->volume()) << c;
    }
  } else {
    EXPECT_GT(cells, 300u);
  }
  // Binary and ascii hold the same numbers.
  EXPECT_EQ(a.coordinates, b.coordinates);
  EXPECT_EQ(a.cellArray("id").u64, b.cellArray("id").u64);
  // Points on the surfaces, particle by particle.
  std::map<std::uint64_t, std::size_t> index;
  for (std::size_t i = 0; i < p.size(); ++i) index[p.id[i]] = i;
  double worst = 0.0;
  std::vector<Vec<D>> mean(p.size(), Vec<D>::Zero());
  std::vector<double> count(p.size(), 0.0);
  for (std::size_t c = 0; c < cells; ++c) {
    const std::size_t i = index.at(b.cellArray("id").u64[c]);
    EXPECT_EQ(b.cellArray("generation").i32[c], p.generation[i]);
    // The particle's fields on each of its cells (Float32).
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(b.cellArray("velocity").f64[3 * c + std::size_t(a)], double(float(a < D ? p.velocity[i][a] : 0.0)));
    }
    EXPECT_EQ(b.cellArray("stress").f64[c], double(float(stress[i])));
    EXPECT_EQ(b.cellArray("strength").f64[c], double(float(p.strength[i])));
    EXPECT_EQ(b.cellArray("criterion_ratio").f64[c], double(float(stress[i] / p.strength[i])));
    const double h = p.shape[i]->grid().spacing();
    for (std::int64_t k : cellList.cell(c)) {
      const Vec<D> x = pointOf<D>(b, k);
      const Vec<D> body = p.rotation(i).transpose() * (x - p.position[i]);
      worst = std::max(worst, std::abs(p.shape[i]->value(body)) / h);
      mean[i] += x;
      count[i] += 1.0;
    }
  }
  EXPECT_LT(worst, surfaceTolerance<D>());
  // 3D: unit normals along the level set's gradient at each point (a step
  // of a tenth of a cell along one raises phi by about that step).
  if constexpr (D == 3) {
    const auto& normals = b.pointArray("Normals");
    ASSERT_EQ(normals.tuples(), b.points);
    for (std::size_t c = 0; c < cells; ++c) {
      const std::size_t i = index.at(b.cellArray("id").u64[c]);
      const double h = p.shape[i]->grid().spacing();
      for (std::int64_t k : cellList.cell(c)) {
        const Vec<3> n(normals.f64[3 * std::size_t(k)], normals.f64[3 * std::size_t(k) + 1],
                       normals.f64[3 * std::size_t(k) + 2]);
        ASSERT_NEAR(n.norm(), 1.0, 1e-6);
        const Vec<3> x = pointOf<3>(b, k);
        const auto phi = [&](const Vec<3>& y) { return p.shape[i]->value(p.rotation(i).transpose() * (y - p.position[i])); };
        EXPECT_NEAR(phi(x + 0.1 * h * n) - phi(x), 0.1 * h, 0.03 * h) << c;
      }
    }
  } else {
    EXPECT_THROW(b.pointArray("Normals"), std::runtime_error);
  }
  // Particle 0's points are its grid-frame contour vertices, placed (to
  // Float32, as surfaces are written: 0.1 um here).
  std::vector<Vec<D>> gridVertices;
  if constexpr (D == 2) {
    for (const auto& loop : geometry::marchingSquares(p.shape[0]->grid())) {
      gridVertices.insert(gridVertices.end(), loop.begin(), loop.end());
    }
  } else {
    gridVertices = geometry::marchingCubes(p.shape[0]->grid()).vertices;
  }
  for (std::size_t k = 0; k < gridVertices.size(); ++k) {
    const Vec<D> body = p.rotation(0).transpose() * (pointOf<D>(b, std::int64_t(k)) - p.position[0]);
    ASSERT_LT((p.shape[0]->bodyToGrid().apply(body) - gridVertices[k]).norm(), 1e-7) << k;
  }
  // The surfaces sit around the centroids (the shapes are symmetric).
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_LT((mean[i] / count[i] - p.position[i]).norm(), 0.5 * p.shape[i]->grid().spacing());
  }
  // Moved and rotated, an ellipse's surface follows: the old points are off it.
  const Vec<D> old = pointOf<D>(b, cellList.cell(0)[0]);
  const World<D> shifted = smallWorld<D>(true);
  const Particles<D>& q = shifted.particles();
  io::writeSurfaceFrame<D>(dir / "moved.vtp", shifted, cache, VtkEncoding::Binary);
  const test::VtpFile m = test::readVtp(dir / "moved.vtp");
  const Vec<D> moved = pointOf<D>(m, m.polyCells.cell(0)[0]);
  EXPECT_GT((moved - old).norm(), 0.005);
  const Vec<D> body = q.rotation(0).transpose() * (moved - q.position[0]);
  EXPECT_LT(std::abs(q.shape[0]->value(body)), surfaceTolerance<D>() * q.shape[0]->grid().spacing());
  const Vec<D> oldBody = q.rotation(0).transpose() * (old - q.position[0]);
  EXPECT_GT(std::abs(q.shape[0]->value(oldBody)), 3.0 * surfaceTolerance<D>() * q.shape[0]->grid().spacing());
}

// Boundary frame: the floor clipped to the extent box exactly; a tool's
// surface at its pose; loads as cell data.
template <int D>
void checkBoundaryFrame() {
  ScratchDir dir("boundaries" + std::to_string(D));
  World<D> w = smallWorld<D>();
  // A tilted plane through the box and a spherical tool.
  PlaneDef<D> wall;
  wall.plane.point = Vec<D>::Constant(0.5);
  wall.plane.normal = Vec<D>::Constant(-1.0).normalized();
  w.addPlane(wall);
  ToolDef<D> tool;
  tool.shape = test::sphereShape<D>(0.1);
  tool.motion = Motion<D>{};
  w.addTool(tool);
  geometry::Box<D> extent;
  extent.lower = Vec<D>::Zero();
  extent.upper = Vec<D>::Ones();
  io::SurfaceCache<D> cache;
  io::writeBoundaryFrame<D>(dir / "b.vtp", w, cache, extent, VtkEncoding::Binary);
  const test::VtpFile b = test::readVtp(dir / "b.vtp");
  const io::BodyContour<D> toolContour = io::bodyContour(*tool.shape);
  const std::size_t cells = 2 + toolContour.cellCount();
  // Planes are segments (line cells) in 2D and polygons in 3D; a tool's
  // surface is polygons in both (2D: closed loops, filled in ParaView).
  EXPECT_EQ(b.lines + b.polys, cells);
  EXPECT_EQ(b.lines, D == 2 ? 2u : 0u);
  EXPECT_EQ(b.points, (D == 2 ? 4u : 4u + 6u) + toolContour.vertices.size());
  const test::VtpCells& list = D == 2 ? b.lineCells : b.polyCells;
  const auto toolCell = [&](std::size_t c) { return b.polyCells.cell(D == 2 ? c - 2 : c); };
  // The floor (y = 0) clipped to the unit box: its edge (2D) or face (3D).
  const std::vector<std::int64_t> floor = list.cell(0);
  ASSERT_EQ(floor.size(), D == 2 ? 2u : 4u);
  double area = 0.0;
  for (std::size_t k = 0; k < floor.size(); ++k) {
    const Vec<D> x = pointOf<D>(b, floor[k]);
    EXPECT_EQ(x[1], 0.0);
    for (int c = 0; c < D; ++c) EXPECT_TRUE(x[c] == 0.0 || x[c] == 1.0) << x.transpose();
    if constexpr (D == 3) {
      const Vec<3> y = pointOf<3>(b, floor[(k + 1) % floor.size()]);
      area += 0.5 * (x[2] * y[0] - x[0] * y[2]);
    }
  }
  if constexpr (D == 3) {
    EXPECT_NEAR(std::abs(area), 1.0, 1e-15);
  }
  // The tilted wall x + y (+ z) = 1.5 (3D) / 1 (2D) cuts the box in a segment
  // (2D: corners (0,1), (1,0)) or a regular hexagon (3D).
  const std::vector<std::int64_t> tilted = list.cell(1);
  ASSERT_EQ(tilted.size(), D == 2 ? 2u : 6u);
  for (std::int64_t k : tilted) EXPECT_NEAR(pointOf<D>(b, k).sum(), 0.5 * D, 1e-14);
  // Tool points on the tool's surface at its pose.
  const auto& pose = w.toolPoses()[0];
  double worst = 0.0;
  for (std::size_t c = 2; c < cells; ++c) {
    EXPECT_EQ(b.cellArray("kind").i32[c], 1);
    EXPECT_EQ(b.cellArray("index").i32[c], 0);
    const std::vector<std::int64_t> cell = toolCell(c);
    if (D == 2) {
      EXPECT_NE(cell.front(), cell.back());
    }
    for (std::int64_t k : cell) {
      const Vec<D> body = Rotation<D>::matrix(pose.orientation).transpose() * (pointOf<D>(b, k) - pose.position);
      worst = std::max(worst, std::abs(tool.shape->value(body)));
    }
  }
  EXPECT_LT(worst, surfaceTolerance<D>() * tool.shape->grid().spacing());
  EXPECT_EQ(b.cellArray("kind").i32[0], 0);
  EXPECT_EQ(b.cellArray("index").i32[1], 1);
  // Geometry only: the loads are in history.csv (a file can stand for many frames).
  EXPECT_THROW(b.cellArray("force"), std::runtime_error);
  // The same boundaries as pieces: the planes, then the tool.
  const std::vector<io::VtpPiece> pieces = io::boundaryPieces<D>(w, cache, extent);
  ASSERT_EQ(pieces.size(), 2u);
  EXPECT_EQ(pieces[0].cellCount(), 2u);
  EXPECT_EQ(pieces[0].pointCount(), D == 2 ? 4u : 10u);
  EXPECT_EQ(pieces[1].polys.size(), toolContour.cellCount());
  EXPECT_EQ(pieces[1].pointCount(), toolContour.vertices.size());
  EXPECT_EQ(std::get<std::vector<std::int32_t>>(pieces[1].cellData[0].values),
            std::vector<std::int32_t>(toolContour.cellCount(), 1));
  // A degenerate extent is refused.
  extent.upper[0] = 0.0;
  EXPECT_THROW(io::writeBoundaryFrame<D>(dir / "x.vtp", w, cache, extent, VtkEncoding::Binary), std::invalid_argument);
}

// Contact frame: one line per touching pair, with its ids and force.
template <int D>
void checkContactFrame() {
  ScratchDir dir("contacts" + std::to_string(D));
  WorldDef<D> def;
  def.contact.kn = 1e5;
  def.contact.hasFriction = false;  // per-node springs only: the force is sum k overlap n
  def.contact.hasDamping = false;
  World<D> w(def);
  const auto s = test::sphereShape<D>(0.05);
  // A row of four spheres: three overlapping neighbours, then a gap.
  for (int k = 0; k < 4; ++k) {
    ParticleDef<D> p;
    p.shape = s;
    p.position = Vec<D>::Zero();
    p.position[0] = 0.095 * k + (k == 3 ? 0.05 : 0.0);
    w.addParticle(p);
  }
  w.step();
  std::size_t touching = 0;
  for (const auto& c : w.contacts().particleContacts()) touching += c.nodeCount > 0;
  ASSERT_EQ(touching, 2u);
  io::writeContactFrame<D>(dir / "b.vtp", w, VtkEncoding::Binary);
  io::writeContactFrame<D>(dir / "a.vtp", w, VtkEncoding::Ascii);
  const test::VtpFile b = test::readVtp(dir / "b.vtp");
  const test::VtpFile a = test::readVtp(dir / "a.vtp");
  EXPECT_EQ(b.points, 2 * touching);
  EXPECT_EQ(b.lines, touching);
  std::size_t line = 0;
  for (const auto& c : w.contacts().particleContacts()) {
    if (c.nodeCount == 0) continue;
    // A line of its own two points, at the centroids, carrying the pair's
    // force as point data too (Tube by force_magnitude).
    const std::int64_t first = std::int64_t(2 * line);
    EXPECT_EQ(b.lineCells.cell(line), (std::vector<std::int64_t>{first, first + 1}));
    for (const auto& [end, i] : {std::pair{first, c.a}, std::pair{first + 1, c.b}}) {
      EXPECT_EQ(b.pointArray("id").u64[std::size_t(end)], w.particles().id[i]);
      for (int k = 0; k < D; ++k) EXPECT_EQ(pointOf<3>(b, end)[k], w.particles().position[i][k]);
      EXPECT_EQ(b.pointArray("force_magnitude").f64[std::size_t(end)], c.force.norm());
      EXPECT_EQ(b.pointArray("normal_force").f64[std::size_t(end)], b.cellArray("normal_force").f64[line]);
    }
    EXPECT_EQ(b.cellArray("id_a").u64[line], w.particles().id[c.a]);
    EXPECT_EQ(b.cellArray("id_b").u64[line], w.particles().id[c.b]);
    EXPECT_EQ(b.cellArray("node_contacts").i32[line], int(c.nodeCount));
    EXPECT_EQ(b.cellArray("force_magnitude").f64[line], c.force.norm());
    EXPECT_GT(c.force.norm(), 0.0);
    // Without friction the force is normal and compressive; the node forces
    // are k overlap |grad phi| n with |grad phi| = 1 to ~1e-3, so the
    // overlap-weighted normal holds all but 2e-3 of it. The two parts make up
    // the whole.
    const double fn = b.cellArray("normal_force").f64[line], ft = b.cellArray("tangential_force").f64[line];
    EXPECT_NEAR(fn * fn + ft * ft, c.force.squaredNorm(), 1e-12 * c.force.squaredNorm());
    EXPECT_NEAR(fn, c.force.norm(), 1e-5 * c.force.norm());
    EXPECT_LT(ft, 2e-3 * c.force.norm());
    ++line;
  }
  EXPECT_EQ(a.cellArray("force").f64, b.cellArray("force").f64);
  EXPECT_EQ(a.cellArray("normal_force").f64, b.cellArray("normal_force").f64);
}

}  // namespace

TEST(Vtk, ParticleFrame2D) { checkParticleFrame<2>(); }
TEST(Vtk, ParticleFrame3D) { checkParticleFrame<3>(); }
TEST(Vtk, SurfaceFrame2D) { checkSurfaceFrame<2>(); }
TEST(Vtk, SurfaceFrame3D) { checkSurfaceFrame<3>(); }
TEST(Vtk, BoundaryFrame2D) { checkBoundaryFrame<2>(); }
TEST(Vtk, BoundaryFrame3D) { checkBoundaryFrame<3>(); }
TEST(Vtk, ContactFrame2D) { checkContactFrame<2>(); }
TEST(Vtk, ContactFrame3D) { checkContactFrame<3>(); }

// The cache keeps a shape alive while it holds it, and prune() lets go of
// shapes nobody else holds.
TEST(Vtk, SurfaceCacheReleasesFreedShapes) {
  io::SurfaceCache<2> cache;
  auto kept = test::sphereShape<2>(0.05);
  auto freed = test::sphereShape<2>(0.02);
  std::weak_ptr<const geometry::Shape<2>> watch = freed;
  const std::size_t loops = cache.contour(kept).cellCount();
  cache.contour(freed);
  EXPECT_EQ(loops, 1u);
  EXPECT_EQ(cache.size(), 2u);
  freed.reset();
  EXPECT_FALSE(watch.expired());  // held by the cache
  cache.prune();
  EXPECT_TRUE(watch.expired());
  EXPECT_EQ(cache.size(), 1u);
  EXPECT_THROW(cache.contour(nullptr), std::invalid_argument);
}

// The series is valid XML listing every frame after each add, restores its
// entries on resume, and truncation drops the later frames.
TEST(Vtk, PvdSeriesAddResumeTruncate) {
  ScratchDir dir("pvd");
  const std::string file = dir / "particles.pvd";
  {
    io::PvdSeries s(file);
    EXPECT_TRUE(test::readPvd(file).empty());
    for (int k = 0; k < 4; ++k) {
      s.add(0.1 * k, "frames/p_" + std::to_string(k) + ".vtp");
      const auto entries = test::readPvd(file);
      ASSERT_EQ(entries.size(), std::size_t(k + 1));
      EXPECT_EQ(entries.back().time, 0.1 * k);
      EXPECT_EQ(entries.back().file, "frames/p_" + std::to_string(k) + ".vtp");
    }
    s.add(0.5, "odd & <name>.vtp");
    EXPECT_EQ(test::readPvd(file).back().file, "odd & <name>.vtp");
  }
  // Resume: the entries come back exactly; truncation keeps t <= 0.2.
  io::PvdSeries resumed(file, true);
  ASSERT_EQ(resumed.entries().size(), 5u);
  EXPECT_EQ(resumed.entries()[3].time, 0.1 * 3);
  EXPECT_EQ(resumed.entries()[4].file, "odd & <name>.vtp");
  resumed.truncateAfter(0.2);
  const auto kept = test::readPvd(file);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_EQ(kept.back().time, 0.1 * 2);
  // A fresh (non-resumed) series starts empty.
  io::PvdSeries fresh(file);
  EXPECT_TRUE(test::readPvd(file).empty());
  // A broken file is an input error naming the file.
  std::ofstream(dir / "broken.pvd") << "<VTKFile type=\"Collection\">\n<Collection>\n<DataSet timestep=\"x1\" "
                                       "file=\"a.vtp\"/>\n</Collection>\n</VTKFile>\n";
  try {
    io::PvdSeries broken(dir / "broken.pvd", true);
    FAIL() << "expected io::InputError";
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.line(), 3);
    EXPECT_EQ(e.key(), "timestep");
  }
}

// The frame writer writes the four series with frames that all parse; a
// resumed writer drops frames after the checkpoint time and continues the
// numbering from there.
TEST(Vtk, FrameWriterSeriesAndResume) {
  ScratchDir dir("writer");
  World<3> w = smallWorld<3>();
  io::FrameWriterDef<3> def;
  def.directory = dir.path() / "out";
  def.extent.lower = Vec<3>::Constant(-1.0);  // a fixed domain: the floor does not change
  def.extent.upper = Vec<3>::Constant(1.0);
  {
    io::FrameWriter<3> writer(def);
    for (int k = 0; k < 3; ++k) {
      writer.write(w);
      w.step();
    }
    EXPECT_EQ(writer.nextFrame(), 3u);
  }
  const std::map<std::string, std::size_t> points{{"particles", 3}};
  std::vector<double> times;
  for (const char* series : {"particles", "surfaces", "boundaries", "contacts"}) {
    const auto entries = test::readPvd((def.directory / (std::string(series) + ".pvd")).string());
    ASSERT_EQ(entries.size(), 3u) << series;
    for (std::size_t k = 0; k < entries.size(); ++k) {
      const test::VtpFile f = test::readVtp((def.directory / entries[k].file).string());
      // The floor stays where it is: written once, named by every frame.
      EXPECT_EQ(entries[k].file, std::string(series) == "boundaries"
                                     ? std::string("frames/boundaries_000000_planes.vtp")
                                     : "frames/" + std::string(series) + "_00000" + std::to_string(k) + ".vtp");
      if (points.count(series)) {
        EXPECT_EQ(f.points, points.at(series));
      }
      if (std::string(series) == "contacts") {
        EXPECT_EQ(f.points, 2 * f.lines);  // each chain its own two ends
      }
      if (std::string(series) == "boundaries") {
        EXPECT_EQ(f.polys, 1u);  // the floor
      }
      if (std::string(series) == "particles") times.push_back(entries[k].time);
    }
  }
  EXPECT_EQ(times[0], 0.0);
  EXPECT_GT(times[2], times[1]);
  // Resume from the checkpoint at the second frame's time.
  def.resume = true;
  def.contacts = false;
  io::FrameWriter<3> resumed(def);
  resumed.truncateAfter(times[1]);
  EXPECT_EQ(resumed.nextFrame(), 2u);
  resumed.write(w);
  const auto entries = test::readPvd((def.directory / "particles.pvd").string());
  ASSERT_EQ(entries.size(), 3u);
  EXPECT_EQ(entries[2].time, w.time());
  EXPECT_EQ(entries[2].file, "frames/particles_000002.vtp");
  EXPECT_EQ(test::readVtp((def.directory / entries[2].file).string()).points, 3u);
}

namespace {

// A world with a floor, a tool at rest and a tool moving at 1 m/s along x.
template <int D>
World<D> toolWorld() {
  World<D> w = smallWorld<D>();
  for (int k = 0; k < 2; ++k) {
    ToolDef<D> tool;
    tool.name = k == 0 ? "anvil" : "hammer";
    tool.shape = test::sphereShape<D>(0.04);
    ConstantVelocity<D> motion;
    motion.position = Vec<D>::Constant(0.6 + 0.2 * k);
    motion.velocity = Vec<D>::UnitX() * double(k);
    tool.motion = motion;
    w.addTool(tool);
  }
  return w;
}

// The boundaries.pvd entries as (part, file) pairs.
std::vector<std::pair<int, std::string>> boundaryEntries(const fs::path& dir) {
  std::vector<std::pair<int, std::string>> out;
  for (const auto& e : io::readPvd(dir / "boundaries.pvd")) out.emplace_back(e.part, e.file);
  return out;
}

// The boundary frame files on disk.
std::set<std::string> boundaryFiles(const fs::path& dir) {
  std::set<std::string> out;
  for (const auto& e : fs::directory_iterator(dir / "frames")) {
    const std::string name = e.path().filename().string();
    if (name.rfind("boundaries_", 0) == 0) out.insert(name);
  }
  return out;
}

template <int D>
void checkBoundariesWrittenOnce() {
  ScratchDir dir("static_boundaries" + std::to_string(D));
  io::FrameWriterDef<D> def;
  def.directory = dir.path() / "straight";
  def.extent.lower = Vec<D>::Constant(-1.0);
  def.extent.upper = Vec<D>::Constant(1.0);
  def.particles = def.surfaces = def.contacts = true;
  // Four frames, a step apart.
  std::vector<double> times;
  {
    World<D> w = toolWorld<D>();
    io::FrameWriter<D> writer(def);
    for (int k = 0; k < 4; ++k) {
      writer.write(w);
      times.push_back(w.time());
      w.step();
    }
  }
  // Each frame: the planes (part 0), the tool at rest (1), the moving tool
  // (2). The first two are the files of frame 0; the moving one is new each time.
  const auto entries = boundaryEntries(def.directory);
  ASSERT_EQ(entries.size(), 12u);
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(entries[3 * k], std::make_pair(0, std::string("frames/boundaries_000000_planes.vtp")));
    EXPECT_EQ(entries[3 * k + 1], std::make_pair(1, std::string("frames/boundaries_000000_tool0.vtp")));
    EXPECT_EQ(entries[3 * k + 2], std::make_pair(2, "frames/boundaries_00000" + std::to_string(k) + "_tool1.vtp"));
  }
  EXPECT_EQ(boundaryFiles(def.directory).size(), 6u);  // 1 + 1 + 4, not 12
  // Every part as VTK reads it: the planes as segments (2D) or polygons, the
  // tools' polygons, with kind and index; the moving tool 1 m/s x dt further each frame.
  const io::VtpPiece planes = io::readVtp(def.directory / entries[0].second);
  EXPECT_EQ(planes.cellCount(), 1u);
  EXPECT_EQ(D == 2 ? planes.lines.size() : planes.polys.size(), 1u);
  EXPECT_FALSE(planes.time.has_value());  // one file for many times
  double first = 0.0;
  for (std::size_t k = 0; k < 4; ++k) {
    const io::VtpPiece hammer = io::readVtp(def.directory / entries[3 * k + 2].second);
    EXPECT_EQ(hammer.lines.size(), 0u);
    EXPECT_GT(hammer.polys.size(), 0u);
    EXPECT_EQ(io::arrayAsDoubles(*io::findArray(hammer.cellData, "index")),
              std::vector<double>(hammer.polys.size(), 1.0));
    double x = 0.0;
    for (std::size_t i = 0; i < hammer.pointCount(); ++i) x += hammer.points[3 * i];
    x /= double(hammer.pointCount());
    if (k == 0) first = x;
    EXPECT_NEAR(x - first, times[k] - times[0], 1e-6) << k;
  }
  EXPECT_GT(times[3], times[0]);

  // The same run stopped after frame 2 and resumed from a checkpoint at
  // frame 1: the same series, the same files.
  def.directory = dir.path() / "resumed";
  {
    World<D> w = toolWorld<D>();
    io::FrameWriter<D> writer(def);
    for (int k = 0; k < 3; ++k) {
      writer.write(w);
      w.step();
    }
  }
  World<D> w = toolWorld<D>();
  w.step();  // the state at frame 1's time (the checkpoint)
  ASSERT_EQ(w.time(), times[1]);
  def.resume = true;
  io::FrameWriter<D> resumed(def);
  resumed.truncateAfter(times[1]);
  EXPECT_EQ(resumed.nextFrame(), 2u);
  for (int k = 2; k < 4; ++k) {
    w.step();
    resumed.write(w);
  }
  EXPECT_EQ(test::readText((dir.path() / "straight" / "boundaries.pvd").string()),
            test::readText((dir.path() / "resumed" / "boundaries.pvd").string()));
  EXPECT_EQ(boundaryFiles(dir.path() / "straight"), boundaryFiles(dir.path() / "resumed"));
  for (const std::string& f : boundaryFiles(dir.path() / "straight")) {
    EXPECT_EQ(test::readText((dir.path() / "straight" / "frames" / f).string()),
              test::readText((dir.path() / "resumed" / "frames" / f).string()))
        << f;
  }
  // A resumed series whose kept files are gone writes them again, and the
  // series still names files that exist.
  def.directory = dir.path() / "straight";
  fs::remove(def.directory / "frames" / "boundaries_000000_tool0.vtp");
  io::FrameWriter<D> again(def);
  again.truncateAfter(times[1]);
  World<D> w2 = toolWorld<D>();
  w2.step();
  w2.step();
  again.write(w2);
  const auto kept = boundaryEntries(def.directory);
  ASSERT_EQ(kept.size(), 9u);
  EXPECT_EQ(kept[7], std::make_pair(1, std::string("frames/boundaries_000002_tool0.vtp")));
  EXPECT_EQ(kept[6], std::make_pair(0, std::string("frames/boundaries_000000_planes.vtp")));
  EXPECT_TRUE(fs::exists(def.directory / "frames" / "boundaries_000002_tool0.vtp"));
}

}  // namespace

// Boundaries that do not move are written once and named by every frame's
// entry; a moving tool gets a file per frame; a resumed writer makes the same
// choices as an uninterrupted one (the same .pvd and files).
TEST(Vtk, StaticBoundariesWrittenOnce2D) { checkBoundariesWrittenOnce<2>(); }
TEST(Vtk, StaticBoundariesWrittenOnce3D) { checkBoundariesWrittenOnce<3>(); }

// Stress invariants of a known tensor: principal stresses 2, -1, -3 MPa (a
// rotated diagonal tensor in 3D); 2D plane stress 2, -1 MPa and 0 out of plane.
TEST(Vtk, StressInvariantsOfAKnownTensor) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Vec<3>(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
  const Mat<3> sigma3 = r * Vec<3>(-3e6, 2e6, -1e6).asDiagonal() * r.transpose();
  const io::StressInvariants s3 = io::stressInvariants<3>(sigma3);
  EXPECT_NEAR(s3.mean, -2e6 / 3.0, 1e-6);
  EXPECT_NEAR(s3.vonMises, std::sqrt(19.0) * 1e6, 1e-6);  // sqrt(((2+1)^2 + (-1+3)^2 + (-3-2)^2) / 2) MPa
  EXPECT_NEAR(s3.principal[0], 2e6, 1e-6);
  EXPECT_NEAR(s3.principal[1], -1e6, 1e-6);
  EXPECT_NEAR(s3.principal[2], -3e6, 1e-6);
  const Eigen::Matrix2d r2 = Eigen::Rotation2Dd(0.3).toRotationMatrix();
  const Mat<2> sigma2 = r2 * Vec<2>(-1e6, 2e6).asDiagonal() * r2.transpose();
  const io::StressInvariants s2 = io::stressInvariants<2>(sigma2);
  EXPECT_NEAR(s2.mean, 1e6 / 3.0, 1e-6);
  EXPECT_NEAR(s2.vonMises, std::sqrt(7.0) * 1e6, 1e-6);  // sqrt((3^2 + 1^2 + 2^2) / 2) MPa
  EXPECT_NEAR(s2.principal[0], 2e6, 1e-6);
  EXPECT_NEAR(s2.principal[1], -1e6, 1e-6);
  EXPECT_EQ(s2.principal[2], 0.0);
}

namespace {

// A grain resting on a floor under gravity: one contact, the floor's push m g
// straight up at the bottom, r below the centroid, so eq. 5 gives uniaxial
// compression sigma_yy = -m g r / V: mean stress sigma_yy / 3 and von Mises
// |sigma_yy| (3D; 2D plane stress the same, the out-of-plane stress being 0).
template <int D>
void checkRestingGrainStress() {
  ScratchDir dir("resting" + std::to_string(D));
  WorldDef<D> def;
  def.gravity = -9.81 * Vec<D>::Unit(1);
  def.globalDamping = 40.0;
  def.contact.kn = 1e6;
  World<D> w(def);
  PlaneDef<D> floor;
  floor.plane.point = Vec<D>::Zero();
  floor.plane.normal = Vec<D>::Unit(1);
  w.addPlane(floor);
  const double r = 0.05;
  ParticleDef<D> grain;
  grain.shape = test::sphereShape<D>(r);
  grain.position = Vec<D>::Unit(1) * (r + 0.002);
  w.addParticle(grain);
  while (w.time() < 0.5) w.step();
  ASSERT_LT(w.particles().velocity[0].norm(), 1e-3);  // at rest (it lands at about 0.2 m/s)
  io::FrameWriterDef<D> wd;
  wd.directory = dir.path();
  wd.surfaces = wd.boundaries = wd.contacts = false;
  io::FrameWriter<D> writer(wd);
  writer.write(w);
  const io::VtpPiece f = io::readVtp(dir.path() / "frames" / "particles_000000.vtp");
  const double m = w.particles().mass[0], volume = w.particles().shape[0]->volume();
  const double syy = -m * 9.81 * r / volume;
  const double mean = io::arrayAsDoubles(*io::findArray(f.pointData, "mean_stress"))[0];
  const double q = io::arrayAsDoubles(*io::findArray(f.pointData, "von_mises_stress"))[0];
  const std::vector<double> principal = io::arrayAsDoubles(*io::findArray(f.pointData, "principal_stress"));
  // The nodes in contact sit a little inside the bottom (overlap, node spread): 3 %.
  EXPECT_NEAR(mean, syy / 3.0, 0.03 * std::abs(syy / 3.0));
  EXPECT_NEAR(q, std::abs(syy), 0.03 * std::abs(syy));
  EXPECT_NEAR(principal[2 - (D == 2 ? 1 : 0)], syy, 0.03 * std::abs(syy));  // the most compressive
  EXPECT_LT(std::abs(principal[0]), 0.03 * std::abs(syy));
}

}  // namespace

TEST(Vtk, RestingGrainStressInvariants2D) { checkRestingGrainStress<2>(); }
TEST(Vtk, RestingGrainStressInvariants3D) { checkRestingGrainStress<3>(); }

// Pieces joined: points in turn, cells by kind (all lines before any
// polygon), arrays every piece has kept in their type (Float64 where the
// types differ), arrays only some pieces have left out.
TEST(Vtk, JoinPiecesKeepsCellOrderAndTypes) {
  io::VtpPiece a, b;
  a.points = {0, 0, 0, 1, 0, 0};
  a.lines.add(std::vector<std::int64_t>{0, 1});
  a.cellData.push_back({"kind", 1, std::vector<std::int32_t>{0}});
  a.cellData.push_back({"value", 1, std::vector<double>{0.5}});
  b.points = {0, 1, 0, 1, 1, 0, 0, 2, 0};
  b.polys.add(std::vector<std::int64_t>{0, 1, 2});
  b.lines.add(std::vector<std::int64_t>{2, 0});
  b.cellData.push_back({"kind", 1, std::vector<std::int32_t>{7, 1}});  // its line, then its polygon
  b.cellData.push_back({"value", 1, std::vector<float>{1.5f, 2.5f}});
  b.cellData.push_back({"extra", 1, std::vector<double>{9.0, 9.0}});
  const std::vector<io::VtpPiece> pieces{a, b};
  const io::VtpPiece j = io::joinPieces(pieces);
  EXPECT_EQ(j.pointCount(), 5u);
  EXPECT_EQ(j.lines.connectivity, (std::vector<std::int64_t>{0, 1, 4, 2}));
  EXPECT_EQ(j.lines.offsets, (std::vector<std::int64_t>{2, 4}));
  EXPECT_EQ(j.polys.connectivity, (std::vector<std::int64_t>{2, 3, 4}));
  ASSERT_EQ(j.cellData.size(), 2u);
  EXPECT_EQ(std::get<std::vector<std::int32_t>>(j.cellData[0].values), (std::vector<std::int32_t>{0, 7, 1}));
  EXPECT_EQ(std::get<std::vector<double>>(j.cellData[1].values), (std::vector<double>{0.5, 1.5, 2.5}));
  ScratchDir dir("join");
  io::writeVtp(dir / "j.vtp", j, VtkEncoding::Compressed);
  EXPECT_EQ(test::readVtp(dir / "j.vtp").cellArray("kind").i32, (std::vector<std::int32_t>{0, 7, 1}));
}
