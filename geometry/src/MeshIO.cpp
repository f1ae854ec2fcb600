#include "lsdem/geometry/MeshIO.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
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
/// identical positions. Throws std::runtime_error for a non-finite vertex or a
/// face index out of range (before anything else looks at them).
class SceneCollector {
 public:
  SceneCollector(const aiScene& scene, double scale, MeshImportReport& report)
      : scene_(scene), scale_(scale), report_(report) {}

  // Meshes of `node` and its children, with the accumulated node transforms.
  void collect(const aiNode& node, const aiMatrix4x4& parent) {
    const aiMatrix4x4 transform = parent * node.mTransformation;
    for (unsigned m = 0; m < node.mNumMeshes; ++m) {
      if (node.mMeshes[m] >= scene_.mNumMeshes) throw std::runtime_error("a node refers to a missing mesh");
      addMesh(*scene_.mMeshes[node.mMeshes[m]], transform);
    }
    for (unsigned c = 0; c < node.mNumChildren; ++c) collect(*node.mChildren[c], transform);
  }

  // The mesh, its coordinates checked against the reader's precision.
  TriangleMesh take() {
    // The importer keeps coordinates in single precision (24 bits: a point
    // at |x| is off by up to |x| 2^-24). Far from the origin against its
    // size a body is then distorted: a 0.3 m cube at 1e6 m came out 8.5 %
    // too large, at 3e7 m not closed. Refused where the error passes 1e-4
    // of its size (1e-3 of a cell at 10 cells across).
    if (!mesh_.vertices.empty()) {
      Vec<3> lo = mesh_.vertices.front(), hi = lo;
      double far = 0.0;
      for (const Vec<3>& v : mesh_.vertices) {
        lo = lo.cwiseMin(v);
        hi = hi.cwiseMax(v);
        far = std::max(far, v.cwiseAbs().maxCoeff());
      }
      const double size = (hi - lo).norm(), error = far * 0x1p-24;
      if (error > 1e-4 * size) {
        std::ostringstream what;
        what << "its vertices lie up to " << far << " m from the origin on a body " << size
             << " m across: the mesh reader keeps single precision (about 7 digits, as binary STL stores), which "
                "can put them up to "
             << error << " m off (";
        if (size > 0.0) {
          what << error / size << " of its size";
        } else {
          what << "all of them round to one point";
        }
        what << "); move the mesh to near the origin (a scene places a shape with `position`)";
        throw std::runtime_error(what.str());
      }
    }
    return std::move(mesh_);
  }

