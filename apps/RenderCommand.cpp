/// @file RenderCommand.cpp
/// @brief `lsdem render DIR [--frame N|last] [--series surfaces|particles] -o IMAGE.png
/// [--view AZ,EL] [--up x|y|z] [--size WxH] [--color id|generation] [--script FILE]`:
/// a PNG of one frame of a run (docs/render.md), drawn by gnuplot.
///
/// The frame is read back from the run's ParaView files (io/VtpRead.h). Every
/// face is projected here (orthographic), shaded and sorted back to front, and
/// gnuplot only fills 2D polygons in that order (painter's algorithm), so the
/// picture does not depend on gnuplot's 3D features. The gnuplot script, with
/// its data inline, is piped to gnuplot's standard input; nothing but the PNG
/// (and the script when asked for) is written. Exit 3 when gnuplot is missing,
/// 2 for a bad folder, frame or option.

#include "Commands.h"

#include "lsdem/io/InputError.h"
#include "lsdem/io/Plot.h"
#include "lsdem/io/Vtk.h"
#include "lsdem/io/VtpRead.h"

#include <Eigen/Dense>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <numbers>
#include <set>
#include <string>
#include <vector>

namespace lsdem::apps {
namespace {

namespace fs = std::filesystem;
using V2 = Eigen::Vector2d;
using V3 = Eigen::Vector3d;

struct RenderOptions {
  std::string dir;
  std::string frame = "last";
  std::string series = "surfaces";
  std::string output;
  std::string view = "-60,25";
  std::string up = "z";
  std::string size = "1200x900";
  std::string color = "id";
  std::string script;
};

// ---------------------------------------------------------------------------
// Options

// "a,b" -> two finite numbers.
std::array<double, 2> parsePair(const std::string& text, char separator, const std::string& option) {
  const std::size_t at = text.find(separator);
  std::array<double, 2> v{};
  bool ok = at != std::string::npos;
  for (int k = 0; ok && k < 2; ++k) {
    const std::string part = k == 0 ? text.substr(0, at) : text.substr(at + 1);
    const auto r = std::from_chars(part.data(), part.data() + part.size(), v[std::size_t(k)]);
    ok = !part.empty() && r.ec == std::errc() && r.ptr == part.data() + part.size() && std::isfinite(v[std::size_t(k)]);
  }
  if (!ok) {
    throw io::InputError(option, 0, "", "expected two numbers separated by '" + std::string(1, separator) + "', got '" + text + "'");
  }
  return v;
}

}  // namespace

std::array<int, 2> imageSize(const std::string& text) {
  std::string pair = text;
  std::replace(pair.begin(), pair.end(), 'X', 'x');
  const std::array<double, 2> size = parsePair(pair, 'x', "--size");
  for (const double v : size) {
    if (!(v >= 64 && v <= 8000 && v == std::floor(v))) {
      throw io::InputError("--size", 0, "", "width and height must be whole numbers of pixels in [64, 8000], got '" + text + "'");
    }
  }
  return {int(size[0]), int(size[1])};
}

namespace {

// ---------------------------------------------------------------------------
// Colours (0xRRGGBB)

std::uint32_t rgb(double r, double g, double b) {
  auto c = [](double x) { return std::uint32_t(std::lround(255.0 * std::clamp(x, 0.0, 1.0))); };
  return (c(r) << 16) | (c(g) << 8) | c(b);
}

std::uint32_t scaled(std::uint32_t colour, double factor) {
  return rgb(factor * double((colour >> 16) & 0xff) / 255.0, factor * double((colour >> 8) & 0xff) / 255.0,
             factor * double(colour & 0xff) / 255.0);
}

// A distinct colour per id: golden-ratio steps of hue, fixed saturation and value.
std::uint32_t idColour(std::uint64_t id) {
  const double h = std::fmod(0.58 + 0.6180339887498949 * double(id % 100000), 1.0) * 6.0;
  const double s = 0.55, v = 0.93;
  const int sector = int(h) % 6;
  const double f = h - std::floor(h);
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  switch (sector) {
    case 0: return rgb(v, t, p);
    case 1: return rgb(q, v, p);
    case 2: return rgb(p, v, t);
    case 3: return rgb(p, q, v);
    case 4: return rgb(t, p, v);
    default: return rgb(v, p, q);
  }
}

// Generation 0, 1, 2, ... : blue, orange, red, purple, green, brown, pink, then cycled.
std::uint32_t generationColour(std::int64_t generation) {
  static constexpr std::uint32_t kPalette[] = {0x4c72b0, 0xdd8452, 0xc44e52, 0x8172b3, 0x55a868, 0x937860, 0xda8bc3};
  return kPalette[std::size_t(std::max<std::int64_t>(generation, 0)) % std::size(kPalette)];
}

constexpr std::uint32_t kToolColour = 0xa7abb2;
constexpr std::uint32_t kPlaneColour = 0x555555;

// ---------------------------------------------------------------------------
// What is drawn

/// One filled polygon (or, with fill false, an open polyline) on screen.
struct Face {
  std::vector<V2> points;     ///< screen coordinates (2D: world x, y), m
  double depth = 0.0;         ///< larger is nearer the viewer (3D)
  std::uint32_t fill = 0;     ///< fill colour
  std::uint32_t line = 0;     ///< outline colour (2D)
};

/// Everything of one picture, in drawing order per layer.
struct Picture {
  std::vector<Face> planes;  ///< 2D: plane segments (lines)
  std::vector<Face> faces;   ///< filled polygons, drawn in order
  bool outlines = false;     ///< 2D: draw each face's outline too
  std::string title;
  bool axes = true;
  std::string unit = "m";  ///< 2D: unit of the axes ("m", or "mm" for small scenes)
};

/// Orthographic view of a 3D scene.
struct Camera {
  V3 toEye, right, up, light;

