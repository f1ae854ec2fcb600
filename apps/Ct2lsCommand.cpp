/// @file Ct2lsCommand.cpp
/// @brief `lsdem ct2ls IMAGE -o DIR [--cells-across N | --grid-spacing H]
/// [--spacing S[,S,S]] [--origin X,Y,Z] [--scale F] [--min-voxels N]
/// [--keep-border] [--background L] [--max-memory MB] [--nodes-per-cell N]
/// [--binary] [--raw-dims NX,NY,NZ --raw-type T [--raw-endian E]
/// [--raw-header-bytes B]]`: a labelled 3D image (segmented X-ray CT: NRRD,
/// TIFF, raw) to one level-set grain file per label (docs/tomography.md),
/// with a list of where each grain was scanned (grains.csv) and a scene
/// fragment that places them there (particles.toml).

#include "Commands.h"

#include "lsdem/geometry/Components.h"
#include "lsdem/geometry/ImageToLevelSet.h"
#include "lsdem/geometry/LabelVolume.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/ShapeDef.h"
#include "lsdem/io/GrainFile.h"
#include "lsdem/io/InputError.h"
#include "lsdem/io/ShapeFile.h"
#include "lsdem/io/VolumeFile.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace lsdem::apps {
namespace {

namespace fs = std::filesystem;
using geometry::Vec;

struct Ct2lsOptions {
  std::string image;
  std::string outDir;
  double cellsAcross = 20.0;
  double gridSpacing = 0.0;
  std::vector<double> spacing;
  std::vector<double> origin;
  double scale = 1.0;
  bool scaleGiven = false;  // --scale on the command line (else from the file's units)
  bool gridSpacingGiven = false;
  long long minVoxels = 100;
  bool keepBorder = false;
  long long background = 0;
  double maxMemoryMb = 4096.0;
  double nodesPerCell = 2.0;
  bool binary = false;
  std::vector<int> rawDims;
  std::string rawType;
  std::string rawEndian = "little";
  bool rawEndianGiven = false;
  long long rawHeaderBytes = 0;
};

using geometry::kMaxCellsAcross;
using geometry::kMinCellsAcross;
// A grain's volume off its voxels' by more than this fraction is noted.
constexpr double kVolumeNoteFraction = 0.02;

// A number with `digits` significant digits ("0.05", "1.5e+05").
std::string shortText(double v, int digits = 6) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*g", digits, v);
  return buf;
}

