#include "lsdem/geometry/MeshIO.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <unordered_map>
#include <utility>
#include <vector>

namespace lsdem::geometry {

namespace {

/// Hash of a position by the bit patterns of its coordinates (exact welding).
struct PositionHash {
  std::size_t operator()(const std::array<double, 3>& p) const {
    std::size_t h = 0;
    for (const double c : p) {
      std::uint64_t bits = 0;
      std::memcpy(&bits, &c, sizeof bits);
      h ^= std::hash<std::uint64_t>{}(bits) + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
    }
    return h;
  }
};

/// Collects the triangles of a scene graph into one mesh, joining vertices at
/// identical positions.
class SceneCollector {
 public:
  SceneCollector(const aiScene& scene, double scale) : scene_(scene), scale_(scale) {}

  // Meshes of `node` and its children, with the accumulated node transforms.
  void collect(const aiNode& node, const aiMatrix4x4& parent) {
    const aiMatrix4x4 transform = parent * node.mTransformation;
    for (unsigned m = 0; m < node.mNumMeshes; ++m) addMesh(*scene_.mMeshes[node.mMeshes[m]], transform);
    for (unsigned c = 0; c < node.mNumChildren; ++c) collect(*node.mChildren[c], transform);
  }

  TriangleMesh take() { return std::move(mesh_); }

 private:
  void addMesh(const aiMesh& source, const aiMatrix4x4& transform) {
    // Vertices: transformed, welded by exact position, then scaled.
    std::vector<int> index(source.mNumVertices);
    for (unsigned v = 0; v < source.mNumVertices; ++v) {
      const aiVector3D p = transform * source.mVertices[v];
      // + 0.0 turns -0.0 into +0.0 so both weld together.
      const std::array<double, 3> key = {double(p.x) + 0.0, double(p.y) + 0.0, double(p.z) + 0.0};
      const auto [it, isNew] = vertexOf_.try_emplace(key, int(mesh_.vertices.size()));
      if (isNew) mesh_.vertices.push_back(scale_ * Vec<3>(key[0], key[1], key[2]));
      index[v] = it->second;
    }
    // Triangles only; faces collapsed by welding are dropped.
    for (unsigned f = 0; f < source.mNumFaces; ++f) {
      const aiFace& face = source.mFaces[f];
      if (face.mNumIndices != 3) continue;
      const std::array<int, 3> t = {index[face.mIndices[0]], index[face.mIndices[1]], index[face.mIndices[2]]};
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
      mesh_.faces.push_back(t);
    }
  }

  const aiScene& scene_;
  double scale_;
  TriangleMesh mesh_;
  std::unordered_map<std::array<double, 3>, int, PositionHash> vertexOf_;
};

// Appends the little-endian bytes of a 32-bit value.
void putU32(std::vector<char>& out, std::uint32_t v) {
  for (int b = 0; b < 4; ++b) out.push_back(char((v >> (8 * b)) & 0xffu));
}
void putF32(std::vector<char>& out, double x) {
  const float f = float(x);
  std::uint32_t bits = 0;
  std::memcpy(&bits, &f, sizeof bits);
  putU32(out, bits);
}

}  // namespace

TriangleMesh readMesh(const std::string& path, double scale) {
  if (!std::isfinite(scale) || !(scale > 0.0)) {
    throw std::invalid_argument("mesh scale must be positive and finite, got " + std::to_string(scale) + " for '" +
                                path + "'");
  }
  const std::string prefix = "cannot read mesh file '" + path + "': ";

  // The file must exist and be a regular file (assimp's messages for these are vague).
  std::error_code error;
  if (!std::filesystem::exists(path, error)) throw MeshError(prefix + "file does not exist");
  if (!std::filesystem::is_regular_file(path, error)) throw MeshError(prefix + "not a regular file");

  // Import: drop normals/colours/texture coordinates (so that vertices differ
  // only by position) and triangulate polygons; points and lines stay and are
  // skipped when collecting.
  Assimp::Importer importer;
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS |
                                                          aiComponent_COLORS | aiComponent_TEXCOORDS |
                                                          aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
                                                          aiComponent_TEXTURES | aiComponent_LIGHTS |
                                                          aiComponent_CAMERAS | aiComponent_MATERIALS);
  const aiScene* scene =
      importer.ReadFile(path, aiProcess_RemoveComponent | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices);
  if (scene == nullptr) {
    const std::string why = importer.GetErrorString();
    throw MeshError(prefix + (why.empty() ? "not a readable STL, OBJ or PLY mesh" : why));
  }
  if (scene->mRootNode == nullptr || scene->mNumMeshes == 0) throw MeshError(prefix + "no triangles");

  // One mesh from the whole scene graph.
  SceneCollector collector(*scene, scale);
  collector.collect(*scene->mRootNode, aiMatrix4x4());
  TriangleMesh mesh = collector.take();
  if (mesh.faces.empty()) throw MeshError(prefix + "no triangles");
  return mesh;
}

void writeStl(const TriangleMesh& mesh, const std::string& path) {
  // Validate before touching the file.
  if (mesh.faces.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw std::invalid_argument("cannot write " + std::to_string(mesh.faces.size()) + " faces to STL '" + path +
                                "': the format counts at most 2^32 - 1");
  }
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    for (const int v : mesh.faces[f]) {
      if (v < 0 || std::size_t(v) >= mesh.vertices.size()) {
        throw std::invalid_argument("cannot write STL '" + path + "': face " + std::to_string(f) +
                                    " refers to vertex " + std::to_string(v) + " of " +
                                    std::to_string(mesh.vertices.size()));
      }
    }
  }

  // Encode: 80-byte header (not starting with "solid", which marks ASCII STL),
  // face count, then per face normal, three vertices and a zero attribute word.
  std::vector<char> bytes;
  bytes.reserve(84 + 50 * mesh.faces.size());
  const std::string header = "lsdem binary STL";
  bytes.insert(bytes.end(), header.begin(), header.end());
  bytes.resize(80, ' ');
  putU32(bytes, std::uint32_t(mesh.faces.size()));
  for (const auto& f : mesh.faces) {
    const Vec<3>& a = mesh.vertices[std::size_t(f[0])];
    const Vec<3>& b = mesh.vertices[std::size_t(f[1])];
    const Vec<3>& c = mesh.vertices[std::size_t(f[2])];
    const Vec<3> n = (b - a).cross(c - a);
    const Vec<3> unit = n.norm() > 0.0 ? Vec<3>(n / n.norm()) : Vec<3>::Zero();
    for (const Vec<3>* p : {&unit, &a, &b, &c}) {
      for (int k = 0; k < 3; ++k) putF32(bytes, (*p)[k]);
    }
    bytes.push_back(0);
    bytes.push_back(0);
  }

  // Write and check.
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw MeshError("cannot write mesh file '" + path + "': " + std::strerror(errno));
  out.write(bytes.data(), std::streamsize(bytes.size()));
  out.close();
  if (!out) throw MeshError("cannot write mesh file '" + path + "': write failed");
}

}  // namespace lsdem::geometry
