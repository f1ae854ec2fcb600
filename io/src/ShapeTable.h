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
ShapeDecl readShapeTable(const toml::table& table, const std::string& file, const std::string& path);

}  // namespace lsdem::io::detail
