// The virtual dyno against closed forms and its own truth.
#include "core/sim/dyno.h"

#include <cmath>
#include <string>

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
  for (const auto& p : PaperFuelPoints())
    num += p.delay_s / p.speed_rpm, den += 1 / (p.speed_rpm * p.speed_rpm);
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

TEST(Dyno, SquareWaveSensorFollowsTheFilmsClosedFormAfterTheDelay) {
  // Without noise and filters, 1/λ(t) = K_b ((1-X) mfi(t-D) + mff(t-D)) with D the delay on the
  // fine grid; after the switch from low to high at T/2 the film rises as a first-order step
  // response: mff = X (low + (high-low)(1 - e^{-(t-T/2)/τff})). The port's history is a ring of
  // D/h + 1 fine steps, not the whole record.
  SquareWaveTest e;
  e.s12 = e.s2 = 0;
  e.recording.filter_hz = 0;
  e.duration = 4.0;  // the first period: low until 2 s, high after
  auto rec = RunSquareWaveTest(e);
  ASSERT_TRUE(rec.ok()) << rec.error().ToString();
  const double h = e.recording.sample_time / e.recording.oversample;
  const double D = static_cast<double>(std::lround(ExhaustDelay(e.speed_rpm) / h)) * h;
  const double bias = 1 / e.Kb, low = bias * (1 - e.amplitude), high = bias * (1 + e.amplitude);
  const double half = e.period / 2;
  const auto& t = rec->columns[0];
  const auto& y = rec->columns[2];
  ASSERT_EQ(t.size(), 320u);
  for (std::size_t k = 0; k < t.size(); ++k) {
    const double s = t[k] - D;  // the time the sensor reads
    const double mfi = s < half - 1e-9 ? low : high;
    const double mff = s < half - 1e-9
                           ? e.X * low
                           : e.X * (low + (high - low) * -std::expm1(-(s - half) / e.tau_ff));
    EXPECT_NEAR(y[k], e.Kb * ((1 - e.X) * mfi + mff), 1e-12) << "t = " << t[k];
  }
}

TEST(Dyno, RecordThatIsNotFiniteIsANumericalErrorNamingItsTimeAndColumn) {
  // A film time constant of 1e-320 s overflows the discretisation: the record is refused, not
  // returned with NaN rows.
  FuelExperiment e;
  e.point = *FindFuelPoint("f1");
  e.point.tau_ff = 1e-320;
  e.duration = 1.0;
  auto rec = RunFuelExperiment(e);
  ASSERT_FALSE(rec.ok());
  EXPECT_EQ(rec.error().kind, ErrorKind::kNumerical);
  EXPECT_NE(
      rec.error().message.find("fuel experiment: the simulated record is not finite from t = 0 s"),
      std::string::npos)
      << rec.error().message;
  EXPECT_NE(rec.error().message.find("(row 1: ilambda is"), std::string::npos)
      << rec.error().message;
}

TEST(Dyno, RefusesARecordBeyondItsLimitsBeforeRunningIt) {
  std::string why;
  FuelExperiment fuel;
  fuel.point = *FindFuelPoint("f1");
  // 10 million samples at 80 Hz is 125 000 s; one sample more is refused.
  fuel.duration = kMaxSamples * 0.0125;
  fuel.recording.oversample = 1;
  EXPECT_TRUE(fuel.IsValid(&why)) << why;
  fuel.duration += 0.0125;
  EXPECT_FALSE(fuel.IsValid(&why));
  EXPECT_NE(why.find("at most 1e+07 are recorded (a duration of at most 125000 s)"),
            std::string::npos)
      << why;
  // The simulated world's steps: 1e8 at 80 Hz and oversample 1000 is 1250 s.
  fuel.recording.oversample = 1000;
  fuel.duration = 1250;
  EXPECT_TRUE(fuel.IsValid(&why)) << why;
  fuel.duration = 1250.0125;
  EXPECT_FALSE(fuel.IsValid(&why));
  EXPECT_NE(why.find("at most 1e+08 are taken"), std::string::npos) << why;
  for (const double d : {0.0, -1.0, 1e-12, std::nan(""), double{INFINITY}, 1e300}) {
    fuel.duration = d;
    EXPECT_FALSE(fuel.IsValid(&why)) << d;
  }
  // The fine step: at least 10 µs.
  CrankshaftExperiment shaft;
  shaft.recording.sample_time = 0.005;
  shaft.recording.oversample = 501;
  EXPECT_FALSE(shaft.IsValid(&why));
  EXPECT_NE(why.find("must be at least 1e-05 s"), std::string::npos) << why;
  shaft.recording.sample_time = INFINITY;
  EXPECT_FALSE(shaft.IsValid(&why));
  // The square wave checks its duration too (it allocated its fine steps' history before).
  SquareWaveTest square;
  square.duration = 1e300;
  auto rec = RunSquareWaveTest(square);
  ASSERT_FALSE(rec.ok());
  EXPECT_NE(rec.error().message.find("at most 1e+07 are recorded"), std::string::npos)
      << rec.error().message;
}

}  // namespace
}  // namespace gb::sim
