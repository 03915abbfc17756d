// Residual diagnostics: is the sequence of standardised one-step residuals z_t = ε_t / sd_t
// (core/filter/predict.h) white, uncorrelated with the inputs, and normal? If the model is right,
// z_t is an independent N(0, 1) sequence.
//
// Indexing is by sample (t = 0 .. n-1 over the rows given), not by time: lags are in samples and
// frequencies in cycles per sample (multiply by 1/Δ for the data's time unit when Δ is constant).
// Missing values (NaN) are skipped as described per statistic; `Diagnose` first cuts the series
// to the rows from the first to the last observed residual (a delayed output has no residual in
// its first d_o rows; those rows are not gaps). Below, n = number of observed values, x̄ their
// mean, T_k = {t : x_t and x_{t+k} both observed}, ν_k = |T_k|. Every band is a 95% band.
//
// ACF (Box & Jenkins, eq. 2.1.12, with gaps):
//   c(k) = (1 - k/n) (1/ν_k) Σ_{t∈T_k} (x_t - x̄)(x_{t+k} - x̄),   c(0) = (1/n) Σ (x_t - x̄)²
//   r(k) = c(k) / c(0),   k = 1 .. K;   band ±1.96/√n.
//   Without gaps this is the usual r(k) = Σ_{t=0}^{n-1-k} (x_t - x̄)(x_{t+k} - x̄) / Σ (x_t - x̄)².
// PACF: φ_kk by the Durbin-Levinson recursion on r(1..K):
//   φ_11 = r(1);  φ_kk = (r(k) - Σ_{j<k} φ_{k-1,j} r(k-j)) / (1 - Σ_{j<k} φ_{k-1,j} r(j)),
//   φ_kj = φ_{k-1,j} - φ_kk φ_{k-1,k-j};   band ±1.96/√n.
//   (φ_kk is the last coefficient of the AR(k) fit by the Yule-Walker equations.)
// CCF between the residuals x and an input u, SIGN CONVENTION:
//   ccf(k) = corr(x_{t+k}, u_t),   k = -K .. K
//          = (1 - |k|/n) (1/ν_k) Σ_{t: x_{t+k}, u_t observed} (x_{t+k} - x̄)(u_t - ū)
//            / sqrt(c_xx(0) c_uu(0))
//   (ū, c_uu(0) over the rows given). A residual that responds to the input k samples later
//   peaks at k = +k (the input leads); a peak at a negative lag means the residual leads the
//   input (feedback from the output to the input). Band ±1.96/√n per lag, valid when the residual
//   is white (whatever the input's own correlation; Bartlett).
// Prewhitened CCF (Box & Jenkins' cross-correlation check of a transfer-function model, 11.3):
//   an input such as a PRBS with a long bit period is strongly autocorrelated, which smears the
//   CCF over many lags and hides where a peak is. So the input is also prewhitened by an AR(p)
//   model, fitted by Yule-Walker (Durbin-Levinson on u's ACF), p = 0 .. min(10, n/10) chosen by
//   AIC = n log σ²_p + 2p with σ²_p = c(0) Π_{k<=p} (1 - φ_kk²):
//     α_t = (u_t - ū) - Σ_{i=1}^{p} φ_i (u_{t-i} - ū)     (NaN for t < p)
//   and the same CCF, with the same convention, is taken between x and α. The verdict uses this
//   one: a peak counts when max_k |ccf_α(k)| exceeds the Bonferroni bound z_{1-0.025/(2K+1)}/√n
//   (5% over all 2K+1 lags).
// Cumulated periodogram (Box & Jenkins, section 8.2.6):
//   a_t = x_t - x̄ (0 where x_t is missing: a gap adds no power), N = number of rows,
//   I(f_j) = (2/N) |Σ_{t=0}^{N-1} a_t e^{-2πi f_j t}|²,   f_j = j/N,  j = 1 .. q,  q = ⌊(N-1)/2⌋
//   C(f_j) = Σ_{i≤j} I(f_i) / Σ_{i≤q} I(f_i)
//   White noise: C(f_j) ≈ j/q (the straight line to (0.5, 1)). Kolmogorov-Smirnov 95% band:
//   j/q ± 1.36/√q; the periodogram "leaves the band" when max_j |C(f_j) - j/q| > 1.36/√q.
//   (Computed by FFT, O(N log N).)
// Ljung-Box:
//   Q = n (n+2) Σ_{k=1}^{h} r(k)² / (n-k),   df = h - (fitted ARMA parameters; 0 here),
//   p = P(χ²_df > Q)   (boost::math chi_squared).
// Normality of the residuals as given (not re-standardised, so a wrong scale shows):
//   m_r = (1/n) Σ (x_t - x̄)^r,  skewness g1 = m3 / m2^{3/2},  excess kurtosis g2 = m4/m2² - 3,
//   Jarque-Bera JB = n/6 (g1² + g2²/4),  p = P(χ²_2 > JB) = e^{-JB/2}.
//   QQ points: the sorted values x_(i) against Φ⁻¹((i - ½)/n), i = 1 .. n (Hazen).
//   Histogram: ⌈2 n^{1/3}⌉ equal bins (Rice's rule, 5 .. 100) from min to max.
//
// Verdict: "white" when the Ljung-Box p >= 0.05 and the cumulated periodogram stays inside its
// band. The words name what failed: the ACF lags outside the band, the Ljung-Box p, a periodogram
// peak, a (prewhitened) CCF peak per input with its lag and a hint (lag > 0: "a missing or wrong
// delay, or missing dynamics?"; lag 0: "a missing direct term?"; lag < 0: "feedback?"; a peak
// below 1.25 times its bound: "possibly chance"), a scale of the standardised residuals outside
// [0.8, 1.25] ("the predicted variances are too small / large"), and non-normality (Jarque-Bera
// p < 0.05, with "heavy tails" when the excess kurtosis exceeds 1).
#pragma once