 private:
  void addMesh(const aiMesh& source, const aiMatrix4x4& transform) {
    // Vertices: transformed, checked finite, welded by exact position, then scaled.
    std::vector<int> index(source.mNumVertices);
    for (unsigned v = 0; v < source.mNumVertices; ++v) {
      const aiVector3D p = transform * source.mVertices[v];
      // + 0.0 turns -0.0 into +0.0 so both weld together.
      const std::array<double, 3> key = {double(p.x) + 0.0, double(p.y) + 0.0, double(p.z) + 0.0};
      const Vec<3> scaled = scale_ * Vec<3>(key[0], key[1], key[2]);
      if (!scaled.allFinite()) {
        const aiVector3D raw = source.mVertices[v];
        throw std::runtime_error("vertex " + std::to_string(vertexBase_ + v) + " (" + std::to_string(raw.x) + ", " +
                                 std::to_string(raw.y) + ", " + std::to_string(raw.z) + ") is not finite" +
                                 (scale_ != 1.0 ? " once scaled" : ""));
      }
      // Lengths are metres; far beyond 1e10 m the orientation and distance
      // tests overflow (a cube scaled by 1e300 was called inverted).
      if (scaled.cwiseAbs().maxCoeff() > 1e10) {
        std::ostringstream what;
        what << "vertex " << vertexBase_ + v << " lies at (" << scaled.x() << ", " << scaled.y() << ", " << scaled.z()
             << ")" << (scale_ != 1.0 ? " once scaled" : "")
             << ": lsdem takes coordinates within 1e10 m of the origin (lengths are in metres)";
        throw std::runtime_error(what.str());
      }
      const auto [it, isNew] = vertexOf_.try_emplace(key, int(mesh_.vertices.size()));
      if (isNew) mesh_.vertices.push_back(scaled);
      index[v] = it->second;
    }
    // Triangles only (points and lines are skipped); indices checked; faces
    // collapsed by welding (zero area) are dropped and counted.
    for (unsigned f = 0; f < source.mNumFaces; ++f) {
      const aiFace& face = source.mFaces[f];
      if (face.mNumIndices != 3) {
        ++report_.skippedPrimitives;
        continue;
      }
      for (unsigned k = 0; k < 3; ++k) {
        if (face.mIndices[k] >= source.mNumVertices) {
          throw std::runtime_error("face " + std::to_string(faceBase_ + f) + " refers to vertex " +
                                   std::to_string(face.mIndices[k]) + ", the file has " +
                                   std::to_string(source.mNumVertices));
        }
      }
      const std::array<int, 3> t = {index[face.mIndices[0]], index[face.mIndices[1]], index[face.mIndices[2]]};
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
        if (report_.droppedFaces++ == 0) report_.firstDroppedFace = (long long)(faceBase_ + f);
        continue;
      }
      mesh_.faces.push_back(t);
    }
    vertexBase_ += source.mNumVertices;
    faceBase_ += source.mNumFaces;
  }

  const aiScene& scene_;
  double scale_;
  MeshImportReport& report_;
  TriangleMesh mesh_;
  std::unordered_map<std::array<double, 3>, int, PositionHash> vertexOf_;
  std::size_t vertexBase_ = 0, faceBase_ = 0;  // numbering across the meshes of the file
};

// ---- PLY structure (checked before the importer sees the file) ----

// A PLY scalar type: byte size and kind ('i' signed, 'u' unsigned, 'f' floating).
struct PlyType {
  int size = 0;
  char kind = 0;
};

std::optional<PlyType> plyType(const std::string& t) {
  if (t == "char" || t == "int8") return PlyType{1, 'i'};
  if (t == "uchar" || t == "uint8") return PlyType{1, 'u'};
  if (t == "short" || t == "int16") return PlyType{2, 'i'};
  if (t == "ushort" || t == "uint16") return PlyType{2, 'u'};
  if (t == "int" || t == "int32") return PlyType{4, 'i'};
  if (t == "uint" || t == "uint32") return PlyType{4, 'u'};
  if (t == "float" || t == "float32") return PlyType{4, 'f'};
  if (t == "double" || t == "float64") return PlyType{8, 'f'};
  return std::nullopt;
}

