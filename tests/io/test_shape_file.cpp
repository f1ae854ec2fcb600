#include "support/Files.h"
#include "support/Meshes.h"
#include "support/Threads.h"
#include "lsdem/geometry/MeshIO.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/ShapeFile.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

using namespace lsdem;
namespace fs = std::filesystem;

namespace {

// Writes `text` to a fresh file in the test's temporary folder and returns its path.
std::string writeFile(const std::string& name, const std::string& text) {
  const fs::path dir = lsdem::test::tempPath("lsdem_test_shape_file");
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream(p) << text;
  return p.string();
}

// The InputError raised by reading `text`, checked to name the file, line and key.
io::InputError errorOf(const std::string& text, int line, const std::string& key) {
  const std::string path = writeFile("bad.toml", text);
  try {
    io::readShapeFile(path);
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(e.key(), key) << e.what();
    return e;
  }
  ADD_FAILURE() << "no error for:\n" << text;
  return io::InputError("", 0, "", "");
}

}  // namespace

TEST(ShapeFile, ReadsTheSphereOfTheDocs) {
  const auto decl = io::readShapeFile(writeFile("sphere.toml",
                                                "[shape]\ndimension = 3\nkind = \"sphere\"\nradius = 0.5\n"
                                                "spacing = 0.05\nnode_density = 2\n"));
  ASSERT_EQ(decl.dimension(), 3);
  const auto& def = std::get<geometry::ShapeDef<3>>(decl.def);
  EXPECT_EQ(def.kind, geometry::ShapeKind::Sphere);
  EXPECT_DOUBLE_EQ(def.radius, 0.5);
  EXPECT_DOUBLE_EQ(def.spacing, 0.05);
  EXPECT_DOUBLE_EQ(def.options.nodesPerCell, 2.0);
  EXPECT_EQ(def.options.massMethod, geometry::MassMethod::Extrapolated);
}

TEST(ShapeFile, ReadsEveryKind) {
  const auto ellipse = io::readShapeFile(writeFile("e.toml",
      "[shape]\ndimension = 2\nkind = \"ellipse\"\nsemi_axes = [0.6, 0.3]\nspacing = 0.02\n"));
  EXPECT_TRUE((std::get<geometry::ShapeDef<2>>(ellipse.def).semiAxes - geometry::Vec<2>(0.6, 0.3)).norm() == 0.0);

  const auto poly = io::readShapeFile(writeFile("p.toml",
      "[shape]\ndimension = 2\nkind = \"polygon\"\nvertices = [[0,0],[1,0],[0,1]]\ncells_across = 20\n"));
  EXPECT_EQ(std::get<geometry::ShapeDef<2>>(poly.def).vertices.size(), 3u);
  EXPECT_DOUBLE_EQ(std::get<geometry::ShapeDef<2>>(poly.def).cellsAcross, 20.0);

  const auto grain = io::readShapeFile(writeFile("g.toml",
      "[shape]\ndimension = 3\nkind = \"random_grain\"\nequivalent_diameter = 2e-3\nelongation = 1.5\n"
      "roughness = 0.2\nseed = 9\ncells_across = 20\nmass_method = \"paper\"\n"));
  const auto& g = std::get<geometry::ShapeDef<3>>(grain.def);
  EXPECT_DOUBLE_EQ(g.grain.equivalentDiameter, 2e-3);
  EXPECT_DOUBLE_EQ(g.grain.elongation, 1.5);
  EXPECT_EQ(g.grain.seed, 9u);
  EXPECT_EQ(g.options.massMethod, geometry::MassMethod::Paper);

  const auto box = io::readShapeFile(writeFile("b.toml",
      "[shape]\ndimension = 3\nkind = \"box\"\nhalf_extents = [1, 2, 3]\nrounding = 0.5\nspacing = 0.1\n"));
  EXPECT_DOUBLE_EQ(std::get<geometry::ShapeDef<3>>(box.def).rounding, 0.5);

  const auto se = io::readShapeFile(writeFile("s.toml",
      "[shape]\ndimension = 3\nkind = \"superellipsoid\"\nsemi_axes = [1, 2, 3]\nexponents = [4, 6]\nspacing = 0.1\n"));
  EXPECT_EQ(std::get<geometry::ShapeDef<3>>(se.def).exponents, (std::vector<double>{4, 6}));

  // A relative mesh path is resolved against the shape file's folder.
  const std::string meshToml = writeFile("m.toml", "[shape]\ndimension = 3\nkind = \"mesh\"\nfile = \"part.stl\"\nscale = 0.001\nspacing = 0.01\n");
  const auto mesh = io::readShapeFile(meshToml);
  EXPECT_EQ(fs::path(std::get<geometry::ShapeDef<3>>(mesh.def).meshFile), fs::path(meshToml).parent_path() / "part.stl");
}

