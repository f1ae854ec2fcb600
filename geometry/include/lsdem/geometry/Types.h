#pragma once
/// @file Types.h
/// @brief Small fixed-size Eigen types shared by every layer, templated on the
/// dimension D (2 or 3).

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>

namespace lsdem::geometry {

/// A point or vector in D dimensions (world or body units: metres unless a name says cells).
template <int D>
using Vec = Eigen::Matrix<double, D, 1>;

/// A D x D matrix (inertia tensors, rotations).
template <int D>
using Mat = Eigen::Matrix<double, D, D>;

/// A grid node index (i, j[, k]), in cells, x fastest in memory.
template <int D>
using Index = Eigen::Array<int, D, 1>;

/// An axis-aligned box [lower, upper] in world units.
template <int D>
struct Box {
  Vec<D> lower = Vec<D>::Zero();
  Vec<D> upper = Vec<D>::Zero();

  /// @brief Box extents (upper - lower), world units.
  Vec<D> size() const { return upper - lower; }
  /// @brief True when x lies in the closed box.
  bool contains(const Vec<D>& x) const {
    return (x.array() >= lower.array()).all() && (x.array() <= upper.array()).all();
  }
};

/// A rigid transform x' = rotation * x + translation in D dimensions.
template <int D>
struct Rigid {
  Mat<D> rotation = Mat<D>::Identity();
  Vec<D> translation = Vec<D>::Zero();

  Vec<D> apply(const Vec<D>& x) const { return rotation * x + translation; }
  /// @brief The inverse map, x = rotation^T (x' - translation).
  Vec<D> applyInverse(const Vec<D>& x) const { return rotation.transpose() * (x - translation); }
  Rigid inverse() const { return {rotation.transpose(), -(rotation.transpose() * translation)}; }
  /// @brief Composition: (this * other)(x) = this(other(x)).
  Rigid operator*(const Rigid& other) const {
    return {rotation * other.rotation, rotation * other.translation + translation};
  }
};

}  // namespace lsdem::geometry
