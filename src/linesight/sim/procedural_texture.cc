#include "linesight/sim/procedural_texture.h"

#include <cmath>
#include <numbers>

namespace linesight::sim::detail {

std::uint64_t Mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

double LatticeHash(std::int64_t x, std::int64_t y, std::int64_t z, std::uint64_t seed) {
  // One mixing round over a linear combination with large odd constants is plenty for textures.
  const std::uint64_t key = static_cast<std::uint64_t>(x) * 0x9e3779b97f4a7c15ULL +
                            static_cast<std::uint64_t>(y) * 0xc2b2ae3d27d4eb4fULL +
                            static_cast<std::uint64_t>(z) * 0x165667b19e3779f9ULL + seed;
  return static_cast<double>(Mix64(key) >> 11) * (1.0 / 9007199254740992.0);
}

namespace {
double Fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
double Lerp(double a, double b, double t) { return a + (b - a) * t; }
}  // namespace

double ValueNoise(Vec3 p, std::uint64_t seed) {
  const double fx = std::floor(p.x), fy = std::floor(p.y), fz = std::floor(p.z);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy),
             iz = static_cast<std::int64_t>(fz);
  const double tx = Fade(p.x - fx), ty = Fade(p.y - fy), tz = Fade(p.z - fz);
  double c[2][2][2];
  for (int dz = 0; dz < 2; ++dz) {
    for (int dy = 0; dy < 2; ++dy) {
      for (int dx = 0; dx < 2; ++dx) c[dz][dy][dx] = LatticeHash(ix + dx, iy + dy, iz + dz, seed);
    }
  }
  const double y0 = Lerp(Lerp(c[0][0][0], c[0][0][1], tx), Lerp(c[0][1][0], c[0][1][1], tx), ty);
  const double y1 = Lerp(Lerp(c[1][0][0], c[1][0][1], tx), Lerp(c[1][1][0], c[1][1][1], tx), ty);
  return Lerp(y0, y1, tz);
}

double FractalNoise(Vec3 p, int octaves, std::uint64_t seed) {
  double sum = 0, amplitude = 1, total = 0;
  for (int octave = 0; octave < octaves; ++octave) {
    sum += amplitude * ValueNoise(p, seed + 7919ULL * octave);
    total += amplitude;
    amplitude *= 0.5;
    // Lacunarity 2 with a small rotation-like shear so the lattices of octaves do not align.
    p = {2.0 * p.x + 0.31 * p.z + 17.3, 2.0 * p.y - 0.27 * p.x + 5.1, 2.0 * p.z + 0.23 * p.y - 9.7};
  }
  return sum / total;
}

double NoiseStream::Uniform() {
  state_ += 0x9e3779b97f4a7c15ULL;
  return static_cast<double>(Mix64(state_) >> 11) * (1.0 / 9007199254740992.0);
}

double NoiseStream::Gaussian() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  double u1 = Uniform();
  while (u1 <= 0) u1 = Uniform();
  const double u2 = Uniform();
  const double radius = std::sqrt(-2.0 * std::log(u1));
  spare_ = radius * std::sin(2.0 * std::numbers::pi * u2);
  has_spare_ = true;
  return radius * std::cos(2.0 * std::numbers::pi * u2);
}

}  // namespace linesight::sim::detail
