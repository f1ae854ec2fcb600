#pragma once
/// @file RunSummary.h
/// @brief The run summary (`summary.json`): steps, simulated and wall time,
/// particles, contacts, removed particles, mass and energy balance, the time
/// step and what limited it over the run, density scaling when used, the
/// effects that ran and the time each stage took.

#include "lsdem/dynamics/World.h"
#include "lsdem/io/JsonWriter.h"

#include <cstdint>
#include <functional>
#include <ostream>
#include <string>

namespace lsdem::io {

/// @brief The name of the contact a TimeStepLimit names: "particles" for
/// particle on particle, else the plane's or tool's name.
template <int D>
std::string limitContactName(const dynamics::World<D>& world, std::int32_t boundary);

/// @brief What set the time step now: for an automatic step, the limit of
/// its last change (the step never grows, so that is the particle and
/// contact that set it, even if they are gone); for a given step, what sets
/// the critical step now.
template <int D>
const dynamics::TimeStepLimit& stepLimit(const dynamics::World<D>& world);

/// @brief Writes the summary of `world` as one JSON object.
/// @param wallSeconds wall-clock time of the run so far, s.
/// @param extra writes more fields into the object (a run adds its mass
///   balance, breakage totals and state), or empty.
template <int D>
void writeRunSummary(const dynamics::World<D>& world, double wallSeconds, std::ostream& out,
                     const std::function<void(JsonWriter&)>& extra = {});

extern template std::string limitContactName<2>(const dynamics::World<2>&, std::int32_t);
extern template std::string limitContactName<3>(const dynamics::World<3>&, std::int32_t);
extern template const dynamics::TimeStepLimit& stepLimit<2>(const dynamics::World<2>&);
extern template const dynamics::TimeStepLimit& stepLimit<3>(const dynamics::World<3>&);
extern template void writeRunSummary<2>(const dynamics::World<2>&, double, std::ostream&,
                                        const std::function<void(JsonWriter&)>&);
extern template void writeRunSummary<3>(const dynamics::World<3>&, double, std::ostream&,
                                        const std::function<void(JsonWriter&)>&);

}  // namespace lsdem::io
