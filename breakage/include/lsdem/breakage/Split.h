#pragma once
/// @file Split.h
/// @brief Level-set splitting of a grain by a fracture surface (paper section
/// 3.2-3.3, eq. 14-15) into fragment shapes, with exact mass bookkeeping.
///
/// Sides. With phi the parent's level set and phi_f the fracture surface's
/// signed distance (both at the same point):
///   - eq. 15, phi4 = max(phi, phi_f), is the part of the grain where phi_f < 0:
///     fragments on that side have `side == -1`;
///   - eq. 14, phi3 = max(phi, -phi_f), is the part where phi_f > 0:
///     fragments on that side have `side == +1`.
/// Each side may fall apart into several face-connected pieces (a cut through
/// both arms of a U gives three fragments); every piece is its own fragment.
///
/// Mass bookkeeping (docs/breakage.md, "Mass of a fragment"). Each fragment's
/// mass properties are its share of the PARENT's mass integrand of eq. 24-30
/// (the smoothed Heaviside H_eps(-phi) of the parent's grid, both estimators'
/// sums), not its own grid's estimate: every parent grid node whose cell the
/// cut cannot cross gives its sample to the piece that owns it; a node whose
/// cell the cut may cross, or that is near both the cut and the surface,
/// gives 4^D sub-cell samples of the multilinear interpolant with a band 4
/// times narrower, each to the side of the cut it lies on (a plane exactly;
/// a sample within half a sub-cell of it is shared in proportion), so a
/// piece a cell or two thick is inflated neither by the smoothing band of
/// its own cut face nor by that of the surface it meets the cut beside. The
/// shares add up to the parent's volume to the quadrature difference between
/// the sub-cell and node samples and between the two bands (reported as
/// SplitResult::rawRelativeError, ~1e-4 to 3e-3), which one common factor removes:
///     volume_k = share_k * parentVolume / sum_j share_j,
/// and the same factor scales the share's second moments. The child shape is
/// made with these mass properties (Shape::fromGridNodesAndMass), so
/// Fragment::massScale() is 1 and mass_k = rho * child volume.
/// Fragment::rawVolume keeps the child grid's own estimate (eq. 24-30 on the
/// child's grid) for comparison.
///
/// Surface matched to the mass (SplitOptions::matchEnclosedVolume, on by
/// default; docs/breakage.md). The multilinear interpolant of the sampled
/// max(phi, -+phi_f) rounds the rim where the cut meets the grain, so a
/// piece's zero set encloses 0.8-1.5 % less than its share per cut (16
/// cells). Each piece's grid is lowered by delta w(x) near its zero set, w
/// being 0 within a cell diagonal (or the largest shift) of the cut, within
/// twice the largest shift of another piece of its side and of any other
/// body (`clearance`), and 1 away from them, with delta (|delta| <=
/// maxSurfaceShift parent cells) such that the polygonised zero set, as the
/// surfaces output draws it, encloses volume_k to 1e-4. The face of the cut,
/// and with it the siblings' contact, is untouched; SplitResult::
/// largestSurfaceShift reports the largest |delta|.
///
/// Re-gridding (SplitOptions::regridCells). A piece whose smallest extent
/// (twice the smallest semi-axis of the ellipsoid of its second moments) is
/// below regridCells cells of the parent's grid gets a grid of its own at
/// spacing extent / regridCells (at most regridMaxFactor times finer, and
/// coarser if the grid would exceed regridMaxNodes values), covering its
/// extent plus the padding: the level set max(phi, -+phi_f) is evaluated at
/// the new nodes from the parent's multilinear field and the fracture surface
/// (a plane is exact at any resolution) and reduced to the piece's component
/// (not reinitialised: the samples are already a distance inside the piece,
/// see Split.cpp), and surface nodes are made afresh on it at the node
/// density per new cell, at least minFragmentNodes of them, then moved in to
/// within 1e-4 parent cells of the parent's surface where the new grid's
/// interpolation left them outside it. The mass
/// stays the share above. The child's contact stiffness per unit area is that
/// of the parent under either law: its contact spacing (ShapeOptions::
/// contactSpacing) stays the parent's (area-weighted law), and its
/// ShapeOptions::nodeStiffnessScale is the parent's times its mean node weight
/// over the parent's (per-node law: a fragment with nodes twice as dense has
/// springs half as stiff).
///
/// Centroids. The fragments stay exactly where the parent's material was
/// (c_k: child centroid in the parent body frame, from its own grid). Their
/// volume-weighted centroid
///     c_bar = sum_k volume_k c_k / parentVolume   (parent body frame, reported as
///     SplitResult::centroidShift and kept in Fragment::centreOfMass)
/// differs from the parent's centroid (0) by the discretisation error of the
/// cut, a small fraction of a cell: the centre of mass moves by R c_bar when
/// the grain breaks. (Moving the fragments by -c_bar instead would keep the
/// centre of mass but push their surfaces by c_bar into whatever the parent
/// touched, and start contact springs from nothing.)
///
/// Momentum (the rule fragmentState() applies). A fragment takes the parent's
/// rigid-body motion with the parent's centroid velocity carried by the
/// fragments' centre of mass, and the parent's angular velocity,
///     v_k = v + w x (x_k - x_bar),   w_k = w,
/// with x_k = x + R c_k and x_bar = x + R c_bar (world frame). Then
///   - linear momentum: sum_k m_k v_k = M v + w x (sum_k m_k (x_k - x_bar)) = M v
///     exactly (to round-off), since sum_k m_k = M and sum_k m_k c_k = M c_bar;
///   - angular momentum about any point: orbital + spin parts give
///     sum_k (m_k x_k x v_k + I_k w) = M x_bar x v + I_comb w, with
///     I_comb = sum_k [I_k + m_k (|r_k|^2 1 - r_k r_k^T)], r_k = R (c_k - c_bar)
///     (the parallel-axis sum about the fragments' centre of mass; in 2D the
///     scalar sum_k [I_k + m_k |r_k|^2]): the parent's I w + M x x v up to
///     (I_comb - I_parent) w, whose relative size is
///     SplitResult::inertiaRelativeError (discretisation error, ~1e-3 at 20
///     cells across), and M (R c_bar) x v, the momentum's moment over the
///     centre of mass's sub-cell move. Kinetic energy changes by
///     (1/2) w.(I_comb - I_parent) w.

