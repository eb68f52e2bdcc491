// Deterministic random numbers for the plant: the same seed gives the same numbers on every
// machine and every libstdc++ (std::normal_distribution is not specified bit-for-bit, so we
// do our own transform on top of std::mt19937_64, whose output sequence *is* specified).
#pragma once
#include <cstdint>
#include <random>

namespace plant {

class Rng {
 public:
  explicit Rng(uint64_t seed = 1) : engine_(seed) {}
  void reseed(uint64_t seed) { engine_.seed(seed); has_spare_ = false; }
  // Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * (1.0 / 9007199254740992.0); }
  // Standard normal (mean 0, sigma 1), Marsaglia polar method; no allocation.
  double normal();
  // Normal with sigma, clamped to +-clamp_sigmas*sigma (parts out of spec are sorted out).
  double normal(double sigma, double clamp_sigmas = 3.0);

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace plant
