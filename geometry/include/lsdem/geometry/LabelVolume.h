#pragma once
/// @file LabelVolume.h
/// @brief A labelled 3D image (segmented X-ray CT): one unsigned label per
/// voxel, 0 the background by default, and the per-label statistics that
/// `lsdem ct2ls` sorts grains by (voxel count, bounding box, border contact).
///
/// Frames: voxel (i, j, k) is a box of `spacing` (world units, per axis:
/// anisotropic scans are allowed) centred at origin + spacing * (i, j, k), so
/// `origin` is the centre of the first voxel (the NRRD "space origin"
/// convention). Labels are stored as 32-bit whatever the file's width: 4
/// bytes per voxel, x fastest.

#include "lsdem/geometry/Types.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace lsdem::geometry {

struct LabelVolume {
  Index<3> dims = Index<3>::Zero();   ///< voxels per axis
  Vec<3> spacing = Vec<3>::Ones();    ///< voxel size per axis, world units
  Vec<3> origin = Vec<3>::Zero();     ///< centre of voxel (0, 0, 0), world units
  std::vector<std::uint32_t> labels;  ///< dims.prod() labels, x fastest

  std::size_t voxelCount() const { return std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]); }
  std::size_t linear(int i, int j, int k) const {
    return std::size_t(i) + std::size_t(dims[0]) * (std::size_t(j) + std::size_t(dims[1]) * std::size_t(k));
  }
  /// @brief World position of the centre of voxel (i, j, k).
  Vec<3> voxelCentre(const Index<3>& v) const { return origin + spacing.cwiseProduct(v.cast<double>().matrix()); }
};

/// What one label covers.
struct LabelStats {
  std::uint32_t label = 0;
  std::size_t voxels = 0;                 ///< voxels holding the label
  Index<3> lower = Index<3>::Zero();      ///< first voxel of the bounding box, per axis
  Index<3> upper = Index<3>::Zero();      ///< last voxel of the bounding box (inclusive)
  Vec<3> voxelCentroid = Vec<3>::Zero();  ///< mean voxel centre, world units
  bool touchesBorder = false;             ///< a voxel on a face of the image (the grain may be cut off)
};

/// @brief The statistics of every label other than `background`, sorted by label.
/// One pass over the image.
std::vector<LabelStats> labelStatistics(const LabelVolume& volume, std::uint32_t background = 0);

}  // namespace lsdem::geometry
