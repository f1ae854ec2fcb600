/// @file main.cpp
/// @brief The `lsdem` command: parses the command line (CLI11) and dispatches
/// to the subcommands. Exit codes (README): 0 done; 2 bad input, one line on
/// stderr ("lsdem: FILE:LINE: KEY: problem"), or a command-line usage error;
/// 1 a failed run (one line); 130 / 143 a run stopped by SIGINT / SIGTERM
/// after its checkpoint; a subcommand's own codes (3: nothing to plot or render).

#include "Commands.h"

#include "lsdem/io/InputError.h"

#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>

int main(int argc, char** argv) {
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

  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // a subcommand's exit code (stopped runs, failed checks)
  } catch (const CLI::ParseError& e) {
    app.exit(e);  // prints the usage error
    return 2;
  } catch (const lsdem::io::InputError& e) {
    std::cerr << "lsdem: " << e.what() << '\n';
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "lsdem: error: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
