#include "lsdem/io/ShapeFile.h"

#include "NumberText.h"
#include "ShapeTable.h"
#include "TomlReader.h"

#include "lsdem/geometry/MeshIO.h"
#include "lsdem/geometry/MeshToLevelSet.h"

#include <exception>
#include <stdexcept>

namespace lsdem::io {

ShapeDecl readShapeFile(const std::string& path) {
  const toml::table root = detail::parseTomlFile(path);
  const toml::table* shape = root["shape"].as_table();
  if (!shape) {
    throw InputError(path, 0, "shape", "missing [shape] table");
  }
  detail::TomlReader top(root, path, "");
  top.skip("shape");
  top.finish();
  return detail::readShapeTable(*shape, path, "shape");
}

namespace {

// An error of a declared shape at its table's key `name` (its table when
// the key is absent).
InputError errorAt(const ShapeDecl& decl, const std::string& name, const std::string& what) {
  const auto at = decl.keyLines.find(name);
  if (at == decl.keyLines.end()) return InputError(decl.file, decl.line, decl.key, what);
  return InputError(decl.file, at->second, decl.key + "." + name, what);
}

}  // namespace

template <int D>
std::shared_ptr<const geometry::Shape<D>> buildDeclaredShape(const ShapeDecl& decl, std::vector<std::string>* notes) {
  const auto* def = std::get_if<geometry::ShapeDef<D>>(&decl.def);
  if (!def) {
    throw InputError(decl.file, decl.line, decl.key, "is a " + std::to_string(decl.dimension()) + "D shape, expected " +
                                                         std::to_string(D) + "D");
  }
  try {
    geometry::MeshImportReport report;
    auto shape = geometry::buildShape(*def, &report);
    if (notes && !report.describe().empty()) {
      notes->push_back(InputError(decl.file, decl.line, decl.key, "mesh '" + def->meshFile + "': " + report.describe())
                           .what());
    }
    // A grid of fewer than 5 cells across is allowed (2 is the least) but
    // holds little of the shape: said, at the resolution's key.
    if (notes && def->kind != geometry::ShapeKind::Mesh) {
      const double cells = geometry::smallestDimension<D>(*def) / shape->grid().spacing();
      if (cells < 5.0) {
        notes->push_back(InputError(decl.file, decl.resolutionLine > 0 ? decl.resolutionLine : decl.line,
                                    decl.resolutionKey.empty() ? decl.key : decl.resolutionKey,
                                    "gives only " + roughText(cells) +
                                        " cells across the shape's smallest dimension: a grid this coarse holds "
                                        "little of its shape (volume, surface, contacts; docs/accuracy.md)")
                             .what());
      }
    }
    if (notes && shape->nodes().size() < kFewSurfaceNodes<D>) {
      notes->push_back(InputError(decl.file, decl.line, decl.key,
                                  "has only " + std::to_string(shape->nodes().size()) +
                                      " surface nodes: contacts are found at these points only (node_density)")
                           .what());
    }
    return shape;
  } catch (const geometry::ResolutionError& e) {
    throw InputError(decl.file, decl.resolutionLine > 0 ? decl.resolutionLine : decl.line,
                     decl.resolutionKey.empty() ? decl.key : decl.resolutionKey, e.what());
  } catch (const geometry::MeshError& e) {
    throw errorAt(decl, "file", e.what());
  } catch (const std::invalid_argument& e) {
    // At the key that causes it, where one does (the table's line else).
    const std::string what = e.what();
    const std::string polygon = "validatePolygon: ";
    if (what.rfind(polygon, 0) == 0) throw errorAt(decl, "vertices", what.substr(polygon.size()));
    if (what.find("node density") != std::string::npos) throw errorAt(decl, "node_density", what);
    throw InputError(decl.file, decl.line, decl.key, what);
  }
}

template <int D>
std::vector<std::shared_ptr<const geometry::Shape<D>>> buildDeclaredShapes(const std::vector<ShapeDecl>& decls,
                                                                           std::vector<std::string>* notes) {
  const std::ptrdiff_t n = std::ptrdiff_t(decls.size());
  std::vector<std::shared_ptr<const geometry::Shape<D>>> shapes(decls.size());
  std::vector<std::vector<std::string>> notesOf(decls.size());
  std::vector<std::exception_ptr> errors(decls.size());
  // One shape per thread at a time, the largest share of a build being
  // serial; a single shape is built alone, its own parallel loops then
  // having every thread. (No exception leaves the parallel loop: each is
  // kept and the first in declaration order thrown after it.)
#pragma omp parallel for schedule(dynamic, 1) if (n > 1)
  for (std::ptrdiff_t s = 0; s < n; ++s) {
    try {
      shapes[std::size_t(s)] = buildDeclaredShape<D>(decls[std::size_t(s)], &notesOf[std::size_t(s)]);
    } catch (...) {
      errors[std::size_t(s)] = std::current_exception();
    }
  }
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  if (notes) {
    for (const std::vector<std::string>& lines : notesOf) notes->insert(notes->end(), lines.begin(), lines.end());
  }
  return shapes;
}

template std::shared_ptr<const geometry::Shape<2>> buildDeclaredShape<2>(const ShapeDecl&, std::vector<std::string>*);
template std::shared_ptr<const geometry::Shape<3>> buildDeclaredShape<3>(const ShapeDecl&, std::vector<std::string>*);
template std::vector<std::shared_ptr<const geometry::Shape<2>>> buildDeclaredShapes<2>(const std::vector<ShapeDecl>&,
                                                                                        std::vector<std::string>*);
template std::vector<std::shared_ptr<const geometry::Shape<3>>> buildDeclaredShapes<3>(const std::vector<ShapeDecl>&,
                                                                                        std::vector<std::string>*);

}  // namespace lsdem::io
