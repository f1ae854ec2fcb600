#pragma once
/// @file Shape.h
/// @brief An immutable particle shape: level-set grid, surface nodes, mass
/// properties per unit density and descriptors, shared by every particle of
/// that shape (`std::shared_ptr<const Shape<D>>`). Breakage makes new shapes
/// and never edits one.
///
/// Frames. The *body frame* has its origin at the centroid and its axes along
/// the principal axes (x = longest, by descending second moment), so the inertia
/// is diagonal there. The *grid frame* is the frame the level set was built in.
/// Rather than resampling the grid into the body frame (which would blur it by
/// one interpolation), the shape keeps the grid as built plus the fixed rigid
/// map `bodyToGrid`. A contact look-up composes that map with the particle's
/// pose once per pair, so it costs nothing per node.

#include "lsdem/geometry/Descriptors.h"
#include "lsdem/geometry/Grid.h"
#include "lsdem/geometry/MassProperties.h"
#include "lsdem/geometry/NodeSet.h"
#include "lsdem/geometry/NodeTree.h"
#include "lsdem/geometry/Types.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace lsdem::geometry {

/// How a shape is made from its grid.
struct ShapeOptions {
  /// Surface nodes per grid-cell length (the paper's "pts/pix"), > 0.
  double nodesPerCell = 2.0;
  /// Mass-property estimator (eq. 24-30 or its eps-extrapolated form).
  MassMethod massMethod = MassMethod::Extrapolated;
  /// Grid spacing the contact law's reference node weight is taken from
  /// (ContactLaw.h, AreaWeighted), world units, >= 0; 0 takes the shape's own
  /// grid spacing. A fragment re-gridded finer than its parent keeps the
  /// parent's, so its contact stiffness per unit area does not change.
  double contactSpacing = 0.0;
  /// Factor on the per-node contact stiffness (ContactLaw.h, PerNode law;
  /// the area-weighted and Hertz laws ignore it), > 0. 1 for a grain made
  /// from a mesh or a grid. A fragment re-gridded with nodes closer together
  /// than its parent's gets parent's factor x (its mean node weight / the
  /// parent's), so its stiffness per unit surface stays its parent's: without
  /// it, a fragment with twice the nodes per area would be twice as stiff and
  /// its splits would make energy (docs/breakage.md, "Energy check").
  double nodeStiffnessScale = 1.0;
};

template <int D>
class Shape {
 public:
  /// @brief Makes a shape from a signed-distance grid in any frame: mass
  /// properties, principal frame, surface nodes at `options.nodesPerCell`,
  /// descriptors.
  /// @note Throws std::invalid_argument when the grid has no interior or the
  /// options are out of range.
  static std::shared_ptr<const Shape> fromGrid(Grid<D> grid, const ShapeOptions& options = {});

  /// @brief Makes a shape from a grid and surface nodes given in the grid's
  /// frame (breakage: a fragment keeps its parent's nodes on its side and gets
  /// new ones on the fracture surface). Mass properties, principal frame and
  /// descriptors are computed as in fromGrid; `options.nodesPerCell` is only
  /// recorded.
  /// @note Throws std::invalid_argument when the grid has no interior, the node
  /// set is empty, or positions and weights differ in count.
  static std::shared_ptr<const Shape> fromGridAndNodes(Grid<D> grid, NodeSet<D> nodesInGridFrame,
                                                      const ShapeOptions& options = {});

  /// @brief Makes a shape from a grid, surface nodes and mass properties per
  /// unit density, all in the grid's frame (breakage: a fragment's mass is its
  /// share of the parent's, not its own grid's estimate). The principal frame
  /// and descriptors come from `massGrid`; `options.nodesPerCell` is only recorded.
  /// @note Throws std::invalid_argument as fromGridAndNodes does, and when
  /// massGrid's volume is not positive or its moments are not finite.
  static std::shared_ptr<const Shape> fromGridNodesAndMass(Grid<D> grid, NodeSet<D> nodesInGridFrame,
                                                          const MassProperties<D>& massGrid,
                                                          const ShapeOptions& options = {});