struct PlyProperty {
  PlyType type;       // the value's (a list's items)
  PlyType countType;  // a list's count; size 0 for a scalar
  std::string name;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

// A binary PLY value at `p` as a double.
double decodePly(const unsigned char* p, PlyType t, bool bigEndian) {
  unsigned char b[8] = {};
  const bool swap = bigEndian != (std::endian::native == std::endian::big);
  for (int k = 0; k < t.size; ++k) b[k] = swap ? p[t.size - 1 - k] : p[k];
  const auto as = [&]<class T>(T) {
    T v;
    std::memcpy(&v, b, sizeof(T));
    return double(v);
  };
  switch (t.size) {
    case 1: return t.kind == 'i' ? as(std::int8_t{}) : as(std::uint8_t{});
    case 2: return t.kind == 'i' ? as(std::int16_t{}) : as(std::uint16_t{});
    case 4: return t.kind == 'f' ? as(float{}) : (t.kind == 'i' ? as(std::int32_t{}) : as(std::uint32_t{}));
    default: return as(double{});
  }
}

// Checks a PLY file's header, that its body holds every element the header
// declares, and that face indices name existing vertices. Throws
// std::runtime_error naming the defect.
void checkPly(const std::string& bytes) {
  // Header lines up to end_header (within the first 64 KiB).
  const std::size_t headerLimit = std::min<std::size_t>(bytes.size(), 1 << 16);
  std::size_t pos = 0;
  const auto nextLine = [&]() -> std::optional<std::string> {
    if (pos >= headerLimit) return std::nullopt;
    std::size_t end = bytes.find('\n', pos);
    if (end == std::string::npos || end >= headerLimit) return std::nullopt;
    std::string line = bytes.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = end + 1;
    return line;
  };
  const auto tokens = [](const std::string& line) {
    std::vector<std::string> out;
    std::istringstream s(line);
    for (std::string t; s >> t;) out.push_back(t);
    return out;
  };
  const auto first = nextLine();
  if (!first || *first != "ply") throw std::runtime_error("not a PLY file (no 'ply' first line)");
  std::string format;
  std::vector<PlyElement> elements;
  bool ended = false;
  for (int lineNumber = 2; !ended; ++lineNumber) {
    const auto line = nextLine();
    if (!line) throw std::runtime_error("the PLY header has no end_header line");
    const std::vector<std::string> t = tokens(*line);
    const std::string where = "PLY header line " + std::to_string(lineNumber);
    if (t.empty() || t[0] == "comment" || t[0] == "obj_info") continue;
    if (t[0] == "end_header") {
      ended = true;
    } else if (t[0] == "format") {
      if (t.size() < 2 || (t[1] != "ascii" && t[1] != "binary_little_endian" && t[1] != "binary_big_endian")) {
        throw std::runtime_error(where + ": unknown format '" + *line + "'");
      }
      format = t[1];
    } else if (t[0] == "element") {
      std::uint64_t count = 0;
      const bool ok = t.size() == 3 &&
                      std::from_chars(t[2].data(), t[2].data() + t[2].size(), count).ptr == t[2].data() + t[2].size();
      if (!ok) throw std::runtime_error(where + ": expected 'element NAME COUNT', got '" + *line + "'");
      elements.push_back(PlyElement{t[1], count, {}});
    } else if (t[0] == "property") {
      if (elements.empty()) throw std::runtime_error(where + ": a property before any element");
      PlyProperty p;
      const bool list = t.size() == 5 && t[1] == "list";
      const auto type = plyType(list ? t[3] : (t.size() == 3 ? t[1] : ""));
      const auto countType = list ? plyType(t[2]) : std::optional<PlyType>(PlyType{});
      if (!type || !countType || (list && countType->kind == 'f')) {
        throw std::runtime_error(where + ": unknown property '" + *line + "'");
      }
      p.type = *type;
      p.countType = *countType;
      p.name = t.back();
      elements.back().properties.push_back(p);
    } else {
      throw std::runtime_error(where + ": unexpected '" + *line + "'");
    }
  }
  if (format.empty()) throw std::runtime_error("the PLY header has no format line");

  std::uint64_t vertices = 0;
  for (const PlyElement& e : elements) {
    if (e.name == "vertex") vertices = e.count;
  }
  const auto isIndexList = [](const PlyElement& e, const PlyProperty& p) {
    return e.name == "face" && p.countType.size > 0 && (p.name == "vertex_indices" || p.name == "vertex_index");
  };
  const auto checkIndex = [&](double index, std::uint64_t face) {
    if (!(index >= 0.0 && index < double(vertices))) {
      std::ostringstream s;
      s << "face " << face << " refers to vertex " << index << ", the file has " << vertices;
      throw std::runtime_error(s.str());
    }
  };
  const auto checkCoordinate = [](const PlyElement& e, const PlyProperty& p, double v, std::uint64_t i) {
    if (e.name == "vertex" && (p.name == "x" || p.name == "y" || p.name == "z") && !std::isfinite(v)) {
      std::ostringstream s;
      s << "vertex " << i << " is not finite (" << p.name << " = " << v << ")";
      throw std::runtime_error(s.str());
    }
  };
  const auto truncated = [](const PlyElement& e, std::uint64_t i) {
    return std::runtime_error("the file is truncated: it ends inside element '" + e.name + "' " + std::to_string(i) +
                              " of " + std::to_string(e.count));
  };

  if (format != "ascii") {
    // Binary: walk every element, at least the fixed part of each first.
    const bool big = format == "binary_big_endian";
    const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
    std::size_t at = pos;
    for (const PlyElement& e : elements) {
      std::uint64_t least = 0;
      for (const PlyProperty& p : e.properties) least += std::uint64_t(p.countType.size > 0 ? p.countType.size : p.type.size);
      if (least > 0 && e.count > (bytes.size() - at) / least) throw truncated(e, (bytes.size() - at) / least);
      for (std::uint64_t i = 0; i < e.count; ++i) {
        for (const PlyProperty& p : e.properties) {
          if (p.countType.size == 0) {
            if (std::size_t(p.type.size) > bytes.size() - at) throw truncated(e, i);
            checkCoordinate(e, p, decodePly(data + at, p.type, big), i);
            at += std::size_t(p.type.size);
            continue;
          }
          if (std::size_t(p.countType.size) > bytes.size() - at) throw truncated(e, i);
          const double n = decodePly(data + at, p.countType, big);
          at += std::size_t(p.countType.size);
          if (!(n >= 0.0)) throw std::runtime_error("element '" + e.name + "' " + std::to_string(i) + " has a negative list size");
          if (n > double((bytes.size() - at) / std::size_t(p.type.size))) throw truncated(e, i);
          for (std::size_t k = 0; k < std::size_t(n); ++k) {
            if (isIndexList(e, p)) checkIndex(decodePly(data + at, p.type, big), i);
            at += std::size_t(p.type.size);
          }
        }
      }
    }
    return;
  }

  // ASCII: the same walk over whitespace-separated numbers.
  std::size_t at = pos;
  const auto nextNumber = [&](const PlyElement& e, std::uint64_t i) {
    while (at < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[at]))) ++at;
    std::size_t end = at;
    while (end < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[end]))) ++end;
    if (end == at) throw truncated(e, i);
    double v = 0.0;
    const auto r = std::from_chars(bytes.data() + at, bytes.data() + end, v);
    if (r.ec != std::errc() || r.ptr != bytes.data() + end) {
      throw std::runtime_error("element '" + e.name + "' " + std::to_string(i) + ": '" + bytes.substr(at, std::min<std::size_t>(end - at, 40)) +
                               "' is not a number");
    }
    at = end;
    return v;
  };
  for (const PlyElement& e : elements) {
    for (std::uint64_t i = 0; i < e.count; ++i) {
      for (const PlyProperty& p : e.properties) {
        if (p.countType.size == 0) {
          checkCoordinate(e, p, nextNumber(e, i), i);
          continue;
        }
        const double n = nextNumber(e, i);
        if (!(n >= 0.0 && n == std::floor(n))) {
          throw std::runtime_error("element '" + e.name + "' " + std::to_string(i) + " has a bad list size");
        }
        for (double k = 0; k < n; ++k) {
          const double v = nextNumber(e, i);
          if (isIndexList(e, p)) checkIndex(v, i);
        }
      }
    }
  }
}