#include <span>
#include <string>
#include <vector>

#include "core/util/result.h"

namespace gb::diagnose {

// 95% two-sided normal quantile and Box & Jenkins' Kolmogorov-Smirnov constant for 5%.
inline constexpr double kBandZ = 1.959963984540054;
inline constexpr double kKolmogorovSmirnov95 = 1.36;
// Below this many observed residuals the statistics mean nothing and Diagnose refuses.
inline constexpr int kMinResiduals = 10;

struct DiagnoseOptions {
  int max_lag = 0;             // K for ACF, PACF and CCF; 0: min(40, n/4), at least 1
  int ljung_box_lags = 0;      // h; 0: min(20, K)
  int fitted_arma_params = 0;  // subtracted from h for the Ljung-Box degrees of freedom
  int histogram_bins = 0;      // 0: Rice's rule
  bool IsValid(std::string* why) const;
};

struct Correlogram {
  std::vector<int> lag;       // 1 .. K (ACF, PACF) or -K .. K (CCF)
  std::vector<double> value;  // NaN where no pair of observed values exists
  double band = 0.0;          // the 95% limits ±band under whiteness, 1.96/√n
  int n = 0;                  // observed values
};

struct CumulatedPeriodogram {
  std::vector<double> frequency;  // f_j = j/N, cycles per sample, j = 1 .. q
  std::vector<double> value;      // C(f_j)
  std::vector<double> white;      // j/q
  double band = 0.0;              // 1.36/√q
  int q = 0;
  double max_deviation = 0.0;   // max_j |C(f_j) - j/q|
  double peak_frequency = 0.0;  // f_j of the largest I(f_j)
  bool inside = true;           // max_deviation <= band
};

struct LjungBox {
  double statistic = 0.0;
  int lags = 0;  // h
  int df = 0;
  double p_value = 1.0;
};

struct Normality {
  int n = 0;
  double mean = 0.0, sd = 0.0;  // sd = sqrt(m2)
  double skewness = 0.0;
  double excess_kurtosis = 0.0;
  double jarque_bera = 0.0;
  double p_value = 1.0;
  std::vector<double> qq_theoretical;   // Φ⁻¹((i - ½)/n)
  std::vector<double> qq_sample;        // sorted values
  std::vector<double> histogram_edges;  // bins + 1
  std::vector<int> histogram_counts;    // bins
};

struct InputSeries {
  std::string name;
  std::span<const double> values;  // the same rows as the residuals
};

struct CrossCorrelogram {
  std::string input;
  Correlogram ccf;              // with the input as measured; lags -K .. K; empty when constant
  Correlogram ccf_prewhitened;  // with the prewhitened input α
  std::vector<double> prewhitening_ar;  // φ_1 .. φ_p (empty: p = 0, α = u - ū)
  bool constant = false;     // the input does not vary over the rows: no correlation exists
  int peak_lag = 0;          // argmax_k |ccf_prewhitened(k)|
  double peak = 0.0;         // ccf_prewhitened(peak_lag)
  double peak_bound = 0.0;   // the Bonferroni bound for the peak
  bool significant = false;  // |peak| > peak_bound
};

struct Prewhitened {
  std::vector<double> ar;      // φ_1 .. φ_p
  std::vector<double> values;  // α_t, NaN for t < p
};

struct ResidualDiagnostics {
  int first_row = 0;  // the rows analysed: [first_row, first_row + rows)
  int rows = 0;
  int n = 0;  // observed residuals among them
  int max_lag = 0;
  Correlogram acf, pacf;
  std::vector<CrossCorrelogram> ccf;  // one per input, in the order given
  CumulatedPeriodogram periodogram;
  LjungBox ljung_box;
  Normality normality;
  bool white = false;
  bool normal = false;
  std::string verdict;  // one or a few sentences for the user
};

// The statistics one by one. `x` may hold NaN (missing). Preconditions (asserted):
// 1 <= max_lag < number of observed values; equal lengths for x and u.
Correlogram Autocorrelation(std::span<const double> x, int max_lag);
Correlogram PartialAutocorrelation(const Correlogram& acf);
Correlogram CrossCorrelation(std::span<const double> x, std::span<const double> u, int max_lag);
// AR order chosen by AIC among 0 .. max_order (0 when u does not vary or is too short).
Prewhitened Prewhiten(std::span<const double> u, int max_order);
CumulatedPeriodogram CumulativePeriodogram(std::span<const double> x);  // needs >= 3 rows
LjungBox LjungBoxTest(const Correlogram& acf, int lags, int fitted_arma_params = 0);
Normality NormalityTests(std::span<const double> x, int histogram_bins = 0);

// Everything above with the verdict, on the rows from the first to the last observed z.
// Precondition (asserted): every input has z.size() values. Errors (kInput): invalid options;
// fewer than kMinResiduals observed residuals; residuals that do not vary; max_lag or the
// Ljung-Box lags not below the number of residuals; no Ljung-Box degrees of freedom left.
Result<ResidualDiagnostics> Diagnose(std::span<const double> z, std::span<const InputSeries> inputs,
                                     const DiagnoseOptions& options = {});

// "1-3, 7, 12-13": lags as ranges (for the verdict and reports).
std::string FormatLagRanges(const std::vector<int>& lags);

}  // namespace gb::diagnose
