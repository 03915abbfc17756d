// Reproducible random numbers: the same seed gives the same numbers with every compiler and
// standard library (std::normal_distribution's algorithm is implementation-defined, so it is not
// used). Uniforms from std::mt19937_64 (fully specified by the standard), normals by the
// Marsaglia polar method.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace gb::sim {

class NormalRng {
 public:
  explicit NormalRng(std::uint64_t seed) : engine_(seed) {}

  // Uniform on (0, 1): 53 random bits, never 0.
  double Uniform() {
    return (static_cast<double>(engine_() >> 11) + 0.5) * (1.0 / 9007199254740992.0);
  }

  // Standard normal.
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * Uniform() - 1.0;
      v = 2.0 * Uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * f;
    has_spare_ = true;
    return u * f;
  }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace gb::sim
