#pragma once
/// @file Commands.h
/// @brief The subcommands of `lsdem`. Each adds itself to the CLI11 app; its
/// callback runs the command and throws io::InputError for bad input.

#include <CLI/CLI.hpp>

namespace lsdem::apps {

/// `lsdem shape FILE.toml [--json]`: mass properties, descriptors, grid and nodes of one shape.
void addShapeCommand(CLI::App& app);

/// `lsdem split FILE.toml --plane nx,ny[,nz],d [--json]`: level-set splitting of one shape by a plane.
void addSplitCommand(CLI::App& app);

}  // namespace lsdem::apps