  Camera(double azimuthDeg, double elevationDeg, const std::string& upAxis) {
    // The horizontal axes and the vertical one, right-handed.
    V3 e1, e2, vertical;
    if (upAxis == "x") {
      e1 = V3::UnitY(), e2 = V3::UnitZ(), vertical = V3::UnitX();
    } else if (upAxis == "y") {
      e1 = V3::UnitZ(), e2 = V3::UnitX(), vertical = V3::UnitY();
    } else {
      e1 = V3::UnitX(), e2 = V3::UnitY(), vertical = V3::UnitZ();
    }
    const double az = azimuthDeg * std::numbers::pi / 180.0, el = elevationDeg * std::numbers::pi / 180.0;
    toEye = std::cos(el) * (std::cos(az) * e1 + std::sin(az) * e2) + std::sin(el) * vertical;
    // Screen axes: right and up (straight down or up: the azimuth's horizontal).
    right = vertical.cross(toEye);
    if (right.norm() < 1e-9) right = -std::sin(az) * e1 + std::cos(az) * e2;
    right.normalize();
    up = toEye.cross(right);
    // A light over the viewer's left shoulder.
    light = (toEye + 0.6 * up - 0.35 * right).normalized();
  }
  V2 project(const V3& x) const { return {x.dot(right), x.dot(up)}; }
  double depth(const V3& x) const { return x.dot(toEye); }
};

V3 point(const io::VtpPiece& piece, std::int64_t i) {
  const double* p = piece.points.data() + 3 * std::size_t(i);
  return {p[0], p[1], p[2]};
}

// A cell array as int64 values, or empty when the array is absent.
std::vector<std::int64_t> cellInts(const std::vector<io::VtkArray>& arrays, const char* name) {
  std::vector<std::int64_t> out;
  if (const io::VtkArray* a = io::findArray(arrays, name)) {
    for (double v : io::arrayAsDoubles(*a)) out.push_back(std::int64_t(v));
  }
  return out;
}

// Cells of one block as index lists.
template <class F>
void forEachCell(const io::VtkCells& cells, F&& f) {
  std::int64_t begin = 0;
  for (std::int64_t end : cells.offsets) {
    f(std::span<const std::int64_t>(cells.connectivity.data() + begin, std::size_t(end - begin)));
    begin = end;
  }
}

// A 3D polygon as a face shaded by its normal against the light (two-sided).
Face shadedFace(const std::vector<V3>& corners, std::uint32_t base, const Camera& camera) {
  Face f;
  V3 normal = V3::Zero(), centre = V3::Zero();
  for (std::size_t k = 0; k < corners.size(); ++k) {
    normal += corners[k].cross(corners[(k + 1) % corners.size()]);
    centre += corners[k];
  }
  centre /= double(corners.size());
  const double shade = normal.norm() > 0.0 ? 0.32 + 0.68 * std::abs(normal.normalized().dot(camera.light)) : 0.32;
  f.fill = scaled(base, shade);
  f.depth = camera.depth(centre);
  for (const V3& x : corners) f.points.push_back(camera.project(x));
  return f;
}

// A 3D segment as thin screen-space quads (so faces in front hide it).
void addSegment(std::vector<Face>& faces, const V3& a, const V3& b, double width, std::uint32_t colour,
                const Camera& camera) {
  const int pieces = 24;
  for (int k = 0; k < pieces; ++k) {
    const V3 p = a + (b - a) * (double(k) / pieces), q = a + (b - a) * (double(k + 1) / pieces);
    const V2 s = camera.project(p), t = camera.project(q);
    V2 n(-(t - s).y(), (t - s).x());
    if (n.norm() == 0.0) continue;
    n *= 0.5 * width / n.norm();
    Face f;
    f.points = {s - n, t - n, t + n, s + n};
    f.depth = camera.depth(0.5 * (p + q)) + 1e-9;
    f.fill = colour;
    faces.push_back(std::move(f));
  }
}

// A unit icosphere (radius 1): 20 faces split `levels` times.
std::vector<std::array<V3, 3>> icosphere(int levels) {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<V3> v{{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                    {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  const int f[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                        {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                        {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  std::vector<std::array<V3, 3>> tris;
  for (const auto& t : f) tris.push_back({v[t[0]].normalized(), v[t[1]].normalized(), v[t[2]].normalized()});
  // Each split makes four triangles of one, corners pushed onto the sphere.
  for (int l = 0; l < levels; ++l) {
    std::vector<std::array<V3, 3>> next;
    for (const auto& t : tris) {
      const V3 a = (t[0] + t[1]).normalized(), b = (t[1] + t[2]).normalized(), c = (t[2] + t[0]).normalized();
      next.push_back({t[0], a, c});
      next.push_back({a, t[1], b});
      next.push_back({c, b, t[2]});
      next.push_back({a, b, c});
    }
    tris = std::move(next);
  }
  return tris;
}

// ---------------------------------------------------------------------------
// Frames of a run

/// One frame of one series: the piece and its time.
struct Frame {
  io::VtpPiece piece;
  double time = 0.0;
  std::size_t index = 0;
  std::size_t count = 0;  ///< frames in the series
};

std::optional<Frame> readFrame(const fs::path& dir, const std::string& series, const std::string& frameText,
                               bool required) {
  const fs::path pvd = dir / (series + ".pvd");
  std::error_code ec;
  if (!fs::is_regular_file(pvd, ec)) {
    if (!required) return std::nullopt;
    throw io::InputError(dir.string(), 0, "",
                         "has no " + series + ".pvd (is it the output folder of `lsdem run`, with the '" + series +
                             "' series in [output] vtk?)");
  }
  const std::vector<io::PvdSeries::Entry> entries = io::readPvd(pvd);
  const std::size_t frames = io::frameCount(entries);
  if (frames == 0) {
    if (!required) return std::nullopt;
    throw io::InputError(pvd.string(), 0, "", "lists no frames");
  }
  // The frame number: "last" or an index into the series.
  std::size_t index = frames - 1;
  if (frameText != "last") {
    std::uint64_t n = 0;
    const auto r = std::from_chars(frameText.data(), frameText.data() + frameText.size(), n);
    if (frameText.empty() || r.ec != std::errc() || r.ptr != frameText.data() + frameText.size()) {
      throw io::InputError("--frame", 0, "", "expected a frame number or 'last', got '" + frameText + "'");
    }
    if (n >= frames) {
      if (!required) return std::nullopt;
      throw io::InputError("--frame", 0, "",
                           "frame " + frameText + " does not exist; " + pvd.string() + " lists frames 0 to " +
                               std::to_string(frames - 1));
    }
    index = std::size_t(n);
  }
  // The frame's parts (boundaries: the planes and each tool), joined.
  const std::vector<io::PvdSeries::Entry> parts = io::frameEntries(entries, index);
  std::vector<io::VtpPiece> pieces;
  for (const io::PvdSeries::Entry& e : parts) {
    const fs::path file = dir / e.file;
    if (!fs::is_regular_file(file, ec)) {
      throw io::InputError(pvd.string(), 0, "", "lists frame file '" + e.file + "', which does not exist");
    }
    pieces.push_back(io::readVtp(file));
  }
  io::VtpPiece piece = pieces.size() == 1 ? std::move(pieces[0]) : io::joinPieces(pieces);
  return Frame{std::move(piece), parts.front().time, index, frames};
}

// ---------------------------------------------------------------------------
// Building the picture

struct Colouring {
  bool byGeneration = false;
  std::uint32_t of(std::uint64_t id, std::int64_t generation) const {
    return byGeneration ? generationColour(generation) : idColour(id);
  }
};

// 2D: outlines of particles (filled), planes as segments, tools filled grey.
void build2d(Picture& pic, const io::VtpPiece& surfaces, const std::string& series, const io::VtpPiece* boundaries,
             const Colouring& colouring) {
  auto xy = [](const io::VtpPiece& piece, std::int64_t i) { return V2(point(piece, i).x(), point(piece, i).y()); };
  pic.outlines = true;
  // Boundaries: planes as thick segments, tools as grey regions.
  if (boundaries) {
    const std::vector<std::int64_t> kind = cellInts(boundaries->cellData, "kind");
    // Planes are line cells, tools polygons (closed polylines in frames of
    // earlier releases): cell data in VTK's order, lines before polygons.
    std::size_t c = boundaries->verts.size();
    const auto add = [&](std::span<const std::int64_t> ids) {
      Face f;
      for (std::int64_t i : ids) f.points.push_back(xy(*boundaries, i));
      const bool plane = c < kind.size() && kind[c] == 0;
      f.fill = plane ? kPlaneColour : kToolColour;
      f.line = plane ? kPlaneColour : scaled(kToolColour, 0.55);
      (plane ? pic.planes : pic.faces).push_back(std::move(f));
      ++c;
    };
    forEachCell(boundaries->lines, add);
    forEachCell(boundaries->polys, add);
  }
  if (series == "particles") {
    // Circles of the particles' equivalent diameters.
    const io::VtkArray* d = io::findArray(surfaces.pointData, "equivalent_diameter");
    const std::vector<double> diameter = d ? io::arrayAsDoubles(*d) : std::vector<double>(surfaces.pointCount(), 0.0);
    const std::vector<std::int64_t> id = cellInts(surfaces.pointData, "id"), gen = cellInts(surfaces.pointData, "generation");
    for (std::size_t i = 0; i < surfaces.pointCount(); ++i) {
      Face f;
      const V2 c = xy(surfaces, std::int64_t(i));
      for (int k = 0; k <= 48; ++k) {
        const double a = 2.0 * std::numbers::pi * k / 48.0;
        f.points.push_back(c + 0.5 * diameter[i] * V2(std::cos(a), std::sin(a)));
      }
      f.fill = colouring.of(i < id.size() ? std::uint64_t(id[i]) : i, i < gen.size() ? gen[i] : 0);
      f.line = scaled(f.fill, 0.5);
      pic.faces.push_back(std::move(f));
    }
    return;
  }
  // Surfaces: one closed loop per polygon cell (per closed line cell in
  // frames of earlier releases).
  const std::vector<std::int64_t> id = cellInts(surfaces.cellData, "id"), gen = cellInts(surfaces.cellData, "generation");
  std::size_t c = surfaces.verts.size();
  const auto add = [&](std::span<const std::int64_t> ids) {
    Face f;
    for (std::int64_t i : ids) f.points.push_back(xy(surfaces, i));
    f.fill = colouring.of(c < id.size() ? std::uint64_t(id[c]) : c, c < gen.size() ? gen[c] : 0);
    f.line = scaled(f.fill, 0.5);
    pic.faces.push_back(std::move(f));
    ++c;
  };
  forEachCell(surfaces.lines, add);
  forEachCell(surfaces.polys, add);
}

// 3D: shaded triangles of particles and tools, plane outlines, back to front.
void build3d(Picture& pic, const io::VtpPiece& surfaces, const std::string& series, const io::VtpPiece* boundaries,
             const Colouring& colouring, const Camera& camera, double lineWidth) {
  pic.axes = false;
  std::vector<V3> corners;
  if (boundaries) {
    const std::vector<std::int64_t> kind = cellInts(boundaries->cellData, "kind");
    std::size_t c = boundaries->verts.size() + boundaries->lines.size();
    forEachCell(boundaries->polys, [&](std::span<const std::int64_t> ids) {
      corners.clear();
      for (std::int64_t i : ids) corners.push_back(point(*boundaries, i));
      if (c < kind.size() && kind[c] == 0) {
        // A plane: its outline only.
        for (std::size_t k = 0; k < corners.size(); ++k) {
          addSegment(pic.faces, corners[k], corners[(k + 1) % corners.size()], lineWidth, kPlaneColour, camera);
        }
      } else if (corners.size() >= 3) {
        pic.faces.push_back(shadedFace(corners, kToolColour, camera));
      }
      ++c;
    });
  }
  if (series == "particles") {
    // Spheres of the particles' equivalent diameters.
    static const std::vector<std::array<V3, 3>> sphere = icosphere(2);
    const io::VtkArray* d = io::findArray(surfaces.pointData, "equivalent_diameter");
    const std::vector<double> diameter = d ? io::arrayAsDoubles(*d) : std::vector<double>(surfaces.pointCount(), 0.0);
    const std::vector<std::int64_t> id = cellInts(surfaces.pointData, "id"), gen = cellInts(surfaces.pointData, "generation");
    for (std::size_t i = 0; i < surfaces.pointCount(); ++i) {
      const V3 c = point(surfaces, std::int64_t(i));
      const std::uint32_t base = colouring.of(i < id.size() ? std::uint64_t(id[i]) : i, i < gen.size() ? gen[i] : 0);
      for (const auto& t : sphere) {
        corners = {c + 0.5 * diameter[i] * t[0], c + 0.5 * diameter[i] * t[1], c + 0.5 * diameter[i] * t[2]};
        pic.faces.push_back(shadedFace(corners, base, camera));
      }
    }
  } else {
    // Surface triangles.
    const std::vector<std::int64_t> id = cellInts(surfaces.cellData, "id"), gen = cellInts(surfaces.cellData, "generation");
    std::size_t c = surfaces.verts.size() + surfaces.lines.size();
    forEachCell(surfaces.polys, [&](std::span<const std::int64_t> ids) {
      corners.clear();
      for (std::int64_t i : ids) corners.push_back(point(surfaces, i));
      if (corners.size() >= 3) {
        pic.faces.push_back(
            shadedFace(corners, colouring.of(c < id.size() ? std::uint64_t(id[c]) : c, c < gen.size() ? gen[c] : 0), camera));
      }
      ++c;
    });
  }
  // Painter's order: farthest first.
  std::stable_sort(pic.faces.begin(), pic.faces.end(), [](const Face& a, const Face& b) { return a.depth < b.depth; });
}

// ---------------------------------------------------------------------------
// The gnuplot script

std::string quoted(const std::string& s) {
  std::string q(1, '\'');
  for (char c : s) {
    q.push_back(c);
    if (c == '\'') q.push_back(c);
  }
  return q + '\'';
}

void appendNumber(std::string& out, double v) {
  char buf[32];
  const int n = std::snprintf(buf, sizeof(buf), "%.7g", v);
  out.append(buf, std::size_t(n));
}

// One polygon per block ("x y colour" rows, a blank line after each).
void appendBlock(std::string& out, const std::string& name, const std::vector<Face>& faces, bool fillColour, bool close) {
  out += "$" + name + " << EOD\n";
  for (const Face& f : faces) {
    const std::uint32_t colour = fillColour ? f.fill : f.line;
    const std::string tail = " " + std::to_string(colour) + "\n";
    for (const V2& p : f.points) {
      appendNumber(out, p.x());
      out += ' ';
      appendNumber(out, p.y());
      out += tail;
    }
    if (close && !f.points.empty() && f.points.front() != f.points.back()) {
      appendNumber(out, f.points.front().x());
      out += ' ';
      appendNumber(out, f.points.front().y());
      out += tail;
    }
    out += '\n';
  }
  out += "EOD\n";
}

std::string gnuplotScript(const Picture& pic, const std::string& output, int width, int height, V2 lo, V2 hi) {
  std::string s;
  s += "# lsdem render: run with `gnuplot THIS_FILE`\n";
  s += "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) { set terminal pngcairo size " + std::to_string(width) + "," +
       std::to_string(height) + " noenhanced font '," + std::to_string(std::clamp(width / 85, 8, 14)) + "' } else { set terminal png size " + std::to_string(width) + "," +
       std::to_string(height) + " noenhanced }\n";
  s += "set output " + quoted(output) + "\n";
  s += "set title " + quoted(pic.title) + " noenhanced\n";
  s += "set size ratio -1\nunset key\n";
  if (pic.axes) {
    s += "set xlabel 'x (" + pic.unit + ")'\nset ylabel 'y (" + pic.unit + ")'\nset grid lc rgb '#dddddd'\n";
  } else {
    s += "unset border\nunset xtics\nunset ytics\n";
  }
  s += "set xrange [";
  appendNumber(s, lo.x());
  s += ":";
  appendNumber(s, hi.x());
  s += "]\nset yrange [";
  appendNumber(s, lo.y());
  s += ":";
  appendNumber(s, hi.y());
  s += "]\n";
  s += "set style fill solid 1.0 noborder\n";
  // Data blocks, then one plot command drawing them in order.
  if (!pic.planes.empty()) appendBlock(s, "PLANES", pic.planes, true, false);
  appendBlock(s, "FACES", pic.faces, true, true);
  if (pic.outlines) appendBlock(s, "LINES", pic.faces, false, true);
  s += "plot ";
  if (!pic.planes.empty()) s += "$PLANES using 1:2:3 with lines lw 4 lc rgb variable, ";
  s += "$FACES using 1:2:3 with filledcurves closed fillcolor rgb variable";
  if (pic.outlines) s += ", $LINES using 1:2:3 with lines lw 1.2 lc rgb variable";
  s += "\n";
  return s;
}

// Pipes `script` into gnuplot; returns its exit status (127: not started).
int runGnuplot(const std::string& script) {
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error("cannot start gnuplot (pipe failed)");
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("cannot start gnuplot (fork failed)");
  if (pid == 0) {
    // Child: the pipe is its standard input.
    dup2(fds[0], STDIN_FILENO);
    close(fds[0]);
    close(fds[1]);
    execlp("gnuplot", "gnuplot", static_cast<char*>(nullptr));
    _exit(127);
  }
  close(fds[0]);
  // Write the whole script; a gnuplot that stopped early must not kill us by SIGPIPE.
  void (*previous)(int) = std::signal(SIGPIPE, SIG_IGN);
  std::size_t written = 0;
  while (written < script.size()) {
    const ssize_t n = write(fds[1], script.data() + written, script.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    written += std::size_t(n);
  }
  close(fds[1]);
  std::signal(SIGPIPE, previous);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error("waiting for gnuplot failed");
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

bool isPng(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  return in && std::string(magic, 8) == std::string("\x89PNG\r\n\x1a\n", 8);
}

// ---------------------------------------------------------------------------
// The command

void render(const RenderOptions& o) {
  // Check the options before reading anything.
  if (o.series != "surfaces" && o.series != "particles") {
    throw io::InputError("--series", 0, "", "expected 'surfaces' or 'particles', got '" + o.series + "'");
  }
  if (o.color != "id" && o.color != "generation") {
    throw io::InputError("--color", 0, "", "expected 'id' or 'generation', got '" + o.color + "'");
  }
  if (o.up != "x" && o.up != "y" && o.up != "z") throw io::InputError("--up", 0, "", "expected x, y or z, got '" + o.up + "'");
  const std::array<double, 2> view = parsePair(o.view, ',', "--view");
  const std::array<int, 2> size = imageSize(o.size);
  const fs::path output(o.output);
  if (output.extension() != ".png") throw io::InputError("-o", 0, "", "the image must end in .png, got '" + o.output + "'");
  std::error_code ec;
  const fs::path outDir = output.has_parent_path() ? output.parent_path() : fs::path(".");
  if (!fs::is_directory(outDir, ec)) throw io::InputError("-o", 0, "", "folder '" + outDir.string() + "' does not exist");
  const fs::path dir(o.dir);
  if (!fs::is_directory(dir, ec)) throw io::InputError(o.dir, 0, "", "is not a folder");

  // The frame, and the boundaries of the same frame number when the run wrote them.
  const Frame frame = *readFrame(dir, o.series, o.frame, true);
  const std::optional<Frame> boundaries = readFrame(dir, "boundaries", std::to_string(frame.index), false);
  const io::VtpPiece* bounds = boundaries ? &boundaries->piece : nullptr;

  // Without gnuplot: say so (after the input is checked) and exit 3.
  if (!io::gnuplotAvailable()) {
    std::cerr << "lsdem render: gnuplot is not installed (apt-get install gnuplot-nox); the frames in " << o.dir
              << " open in ParaView\n";
    throw CLI::RuntimeError(3);
  }

  // Dimension: 2D runs are written in z = 0 (3D surfaces carry normals).
  const io::VtpPiece& piece = frame.piece;
  bool flat = true;
  for (const io::VtpPiece* p : {&piece, bounds}) {
    if (!p) continue;
    for (std::size_t i = 2; i < p->points.size(); i += 3) flat = flat && p->points[i] == 0.0;
  }
  const bool is2d = flat && io::findArray(piece.pointData, "Normals") == nullptr;

  // Particles in the frame (distinct ids).
  std::set<std::int64_t> ids;
  for (std::int64_t i : cellInts(o.series == "particles" ? piece.pointData : piece.cellData, "id")) ids.insert(i);

  // The picture, with equal scaling in screen space.
  Picture pic;
  Colouring colouring{o.color == "generation"};
  const Camera camera(view[0], view[1], o.up);
  if (is2d) {
    build2d(pic, piece, o.series, bounds, colouring);
  } else {
    // First pass for the extent (line widths and face growth are in pixels).
    Picture probe;
    build3d(probe, piece, o.series, bounds, colouring, camera, 0.0);
    V2 lo = V2::Constant(1e300), hi = V2::Constant(-1e300);
    for (const Face& f : probe.faces) {
      for (const V2& p : f.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    }
    const double pixel = lo.x() <= hi.x() ? std::max((hi - lo).x() / size[0], (hi - lo).y() / size[1]) : 0.0;
    build3d(pic, piece, o.series, bounds, colouring, camera, 1.6 * pixel);
    // Grow each face by half a pixel so neighbours leave no hairline seams.
    for (Face& f : pic.faces) {
      V2 c = V2::Zero();
      for (const V2& p : f.points) c += p;
      c /= double(f.points.size());
      for (V2& p : f.points) {
        const double r = (p - c).norm();
        if (r > 0.0) p += (0.6 * pixel / r) * (p - c);
      }
    }
  }
  V2 lo = V2::Constant(1e300), hi = V2::Constant(-1e300);
  for (const auto* layer : {&pic.planes, &pic.faces}) {
    for (const Face& f : *layer) {
      for (const V2& p : f.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    }
  }
  if (!(lo.x() <= hi.x())) throw io::InputError(o.dir, 0, "", "frame " + std::to_string(frame.index) + " has nothing to draw");
  const V2 margin = V2::Constant(0.03 * std::max((hi - lo).maxCoeff(), 1e-12));
  lo -= margin;
  hi += margin;
  // Small 2D scenes are labelled in millimetres.
  if (is2d && (hi - lo).maxCoeff() < 0.05) {
    pic.unit = "mm";
    for (auto* layer : {&pic.planes, &pic.faces}) {
      for (Face& f : *layer) {
        for (V2& p : f.points) p *= 1000.0;
      }
    }
    lo *= 1000.0;
    hi *= 1000.0;
  }

  // Title: the run, the frame, its time and particle count.
  char title[512];
  const std::string runName = fs::absolute(dir).lexically_normal().filename().string().empty()
                                  ? fs::absolute(dir).lexically_normal().parent_path().filename().string()
                                  : fs::absolute(dir).lexically_normal().filename().string();
  std::snprintf(title, sizeof(title), "%s: frame %zu/%zu, t = %.4g s, %zu particles", runName.c_str(), frame.index,
                frame.count - 1, frame.time, ids.size());
  pic.title = title;

  // Draw: the script (kept when asked for), piped to gnuplot.
  const std::string script = gnuplotScript(pic, output.string(), int(size[0]), int(size[1]), lo, hi);
  if (!o.script.empty()) io::writeFileAtomically(o.script, script);
  fs::remove(output, ec);
  const int status = runGnuplot(script);
  if (status == 127) {
    std::cerr << "lsdem render: gnuplot could not be started\n";
    throw CLI::RuntimeError(3);
  }
  if (status != 0 || !isPng(output)) {
    throw std::runtime_error("gnuplot failed to draw " + output.string() + " (exit status " + std::to_string(status) +
                             "; rerun with --script FILE to see the script)");
  }
  std::cout << "wrote " << output.string() << " (" << (is2d ? "2D" : "3D") << ", frame " << frame.index << ", t = "
            << frame.time << " s, " << ids.size() << " particles, " << pic.faces.size() << " faces)\n";
}

}  // namespace

void addRenderCommand(CLI::App& app) {
  auto opts = std::make_shared<RenderOptions>();
  CLI::App* cmd = app.add_subcommand("render", "PNG image of one frame of a run (needs gnuplot; docs/render.md)");
  cmd->add_option("dir", opts->dir, "a run's output folder (written by lsdem run)")->required();
  cmd->add_option("-o,--output", opts->output, "the PNG file to write")->required();
  cmd->add_option("--frame", opts->frame, "frame number (from 0) or 'last'")->capture_default_str();
  cmd->add_option("--series", opts->series, "surfaces (outlines / surfaces) or particles (equivalent circles / spheres)")
      ->capture_default_str();
  cmd->add_option("--view", opts->view, "3D: azimuth,elevation of the viewer in degrees")->capture_default_str();
  cmd->add_option("--up", opts->up, "3D: the world axis drawn vertical (x, y or z)")->capture_default_str();
  cmd->add_option("--size", opts->size, "image size WxH in pixels")->capture_default_str();
  cmd->add_option("--color", opts->color, "colour particles by 'id' or 'generation'")->capture_default_str();
  cmd->add_option("--script", opts->script, "also write the gnuplot script (data inline) to this file");
  cmd->callback([opts] { render(*opts); });
}

}  // namespace lsdem::apps
