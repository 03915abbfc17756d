#include "core/design/prbs.h"

#include <gtest/gtest.h>

namespace gb::design {
namespace {

// The smallest p > 0 with bits[i + p] == bits[i] for all i (brute force over two periods).
std::size_t Period(const std::vector<std::uint8_t>& bits, std::size_t max_period) {
  for (std::size_t p = 1; p <= max_period; ++p) {
    bool repeats = true;
    for (std::size_t i = 0; i + p < bits.size() && repeats; ++i) repeats = bits[i] == bits[i + p];
    if (repeats) return p;
  }
  return 0;
}

TEST(Prbs, IsMaximalLengthAndBalancedForEveryOrderOffered) {
  for (int n = kMinPrbsOrder; n <= kMaxPrbsOrder; ++n) {
    const std::size_t period = (std::size_t{1} << n) - 1;
    const auto bits = PrbsBits(n, 1, 2 * period + 1);
    if (n <= 16) {
      EXPECT_EQ(Period(bits, period), period) << "order " << n;
    } else {
      // Too long to search every shorter period: check that the register returns to its start
      // exactly after 2^n - 1 steps and not after any proper divisor of it.
      for (std::size_t i = 0; i < period + 1; ++i) ASSERT_EQ(bits[i], bits[i + period]) << n;
      for (std::size_t d = 1; d < period; ++d) {
        if (period % d) continue;
        bool repeats = true;
        for (std::size_t i = 0; i + d < bits.size() && repeats; ++i)
          repeats = bits[i] == bits[i + d];
        EXPECT_FALSE(repeats) << "order " << n << " repeats after " << d;
      }
    }
    std::size_t ones = 0;
    for (std::size_t i = 0; i < period; ++i) ones += bits[i];
    EXPECT_EQ(ones, (period + 1) / 2) << "order " << n << ": 2^(n-1) ones per period";
  }
}

TEST(Prbs, SwitchesOnlyAtBitBoundariesAndCoversTheDuration) {
  PrbsOptions o;
  o.order = 6;
  o.bit_period = 0.5;
  o.sample_time = 0.0125;
  o.duration = 10;
  o.low = 1.08;
  o.high = 1.32;
  auto s = MakePrbs(o);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->t.size(), 800u);
  EXPECT_EQ(s->t[3], 0.0375);  // printed as written, not 0.037500000000000006
  for (std::size_t k = 1; k < s->u.size(); ++k) {
    if (s->u[k] != s->u[k - 1]) {
      EXPECT_EQ(k % 40, 0u) << "switch inside a bit at sample " << k;
    }
    EXPECT_TRUE(s->u[k] == 1.08 || s->u[k] == 1.32);
  }
  EXPECT_DOUBLE_EQ(PrbsPeriod(6, 0.5), 31.5);
  const auto range = EstimableTimeConstants(6, 0.5);
  EXPECT_DOUBLE_EQ(range.shortest, 0.05);
  EXPECT_DOUBLE_EQ(range.longest, 6.0);
}

TEST(Prbs, RefusesSettingsThatCannotWork) {
  PrbsOptions o;
  o.order = 1;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("--order 1"), std::string::npos);
  o.order = 6;
  o.bit_period = 0.001;
  o.sample_time = 0.01;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("shorter than the sample time"), std::string::npos);
  o.bit_period = 0.01;
  o.duration = 1e-300;  // was a file of no rows
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("--duration 1e-300 at --ts 0.01 gives no sample"), std::string::npos) << why;
}

}  // namespace
}  // namespace gb::design
