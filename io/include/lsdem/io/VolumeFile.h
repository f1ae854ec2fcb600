#pragma once
/// @file VolumeFile.h
/// @brief Labelled 3D images (segmented X-ray CT) for `lsdem ct2ls`
/// (docs/tomography.md): NRRD (attached or detached header, raw or gzip
/// data), TIFF (one multi-page file, or a folder or pattern of 2D slices;
/// read by libtiff, so any compression libtiff decodes), and headerless raw
/// binary described on the command line. Labels are 8, 16 or 32-bit
/// integers (unsigned, or signed with no negative value).
///
/// Why not ITK or another imaging library: reading a label image needs a
/// header parser and a byte decoder; libtiff (a Debian package) covers the
/// one format too rich to parse by hand, zlib (already linked) the gzip
/// NRRD, and ITK would add hundreds of megabytes of build for that.

#include "lsdem/geometry/LabelVolume.h"

#include <cstddef>
#include <optional>
#include <string>

namespace lsdem::io {

/// The integer type of a voxel in a file.
enum class VoxelType { UInt8, UInt16, UInt32, Int8, Int16, Int32 };

/// @brief Bytes per voxel of `type`.
std::size_t voxelBytes(VoxelType type);
/// @brief The type named "uint8", "uint16", "uint32", "int8", "int16" or
/// "int32"; std::nullopt for any other name.
std::optional<VoxelType> voxelTypeNamed(const std::string& name);

/// Layout of a headerless raw file (`lsdem ct2ls --raw-dims ...`).
struct RawLayout {
  geometry::Index<3> dims = geometry::Index<3>::Zero();  ///< voxels per axis, x fastest in the file
  VoxelType type = VoxelType::UInt8;
  bool bigEndian = false;
  std::size_t headerBytes = 0;  ///< bytes to skip before the voxels
};

/// How a volume is read.
struct VolumeReadOptions {
  /// Refuse a volume whose labels (4 bytes per voxel) and decoding buffer
  /// would take more than this many bytes, before allocating them.
  std::size_t maxBytes = std::size_t(4) << 30;
  /// Set: the file is headerless raw with this layout (any extension).
  std::optional<RawLayout> raw;
};

/// A volume as read, and what its file said about its geometry.
struct VolumeRead {
  geometry::LabelVolume volume;  ///< spacing 1 and origin 0 where the file has none
  std::string format;            ///< "nrrd", "tiff", "tiff slices" or "raw"
  bool hasSpacing = false;       ///< the file gave the voxel spacing (NRRD "spacings" / "space directions")
  bool hasOrigin = false;        ///< the file gave the origin (NRRD "space origin")
  /// The length unit of spacing and origin the file names (NRRD "space
  /// units", one for all axes, e.g. "mm"); empty when it names none.
  std::string units;
  int files = 1;  ///< files read (slices of a folder)
};

/// @brief Reads a labelled volume. The format comes from options.raw, else
/// from the path: a folder, or a file name with `*` or `?` in it, is a stack
/// of 2D TIFF slices (files *.tif / *.tiff, or those matching the pattern, in
/// natural order: slice2 before slice10), one slice per z; `.nrrd` / `.nhdr`
/// is NRRD; `.tif` / `.tiff` a multi-page TIFF (one page per z); any other
/// name is recognised by its first bytes (NRRD magic, TIFF byte-order mark).
/// @note Throws InputError naming the file (and the header line or page)
/// for a truncated or inconsistent file, a size that does not match the
/// header, an unsupported type or encoding, a negative label, or a volume
/// over options.maxBytes. Reading or writing TIFF installs libtiff's
/// process-wide error handler (its messages become the InputError's) and a
/// silent warning handler.
VolumeRead readLabelVolume(const std::string& path, const VolumeReadOptions& options = {});

/// @brief Writes a volume as NRRD with an attached header (type, sizes,
/// space directions from the spacing, space origin, little endian), the
/// data raw or gzip-compressed. For tests and for exporting volumes made in code.
/// @note Throws std::runtime_error when the file cannot be written or a label
/// does not fit `type`.
void writeNrrd(const std::string& path, const geometry::LabelVolume& volume, VoxelType type, bool gzip);

/// @brief Writes a volume as TIFF, one page per z slice (a multi-page file;
/// a volume one slice thick gives a plain 2D TIFF), deflate-compressed when
/// `compress`. Spacing and origin are not stored (TIFF has no field for them).
/// @note Throws std::runtime_error when the file cannot be written or a label
/// does not fit `type`.
void writeTiff(const std::string& path, const geometry::LabelVolume& volume, VoxelType type, bool compress);

}  // namespace lsdem::io
