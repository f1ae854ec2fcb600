/// @file main.cpp
/// @brief The `lsdem` command: parses the command line (CLI11) and dispatches
/// to the subcommands. Exit codes (README): 0 done; 2 bad input, one line on
/// stderr ("lsdem: FILE:LINE: KEY: problem"), or a command-line usage error;
/// 1 a failed run (one line); 130 / 143 a run stopped by SIGINT / SIGTERM
/// after its checkpoint; a subcommand's own codes (3: nothing to plot or render).

#include "Commands.h"

#include "lsdem/io/InputError.h"

#include <CLI/CLI.hpp>

#ifdef LSDEM_HAVE_MPI
#include <mpi.h>

#include <chrono>
#include <thread>
#endif

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>

namespace lsdem::apps {
namespace {
int gRanks = 1, gRank = 0;
}
int mpiRanks() { return gRanks; }
int mpiRank() { return gRank; }
}  // namespace lsdem::apps

namespace {

// Under mpirun (docs/parallel.md "lsdem run on N ranks"): MPI starts before
// the command line is read, and a failure on any rank ends every rank.
struct Mpi {
  bool started = false;
  Mpi(int& argc, char**& argv) {
#ifdef LSDEM_HAVE_MPI
    // Started by a launcher (Open MPI, PMIx, MPICH), not by hand.
    if (!std::getenv("OMPI_COMM_WORLD_SIZE") && !std::getenv("PMIX_RANK") && !std::getenv("PMI_SIZE")) return;
    int provided = 0;
    MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
    started = true;
    MPI_Comm_size(MPI_COMM_WORLD, &lsdem::apps::gRanks);
    MPI_Comm_rank(MPI_COMM_WORLD, &lsdem::apps::gRank);
#else
    (void)argc;
    (void)argv;
#endif
  }
  ~Mpi() {
#ifdef LSDEM_HAVE_MPI
    if (started) MPI_Finalize();
#endif
  }
  // The exit of a process that failed with `message` (code `code`): on several
  // ranks, one line naming the rank, then every rank ends (mpirun exits with
  // `code`). Every rank meets the same bad input: rank 0 says it, the others
  // wait to be ended with it.
  int fail(int code, const std::string& message, bool sameOnEveryRank) {
    const int ranks = lsdem::apps::mpiRanks(), rank = lsdem::apps::mpiRank();
    if (ranks <= 1) {
      std::cerr << message << '\n';
      return code;
    }
#ifdef LSDEM_HAVE_MPI
    if (sameOnEveryRank && rank != 0) std::this_thread::sleep_for(std::chrono::seconds(5));
    std::string line = message;
    if (line.rfind("lsdem: ", 0) == 0) line = line.substr(7);
    // One write, so that mpirun's own lines cannot split it.
    line = "lsdem: rank " + std::to_string(rank) + " of " + std::to_string(ranks) + ": " + line + "\n";
    std::fwrite(line.data(), 1, line.size(), stderr);
    std::fflush(stderr);
    MPI_Abort(MPI_COMM_WORLD, code);
#else
    (void)rank, (void)sameOnEveryRank;  // (used on several ranks only)
#endif
    return code;
  }
};

}  // namespace

int main(int argc, char** argv) {
  Mpi mpi(argc, argv);
#ifdef SIGXFSZ
  // Past a file size limit (ulimit -f) a write fails with EFBIG, as on a
  // full disk, and the run stops with its one-line error, its summary and
  // no lock left, instead of being killed mid-write.
  std::signal(SIGXFSZ, SIG_IGN);
#endif
  if (lsdem::apps::mpiRanks() > 1 && (argc < 2 || std::strcmp(argv[1], "run") != 0)) {
    return mpi.fail(2, "lsdem: only `lsdem run` runs on several MPI ranks", true);
  }
  CLI::App app{"lsdem: Level Set DEM with brittle breakage by level-set splitting (2D and 3D)", "lsdem"};
  app.set_version_flag("--version", std::string("lsdem ") + LSDEM_VERSION);
  app.require_subcommand(1);
  lsdem::apps::addRunCommand(app);
  lsdem::apps::addShapeCommand(app);
  lsdem::apps::addSplitCommand(app);
  lsdem::apps::addMesh2lsCommand(app);
  lsdem::apps::addCt2lsCommand(app);
  lsdem::apps::addPlotCommand(app);
  lsdem::apps::addRenderCommand(app);
  lsdem::apps::addParaviewCommand(app);
  CLI::App* bench = app.add_subcommand("bench", "measured studies: accuracy and cost, stability");
  bench->require_subcommand(1);
  lsdem::apps::addStabilityBench(*bench);
  lsdem::apps::addAccuracyBench(*bench);

  // A first word that names no command: said so (CLI11 says only that a
  // command is required).
  if (argc >= 2 && argv[1][0] != '-') {
    std::string names;
    bool known = false;
    for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
      known = known || sub->get_name() == argv[1];
      names += (names.empty() ? "" : ", ") + sub->get_name();
    }
    if (!known) return mpi.fail(2, "lsdem: unknown command '" + std::string(argv[1]) + "' (the commands: " + names + ")", true);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // a subcommand's exit code (stopped runs, failed checks)
  } catch (const CLI::ParseError& e) {
    // One line, as every other input error: what is wrong, and where the
    // options are listed.
    // (The commands parsed before the mistake: "run ", "bench stability ".)
    std::string command;
    for (const CLI::App* at = &app; !at->get_subcommands().empty();) {
      at = at->get_subcommands().front();
      command += at->get_name() + " ";
    }
    return mpi.fail(2, std::string("lsdem: ") + e.what() + " (lsdem " + command + "--help lists the options)", true);
  } catch (const lsdem::io::InputError& e) {
    return mpi.fail(2, std::string("lsdem: ") + e.what(), true);
  } catch (const std::exception& e) {
    return mpi.fail(1, std::string("lsdem: error: ") + e.what(), false);
  }
  return 0;
}
