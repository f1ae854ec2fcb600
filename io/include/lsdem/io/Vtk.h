#pragma once
/// @file Vtk.h
/// @brief ParaView output written by the project itself (no VTK library): VTK
/// XML PolyData frames (`.vtp`) and ParaView time series (`.pvd`) listing them
/// (docs/paraview.md).
///
/// File format. Every `.vtp` is `<VTKFile type="PolyData" version="1.0"
/// byte_order="LittleEndian" header_type="UInt64">` with one Piece. Cells use
/// the version-1.0 layout: a `connectivity` array and an `offsets` array
/// holding the end of each cell, Int32 where every value fits (else Int64). Arrays are written in one of four
/// encodings (VtkEncoding):
/// - Compressed (the default): the root also says
///   `compressor="vtkZLibDataCompressor"`; every DataArray is
///   `format="appended" offset="N"` and its bytes are in the file's
///   `<AppendedData encoding="raw">` after the `_` mark, at byte N from it:
///   a header of UInt64 words [blocks, block size, size of the last block
///   (0: full), compressed size of each block], then each block of up to
///   32 KiB of the raw little-endian values, compressed by zlib. What VTK's
///   own writer (and ParaView's Save Data) produces by default.
/// - Appended: the same without compression: at byte N, a UInt64 byte count
///   then the raw values.
/// - Binary: `format="binary"`, inline base64 (RFC 4648 alphabet, '=' padding)
///   of ONE byte stream made of an 8-byte little-endian unsigned byte count of
///   the data followed by the raw little-endian data (no compression). This is
///   what VTK's own writer produces for uncompressed inline data.
/// - Ascii: `format="ascii"`, decimal numbers separated by blanks, in the
///   shortest form that reads back to the same value (std::to_chars).
///
/// 2D worlds are written in the z = 0 plane: points, velocities and forces get
/// z = 0; angular velocity is (0, 0, w).
///
/// Files are written atomically: to `<file>.tmp`, then renamed over `<file>`,
/// so a run killed at any moment leaves either the old or the new file, never
/// half of one. All output happens between steps; nothing here is called from
/// the step's loops.

#include "lsdem/dynamics/World.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/Types.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <variant>
#include <vector>

namespace lsdem::io {

/// How DataArray values are stored in a `.vtp` file (see the file comment).
enum class VtkEncoding { Compressed, Appended, Binary, Ascii };

/// @brief The scene's name of an encoding: "compressed", "appended", "binary", "ascii".
const char* encodingName(VtkEncoding encoding);
/// @brief The encoding of a scene's name, or nullopt.
std::optional<VtkEncoding> encodingNamed(std::string_view name);

/// One named DataArray: `components` values per tuple, tuples one after the
/// other (x0 y0 z0 x1 y1 z1 ...). The vector's element type picks the VTK type:
/// double -> Float64, int64 -> Int64, uint64 -> UInt64, int32 -> Int32,
/// float -> Float32 (written only; io::readVtp reads Float32 as double).
struct VtkArray {
  using Values = std::variant<std::vector<double>, std::vector<std::int64_t>, std::vector<std::uint64_t>,
                              std::vector<std::int32_t>, std::vector<float>>;
  std::string name;    ///< array name shown in ParaView
  int components = 1;  ///< values per tuple, >= 1
  Values values;       ///< tuples x components values

  /// @brief Number of values held (tuples x components).
  std::size_t valueCount() const;
};

/// Cells of one kind (vertices, polylines or polygons) in VTK's 1.0 layout.
struct VtkCells {
  std::vector<std::int64_t> connectivity;  ///< point indices of all cells, one cell after the other
  std::vector<std::int64_t> offsets;       ///< end of each cell in `connectivity` (exclusive)

