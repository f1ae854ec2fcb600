#pragma once
/// @file ContactLaw.h
/// @brief The contact law as composable parts chosen by the scene (STYLE 8):
/// a normal model (linear per node, as in the paper, or Hertz), a force
/// formulation (per node or area weighted), Coulomb friction with shear history
/// and contact damping. A part the scene does not declare costs nothing: the
/// contact solver (NarrowPhase.h) picks a compiled kernel for the declared
/// combination once per step.
///
/// Conventions shared by every part. A *node contact* is one surface node of one
/// body found inside the other body (eq. 3), with overlap delta = -phi > 0 (m)
/// and unit normal n = grad phi / |grad phi| of the other body's level set
/// (eq. 4). Forces are in N (N per metre of thickness in 2D, where masses are
/// per metre of thickness too), stiffnesses in N/m.
///
/// Normal models
/// - Linear + PerNode (the paper, Tables 1-2): every node contact carries
///   F_i = kn s delta_i along its normal; `kn` is the stiffness of one node, N/m.
///   The stiffness of a contact patch grows with the node density. s is the
///   node owner's Shape::nodeStiffnessScale(): 1 for every grain a scene
///   makes; a fragment re-gridded with its nodes closer together than its
///   parent's gets the ratio of their mean node weights, so breaking does not
///   stiffen the material.
/// - Linear + AreaWeighted: every node contact carries
///   F_i = kn delta_i w_i / w_ref, with w_i the node's length (2D) or area (3D)
///   share (Shape::nodes().weights) and w_ref = referenceNodeWeight<D>(h) for
///   the node owner's grid spacing h. `kn` is then the stiffness of a piece of
///   surface of size w_ref, N/m, i.e. kn / w_ref is a stiffness per unit contact
///   length/area; a patch keeps its stiffness whatever the node density, and at
///   1 node per cell both formulations agree (to the spread of node weights).
/// - Hertz: a pair-level law F = 4/3 E* sqrt(R*) delta^(3/2) (hertzForce),
///   delta the deepest node overlap of the pair; see hertzForce for E*, R* and
///   how the force is spread over the pair's node contacts.
///
/// Damping (C_res, `dampingRatio` zeta): a dashpot C = 2 zeta sqrt(m_eff K)
/// per pair (dampingCoefficient), K the pair's current total normal stiffness
/// (sum of its node stiffnesses; dF/ddelta for Hertz), shared over the node
/// contacts in proportion to their stiffness (Hertz: to their share of the
/// force), each part opposing the normal relative velocity at its node.
///
/// No tensile contact forces. While two surfaces separate, the dashpot pulls
/// them together; near the end of a contact its pull exceeds the spring's
/// push, and a plain spring-dashpot would then hold the bodies together (an
/// attraction contact mechanics does not have). lsdem clips the normal force
/// of every node contact at zero, the usual DEM choice: the dashpot part of a
/// node's force is max(-c_i v_n, -F_spring,i), so it may cancel the spring's
/// push but never pull. The dashpot records (PairDashpot) hold the force
/// actually applied, so the energy ledger books exactly the work the clipped
/// dashpot did and the budget closes. The clip changes the restitution of the
/// linear law to e = exp(-zeta / sqrt(1 - zeta^2) (pi - 2 asin zeta))
/// (restitutionCoefficient; 0.364 at zeta = 0.4, where the unclipped law gives
/// 0.254), and the bodies part at the speed they have when the force reaches
/// zero. The dashpot force jumps from zero to c v_n where a contact begins
/// (and, were it not clipped before, would drop from c v_n where it ends), so
/// in the first and last step of a node contact the solver weights it by the
/// fraction of the step the node touches (estimated from the overlap and the
/// normal speed; see NarrowPhase.cpp, boundaryWeight): the restitution then
/// does not depend on where in a step a contact starts. The
/// integrator hands forces the half-step velocity, which raises the effective
/// damping ratio by ~zeta omega dt / 2 (e is 0.55 % low at zeta = 0.4 with 200
/// steps per contact, 2.2 % with 50).
///
/// Friction: a tangential spring on the shear displacement each node contact
/// accumulates, capped at mu |F_n| of the node (Coulomb). Its stiffness:
/// - Linear tangential model: ks per node contact, scaled like the normal
///   stiffness of that node (per node, or by w_i / w_ref).
/// - Mindlin (Hertz only; the default of a Hertz law without `ks`): the no-slip
///   Mindlin stiffness of the pair, k_t = 8 G* sqrt(R* delta), with
///   1/G* = (2 - nu_a)/G_a + (2 - nu_b)/G_b and G = E / (2 (1 + nu)), shared
///   over the node contacts like the Hertz force (node i carries k_t share_i).
///   The spring force is k_t times the shear displacement, so it follows the
///   stiffness as the overlap changes; the energy that change puts into or
///   takes out of a loaded spring, (1/2) (k_t,old - k_t,new) |s|^2 for a
///   shear displacement s, is booked with the contact losses so the energy
///   ledger closes (a loss while the contact unloads, the micro-slip of the
///   shrinking contact area).
///
/// Walls and tools may have their own material (BoundaryMaterial): the
/// constants of a grain-boundary contact then come from both materials
/// (boundaryConstants): Hertz E* and G* from the grain's and the wall's E and
/// nu (a rigid wall drops its terms), the linear law's kn and ks from the wall's
/// own values (a rigid wall: 2 kn and 2 ks, see BoundaryMaterial), and the
/// wall's friction coefficient.

