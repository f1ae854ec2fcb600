#pragma once
/// @file ShapeTable.h
/// @brief Private to io: reads one shape table (`[shape]` of a shape file, or a
/// shape of a scene file) into a ShapeDef of its declared dimension.

#include "lsdem/io/ShapeFile.h"

#include <toml++/toml.h>

#include <string>

namespace lsdem::io::detail {

/// @param table  the shape's table
/// @param file   the file it came from (messages, and the folder for relative mesh paths)
/// @param path   dotted path of the table in the file ("shape", "shapes.grain")
/// @param dimension  0: the table must give `dimension`; 2 or 3: the scene's
///   dimension (the table may repeat it, and must then agree)
ShapeDecl readShapeTable(const toml::table& table, const std::string& file, const std::string& path, int dimension = 0);

}  // namespace lsdem::io::detail
