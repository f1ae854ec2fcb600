#pragma once
/// @file ShapeFile.h
/// @brief Reading a `[shape]` table (shape files, and the shapes of scene
/// files). Every key is documented in docs/shapes.md.

#include "lsdem/geometry/ShapeDef.h"

#include <cstddef>
#include <map>
#include <memory>
#include <string>
#include <variant>
#include <vector>

namespace lsdem::io {

/// A shape definition of either dimension, as a file declares it.
using AnyShapeDef = std::variant<geometry::ShapeDef<2>, geometry::ShapeDef<3>>;

/// A shape definition and where it was declared (for messages).
struct ShapeDecl {
  AnyShapeDef def;
  std::string file;  ///< the file it came from
  int line = 0;      ///< line of its table
  std::string key;   ///< dotted path of its table ("shape")
  /// Where its resolution is given (`spacing` or `cells_across`): the line
  /// and dotted key an error only the built shape shows names (a mesh's
  /// spacing against the mesh's size).
  int resolutionLine = 0;
  std::string resolutionKey;
  /// The line of each key of its table (`file`, `vertices`, `node_density`,
  /// ...): where an error of the built shape that one key causes points.
  std::map<std::string, int> keyLines;
  int dimension() const { return def.index() == 0 ? 2 : 3; }
};

/// Fewer surface nodes than this make a shape whose contacts are found at a
/// handful of points (node_density = 1e-6 gave a sphere 4): noted wherever
/// a shape is made (`lsdem shape`, `run`, `mesh2ls`, `ct2ls`).
template <int D>
constexpr std::size_t kFewSurfaceNodes = D == 2 ? 8 : 20;

/// @brief Reads the `[shape]` table of the TOML file at `path`.
/// Relative mesh paths are resolved against the file's folder.
/// @note Throws InputError (file:line: key: problem) for syntax errors, missing,
/// unknown or mistyped keys and out-of-range values.
ShapeDecl readShapeFile(const std::string& path);

/// @brief Builds the declared shape. Problems only geometry can see (a
/// self-intersecting polygon, a broken mesh, a shape with no interior) become
/// InputError at the declaration's table.
/// @param notes when given, receives one line "FILE:LINE: KEY: ..." per thing
/// left out of a mesh file (zero-area faces dropped).
template <int D>
std::shared_ptr<const geometry::Shape<D>> buildDeclaredShape(const ShapeDecl& decl,
                                                             std::vector<std::string>* notes = nullptr);

/// @brief Builds the declared shapes, several at a time on OpenMP threads
/// (each shape's own build is mostly serial: mesh remeshing, fast
/// sweeping). Returns them in the order given; the notes come in that
/// order too. Each shape is the one buildDeclaredShape makes, whatever the
/// thread count. A problem throws the InputError of the first declaration
/// (in the order given) that has one, after every build has ended.
template <int D>
std::vector<std::shared_ptr<const geometry::Shape<D>>> buildDeclaredShapes(const std::vector<ShapeDecl>& decls,
                                                                           std::vector<std::string>* notes = nullptr);

}  // namespace lsdem::io
