#pragma once
/// @file GrainFile.h
/// @brief Grain files (docs/grains.md): one level-set grain per file, as text
/// or binary, and a folder of grain files as a shape pool.
///
/// Two text forms are read. The *full* form, written by lsdem, holds every
/// stored part of a Shape (Shape<D>::parts(): grid, body-to-grid map, surface
/// nodes with weights in the body frame, mass properties per unit density,
/// descriptors, bounding radius, options) with numbers in their shortest
/// round-trip form, so reading it back gives a shape equal bit for bit. The
/// *minimal* form, for hand-made files or grains exported by other LS-DEM
/// codes, holds only the grid (dimension, dims, origin, spacing, values) and
/// optionally surface nodes in the grid frame; the shape is then rebuilt from
/// them (Shape::fromGrid / fromGridAndNodes). The binary form holds the same
/// parts as the full text form as raw little-endian numbers after a magic and a
/// version; it is what checkpoints use.
///
/// Several grains may follow each other in one stream: a text grain ends at a
/// line `end` (or at the end of the stream) and a binary grain at its last
/// field, so readGrain leaves the stream just after the grain it read.

#include "lsdem/geometry/Shape.h"

#include <istream>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

namespace lsdem::io {

/// How a grain is written.
enum class GrainFormat {
  Text,   ///< the full text form (keys and numbers, one field per line)
  Binary  ///< raw little-endian numbers after the magic "\x89LSDEMG\n" and a version
};

/// @brief Writes a shape exactly: Shape<D>::parts() (grid dims, origin,
/// spacing and values; bodyToGrid; nodes and weights in the body frame; mass
/// properties per unit density; descriptors; bounding radius; options), so
/// that readGrain gives back a shape equal bit for bit.
/// @param out stream to write to (open it in binary mode for GrainFormat::Binary).
/// @param shape the shape.
/// @param format GrainFormat::Text (numbers in shortest round-trip form via
/// std::to_chars) or GrainFormat::Binary (raw little-endian, magic + version header).
/// @note Throws std::runtime_error when the stream fails.
template <int D>
void writeGrain(std::ostream& out, const geometry::Shape<D>& shape, GrainFormat format);

/// @brief writeGrain to a file, atomically: the grain is written to
/// "PATH.tmp" and renamed to PATH once complete, so a reader never sees half a file.
/// @note Throws std::runtime_error "cannot write grain file 'PATH': reason".
template <int D>
void writeGrainFile(const std::string& path, const geometry::Shape<D>& shape, GrainFormat format);

/// @brief Reads one grain in any form (full text, minimal text, binary; the
/// form is detected from the first byte).
/// @param in stream positioned at the start of a grain.
/// @param sourceName the name errors are reported under (usually the file name).
/// @return the shape; for the full text and binary forms equal bit for bit to
/// the one written, for the minimal form rebuilt from the grid (and nodes).
/// @note Throws io::InputError with file = sourceName, line (text form; 0 for
/// binary) and key (the field, e.g. "values") for a truncated grain, wrong
/// counts, non-finite numbers, an unknown key or dimension, a grain of the
/// other dimension than D, a bad magic or version, or inconsistent parts.
template <int D>
std::shared_ptr<const geometry::Shape<D>> readGrain(std::istream& in, const std::string& sourceName);

/// @brief readGrain from the file at `path` (errors name `path`).
/// @note Throws io::InputError when the file cannot be opened or its grain is bad.
template <int D>
std::shared_ptr<const geometry::Shape<D>> readGrainFile(const std::string& path);

/// @brief The dimension (2 or 3) of the grain in the file at `path`, from its header.
/// @note Throws io::InputError when the file cannot be opened, is not a grain
/// file, or names another dimension.
int grainFileDimension(const std::string& path);

/// @brief A folder of grain files as a shape pool: every regular file named
/// *.lsg directly in `dir`, sorted by file name (byte order), read with readGrainFile.
/// @param dir the folder.
/// @note Throws io::InputError when `dir` is not a folder, holds no *.lsg file,
/// or one of its grains is bad (the error names that file).
template <int D>
std::vector<std::shared_ptr<const geometry::Shape<D>>> readGrainFolder(const std::string& dir);

extern template void writeGrain<2>(std::ostream&, const geometry::Shape<2>&, GrainFormat);
extern template void writeGrain<3>(std::ostream&, const geometry::Shape<3>&, GrainFormat);
extern template void writeGrainFile<2>(const std::string&, const geometry::Shape<2>&, GrainFormat);
extern template void writeGrainFile<3>(const std::string&, const geometry::Shape<3>&, GrainFormat);
extern template std::shared_ptr<const geometry::Shape<2>> readGrain<2>(std::istream&, const std::string&);
extern template std::shared_ptr<const geometry::Shape<3>> readGrain<3>(std::istream&, const std::string&);
extern template std::shared_ptr<const geometry::Shape<2>> readGrainFile<2>(const std::string&);
extern template std::shared_ptr<const geometry::Shape<3>> readGrainFile<3>(const std::string&);
extern template std::vector<std::shared_ptr<const geometry::Shape<2>>> readGrainFolder<2>(const std::string&);
extern template std::vector<std::shared_ptr<const geometry::Shape<3>>> readGrainFolder<3>(const std::string&);

}  // namespace lsdem::io