#include <optional>

namespace lsdem::dynamics {

/// The normal force model.
enum class NormalModel {
  Linear,  ///< F = k delta per node contact (the paper)
  Hertz,   ///< F = 4/3 E* sqrt(R*) delta^(3/2) per pair
};

/// The tangential (friction) spring's model.
enum class TangentialModel {
  Linear,   ///< ks per node contact, scaled like kn (the paper)
  Mindlin,  ///< Hertz only: no-slip Mindlin k_t = 8 G* sqrt(R* delta) per pair
};

/// How a node contact's stiffness relates to the node discretisation.
enum class ForceFormulation {
  PerNode,       ///< every node carries the full kn (the paper)
  AreaWeighted,  ///< a node carries kn w_i / w_ref (its share of the surface)
};

/// How the narrow phase reads the other body's level set at a node (eq. 3-4).
enum class LevelSetInterpolation {
  /// Multilinear on the grid cell (the paper): 2^D values per look-up. On a
  /// convex surface it overestimates the distance by up to ~h^2 / (8 R) per
  /// curved direction (R the radius of curvature), so at coarse grids it
  /// loses much of a small overlap.
  Trilinear,
  /// Catmull-Rom tricubic (bicubic in 2D) on the same grid
  /// (Grid::cubicValueAtCells): 4^D values per look-up, error O(h^3), the
  /// normal from its exact gradient. Bulk rejection and certificates keep
  /// their multilinear tests with a margin (Shape::cubicMargin).
  Tricubic,
};

/// Definition of a contact law (STYLE 7). Defaults are the paper's Table 1
/// (jaw crusher): kn = 3e7 N/m, ks = 0.8 kn, mu = 0.6, C_res = 0.4.
struct ContactLawDef {
  NormalModel normal = NormalModel::Linear;
  ForceFormulation formulation = ForceFormulation::PerNode;
  /// Normal stiffness, N/m, > 0. Linear + PerNode: per node contact (the paper's
  /// k_n). Linear + AreaWeighted: per reference node weight w_ref (see the file
  /// comment). Not read by Hertz.
  double kn = 3e7;
  /// Tangential stiffness, N/m, >= 0, same meaning per node as `kn` (per node,
  /// or per w_ref with AreaWeighted); the Linear tangential model's, with
  /// either normal model.
  double ks = 0.8 * 3e7;
  /// The friction spring: Linear (ks) or Mindlin (Hertz only, from the materials).
  TangentialModel tangential = TangentialModel::Linear;
  /// Coulomb friction coefficient mu, >= 0; the tangential part exists only when `hasFriction`.
  double friction = 0.6;
  /// C_res: fraction of critical damping of the pair's normal spring, 0 <= zeta < 1;
  /// exists only when `hasDamping`.
  double dampingRatio = 0.4;
  /// Hertz: Young's modulus of the grains' material, Pa, > 0 (same material on both sides).
  double youngsModulus = 0.0;
  /// Hertz: Poisson's ratio, 0 <= nu < 0.5.
  double poissonRatio = 0.25;
  bool hasFriction = true;  ///< Coulomb friction with shear history
  /// Simulated time, s, >= 0, from which friction acts (when `hasFriction`);
  /// before it the law is frictionless and keeps no shear history, and the
  /// shear springs start from zero at that time. A dense specimen is made
  /// frictionless, then tested with friction.
  double frictionFrom = 0.0;
  bool hasDamping = true;   ///< contact damping C_res
  /// The look-up of a node in the other body's level set (planes are exact either way).
  LevelSetInterpolation interpolation = LevelSetInterpolation::Trilinear;
};

/// The contact material of a wall (plane) or tool against the grains
/// (STYLE 7). A boundary without one meets the grains with the law's own
/// constants, as if it were of the grains' material.
struct BoundaryMaterial {
  /// Infinitely stiff. Hertz: the wall's terms drop out of 1/E* and 1/G*, so
  /// 1/E* = (1 - nu^2)/E of the grain alone. Linear: a grain-grain node
  /// contact's kn is two grain halves of 2 kn in series; against a rigid
  /// wall only the grain's half remains, so the wall contact has 2 kn and 2 ks.
  bool rigid = false;
  double youngsModulus = 0.0;  ///< Hertz, not rigid: the wall's E, Pa (> 0)
  double poissonRatio = 0.0;   ///< Hertz, not rigid: the wall's nu, in [0, 0.5)
  double kn = 0.0;             ///< linear, not rigid: normal stiffness, N/m (> 0), same meaning as ContactLawDef::kn
  /// Linear, not rigid: tangential stiffness, N/m (>= 0); absent: kn x the law's ks / kn.
  std::optional<double> ks;
  /// Coulomb coefficient of a grain on this boundary (>= 0; needs a law with
  /// friction); absent: the law's.
  std::optional<double> friction;
};

/// The constants of one kind of contact: grain on grain (lawConstants) or
/// grain on one boundary (boundaryConstants).
struct ContactConstants {
  double kn = 0.0;        ///< linear: normal stiffness, N/m (per node, or per w_ref)
  double ks = 0.0;        ///< linear tangential model: tangential stiffness, N/m; 0 with Mindlin
  double friction = 0.0;  ///< Coulomb mu
  double eStar = 0.0;     ///< Hertz: E*, Pa
  double gStar = 0.0;     ///< Mindlin: G*, Pa (0 with the linear tangential model)
};

/// @brief Checks every parameter of the law: kn > 0, ks >= 0, mu >= 0,
/// 0 <= zeta < 1, and for Hertz E > 0 and 0 <= nu < 0.5, all finite;
/// Mindlin only with Hertz.
/// @note Throws std::invalid_argument with a one-line message naming the
/// parameter and its value.
void validateContactLaw(const ContactLawDef& law);

/// @brief Checks a boundary's material against the law it meets the grains
/// with: Hertz needs E > 0 and 0 <= nu < 0.5 unless rigid, linear kn > 0
/// unless rigid, ks >= 0, friction >= 0 only with a law that has friction.
/// @note Throws std::invalid_argument with a one-line message.
void validateBoundaryMaterial(const ContactLawDef& law, const BoundaryMaterial& material);

/// @brief Hertz effective modulus for two bodies of the law's material:
/// 1/E* = (1 - nu^2)/E + (1 - nu^2)/E, Pa.
double effectiveModulus(const ContactLawDef& law);

/// @brief Mindlin effective shear modulus for two bodies of the law's
/// material: 1/G* = 2 (2 - nu)/G, G = E / (2 (1 + nu)), Pa.
double effectiveShearModulus(const ContactLawDef& law);

/// @brief The constants of a grain-grain contact under `law`.
ContactConstants lawConstants(const ContactLawDef& law);

/// @brief The constants of a grain-boundary contact (see BoundaryMaterial and
/// the file comment). @note Throws as validateBoundaryMaterial.
ContactConstants boundaryConstants(const ContactLawDef& law, const BoundaryMaterial& material);

/// @brief No-slip Mindlin tangential stiffness k_t = 8 G* sqrt(R* delta), N/m.
double mindlinStiffness(double effectiveShearModulus, double radius, double overlap);

/// @brief The radius of curvature a body brings to a Hertz contact: the radius
/// of the sphere (3D) or circle (2D) of equal volume (area), m.
/// 3D: (3 V / (4 pi))^(1/3); 2D: sqrt(A / pi).
/// @param volume volume (3D, m^3) or area (2D, m^2) of the body, > 0.
template <int D>
double equivalentRadius(double volume);

/// @brief Combined radius R* of two bodies: 1/R* = 1/Ra + 1/Rb, m. A plane is
/// Rb = infinity (pass std::numeric_limits<double>::infinity()): R* = Ra.
double combinedRadius(double radiusA, double radiusB);

/// @brief Hertz normal force F = 4/3 E* sqrt(R*) delta^(3/2), N.
///
/// In 3D this is the sphere-sphere law. In 2D the same formula is used as the
/// force on a slice of unit thickness (N per metre, like the 2D masses): it is
/// the 3D law of the equivalent spheres applied to the 2D slice, not the
/// (logarithmic) law of two parallel cylinders; it keeps the 3/2 power that
/// makes the contact stiffen with load.
///
/// In the contact solver delta is the deepest node overlap of the pair (both
/// directions of a particle pair). The force is spread over the pair's node
/// contacts in proportion to w_i delta_i (node weight times overlap: the local
/// share of the overlap volume), each share along its node's normal, so the
/// total does not depend on the node count and the centre of pressure moves
/// continuously as nodes enter and leave the contact.
/// @param effectiveModulus E*, Pa. @param radius R*, m. @param overlap delta, m (<= 0 gives 0).
double hertzForce(double effectiveModulus, double radius, double overlap);

/// @brief Hertz contact stiffness dF/ddelta = 2 E* sqrt(R* delta), N/m.
double hertzStiffness(double effectiveModulus, double radius, double overlap);

/// @brief Contact damping coefficient C = 2 zeta sqrt(m_eff K), N s/m.
/// @param zeta damping ratio C_res. @param effectiveMass m_eff = ma mb / (ma + mb)
/// (ma against a wall or tool), kg. @param stiffness the pair's normal stiffness K, N/m.
double dampingCoefficient(double zeta, double effectiveMass, double stiffness);

/// @brief Coefficient of restitution of lsdem's linear spring-dashpot with
/// damping ratio zeta (the tensile part clipped, see the file comment):
/// e = exp(-zeta / sqrt(1 - zeta^2) (pi - 2 asin zeta)).
///
/// Derivation: the overlap x = (v0 / omega_d) exp(-zeta omega t) sin(omega_d t)
/// gives the normal force k x + c x' proportional to sin(omega_d t + 2 alpha),
/// sin alpha = zeta, which reaches zero at omega_d t* = pi - 2 alpha; the
/// bodies leave with the speed they have then, v0 exp(-zeta omega t*), and
/// fly apart with no force. Without the clip the formula would be
/// exp(-pi zeta / sqrt(1 - zeta^2)) (0.254 instead of 0.364 at zeta = 0.4).
/// e falls from 1 at zeta = 0 to exp(-2) = 0.135 as zeta -> 1.
double restitutionCoefficient(double zeta);

/// @brief Duration of a linear spring-dashpot impact from the first touch to
/// the moment the surfaces part (overlap back to zero), s:
/// (pi - 2 asin zeta) / omega_d + 2 zeta / omega, omega_d = omega sqrt(1 - zeta^2).
/// The force ends 2 zeta / omega before the overlap does (at the clip).
/// @param zeta damping ratio. @param omega sqrt(K / m_eff), rad/s.
double contactDuration(double zeta, double omega);

/// Restitution of the clipped linear spring-dashpot at critical damping: the
/// lowest it can give (restitutionCoefficient as zeta -> 1).
inline constexpr double kMinimumRestitution = 0.1353352832366127;  // exp(-2)

/// @brief Inverse of restitutionCoefficient (a scene may give a restitution
/// instead of C_res), solved by bisection to round-off.
/// @note Throws std::invalid_argument unless exp(-2) < e <= 1.
double dampingRatioForRestitution(double restitution);

/// Mean node weight of lsdem's 3D surface nodes at 1 node per cell, in units
/// of h^2: the isotropic remesher's vertices stand for ~0.70 h^2 each (measured
/// 0.709 on a sphere and 0.688 on a box at 10 cells across).
inline constexpr double kNodeAreaPerCellArea3D = 0.7;

/// @brief The reference node weight w_ref of the AreaWeighted formulation for
/// a node owner whose grid spacing is h: the length (2D) or area (3D) a node
/// stands for at 1 node per cell. 2D: h (nodes are h apart along the contour);
/// 3D: kNodeAreaPerCellArea3D h^2.
/// @param spacing the owner shape's grid spacing h, m.
template <int D>
double referenceNodeWeight(double spacing);

extern template double equivalentRadius<2>(double);
extern template double equivalentRadius<3>(double);
extern template double referenceNodeWeight<2>(double);
extern template double referenceNodeWeight<3>(double);

}  // namespace lsdem::dynamics
