// The virtual dyno against closed forms and its own truth.
#include "core/sim/dyno.h"

#include <cmath>

#include <gtest/gtest.h>

namespace gb::sim {
namespace {

TEST(Dyno, HasTheSixOperatingPointsOfTable2) {
  ASSERT_EQ(PaperFuelPoints().size(), 6u);
  const auto f1 = FindFuelPoint("f1");
  ASSERT_TRUE(f1.ok());
  EXPECT_EQ(f1->speed_rpm, 2931);
  EXPECT_EQ(f1->delay_s, 0.0625);
  EXPECT_EQ(f1->s2, 1.2570e-4);  // σ2² · 10⁻⁴ as printed
  EXPECT_FALSE(FindFuelPoint("f5").ok());
}

TEST(Dyno, DelayFallsWithSpeedAsFittedToTable2) {
  // c = Σ(Δt/n) / Σ(1/n²) by brute force.
  double num = 0, den = 0;
  for (const auto& p : PaperFuelPoints()) num += p.delay_s / p.speed_rpm, den += 1 / (p.speed_rpm * p.speed_rpm);
  EXPECT_NEAR(ExhaustDelay(3000), num / den / 3000, 1e-15);
  EXPECT_GT(ExhaustDelay(2600), ExhaustDelay(3600));
}

TEST(Dyno, NoiseFreeUnfilteredFuelRecordFollowsTheFilmModelExactly) {
  // Without noise and filters, a step of the injected fuel reaches 1/λ after the delay as the sum
  // of two first-order responses: Kb [(1-X)(1 - e^{-t/τfv}) + X (1 - e^{-t/τff})] · step.
  FuelExperiment e;
  e.point = *FindFuelPoint("f1");
  e.point.s11 = e.point.s12 = e.point.s2 = 0;
  e.recording.filter_hz = 0;
  e.duration = 3.0;
  auto rec = RunFuelExperiment(e);
  ASSERT_TRUE(rec.ok()) << rec.error().ToString();
  const auto& t = rec->columns[0];
  const auto& u = rec->columns[1];
  const auto& y = rec->columns[2];
  const double bias = 1 / e.point.Kb;
  const double first = u[0] - bias;  // the first PRBS level, applied from t = 0
  const int d = static_cast<int>(std::lround(e.point.delay_s / e.recording.sample_time));
  for (int k = 0; k < 30; ++k) {
    // Up to the first PRBS switch (0.5 s = 40 samples) the response is a single step.
    const double tau = t[k] - e.point.delay_s;
    const double expected =
        1.0 + (tau <= 0 ? 0.0
                        : e.point.Kb * first *
                              ((1 - e.point.X) * -std::expm1(-tau / e.point.tau_fv) +
                               e.point.X * -std::expm1(-tau / e.point.tau_ff)));
    EXPECT_NEAR(y[k], expected, 1e-12) << "sample " << k << " (delay " << d << ")";
  }
}

TEST(Dyno, AntiAliasFilterKeepsTheMeanLevelOfTheInput) {
  // Unit gain at DC: over a record the filtered input has the raw input's mean level.
  FuelExperiment e;
  e.point = *FindFuelPoint("f4");
  e.point.s11 = e.point.s12 = e.point.s2 = 0;
  e.duration = 5.0;
  auto filtered = RunFuelExperiment(e);
  e.recording.filter_hz = 0;
  auto raw = RunFuelExperiment(e);
  ASSERT_TRUE(filtered.ok() && raw.ok());
  double sum_f = 0, sum_r = 0;
  for (std::size_t k = 0; k < raw->columns[1].size(); ++k)
    sum_f += filtered->columns[1][k], sum_r += raw->columns[1][k];
  EXPECT_NEAR(sum_f / sum_r, 1.0, 5e-3);
}

}  // namespace
}  // namespace gb::sim
