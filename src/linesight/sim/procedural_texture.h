// Internal to the sim module: deterministic procedural textures defined in 3D, so that a surface
// point has the same appearance whichever camera sees it.
#pragma once

#include <cstdint>

#include "linesight/sim/ray_tracing.h"

namespace linesight::sim::detail {

// SplitMix64 finaliser: a well-mixed 64-bit hash.
std::uint64_t Mix64(std::uint64_t x);
// Uniform in [0, 1) from a lattice point and a seed.
double LatticeHash(std::int64_t x, std::int64_t y, std::int64_t z, std::uint64_t seed);
// Smooth value noise in [0, 1], quintic interpolation between lattice values.
double ValueNoise(Vec3 p, std::uint64_t seed);
// Fractal sum of `octaves` value-noise layers (lacunarity 2, gain 0.5), normalised to [0, 1].
double FractalNoise(Vec3 p, int octaves, std::uint64_t seed);

// Deterministic stream of uniform and Gaussian numbers (SplitMix64 + Box-Muller), identical on
// every platform (std::normal_distribution is not).
class NoiseStream {
 public:
  explicit NoiseStream(std::uint64_t seed) : state_(seed) {}
  double Uniform();   // [0, 1)
  double Gaussian();  // N(0, 1)

 private:
  std::uint64_t state_;
  bool has_spare_ = false;
  double spare_ = 0;
};

}  // namespace linesight::sim::detail