#include "lsdem/dynamics/Rotation.h"
#include "lsdem/geometry/Csg.h"
#include "lsdem/geometry/Grid.h"
#include "lsdem/geometry/Primitives.h"
#include "lsdem/geometry/Shape.h"
#include "lsdem/geometry/SurfaceNodes.h"
#include "lsdem/geometry/Types.h"

#include <memory>
#include <optional>
#include <cstdint>
#include <vector>

namespace lsdem::breakage {

/// @brief A fracture surface in the parent's BODY frame (world units).
/// Exactly one of the two is used: the plane when set (flat cuts, eq. 18-20:
/// the fragments get exact new nodes on it), otherwise the signed distance
/// `field` (curved cuts: fragment nodes are regenerated from their grids).
template <int D>
struct FractureSurface {
  /// Flat cut normal . x = offset in the parent's body frame. The normal need
  /// not be unit length: the split divides normal and offset by |normal|.
  std::optional<geometry::HalfSpace<D>> plane;
  /// Any signed distance phi_f(x_body), world units; used when `plane` is empty.
  /// Called from several threads at once: it must be a pure function.
  geometry::SignedDistance<D> field;
};

/// One fragment of a split.
template <int D>
struct Fragment {
  /// The child's own shape: its grid (a crop of the split level set, in the
  /// parent's grid frame), nodes and mass properties in its own principal body frame.
  std::shared_ptr<const geometry::Shape<D>> shape;
  /// Child body frame -> parent body frame: translation = child centroid in
  /// parent body coordinates (where the parent's material was, see the file comment),
  /// rotation = child principal axes in parent body coordinates.
  geometry::Rigid<D> childToParent;
  /// The centre of mass of all the split's fragments, parent body frame
  /// (SplitResult::centroidShift); fragmentState() moves it with the parent's
  /// centroid velocity.
  geometry::Vec<D> centreOfMass = geometry::Vec<D>::Zero();
  double rawVolume = 0.0;  ///< volume (area in 2D) the child's own grid gives (eq. 24-30), world units^D, for comparison
  double volume = 0.0;     ///< the child's share of the parent's volume (file comment), world units^D
  int side = 0;            ///< -1: the phi_f < 0 side (eq. 15); +1: the phi_f > 0 side (eq. 14)
  bool regridded = false;  ///< the child got a finer grid of its own (SplitOptions::regridCells)
  /// The child's nodes that were not nodes of the parent, ascending: those
  /// on its new face (on the fracture surface, within a quarter of its own
  /// cell, and more than a twentieth of a parent cell inside the parent's
  /// surface), those a projection onto its surface carried along it to a
  /// point the parent had no node at, or all of them when its nodes were
  /// made afresh (a re-gridded
  /// fragment with fewer than SplitOptions::minFragmentNodes of the parent's,
  /// or a curved cut). Where one is born inside another body, its spring
  /// starts relaxed (dynamics::ContactSolver::markNewborn), so a split stores
  /// no energy in contacts that did not exist before it.
  std::vector<std::uint32_t> cutFaceNodes;

