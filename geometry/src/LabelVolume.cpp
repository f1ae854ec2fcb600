#include "lsdem/geometry/LabelVolume.h"

#include <algorithm>
#include <map>

namespace lsdem::geometry {

std::vector<LabelStats> labelStatistics(const LabelVolume& volume, std::uint32_t background) {
  // One pass: count, bounding box and sum of voxel indices per label. The
  // last label seen is cached, since neighbouring voxels mostly share one.
  struct Accumulator {
    LabelStats stats;
    Eigen::Vector3d indexSum = Eigen::Vector3d::Zero();
  };
  std::map<std::uint32_t, Accumulator> found;
  const Index<3>& n = volume.dims;
  Accumulator* last = nullptr;
  std::uint32_t lastLabel = background;
  std::size_t v = 0;
  for (int k = 0; k < n[2]; ++k) {
    for (int j = 0; j < n[1]; ++j) {
      const bool edgeRow = k == 0 || k == n[2] - 1 || j == 0 || j == n[1] - 1;
      for (int i = 0; i < n[0]; ++i, ++v) {
        const std::uint32_t l = volume.labels[v];
        if (l == background) continue;
        if (last == nullptr || l != lastLabel) {
          auto [it, isNew] = found.try_emplace(l);
          if (isNew) {
            it->second.stats.label = l;
            it->second.stats.lower = Index<3>(i, j, k);
            it->second.stats.upper = Index<3>(i, j, k);
          }
          last = &it->second;
          lastLabel = l;
        }
        LabelStats& s = last->stats;
        ++s.voxels;
        const Index<3> idx(i, j, k);
        s.lower = s.lower.min(idx);
        s.upper = s.upper.max(idx);
        last->indexSum += Eigen::Vector3d(i, j, k);
        if (edgeRow || i == 0 || i == n[0] - 1) s.touchesBorder = true;
      }
    }
  }
  std::vector<LabelStats> out;
  out.reserve(found.size());
  for (auto& [label, acc] : found) {
    const Vec<3> meanIndex = acc.indexSum / double(acc.stats.voxels);
    acc.stats.voxelCentroid = volume.origin + volume.spacing.cwiseProduct(meanIndex);
    out.push_back(acc.stats);
  }
  return out;
}

}  // namespace lsdem::geometry
