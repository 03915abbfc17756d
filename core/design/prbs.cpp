#include "core/design/prbs.h"

#include <bit>
#include <cassert>
#include <cmath>

#include <fmt/format.h>

namespace gb::design {
namespace {

// Tap positions (1-based, the register's bit n is the output) of primitive polynomials
// x^n + ... + 1, one per order; maximal length is verified for every order by the tests.
const std::vector<std::vector<int>>& Taps() {
  static const std::vector<std::vector<int>> kTaps = {{},
                                                      {},
                                                      {2, 1},
                                                      {3, 2},
                                                      {4, 3},
                                                      {5, 3},
                                                      {6, 5},
                                                      {7, 6},
                                                      {8, 6, 5, 4},
                                                      {9, 5},
                                                      {10, 7},
                                                      {11, 9},
                                                      {12, 6, 4, 1},
                                                      {13, 4, 3, 1},
                                                      {14, 5, 3, 1},
                                                      {15, 14},
                                                      {16, 15, 13, 4},
                                                      {17, 14},
                                                      {18, 11},
                                                      {19, 6, 2, 1},
                                                      {20, 17},
                                                      {21, 19},
                                                      {22, 21},
                                                      {23, 18},
                                                      {24, 23, 22, 17}};
  return kTaps;
}

// Samples of a piecewise-constant signal at t = k T_s, 0 <= t < duration; `level(t)` gives it.
template <class F>
Signal Sample(double sample_time, double duration, F level) {
  Signal s;
  const auto n = static_cast<std::size_t>(std::ceil(duration / sample_time - 1e-9));
  s.t.reserve(n);
  s.u.reserve(n);
  // When 1/T_s is a whole number (80 Hz), k / 80 is the double nearest to the decimal time, so
  // files show 0.0375 rather than 3 * 0.0125 = 0.037500000000000006.
  const double rate = 1.0 / sample_time;
  const bool whole_rate = std::abs(rate - std::round(rate)) < 1e-9 * rate;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = whole_rate ? static_cast<double>(k) / std::round(rate)
                                : static_cast<double>(k) * sample_time;
    s.t.push_back(t);
    s.u.push_back(level(t));
  }
  return s;
}

}  // namespace

PrbsRegister::PrbsRegister(int order, std::uint32_t seed) : order_(order) {
  assert(order >= kMinPrbsOrder && order <= kMaxPrbsOrder);
  mask_ = (1u << order) - 1u;
  taps_ = 0;
  for (int tap : Taps()[order]) taps_ |= 1u << (tap - 1);
  reg_ = seed & mask_;
  if (reg_ == 0) reg_ = 1;
}

std::uint8_t PrbsRegister::Next() {
  const auto bit = static_cast<std::uint8_t>((reg_ >> (order_ - 1)) & 1u);
  const auto feedback = static_cast<std::uint32_t>(std::popcount(reg_ & taps_) & 1);
  reg_ = ((reg_ << 1) | feedback) & mask_;
  return bit;
}

std::vector<std::uint8_t> PrbsBits(int order, std::uint32_t seed, std::size_t count) {
  PrbsRegister reg(order, seed);
  std::vector<std::uint8_t> bits(count);
  for (auto& b : bits) b = reg.Next();
  return bits;
}

bool PrbsOptions::IsValid(std::string* why) const {
  auto fail = [&](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (order < kMinPrbsOrder || order > kMaxPrbsOrder)
    return fail(fmt::format("--order {} is not offered (use {} to {})", order, kMinPrbsOrder,
                            kMaxPrbsOrder));
  if (!(bit_period > 0) || !std::isfinite(bit_period))
    return fail("--period (the bit period) must be a positive number");
  if (!(sample_time > 0) || !std::isfinite(sample_time))
    return fail("--ts (the sample time) must be a positive number");
  if (!(duration > 0) || !std::isfinite(duration))
    return fail("--duration must be a positive number");
  if (std::ceil(duration / sample_time - 1e-9) < 1)
    return fail(fmt::format("--duration {} at --ts {} gives no sample", duration, sample_time));
  if (duration / sample_time > 5e7)
    return fail(fmt::format("--duration {} at --ts {} would give more than 50 million samples",
                            duration, sample_time));
  if (!std::isfinite(low) || !std::isfinite(high)) return fail("--low and --high must be finite");
  if (bit_period < sample_time * (1 - 1e-9))
    return fail(
        fmt::format("the bit period {} is shorter than the sample time {}: bits would be "
                    "lost between samples",
                    bit_period, sample_time));
  return true;
}

Result<Signal> MakePrbs(const PrbsOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) return InputError(why);
  const auto n_bits = static_cast<std::size_t>(std::ceil(o.duration / o.bit_period)) + 1;
  const std::vector<std::uint8_t> bits = PrbsBits(o.order, o.seed, n_bits);
  return Sample(o.sample_time, o.duration, [&](double t) {
    const auto i = static_cast<std::size_t>(std::floor(t / o.bit_period + 1e-9));
    return bits[std::min(i, bits.size() - 1)] ? o.high : o.low;
  });
}

Result<Signal> MakeSquareWave(double period, double sample_time, double duration, double low,
                              double high) {
  if (!(period > 0) || !(sample_time > 0) || !(duration > 0))
    return InputError("the period, sample time and duration of a square wave must be positive");
  return Sample(sample_time, duration, [&](double t) {
    const double phase = t / period - std::floor(t / period + 1e-9);
    return phase < 0.5 - 1e-9 ? low : high;
  });
}

double PrbsPeriod(int order, double bit_period) {
  return static_cast<double>((1u << order) - 1u) * bit_period;
}

TimeConstantRange EstimableTimeConstants(int order, double bit_period) {
  return {bit_period / 10.0, 2.0 * order * bit_period};
}

}  // namespace gb::design