  /// @brief Number of cells.
  std::size_t size() const { return offsets.size(); }
  /// @brief Appends one cell made of `points` (point indices).
  void add(std::span<const std::int64_t> points);
};

/// One PolyData piece: points, cells and the arrays on them. Cell data runs
/// over all cells in VTK's order: verts, then lines, then polys.
struct VtpPiece {
  std::vector<double> points;  ///< 3 coordinates per point, world frame, m
  VtkCells verts;              ///< vertex cells
  VtkCells lines;              ///< polyline cells
  VtkCells polys;              ///< polygon cells
  std::vector<VtkArray> pointData;  ///< one tuple per point
  std::vector<VtkArray> cellData;   ///< one tuple per cell (verts + lines + polys)
  /// Write the points as Float32: surfaces and boundaries, contours drawn at
  /// their grid's resolution (7 significant digits: 0.1 um at 1 m), half the
  /// bytes of the largest array. Particle frames keep Float64.
  bool singlePrecisionPoints = false;
  /// The simulated time of the frame, s: written as the data set's field
  /// data `TimeValue` (what ParaView shows for a file opened on its own).
  std::optional<double> time;

  /// @brief Number of points (points.size() / 3).
  std::size_t pointCount() const { return points.size() / 3; }
  /// @brief Number of cells of all kinds.
  std::size_t cellCount() const { return verts.size() + lines.size() + polys.size(); }
};

/// @brief Pieces joined into one (the parts of a frame): points one piece
/// after the other, cells of each kind in piece order (VTK's cell order,
/// verts, lines, polys, kept), and the point and cell data arrays every piece
/// has with the same component count: of their own type where every piece
/// has that type, else Float64; other arrays are left out. No time.
VtpPiece joinPieces(std::span<const VtpPiece> pieces);

/// @brief Writes `piece` as a VTK XML PolyData file, atomically (`file.tmp`, then rename).
/// @note Throws std::invalid_argument when an array's size does not match its
/// point or cell count, a cell refers to a missing point, or offsets are not
/// increasing; std::runtime_error naming the path when the file cannot be
/// written (missing or read-only directory, full disk).
void writeVtp(const std::filesystem::path& file, const VtpPiece& piece, VtkEncoding encoding);

/// @brief The layout of `piece`: the names, types and component counts of
/// its point and cell data and the precision of its points, with no values
/// and no geometry (what a `.pvtp` declares of its pieces).
VtpPiece layoutOf(const VtpPiece& piece);

/// @brief Writes a parallel PolyData index (`.pvtp`, VTK's PPolyData) of the
/// pieces `pieceFiles` (paths relative to the index's directory), each a
/// `.vtp` with the arrays of `layout` (layoutOf one of them), atomically.
/// ParaView reads it as one data set; io::readVtp joins its pieces.
/// @note Throws std::runtime_error naming the path when it cannot be written.
void writePvtp(const std::filesystem::path& file, const VtpPiece& layout, std::span<const std::string> pieceFiles);

/// @brief Writes `content` to `file` atomically: to `file.tmp`, then renamed over `file`.
/// @note Throws std::runtime_error naming the path when it cannot be written.
void writeFileAtomically(const std::filesystem::path& file, const std::string& content);
/// @brief The same for content in parts, written one after the other.
void writeFileAtomically(const std::filesystem::path& file, std::span<const std::string_view> parts);

/// The zero level set of one shape in its BODY frame (origin at the centroid,
/// principal axes), world units: closed loops in 2D (each loop one polygon
/// cell, its vertices in order, the first not repeated at the end), triangles
/// in 3D.
template <int D>
struct BodyContour {
  std::vector<geometry::Vec<D>> vertices;  ///< body frame, m
  std::vector<geometry::Vec<D>> normals;   ///< 3D: outward unit normal at each vertex (the level set's gradient), body frame; 2D: empty
  std::vector<std::int64_t> connectivity;  ///< vertex indices of all cells
  std::vector<std::int64_t> offsets;       ///< end of each cell (exclusive)

  /// @brief Number of cells (loops in 2D, triangles in 3D).
  std::size_t cellCount() const { return offsets.size(); }
  /// @brief Number of edges in 2D (sum over loops of their vertex count: a
  /// closed loop of n vertices has n edges) or triangles in 3D.
  std::size_t pieceCount() const;
};

/// @brief The zero level set (eq. 2) of `shape` in its body frame: marching
/// squares (2D) or marching cubes (3D) on its grid, mapped grid frame -> body
/// frame by the inverse of Shape::bodyToGrid().
template <int D>
BodyContour<D> bodyContour(const geometry::Shape<D>& shape);

/// Body-frame contours of shapes, computed once per shape. Many particles share
/// a shape and breakage makes new ones, so the cache holds a reference to every
/// shape it has a contour of: a shape's address cannot be reused by a new shape
/// while it is cached, so the address is a safe key. prune() releases the
/// shapes nobody else holds any more (freed fragments).
template <int D>
class SurfaceCache {
 public:
  /// @brief The body-frame contour of `shape`, computed on first use.
  /// @note Throws std::invalid_argument for a null shape.
  const BodyContour<D>& contour(const std::shared_ptr<const geometry::Shape<D>>& shape);
  /// @brief Drops the entries whose shape is held by the cache alone.
  void prune();
  /// @brief Number of cached shapes.
  std::size_t size() const { return entries_.size(); }

