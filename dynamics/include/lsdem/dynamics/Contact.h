#pragma once
/// @file Contact.h
/// @brief What the contact stages produce each step and what persists between
/// steps: node contacts (eq. 3-4), per-pair results, and the shear history.
///
/// A pair is always stored in canonical order: `a` is the particle with the
/// lower global id. Forces are "on a"; b receives the opposite force. Breakage
/// reads these records (points, forces, branch vectors); it never recomputes
/// contacts.

#include "lsdem/dynamics/Rotation.h"

#include <cstdint>
#include <vector>

namespace lsdem::dynamics {

/// One surface node of one body found inside the other body (eq. 3: phi < 0).
template <int D>
struct NodeContact {
  Vec<D> point = Vec<D>::Zero();   ///< world position of the node, m
  Vec<D> normal = Vec<D>::Zero();  ///< world unit normal pointing from b towards a (eq. 4)
  Vec<D> force = Vec<D>::Zero();   ///< total force of this node contact on a, N
  double overlap = 0.0;            ///< penetration depth -phi > 0, m
  std::uint32_t node = 0;          ///< node index in its owner's shape
  std::uint8_t ownerIsB = 0;       ///< 0: a node of a inside b; 1: a node of b inside a
  /// Zero bytes where the compiler would put padding: checkpoints write the
  /// records' bytes as they are (State.h), and padding would carry whatever
  /// the stack held, so two saves of one state would differ.
  std::uint8_t reserved[3] = {0, 0, 0};
};

// No implicit padding in the records checkpoints write raw (State.h).
static_assert(sizeof(NodeContact<2>) == 7 * sizeof(double) + 8);
static_assert(sizeof(NodeContact<3>) == 10 * sizeof(double) + 8);

/// Result of one particle pair (or particle-wall pair) this step.
template <int D>
struct PairContact {
  std::uint32_t a = 0;                   ///< particle index (lower global id)
  std::uint32_t b = 0;                   ///< particle index, or wall/tool index for wall contacts
  std::uint32_t firstNode = 0;           ///< first of this pair's records in the node-contact buffer
  std::uint32_t nodeCount = 0;           ///< number of node contacts (0: the pair does not touch)
  Vec<D> force = Vec<D>::Zero();         ///< total force on a, N (b gets -force)
  Spin<D> torqueA = Rotation<D>::zeroSpin();  ///< torque on a about its centroid, N m
  Spin<D> torqueB = Rotation<D>::zeroSpin();  ///< torque on b about its centroid (particle pairs), or on the plane / tool about Plane::point / ToolPose::position, N m
  double elasticEnergy = 0.0;            ///< energy stored in the pair's springs, J
  double dissipatedPower = 0.0;          ///< power lost to contact damping and sliding friction, W
};

static_assert(sizeof(PairContact<2>) == 4 * 4 + 6 * sizeof(double));
static_assert(sizeof(PairContact<3>) == 4 * 4 + 11 * sizeof(double));

}  // namespace lsdem::dynamics