  /// @brief volume / the child shape's volume: the factor applied to the
  /// child's mass and inertia per unit density; 1 (the shape carries its share).
  double massScale() const { return volume / shape->volume(); }
};

/// Options of splitShape().
struct SplitOptions {
  /// Surface-node density of the fragments, nodes per grid cell of length
  /// (pts/pix); 0 takes the parent's (parent.options().nodesPerCell). The new
  /// nodes on a fracture plane are spaced h / nodesPerCell apart.
  double nodesPerCell = 0.0;
  /// Cells of padding around each fragment's cropped grid, >= 3 (the
  /// smoothed-Heaviside band of the mass properties is 3 cells wide).
  int paddingCells = geometry::kDefaultPaddingCells;
  /// Re-grid a fragment whose smallest extent is below this many cells of the
  /// parent's grid (file comment); 0 (the default) turns re-gridding off; 10
  /// is the value measured in docs/breakage.md.
  double regridCells = 0.0;
  /// A re-gridded fragment's grid is at most this many times finer than the parent's, >= 1.
  int regridMaxFactor = 8;
  /// A re-gridded fragment's grid holds at most this many values (memory bound:
  /// 4 bytes each, 1 MiB at the default 2^18); the spacing grows to fit.
  std::size_t regridMaxNodes = std::size_t(1) << 18;
  /// A re-gridded fragment gets at least this many surface nodes (its node
  /// density is raised until it does), >= 1.
  int minFragmentNodes = 24;
  /// A re-gridded fragment's nodes keep the parent's node spacing in metres
  /// instead of nodesPerCell per new cell: after a flat cut they are the
  /// parent's own nodes on the piece and the cut's (projected onto the new
  /// grid's zero set), so the fragment touches its neighbours where the
  /// parent did; made afresh at nodesPerCell x new spacing / parent spacing
  /// per new cell when fewer than minFragmentNodes remain or the cut is
  /// curved. With the per-node contact law every node is a full spring, so
  /// this keeps a fragment's contact stiffness per unit area (and the time
  /// step) its parent's; the scene reader sets it by default.
  bool regridKeepsNodeSpacing = false;
  /// Pieces whose share of the volume is at most this are not re-gridded,
  /// world units^D, >= 0 (the breakage effect sets its fines size: such
  /// pieces leave the simulation at once).
  double regridMinVolume = 0.0;
  /// Move each fragment's surface (not its cut face) so that it encloses its
  /// share of the parent's volume (file comment, "Surface matched to the
  /// mass"): the uniform outward shift that puts back what the cut's rim lost.
  bool matchEnclosedVolume = true;
  /// The largest shift of matchEnclosedVolume, in cells of the parent's grid,
  /// in [0, 1]; a fragment that needs more (a chip a few cells across) is
  /// moved this far and keeps the rest of its deviation.
  double maxSurfaceShift = 0.25;
  /// The interpolant the contact reads level sets with (the scene's
  /// `[contact] interpolation`; the breakage effect sets it): a re-gridded
  /// fragment's nodes are put on its surface as that interpolant draws it
  /// (nearer the rim's true surface: 3D, mean 3.8e-4 against 5.0e-4 m within
  /// three cells of the cut, 10-cell sphere). A piece on its parent's grid is projected with the
  /// multilinear interpolant whatever this is: the Catmull-Rom interpolant of
  /// the cut's kink on the parent's coarse grid bulges out at the rim, and
  /// nodes put on it sat twice as deep in their sibling as the tricubic
  /// contact reads it. Either way a parent's node keeps the offset it had
  /// from the parent's interpolated surface, faded to 0 within a cell
  /// diagonal of the cut (nodesOnPiece in Split.cpp), so nodes on the true
  /// surface stay there away from the cut.
  geometry::GridInterpolant nodeInterpolant = geometry::GridInterpolant::Multilinear;
};

/// @brief Checks SplitOptions: nodesPerCell finite and >= 0, paddingCells >= 3,
/// regridCells finite and >= 0, regridMaxFactor >= 1, regridMaxNodes >= 64,
/// minFragmentNodes >= 1, regridMinVolume finite and >= 0, maxSurfaceShift in [0, 1].
/// @note Throws std::invalid_argument naming the option and its value.
void validateSplitOptions(const SplitOptions& options);

/// Outcome of splitShape().
template <int D>
struct SplitResult {
  /// The fragments, the phi_f < 0 side first, each side's pieces in the order
  /// of their lowest grid node. Empty when the grain is not split.
  std::vector<Fragment<D>> fragments;
  /// True when two or more fragments were made. A surface that leaves the
  /// grain whole (it misses the grain, or only grazes it so that one side holds
  /// no interior grid node) gives no fragments and isSplit == false; so does a
  /// split whose pieces but one are dropped as degenerate.
  bool isSplit = false;
  double parentVolume = 0.0;      ///< the parent's volume, world units^D
  double rawVolumeSum = 0.0;      ///< sum of the kept fragments' shares before the common factor, world units^D
  double droppedRawVolume = 0.0;  ///< shares of the pieces dropped as degenerate (no surface nodes), world units^D
  int droppedCount = 0;           ///< number of pieces dropped
  /// (rawVolumeSum + droppedRawVolume - parentVolume) / parentVolume: the
  /// quadrature difference of the shares before the common factor (file
  /// comment; 0 when not split).
  double rawRelativeError = 0.0;
  /// c_bar: the corrected-volume-weighted centroid of the fragments (their
  /// common centre of mass), parent body frame, world units.
  geometry::Vec<D> centroidShift = geometry::Vec<D>::Zero();
  /// |I_comb - I_parent| / |I_parent| per unit density (2D: polar moments;
  /// 3D: Frobenius norms of the tensors), with the corrected inertias about the
  /// fragments' centre of mass: the relative change of spin angular momentum (file comment).
  double inertiaRelativeError = 0.0;
  /// The largest |shift| of a fragment's surface (SplitOptions::
  /// matchEnclosedVolume), in cells of the parent's grid; 0 when off.
  double largestSurfaceShift = 0.0;
};

/// @brief eq. 14-15: splits `parent` by `surface` into fragment shapes.
///
/// Steps: the surface is mapped from the parent's body frame to its grid frame
/// (parent.bodyToGrid()); phi4 = max(phi, phi_f) and phi3 = max(phi, -phi_f) are
/// formed node by node on the parent's grid (geometry::csgSplit); each is split into face-connected
/// components (connectedComponents; a side in one piece is simply cropped),
/// each cropped to the piece's extent plus `paddingCells`. Nodes (section 3.3):
///   - flat cut: every parent node goes to the side of the sign of phi_f at it
///     (phi_f < 0: side -1, else +1); new nodes are placed on the plane inside
///     the parent on a square lattice of spacing s = h / nodesPerCell along two
///     (3D) or one (2D) tangent directions, centred on the projection of the
///     parent's centroid; lattice points with phi < -s/4 are kept (none closer
///     to the rim, where the parent's own nodes are), and each gets the weight
///     A / n_kept, with A = s^(D-1) times the number of lattice points with
///     phi < 0 (the lattice estimate of the section's length/area). Both sides
///     get the plane nodes. On each side a node goes to the piece whose cropped
///     grid is smallest at it.
///   - curved cut (`field`): each piece's nodes are regenerated from its own
///     grid (geometry::surfaceNodes).
///   Every node is then put back on its piece's own surface by damped
///   Newton steps (a re-gridded piece's with the contact's interpolant,
///   SplitOptions::nodeInterpolant): a cut's node onto the zero set, a
///   parent's node onto the level it had in the parent, less the piece's
///   surface shift, faded to 0 within a cell diagonal of the cut (its offset
///   from the parent's interpolated surface: a node on the true surface
///   stays on it away from the cut); near the new
///   rim the interpolant rounds the max() kink of eq. 14-15 by up to ~h/4;
///   nodes within 1e-4 h of their level stay put.
///   A piece left with no node (a sliver) gets nodes from its own grid; if it
///   still has none it is dropped (droppedCount, droppedRawVolume).
///   A small piece is re-gridded instead (file comment), with nodes made on
///   its new grid.
/// Each piece's mass properties are its share of the parent's integrand (file
/// comment); it becomes a shape with Shape::fromGridNodesAndMass.
/// @param parent the grain to split.
/// @param surface the fracture surface in the parent's body frame.
/// @param options node density and padding.
/// @param clearance distance from a point of the parent's body frame to the
/// nearest other body (world units; a lower bound will do): matchEnclosedVolume
/// moves no surface within twice its largest shift of another body (file comment).
/// Empty: nothing around the grain.
/// @return the fragments and the bookkeeping (see SplitResult).
/// @note Throws std::invalid_argument when the surface has neither a plane nor
/// a field, the field gives NaN at a grid node, the plane's normal is zero or not finite or its offset not finite,
/// or the options are out of range (validateSplitOptions).
/// Deterministic: the same fragments for any number of threads.
template <int D>
SplitResult<D> splitShape(const geometry::Shape<D>& parent, const FractureSurface<D>& surface,
                          const SplitOptions& options = {}, const geometry::SignedDistance<D>& clearance = {});

/// Where a fragment starts and how it moves when its parent breaks.
template <int D>
struct FragmentState {
  geometry::Vec<D> position = geometry::Vec<D>::Zero();    ///< centroid, world frame, m
  geometry::Mat<D> rotation = geometry::Mat<D>::Identity(); ///< child body -> world rotation
  geometry::Vec<D> velocity = geometry::Vec<D>::Zero();    ///< v + w x (x_k - x_bar), world frame, m/s
  dynamics::Spin<D> angularVelocity = dynamics::Rotation<D>::zeroSpin();  ///< the parent's w, world frame, rad/s
};

/// @brief The rigid-body rule for a fragment's pose and velocity (file
/// comment): x_k = x + R c_k, R_k = R R_c, v_k = v + w x (x_k - x - R c_bar), w_k = w.
/// @param fragment a fragment of the parent's split.
/// @param parentPosition parent centroid x, world frame, m.
/// @param parentRotation parent body -> world rotation R.
/// @param parentVelocity parent centroid velocity v, world frame, m/s.
/// @param parentSpin parent angular velocity w, world frame, rad/s.
template <int D>
FragmentState<D> fragmentState(const Fragment<D>& fragment, const geometry::Vec<D>& parentPosition,
                               const geometry::Mat<D>& parentRotation, const geometry::Vec<D>& parentVelocity,
                               const dynamics::Spin<D>& parentSpin);

extern template SplitResult<2> splitShape<2>(const geometry::Shape<2>&, const FractureSurface<2>&, const SplitOptions&,
                                                 const geometry::SignedDistance<2>&);
extern template SplitResult<3> splitShape<3>(const geometry::Shape<3>&, const FractureSurface<3>&, const SplitOptions&,
                                                 const geometry::SignedDistance<3>&);
extern template FragmentState<2> fragmentState<2>(const Fragment<2>&, const geometry::Vec<2>&, const geometry::Mat<2>&,
                                                  const geometry::Vec<2>&, const dynamics::Spin<2>&);
extern template FragmentState<3> fragmentState<3>(const Fragment<3>&, const geometry::Vec<3>&, const geometry::Mat<3>&,
                                                  const geometry::Vec<3>&, const dynamics::Spin<3>&);

}  // namespace lsdem::breakage
