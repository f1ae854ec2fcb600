#pragma once
/// @file ImageToLevelSet.h
/// @brief Scanned grain -> level set (eq. 1): the signed distance grid of one
/// label of a labelled 3D image (X-ray CT), LS-DEM's founding use.
///
/// Steps, per label: crop the image around the label (its bounding box grown
/// by two grid cells, at most its own extent, and three voxels); take the
/// label's binary mask's signed distance at the voxel centres by the exact
/// Euclidean distance transform and its feature transform
/// (DistanceTransform.h: the distance to the box of the nearest voxel of the
/// other phase, so the zero level lies on the faces between inside and
/// outside voxels); resample it with the Catmull-Rom tricubic interpolant onto
/// a cubic grid of the chosen spacing covering the label with
/// kDefaultPaddingCells of padding (nodes past the crop take the value at the
/// nearest crop point plus the distance to it); and reinitialise that grid
/// (Reinitialize.h, fast sweeping) so it is a signed distance again with its
/// zero level set unmoved. The grid is in the image's world frame, so the
/// shape's centroid is where the grain was scanned. Measured: the level set's
/// volume is the voxel count's to 0.1 % for spheres 10-40 voxels across
/// (docs/tomography.md).

#include "lsdem/geometry/Grid.h"
#include "lsdem/geometry/LabelVolume.h"

#include <cstddef>

namespace lsdem::geometry {

/// How a label's grid is sized.
struct LabelGridOptions {
  /// Grid cells across the smallest extent of the label's voxel bounding box
  /// (as a shape's `cells_across`), > 0; used when `spacing` is 0.
  double cellsAcross = 20.0;
  /// Grid spacing, world units; > 0 overrides cellsAcross.
  double spacing = 0.0;
  /// Cells of padding around the label on every side (>= 0).
  int paddingCells = kDefaultPaddingCells;
};

/// @brief The grid spacing a label gets (world units).
double labelGridSpacing(const LabelVolume& volume, const LabelStats& label, const LabelGridOptions& options);

/// @brief An upper estimate of the bytes labelLevelSet allocates for this
/// label (distance transforms of the crop and the new grid with its
/// reinitialisation), to check against a memory cap before allocating.
std::size_t labelLevelSetBytes(const LabelVolume& volume, const LabelStats& label, const LabelGridOptions& options);

/// @brief The signed distance grid of one label (see the file comment):
/// world units, phi < 0 inside, grid frame = the image's world frame.
/// @param volume the labelled image.
/// @param label its statistics (labelStatistics): bounding box and count.
/// @param options grid size.
/// @note Throws std::invalid_argument when the options are out of range, the
/// label holds no voxel, its bounding box is not inside the volume, or no
/// node of the new grid falls inside the label (a spacing far coarser than
/// the grain).
Grid<3> labelLevelSet(const LabelVolume& volume, const LabelStats& label, const LabelGridOptions& options);

}  // namespace lsdem::geometry
