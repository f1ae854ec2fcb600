#include "lsdem/breakage/GrainStress.h"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <stdexcept>
#include <string>

namespace lsdem::breakage {

namespace {

/// Throws when a contact record names a particle index outside the store.
void checkIndex(std::uint32_t index, std::size_t count, const char* what) {
  if (index >= count) {
    throw std::invalid_argument(std::string(what) + ": contact record names particle " + std::to_string(index) +
                                " but there are " + std::to_string(count) + " particles");
  }
}

/// The node contact of one pair record with the largest force magnitude (the
/// first one on ties); the record must have nodeCount > 0.
template <int D>
const dynamics::NodeContact<D>& strongestNode(const dynamics::PairContact<D>& pair,
                                              std::span<const dynamics::NodeContact<D>> nodes, double& force) {
  const dynamics::NodeContact<D>* best = &nodes[pair.firstNode];
  force = best->force.norm();
  for (std::uint32_t k = 1; k < pair.nodeCount; ++k) {
    const dynamics::NodeContact<D>& c = nodes[pair.firstNode + k];
    const double f = c.force.norm();
    if (f > force) {
      force = f;
      best = &c;
    }
  }
  return *best;
}

}  // namespace

template <int D>
Mat<D> averageStress(std::span<const Vec<D>> branches, std::span<const Vec<D>> forces, double volume) {
  // Check the input.
  if (branches.size() != forces.size()) {
    throw std::invalid_argument("averageStress: branches has " + std::to_string(branches.size()) +
                                " entries but forces has " + std::to_string(forces.size()));
  }
  if (!(volume > 0.0) || !std::isfinite(volume)) {
    throw std::invalid_argument("averageStress: volume must be finite and > 0, got " + std::to_string(volume));
  }
  // eq. 5: sum of the dyads x_c F_c^T, then its symmetric part over V.
  Mat<D> sum = Mat<D>::Zero();
  for (std::size_t c = 0; c < branches.size(); ++c) sum.noalias() += branches[c] * forces[c].transpose();
  return (0.5 / volume) * (sum + sum.transpose());
}

template <int D>
Vec<D> principalStresses(const Mat<D>& sigma) {
  // eq. 6: eigenvalues of the symmetric tensor (Eigen returns them ascending).
  const Eigen::SelfAdjointEigenSolver<Mat<D>> solver(sigma, Eigen::EigenvaluesOnly);
  return solver.eigenvalues().reverse();
}

template <int D>
Vec<3> principalStressTriple(const Mat<D>& sigma) {
  const Vec<D> s = principalStresses<D>(sigma);
  if constexpr (D == 3) {
    return s;
  } else {
    // Plane stress: the out-of-plane principal stress is zero.
    return Vec<3>(s[0], s[1], 0.0);
  }
}

template <int D>
void grainStresses(const dynamics::Particles<D>& particles, const dynamics::ContactSolver<D>& contacts,
                   std::vector<Mat<D>>& out) {
  const std::size_t n = particles.size();
  const std::span<const dynamics::NodeContact<D>> nodes = contacts.nodeContacts();
  out.assign(n, Mat<D>::Zero());

  // Particle pairs: a gets the node force, b the opposite; both about their own centroid.
  for (const dynamics::PairContact<D>& pair : contacts.particleContacts()) {
    checkIndex(pair.a, n, "grainStresses");
    checkIndex(pair.b, n, "grainStresses");
    for (std::uint32_t k = 0; k < pair.nodeCount; ++k) {
      const dynamics::NodeContact<D>& c = nodes[pair.firstNode + k];
      out[pair.a].noalias() += (c.point - particles.position[pair.a]) * c.force.transpose();
      out[pair.b].noalias() -= (c.point - particles.position[pair.b]) * c.force.transpose();
    }
  }

  // Planes and tools: only particle a is a particle.
  const auto addBoundary = [&](std::span<const dynamics::PairContact<D>> records) {
    for (const dynamics::PairContact<D>& pair : records) {
      checkIndex(pair.a, n, "grainStresses");
      for (std::uint32_t k = 0; k < pair.nodeCount; ++k) {
        const dynamics::NodeContact<D>& c = nodes[pair.firstNode + k];
        out[pair.a].noalias() += (c.point - particles.position[pair.a]) * c.force.transpose();
      }
    }
  };
  addBoundary(contacts.planeContacts());
  addBoundary(contacts.toolContacts());

  // Symmetric part over each particle's volume (eq. 5).
  for (std::size_t i = 0; i < n; ++i) {
    const double scale = 0.5 / particles.shape[i]->volume();
    out[i] = scale * (out[i] + out[i].transpose()).eval();
  }
}

template <int D>
void strongestContacts(const dynamics::Particles<D>& particles, const dynamics::ContactSolver<D>& contacts,
                       GrainContactPoints<D>& out) {
  const std::size_t n = particles.size();
  const std::span<const dynamics::NodeContact<D>> nodes = contacts.nodeContacts();
  const std::span<const dynamics::PairContact<D>> particlePairs = contacts.particleContacts();
  const std::span<const dynamics::PairContact<D>> all = contacts.pairContacts();

  // Count one entry per touching pair and particle side; row starts by prefix sum.
  out.offset.assign(n + 1, 0);
  for (std::size_t r = 0; r < all.size(); ++r) {
    const dynamics::PairContact<D>& pair = all[r];
    if (pair.nodeCount == 0) continue;
    checkIndex(pair.a, n, "strongestContacts");
    ++out.offset[pair.a + 1];
    if (r < particlePairs.size()) {
      checkIndex(pair.b, n, "strongestContacts");
      ++out.offset[pair.b + 1];
    }
  }
  for (std::size_t i = 0; i < n; ++i) out.offset[i + 1] += out.offset[i];

  // Fill the rows in record order with each pair's strongest node contact.
  // (offset[i] serves as row i's write cursor and ends at row i + 1's start;
  // shifting the array by one afterwards restores the row starts.)
  out.points.resize(out.offset[n]);
  for (std::size_t r = 0; r < all.size(); ++r) {
    const dynamics::PairContact<D>& pair = all[r];
    if (pair.nodeCount == 0) continue;
    double force = 0.0;
    const dynamics::NodeContact<D>& c = strongestNode(pair, nodes, force);
    out.points[out.offset[pair.a]++] = ContactPoint<D>{c.point, force};
    if (r < particlePairs.size()) out.points[out.offset[pair.b]++] = ContactPoint<D>{c.point, force};
  }
  for (std::size_t i = n; i > 0; --i) out.offset[i] = out.offset[i - 1];
  out.offset[0] = 0;

  // Sort each row by force, descending; insertion sort is stable and rows are short.
  for (std::size_t i = 0; i < n; ++i) {
    ContactPoint<D>* row = out.points.data() + out.offset[i];
    const std::size_t count = out.offset[i + 1] - out.offset[i];
    for (std::size_t j = 1; j < count; ++j) {
      const ContactPoint<D> moving = row[j];
      std::size_t k = j;
      while (k > 0 && row[k - 1].force < moving.force) {
        row[k] = row[k - 1];
        --k;
      }
      row[k] = moving;
    }
  }
}

template Mat<2> averageStress<2>(std::span<const Vec<2>>, std::span<const Vec<2>>, double);
template Mat<3> averageStress<3>(std::span<const Vec<3>>, std::span<const Vec<3>>, double);
template Vec<2> principalStresses<2>(const Mat<2>&);
template Vec<3> principalStresses<3>(const Mat<3>&);
template Vec<3> principalStressTriple<2>(const Mat<2>&);
template Vec<3> principalStressTriple<3>(const Mat<3>&);
template void grainStresses<2>(const dynamics::Particles<2>&, const dynamics::ContactSolver<2>&,
                               std::vector<Mat<2>>&);
template void grainStresses<3>(const dynamics::Particles<3>&, const dynamics::ContactSolver<3>&,
                               std::vector<Mat<3>>&);
template void strongestContacts<2>(const dynamics::Particles<2>&, const dynamics::ContactSolver<2>&,
                                   GrainContactPoints<2>&);
template void strongestContacts<3>(const dynamics::Particles<3>&, const dynamics::ContactSolver<3>&,
                                   GrainContactPoints<3>&);

}  // namespace lsdem::breakage
