// Residual diagnostics against brute-force computations written out here (plain sums, a naive
// O(N²) DFT, Yule-Walker solves, the closed-form chi-square tail for even degrees of freedom)
// and against Monte Carlo properties of white noise, AR(1) and a sinusoid in noise.
// Sections: references, ACF and PACF, CCF (and prewhitening), cumulated periodogram, Ljung-Box,
// normality, Diagnose and the verdict.
#include "core/diagnose/residuals.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "core/design/prbs.h"
#include "core/sim/random.h"

namespace gb::diagnose {
namespace {

// ---- references ------------------------------------------------------------------------------

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kExact = 1e-10;  // two computations of the same sums

std::vector<double> WhiteNoise(int n, std::uint64_t seed) {
  sim::NormalRng rng(seed);
  std::vector<double> x(n);
  for (double& v : x) v = rng.Normal();
  return x;
}

std::vector<double> Ar1(int n, double phi, std::uint64_t seed) {
  sim::NormalRng rng(seed);
  std::vector<double> x(n);
  x[0] = rng.Normal() / std::sqrt(1 - phi * phi);  // stationary start
  for (int t = 1; t < n; ++t) x[t] = phi * x[t - 1] + rng.Normal();
  return x;
}

double Mean(const std::vector<double>& x) {
  double s = 0;
  for (double v : x) s += v;
  return s / static_cast<double>(x.size());
}

// r(k) = Σ_{t=0}^{n-1-k} (x_t - x̄)(x_{t+k} - x̄) / Σ (x_t - x̄)²  (no missing values)
double NaiveAcf(const std::vector<double>& x, int k) {
  const double m = Mean(x);
  double num = 0, den = 0;
  for (std::size_t t = 0; t < x.size(); ++t) {
    den += (x[t] - m) * (x[t] - m);
    if (t + k < x.size()) num += (x[t] - m) * (x[t + k] - m);
  }
  return num / den;
}

// corr(x_{t+k}, u_t) = Σ_t (x_{t+k} - x̄)(u_t - ū) / sqrt(Σ (x - x̄)² Σ (u - ū)²)
double NaiveCcf(const std::vector<double>& x, const std::vector<double>& u, int k) {
  const double mx = Mean(x), mu = Mean(u);
  double num = 0, sx = 0, su = 0;
  const int n = static_cast<int>(x.size());
  for (int t = 0; t < n; ++t) {
    sx += (x[t] - mx) * (x[t] - mx);
    su += (u[t] - mu) * (u[t] - mu);
    if (t + k >= 0 && t + k < n) num += (x[t + k] - mx) * (u[t] - mu);
  }
  return num / std::sqrt(sx * su);
}

// The last coefficient of the AR(k) Yule-Walker fit: solve R φ = r with R_ij = r(|i-j|).
double YuleWalkerLast(const std::vector<double>& x, int k) {
  Eigen::MatrixXd R(k, k);
  Eigen::VectorXd r(k);
  for (int i = 0; i < k; ++i) {
    r(i) = NaiveAcf(x, i + 1);
    for (int j = 0; j < k; ++j) R(i, j) = i == j ? 1.0 : NaiveAcf(x, std::abs(i - j));
  }
  return R.partialPivLu().solve(r)(k - 1);
}

// I(f_j) = (2/N) [(Σ a_t cos 2π f_j t)² + (Σ a_t sin 2π f_j t)²], j = 1 .. ⌊(N-1)/2⌋.
std::vector<double> NaivePeriodogram(const std::vector<double>& x) {
  const int N = static_cast<int>(x.size());
  const double m = Mean(x);
  std::vector<double> I;
  for (int j = 1; j <= (N - 1) / 2; ++j) {
    double c = 0, s = 0;
    for (int t = 0; t < N; ++t) {
      const double w = 2 * std::numbers::pi * j * t / N;
      c += (x[t] - m) * std::cos(w);
      s += (x[t] - m) * std::sin(w);
    }
    I.push_back(2.0 / N * (c * c + s * s));
  }
  return I;
}

// P(χ²_df > q) for even df: e^{-q/2} Σ_{i < df/2} (q/2)^i / i!  (the Poisson tail).
double ChiSquareTailEvenDf(double q, int df) {
  double term = 1.0, sum = 0.0;
  for (int i = 0; i < df / 2; ++i) {
    if (i > 0) term *= (q / 2) / i;
    sum += term;
  }
  return std::exp(-q / 2) * sum;
}

// ---- ACF and PACF ----------------------------------------------------------------------------

TEST(Autocorrelation, EqualsTheTextbookSumsWithoutMissingValues) {
  const std::vector<double> x = Ar1(300, 0.5, 1);
  const Correlogram acf = Autocorrelation(x, 25);
  ASSERT_EQ(acf.value.size(), 25u);
  EXPECT_EQ(acf.n, 300);
  EXPECT_NEAR(acf.band, 1.959963984540054 / std::sqrt(300.0), 1e-15);
  for (int k = 1; k <= 25; ++k) {
    EXPECT_EQ(acf.lag[k - 1], k);
    EXPECT_NEAR(acf.value[k - 1], NaiveAcf(x, k), kExact) << "lag " << k;
  }
}

TEST(Autocorrelation, IgnoresMissingValuesAtTheEnds) {
  std::vector<double> x = WhiteNoise(200, 2);
  std::vector<double> padded = {kNaN, kNaN};
  padded.insert(padded.end(), x.begin(), x.end());
  padded.push_back(kNaN);
  const Correlogram acf = Autocorrelation(padded, 10);
  EXPECT_EQ(acf.n, 200);
  for (int k = 1; k <= 10; ++k) EXPECT_NEAR(acf.value[k - 1], NaiveAcf(x, k), kExact);
}

TEST(Autocorrelation, OfAnAr1WithGapsIsPhiToTheLag) {
  constexpr double phi = 0.7;
  constexpr int N = 40000;
  std::vector<double> x = Ar1(N, phi, 3);
  sim::NormalRng rng(33);
  for (double& v : x)
    if (rng.Uniform() < 0.2) v = kNaN;  // 20 % missing at random
  const Correlogram acf = Autocorrelation(x, 10);
  for (int k = 1; k <= 10; ++k) {
    const double p2k = std::pow(phi, 2 * k);
    // Bartlett's variance of r(k) for an AR(1), inflated for the missing fifth.
    const double var = ((1 + phi * phi) * (1 - p2k) / (1 - phi * phi) - 2 * k * p2k) / (0.8 * N);
    EXPECT_NEAR(acf.value[k - 1], std::pow(phi, k), 4 * std::sqrt(var)) << "lag " << k;
  }
}

TEST(Autocorrelation, OfWhiteNoiseStaysInsideTheBandAbout95PercentOfTheTime) {
  int inside = 0, total = 0;
  for (std::uint64_t s = 0; s < 100; ++s) {
    const Correlogram acf = Autocorrelation(WhiteNoise(400, 100 + s), 20);
    for (double r : acf.value) {
      inside += std::abs(r) <= acf.band;
      ++total;
    }
  }
  const double fraction = static_cast<double>(inside) / total;
  EXPECT_GT(fraction, 0.93);
  EXPECT_LT(fraction, 0.975);
}

TEST(PartialAutocorrelation, EqualsTheLastYuleWalkerCoefficient) {
  const std::vector<double> x = Ar1(500, -0.4, 4);
  const Correlogram pacf = PartialAutocorrelation(Autocorrelation(x, 12));
  for (int k = 1; k <= 12; ++k)
    EXPECT_NEAR(pacf.value[k - 1], YuleWalkerLast(x, k), 1e-9) << "lag " << k;
}

TEST(PartialAutocorrelation, OfAnAr1IsPhiAtLagOneAndNoneAfter) {
  constexpr double phi = 0.7;
  constexpr int N = 20000;
  const Correlogram pacf = PartialAutocorrelation(Autocorrelation(Ar1(N, phi, 5), 20));
  EXPECT_NEAR(pacf.value[0], phi, 4 * std::sqrt((1 - phi * phi) / N));
  for (int k = 2; k <= 20; ++k) EXPECT_LT(std::abs(pacf.value[k - 1]), 4 / std::sqrt(N)) << k;
}

// ---- CCF -------------------------------------------------------------------------------------

TEST(CrossCorrelation, EqualsTheTextbookSumsWithTheDocumentedSign) {
  const std::vector<double> x = WhiteNoise(250, 6), u = Ar1(250, 0.6, 7);
  const Correlogram ccf = CrossCorrelation(x, u, 15);
  ASSERT_EQ(ccf.value.size(), 31u);
  for (int i = 0; i < 31; ++i) {
    EXPECT_EQ(ccf.lag[i], i - 15);
    EXPECT_NEAR(ccf.value[i], NaiveCcf(x, u, i - 15), kExact) << "lag " << i - 15;
  }
}

TEST(CrossCorrelation, AResidualThatRespondsToTheInputLaterPeaksAtThatPositiveLag) {
  // ε_t = 0.6 u_{t-3} + e_t: the residual responds to the input 3 samples later, so by the
  // convention ccf(k) = corr(ε_{t+k}, u_t) the peak is at k = +3, of height 0.6/sqrt(1.36).
  constexpr int N = 2000, kDelay = 3;
  const std::vector<double> u = WhiteNoise(N, 8), e = WhiteNoise(N, 9);
  std::vector<double> eps(N);
  for (int t = 0; t < N; ++t) eps[t] = (t >= kDelay ? 0.6 * u[t - kDelay] : 0.0) + e[t];
  const std::vector<InputSeries> inputs = {{"mfi", u}};
  const auto d = Diagnose(eps, inputs);
  ASSERT_TRUE(d.ok()) << d.error().ToString();
  ASSERT_EQ(d->ccf.size(), 1u);
  const CrossCorrelogram& c = d->ccf[0];
  EXPECT_EQ(c.peak_lag, kDelay);
  EXPECT_NEAR(c.peak, 0.6 / std::sqrt(1.36), 4 / std::sqrt(N));
  EXPECT_NEAR(c.ccf.value[40 + kDelay], NaiveCcf(eps, u, kDelay), kExact);  // lags -40 .. 40
  EXPECT_TRUE(c.significant);
  EXPECT_NE(d->verdict.find("CCF with mfi peaks at lag +3"), std::string::npos) << d->verdict;
  EXPECT_NE(d->verdict.find("delay"), std::string::npos) << d->verdict;
  // Every other lag stays small.
  ASSERT_EQ(c.ccf.lag[40 + kDelay], kDelay);
  for (std::size_t i = 0; i < c.ccf.value.size(); ++i)
    if (c.ccf.lag[i] != kDelay) {
      EXPECT_LT(std::abs(c.ccf.value[i]), 4 / std::sqrt(N));
    }
}

TEST(CrossCorrelation, AResidualThatLeadsTheInputPeaksAtANegativeLag) {
  // u_t = ε_{t-2} (feedback: the input follows the residual 2 samples later) peaks at k = -2.
  constexpr int N = 1500;
  const std::vector<double> eps = WhiteNoise(N, 10), w = WhiteNoise(N, 11);
  std::vector<double> u(N);
  for (int t = 0; t < N; ++t) u[t] = (t >= 2 ? eps[t - 2] : 0.0) + 0.5 * w[t];
  const std::vector<InputSeries> inputs = {{"u", u}};
  const auto d = Diagnose(eps, inputs);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->ccf[0].peak_lag, -2);
  EXPECT_NE(d->verdict.find("lag -2"), std::string::npos) << d->verdict;
  EXPECT_NE(d->verdict.find("feedback"), std::string::npos) << d->verdict;
}

TEST(Prewhiten, FitsAnAr1InputAndFiltersItByItsCoefficients) {
  constexpr double phi = 0.8;
  constexpr int N = 5000;
  const std::vector<double> u = Ar1(N, phi, 24);
  const Prewhitened pw = Prewhiten(u, 10);
  ASSERT_GE(pw.ar.size(), 1u);
  EXPECT_NEAR(pw.ar[0], phi, 4 * std::sqrt((1 - phi * phi) / N));
  for (std::size_t i = 1; i < pw.ar.size(); ++i) EXPECT_LT(std::abs(pw.ar[i]), 4 / std::sqrt(N));
  const double m = Mean(u);
  const int p = static_cast<int>(pw.ar.size());
  for (int t = 0; t < N; ++t) {
    if (t < p) {
      EXPECT_TRUE(std::isnan(pw.values[t]));
      continue;
    }
    double a = u[t] - m;
    for (int i = 1; i <= p; ++i) a -= pw.ar[i - 1] * (u[t - i] - m);
    EXPECT_NEAR(pw.values[t], a, 1e-12);
  }
}

TEST(CrossCorrelation, PrewhiteningLocatesTheLagOfAResponseToAPiecewiseConstantInput) {
  // A PRBS with 40 samples per bit, and a residual that responds to its steps 2 samples later
  // (what an output delay 2 samples too short leaves): the raw CCF is smeared over the bit
  // length, the prewhitened one peaks at +2.
  design::PrbsOptions o;
  o.order = 6;
  o.bit_period = 0.5;
  o.sample_time = 0.0125;
  o.duration = 60;
  const auto prbs = design::MakePrbs(o);
  ASSERT_TRUE(prbs.ok());
  const std::vector<double>& u = prbs->u;
  const int N = static_cast<int>(u.size());
  const std::vector<double> e = WhiteNoise(N, 25);
  std::vector<double> eps(N);
  for (int t = 0; t < N; ++t) eps[t] = (t >= 3 ? 0.5 * (u[t - 2] - u[t - 3]) : 0.0) + e[t];
  const std::vector<InputSeries> inputs = {{"mfi", u}};
  const auto d = Diagnose(eps, inputs);
  ASSERT_TRUE(d.ok());
  const CrossCorrelogram& c = d->ccf[0];
  EXPECT_EQ(c.peak_lag, 2);
  EXPECT_TRUE(c.significant);
  EXPECT_NE(d->verdict.find("CCF with mfi peaks at lag +2"), std::string::npos) << d->verdict;
  double raw_max = 0;
  for (double v : c.ccf.value) raw_max = std::max(raw_max, std::abs(v));
  EXPECT_LT(raw_max, 0.5 * std::abs(c.peak)) << "the raw CCF hides the peak";
}

TEST(CrossCorrelation, IsLeftOutForAConstantInput) {
  const std::vector<double> eps = WhiteNoise(100, 12), u(100, 3.0);
  const std::vector<InputSeries> inputs = {{"u", u}};
  const auto d = Diagnose(eps, inputs);
  ASSERT_TRUE(d.ok());
  EXPECT_TRUE(d->ccf[0].constant);
  EXPECT_FALSE(d->ccf[0].significant);
  EXPECT_TRUE(d->ccf[0].ccf.value.empty());
}

// ---- cumulated periodogram -------------------------------------------------------------------

void ExpectMatchesNaiveDft(const std::vector<double>& x, const CumulatedPeriodogram& cp) {
  const std::vector<double> I = NaivePeriodogram(x);
  const int N = static_cast<int>(x.size());
  const int q = (N - 1) / 2;
  ASSERT_EQ(cp.q, q);
  ASSERT_EQ(static_cast<int>(cp.value.size()), q);
  EXPECT_NEAR(cp.band, 1.36 / std::sqrt(q), 1e-15);
  double total = 0;
  for (double v : I) total += v;
  double cum = 0;
  for (int j = 1; j <= q; ++j) {
    cum += I[j - 1];
    EXPECT_NEAR(cp.frequency[j - 1], static_cast<double>(j) / N, 1e-15);
    EXPECT_NEAR(cp.value[j - 1], cum / total, kExact) << "j " << j;
    EXPECT_NEAR(cp.white[j - 1], static_cast<double>(j) / q, 1e-15);
  }
}

TEST(CumulativePeriodogram, OfASinusoidInNoiseJumpsAtItsFrequencyAndLeavesTheBand) {
  for (int N : {500, 501}) {  // even and odd lengths (q = 249 and 250)
    constexpr double f0 = 0.1, amplitude = 1.5;
    std::vector<double> x = WhiteNoise(N, 13);
    for (int t = 0; t < N; ++t) x[t] += amplitude * std::sin(2 * std::numbers::pi * f0 * t + 0.3);
    const CumulatedPeriodogram cp = CumulativePeriodogram(x);
    ExpectMatchesNaiveDft(x, cp);
    EXPECT_NEAR(cp.peak_frequency, f0, 1.0 / N);
    const int j0 = static_cast<int>(std::lround(cp.peak_frequency * N));
    // The sinusoid holds amplitude²/2 of the 1 + amplitude²/2 total power.
    EXPECT_GT(cp.value[j0 - 1] - cp.value[j0 - 2], 0.4) << "N " << N;
    EXPECT_FALSE(cp.inside);
    EXPECT_GT(cp.max_deviation, cp.band);
  }
}

TEST(CumulativePeriodogram, OfWhiteNoiseLeavesTheBandAboutOneTimeInTwenty) {
  const std::vector<double> x = WhiteNoise(1000, 14);
  ExpectMatchesNaiveDft(x, CumulativePeriodogram(x));
  int outside = 0;
  constexpr int kSeries = 300;
  for (std::uint64_t s = 0; s < kSeries; ++s)
    outside += !CumulativePeriodogram(WhiteNoise(400, 500 + s)).inside;
  EXPECT_LT(outside, 0.10 * kSeries);
}

TEST(CumulativePeriodogram, AMissingValueAddsNoPower) {
  std::vector<double> x = WhiteNoise(301, 15);
  x[100] = kNaN;
  const CumulatedPeriodogram cp = CumulativePeriodogram(x);
  double m = 0;
  int n = 0;
  for (double v : x)
    if (!std::isnan(v)) m += v, ++n;
  m /= n;
  std::vector<double> filled = x;
  filled[100] = m;  // the mean: a centred value of 0
  ExpectMatchesNaiveDft(filled, cp);
}

// ---- Ljung-Box -------------------------------------------------------------------------------

TEST(LjungBox, EqualsTheTextbookStatisticAndChiSquareTail) {
  const std::vector<double> x = Ar1(400, 0.15, 16);
  const Correlogram acf = Autocorrelation(x, 30);
  for (int h : {10, 20}) {
    const LjungBox lb = LjungBoxTest(acf, h);
    double q = 0;
    for (int k = 1; k <= h; ++k) q += NaiveAcf(x, k) * NaiveAcf(x, k) / (400.0 - k);
    q *= 400.0 * 402.0;
    EXPECT_NEAR(lb.statistic, q, 1e-9 * q);
    EXPECT_EQ(lb.df, h);
    EXPECT_NEAR(lb.p_value, ChiSquareTailEvenDf(q, h), 1e-12);
    const LjungBox fitted = LjungBoxTest(acf, h, 2);
    EXPECT_EQ(fitted.df, h - 2);
    EXPECT_NEAR(fitted.p_value, ChiSquareTailEvenDf(q, h - 2), 1e-12);
  }
}

TEST(LjungBox, PValuesOfWhiteNoiseAreRoughlyUniform) {
  constexpr int kSeries = 400;
  std::vector<double> p;
  for (std::uint64_t s = 0; s < kSeries; ++s)
    p.push_back(LjungBoxTest(Autocorrelation(WhiteNoise(300, 2000 + s), 20), 20).p_value);
  std::sort(p.begin(), p.end());
  double ks = 0;  // Kolmogorov-Smirnov distance to the uniform distribution
  for (int i = 0; i < kSeries; ++i)
    ks = std::max({ks, std::abs(p[i] - static_cast<double>(i) / kSeries),
                   std::abs(p[i] - static_cast<double>(i + 1) / kSeries)});
  EXPECT_LT(ks, 1.63 / std::sqrt(kSeries));  // the 1 % critical value
  const double below = std::count_if(p.begin(), p.end(), [](double v) { return v < 0.05; });
  EXPECT_GT(below / kSeries, 0.015);
  EXPECT_LT(below / kSeries, 0.09);
}

// ---- normality -------------------------------------------------------------------------------

TEST(NormalityTests, MomentsJarqueBeraAndQqPointsEqualTheirDefinitions) {
  std::vector<double> x = {0.3, -1.2, 2.5, 0.0, 0.7, -0.4, 1.9, -2.2, 0.1, 3.3, kNaN, -0.8};
  const Normality nm = NormalityTests(x, 4);
  std::vector<double> v;
  for (double e : x)
    if (!std::isnan(e)) v.push_back(e);
  const double n = static_cast<double>(v.size());
  const double m = Mean(v);
  double m2 = 0, m3 = 0, m4 = 0;
  for (double e : v) {
    m2 += std::pow(e - m, 2) / n;
    m3 += std::pow(e - m, 3) / n;
    m4 += std::pow(e - m, 4) / n;
  }
  const double g1 = m3 / std::pow(m2, 1.5), g2 = m4 / (m2 * m2) - 3;
  const double jb = n / 6 * (g1 * g1 + g2 * g2 / 4);
  EXPECT_EQ(nm.n, 11);
  EXPECT_NEAR(nm.mean, m, 1e-14);
  EXPECT_NEAR(nm.sd, std::sqrt(m2), 1e-14);
  EXPECT_NEAR(nm.skewness, g1, 1e-12);
  EXPECT_NEAR(nm.excess_kurtosis, g2, 1e-12);
  EXPECT_NEAR(nm.jarque_bera, jb, 1e-12);
  EXPECT_NEAR(nm.p_value, ChiSquareTailEvenDf(jb, 2), 1e-14);
  std::sort(v.begin(), v.end());
  EXPECT_EQ(nm.qq_sample, v);
  for (int i = 0; i < 11; ++i) {
    // Φ(z) = erfc(-z/√2)/2 at the theoretical quantile gives back (i + ½)/n.
    EXPECT_NEAR(0.5 * std::erfc(-nm.qq_theoretical[i] / std::sqrt(2.0)), (i + 0.5) / n, 1e-12);
  }
  ASSERT_EQ(nm.histogram_counts.size(), 4u);
  ASSERT_EQ(nm.histogram_edges.size(), 5u);
  EXPECT_DOUBLE_EQ(nm.histogram_edges.front(), -2.2);
  EXPECT_DOUBLE_EQ(nm.histogram_edges.back(), 3.3);
  // Bins of width 1.375: [-2.2,-0.825) [-0.825,0.55) [0.55,1.925) [1.925,3.3].
  EXPECT_EQ(nm.histogram_counts, (std::vector<int>{2, 5, 2, 2}));
}

TEST(NormalityTests, AHistogramOverTheWholeRangeOfDoublesHasFiniteEdgesAndEveryValue) {
  // hi - lo overflows: the edges and the bin of each value are computed on halves.
  const double big = std::numeric_limits<double>::max();
  const std::vector<double> x = {-big, -1e307, 0.0, 1e307, big};
  const Normality nm = NormalityTests(x, 4);
  ASSERT_EQ(nm.histogram_edges.size(), 5u);
  for (double e : nm.histogram_edges) EXPECT_TRUE(std::isfinite(e)) << e;
  EXPECT_TRUE(std::is_sorted(nm.histogram_edges.begin(), nm.histogram_edges.end()));
  EXPECT_EQ(nm.histogram_edges.front(), -big);
  EXPECT_EQ(nm.histogram_edges[2], 0.0);
  EXPECT_EQ(nm.histogram_edges.back(), big);
  EXPECT_EQ(nm.histogram_counts, (std::vector<int>{1, 1, 2, 1}));
}

TEST(NormalityTests, RejectHeavyTailsAndAcceptGaussianNoise) {
  sim::NormalRng rng(17);
  std::vector<double> laplace(3000);  // excess kurtosis 3
  for (double& v : laplace) v = (rng.Uniform() < 0.5 ? -1 : 1) * -std::log(rng.Uniform());
  const Normality heavy = NormalityTests(laplace);
  EXPECT_LT(heavy.p_value, 1e-6);
  EXPECT_NEAR(heavy.excess_kurtosis, 3.0, 1.0);
  EXPECT_GT(NormalityTests(WhiteNoise(3000, 18)).p_value, 0.01);
}

// ---- Diagnose and the verdict ----------------------------------------------------------------

TEST(Diagnose, CallsWhiteNoiseWhiteAndSkipsTheRowsBeforeTheFirstResidual) {
  std::vector<double> z = {kNaN, kNaN, kNaN};
  const std::vector<double> w = WhiteNoise(1000, 19);
  z.insert(z.end(), w.begin(), w.end());
  const std::vector<double> u = Ar1(1003, 0.9, 20);
  const std::vector<InputSeries> inputs = {{"u", u}};
  const auto d = Diagnose(z, inputs);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->first_row, 3);
  EXPECT_EQ(d->rows, 1000);
  EXPECT_EQ(d->n, 1000);
  EXPECT_EQ(d->max_lag, 40);
  EXPECT_EQ(d->ljung_box.lags, 20);
  EXPECT_TRUE(d->white) << d->verdict;
  EXPECT_TRUE(d->normal) << d->verdict;
  EXPECT_FALSE(d->ccf[0].significant);
  EXPECT_EQ(d->verdict.rfind("Residuals look white (Ljung-Box p = ", 0), 0u) << d->verdict;
  EXPECT_EQ(d->verdict.find("CCF"), std::string::npos) << d->verdict;
  for (int k = 1; k <= 40; ++k) EXPECT_NEAR(d->acf.value[k - 1], NaiveAcf(w, k), kExact);
}

