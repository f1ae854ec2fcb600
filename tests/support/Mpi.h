#pragma once
/// @file Mpi.h
/// @brief Test helpers for the MPI tests (tests/parallel/).

#include <mpi.h>

namespace lsdem::test {

/// This process's rank in `comm`.
inline int rankOf(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}

}  // namespace lsdem::test
