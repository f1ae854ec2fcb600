#pragma once
/// @file MeshIO.h
/// @brief Reading CAD meshes (STL, OBJ, PLY) with assimp and writing binary
/// STL: the only files the geometry layer touches (DESIGN.md).

#include "lsdem/geometry/TriangleMesh.h"

#include <string>

namespace lsdem::geometry {

/// @brief Reads a triangle mesh from an STL (ASCII or binary), OBJ or PLY file.
/// @param path file to read; the format is detected by assimp from the
/// extension and contents.
/// @param scale factor applied to every coordinate (file units -> world units,
/// e.g. 0.001 for millimetres -> metres); finite and > 0.
/// @return All meshes of the file in one TriangleMesh (scene-graph transforms
/// applied), polygons triangulated, world units. Vertices at identical
/// positions are joined (so an STL's triangle soup becomes a connected mesh)
/// and faces that collapse to a repeated vertex are dropped; points and lines
/// are ignored. Face orientation is kept as stored.
/// @note Throws MeshError "cannot read mesh file 'PATH': <reason>" when the file
/// is missing, unreadable or not a mesh, or holds no triangles, and
/// std::invalid_argument for a bad scale. The mesh is not checked for
/// closedness here (see inspectMesh / meshToLevelSet).
TriangleMesh readMesh(const std::string& path, double scale = 1.0);

/// @brief Writes a mesh as a binary STL (little-endian float32, one facet
/// normal per face from its right-hand rule).
/// @param mesh mesh in world units (written as is).
/// @param path file to create or overwrite.
/// @note Throws MeshError "cannot write mesh file 'PATH': <reason>" when the file
/// cannot be written, and std::invalid_argument when a face refers to a missing
/// vertex or the mesh has more faces than STL can count (2^32 - 1).
void writeStl(const TriangleMesh& mesh, const std::string& path);

}  // namespace lsdem::geometry
