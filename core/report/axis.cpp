#include "core/report/axis.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace gb::report {
namespace {

// Magnitudes outside [1e-4, 1e5) get a shared power of ten: beyond that, plain labels grow
// too long to read at a glance.
constexpr int kMaxPlainExponent = 4;
constexpr int kMinPlainExponent = -4;

double NiceStep(double span, int max_ticks) {
  const double raw = span / std::max(1, max_ticks - 1);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double normalized = raw / magnitude;
  double nice = 10.0;
  if (normalized <= 1.0) {
    nice = 1.0;
  } else if (normalized <= 2.0) {
    nice = 2.0;
  } else if (normalized <= 5.0) {
    nice = 5.0;
  }
  return nice * magnitude;
}

// The 1-2-5 step below `step`: 5 -> 2 -> 1 -> 0.5 -> 0.2 ...
double SmallerStep(double step) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(step) + 1e-9));
  const double mantissa = step / magnitude;  // 1, 2 or 5
  if (mantissa > 3.5) return 2.0 * magnitude;
  if (mantissa > 1.5) return magnitude;
  return 0.5 * magnitude;
}

// The multiples of `step` inside `range`. Integer multiples, so labels do not accumulate
// rounding error.
std::vector<double> Multiples(Range range, double step) {
  std::vector<double> values;
  const double first = std::ceil(range.min / step - 1e-9);
  const double last = std::floor(range.max / step + 1e-9);
  // A whole count of steps (the range and the step are finite: NiceTicks' caller checks).
  const auto steps = static_cast<long long>(last - first);
  for (long long i = 0; i <= steps; ++i) {
    double v = (first + static_cast<double>(i)) * step;
    if (std::abs(v) < step * 1e-9) v = 0.0;
    values.push_back(v);
  }
  return values;
}

}  // namespace

Ticks NiceTicks(Range range, int max_ticks) {
  Ticks ticks;
  const double span = range.Span();
  if (!std::isfinite(range.min) || !std::isfinite(range.max) || !(span > 0.0)) return ticks;
  max_ticks = std::max(kMinTicks, max_ticks);

  ticks.step = NiceStep(span, max_ticks);
  ticks.values = Multiples(range, ticks.step);
  // One or two labels show little of the scale (a short QQ or residual plot ended with one).
  // A short axis, 0.13 to 0.71 with room for two labels, gets the step 1 and no tick at all;
  // smaller steps are taken until kMinTicks fit. NiceStep's step is at most 2.5 times the span
  // and each step down divides it by 2 or 2.5, so five steps down reach a third of the span,
  // where three ticks always fit.
  for (int i = 0; i < 6 && ticks.values.size() < static_cast<std::size_t>(kMinTicks); ++i) {
    ticks.step = SmallerStep(ticks.step);
    ticks.values = Multiples(range, ticks.step);
  }

  const double magnitude = std::max(std::abs(range.min), std::abs(range.max));
  const int e = static_cast<int>(std::floor(std::log10(magnitude)));
  if (e > kMaxPlainExponent || e < kMinPlainExponent) ticks.exponent = e;
  const double scaled_step = ticks.step / std::pow(10.0, ticks.exponent);
  ticks.decimals = std::max(0, static_cast<int>(std::ceil(-std::log10(scaled_step) - 1e-9)));
  return ticks;
}

std::string FormatTick(double value, const Ticks& ticks) {
  const double scaled = value / std::pow(10.0, ticks.exponent);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", ticks.decimals, scaled);
  std::string s = buf;
  // "-0", "-0.00": a rounding artefact, not a negative number.
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

std::string FormatValue(double value) {
  if (std::isnan(value)) return "missing";
  if (std::isinf(value)) return "not finite";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", value);
  return buf;
}

}  // namespace gb::report
