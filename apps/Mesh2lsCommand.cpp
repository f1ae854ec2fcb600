/// @file Mesh2lsCommand.cpp
/// @brief `lsdem mesh2ls MESH --spacing H [--scale S] [--nodes-per-cell N]
/// [--nodes-on exact_surface|grid] [--binary] -o OUT.lsg [--json]`: turns a
/// closed CAD mesh (STL/OBJ/PLY) into a level-set grain file (docs/grains.md),
/// its surface nodes on the mesh's triangles (or on the grid's zero set), and
/// prints the grain's volume, centroid and node count.

#include "Commands.h"

#include "lsdem/geometry/Components.h"
#include "lsdem/geometry/MeshIO.h"
#include "lsdem/geometry/MeshToLevelSet.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/ShapeDef.h"
#include "lsdem/geometry/SurfaceNodes.h"
#include "lsdem/io/GrainFile.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/JsonWriter.h"
#include "lsdem/io/ShapeFile.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace lsdem::apps {
namespace {

struct Mesh2lsOptions {
  std::string mesh;
  std::string output;
  double spacing = 0.0;
  double scale = 1.0;
  double nodesPerCell = 2.0;
  std::string nodesOn = "exact_surface";
  bool binary = false;
  bool json = false;
};

void run(const Mesh2lsOptions& o) {
  // Check the options before reading anything.
  requirePositive("--spacing", o.spacing);
  requirePositive("--scale", o.scale);
  requirePositive("--nodes-per-cell", o.nodesPerCell);
  if (o.nodesOn != "exact_surface" && o.nodesOn != "grid") {
    throw io::InputError("--nodes-on", 0, "", "must be exact_surface or grid, got '" + o.nodesOn + "'");
  }
  std::error_code ec;
  if (!std::filesystem::is_regular_file(o.mesh, ec)) throw io::InputError(o.mesh, 0, "", "no such mesh file");

  // Read and check the mesh; a broken one is reported by file name and problem.
  geometry::TriangleMesh mesh;
  geometry::MeshImportReport imported;
  try {
    mesh = geometry::readMesh(o.mesh, o.scale, &imported);
  } catch (const geometry::MeshError& e) {
    throw io::InputError(o.mesh, 0, "", e.what());
  }
  if (!imported.describe().empty()) std::cerr << "lsdem: note: " << o.mesh << ": " << imported.describe() << '\n';
  const geometry::MeshReport report = geometry::inspectMesh(mesh);
  if (!report.ok()) throw io::InputError(o.mesh, 0, "", "mesh " + report.describe());

  // Level set, shape (mass properties, principal frame, nodes) and the grain file.
  try {
    geometry::checkMeshResolution(mesh, o.spacing);
  } catch (const geometry::ResolutionError& e) {
    throw io::InputError("--spacing", 0, "", e.what());
  }
  geometry::Grid<3> grid;
  try {
    grid = geometry::meshToLevelSet(mesh, o.spacing, geometry::kDefaultPaddingCells, o.mesh);
  } catch (const geometry::MeshError& e) {
    throw io::InputError(o.mesh, 0, "", e.what());
  }
  // A grain is one body.
  std::vector<int> labels;
  if (const int bodies = geometry::labelComponents<3>(grid, labels); bodies > 1) {
    throw io::InputError(o.mesh, 0, "", "mesh holds " + std::to_string(bodies) +
                                            " separate bodies; a grain is one (give each body its own file)");
  }
  geometry::ShapeOptions options;
  options.nodesPerCell = o.nodesPerCell;
  std::shared_ptr<const geometry::Shape<3>> shape;
  try {
    // Nodes made on the grid's zero set, then moved on to the triangles.
    if (o.nodesOn == "grid") {
      shape = geometry::Shape<3>::fromGrid(std::move(grid), options);
    } else {
      geometry::NodeSet<3> nodes = geometry::surfaceNodes(grid, o.nodesPerCell, nullptr,
                                                          geometry::meshSurfaceProjector(mesh, o.spacing));
      if (nodes.empty()) throw std::invalid_argument("the level set has no surface to place nodes on");
      shape = geometry::Shape<3>::fromGridAndNodes(std::move(grid), std::move(nodes), options);
    }
  } catch (const std::invalid_argument& e) {
    throw io::InputError(o.mesh, 0, "", std::string("no grain at this --spacing: ") + e.what());
  }
  io::writeGrainFile<3>(o.output, *shape, o.binary ? io::GrainFormat::Binary : io::GrainFormat::Text);

  // Report: the centroid is in the mesh's frame (the grid frame).
  const geometry::Vec<3> centroid = shape->bodyToGrid().translation;
  if (o.json) {
    io::JsonWriter w(std::cout);
    w.beginObject()
        .field("mesh", o.mesh)
        .field("output", o.output)
        .field("format", o.binary ? "binary" : "text")
        .field("faces", mesh.faces.size())
        .field("dropped_faces", imported.droppedFaces)
        .field("mesh_volume", mesh.signedVolume())
        .field("volume", shape->volume())
        .field("centroid", centroid)
        .field("nodes", shape->nodes().size())
        .field("grid_cells", shape->grid().dims().matrix().cast<double>())
        .field("spacing", o.spacing)
        .endObject();
    std::cout << '\n';
  } else {
    std::printf("mesh2ls %s -> %s (%s)\n", o.mesh.c_str(), o.output.c_str(), o.binary ? "binary" : "text");
    std::printf("  %-14s %zu faces, volume %.6g m^3\n", "mesh", mesh.faces.size(), mesh.signedVolume());
    std::printf("  %-14s %.6g m^3\n", "volume", shape->volume());
    std::printf("  %-14s (%.6g, %.6g, %.6g) m\n", "centroid", centroid[0], centroid[1], centroid[2]);
    std::printf("  %-14s %zu\n", "surface nodes", shape->nodes().size());
    std::printf("  %-14s %d x %d x %d nodes, spacing %.6g m\n", "grid", shape->grid().dims()[0], shape->grid().dims()[1],
                shape->grid().dims()[2], o.spacing);
  }
  if (shape->nodes().size() < io::kFewSurfaceNodes<3>) {
    std::fflush(stdout);
    std::cerr << "lsdem: note: " << o.output << ": the grain has only " << shape->nodes().size()
              << " surface nodes: contacts are found at these points only (--nodes-per-cell)\n";
  }
}

}  // namespace

void addMesh2lsCommand(CLI::App& app) {
  auto opts = std::make_shared<Mesh2lsOptions>();
  CLI::App* cmd = app.add_subcommand("mesh2ls", "Convert a closed CAD mesh (STL/OBJ/PLY) to a level-set grain file");
  cmd->add_option("mesh", opts->mesh, "mesh file (STL, OBJ or PLY), closed and outward-oriented")->required();
  cmd->add_option("--spacing", opts->spacing, "grid spacing, metres (after --scale)")->required();
  cmd->add_option("--scale", opts->scale, "factor from mesh units to metres (default 1; 0.001 for millimetres)");
  cmd->add_option("--nodes-per-cell", opts->nodesPerCell, "surface nodes per grid-cell length (default 2)");
  cmd->add_option("--nodes-on", opts->nodesOn,
                  "exact_surface (default: nodes on the mesh's triangles) or grid (on the level set's zero set)");
  cmd->add_flag("--binary", opts->binary, "write the binary grain form instead of text");
  cmd->add_option("-o,--output", opts->output, "grain file to write (.lsg)")->required();
  cmd->add_flag("--json", opts->json, "Print JSON instead of text");
  cmd->callback([opts] { run(*opts); });
}

}  // namespace lsdem::apps