TEST(Diagnose, NamesTheAcfLagsOutsideTheBandForAnAr1) {
  const auto d = Diagnose(Ar1(2000, 0.6, 21), {});
  ASSERT_TRUE(d.ok());
  EXPECT_FALSE(d->white);
  EXPECT_LT(d->ljung_box.p_value, 1e-10);
  EXPECT_EQ(d->verdict.rfind("Residuals are not white: ACF exceeds the band at lags 1-", 0), 0u)
      << d->verdict;
}

TEST(Diagnose, RemarksOnHeavyTailsAndAWrongScale) {
  sim::NormalRng rng(22);
  std::vector<double> z(2000);
  for (double& v : z) v = 2.0 * (rng.Uniform() < 0.5 ? -1 : 1) * -std::log(rng.Uniform());
  const auto d = Diagnose(z, {});
  ASSERT_TRUE(d.ok());
  EXPECT_FALSE(d->normal);
  EXPECT_NE(d->verdict.find("heavy tails"), std::string::npos) << d->verdict;
  EXPECT_NE(d->verdict.find("too small"), std::string::npos) << d->verdict;
}

TEST(Diagnose, RefusesTooFewOrConstantResidualsAndBadOptions) {
  EXPECT_FALSE(Diagnose(std::vector<double>{1, 2, 3, kNaN, 5}, {}).ok());
  EXPECT_FALSE(Diagnose(std::vector<double>(50, 1.0), {}).ok());
  DiagnoseOptions o;
  o.max_lag = 60;
  const auto d = Diagnose(WhiteNoise(50, 23), {}, o);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().message.find("max_lag 60"), std::string::npos) << d.error().message;
  o = DiagnoseOptions{};
  o.ljung_box_lags = 5;
  o.fitted_arma_params = 5;
  EXPECT_FALSE(Diagnose(WhiteNoise(50, 23), {}, o).ok());
  o.fitted_arma_params = -1;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_FALSE(why.empty());
}

TEST(FormatLagRanges, JoinsConsecutiveLags) {
  EXPECT_EQ(FormatLagRanges({1, 2, 3, 7, 9, 10}), "1-3, 7, 9-10");
  EXPECT_EQ(FormatLagRanges({4}), "4");
  EXPECT_EQ(FormatLagRanges({}), "");
}

}  // namespace
}  // namespace gb::diagnose
