// Experiment design: maximal-length pseudo-random binary sequences and square waves.
//
// PRBS of order n: a Fibonacci linear-feedback shift register of n bits whose feedback polynomial
// is primitive, so the bit sequence repeats after exactly 2^n - 1 bits and holds 2^(n-1) ones and
// 2^(n-1) - 1 zeros per period (balanced to one bit). Orders 2..24 are offered.
//
// As an input signal: the level switches only at multiples of the bit period T_prbs; a sample at
// time t takes bit floor(t / T_prbs). The signal's period is (2^n - 1) T_prbs. A rule of thumb
// (Madsen 1988, quoted in the paper, section 3): time constants between T_prbs/10 and 2 n T_prbs
// can be estimated (0.05-6 s for n = 6, T_prbs = 0.5 s).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/util/result.h"

namespace gb::design {

constexpr int kMinPrbsOrder = 2;
constexpr int kMaxPrbsOrder = 24;

// `count` bits of the maximal-length sequence of `order`, starting from register state `seed`
// (any value; it is reduced to n bits, and 0 is replaced by 1 since the all-zero state is stuck).
std::vector<std::uint8_t> PrbsBits(int order, std::uint32_t seed, std::size_t count);

// The same register, for a sequence without end (a live experiment): Next() returns the bits
// PrbsBits(order, seed, ·) returns, one at a time, and repeats after 2^n - 1 of them.
// Precondition: kMinPrbsOrder <= order <= kMaxPrbsOrder.
class PrbsRegister {
 public:
  PrbsRegister(int order, std::uint32_t seed);
  std::uint8_t Next();

 private:
  int order_;
  std::uint32_t mask_;
  std::uint32_t taps_;  // bit (tap - 1) set for every tap
  std::uint32_t reg_;
};

struct PrbsOptions {
  int order = 6;
  double bit_period = 0.5;      // T_prbs, in the time unit of the data
  double sample_time = 0.0125;  // T_s
  double duration = 10.0;       // samples are taken at t = k T_s for 0 <= t < duration
  double low = -1.0;            // the level of a 0 bit
  double high = 1.0;            // the level of a 1 bit
  std::uint32_t seed = 1;
  std::string name = "u";  // the column name when written
  bool IsValid(std::string* why) const;
};

struct Signal {
  std::vector<double> t;
  std::vector<double> u;
};

Result<Signal> MakePrbs(const PrbsOptions& options);

// A square wave: `low` for the first half of each period, `high` for the second.
Result<Signal> MakeSquareWave(double period, double sample_time, double duration, double low,
                              double high);

// The period of the PRBS signal, (2^n - 1) T_prbs.
double PrbsPeriod(int order, double bit_period);

// The rule-of-thumb range of estimable time constants, [T_prbs/10, 2 n T_prbs].
struct TimeConstantRange {
  double shortest;
  double longest;
};
TimeConstantRange EstimableTimeConstants(int order, double bit_period);

}  // namespace gb::design
