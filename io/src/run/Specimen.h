#pragma once
/// @file Specimen.h
/// @brief The specimen of `[output.specimen]` (internal to io): its height,
/// vertical stress and solid volume in a world, for history.csv and the
/// distributions' strain (docs/scenes.md).

#include "lsdem/dynamics/World.h"
#include "lsdem/io/Scene.h"

namespace lsdem::io {

/// @brief From the bottom plane to the face of the top boundary (a plane, or
/// a tool's lowest node along the bottom's normal), m; 0 when either is not
/// in the world.
template <int D>
double specimenHeight(const SpecimenDef& specimen, const dynamics::World<D>& world);

/// @brief The top boundary's load along the bottom's normal over the width
/// (2D) or area (3D), Pa.
template <int D>
double specimenStress(const SpecimenDef& specimen, const dynamics::World<D>& world);

/// @brief The particles' volume (2D: area), m^3.
template <int D>
double solidVolume(const dynamics::World<D>& world);

/// @brief (h0 - h) / h0, or 0 when h0 is not > 0.
inline double specimenStrain(double h0, double h) { return h0 > 0.0 ? (h0 - h) / h0 : 0.0; }

}  // namespace lsdem::io