// ---- the importer, run in a child process ----

// Imports with assimp and collects one mesh (in the child process).
TriangleMesh importWithAssimp(const std::string& path, double scale, MeshImportReport& report) {
  // Drop normals/colours/texture coordinates (so that vertices differ only by
  // position) and triangulate polygons; points and lines stay and are skipped
  // when collecting.
  Assimp::Importer importer;
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS |
                                                          aiComponent_COLORS | aiComponent_TEXCOORDS |
                                                          aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
                                                          aiComponent_TEXTURES | aiComponent_LIGHTS |
                                                          aiComponent_CAMERAS | aiComponent_MATERIALS);
  const aiScene* scene =
      importer.ReadFile(path, aiProcess_RemoveComponent | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices);
  if (scene == nullptr) {
    // (An ASCII parse error quotes the rest of the file from the bad token
    // on, its line breaks shown as '?': the first line of it is kept.)
    std::string why = importer.GetErrorString();
    const std::size_t quote = why.find('"');
    const std::size_t cut = quote == std::string::npos ? std::string::npos : why.find('?', quote);
    const std::size_t close = why.rfind('"');
    if (cut != std::string::npos && close != std::string::npos && close > cut) why = why.substr(0, cut) + why.substr(close);
    if (why.size() > 300) why = why.substr(0, 300) + "...";
    throw std::runtime_error(why.empty() ? "not a readable STL, OBJ or PLY mesh" : why);
  }
  if (scene->mRootNode == nullptr || scene->mNumMeshes == 0) throw std::runtime_error("no triangles");
  SceneCollector collector(*scene, scale, report);
  collector.collect(*scene->mRootNode, aiMatrix4x4());
  return collector.take();
}