  /// The stored parts of a shape, exactly as a shape holds them (grain files
  /// and checkpoints write these and read them back bit for bit).
  struct Parts {
    Grid<D> grid;                 ///< level set, grid frame
    Rigid<D> bodyToGrid;          ///< body frame -> grid frame
    NodeSet<D> nodes;             ///< surface nodes, body frame
    MassProperties<D> mass;       ///< per unit density, body frame (centroid 0, diagonal second moment)
    Descriptors<D> descriptors;   ///< frame-independent descriptors
    double boundingRadius = 0.0;  ///< world units
    ShapeOptions options;         ///< how the shape was made
  };

  /// @brief Restores a shape from its stored parts without recomputing
  /// anything (so a restored shape equals the written one bit for bit).
  /// @note Throws std::invalid_argument when the parts are inconsistent: an
  /// empty grid or node set, positions and weights of different counts, a
  /// volume or bounding radius not > 0, or a value that is not finite.
  static std::shared_ptr<const Shape> fromParts(Parts parts);
  /// @brief The stored parts (a copy), the inverse of fromParts.
  Parts parts() const;

  /// The level set, in the grid frame (world units).
  const Grid<D>& grid() const { return grid_; }
  /// Map from body-frame points to grid-frame points: x_grid = bodyToGrid().apply(x_body).
  const Rigid<D>& bodyToGrid() const { return bodyToGrid_; }
  /// Surface nodes in the body frame with their length/area weights.
  const NodeSet<D>& nodes() const { return nodes_; }
  /// Mass properties per unit density in the body frame: centroid 0, diagonal second moment.
  const MassProperties<D>& mass() const { return mass_; }
  /// Shape descriptors (frame-independent).
  const Descriptors<D>& descriptors() const { return descriptors_; }
  /// Volume (area in 2D) in world units^D: the mass per unit density.
  double volume() const { return mass_.volume; }
  /// Radius of a body-frame sphere about the centroid holding every node and
  /// every interior grid node (world units): the broad phase's bounding sphere.
  double boundingRadius() const { return boundingRadius_; }
  /// Spacing of the contact law's reference node weight (ShapeOptions::contactSpacing), world units.
  double contactSpacing() const { return options_.contactSpacing > 0.0 ? options_.contactSpacing : grid_.spacing(); }
  /// Factor on the per-node contact stiffness (ShapeOptions::nodeStiffnessScale).
  double nodeStiffnessScale() const { return options_.nodeStiffnessScale; }
  /// Mean node weight: surface length (2D) or area (3D) per node, world units^(D-1).
  double meanNodeWeight() const { return nodes_.meanWeight(); }
  /// Bounding-sphere tree over the surface nodes (NodeTree.h), body frame:
  /// the narrow phase's bulk rejection.
  const NodeTree<D>& nodeTree() const { return nodeTree_; }
  /// The largest |grad phi| of the level set's interpolant inside the grid
  /// box (Grid::maxGradientNorm, exact; 1.1-1.4 for superellipsoids, sqrt(D)
  /// for a sphere, whose centre is a kink of its distance). So
  /// phi(y) >= phi(x) - this x |y - x| for any two points x, y of the box (a
  /// segment in the box), which lets one look-up at a sphere's centre show
  /// that every point of the sphere in the box is outside the shape.
  double levelSetSlope() const { return levelSetSlope_; }
  /// The tricubic look-up's data (derived together on the first call).
  struct CubicLookup {
    /// A bound E >= 0 (world units) such that wherever the multilinear
    /// interpolant exceeds E, the Catmull-Rom interpolant
    /// (Grid::cubicValueAtCells) is positive: the largest over the cells
    /// where the cubic may be <= 0 of min(the cell's deviation bound, its
    /// largest corner value) (Grid::cubicDeviationBounds).
    double margin = 0.0;
    /// The bounding radius for the tricubic look-up (world units, >=
    /// boundingRadius()): it also holds every cell where the Catmull-Rom
    /// interpolant may be negative.
    double boundingRadius = 0.0;
    /// Per cell (indexed by its lowest corner's Grid::linear offset), E_c =
    /// cellUnit x cellSteps[c] <= E such that wherever the multilinear
    /// interpolant in the cell exceeds E_c the Catmull-Rom interpolant is
    /// positive: 0 for a cell where the cubic is positive throughout, else
    /// min(the cell's deviation bound, E) rounded up to a step of E / 255
    /// (one byte per grid node, two with nearSteps).
    std::vector<std::uint8_t> cellSteps;
    /// Per cell, the largest cellSteps of the cells within one cell of it
    /// along every axis: every point within distance 1 (cells) of a point
    /// of cell c lies in such a cell, so a multilinear value above
    /// nearMargin(c) there makes the cubic positive.
    std::vector<std::uint8_t> nearSteps;
    double cellUnit = 0.0;
    /// An upper bound of |grad| of the Catmull-Rom interpolant in the node
    /// box (world units per world unit): per axis a, |d/dx_a| <= 1.5 x
    /// 1.25^(D-1) x the largest difference of neighbouring grid values along
    /// a, over the spacing (cubicData). So a point where the cubic is phi >= 0
    /// keeps it >= 0 while it moves less than phi / slope within the box.
    double slope = 0.0;
    double cellMargin(std::size_t cell) const { return cellUnit * double(cellSteps[cell]); }
    /// The margin over the cells within one cell of `cell`.
    double nearMargin(std::size_t cell) const { return cellUnit * double(nearSteps[cell]); }
  };
  /// The tricubic look-up's data, computed on the first call (from any
  /// thread), so shapes that never meet the tricubic look-up never pay for
  /// it (a pass over the grid: ~12 ms at 64^3). The narrow phase's
  /// multilinear bulk rejection and separation certificates hold for the
  /// tricubic look-up with their margins lowered by `margin`; a single node
  /// is cleared by its cell's own margin. Callers in a loop take the
  /// reference once (the first-call check is a synchronised call).
  const CubicLookup& cubicLookup() const {
    deriveCubicData();
    return cubic_;
  }
  /// cubicLookup().margin.
  double cubicMargin() const { return cubicLookup().margin; }
  /// cubicLookup().boundingRadius.
  double cubicBoundingRadius() const { return cubicLookup().boundingRadius; }
  /// Options the shape was made with.
  const ShapeOptions& options() const { return options_; }
  /// Bytes held by the shape (grid values and nodes).
  std::size_t bytes() const;

