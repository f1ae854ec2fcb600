#pragma once
/// @file BreakageLog.h
/// @brief The breakage log as CSV (docs/outputs.md): one row per split with
/// time, parent and child ids, criterion value, strength, fracture plane and
/// fragment sizes. Lists inside a cell are separated by ';'.

#include "lsdem/breakage/Breakage.h"

#include <ostream>
#include <span>

namespace lsdem::io {

/// @brief Writes the header row (column names with units).
template <int D>
void writeBreakageLogHeader(std::ostream& out);

/// @brief Appends one row per event, in order.
template <int D>
void writeBreakageLogRows(std::span<const breakage::BreakageEvent<D>> events, std::ostream& out);

extern template void writeBreakageLogHeader<2>(std::ostream&);
extern template void writeBreakageLogHeader<3>(std::ostream&);
extern template void writeBreakageLogRows<2>(std::span<const breakage::BreakageEvent<2>>, std::ostream&);
extern template void writeBreakageLogRows<3>(std::span<const breakage::BreakageEvent<3>>, std::ostream&);

}  // namespace lsdem::io