TEST(ShapeFile, BadInputNamesFileLineAndKey) {
  const std::string head = "[shape]\ndimension = 3\nkind = \"sphere\"\n";
  EXPECT_NE(std::string(errorOf(head + "radius = -0.5\nspacing = 0.05\n", 4, "shape.radius").what()).find("must be positive"),
            std::string::npos);
  errorOf(head + "radius = 0.5\nspacing = 0.05\nradus = 1\n", 6, "shape.radus");            // unknown key (typo)
  // A required key misspelt: missing, with the misspelling named.
  EXPECT_STREQ(errorOf(head + "radus = 0.5\nspacing = 0.05\n", 1, "shape").what(),
               (writeFile("bad.toml", "") + ":1: shape: missing key 'radius' ('radus' on line 4: misspelt?)").c_str());
  errorOf(head + "radius = \"big\"\nspacing = 0.05\n", 4, "shape.radius");                  // wrong type
  errorOf(head + "radius = nan\nspacing = 0.05\n", 4, "shape.radius");                      // NaN
  errorOf(head + "radius = 0.5\n", 1, "shape");                                             // no resolution
  errorOf(head + "radius = 0.5\nspacing = 0.05\ncells_across = 20\n", 6, "shape.cells_across");  // both
  errorOf(head + "radius = 0.5\nspacing = 0\n", 5, "shape.spacing");
  errorOf(head + "radius = 0.5\nspacing = 0.05\nnode_density = -2\n", 6, "shape.node_density");
  errorOf("[shape]\ndimension = 4\nkind = \"sphere\"\n", 2, "shape.dimension");
  errorOf("[shape]\ndimension = 2\nkind = \"sphere\"\nradius = 1\nspacing = 0.1\n", 3, "shape.kind");   // 3D kind in 2D
  errorOf("[shape]\ndimension = 3\nkind = \"ellipsoid\"\nsemi_axes = [1, 2]\nspacing = 0.1\n", 4, "shape.semi_axes");
  errorOf("[shape]\ndimension = 2\nkind = \"polygon\"\nvertices = [[0,0],[1,0]]\nspacing = 0.1\n", 4, "shape.vertices");
  errorOf("[shape]\ndimension = 3\nkind = \"random_grain\"\nequivalent_diameter = 1\nroughness = 0.9\nspacing = 0.1\n", 5,
          "shape.roughness");
  errorOf("[shape]\ndimension = 3\nkind = \"sphere\"\nradius = 0.5\nspacing = 0.05\nmass_method = \"exact\"\n", 6,
          "shape.mass_method");
  errorOf("[shape]\ndimension = 3\nkind = \"sphere\"\nradius = 0.5\nspacing = 0.05\n[other]\n", 6, "other");
  errorOf("[shape]\ndimension = 3\nkind = sphere\n", 3, "");                                // TOML syntax
}

// A grid of fewer than 5 cells across the shape builds, with a note at the
// resolution's key; 5 or more, none.
TEST(ShapeFile, AVeryCoarseGridIsNoted) {
  for (const double cells : {3.0, 5.0}) {
    const std::string path = writeFile("coarse_sphere.toml", "[shape]\ndimension = 3\nkind = \"sphere\"\nradius = 0.5\n"
                                                             "cells_across = " + std::to_string(cells) + "\n");
    std::vector<std::string> notes;
    io::buildDeclaredShape<3>(io::readShapeFile(path), &notes);
    if (cells < 5.0) {
      ASSERT_EQ(notes.size(), 1u);
      EXPECT_EQ(notes[0].rfind(path + ":5: shape.cells_across: gives only 3 cells across", 0), 0u) << notes[0];
    } else {
      EXPECT_TRUE(notes.empty()) << notes[0];
    }
  }
}

