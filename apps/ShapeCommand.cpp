/// @file ShapeCommand.cpp
/// @brief `lsdem shape FILE.toml [--json]`: builds the shape a `[shape]` table
/// declares and prints its mass properties (per unit density), descriptors,
/// grid size, node count and memory.

#include "Commands.h"

#include "lsdem/geometry/Contours.h"
#include "lsdem/io/JsonWriter.h"
#include "lsdem/io/ShapeFile.h"

#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

namespace lsdem::apps {
namespace {

using geometry::Shape;

struct ShapeReport {
  int dimension;
  double volume;
  double enclosedVolume;  // inside the zero level set as the surfaces output draws it
  Eigen::VectorXd centroid;
  Eigen::VectorXd inertiaPrincipal;  // 3 principal moments in 3D; the polar moment in 2D
  double surfaceArea, circularity, aspectRatio, equivalentDiameter, sieveSize, intermediateAxis;
  Eigen::VectorXi gridDims;
  std::size_t gridValues, nodes, bytes;
  double spacing, buildSeconds;
};

template <int D>
ShapeReport report(const io::ShapeDecl& decl) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::string> notes;
  const std::shared_ptr<const Shape<D>> shape = io::buildDeclaredShape<D>(decl, &notes);
  // (What `lsdem run` notes of a shape, said here too.)
  for (const std::string& n : notes) std::cerr << "lsdem: note: " << n << '\n';
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto& mass = shape->mass();
  const auto& desc = shape->descriptors();
  ShapeReport r;
  r.dimension = D;
  r.volume = mass.volume;
  r.enclosedVolume = geometry::enclosedVolume<D>(shape->grid());
  // The centroid in the frame the shape was declared in (its grid frame).
  r.centroid = shape->bodyToGrid().translation;
  if constexpr (D == 3) {
    r.inertiaPrincipal = mass.principalInertia();
  } else {
    r.inertiaPrincipal = Eigen::VectorXd::Constant(1, mass.polarMoment());
  }
  r.surfaceArea = desc.surfaceArea;
  r.circularity = desc.circularity;
  r.aspectRatio = desc.aspectRatio;
  r.equivalentDiameter = desc.equivalentDiameter;
  r.sieveSize = desc.sieveSize;
  r.intermediateAxis = desc.intermediateAxis;
  r.gridDims = shape->grid().dims().matrix();
  r.gridValues = shape->grid().size();
  r.nodes = shape->nodes().size();
  r.bytes = shape->bytes();
  r.spacing = shape->grid().spacing();
  r.buildSeconds = seconds;
  return r;
}

void printJson(const ShapeReport& r) {
  io::JsonWriter w(std::cout);
  w.beginObject().field("dimension", r.dimension).field("volume", r.volume)
      .field(r.dimension == 2 ? "enclosed_area" : "enclosed_volume", r.enclosedVolume)
      .field("centroid", r.centroid);
  if (r.dimension == 3) {
    w.field("inertia_principal", r.inertiaPrincipal);
  } else {
    w.field("inertia_principal", r.inertiaPrincipal[0]);
  }
  w.field("surface_area", r.surfaceArea)
      .field(r.dimension == 2 ? "circularity" : "sphericity", r.circularity)
      .field("aspect_ratio", r.aspectRatio)
      .field("equivalent_diameter", r.equivalentDiameter)
      .field("sieve_size", r.sieveSize);
  if (r.dimension == 3) w.field("intermediate_axis", r.intermediateAxis);
  w.field("spacing", r.spacing)
      .field("grid_cells", r.gridDims.cast<double>())
      .field("grid_values", r.gridValues)
      .field("nodes", r.nodes)
      .field("bytes", r.bytes)
      .field("build_seconds", r.buildSeconds)
      .endObject();
}

void printText(const ShapeReport& r, const std::string& file) {
  const bool two = r.dimension == 2;
  auto vec = [](const Eigen::VectorXd& v) {
    std::string s;
    for (Eigen::Index i = 0; i < v.size(); ++i) {
      char buf[32];
      std::snprintf(buf, sizeof(buf), "%s%.6g", i ? ", " : "", v[i]);
      s += buf;
    }
    return "(" + s + ")";
  };
  std::printf("shape %s (%dD), per unit density\n", file.c_str(), r.dimension);
  std::printf("  %-22s %.6g %s\n", two ? "area" : "volume", r.volume, two ? "m^2" : "m^3");
  std::printf("  %-22s %.6g %s (%+.2f %% from the %s)\n", two ? "enclosed area" : "enclosed volume",
              r.enclosedVolume, two ? "m^2" : "m^3", 100.0 * (r.enclosedVolume / r.volume - 1.0),
              two ? "area" : "volume");
  std::printf("  %-22s %s m\n", "centroid", vec(r.centroid).c_str());
  if (two) {
    std::printf("  %-22s %.6g m^4\n", "polar moment", r.inertiaPrincipal[0]);
  } else {
    std::printf("  %-22s %s m^5\n", "principal inertia", vec(r.inertiaPrincipal).c_str());
  }
  std::printf("  %-22s %.6g %s\n", two ? "perimeter" : "surface area", r.surfaceArea, two ? "m" : "m^2");
  // (Measured from the grid's volume and the nodes' perimeter or area, it can
  // come out a little above 1 for a circle or sphere.)
  std::printf("  %-22s %.6g%s\n", two ? "circularity" : "sphericity", r.circularity,
              r.circularity > 1.0 ? (two ? " (over 1 from the discretised area and perimeter; a circle is 1)"
                                         : " (over 1 from the discretised volume and area; a sphere is 1)")
                                  : "");
  std::printf("  %-22s %.6g\n", "aspect ratio", r.aspectRatio);
  std::printf("  %-22s %.6g m\n", "equivalent diameter", r.equivalentDiameter);
  std::printf("  %-22s %.6g m\n", "sieve size", r.sieveSize);
  if (!two) std::printf("  %-22s %.6g m\n", "intermediate axis", r.intermediateAxis);
  std::printf("  %-22s %s nodes, spacing %.6g m (%zu values)\n", "grid",
              vec(r.gridDims.cast<double>()).c_str(), r.spacing, r.gridValues);
  std::printf("  %-22s %zu\n", "surface nodes", r.nodes);
  std::printf("  %-22s %zu bytes\n", "memory", r.bytes);
  std::printf("  %-22s %.3f s\n", "build time", r.buildSeconds);
}

}  // namespace

void addShapeCommand(CLI::App& app) {
  struct Options {
    std::string file;
    bool json = false;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("shape", "Build one shape from a [shape] table and print its properties");
  cmd->add_option("file", opts->file, "TOML file with a [shape] table (keys: docs/shapes.md)")->required();
  cmd->add_flag("--json", opts->json, "Print JSON instead of text");
  cmd->callback([opts] {
    const io::ShapeDecl decl = io::readShapeFile(opts->file);
    const ShapeReport r = decl.dimension() == 2 ? report<2>(decl) : report<3>(decl);
    if (opts->json) {
      printJson(r);
    } else {
      printText(r, opts->file);
    }
  });
}

}  // namespace lsdem::apps