 private:
  struct Entry {
    std::shared_ptr<const geometry::Shape<D>> shape;  ///< keeps the key's address alive
    BodyContour<D> contour;
  };
  std::unordered_map<const geometry::Shape<D>*, Entry> entries_;
};

/// @brief Particle frame: one vertex per particle at its centroid (world
/// frame), with point data (units in docs/paraview.md): id (UInt64),
/// parent_id (Int64, -1 for none), generation (Int32), radius (bounding radius,
/// m), equivalent_diameter (m), mass (kg), velocity (3, m/s), angular_velocity
/// (3, rad/s), orientation (4: quaternion w, x, y, z, body to world; 2D: the
/// rotation about z), axis_x/y/z (3 each: the body axes in the world), stress
/// (the breakage criterion value, Pa), strength (Pa), criterion_ratio, and the
/// invariants of each grain's average stress tensor (eq. 5, tension positive,
/// Pa): mean_stress (tr(sigma) / 3), von_mises_stress (sqrt(3 J2)) and
/// principal_stress (3: principalStressTriple, s1 >= s2 >= s3 in 3D; 2D plane
/// stress (s1, s2, 0)).
/// A world with ghosts (a part of a distributed run) writes its own
/// particles only, as do the surface and contact frames (a pair with a ghost
/// is its lower-id particle's owner's): its piece of the run's frame. Each of
/// the three returns the layout of what it wrote (layoutOf).
/// @param stressMeasure one value per particle in store order, or empty (zeros written).
/// @param stressTensors each particle's average stress tensor (world frame,
/// Pa, tension positive; breakage::grainStresses), or empty (the invariants
/// are written as zeros).
/// @note Throws std::invalid_argument when stressMeasure or stressTensors is
/// neither empty nor one value per particle; std::runtime_error when the file
/// cannot be written.
template <int D>
VtpPiece writeParticleFrame(const std::filesystem::path& file, const dynamics::World<D>& world,
                        std::span<const double> stressMeasure, VtkEncoding encoding,
                        std::span<const geometry::Mat<D>> stressTensors = {});

/// The stress invariants the particle frame writes, of one stress tensor
/// (Pa, tension positive).
struct StressInvariants {
  double mean = 0.0;                  ///< tr(sigma) / 3 (2D plane stress: (s1 + s2) / 3), Pa; < 0 in compression
  double vonMises = 0.0;              ///< sqrt(3 J2) = sqrt(((s1-s2)^2 + (s2-s3)^2 + (s3-s1)^2) / 2), Pa, >= 0
  std::array<double, 3> principal{};  ///< breakage::principalStressTriple, Pa
};

/// @brief Mean stress, von Mises stress and principal stresses of `sigma`
/// (a symmetric tensor, world frame, Pa; only its lower triangle is read). 2D
/// tensors are taken as plane stress (the out-of-plane stress is zero).
template <int D>
StressInvariants stressInvariants(const geometry::Mat<D>& sigma);

/// @brief Surface frame: every particle's surface in world coordinates (body
/// contour placed at the particle's pose: x = R x_body + position), as
/// polygons in 2D (one per closed loop: ParaView fills them) and triangles in
/// 3D. Cell data, the particle's: id
/// (UInt64), generation (Int32), velocity (3), stress, strength and
/// criterion_ratio (as in the particle frame). 3D point data: Normals
/// (Float32, outward unit normals from the level set's gradient, rotated with
/// the particle), so ParaView shades the surfaces smoothly.
/// @param cache body contours, reused across frames (pruned here).
/// @param stressMeasure per particle criterion value (Pa), or empty (0).
template <int D>
VtpPiece writeSurfaceFrame(const std::filesystem::path& file, const dynamics::World<D>& world, SurfaceCache<D>& cache,
                       VtkEncoding encoding, std::span<const double> stressMeasure = {});

/// @brief The boundaries' geometry, one piece per boundary group: piece 0
/// holds the planes clipped to `extent` (a segment, a line cell, in 2D; a
/// polygon in 3D; a plane that misses the box is drawn as a segment / square
/// of the box's diagonal centred at the box centre's projection), piece 1 + k
/// tool k's surface at its current pose (polygons in 2D, triangles in 3D).
/// Cell data: kind (Int32, 0 plane, 1 tool), index (Int32, within its kind).
/// Points are Float32; no time (a piece can stand for many frames: the loads
/// on the boundaries are in history.csv, docs/outputs.md).
/// @param extent the scene's domain, world frame, m.
/// @note Throws std::invalid_argument when the extent is not a box of positive size.
template <int D>
std::vector<VtpPiece> boundaryPieces(const dynamics::World<D>& world, SurfaceCache<D>& cache,
                                     const geometry::Box<D>& extent);

/// @brief Boundary frame: every piece of boundaryPieces in one file (planes,
/// then tools).
/// @note Throws std::invalid_argument when the extent is not a box of positive size.
template <int D>
void writeBoundaryFrame(const std::filesystem::path& file, const dynamics::World<D>& world, SurfaceCache<D>& cache,
                        const geometry::Box<D>& extent, VtkEncoding encoding);

/// @brief Contact force chain frame: one point per particle (its centroid;
/// point data id), one line cell per touching particle pair of the last force
/// computation (centroid of a to centroid of b). Cell data: force (3, N, on a),
/// force_magnitude (N), normal_force (N, > 0 compressive, along the overlap-weighted mean node
/// normal from b to a, eq. 4), tangential_force (N), node_contacts (Int32),
/// id_a and id_b (UInt64).
/// @note Contacts describe the state of the last force computation: written
/// right after a step they match the particles. Pairs whose indices are beyond
/// the particle store (particles removed since) are skipped.
template <int D>
VtpPiece writeContactFrame(const std::filesystem::path& file, const dynamics::World<D>& world, VtkEncoding encoding);

/// A ParaView time series (`.pvd`): a list of (time, part, file) entries,
/// rewritten atomically after every change, so a run killed at any moment
/// leaves a valid `.pvd` listing frames that exist. A frame is one entry, or
/// several with the same time and parts 0, 1, ... (ParaView shows the parts
/// of a time as the blocks of one data set); an entry of part 0 starts a frame.
/// Entries of different frames can name the same file.
class PvdSeries {
 public:
  /// One file of a frame of the series.
  struct Entry {
    double time = 0.0;  ///< simulated time, s
    std::string file;   ///< path relative to the .pvd's directory
    int part = 0;       ///< part of its frame, 0 first
  };