// A shape with fewer than 20 surface nodes (8 in 2D) is noted: a sphere at
// node_density 1e-6 has 4.
TEST(ShapeFile, AShapeWithAHandfulOfNodesIsNoted) {
  for (const char* density : {"1e-6", "2"}) {
    const std::string path = writeFile("sparse_sphere.toml", "[shape]\ndimension = 3\nkind = \"sphere\"\nradius = 0.5\n"
                                                             "cells_across = 10\nnode_density = " + std::string(density) + "\n");
    std::vector<std::string> notes;
    const auto shape = io::buildDeclaredShape<3>(io::readShapeFile(path), &notes);
    if (shape->nodes().size() < 20) {
      ASSERT_EQ(notes.size(), 1u) << density;
      EXPECT_EQ(notes[0], path + ":1: shape: has only " + std::to_string(shape->nodes().size()) +
                              " surface nodes: contacts are found at these points only (node_density)");
    } else {
      EXPECT_STREQ(density, "2");
      EXPECT_TRUE(notes.empty()) << notes[0];
    }
  }
}

TEST(ShapeFile, MissingFileAndTable) {
  EXPECT_THROW(io::readShapeFile("/nonexistent/lsdem/shape.toml"), io::InputError);
  EXPECT_THROW(io::readShapeFile(writeFile("empty.toml", "[grain]\nradius = 1\n")), io::InputError);
}

TEST(ShapeFile, GeometryProblemsBecomeInputErrors) {
  // A self-intersecting (bow-tie) polygon is only seen by geometry; it is
  // still reported at its key (it was the table, with the geometry
  // function's name in the text).
  const auto decl = io::readShapeFile(writeFile("bowtie.toml",
      "[shape]\ndimension = 2\nkind = \"polygon\"\nvertices = [[0,0],[1,1],[1,0],[0,1]]\nspacing = 0.05\n"));
  try {
    io::buildDeclaredShape<2>(decl);
    ADD_FAILURE() << "a bow-tie polygon was accepted";
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.line(), 4);
    EXPECT_EQ(e.key(), "shape.vertices");
    EXPECT_EQ(e.problem(), "the polygon has zero area (0)");
  }
  // Too many nodes: at node_density.
  try {
    io::buildDeclaredShape<3>(io::readShapeFile(writeFile("dense.toml",
        "[shape]\ndimension = 3\nkind = \"sphere\"\nradius = 1.0\ncells_across = 10\nnode_density = 1e9\n")));
    ADD_FAILURE() << "1e9 nodes per cell were accepted";
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.line(), 6);
    EXPECT_EQ(e.key(), "shape.node_density");
    EXPECT_NE(e.problem().find("surface node density 1e+09 would give about 7.2e+20 nodes (at most 1e+08)"),
              std::string::npos)
        << e.what();
  }
  // A 2D declaration asked for as 3D.
  EXPECT_THROW(io::buildDeclaredShape<3>(decl), io::InputError);

  // A mesh's spacing is checked against the mesh once it is read: 0.5 m
  // gives 0.6 cells across a box 0.3 m thick. The error names the key's line.
  const std::string boxFile = writeFile("thin_box.stl", "");
  geometry::writeStl(lsdem::test::boxMesh(geometry::Vec<3>::Zero(), geometry::Vec<3>(0.5, 0.4, 0.15)), boxFile);
  const std::string meshToml =
      writeFile("coarse.toml", "[shape]\ndimension = 3\nkind = \"mesh\"\nfile = \"thin_box.stl\"\n\nspacing = 0.5\n");
  try {
    io::buildDeclaredShape<3>(io::readShapeFile(meshToml));
    ADD_FAILURE() << "a spacing coarser than the mesh was accepted";
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.file(), meshToml);
    EXPECT_EQ(e.line(), 6) << e.what();
    EXPECT_EQ(e.key(), "shape.spacing") << e.what();
    EXPECT_NE(std::string(e.what()).find("gives 0.6 cells across the mesh's smallest extent (0.3 at spacing 0.5)"),
              std::string::npos)
        << e.what();
  }
  // A broken mesh: at its `file` (it was the table's first line).
  geometry::TriangleMesh open = lsdem::test::boxMesh(geometry::Vec<3>::Zero(), geometry::Vec<3>(0.5, 0.4, 0.3));
  open.faces.pop_back();
  geometry::writeStl(open, writeFile("open_box.stl", ""));
  try {
    io::buildDeclaredShape<3>(io::readShapeFile(
        writeFile("open.toml", "[shape]\ndimension = 3\nkind = \"mesh\"\n\nfile = \"open_box.stl\"\nspacing = 0.05\n")));
    ADD_FAILURE() << "an open mesh was accepted";
  } catch (const io::InputError& e) {
    EXPECT_EQ(e.line(), 5) << e.what();
    EXPECT_EQ(e.key(), "shape.file") << e.what();
    EXPECT_NE(e.problem().find("is not closed"), std::string::npos) << e.what();
  }
}

