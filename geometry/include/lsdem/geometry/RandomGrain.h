#pragma once
/// @file RandomGrain.h
/// @brief Random star-shaped grains with sand-like roughness spectra: the
/// shipped stand-in for tomography-derived sand grains, as signed-distance grids.
///
/// 2D: r(theta) = r0 (1 + sum_{n=2..16} (alpha_n cos n theta + beta_n sin n theta)),
/// Fourier descriptors with Gaussian alpha_n, beta_n of standard deviation ~ n^-2
/// (the decay sand descriptors show). 3D: r(u) = r0 (1 + sum_{l=2..8} sum_m c_lm
/// Y_lm(u)) with orthonormal real spherical harmonics and Gaussian c_lm of
/// standard deviation ~ l^-2 (degree amplitude sqrt(sum_m c_lm^2) ~ l^-1.5).
/// The coefficients are scaled so the standard deviation of r/r0 over the circle
/// / sphere equals the roughness, then r/r0 goes through a smooth floor that
/// keeps it >= 0.3 (the shape stays star-shaped around the origin); r0 makes the
/// area / volume that of the equivalent circle / sphere. An area/volume
/// preserving stretch then imposes the elongation.

#include "lsdem/geometry/Grid.h"

#include <cstdint>
#include <functional>

namespace lsdem::geometry {

/// Definition of a random grain (see the file comment for the shape model).
struct RandomGrainDef {
  double equivalentDiameter = 1.0;  ///< world units: diameter of the circle/sphere of equal area/volume
  double elongation = 1.0;          ///< >= 1: long/short axis ratio imposed by stretching (x is the long axis)
  double roughness = 0.1;           ///< [0, 0.5]: standard deviation of r/r0 over the boundary
  std::uint64_t seed = 1;           ///< seed of the std::mt19937_64 that draws the coefficients
};

/// @brief Signed-distance grid of a random grain centred on the origin.
///
/// The elongation e stretches x by sqrt(e) and y by 1/sqrt(e) in 2D, x by
/// e^(2/3) and y, z by e^(-1/3) in 3D. The grid is first filled with the signed
/// distance along the ray from the centre (exact on the surface), then
/// reinitialised by fast sweeping (eq. 17), whose subcell interface step makes
/// the nodes next to the surface accurate.
///
/// Reproducibility: the coefficients come from std::mt19937_64 with the
/// project's own uniform (53 high bits) and normal (Box-Muller) transforms, not
/// the std distributions (which differ between standard libraries), and every
/// node is computed independently; the same seed gives bit-identical grids for
/// any thread count (and on any platform with the same libm).
/// @param def grain definition.
/// @param spacing node spacing, world units.
/// @param paddingCells cells of padding beyond the grain's bounding box.
/// @note equivalentDiameter > 0, 1 <= elongation, 0 <= roughness <= 0.5, all
/// finite, spacing > 0; throws std::invalid_argument otherwise. The area/volume
/// is that of the equivalent diameter (quadrature of the final profile, floor
/// included). The roughness is the standard deviation of the profile before the
/// floor; it is that of the grain while the floor is inactive (r/r0 > 0.4
/// everywhere, in practice roughness <= 0.2).
template <int D>
Grid<D> randomGrainGrid(const RandomGrainDef& def, double spacing, int paddingCells = kDefaultPaddingCells);

/// @brief The grain's exact surface as the zero set of a function: the
/// signed distance along the ray from the centre that randomGrainGrid samples
/// before reinitialising (world units; exact on the surface, negative
/// inside). The function is thread-safe and holds its own copy of the profile.
/// @note Throws std::invalid_argument for a definition randomGrainGrid rejects.
template <int D>
std::function<double(const Vec<D>&)> randomGrainSurface(const RandomGrainDef& def);

}  // namespace lsdem::geometry
