// CUSUM tests against published ARLs (Lucas & Crosier 1982 and Montgomery for the mean test,
// Brook & Evans 1972 and Waldmann 1986, Knoth 2006 for the CUSUM-S²), Siegmund's approximation,
// Monte Carlo run lengths and alarm rates on simulated innovations, and the quadrature's own
// convergence.
// Sections: helpers, increments, published ARLs, convergence, Monte Carlo, design, detector.
#include "core/online/cusum.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <boost/math/distributions/normal.hpp>
#include <gtest/gtest.h>

#include "core/sim/random.h"

namespace gb::online {
namespace {

// ---- helpers -----------------------------------------------------------------------------------

constexpr CusumChange kMeanUp{CusumKind::kMeanUp, 1.0};
constexpr CusumChange kMeanDown{CusumKind::kMeanDown, 1.0};
constexpr CusumChange kVarianceUp{CusumKind::kVarianceUp, 2.0};
constexpr double kMonteCarloSigmas = 3.0;

// Two one-sided schemes run together: their alarm rates add, 1/L = 1/L+ + 1/L-.
double TwoSided(double up, double down) { return 1.0 / (1.0 / up + 1.0 / down); }

// The variance ratio ρ whose CUSUM-S² reference value log ρ / (1 - 1/ρ) is k (increasing in ρ).
double RatioForReference(double k) {
  double lo = 1.0 + 1e-9, hi = 100.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (std::log(mid) / (1.0 - 1.0 / mid) < k ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Siegmund's approximation of the one-sided ARL of C_t = max(0, C_{t-1} + z_t - k), alarm at
// C_t > h, z ~ N(μ, 1): (exp(-2Δb) + 2Δb - 1) / (2Δ²), Δ = μ - k, b = h + 1.166.
double Siegmund(double mu, double k, double h) {
  const double delta = mu - k, b = h + 1.166;
  if (std::abs(delta) < 1e-12) return b * b;
  return (std::exp(-2.0 * delta * b) + 2.0 * delta * b - 1.0) / (2.0 * delta * delta);
}

CusumDesign HandDesign(int outputs, double h_mean, double h_variance) {
  CusumDesign design;
  design.outputs = outputs;
  design.statistics = kCusumKinds * outputs;
  design.mean_shift = 1.0;
  design.variance_ratio = 2.0;
  design.h_mean = h_mean;
  design.h_variance = h_variance;
  return design;
}

struct RunLengths {
  double mean = 0.0;
  double standard_error = 0.0;
  long long runs = 0;
};

// Feeds `samples` innovations z ~ N(mean, variance) to one output of a detector and returns, per
// test, the mean time between its alarms: each statistic restarts at 0 after its alarm, so its
// run lengths are i.i.d. with mean L(0).
std::array<RunLengths, kCusumKinds> SimulateRunLengths(const CusumDesign& design,
                                                       const Innovations& truth, long samples,
                                                       std::uint64_t seed) {
  CusumDetector detector(design);
  sim::NormalRng rng(seed);
  const double sd = std::sqrt(truth.variance);
  std::array<long, kCusumKinds> last{};
  std::array<double, kCusumKinds> sum{}, sum2{};
  std::array<RunLengths, kCusumKinds> out;
  for (long t = 1; t <= samples; ++t) {
    for (const CusumAlarm& alarm : detector.Update(0, truth.mean + sd * rng.Normal())) {
      const int k = static_cast<int>(alarm.kind);
      const double run = static_cast<double>(t - last[k]);
      last[k] = t;
      sum[k] += run;
      sum2[k] += run * run;
      ++out[k].runs;
    }
  }
  for (int k = 0; k < kCusumKinds; ++k) {
    const double n = static_cast<double>(out[k].runs);
    out[k].mean = sum[k] / n;
    out[k].standard_error = std::sqrt((sum2[k] / n - out[k].mean * out[k].mean) / (n - 1.0));
  }
  return out;
}

// ---- increments --------------------------------------------------------------------------------

TEST(Cusum, IncrementsAreLogLikelihoodRatios) {
  using boost::math::normal;
  using boost::math::pdf;
  const double delta = 0.7, rho = 2.5;
  for (double z : {-2.5, -0.3, 0.0, 1.7, 4.0}) {
    const double f0 = pdf(normal(0.0, 1.0), z);
    EXPECT_NEAR(CusumIncrement({CusumKind::kMeanUp, delta}, z),
                std::log(pdf(normal(delta, 1.0), z) / f0), 1e-12);
    EXPECT_NEAR(CusumIncrement({CusumKind::kMeanDown, delta}, z),
                std::log(pdf(normal(-delta, 1.0), z) / f0), 1e-12);
    EXPECT_NEAR(CusumIncrement({CusumKind::kVarianceUp, rho}, z),
                std::log(pdf(normal(0.0, std::sqrt(rho)), z) / f0), 1e-12);
  }
}

TEST(Cusum, MeanTestIsTheTabularCusumScaledByDelta) {
  // S_t = δ C_t for C_t = max(0, C_{t-1} + z_t - δ/2): the header's relation to k and H.
  const double delta = 0.8, big = 1e9;  // thresholds that never alarm
  CusumDesign design = HandDesign(1, big, big);
  design.mean_shift = delta;
  CusumDetector detector(design);
  sim::NormalRng rng(7);
  double c = 0.0;
  for (int t = 0; t < 200; ++t) {
    const double z = 0.3 + rng.Normal();
    c = std::max(0.0, c + z - 0.5 * delta);
    detector.Update(0, z);
    ASSERT_NEAR(detector.Statistic(0, CusumKind::kMeanUp) * big, delta * c, 1e-9);
  }
}

// ---- published ARLs ----------------------------------------------------------------------------

TEST(Cusum, ArlMatchesPublishedTablesForKHalf) {
  // Two-sided tabular CUSUM, k = 0.5, z ~ N(μ, 1). Lucas & Crosier (1982), Technometrics 24,
  // Table 1, h = 4 (as quoted in the documentation of the R package spc, xcusum.arl; the same
  // column is Montgomery's table of tabular-CUSUM ARLs for k = 1/2); Montgomery, Introduction to
  // Statistical Quality Control, same table, h = 5: 465 in control and 10.4 for a 1σ shift.
  // These are TWO-sided: the one-sided ARL0 is twice as long (335.4 and 930.9).
  struct Published {
    double h, mu, arl;
  };
  const Published table[] = {{4, 0.00, 168},  {4, 0.25, 74.2}, {4, 0.50, 26.6}, {4, 0.75, 13.3},
                             {4, 1.00, 8.38}, {4, 1.50, 4.75}, {4, 2.00, 3.34}, {4, 2.50, 2.62},
                             {4, 3.00, 2.19}, {4, 4.00, 1.71}, {4, 5.00, 1.31}, {5, 0.00, 465},
                             {5, 1.00, 10.4}};
  for (const Published& p : table) {
    const double up = AverageRunLength(kMeanUp, p.h, {p.mu, 1.0});
    const double down = AverageRunLength(kMeanDown, p.h, {p.mu, 1.0});
    // Three significant digits: within half a unit of the last one.
    const double last_digit = std::pow(10.0, std::floor(std::log10(p.arl)) - 2.0);
    EXPECT_NEAR(TwoSided(up, down), p.arl, 0.5 * last_digit) << "h = " << p.h << ", μ = " << p.mu;
  }
  // One-sided, k = 0.5, h = 3: Brook & Evans (1972), Biometrika 59, section 4.3: 117.59 in
  // control, 3.75 at μ = 1.5 (a Markov chain, good to about 1e-4); Waldmann (1986), Technometrics
  // 28, Tables 3 and 5: 1963 at μ = -0.5, 17.35 at μ = 0.5.
  EXPECT_NEAR(AverageRunLength(kMeanUp, 3.0), 117.59, 0.02);
  EXPECT_NEAR(AverageRunLength(kMeanUp, 3.0, {1.5, 1.0}), 3.75, 0.005);
  EXPECT_NEAR(AverageRunLength(kMeanUp, 3.0, {-0.5, 1.0}), 1963, 0.5);
  EXPECT_NEAR(AverageRunLength(kMeanUp, 3.0, {0.5, 1.0}), 17.35, 0.005);
}

TEST(Cusum, ArlIsCloseToSiegmundsApproximation) {
  // A loose, independent cross-check: Siegmund's formula is good to about 1% for |μ - k| <= ½.
  for (double h : {4.0, 5.0, 8.0}) {
    for (double mu : {0.0, 0.5, 1.0}) {
      const double arl = AverageRunLength(kMeanUp, h, {mu, 1.0});
      EXPECT_NEAR(arl / Siegmund(mu, 0.5, h), 1.0, 0.015) << "h = " << h << ", μ = " << mu;
    }
  }
}

TEST(Cusum, VarianceArlMatchesKnothsCollocation) {
  // Knoth (2006), Computational Statistics & Data Analysis 51, Table 1 (column coll63, quoted in
  // the documentation of the R package spc, scusum.arl): the upper CUSUM-S² for one degree of
  // freedom, C_t = max(0, C_{t-1} + z_t² - k), k = 1.46, h = 10, z ~ N(0, σ²). Here
  // k = log ρ / (1 - 1/ρ) and h = 10 · ½ (1 - 1/ρ) in S units (see the header).
  const double rho = RatioForReference(1.46);
  const double h = 10.0 * 0.5 * (1.0 - 1.0 / rho);
  struct Published {
    double sigma, arl;
  };
  const Published table[] = {{1.0, 260.7369}, {1.1, 90.1319}, {1.2, 43.6867}, {1.3, 26.2916},
                             {1.4, 18.1231},  {1.5, 13.6268}, {2.0, 5.9904}};
  for (const Published& p : table) {
    // Published to four decimals: within one unit of the last (their own error, by their Monte
    // Carlo check, is of that order).
    EXPECT_NEAR(AverageRunLength({CusumKind::kVarianceUp, rho}, h, {0.0, p.sigma * p.sigma}), p.arl,
                1e-4)
        << "σ = " << p.sigma;
  }
}

// ---- convergence -------------------------------------------------------------------------------

TEST(Cusum, ArlChangesByLessThan1e6WhenTheNodesDouble) {
  ArlOptions coarse, fine;
  coarse.nodes_per_piece = 12;
  fine.nodes_per_piece = 24;
  struct Case {
    CusumChange change;
    double h;
    Innovations truth;
  };
  const Case cases[] = {{kMeanUp, 5.0, {}},
                        {kMeanUp, 5.0, {1.0, 1.0}},
                        {kMeanUp, 20.0, {}},
                        {{CusumKind::kMeanDown, 0.5}, 8.0, {0.2, 1.5}},
                        {kVarianceUp, 8.0, {}},
                        {kVarianceUp, 8.0, {0.0, 2.0}},
                        {kVarianceUp, 4.0, {0.5, 1.2}}};
  for (const Case& c : cases) {
    const double a = AverageRunLength(c.change, c.h, c.truth, coarse);
    const double b = AverageRunLength(c.change, c.h, c.truth, fine);
    EXPECT_NEAR(a / b, 1.0, 1e-6) << CusumKindName(c.change.kind) << " h = " << c.h
                                  << " ARL = " << b;
  }
}

// ---- Monte Carlo -------------------------------------------------------------------------------

TEST(Cusum, MonteCarloRunLengthsMatchTheArl) {
  // Both mean tests at h = 4 (ARL0 335) and the variance test at h = 3 (ARL0 about 400), in
  // control and after a change, checked within kMonteCarloSigmas standard errors.
  const CusumDesign design = HandDesign(1, 4.0, 3.0);
  const std::array<CusumChange, kCusumKinds> changes{kMeanUp, kMeanDown, kVarianceUp};
  const std::array<double, kCusumKinds> h{4.0, 4.0, 3.0};

  const auto in_control = SimulateRunLengths(design, {}, 2'000'000, 11);
  for (int k = 0; k < kCusumKinds; ++k) {
    const double arl = AverageRunLength(changes[k], h[k]);
    EXPECT_GT(in_control[k].runs, 3000);
    EXPECT_NEAR(in_control[k].mean, arl, kMonteCarloSigmas * in_control[k].standard_error)
        << CusumKindName(changes[k].kind) << " in control";
  }
  const Innovations shifted{1.0, 1.0}, wider{0.0, 2.0};
  const auto after_shift = SimulateRunLengths(design, shifted, 200'000, 12);
  EXPECT_NEAR(after_shift[0].mean, AverageRunLength(kMeanUp, 4.0, shifted),
              kMonteCarloSigmas * after_shift[0].standard_error);
  const auto after_widening = SimulateRunLengths(design, wider, 200'000, 13);
  EXPECT_NEAR(after_widening[2].mean, AverageRunLength(kVarianceUp, 3.0, wider),
              kMonteCarloSigmas * after_widening[2].standard_error);
}

// ---- design ------------------------------------------------------------------------------------

TEST(Cusum, ThresholdGivesBackTheTargetArl) {
  for (const CusumChange& change : {kMeanUp, kVarianceUp}) {
    for (double target : {500.0, 1e6}) {
      const Result<double> h = ThresholdForArl0(change, target);
      ASSERT_TRUE(h.ok()) << h.error().message;
      EXPECT_NEAR(AverageRunLength(change, *h) / target, 1.0, 1e-6)
          << CusumKindName(change.kind) << " " << target;
      EXPECT_GE(target, std::exp(*h));  // ARL0 >= e^h for an LLR CUSUM
    }
  }
  // The mean tests are mirror images.
  EXPECT_NEAR(*ThresholdForArl0(kMeanDown, 500.0), *ThresholdForArl0(kMeanUp, 500.0), 1e-8);
}

TEST(Cusum, ThresholdRefusesTargetsOutOfReach) {
  // With h -> 0+ the mean-up test alarms at the first z > δ/2: after 1/P(z > ½) = 3.24 samples.
  const Result<double> too_short = ThresholdForArl0(kMeanUp, 3.0);
  ASSERT_FALSE(too_short.ok());
  EXPECT_NE(too_short.error().message.find("out of reach"), std::string::npos);
  EXPECT_TRUE(ThresholdForArl0(kMeanUp, 3.3).ok());
  EXPECT_FALSE(ThresholdForArl0(kMeanUp, 2.0 * kMaxArl0).ok());
  EXPECT_FALSE(ThresholdForArl0({CusumKind::kMeanUp, 0.0}, 500.0).ok());
  EXPECT_FALSE(ThresholdForArl0({CusumKind::kVarianceUp, 1.0}, 500.0).ok());
}

TEST(Cusum, DesignedDetectorAlarmsAtTheSetRateOnWhiteNoise) {
  // 3600 false alarms per hour over 2 outputs sampled at 100 Hz: 6 statistics at 600 per hour
  // each, ARL0 = 3600 · 6 / (3600 · 0.01) = 600 samples.
  CusumOptions options;
  options.outputs = 2;
  options.sample_time = 0.01;
  options.false_alarms_per_hour = 3600.0;
  const Result<CusumDesign> design = DesignCusum(options);
  ASSERT_TRUE(design.ok()) << design.error().message;
  EXPECT_EQ(design->statistics, 6);
  EXPECT_NEAR(design->arl0, 600.0, 1e-9);
  EXPECT_GT(design->arl1_mean, 1.0);
  EXPECT_LT(design->arl1_mean, 20.0);
  EXPECT_NE(design->Report().find("Variance test"), std::string::npos);

  // The alarm count in batches of the run: their spread gives the standard error without assuming
  // the statistics independent (the two mean tests and the variance test share each z).
  constexpr int kBatches = 20;
  constexpr long kSamplesPerBatch = 10'000;
  CusumDetector detector(*design);
  sim::NormalRng rng(21);
  std::vector<double> batch_rate(kBatches);
  long long samples_with_alarm = 0;
  for (int b = 0; b < kBatches; ++b) {
    const long long before = detector.AlarmCount();
    for (long t = 0; t < kSamplesPerBatch; ++t) {
      bool any = false;
      for (int output = 0; output < options.outputs; ++output)
        any = detector.Update(output, rng.Normal()).any() || any;
      samples_with_alarm += any;
    }
    const double hours = kSamplesPerBatch * options.sample_time / 3600.0;
    batch_rate[b] = static_cast<double>(detector.AlarmCount() - before) / hours;
  }
  double mean = 0.0, var = 0.0;
  for (double r : batch_rate) mean += r / kBatches;
  for (double r : batch_rate) var += (r - mean) * (r - mean) / (kBatches - 1);
  const double standard_error = std::sqrt(var / kBatches);
  // The expected count over all statistics is the set rate; fewer samples carry an alarm.
  EXPECT_LE(mean, options.false_alarms_per_hour + kMonteCarloSigmas * standard_error);
  EXPECT_GE(mean, options.false_alarms_per_hour - kMonteCarloSigmas * standard_error);
  EXPECT_LE(samples_with_alarm, detector.AlarmCount());
}

TEST(Cusum, DesignRefusesRatesItCannotMeet) {
  CusumOptions options;
  options.false_alarms_per_hour = 1e6;  // ARL0 = 0.86 samples
  Result<CusumDesign> design = DesignCusum(options);
  ASSERT_FALSE(design.ok());
  EXPECT_NE(design.error().message.find("out of reach"), std::string::npos);
  options.false_alarms_per_hour = 1e-12;  // ARL0 = 8.6e17 samples
  EXPECT_FALSE(DesignCusum(options).ok());
  for (auto spoil : std::vector<void (*)(CusumOptions&)>{
           [](CusumOptions& o) { o.outputs = 0; }, [](CusumOptions& o) { o.sample_time = -1; },
           [](CusumOptions& o) { o.false_alarms_per_hour = 0; },
           [](CusumOptions& o) { o.mean_shift = 0.05; },
           [](CusumOptions& o) { o.variance_ratio = 1.05; },
           [](CusumOptions& o) { o.arl.nodes_per_piece = 1; }}) {
    CusumOptions bad;
    spoil(bad);
    std::string why;
    EXPECT_FALSE(bad.IsValid(&why));
    EXPECT_FALSE(why.empty());
    EXPECT_FALSE(DesignCusum(bad).ok());
  }
}

// ---- detector ----------------------------------------------------------------------------------

TEST(Cusum, DetectorReportsWhichTestAlarmed) {
  CusumDetector detector(HandDesign(2, 4.0, 5.0));
  const double s_variance_2 = 0.5 * std::log(0.5) + 0.5 * 4.0 * 0.5;  // z = 2, ρ = 2

  EXPECT_FALSE(detector.Update(1, 2.0).any());  // mean up: 2 - ½ = 1.5
  EXPECT_DOUBLE_EQ(detector.Statistic(1, CusumKind::kMeanUp), 1.5 / 4.0);
  EXPECT_EQ(detector.Statistic(1, CusumKind::kMeanDown), 0.0);
  EXPECT_DOUBLE_EQ(detector.Statistic(1, CusumKind::kVarianceUp), s_variance_2 / 5.0);
  EXPECT_EQ(detector.Statistic(0, CusumKind::kMeanUp), 0.0);

  // A missing observation changes nothing.
  EXPECT_FALSE(detector.Update(1, std::nan("")).any());
  EXPECT_DOUBLE_EQ(detector.Statistic(1, CusumKind::kMeanUp), 1.5 / 4.0);

  // z = 5: mean up 1.5 + 4.5 = 6 > 4; variance up s_variance_2 + ½ log ½ + ½ · 25 · ½ > 5.
  const CusumAlarms alarms = detector.Update(1, 5.0);
  ASSERT_EQ(alarms.count, 2);
  EXPECT_EQ(alarms.alarm[0].output, 1);
  EXPECT_STREQ(alarms.alarm[0].name(), "mean up");
  EXPECT_DOUBLE_EQ(alarms.alarm[0].statistic, 6.0 / 4.0);
  EXPECT_STREQ(alarms.alarm[1].name(), "variance up");
  EXPECT_EQ(detector.Statistic(1, CusumKind::kMeanUp), 0.0);  // restarted
  EXPECT_EQ(detector.AlarmCount(), 2);
  EXPECT_EQ(detector.AlarmCount(1, CusumKind::kMeanUp), 1);
  EXPECT_EQ(detector.AlarmCount(0, CusumKind::kMeanUp), 0);

  const CusumAlarms down = detector.Update(0, -10.0);
  ASSERT_EQ(down.count, 2);
  EXPECT_STREQ(down.alarm[0].name(), "mean down");
  EXPECT_EQ(down.alarm[0].output, 0);

  // A diverged filter's infinite innovation alarms.
  const CusumAlarms infinite = detector.Update(0, std::numeric_limits<double>::infinity());
  ASSERT_EQ(infinite.count, 2);
  EXPECT_STREQ(infinite.alarm[0].name(), "mean up");
  EXPECT_STREQ(infinite.alarm[1].name(), "variance up");

  detector.Reset();
  EXPECT_EQ(detector.AlarmCount(), 0);
  for (int output = 0; output < 2; ++output)
    for (CusumKind kind : {CusumKind::kMeanUp, CusumKind::kMeanDown, CusumKind::kVarianceUp})
      EXPECT_EQ(detector.Statistic(output, kind), 0.0);
}

}  // namespace
}  // namespace gb::online
