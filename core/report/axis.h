// Axis arithmetic for plots (the workbench's plot widget, the SVG figures of
// core/report/figure.h): "nice" tick positions (steps of 1, 2 or 5 times a power of ten) and
// their labels. Pure functions: no ImGui, no state.
//
//   ticks = NiceTicks({0.0, 47.3}, 6)   -> step 10: 0 10 20 30 40, decimals 0
//   ticks = NiceTicks({0.0, 2.4e-5}, 6) -> step 5e-6, shown as 0 0.5 1 1.5 2 with exponent -5
//
// A tick label never repeats another label of the same axis: the number of decimals follows
// the step. Very large or very small magnitudes share one power of ten (`exponent`), which
// the plot prints once at the end of the axis ("×10^-5").
#pragma once

#include <string>
#include <vector>

namespace gb::report {

struct Range {
  double min = 0.0;
  double max = 1.0;
  double Span() const { return max - min; }
  bool Contains(double v) const { return v >= min && v <= max; }
};

struct Ticks {
  std::vector<double> values;  // ascending, all inside the range
  double step = 1.0;
  int decimals = 0;  // digits after the decimal point, after scaling by 10^-exponent
  int exponent = 0;  // labels show value / 10^exponent; 0 = plain numbers
};

// Ticks at multiples of a 1-2-5 step inside `range`: the largest step that gives at most
// `max_ticks` of them (at least kMinTicks are asked for), except that every axis shows at least
// kMinTicks labels, so when that step gives fewer the step shrinks until kMinTicks fit (a short
// axis may then get more than max_ticks). A range that is empty, inverted or not finite gives no
// ticks.
inline constexpr int kMinTicks = 3;
Ticks NiceTicks(Range range, int max_ticks);

// The label of one tick value ("0.25", "-3", "1.5").
std::string FormatTick(double value, const Ticks& ticks);

// A value for readouts (hover, tables): 6 significant digits, no trailing zeros.
std::string FormatValue(double value);

}  // namespace gb::report
