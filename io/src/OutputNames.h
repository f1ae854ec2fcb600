#pragma once
/// @file OutputNames.h
/// @brief The names of the files a run writes into its folder
/// (docs/outputs.md), in one place: the runner writes the files, FrameWriter
/// the ParaView series, and OutputFolder recognises another run's outputs by
/// the same names.

#include <array>

namespace lsdem::io::outputs {

inline constexpr const char* kSummary = "summary.json";
inline constexpr const char* kHistory = "history.csv";
inline constexpr const char* kCheckpoint = "checkpoint.lsc";
inline constexpr const char* kPsd = "psd.csv";
inline constexpr const char* kShapeStats = "shape_stats.csv";
inline constexpr const char* kShapeHistograms = "shape_histograms.csv";
inline constexpr const char* kRemoved = "removed.csv";
inline constexpr const char* kBreakageLog = "breakage_log.csv";
inline constexpr const char* kProductPsd = "product_psd.csv";
inline constexpr const char* kTracks = "tracks.csv";

/// Every file of a run besides its series, `scene.toml` and `frames/`.
inline constexpr std::array<const char*, 10> kFiles = {kSummary,     kHistory,         kCheckpoint, kPsd,
                                                       kShapeStats, kShapeHistograms, kRemoved,    kBreakageLog,
                                                       kProductPsd, kTracks};

/// The ParaView series: SERIES.pvd, with its frames in frames/SERIES_NNNNNN.vtp.
inline constexpr const char* kParticles = "particles";
inline constexpr const char* kSurfaces = "surfaces";
inline constexpr const char* kBoundaries = "boundaries";
inline constexpr const char* kContacts = "contacts";
inline constexpr std::array<const char*, 4> kSeries = {kParticles, kSurfaces, kBoundaries, kContacts};

}  // namespace lsdem::io::outputs
