#pragma once
/// @file MeshToLevelSet.h
/// @brief CAD part -> level set (eq. 1): the signed distance grid of a closed
/// triangle mesh, after checking that the mesh can be trusted to have an inside.

#include "lsdem/geometry/Grid.h"
#include "lsdem/geometry/SurfaceNodes.h"
#include "lsdem/geometry/TriangleMesh.h"

#include <string>

namespace lsdem::geometry {

/// @brief What is wrong with a triangle mesh, if anything (inspectMesh).
/// Counts are of mesh elements; a check that cannot be made because an earlier
/// one failed is left at its default (see inspectMesh).
struct MeshReport {
  /// Edges used by exactly one face (holes, open shells).
  int borderEdges = 0;
  /// Edges used by more than two faces.
  int nonManifoldEdges = 0;
  /// Edges whose two faces traverse them in the same direction (neighbouring
  /// faces with opposite orientations).
  int misorientedEdges = 0;
  /// Vertices where separate fans of faces meet (e.g. two solids touching at a point).
  int nonManifoldVertices = 0;
  /// Faces referring to a vertex index outside [0, vertices.size()).
  int badIndexFaces = 0;
  /// Vertices with a NaN or infinite coordinate (nothing else is checked then).
  int nonFiniteVertices = 0;
  /// Faces of zero area (repeated vertex or three collinear vertices, tested exactly).
  int degenerateFaces = 0;
  /// Index of the first degenerate face, -1 when none.
  long long firstDegenerateFace = -1;
  /// Two faces intersect other than at a shared edge or vertex.
  bool selfIntersecting = false;
  /// A closed mesh with normals pointing inward: signed volume <= 0, or a shell
  /// facing against its nesting (an outer shell facing in, a cavity facing out;
  /// CGAL Polygon_mesh_processing::does_bound_a_volume).
  bool inverted = false;
  /// No faces or no vertices.
  bool empty = false;
  /// Separate solids the mesh bounds (CGAL volume_connected_components: a
  /// shell with the cavities nested in it is one solid); 0 when not checked
  /// (an open, self-intersecting or inverted mesh). More than one is refused:
  /// a grain or a tool is one body (put each in a file of its own).
  int bodies = 0;

  /// @brief True when nothing is wrong: the mesh bounds a solid with outward normals.
  bool ok() const;
  /// @brief What is wrong, as a phrase for "mesh 'NAME' ...", problems joined by
  /// "; " (e.g. "is not closed (12 border edges); has 3 degenerate faces"); "is ok" when ok().
  std::string describe() const;
};

/// @brief Checks that a triangle mesh bounds a solid: indices in range,
/// non-empty, closed (no border edges), manifold (edges and vertices),
/// consistently oriented, no degenerate faces, no self-intersections (CGAL
/// Polygon_mesh_processing::does_self_intersect), outward (signed volume > 0),
/// one body (MeshReport::bodies).
/// @param mesh triangle mesh, any units.
/// @return The report; never throws on bad geometry.
/// @note Order of checks: emptiness, then indices (faces with bad indices stop
/// the inspection), then finite vertices (non-finite ones stop it: CGAL's
/// predicates never see them), then degenerate faces and edges, then vertices (only when
/// edges are manifold and consistent), then self-intersection (only for a
/// manifold, consistently oriented mesh without degenerate faces, where the
/// test is well defined), then orientation (only for a closed manifold mesh).
MeshReport inspectMesh(const TriangleMesh& mesh);

/// @brief Signed distance grid of a closed mesh (eq. 1: phi = -d inside, +d outside).
/// @param mesh closed, manifold, outward-oriented, self-intersection-free
/// triangle mesh, world units.
/// @param spacing grid spacing, world units (> 0).
/// @param paddingCells cells of padding around the mesh bounds (>= 0).
/// @param name the mesh's name for error messages (e.g. its file name).
/// @return A grid covering the mesh bounds + paddingCells (Grid::covering);
/// |phi| is the exact distance to the nearest face (CGAL AABB tree), the sign
/// comes from ray casting (CGAL::Side_of_triangle_mesh): points inside get
/// phi < 0, points on the surface phi = 0.
/// @note Throws MeshError "mesh 'NAME': <what is wrong>" (MeshReport::describe)
/// when inspectMesh finds a problem — never a silently mis-signed grid — and
/// std::invalid_argument for a bad spacing or padding. The nodes are computed
/// in parallel (z-slices); the result does not depend on the thread count.
Grid<3> meshToLevelSet(const TriangleMesh& mesh, double spacing, int paddingCells = kDefaultPaddingCells,
                       const std::string& name = "mesh");

/// @brief Surface nodes on a CAD part's true surface: moves a point (world
/// units, the mesh's frame) to the closest point of the mesh's triangles
/// (CGAL AABB tree, exact distance), the surface its level set samples.
/// The grid's zero set lies ~h^2 / (8 R) inside a convex curved part and
/// cuts its edges and corners; the closest point is the move along the
/// surface's normal that undoes it (on a face, along the face's normal; off
/// an edge or a corner, onto it). A point farther than `spacing` from the
/// mesh is returned unmoved (it stays on the grid's surface), as
/// projectOntoSurface does for primitives.
/// @param mesh a mesh meshToLevelSet accepts (closed, manifold,
/// outward-oriented), world units.
/// @param spacing the grid spacing, world units (> 0): the largest move.
/// @return A projector that holds its own copy of the mesh and its tree
/// (built here; queries from several threads at once only read them).
/// @note Throws std::invalid_argument for a bad spacing and MeshError when
/// the faces do not form a manifold surface (cgal::toSurfaceMesh).
SurfaceProjector<3> meshSurfaceProjector(const TriangleMesh& mesh, double spacing);

}  // namespace lsdem::geometry