  /// @brief A series written to `pvdFile`.
  /// @param resume true: read the entries of an existing `pvdFile` (a resumed
  /// run; follow with truncateAfter(checkpoint time)); false, or no such file:
  /// start empty. The file is (re)written at once.
  /// @note Throws io::InputError when a resumed file is not a readable
  /// series; std::runtime_error when the file cannot be written.
  explicit PvdSeries(std::filesystem::path pvdFile, bool resume = false);

  /// @brief Appends a frame and rewrites the file.
  /// @param relativeFile path of the frame relative to the .pvd's directory.
  void add(double time, const std::string& relativeFile);
  /// @brief Appends a frame of several parts (files relative to the .pvd's
  /// directory, part 0 first) and rewrites the file once.
  void add(double time, std::span<const std::string> partFiles);
  /// @brief Drops every entry later than `time` (s) and rewrites the file.
  void truncateAfter(double time);
  /// @brief The entries, in order of addition.
  const std::vector<Entry>& entries() const { return entries_; }
  /// @brief Number of frames (entries of part 0).
  std::size_t frameCount() const;
  /// @brief The .pvd file.
  const std::filesystem::path& path() const { return path_; }

 private:
  void save() const;

  std::filesystem::path path_;
  std::vector<Entry> entries_;
};

/// What FrameWriter writes, and where.
template <int D>
struct FrameWriterDef {
  std::filesystem::path directory;           ///< output directory (created); frames go to directory/frames/
  VtkEncoding encoding = VtkEncoding::Compressed;
  bool particles = true;                     ///< particles.pvd
  bool surfaces = true;                      ///< surfaces.pvd
  bool boundaries = true;                    ///< boundaries.pvd
  bool contacts = true;                      ///< contacts.pvd
  /// Domain the planes are clipped to, world frame, m. A box of zero size:
  /// the particles' bounding spheres grown by 10% on each side, per frame.
  geometry::Box<D> extent;
  bool resume = false;                       ///< keep the entries of existing .pvd files (then call truncateAfter)
  /// A distributed run's frames in per-rank pieces: the number of ranks (0:
  /// whole frames). Then a frame of particles, surfaces and contacts is
  /// `frames/<series>_NNNNNN.pvtp`, an index of the ranks' pieces
  /// `frames/<series>_NNNNNN_rRRRRR.vtp` (writeFramePieces).
  int pieces = 0;
};

/// @brief The stresses a frame shows: the grains' average stress tensors
/// (eq. 5, breakage::grainStresses) of `world` into `out`, one per particle,
/// while its contact records describe the particles; zeros otherwise (right
/// after a breakage or removal).
template <int D>
void frameStresses(const dynamics::World<D>& world, std::vector<geometry::Mat<D>>& out);

/// @brief Rank `rank`'s piece of frame `number` of a distributed run
/// (FrameWriterDef::pieces): the particle, surface and contact frames of the
/// series `def` enables, of `world`'s own particles (writeParticleFrame), to
/// `frames/<series>_NNNNNN_rRRRRR.vtp`. Every rank calls it for the frame;
/// the writing rank's FrameWriter then writes the frame's index.
/// @param stressMeasure, stress as for FrameWriter::write (empty: stresses
/// from the world's contact records).
/// @return the layouts of the pieces written (particles, surfaces, contacts;
/// empty for a series not written), for FrameWriter::setPieceLayouts.
template <int D>
std::array<VtpPiece, 3> writeFramePieces(const FrameWriterDef<D>& def, std::size_t number, int rank,
                                         const dynamics::World<D>& world, SurfaceCache<D>& cache,
                                         std::span<const double> stressMeasure = {},
                                         std::span<const geometry::Mat<D>> stress = {});

/// The four series of a run: `particles.pvd`, `surfaces.pvd`,
/// `boundaries.pvd`, `contacts.pvd` in the output directory, with frames in
/// `frames/<series>_NNNNNN.vtp` (NNNNNN the frame number from 0).
///
/// Boundaries are written once and referenced while they stay where they
/// are: each frame of `boundaries.pvd` has one part per piece of
/// boundaryPieces (part 0 the planes, `frames/boundaries_NNNNNN_planes.vtp`;
/// part 1 + k tool k, `frames/boundaries_NNNNNN_tool<k>.vtp`), and a piece
/// whose points and cells are those of its last written file (compared as
/// written, Float32) is not written again: the frame's entry names that file.
/// A static floor is one file for the whole run; a moving jaw one per frame.
/// A resumed writer reads the files the kept frames name, so it makes the
/// same choices as an uninterrupted run.
template <int D>
class FrameWriter {
 public:
  /// @brief Creates the directories and the enabled series.
  /// @note Throws std::runtime_error naming the directory when it cannot be created.
  explicit FrameWriter(FrameWriterDef<D> def);

