#pragma once
/// @file Mpi.h
/// @brief Test helpers for the MPI tests (tests/parallel/).

#include "lsdem/dynamics/World.h"

#include <gtest/gtest.h>
#include <mpi.h>

namespace lsdem::test {

/// This process's rank in `comm`.
inline int rankOf(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}

/// Checks a distributed run's energy ledger (DistributedWorld::energy)
/// against one world's: every term, and the balance error, within
/// `tolerance` of the run's energy scale (the ranks sum the same terms in
/// another order); and the run did work of the kinds the test names.
inline void expectSameLedger(const dynamics::EnergyLedger& got, const dynamics::EnergyLedger& want,
                             double tolerance = 1e-10) {
  const double scale = want.scale();
  const auto near = [&](double a, double b, const char* term) {
    EXPECT_NEAR(a, b, tolerance * scale) << term << " (energy scale " << scale << " J)";
  };
  near(got.kineticTranslational, want.kineticTranslational, "kinetic translational");
  near(got.kineticRotational, want.kineticRotational, "kinetic rotational");
  near(got.elastic, want.elastic, "elastic");
  near(got.gravityWork, want.gravityWork, "gravity work");
  near(got.boundaryWork, want.boundaryWork, "boundary work");
  near(got.dampingLoss, want.dampingLoss, "damping loss");
  near(got.contactLoss, want.contactLoss, "contact loss");
  near(got.removedEnergy, want.removedEnergy, "removed energy");
  near(got.addedEnergy, want.addedEnergy, "added energy");
  near(got.splitRelease, want.splitRelease, "split release");
  near(got.initial, want.initial, "initial");
  near(got.balanceError(), want.balanceError(), "balance error");
}

}  // namespace lsdem::test
