// The simulator's random numbers: raw std::mt19937_64 output mapped to uniform and Gaussian
// numbers by our own code (not <random> distributions), so that the same seed gives the same
// numbers, and the same dataset bytes, with every standard library.
#ifndef HETSLAM_DATASETS_SIM_SIM_RANDOM_H_
#define HETSLAM_DATASETS_SIM_SIM_RANDOM_H_

#include <cmath>
#include <random>

namespace hetslam {
namespace sim {

// Uniform in [0, 1) from the top 53 bits of one draw (exact, library independent).
inline double Uniform01(std::mt19937_64* rng) {
  return static_cast<double>((*rng)() >> 11) * (1.0 / 9007199254740992.0);  // 2^-53
}

// Uniform in [lo, hi) from one draw.
inline double UniformIn(double lo, double hi, std::mt19937_64* rng) {
  return lo + (hi - lo) * Uniform01(rng);
}

// Standard normal by Box-Muller from two draws (no cached second value, so the number of
// draws per call is always two).
inline double StandardGaussian(std::mt19937_64* rng) {
  const double u1 = 1.0 - Uniform01(rng);  // (0, 1]: log is finite
  const double u2 = Uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

}  // namespace sim
}  // namespace hetslam

#endif  // HETSLAM_DATASETS_SIM_SIM_RANDOM_H_