  /// @brief Writes one frame of every enabled series at world.time().
  /// @param stressMeasure per particle criterion value (Pa), or empty.
  /// @param stress per particle average stress tensor (eq. 5), or empty: then
  ///   breakage::grainStresses on the world's contact records (zeros while the
  ///   records do not describe the particles, right after a breakage).
  /// @note The particles' stress invariants are those of `stress`.
  void write(const dynamics::World<D>& world, std::span<const double> stressMeasure = {},
             std::span<const geometry::Mat<D>> stress = {});
  /// @brief Drops frames later than `time` (s) from every series (resumed runs).
  void truncateAfter(double time);
  /// @brief With pieces (FrameWriterDef::pieces): the layouts of the pieces
  /// of the frame write() writes next (writeFramePieces' result, of any
  /// rank), which its indices declare.
  void setPieceLayouts(std::array<VtpPiece, 3> layouts) { pieceLayouts_ = std::move(layouts); }
  /// @brief The number the next frame gets.
  std::size_t nextFrame() const { return nextFrame_; }
  /// @brief What the writer was made with.
  const FrameWriterDef<D>& def() const { return def_; }

 private:
  /// The last written file of one boundary piece, as written.
  struct WrittenPiece {
    std::string file;                ///< relative to the output directory; empty: none yet
    std::vector<float> points;       ///< Float32 coordinates, as in the file
    VtkCells lines, polys;
  };

