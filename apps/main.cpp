/// @file main.cpp
/// @brief The `lsdem` command: parses the command line (CLI11) and dispatches
/// to the subcommands. Errors in user input end in one line on stderr and exit
/// code 2; unexpected failures in exit code 1.

#include "lsdem/io/InputError.h"

#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>

int main(int argc, char** argv) {
  CLI::App app{"lsdem: Level Set DEM with brittle breakage by level-set splitting (2D and 3D)", "lsdem"};
  app.set_version_flag("--version", std::string("lsdem ") + LSDEM_VERSION);
  app.require_subcommand(1);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return 0;
}
