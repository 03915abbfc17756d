#include "ui/widgets/plot_axis.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace gb::ui::plot {
namespace {

// The step's mantissa, recovered independently of how NiceTicks computed it.
double Mantissa(double step) { return step / std::pow(10.0, std::floor(std::log10(step) + 1e-9)); }

TEST(NiceTicks, StepIsOneTwoOrFiveTimesAPowerOfTen) {
  for (double span : {1e-7, 3.3e-3, 0.047, 1.0, 7.0, 47.3, 999.0, 2.5e6}) {
    for (int max_ticks : {2, 4, 7, 12}) {
      const Ticks t = NiceTicks({-0.3 * span, 0.7 * span}, max_ticks);
      const double m = Mantissa(t.step);
      EXPECT_TRUE(std::abs(m - 1) < 1e-9 || std::abs(m - 2) < 1e-9 || std::abs(m - 5) < 1e-9)
          << "span " << span << " step " << t.step;
    }
  }
}

TEST(NiceTicks, TicksAreInsideTheRangeEquallySpacedAndAtMostAsMany) {
  const Range r{-3.7, 12.2};
  for (int max_ticks = 2; max_ticks < 15; ++max_ticks) {
    const Ticks t = NiceTicks(r, max_ticks);
    ASSERT_GE(t.values.size(), 3u);
    EXPECT_LE(static_cast<int>(t.values.size()), std::max(max_ticks, kMinTicks));
    for (std::size_t i = 0; i < t.values.size(); ++i) {
      EXPECT_TRUE(r.Contains(t.values[i]));
      if (i > 0) {
        EXPECT_NEAR(t.values[i] - t.values[i - 1], t.step, 1e-12);
      }
    }
    // No room for another tick on either side.
    EXPECT_LT(t.values.front() - t.step, r.min);
    EXPECT_GT(t.values.back() + t.step, r.max);
  }
}

// Every 1-2-5 step from 1e-12 to 1e12 and the number of its multiples inside `r`, by brute force.
std::vector<std::pair<double, int>> AllStepsAndCounts(Range r) {
  std::vector<std::pair<double, int>> out;
  for (int e = -12; e <= 12; ++e) {
    for (double m : {1.0, 2.0, 5.0}) {
      const double step = m * std::pow(10.0, e);
      const double n = std::floor(r.max / step + 1e-9) - std::ceil(r.min / step - 1e-9) + 1;
      out.emplace_back(step, static_cast<int>(std::clamp(n, 0.0, 1e9)));
    }
  }
  return out;
}

TEST(NiceTicks, NeverFewerThanThreeAndNoMoreThanAskedUnlessNoStepGivesThreeToThatMany) {
  // Found in the QQ and residual plots: a short axis with room for two labels got one; every
  // axis now shows at least three.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> centre(-5.0, 5.0), log_span(-6.0, 6.0);
  for (int trial = 0; trial < 2000; ++trial) {
    const double span = std::pow(10.0, log_span(rng));
    const double lo = centre(rng) * span;
    const Range r{lo, lo + span};
    for (int max_ticks = 2; max_ticks <= 6; ++max_ticks) {
      const Ticks t = NiceTicks(r, max_ticks);
      ASSERT_GE(t.values.size(), 3u) << r.min << " " << r.max << " max " << max_ticks;
      bool some_step_fits = false;
      for (const auto& [step, n] : AllStepsAndCounts(r))
        if (n >= 3 && n <= max_ticks) some_step_fits = true;
      if (some_step_fits) {
        EXPECT_LE(static_cast<int>(t.values.size()), max_ticks) << r.min << " " << r.max;
      }
      // Over the limit only when no larger step gives three ticks.
      if (static_cast<int>(t.values.size()) > std::max(max_ticks, 3)) {
        for (const auto& [step, n] : AllStepsAndCounts(r)) {
          if (step > t.step * (1 + 1e-9)) {
            EXPECT_LT(n, 3) << "step " << step << " gives " << n;
          }
        }
      }
    }
  }
  const Ticks short_axis = NiceTicks({0.13, 0.71}, 2);  // step 1 fits no tick; 0.5 one; 0.2 three
  EXPECT_EQ(short_axis.values.size(), 3u);
}

TEST(NiceTicks, TimeAxisOfFortySevenSeconds) {
  const Ticks t = NiceTicks({0.0, 47.3}, 6);
  EXPECT_DOUBLE_EQ(t.step, 10.0);
  EXPECT_EQ(t.values, (std::vector<double>{0, 10, 20, 30, 40}));
  EXPECT_EQ(FormatTick(20.0, t), "20");
}

TEST(NiceTicks, EmptyOrInvalidRangesGiveNoTicks) {
  EXPECT_TRUE(NiceTicks({1.0, 1.0}, 5).values.empty());
  EXPECT_TRUE(NiceTicks({2.0, 1.0}, 5).values.empty());
  EXPECT_TRUE(NiceTicks({0.0, NAN}, 5).values.empty());
  EXPECT_TRUE(NiceTicks({-INFINITY, 0.0}, 5).values.empty());
}

TEST(FormatTick, LabelsOfOneAxisAreDistinctAndNeverNegativeZero) {
  const Range ranges[] = {{-1e-6, 3e-6}, {-0.35, 0.35},    {0.0, 1.0}, {999.0, 1001.0},
                          {-2.5e7, 1e7}, {1e5, 1e5 + 0.5}, {-1.0, 1.0}};
  for (const Range& r : ranges) {
    const Ticks t = NiceTicks(r, 9);
    std::set<std::string> labels;
    for (double v : t.values) {
      const std::string s = FormatTick(v, t);
      EXPECT_NE(s, "-0") << r.min << " " << r.max;
      EXPECT_TRUE(labels.insert(s).second) << "duplicate label " << s;
      // The label, times the shared power of ten, reads back as the tick value.
      EXPECT_NEAR(std::stod(s) * std::pow(10.0, t.exponent), v, 1e-9 * t.step * 1e3);
    }
  }
}

TEST(FormatTick, SmallMagnitudesShareAPowerOfTen) {
  const Ticks t = NiceTicks({0.0, 2.4e-5}, 6);
  EXPECT_EQ(t.exponent, -5);
  EXPECT_EQ(FormatTick(1.5e-5, t), "1.5");
}

TEST(FormatValue, SixSignificantDigitsAndMissing) {
  EXPECT_EQ(FormatValue(0.0123456789), "0.0123457");
  EXPECT_EQ(FormatValue(NAN), "missing");
}

}  // namespace
}  // namespace gb::ui::plot