  void updateNextFrame();
  void writeBoundaries(const dynamics::World<D>& world, const std::string& number);
  void recallBoundaries(std::size_t pieces);

  FrameWriterDef<D> def_;
  SurfaceCache<D> cache_;
  std::vector<WrittenPiece> boundaryFiles_;  ///< per boundary piece
  bool boundariesRecalled_ = false;          ///< boundaryFiles_ read from the series (resume) or started
  std::vector<geometry::Mat<D>> stress_;     ///< scratch: the grains' stress tensors
  std::optional<PvdSeries> particles_, surfaces_, boundaries_, contacts_;
  std::size_t nextFrame_ = 0;
  std::optional<std::array<VtpPiece, 3>> pieceLayouts_;  ///< setPieceLayouts
};

extern template struct BodyContour<2>;
extern template struct BodyContour<3>;
extern template BodyContour<2> bodyContour<2>(const geometry::Shape<2>&);
extern template BodyContour<3> bodyContour<3>(const geometry::Shape<3>&);
extern template class SurfaceCache<2>;
extern template class SurfaceCache<3>;
extern template VtpPiece writeParticleFrame<2>(const std::filesystem::path&, const dynamics::World<2>&,
                                           std::span<const double>, VtkEncoding, std::span<const geometry::Mat<2>>);
extern template VtpPiece writeParticleFrame<3>(const std::filesystem::path&, const dynamics::World<3>&,
                                           std::span<const double>, VtkEncoding, std::span<const geometry::Mat<3>>);
extern template StressInvariants stressInvariants<2>(const geometry::Mat<2>&);
extern template StressInvariants stressInvariants<3>(const geometry::Mat<3>&);
extern template std::vector<VtpPiece> boundaryPieces<2>(const dynamics::World<2>&, SurfaceCache<2>&,
                                                        const geometry::Box<2>&);
extern template std::vector<VtpPiece> boundaryPieces<3>(const dynamics::World<3>&, SurfaceCache<3>&,
                                                        const geometry::Box<3>&);
extern template VtpPiece writeSurfaceFrame<2>(const std::filesystem::path&, const dynamics::World<2>&, SurfaceCache<2>&,
                                          VtkEncoding, std::span<const double>);
extern template VtpPiece writeSurfaceFrame<3>(const std::filesystem::path&, const dynamics::World<3>&, SurfaceCache<3>&,
                                          VtkEncoding, std::span<const double>);
extern template void writeBoundaryFrame<2>(const std::filesystem::path&, const dynamics::World<2>&, SurfaceCache<2>&,
                                           const geometry::Box<2>&, VtkEncoding);
extern template void writeBoundaryFrame<3>(const std::filesystem::path&, const dynamics::World<3>&, SurfaceCache<3>&,
                                           const geometry::Box<3>&, VtkEncoding);
extern template VtpPiece writeContactFrame<2>(const std::filesystem::path&, const dynamics::World<2>&, VtkEncoding);
extern template VtpPiece writeContactFrame<3>(const std::filesystem::path&, const dynamics::World<3>&, VtkEncoding);
extern template std::array<VtpPiece, 3> writeFramePieces<2>(const FrameWriterDef<2>&, std::size_t, int,
                                                              const dynamics::World<2>&, SurfaceCache<2>&,
                                                              std::span<const double>,
                                                              std::span<const geometry::Mat<2>>);
extern template std::array<VtpPiece, 3> writeFramePieces<3>(const FrameWriterDef<3>&, std::size_t, int,
                                                              const dynamics::World<3>&, SurfaceCache<3>&,
                                                              std::span<const double>,
                                                              std::span<const geometry::Mat<3>>);
extern template class FrameWriter<2>;
extern template class FrameWriter<3>;

}  // namespace lsdem::io
