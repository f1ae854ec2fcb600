#pragma once
/// @file VtpRead.h
/// @brief Reading back the ParaView files lsdem writes (io/Vtk.h): VTK XML
/// PolyData frames (`.vtp`) and ParaView time series (`.pvd`). Used by
/// `lsdem render` and by tests that check what a run wrote.
///
/// What is read. A `.vtp` is `<VTKFile type="PolyData">` with exactly one
/// `<Piece>`; its DataArrays may be `format="ascii"`, `format="binary"`
/// (inline base64 of a byte-count header, UInt64 or UInt32 as `header_type`
/// says, then the raw little-endian values; the header and the data may be one
/// base64 stream, as lsdem writes them, or two, as VTK writes them) or
/// `format="appended"` (at `offset` in the file's `<AppendedData
/// encoding="raw">` after its `_` mark: the byte-count header and the values).
/// With `compressor="vtkZLibDataCompressor"` (what lsdem and ParaView write by
/// default) the byte-count header is VTK's compression header and the values
/// are zlib blocks, inline (header and blocks as separate base64 streams) or
/// appended. Other compressors, base64-encoded appended data, big-endian files
/// and triangle strips are refused with a message. Cells may use VTK's 1.0
/// layout (offsets hold the end of each cell) or start with a leading 0.
/// Value types: Float64 and Float32 are read as double, Int64 as int64,
/// UInt64 as uint64, Int32 as int32, and Int8, UInt8, Int16, UInt16, UInt32 as
/// int64.

#include "lsdem/io/Vtk.h"

#include <filesystem>
#include <string_view>
#include <vector>

namespace lsdem::io {

/// @brief Reads one VTK XML PolyData file into a piece (points, the four cell
/// kinds but strips, point and cell data, in file order).
/// A parallel index (`.pvtp`, VTK's PPolyData: writePvtp) is read as its
/// pieces joined (joinPieces), each read from its `Source` relative to the
/// index's folder.
/// @return the piece; points are 3 coordinates each, as in the file.
/// @note Throws io::InputError (file, line of the offending element, the
/// element or array name, the problem) when the file cannot be read, is not
/// PolyData, uses an encoding listed above as refused, or is inconsistent: an
/// array whose value count does not match its tuple count, offsets that
/// decrease or do not end at the connectivity size, a cell naming a missing
/// point, a number that does not parse, a base64 stream whose byte count
/// differs from its header, an appended offset or a compressed block past the
/// end of the file, a block that does not decompress to its size.
VtpPiece readVtp(const std::filesystem::path& file);

/// @brief Reads the entries of a ParaView series (`.pvd`): one (time, file,
/// part) per `<DataSet timestep=... file=... [part=...]>`, in file order
/// (part 0 when the attribute is absent). The file names are as written
/// (relative to the `.pvd`'s folder). The file is only read.
/// @note Throws io::InputError when the file cannot be read, is not a
/// `<VTKFile type="Collection">`, or a DataSet lacks a finite timestep or a
/// file, or has a part that is not a number >= 0.
std::vector<PvdSeries::Entry> readPvd(const std::filesystem::path& file);

/// @brief The entries of frame `frame` of a series (PvdSeries: an entry of
/// part 0 starts a frame): its parts, in file order.
/// @return empty when the series has no such frame.
std::vector<PvdSeries::Entry> frameEntries(const std::vector<PvdSeries::Entry>& entries, std::size_t frame);

/// @brief The number of frames of a series (its entries of part 0).
std::size_t frameCount(const std::vector<PvdSeries::Entry>& entries);


/// @brief The array called `name` in `arrays`, or nullptr.
const VtkArray* findArray(const std::vector<VtkArray>& arrays, std::string_view name);

/// @brief The values of `array` converted to double (integers exactly up to 2^53).
std::vector<double> arrayAsDoubles(const VtkArray& array);

}  // namespace lsdem::io
