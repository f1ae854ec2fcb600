#include "lsdem/io/ShapeFile.h"

#include "ShapeTable.h"
#include "TomlReader.h"

#include "lsdem/geometry/MeshIO.h"
#include "lsdem/geometry/MeshToLevelSet.h"

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
    return shape;
  } catch (const geometry::MeshError& e) {
    throw InputError(decl.file, decl.line, decl.key, e.what());
  } catch (const std::invalid_argument& e) {
    throw InputError(decl.file, decl.line, decl.key, e.what());
  }
}

template std::shared_ptr<const geometry::Shape<2>> buildDeclaredShape<2>(const ShapeDecl&, std::vector<std::string>*);
template std::shared_ptr<const geometry::Shape<3>> buildDeclaredShape<3>(const ShapeDecl&, std::vector<std::string>*);

}  // namespace lsdem::io
