#include "lsdem/geometry/ImageToLevelSet.h"

#include "lsdem/geometry/DistanceTransform.h"
#include "lsdem/geometry/Reinitialize.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace lsdem::geometry {
namespace {

void checkOptions(const LabelGridOptions& o) {
  if (o.spacing != 0.0 && !(o.spacing > 0.0 && std::isfinite(o.spacing))) {
    throw std::invalid_argument("grid spacing must be positive, got " + std::to_string(o.spacing));
  }
  if (o.spacing == 0.0 && !(o.cellsAcross > 0.0 && std::isfinite(o.cellsAcross))) {
    throw std::invalid_argument("cells across must be positive, got " + std::to_string(o.cellsAcross));
  }
  if (o.paddingCells < 0) throw std::invalid_argument("padding cells must be >= 0");
}

/// The label's voxel bounding box in world units (outer faces of its voxels).
Box<3> labelBox(const LabelVolume& volume, const LabelStats& label) {
  const Vec<3> half = 0.5 * volume.spacing;
  return {volume.voxelCentre(label.lower) - half, volume.voxelCentre(label.upper) + half};
}

/// The new grid (values unset) and the voxel crop: the label's bounding box
/// grown on each side by two grid cells (at most the label's own extent) and
/// three voxels, so every grid node next to the zero level set and the
/// tricubic stencils about it fall inside. Nodes farther out, in the padding,
/// get the value at the nearest crop point plus the distance to it (positive,
/// as the crop's border voxels are outside the label); the reinitialisation
/// then makes them distances. So the crop, and the memory, grows with the
/// label, not with the padding. The crop may reach past the image: voxels
/// there are outside the label.
struct Layout {
  Grid<3> grid;
  Index<3> cropLower;
  Index<3> cropDims;
};

Layout layoutFor(const LabelVolume& volume, const LabelStats& label, const LabelGridOptions& options) {
  Layout l;
  const double h = labelGridSpacing(volume, label, options);
  l.grid = Grid<3>::covering(labelBox(volume, label), h, options.paddingCells);
  for (int a = 0; a < 3; ++a) {
    const int extent = label.upper[a] - label.lower[a] + 1;
    const double cells = std::min(std::ceil(2.0 * h / volume.spacing[a]), double(extent));
    const int margin = int(cells) + 3;
    l.cropLower[a] = label.lower[a] - margin;
    l.cropDims[a] = extent + 2 * margin;
  }
  return l;
}

}  // namespace

double labelGridSpacing(const LabelVolume& volume, const LabelStats& label, const LabelGridOptions& options) {
  checkOptions(options);
  if (options.spacing > 0.0) return options.spacing;
  return labelBox(volume, label).size().minCoeff() / options.cellsAcross;
}

std::size_t labelLevelSetBytes(const LabelVolume& volume, const LabelStats& label, const LabelGridOptions& options) {
  const Layout l = layoutFor(volume, label, options);
  // Crop: mask and its complement (1 + 1), two squared distances (8 + 8), the
  // signed distance (4); grid: values (4) and the reinitialisation's
  // working arrays (at most 40 per node).
  const double crop = double(l.cropDims[0]) * double(l.cropDims[1]) * double(l.cropDims[2]);
  const double nodes = double(l.grid.size());
  return std::size_t(22.0 * crop + 44.0 * nodes);
}

Grid<3> labelLevelSet(const LabelVolume& volume, const LabelStats& label, const LabelGridOptions& options) {
  if (label.voxels == 0) throw std::invalid_argument("label " + std::to_string(label.label) + " holds no voxel");
  if ((label.lower < 0).any() || (label.upper >= volume.dims).any() || (label.lower > label.upper).any() ||
      volume.labels.size() != volume.voxelCount()) {
    throw std::invalid_argument("label " + std::to_string(label.label) + ": bounding box outside the volume");
  }
  Layout l = layoutFor(volume, label, options);
  const Index<3>& n = l.cropDims;

  // The label's mask on the crop (voxels past the image are outside).
  const std::size_t cropCount = std::size_t(n[0]) * std::size_t(n[1]) * std::size_t(n[2]);
  std::vector<std::uint8_t> mask(cropCount, 0);
  for (int k = label.lower[2]; k <= label.upper[2]; ++k) {
    for (int j = label.lower[1]; j <= label.upper[1]; ++j) {
      for (int i = label.lower[0]; i <= label.upper[0]; ++i) {
        if (volume.labels[volume.linear(i, j, k)] != label.label) continue;
        const std::size_t c =
            std::size_t(i - l.cropLower[0]) +
            std::size_t(n[0]) * (std::size_t(j - l.cropLower[1]) + std::size_t(n[1]) * std::size_t(k - l.cropLower[2]));
        mask[c] = 1;
      }
    }
  }

  // Signed distance at the voxel centres (zero level on the voxel faces).
  const std::vector<float> voxelPhi = maskSignedDistance(mask, n, volume.spacing);
  mask = {};

  // Catmull-Rom (tricubic) resampling onto the new grid's nodes (stencil
  // indices past the crop take its border voxel; nodes outside it take the
  // value at the nearest crop point plus the distance to it). It reproduces
  // quadratics, so it does not pull a curved surface inwards by the
  // s^2 / (8 R) of trilinear resampling (measured: -0.8 % of a sphere's volume
  // at 20 voxels across with trilinear, see docs/tomography.md).
  Grid<3>& grid = l.grid;
  const Vec<3> cropOrigin = volume.voxelCentre(l.cropLower);
  const std::size_t stride[3] = {1, std::size_t(n[0]), std::size_t(n[0]) * std::size_t(n[1])};
  const long long nodes = (long long)grid.size();
#pragma omp parallel for schedule(static)
  for (long long node = 0; node < nodes; ++node) {
    const Index<3> idx = grid.unlinear(std::size_t(node));
    const Vec<3> u = (grid.nodePosition(idx) - cropOrigin).cwiseQuotient(volume.spacing);
    double w[3][4];
    std::size_t offset[3][4];
    double outside2 = 0.0;  // squared distance from the node to the crop, world units
    for (int a = 0; a < 3; ++a) {
      const double ua = std::clamp(u[a], 0.0, double(n[a] - 1));
      outside2 += (u[a] - ua) * (u[a] - ua) * volume.spacing[a] * volume.spacing[a];
      const int c = std::clamp(int(ua), 0, n[a] - 2);
      detail::catmullRomWeights(ua - c, w[a]);
      for (int k = 0; k < 4; ++k) offset[a][k] = stride[a] * std::size_t(std::clamp(c + k - 1, 0, n[a] - 1));
    }
    double value = 0.0;
    for (int k = 0; k < 4; ++k) {
      double plane = 0.0;
      for (int j = 0; j < 4; ++j) {
        const float* r = voxelPhi.data() + offset[2][k] + offset[1][j];
        plane += w[1][j] * (w[0][0] * r[offset[0][0]] + w[0][1] * r[offset[0][1]] + w[0][2] * r[offset[0][2]] +
                            w[0][3] * r[offset[0][3]]);
      }
      value += w[2][k] * plane;
    }
    grid[std::size_t(node)] = float(value + std::sqrt(outside2));
  }

  // A distance again, the zero level set kept in place.
  const bool anyInside = std::any_of(grid.values().begin(), grid.values().end(), [](float v) { return v < 0.0f; });
  if (!anyInside) {
    throw std::invalid_argument("no grid node falls inside label " + std::to_string(label.label) + " at spacing " +
                                std::to_string(grid.spacing()));
  }
  reinitialize(grid);
  return std::move(l.grid);
}

}  // namespace lsdem::geometry