std::string fixed(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

// The read options from the command line: the raw layout when --raw-dims is given.
io::VolumeReadOptions readOptions(const Ct2lsOptions& o) {
  io::VolumeReadOptions r;
  r.maxBytes = std::size_t(o.maxMemoryMb * 1048576.0);
  if (o.rawDims.empty()) {
    if (!o.rawType.empty()) throw io::InputError("--raw-type", 0, "", "needs --raw-dims");
    if (o.rawEndianGiven) throw io::InputError("--raw-endian", 0, "", "needs --raw-dims");
    if (o.rawHeaderBytes != 0) throw io::InputError("--raw-header-bytes", 0, "", "needs --raw-dims");
    return r;
  }
  if (o.rawType.empty()) throw io::InputError("--raw-dims", 0, "", "needs --raw-type");
  if (o.rawDims.size() != 3) throw io::InputError("--raw-dims", 0, "", "needs three sizes NX,NY,NZ");
  io::RawLayout layout;
  for (int a = 0; a < 3; ++a) {
    if (o.rawDims[std::size_t(a)] < 1) throw io::InputError("--raw-dims", 0, "", "sizes must be >= 1");
    layout.dims[a] = o.rawDims[std::size_t(a)];
  }
  const auto type = io::voxelTypeNamed(o.rawType);
  if (!type) {
    throw io::InputError("--raw-type", 0, "",
                         "must be uint8, uint16, uint32, int8, int16 or int32, got '" + o.rawType + "'");
  }
  layout.type = *type;
  if (o.rawEndian != "little" && o.rawEndian != "big") {
    throw io::InputError("--raw-endian", 0, "", "must be little or big, got '" + o.rawEndian + "'");
  }
  layout.bigEndian = o.rawEndian == "big";
  if (o.rawHeaderBytes < 0) throw io::InputError("--raw-header-bytes", 0, "", "must be >= 0");
  layout.headerBytes = std::size_t(o.rawHeaderBytes);
  r.raw = layout;
  return r;
}

// Metres per unit of the lengths a file names ("mm", ...); nullopt for others.
std::optional<double> metresPer(const std::string& unit) {
  if (unit == "m") return 1.0;
  if (unit == "cm") return 1e-2;
  if (unit == "mm") return 1e-3;
  if (unit == "um" || unit == "\u00b5m" || unit == "micron" || unit == "microns") return 1e-6;
  if (unit == "nm") return 1e-9;
  return std::nullopt;
}

// Rotation angles [rx, ry, rz] in degrees with R = Rz Ry Rx (a scene's `rotations_deg`).
Vec<3> rotationDegrees(const geometry::Mat<3>& r) {
  const Vec<3> zyx = r.eulerAngles(2, 1, 0);
  return Vec<3>(zyx[2], zyx[1], zyx[0]) * (180.0 / M_PI);
}

void run(const Ct2lsOptions& o) {
  // Options first, before reading anything.
  if (o.gridSpacingGiven) {
    requirePositive("--grid-spacing", o.gridSpacing);
  } else if (!(o.cellsAcross >= kMinCellsAcross && o.cellsAcross <= kMaxCellsAcross)) {
    // (As a shape's `cells_across`: fewer cells make no grain, 1 cell gave
    // 5x the scanned volume; more, grids no machine holds.)
    throw io::InputError("--cells-across", 0, "", "must be in [2, 10000], got " + shortText(o.cellsAcross));
  }
  if (o.scaleGiven) requirePositive("--scale", o.scale);
  requirePositive("--max-memory", o.maxMemoryMb);
  requirePositive("--nodes-per-cell", o.nodesPerCell);
  if (o.minVoxels < 1) throw io::InputError("--min-voxels", 0, "", "must be >= 1");
  if (o.background < 0 || o.background > 0xFFFFFFFFLL)
    throw io::InputError("--background", 0, "", "must be a label >= 0");
  if (!o.spacing.empty() && o.spacing.size() != 1 && o.spacing.size() != 3) {
    throw io::InputError("--spacing", 0, "", "needs one spacing or three (SX,SY,SZ)");
  }
  for (const double s : o.spacing) requirePositive("--spacing", s);
  if (!o.origin.empty() && o.origin.size() != 3) throw io::InputError("--origin", 0, "", "needs three numbers X,Y,Z");
  const io::VolumeReadOptions readOpts = readOptions(o);

  // The image, its geometry (file, then options, then --scale to metres).
  const auto t0 = std::chrono::steady_clock::now();
  io::VolumeRead read = io::readLabelVolume(o.image, readOpts);
  geometry::LabelVolume& volume = read.volume;
  if (!o.spacing.empty()) {
    volume.spacing =
        o.spacing.size() == 1 ? Vec<3>::Constant(o.spacing[0]) : Vec<3>(o.spacing[0], o.spacing[1], o.spacing[2]);
  } else if (!read.hasSpacing) {
    throw io::InputError(o.image, 0, "", "the " + read.format + " file gives no voxel spacing; give --spacing");
  }
  if (!o.origin.empty()) volume.origin = Vec<3>(o.origin[0], o.origin[1], o.origin[2]);
  // To metres: --scale, else the unit the file names, else metres.
  double scale = o.scale;
  if (!o.scaleGiven && !read.units.empty()) {
    const auto factor = metresPer(read.units);
    if (!factor) {
      throw io::InputError(o.image, 0, "space units",
                           "unknown unit '" + read.units + "'; give --scale (the factor to metres)");
    }
    scale = *factor;
  }
  volume.spacing *= scale;
  volume.origin *= scale;
  // Lengths are metres: as a mesh's coordinates, within 1e10 m of the origin
  // (a NaN or 1e300 origin failed later as "grid spacing must be positive").
  if (!volume.origin.allFinite() || volume.origin.cwiseAbs().maxCoeff() > 1e10) {
    throw io::InputError(o.origin.empty() ? o.image : "--origin", 0, o.origin.empty() ? "space origin" : "",
                         "the first voxel lies at (" + shortText(volume.origin[0]) + ", " + shortText(volume.origin[1]) +
                             ", " + shortText(volume.origin[2]) +
                             ") m: lsdem takes coordinates within 1e10 m of the origin (lengths are in metres)");
  }
  const double readSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // The labels, and which of them become grains.
  const std::vector<geometry::LabelStats> labels = geometry::labelStatistics(volume, std::uint32_t(o.background));
  if (labels.empty()) {
    throw io::InputError(o.image, 0, "", "holds no label other than the background " + std::to_string(o.background));
  }
  const std::string unitNote =
      !o.scaleGiven && !read.units.empty() ? ", lengths in " + read.units + " -> scale " + fixed(scale) : "";
  std::printf("ct2ls %s (%s, %d x %d x %d voxels of %s x %s x %s m%s, read in %.2f s): %zu labels\n", o.image.c_str(),
              read.format.c_str(), volume.dims[0], volume.dims[1], volume.dims[2], fixed(volume.spacing[0]).c_str(),
              fixed(volume.spacing[1]).c_str(), fixed(volume.spacing[2]).c_str(), unitNote.c_str(), readSeconds,
              labels.size());
  std::fflush(stdout);  // before any error line on stderr
  // Which labels become grains (the others are skipped below, with a line),
  // and each one's smallest extent (m), across which --cells-across counts.
  const auto kept = [&](const geometry::LabelStats& s) {
    return !(s.touchesBorder && !o.keepBorder) && (long long)s.voxels >= o.minVoxels;
  };
  const auto smallestExtent = [&](const geometry::LabelStats& s) {
    geometry::LabelGridOptions extent;
    extent.cellsAcross = 1.0;
    return geometry::labelGridSpacing(volume, s, extent);
  };
  // --grid-spacing: every grain kept gets 2 to 10000 cells, as --cells-across
  // gives them (checked before anything is written).
  for (const geometry::LabelStats& s : labels) {
    if (!o.gridSpacingGiven || !kept(s)) continue;
    const double across = smallestExtent(s), cells = across / o.gridSpacing;
    if (!(cells >= kMinCellsAcross && cells <= kMaxCellsAcross)) {
      throw io::InputError("--grid-spacing", 0, "",
                           shortText(o.gridSpacing) + " m gives label " + std::to_string(s.label) + " " +
                               shortText(cells, 3) + " cells across its smallest extent (" + fixed(across) +
                               " m); a grain needs 2 to 10000" +
                               (cells < kMinCellsAcross ? " (lower it, or raise --min-voxels to skip small labels)"
                                                        : " (raise it)"));
    }
  }
  std::error_code ec;
  fs::create_directories(o.outDir, ec);
  if (!fs::is_directory(o.outDir)) throw io::InputError(o.outDir, 0, "", "cannot create the output folder");

  geometry::LabelGridOptions gridOptions;
  gridOptions.cellsAcross = o.cellsAcross;
  gridOptions.spacing = o.gridSpacing;
  geometry::ShapeOptions shapeOptions;
  shapeOptions.nodesPerCell = o.nodesPerCell;
  const std::size_t digits = std::to_string(labels.back().label).size();

  struct Written {
    std::uint32_t label;
    std::size_t voxels;
    double volume, voxelVolume;
    Vec<3> centroid, rotation;
    std::size_t nodes;
    std::string file;
  };
  std::vector<Written> written;
  int skippedBorder = 0, skippedSmall = 0, skippedPieces = 0, noted = 0;
  const double voxelVolume = volume.spacing.prod();
  double labelSeconds = 0.0;
  for (const geometry::LabelStats& s : labels) {
    // Skipped labels: one line each.
    if (s.touchesBorder && !o.keepBorder) {  // (kept(s) is false for these and the next)
      std::printf("  label %u: skipped: touches the image border (the grain may be cut off; --keep-border keeps it)\n",
                  s.label);
      ++skippedBorder;
      std::fflush(stdout);
      continue;
    }
    if ((long long)s.voxels < o.minVoxels) {
      std::printf("  label %u: skipped: %zu voxels, below --min-voxels %lld\n", s.label, s.voxels, o.minVoxels);
      ++skippedSmall;
      std::fflush(stdout);
      continue;
    }
    const std::string key = "label " + std::to_string(s.label);
    // Memory: estimated before anything of the label is allocated.
    const char* resolution = o.gridSpacingGiven ? "--grid-spacing" : "--cells-across";
    std::size_t need = 0;
    try {
      need = geometry::labelLevelSetBytes(volume, s, gridOptions);
    } catch (const std::invalid_argument& e) {
      // (A grid past what an index holds: 2^31 values.)
      throw io::InputError(resolution, 0, "",
                           key + ": " + e.what() + (o.gridSpacingGiven ? " (raise it)" : " (lower it)"));
    }
    if (double(need) > o.maxMemoryMb * 1048576.0) {
      char text[256];
      std::snprintf(text, sizeof text,
                    "needs about %.3g MB for its distance transform and grid, over --max-memory %g MB (raise it, or "
                    "%s %s)",
                    double(need) / 1048576.0, o.maxMemoryMb, o.gridSpacingGiven ? "raise" : "lower", resolution);
      throw io::InputError(o.image, 0, key, text);
    }
    // Level set (one body: a label in pieces is skipped), shape and grain file.
    const auto start = std::chrono::steady_clock::now();
    std::shared_ptr<const geometry::Shape<3>> shape;
    try {
      geometry::Grid<3> grid = geometry::labelLevelSet(volume, s, gridOptions);
      std::vector<int> components;
      if (const int bodies = geometry::labelComponents<3>(grid, components); bodies > 1) {
        std::printf("  label %u: skipped: %d separate bodies (a grain is one; split the label in the segmentation)\n",
                    s.label, bodies);
        ++skippedPieces;
        std::fflush(stdout);
        continue;
      }
      shape = geometry::Shape<3>::fromGrid(std::move(grid), shapeOptions);
    } catch (const std::invalid_argument& e) {
      throw io::InputError(o.image, 0, key, std::string("no grain: ") + e.what());
    }
    std::string number = std::to_string(s.label);
    number.insert(0, digits - number.size(), '0');
    const std::string name = "grain_" + number + ".lsg";
    io::writeGrainFile<3>((fs::path(o.outDir) / name).string(), *shape,
                          o.binary ? io::GrainFormat::Binary : io::GrainFormat::Text);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    labelSeconds += seconds;
    const Written w{s.label,
                    s.voxels,
                    shape->volume(),
                    double(s.voxels) * voxelVolume,
                    shape->bodyToGrid().translation,
                    rotationDegrees(shape->bodyToGrid().rotation),
                    shape->nodes().size(),
                    name};
    written.push_back(w);
    std::printf(
        "  label %u -> %s: %zu voxels, volume %.6g m^3 (voxels %.6g), centroid (%.6g, %.6g, %.6g) m, %zu nodes, "
        "grid %d x %d x %d, %.2f s\n",
        s.label, name.c_str(), s.voxels, w.volume, w.voxelVolume, w.centroid[0], w.centroid[1], w.centroid[2], w.nodes,
        shape->grid().dims()[0], shape->grid().dims()[1], shape->grid().dims()[2], seconds);
    // A grain whose level set holds another volume than its voxels is
    // under-resolved (at 2 cells across a ball came out 1.7x its voxels) or
    // thinner than a few voxels somewhere (docs/tomography.md).
    if (const double excess = w.volume / w.voxelVolume - 1.0; std::abs(excess) > kVolumeNoteFraction) {
      std::printf("  note: label %u: its grain's volume is %.1f%% %s its voxels' (%s cells across its smallest "
                  "extent): %s\n",
                  s.label, 100.0 * std::abs(excess), excess > 0.0 ? "above" : "below",
                  shortText(smallestExtent(s) / shape->grid().spacing(), 3).c_str(),
                  "too few cells (raise --cells-across or lower --grid-spacing), or a grain a voxel or two thin");
      ++noted;
    }
    if (w.nodes < io::kFewSurfaceNodes<3>) {
      std::printf("  note: label %u: its grain has only %zu surface nodes: contacts are found at these points only "
                  "(--nodes-per-cell)\n",
                  s.label, w.nodes);
      ++noted;
    }
    std::fflush(stdout);
  }
  if (written.empty()) {
    throw io::InputError(o.image, 0, "",
                         "no grain written: all " + std::to_string(labels.size()) + " labels skipped (" +
                             std::to_string(skippedBorder) + " on the border, " + std::to_string(skippedSmall) +
                             " below --min-voxels, " + std::to_string(skippedPieces) + " in pieces)");
  }

  // Where each grain was scanned: a table and a scene fragment placing them there.
  std::ostringstream csv, toml;
  csv << "label,voxels,volume_m3,voxel_volume_m3,centroid_x_m,centroid_y_m,centroid_z_m,rx_deg,ry_deg,rz_deg,nodes,"
         "file\n";
  toml << "# Grains of " << o.image << " where they were scanned (lsdem ct2ls). Paths are relative to\n"
       << "# this folder: copy these tables into a scene placed beside it (or fix the paths),\n"
       << "# and give the particles a material or density.\n";
  std::ostringstream shapes, positions, rotations;
  for (std::size_t i = 0; i < written.size(); ++i) {
    const Written& w = written[i];
    csv << w.label << ',' << w.voxels << ',' << fixed(w.volume) << ',' << fixed(w.voxelVolume) << ','
        << fixed(w.centroid[0]) << ',' << fixed(w.centroid[1]) << ',' << fixed(w.centroid[2]) << ','
        << fixed(w.rotation[0]) << ',' << fixed(w.rotation[1]) << ',' << fixed(w.rotation[2]) << ',' << w.nodes << ','
        << w.file << '\n';
    toml << "\n[shapes.label_" << w.label << "]\nkind = \"grain_file\"\npath = \"" << w.file << "\"\n";
    const char* sep = i == 0 ? "" : ", ";
    shapes << sep << "\"label_" << w.label << '"';
    positions << sep << '[' << fixed(w.centroid[0]) << ", " << fixed(w.centroid[1]) << ", " << fixed(w.centroid[2])
              << ']';
    rotations << sep << '[' << fixed(w.rotation[0]) << ", " << fixed(w.rotation[1]) << ", " << fixed(w.rotation[2])
              << ']';
  }
  toml << "\n[[particles]]\nshapes = [" << shapes.str() << "]\nplacement = \"list\"\npositions = [" << positions.str()
       << "]\nrotations_deg = [" << rotations.str() << "]\n";
  for (const auto& [file, text] : {std::pair{"grains.csv", csv.str()}, std::pair{"particles.toml", toml.str()}}) {
    std::ofstream f(fs::path(o.outDir) / file);
    f << text;
    if (!f) throw io::InputError((fs::path(o.outDir) / file).string(), 0, "", "cannot write");
  }
  std::printf(
      "ct2ls: %zu grains written to %s (%.2f s), %d skipped on the border, %d below --min-voxels, %d in pieces; "
      "grains.csv and particles.toml list where they were scanned\n",
      written.size(), o.outDir.c_str(), labelSeconds, skippedBorder, skippedSmall, skippedPieces);
  if (noted > 0) {
    std::printf("ct2ls: %d notes above (a volume more than %g%% off the voxels', or few surface nodes)\n", noted,
                100.0 * kVolumeNoteFraction);
  }
}

}  // namespace