// A scene's shapes are built several at a time (buildDeclaredShapes): each
// is the shape built alone, bit for bit (grid, nodes, mass), in the order
// declared, at one thread or two.
TEST(ShapeFile, ShapesBuiltTogetherAreThoseBuiltAlone) {
  std::vector<io::ShapeDecl> decls;
  decls.push_back(io::readShapeFile(writeFile("t_se.toml",
      "[shape]\ndimension = 3\nkind = \"superellipsoid\"\nsemi_axes = [0.5, 0.4, 0.3]\nexponents = [2.5, 3]\n"
      "cells_across = 12\n")));
  decls.push_back(io::readShapeFile(writeFile("t_grain.toml",
      "[shape]\ndimension = 3\nkind = \"random_grain\"\nequivalent_diameter = 1\nroughness = 0.2\nseed = 4\n"
      "cells_across = 12\n")));
  decls.push_back(io::readShapeFile(writeFile("t_sphere.toml",
      "[shape]\ndimension = 3\nkind = \"sphere\"\nradius = 0.4\ncells_across = 10\n")));
  std::vector<std::shared_ptr<const geometry::Shape<3>>> alone;
  for (const io::ShapeDecl& d : decls) alone.push_back(io::buildDeclaredShape<3>(d));
  for (int threads : {1, 2}) {
    const lsdem::test::ScopedThreads scoped(threads);
    const auto together = io::buildDeclaredShapes<3>(decls);
    ASSERT_EQ(together.size(), decls.size());
    for (std::size_t s = 0; s < decls.size(); ++s) {
      SCOPED_TRACE("shape " + std::to_string(s) + ", threads " + std::to_string(threads));
      EXPECT_EQ(together[s]->grid().values(), alone[s]->grid().values());
      EXPECT_EQ(together[s]->nodes().positions, alone[s]->nodes().positions);
      EXPECT_EQ(together[s]->nodes().weights, alone[s]->nodes().weights);
      EXPECT_EQ(together[s]->volume(), alone[s]->volume());
      EXPECT_EQ(together[s]->mass().inertiaTensor(), alone[s]->mass().inertiaTensor());
    }
  }
}

// Two bad declarations among good ones: the error is the first one's (in
// the order given), whichever build ends first.
TEST(ShapeFile, ShapesBuiltTogetherReportTheFirstBadDeclaration) {
  const io::ShapeDecl good = io::readShapeFile(writeFile("t_disc.toml",
      "[shape]\ndimension = 2\nkind = \"circle\"\nradius = 0.5\ncells_across = 16\n"));
  io::ShapeDecl bowtie = io::readShapeFile(writeFile("t_bowtie.toml",
      "[shape]\ndimension = 2\nkind = \"polygon\"\nvertices = [[0,0],[1,1],[1,0],[0,1]]\nspacing = 0.05\n"));
  std::vector<io::ShapeDecl> decls{good, bowtie, good, bowtie};
  decls[1].key = "shapes.first";
  decls[3].key = "shapes.second";
  for (int threads : {1, 2}) {
    const lsdem::test::ScopedThreads scoped(threads);
    try {
      io::buildDeclaredShapes<2>(decls);
      ADD_FAILURE() << "a bow-tie polygon was accepted";
    } catch (const io::InputError& e) {
      EXPECT_EQ(e.key(), "shapes.first.vertices") << e.what();
    }
  }
}
