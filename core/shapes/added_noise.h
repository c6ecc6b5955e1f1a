// Seeded noise added to a mesh: the paper's uniform noise and the denoising literature's
// Gaussian noise. Same seed, same bytes, on every machine.
#pragma once

#include <cstdint>

#include "core/mesh.h"

namespace meshsmooth {

// Adds to every coordinate of every vertex an independent uniform value in
// [-fraction * h, fraction * h], with h the mesh's mean edge length (the paper's "uniform
// noise"). Seeded: the same seed gives the same noise.
void AddUniformNoise(Mesh& mesh, double fraction_of_mean_edge, uint64_t seed);

// The mesh-denoising literature's noise: each vertex that a usable face touches moves by an
// independent Gaussian distance N(0, (sigma h)^2), h the mesh's mean edge length, along its
// area-weighted vertex normal (VertexNormals; a vertex whose normal is zero stays put).
// Vertices no usable face touches stay put. Seeded, and the same bytes on every machine (the
// Gaussian uses no libm function whose last bit may vary between CPUs).
void AddNormalNoise(Mesh& mesh, double sigma_fraction_of_mean_edge, uint64_t seed);

// Same, each vertex along its own direction drawn uniformly from the unit sphere rather than
// along its normal: the displacement's RMS is again sigma h, its normal part sigma h / sqrt(3).
void AddRandomDirectionNoise(Mesh& mesh, double sigma_fraction_of_mean_edge, uint64_t seed);

// Impulsive noise, a scanner's outliers: each vertex a usable face touches is, with probability
// `share`, thrown along its vertex normal (either way) by a distance drawn uniformly from
// [scale h, 3 scale h]; the others stay put.
void AddImpulsiveNoise(Mesh& mesh, double share, double scale_fraction_of_mean_edge, uint64_t seed);

}  // namespace meshsmooth
