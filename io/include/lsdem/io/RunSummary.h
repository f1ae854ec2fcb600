#pragma once
/// @file RunSummary.h
/// @brief The run summary (`summary.json`): steps, simulated and wall time,
/// particles, contacts, removed particles, mass and energy balance, the effects
/// that ran and the time each stage took.

#include "lsdem/dynamics/World.h"
#include "lsdem/io/JsonWriter.h"

#include <functional>
#include <ostream>

namespace lsdem::io {

/// @brief Writes the summary of `world` as one JSON object.
/// @param wallSeconds wall-clock time of the run so far, s.
/// @param extra writes more fields into the object (a run adds its mass
///   balance, breakage totals and state), or empty.
template <int D>
void writeRunSummary(const dynamics::World<D>& world, double wallSeconds, std::ostream& out,
                     const std::function<void(JsonWriter&)>& extra = {});

extern template void writeRunSummary<2>(const dynamics::World<2>&, double, std::ostream&,
                                        const std::function<void(JsonWriter&)>&);
extern template void writeRunSummary<3>(const dynamics::World<3>&, double, std::ostream&,
                                        const std::function<void(JsonWriter&)>&);

}  // namespace lsdem::io