  /// @brief Level-set value at a body-frame point (world units).
  double value(const Vec<D>& xBody) const { return grid_.value(bodyToGrid_.apply(xBody)); }
  /// @brief Value and body-frame gradient at a body-frame point.
  double valueAndGradient(const Vec<D>& xBody, Vec<D>& gradBody) const {
    Vec<D> g;
    const double v = grid_.valueAndGradient(bodyToGrid_.apply(xBody), g);
    gradBody = bodyToGrid_.rotation.transpose() * g;
    return v;
  }

 private:
  Shape() = default;

  Grid<D> grid_;
  Rigid<D> bodyToGrid_;
  NodeSet<D> nodes_;
  MassProperties<D> mass_;
  Descriptors<D> descriptors_;
  double boundingRadius_ = 0.0;
  ShapeOptions options_;
  // Derived on construction (not stored in grain files or checkpoints).
  NodeTree<D> nodeTree_;
  double levelSetSlope_ = 0.0;
  // Derived on first use (cubicLookup): the tricubic look-up's data. A
  // copy of a shape starts without them and derives its own.
  struct CubicOnce {
    std::once_flag flag;
    CubicOnce() = default;
    CubicOnce(const CubicOnce&) {}
    CubicOnce& operator=(const CubicOnce&) { return *this; }
  };
  mutable CubicOnce cubicOnce_;
  mutable CubicLookup cubic_;
  void deriveCubicData() const;
  void deriveSearchData();
};

extern template class Shape<2>;
extern template class Shape<3>;

}  // namespace lsdem::geometry