// The child's answer through the pipe: a status byte ('M' a mesh, 'E' an
// error), then the report, vertices and faces, or the message.
void put(std::string& out, const void* p, std::size_t n) { out.append(static_cast<const char*>(p), n); }

std::string encodeImport(const std::string& path, double scale) {
  std::string out;
  try {
    MeshImportReport report;
    const TriangleMesh mesh = importWithAssimp(path, scale, report);
    out += 'M';
    const std::int64_t header[5] = {report.droppedFaces, report.firstDroppedFace, report.skippedPrimitives,
                                    std::int64_t(mesh.vertices.size()), std::int64_t(mesh.faces.size())};
    put(out, header, sizeof(header));
    for (const Vec<3>& v : mesh.vertices) put(out, v.data(), 3 * sizeof(double));
    for (const auto& f : mesh.faces) put(out, f.data(), 3 * sizeof(int));
  } catch (const std::exception& e) {
    out = std::string("E") + e.what();
  } catch (...) {
    out = "Eunknown error";
  }
  return out;
}

TriangleMesh decodeImport(const std::string& in, MeshImportReport& report) {
  if (in.empty()) throw std::runtime_error("the importer stopped without an answer");
  if (in[0] == 'E') throw std::runtime_error(in.substr(1));
  std::int64_t header[5];
  if (in[0] != 'M' || in.size() < 1 + sizeof(header)) throw std::runtime_error("the importer's answer is incomplete");
  std::memcpy(header, in.data() + 1, sizeof(header));
  const std::size_t nv = std::size_t(header[3]), nf = std::size_t(header[4]);
  if (in.size() != 1 + sizeof(header) + nv * 3 * sizeof(double) + nf * 3 * sizeof(int)) {
    throw std::runtime_error("the importer's answer is incomplete");
  }
  report.droppedFaces = int(header[0]);
  report.firstDroppedFace = header[1];
  report.skippedPrimitives = int(header[2]);
  TriangleMesh mesh;
  mesh.vertices.resize(nv);
  mesh.faces.resize(nf);
  const char* p = in.data() + 1 + sizeof(header);
  for (Vec<3>& v : mesh.vertices) {
    std::memcpy(v.data(), p, 3 * sizeof(double));
    p += 3 * sizeof(double);
  }
  for (auto& f : mesh.faces) {
    std::memcpy(f.data(), p, 3 * sizeof(int));
    p += 3 * sizeof(int);
  }
  return mesh;
}

