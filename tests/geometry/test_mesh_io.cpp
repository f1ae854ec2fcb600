#include "lsdem/geometry/MeshIO.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>
#include <string>
#include <unistd.h>

using namespace lsdem::geometry;

namespace {

namespace fs = std::filesystem;

// The 8 corners of the box [0, size]^3 (corner c has bit a set for the upper side on axis a).
Vec<3> corner(int c, double size) { return size * Vec<3>(c & 1, (c >> 1) & 1, (c >> 2) & 1); }

// The 6 faces of a cube as corner quads, counter-clockwise seen from outside.
constexpr int kQuads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};

// A cube of side `size` as 12 outward triangles with 8 shared vertices.
TriangleMesh cubeMesh(double size) {
  TriangleMesh mesh;
  for (int c = 0; c < 8; ++c) mesh.vertices.push_back(corner(c, size));
  for (const auto& q : kQuads) {
    mesh.faces.push_back({q[0], q[1], q[2]});
    mesh.faces.push_back({q[0], q[2], q[3]});
  }
  return mesh;
}

// A fresh temporary directory per test, removed afterwards.
class MeshIO : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lsdem_mesh_io_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string file(const std::string& name) const { return (dir_ / name).string(); }
  void writeText(const std::string& name, const std::string& text) const { std::ofstream(file(name)) << text; }

  fs::path dir_;
};

// The message of the MeshError readMesh throws ("" when none).
std::string readError(const std::string& path) {
  try {
    readMesh(path);
  } catch (const MeshError& e) {
    return e.what();
  }
  return "";
}

void expectUnitCube(const TriangleMesh& mesh, double size) {
  EXPECT_EQ(mesh.vertices.size(), 8u);
  EXPECT_EQ(mesh.faces.size(), 12u);
  EXPECT_NEAR(mesh.area(), 6 * size * size, 1e-6 * size * size);
  EXPECT_NEAR(mesh.signedVolume(), size * size * size, 1e-6 * size * size * size);
  EXPECT_NEAR(mesh.bounds().upper[2] - mesh.bounds().lower[2], size, 1e-7 * size);
}

}  // namespace

// ASCII STL in millimetres, read with scale 0.001: a 1 m cube, welded to 8 vertices.
TEST_F(MeshIO, AsciiStlWithScale) {
  std::string text = "solid cube\n";
  for (const auto& q : kQuads) {
    for (const auto& tri : {std::array<int, 3>{q[0], q[1], q[2]}, std::array<int, 3>{q[0], q[2], q[3]}}) {
      text += "  facet normal 0 0 0\n    outer loop\n";
      for (const int c : tri) {
        const Vec<3> p = corner(c, 1000.0);
        text += "      vertex " + std::to_string(p[0]) + " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + "\n";
      }
      text += "    endloop\n  endfacet\n";
    }
  }
  text += "endsolid cube\n";
  writeText("cube.stl", text);
  expectUnitCube(readMesh(file("cube.stl"), 0.001), 1.0);
}

// writeStl then readMesh: same cube, vertices equal to float precision, file size 84 + 50 F.
TEST_F(MeshIO, BinaryStlRoundTrip) {
  const TriangleMesh cube = cubeMesh(0.25);
  writeStl(cube, file("cube.stl"));
  EXPECT_EQ(fs::file_size(file("cube.stl")), 84u + 50u * 12u);
  const TriangleMesh back = readMesh(file("cube.stl"));
  expectUnitCube(back, 0.25);
  // Faces keep their orientation: each read face matches an original one up to rotation.
  for (const auto& f : back.faces) {
    const Vec<3> n = (back.vertices[std::size_t(f[1])] - back.vertices[std::size_t(f[0])])
                         .cross(back.vertices[std::size_t(f[2])] - back.vertices[std::size_t(f[0])]);
    const Vec<3> centroid = (back.vertices[std::size_t(f[0])] + back.vertices[std::size_t(f[1])] +
                             back.vertices[std::size_t(f[2])]) / 3.0;
    EXPECT_GT(n.dot(centroid - Vec<3>::Constant(0.125)), 0.0);
  }
}

// OBJ with quads: triangulated to 12 faces on 8 vertices.
TEST_F(MeshIO, ObjQuads) {
  std::string text = "# cube\no cube\n";
  for (int c = 0; c < 8; ++c) {
    const Vec<3> p = corner(c, 2.0);
    text += "v " + std::to_string(p[0]) + " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + "\n";
  }
  for (const auto& q : kQuads) {
    text += "f " + std::to_string(q[0] + 1) + " " + std::to_string(q[1] + 1) + " " + std::to_string(q[2] + 1) + " " +
            std::to_string(q[3] + 1) + "\n";
  }
  writeText("cube.obj", text);
  expectUnitCube(readMesh(file("cube.obj")), 2.0);
}

// ASCII PLY with quads.
TEST_F(MeshIO, PlyQuads) {
  std::string text =
      "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 6\nproperty list uchar int vertex_indices\nend_header\n";
  for (int c = 0; c < 8; ++c) {
    const Vec<3> p = corner(c, 0.5);
    text += std::to_string(p[0]) + " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + "\n";
  }
  for (const auto& q : kQuads) {
    text += "4 " + std::to_string(q[0]) + " " + std::to_string(q[1]) + " " + std::to_string(q[2]) + " " +
            std::to_string(q[3]) + "\n";
  }
  writeText("cube.ply", text);
  expectUnitCube(readMesh(file("cube.ply")), 0.5);
}

// Missing, garbage and empty files raise MeshError naming the file.
TEST_F(MeshIO, BadFilesRaiseMeshError) {
  const std::string missing = file("missing.stl");
  EXPECT_EQ(readError(missing), "cannot read mesh file '" + missing + "': file does not exist");

  std::mt19937 rng(3);
  std::string garbage(1000, '\0');
  for (char& c : garbage) c = char(rng() & 0xff);
  std::ofstream(file("garbage.stl"), std::ios::binary) << garbage;
  const std::string garbageError = readError(file("garbage.stl"));
  std::cout << "garbage: " << garbageError << "\n";
  EXPECT_EQ(garbageError.rfind("cannot read mesh file '" + file("garbage.stl") + "': ", 0), 0u) << garbageError;

  writeText("empty.obj", "# nothing here\n");
  const std::string emptyError = readError(file("empty.obj"));
  std::cout << "empty: " << emptyError << "\n";
  EXPECT_EQ(emptyError.rfind("cannot read mesh file '" + file("empty.obj") + "': ", 0), 0u) << emptyError;

  // Vertices and a line but no face.
  writeText("lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n");
  const std::string linesError = readError(file("lines.obj"));
  EXPECT_EQ(linesError, "cannot read mesh file '" + file("lines.obj") + "': no triangles");

  EXPECT_EQ(readError(dir_.string()), "cannot read mesh file '" + dir_.string() + "': not a regular file");
  EXPECT_THROW(readMesh(file("missing.stl"), 0.0), std::invalid_argument);
  EXPECT_THROW(readMesh(file("missing.stl"), std::numeric_limits<double>::infinity()), std::invalid_argument);
}

// writeStl refuses bad indices and unwritable paths.
TEST_F(MeshIO, WriteErrors) {
  TriangleMesh bad = cubeMesh(1.0);
  bad.faces[2][0] = 9;
  EXPECT_THROW(writeStl(bad, file("bad.stl")), std::invalid_argument);
  EXPECT_FALSE(fs::exists(file("bad.stl")));
  EXPECT_THROW(writeStl(cubeMesh(1.0), file("no/such/dir/cube.stl")), MeshError);
}