void addCt2lsCommand(CLI::App& app) {
  auto opts = std::make_shared<Ct2lsOptions>();
  CLI::App* cmd =
      app.add_subcommand("ct2ls", "Convert a labelled 3D image (segmented CT: NRRD, TIFF, raw) to grain files");
  cmd->add_option("image", opts->image,
                  "labelled volume: .nrrd/.nhdr, multi-page .tif/.tiff, a folder or pattern ('slices/z*.tif') of 2D "
                  "TIFF slices, or raw with --raw-dims")
      ->required();
  cmd->add_option("-o,--out", opts->outDir, "folder for the grain files, grains.csv and particles.toml")->required();
  CLI::Option* cellsAcross = cmd->add_option("--cells-across", opts->cellsAcross,
                                             "grid cells across the smallest extent of each grain's voxel box (default 20)");
  CLI::Option* gridSpacing = cmd->add_option("--grid-spacing", opts->gridSpacing,
                                             "grid spacing in metres for every grain (instead of --cells-across; it "
                                             "must give each grain 2 to 10000 cells across)")
                                  ->excludes(cellsAcross);
  cmd->add_option("--spacing", opts->spacing, "voxel size SX[,SY,SZ] in image units (overrides the file's)")
      ->delimiter(',');
  cmd->add_option("--origin", opts->origin, "centre of the first voxel X,Y,Z in image units (overrides the file's)")
      ->delimiter(',');
  CLI::Option* scale = cmd->add_option(
      "--scale", opts->scale,
      "factor from image units to metres (default: from the NRRD 'space units' if given, else 1; 0.001 for mm)");
  cmd->add_option("--min-voxels", opts->minVoxels, "skip labels with fewer voxels (default 100)");
  cmd->add_flag("--keep-border", opts->keepBorder, "keep labels that touch the image border (skipped by default)");
  cmd->add_option("--background", opts->background, "the label of the space between grains (default 0)");
  cmd->add_option("--max-memory", opts->maxMemoryMb,
                  "refuse an image or a label needing more than this many MB (default 4096)");
  cmd->add_option("--nodes-per-cell", opts->nodesPerCell, "surface nodes per grid-cell length (default 2)");
  cmd->add_flag("--binary", opts->binary, "write the binary grain form instead of text");
  cmd->add_option("--raw-dims", opts->rawDims, "headerless raw file of NX,NY,NZ voxels (x fastest)")->delimiter(',');
  cmd->add_option("--raw-type", opts->rawType, "raw voxel type: uint8, uint16, uint32, int8, int16, int32");
  CLI::Option* endian = cmd->add_option("--raw-endian", opts->rawEndian, "raw byte order: little (default) or big");
  cmd->add_option("--raw-header-bytes", opts->rawHeaderBytes, "bytes before the raw voxels (default 0)");
  cmd->callback([opts, scale, endian, gridSpacing] {
    opts->scaleGiven = scale->count() > 0;
    opts->gridSpacingGiven = gridSpacing->count() > 0;
    opts->rawEndianGiven = endian->count() > 0;
    run(*opts);
  });
}

}  // namespace lsdem::apps
