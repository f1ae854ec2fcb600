#pragma once
/// @file DistributedRun.h
/// @brief `mpirun -np N lsdem run SCENE.toml`: the engine of a run spread
/// over MPI ranks (io::RunEngine; docs/parallel.md "lsdem run on N ranks").
///
/// Every rank reads the scene and builds the world alike (or restores it from
/// the checkpoint alike), and a DistributedWorld spreads it: each rank steps
/// its own particles and their ghosts. Rank 0 writes the outputs, from a
/// view of the whole run: a second world built from the scene, which nothing
/// steps, brought up to the run (DistributedWorld::updateView, the breakage
/// log, the removal records and the energy ledger's shares gathered) at the
/// instants an output or a checkpoint is due; with `[output] frame_pieces =
/// "ranks"` every rank writes its own particles' piece of each frame and
/// rank 0 the frame's index. The checkpoint is the whole run's, in the
/// one-process format: a run resumes from it on any number of ranks, one
/// included.
///
/// A scene needs no change, within what DistributedWorld distributes (its
/// constructor refuses the rest, naming it).

#include "lsdem/io/Run.h"
#include "lsdem/parallel/DistributedWorld.h"

#include <mpi.h>

#include <memory>

namespace lsdem::parallel {

/// @brief The engine for io::RunOptions::engine on the ranks of `comm`
/// (rank 0 writes the outputs); the scene's `[parallel]` settings give the
/// rebalancing (DistributedDef).
std::shared_ptr<const io::RunEngineFactory> distributedRun(MPI_Comm comm);

}  // namespace lsdem::parallel
