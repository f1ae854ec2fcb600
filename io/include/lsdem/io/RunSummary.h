#pragma once
/// @file RunSummary.h
/// @brief The run summary (`summary.json`): steps, simulated and wall time,
/// particles, contacts, removed particles, mass and energy balance, the effects
/// that ran and the time each stage took.

#include "lsdem/dynamics/World.h"

#include <ostream>

namespace lsdem::io {

/// @brief Writes the summary of `world` as one JSON object.
/// @param wallSeconds wall-clock time of the run so far, s.
template <int D>
void writeRunSummary(const dynamics::World<D>& world, double wallSeconds, std::ostream& out);

extern template void writeRunSummary<2>(const dynamics::World<2>&, double, std::ostream&);
extern template void writeRunSummary<3>(const dynamics::World<3>&, double, std::ostream&);

}  // namespace lsdem::io
