#pragma once
/// @file MeshIO.h
/// @brief Reading CAD meshes (STL, OBJ, PLY) with assimp and writing binary
/// STL: the only files the geometry layer touches (DESIGN.md).

#include "lsdem/geometry/TriangleMesh.h"

#include <cstdint>
#include <string>

namespace lsdem::geometry {

/// Limits of readMesh, against files that are too large or that make the
/// importer hang or crash.
struct MeshImportLimits {
  std::uint64_t maxBytes = std::uint64_t(1) << 30;  ///< largest file accepted, bytes (1 GiB)
  double seconds = 300.0;                           ///< wall time the importer may take, s
  /// Check the structure of PLY files (header, element sizes, vertex indices)
  /// before the importer sees them. Off only to test the isolation below.
  bool checkFormat = true;
};

/// What readMesh left out of a mesh file (nothing when all zero).
struct MeshImportReport {
  int droppedFaces = 0;         ///< faces of zero area (a repeated vertex once identical positions are joined), dropped
  long long firstDroppedFace = -1;  ///< index of the first dropped face among the imported triangles, -1 when none
  int skippedPrimitives = 0;    ///< points and lines, skipped
  /// @brief "2 zero-area faces dropped (the first: face 17)", or "" when nothing was left out.
  std::string describe() const;
};

/// @brief Reads a triangle mesh from an STL (ASCII or binary), OBJ or PLY file.
/// @param path file to read; the format is detected by assimp from the
/// extension and contents.
/// @param scale factor applied to every coordinate (file units -> world units,
/// e.g. 0.001 for millimetres -> metres); finite and > 0.
/// @param report when given, receives what was left out (dropped zero-area faces).
/// @param limits size and time limits (defaults: 1 GiB, 300 s).
/// @return All meshes of the file in one TriangleMesh (scene-graph transforms
/// applied), polygons triangulated, world units. Vertices at identical
/// positions are joined (so an STL's triangle soup becomes a connected mesh)
/// and faces that collapse to a repeated vertex are dropped (counted in
/// `report`); points and lines are ignored. Face orientation is kept as stored.
/// Every vertex is finite and every face refers to existing vertices.
/// @note Throws MeshError "cannot read mesh file 'PATH': <reason>" when the file
/// is missing, unreadable, larger than the limit or not a mesh, holds no
/// triangles, has a non-finite vertex or a face index out of range, or (PLY)
/// has a malformed header or is truncated; and std::invalid_argument for a bad
/// scale. The importer (assimp) runs in a child process: when it crashes or
/// exceeds the time limit the error says so, and this process is unharmed. The
/// mesh is not checked for closedness here (see inspectMesh / meshToLevelSet).
TriangleMesh readMesh(const std::string& path, double scale = 1.0, MeshImportReport* report = nullptr,
                      const MeshImportLimits& limits = {});

/// @brief Writes a mesh as a binary STL (little-endian float32, one facet
/// normal per face from its right-hand rule).
/// @param mesh mesh in world units (written as is).
/// @param path file to create or overwrite.
/// @note Throws MeshError "cannot write mesh file 'PATH': <reason>" when the file
/// cannot be written, and std::invalid_argument when a face refers to a missing
/// vertex or the mesh has more faces than STL can count (2^32 - 1).
void writeStl(const TriangleMesh& mesh, const std::string& path);

}  // namespace lsdem::geometry