// Runs the import in a child process, so that an importer that crashes or
// hangs on a malformed file cannot take this process with it.
TriangleMesh importIsolated(const std::string& path, double scale, double seconds, MeshImportReport& report) {
  int fds[2];
  if (::pipe(fds) != 0) throw std::runtime_error(std::string("cannot start the importer: ") + std::strerror(errno));
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int error = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw std::runtime_error(std::string("cannot start the importer: ") + std::strerror(error));
  }
  if (pid == 0) {
    // The child: import, send the answer, leave without running any of the parent's exit handlers.
    ::close(fds[0]);
    const std::string answer = encodeImport(path, scale);
    for (std::size_t sent = 0; sent < answer.size();) {
      const ssize_t k = ::write(fds[1], answer.data() + sent, answer.size() - sent);
      if (k < 0 && errno == EINTR) continue;
      if (k <= 0) break;
      sent += std::size_t(k);
    }
    ::_exit(0);
  }

  // The parent: read the answer until the child closes the pipe or the time is up.
  ::close(fds[1]);
  std::string answer;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  bool timedOut = false;
  std::vector<char> buffer(1 << 16);
  while (true) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timedOut = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int ready = ::poll(&p, 1, int(std::min<long long>(left.count(), 1000)));
    if (ready < 0 && errno != EINTR) break;
    if (ready <= 0) continue;
    const ssize_t k = ::read(fds[0], buffer.data(), buffer.size());
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) break;
    answer.append(buffer.data(), std::size_t(k));
  }
  ::close(fds[0]);
  if (timedOut) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timedOut) {
    std::ostringstream s;
    s << "the importer did not finish within " << seconds << " s (a malformed file?); stopped";
    throw std::runtime_error(s.str());
  }
  if (WIFSIGNALED(status)) {
    throw std::runtime_error("the importer crashed on this file (signal " + std::to_string(WTERMSIG(status)) + ", " +
                             ::strsignal(WTERMSIG(status)) + "): it is malformed");
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) != 0) {
    // (a sanitizer build reports a crash and exits instead)
    throw std::runtime_error("the importer crashed on this file (exit status " + std::to_string(WEXITSTATUS(status)) +
                             "): it is malformed");
  }
  return decodeImport(answer, report);
}

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

std::string MeshImportReport::describe() const {
  std::string out;
  if (droppedFaces > 0) {
    out = std::to_string(droppedFaces) + (droppedFaces == 1 ? " zero-area face" : " zero-area faces") +
          " dropped (the first: face " + std::to_string(firstDroppedFace) + ")";
  }
  if (skippedPrimitives > 0) {
    out += (out.empty() ? "" : "; ") + std::to_string(skippedPrimitives) + " points or lines skipped";
  }
  return out;
}

TriangleMesh readMesh(const std::string& path, double scale, MeshImportReport* report, const MeshImportLimits& limits) {
  if (!std::isfinite(scale) || !(scale > 0.0)) {
    throw std::invalid_argument("mesh scale must be positive and finite, got " + std::to_string(scale) + " for '" +
                                path + "'");
  }
  const std::string prefix = "cannot read mesh file '" + path + "': ";

  // The file must exist, be a regular file and fit the size limit (assimp's messages for these are vague).
  std::error_code error;
  if (!std::filesystem::exists(path, error)) throw MeshError(prefix + "file does not exist");
  if (!std::filesystem::is_regular_file(path, error)) throw MeshError(prefix + "not a regular file");
  const std::uintmax_t bytes = std::filesystem::file_size(path, error);
  if (error) throw MeshError(prefix + error.message());
  if (bytes == 0) throw MeshError(prefix + "the file is empty");
  if (bytes > limits.maxBytes) {
    throw MeshError(prefix + "the file has " + std::to_string(bytes) + " bytes, over the limit of " +
                    std::to_string(limits.maxBytes));
  }

  try {
    // PLY: the structure is checked here first (the importer crashes on
    // truncated files and bad indices, and hangs without end_header).
    if (limits.checkFormat) {
      std::ifstream in(path, std::ios::binary);
      char magic[4] = {};
      in.read(magic, 4);
      if (in && std::string(magic, 3) == "ply" && (magic[3] == '\n' || magic[3] == '\r')) {
        std::string all(static_cast<std::size_t>(bytes), '\0');
        in.seekg(0);
        in.read(all.data(), std::streamsize(all.size()));
        if (!in) throw std::runtime_error("cannot read the whole file");
        checkPly(all);
      }
    }
    // One mesh from the whole scene graph, imported out of process.
    MeshImportReport local;
    TriangleMesh mesh = importIsolated(path, scale, limits.seconds, report ? *report : local);
    if (mesh.faces.empty()) throw std::runtime_error("no triangles");
    return mesh;
  } catch (const std::runtime_error& e) {
    throw MeshError(prefix + e.what());
  }
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
