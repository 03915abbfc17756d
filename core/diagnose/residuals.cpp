// Sections: 1. correlograms (ACF, PACF by Durbin-Levinson, prewhitening, CCF)
//           2. cumulated periodogram  3. tests (Ljung-Box, normality)  4. Diagnose and the verdict
#include "core/diagnose/residuals.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <complex>
#include <limits>

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>
#include <fmt/format.h>
#include <unsupported/Eigen/FFT>

namespace gb::diagnose {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kTestLevel = 0.05;
constexpr int kDefaultMaxLag = 40;
constexpr int kDefaultLjungBoxLags = 20;
constexpr int kMaxPrewhiteningOrder = 10;
constexpr int kMinHistogramBins = 5;
constexpr int kMaxHistogramBins = 100;
// Lag ranges listed in the verdict before "...".
constexpr int kMaxRangesInVerdict = 8;
// Standardised residuals whose sd leaves [1/kScaleRatio, kScaleRatio] get a remark on the scale.
constexpr double kScaleRatio = 1.25;
// A CCF peak below kMarginal times its bound is called possibly chance in the verdict.
constexpr double kMarginal = 1.25;

struct Moments {
  int n = 0;
  double mean = 0.0;
  double m2 = 0.0;  // (1/n) Σ (x - mean)²
};

Moments ObservedMoments(std::span<const double> x) {
  Moments m;
  double sum = 0.0;
  for (double v : x) {
    if (std::isnan(v)) continue;
    sum += v;
    ++m.n;
  }
  if (m.n == 0) return m;
  m.mean = sum / m.n;
  for (double v : x)
    if (!std::isnan(v)) m.m2 += (v - m.mean) * (v - m.mean);
  m.m2 /= m.n;
  return m;
}

}  // namespace

bool DiagnoseOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (max_lag < 0) return fail("max_lag must be >= 0 (0: automatic)");
  if (ljung_box_lags < 0) return fail("ljung_box_lags must be >= 0 (0: automatic)");
  if (fitted_arma_params < 0) return fail("fitted_arma_params must be >= 0");
  if (histogram_bins < 0) return fail("histogram_bins must be >= 0 (0: automatic)");
  return true;
}

// ---- 1. correlograms -------------------------------------------------------------------------

Correlogram Autocorrelation(std::span<const double> x, int max_lag) {
  const Moments mo = ObservedMoments(x);
  assert(max_lag >= 1 && max_lag < mo.n && "1 <= max_lag < observed values");
  const int N = static_cast<int>(x.size());
  Correlogram out;
  out.n = mo.n;
  out.band = kBandZ / std::sqrt(static_cast<double>(mo.n));
  for (int k = 1; k <= max_lag; ++k) {
    double sum = 0.0;
    int pairs = 0;
    for (int t = 0; t + k < N; ++t) {
      if (std::isnan(x[t]) || std::isnan(x[t + k])) continue;
      sum += (x[t] - mo.mean) * (x[t + k] - mo.mean);
      ++pairs;
    }
    out.lag.push_back(k);
    out.value.push_back(pairs > 0 && mo.m2 > 0
                            ? (1.0 - static_cast<double>(k) / mo.n) * (sum / pairs) / mo.m2
                            : kNaN);
  }
  return out;
}

namespace {

// The Durbin-Levinson recursion on r(1..K): φ_kk for every order reached, and the coefficients
// φ_{p,1..p} of the last order p. Stops early where r has no value or stops being a valid ACF.
struct Levinson {
  std::vector<double> phi_kk;  // φ_11, φ_22, ...
  std::vector<double> phi;     // φ_{p,1..p}, p = phi_kk.size()
};

Levinson DurbinLevinson(const std::vector<double>& r_from_1, int K) {
  Levinson out;
  const auto r = [&](int k) { return r_from_1[k - 1]; };
  std::vector<double> next;
  for (int k = 1; k <= K; ++k) {
    double num = r(k), den = 1.0;
    for (int j = 1; j < k; ++j) {
      num -= out.phi[j - 1] * r(k - j);
      den -= out.phi[j - 1] * r(j);
    }
    if (!std::isfinite(num) || !(den > 0.0)) break;
    const double phi_kk = num / den;
    next.assign(k, 0.0);
    for (int j = 1; j < k; ++j) next[j - 1] = out.phi[j - 1] - phi_kk * out.phi[k - j - 1];
    next[k - 1] = phi_kk;
    out.phi.swap(next);
    out.phi_kk.push_back(phi_kk);
  }
  return out;
}

}  // namespace

Correlogram PartialAutocorrelation(const Correlogram& acf) {
  Correlogram out;
  out.n = acf.n;
  out.band = acf.band;
  out.lag = acf.lag;
  const int K = static_cast<int>(acf.value.size());
  out.value.assign(K, kNaN);
  const Levinson lev = DurbinLevinson(acf.value, K);
  std::copy(lev.phi_kk.begin(), lev.phi_kk.end(), out.value.begin());
  return out;
}

Prewhitened Prewhiten(std::span<const double> u, int max_order) {
  const Moments mo = ObservedMoments(u);
  Prewhitened out;
  const int N = static_cast<int>(u.size());
  int order = 0;
  if (mo.m2 > 0 && max_order > 0 && mo.n > max_order + 1) {
    const Correlogram acf = Autocorrelation(u, max_order);
    const Levinson lev = DurbinLevinson(acf.value, max_order);
    // AIC(p) = n log σ²_p + 2p with σ²_p = c(0) Π_{k<=p} (1 - φ_kk²); c(0) drops out.
    double log_var = 0.0, best_aic = 0.0;
    for (int p = 1; p <= static_cast<int>(lev.phi_kk.size()); ++p) {
      log_var += std::log1p(-lev.phi_kk[p - 1] * lev.phi_kk[p - 1]);
      const double aic = mo.n * log_var + 2.0 * p;
      if (aic < best_aic) {
        best_aic = aic;
        order = p;
      }
    }
    // The coefficients of the chosen order: rerun the recursion to that order.
    if (order > 0) out.ar = DurbinLevinson(acf.value, order).phi;
  }
  out.values.assign(N, kNaN);
  for (int t = order; t < N; ++t) {
    double a = u[t] - mo.mean;
    for (int i = 1; i <= order; ++i) a -= out.ar[i - 1] * (u[t - i] - mo.mean);
    out.values[t] = a;  // NaN when any term is missing
  }
  return out;
}

Correlogram CrossCorrelation(std::span<const double> x, std::span<const double> u, int max_lag) {
  assert(x.size() == u.size() && "the residuals and the input cover the same rows");
  const Moments mx = ObservedMoments(x);
  const Moments mu = ObservedMoments(u);
  assert(max_lag >= 1 && max_lag < mx.n && "1 <= max_lag < observed values");
  const int N = static_cast<int>(x.size());
  const double scale = std::sqrt(mx.m2 * mu.m2);
  Correlogram out;
  out.n = mx.n;
  out.band = kBandZ / std::sqrt(static_cast<double>(mx.n));
  for (int k = -max_lag; k <= max_lag; ++k) {
    // corr(x_{t+k}, u_t) over the t where both exist.
    double sum = 0.0;
    int pairs = 0;
    for (int t = std::max(0, -k); t < N && t + k < N; ++t) {
      const double a = x[t + k], b = u[t];
      if (std::isnan(a) || std::isnan(b)) continue;
      sum += (a - mx.mean) * (b - mu.mean);
      ++pairs;
    }
    out.lag.push_back(k);
    const double taper = 1.0 - static_cast<double>(std::abs(k)) / mx.n;
    out.value.push_back(pairs > 0 && scale > 0 ? taper * (sum / pairs) / scale : kNaN);
  }
  return out;
}

// ---- 2. cumulated periodogram ----------------------------------------------------------------

CumulatedPeriodogram CumulativePeriodogram(std::span<const double> x) {
  const int N = static_cast<int>(x.size());
  assert(N >= 3 && "a periodogram needs at least 3 rows");
  const Moments mo = ObservedMoments(x);
  std::vector<double> a(N);
  for (int t = 0; t < N; ++t) a[t] = std::isnan(x[t]) ? 0.0 : x[t] - mo.mean;
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> spectrum;
  fft.fwd(spectrum, a);

  CumulatedPeriodogram out;
  out.q = (N - 1) / 2;
  out.band = kKolmogorovSmirnov95 / std::sqrt(static_cast<double>(out.q));
  std::vector<double> I(out.q);
  double total = 0.0, largest = -1.0;
  for (int j = 1; j <= out.q; ++j) {
    I[j - 1] = 2.0 / N * std::norm(spectrum[j]);
    total += I[j - 1];
    if (I[j - 1] > largest) {
      largest = I[j - 1];
      out.peak_frequency = static_cast<double>(j) / N;
    }
  }
  double cum = 0.0;
  for (int j = 1; j <= out.q; ++j) {
    cum += I[j - 1];
    const double white = static_cast<double>(j) / out.q;
    const double value = total > 0 ? cum / total : white;
    out.frequency.push_back(static_cast<double>(j) / N);
    out.value.push_back(value);
    out.white.push_back(white);
    out.max_deviation = std::max(out.max_deviation, std::abs(value - white));
  }
  out.inside = out.max_deviation <= out.band;
  return out;
}

// ---- 3. tests --------------------------------------------------------------------------------

LjungBox LjungBoxTest(const Correlogram& acf, int lags, int fitted_arma_params) {
  assert(lags >= 1 && lags <= static_cast<int>(acf.value.size()) && lags < acf.n);
  LjungBox lb;
  lb.lags = lags;
  lb.df = lags - fitted_arma_params;
  const double n = acf.n;
  double sum = 0.0;
  for (int k = 1; k <= lags; ++k) {
    const double r = acf.value[k - 1];
    if (!std::isnan(r)) sum += r * r / (n - k);
  }
  lb.statistic = n * (n + 2.0) * sum;
  if (lb.df >= 1) {
    const boost::math::chi_squared_distribution<double> chi2(lb.df);
    lb.p_value = boost::math::cdf(boost::math::complement(chi2, lb.statistic));
  } else {
    lb.p_value = kNaN;
  }
  return lb;
}

Normality NormalityTests(std::span<const double> x, int histogram_bins) {
  Normality out;
  std::vector<double> v;
  for (double e : x)
    if (!std::isnan(e)) v.push_back(e);
  const int n = static_cast<int>(v.size());
  out.n = n;
  if (n == 0) return out;
  double sum = 0.0;
  for (double e : v) sum += e;
  out.mean = sum / n;
  double m2 = 0.0, m3 = 0.0, m4 = 0.0;
  for (double e : v) {
    const double d = e - out.mean, d2 = d * d;
    m2 += d2;
    m3 += d2 * d;
    m4 += d2 * d2;
  }
  m2 /= n;
  m3 /= n;
  m4 /= n;
  out.sd = std::sqrt(m2);
  if (m2 > 0) {
    out.skewness = m3 / (m2 * out.sd);
    out.excess_kurtosis = m4 / (m2 * m2) - 3.0;
    out.jarque_bera =
        n / 6.0 * (out.skewness * out.skewness + 0.25 * out.excess_kurtosis * out.excess_kurtosis);
    out.p_value = std::exp(-0.5 * out.jarque_bera);
  } else {
    out.skewness = out.excess_kurtosis = out.jarque_bera = out.p_value = kNaN;
  }

  std::sort(v.begin(), v.end());
  const boost::math::normal_distribution<double> normal;
  out.qq_sample = v;
  out.qq_theoretical.resize(n);
  for (int i = 0; i < n; ++i) out.qq_theoretical[i] = boost::math::quantile(normal, (i + 0.5) / n);

  int bins = histogram_bins > 0
                 ? histogram_bins
                 : std::clamp(static_cast<int>(std::ceil(2.0 * std::cbrt(static_cast<double>(n)))),
                              kMinHistogramBins, kMaxHistogramBins);
  double lo = v.front(), hi = v.back();
  if (!(hi > lo)) {  // every value equal: one bin around it
    lo -= 0.5;
    hi += 0.5;
    bins = 1;
  }
  // Halved where hi - lo would overflow (residuals of ±1e308), so no edge or bin index is inf
  // or NaN.
  const double half_span = 0.5 * hi - 0.5 * lo;
  for (int b = 0; b <= bins; ++b) {
    const double f = static_cast<double>(b) / bins;
    out.histogram_edges.push_back(b == bins ? hi : (lo + f * half_span) + f * half_span);
  }
  out.histogram_counts.assign(bins, 0);
  for (double e : v) {
    const double pos = (0.5 * e - 0.5 * lo) / half_span * bins;
    ++out.histogram_counts[pos >= bins - 1 ? bins - 1 : pos > 0 ? static_cast<int>(pos) : 0];
  }
  return out;
}

// ---- 4. Diagnose and the verdict -------------------------------------------------------------

std::string FormatLagRanges(const std::vector<int>& lags) {
  std::string out;
  for (std::size_t i = 0; i < lags.size();) {
    std::size_t j = i;
    while (j + 1 < lags.size() && lags[j + 1] == lags[j] + 1) ++j;
    if (!out.empty()) out += ", ";
    out += j == i ? fmt::format("{}", lags[i]) : fmt::format("{}-{}", lags[i], lags[j]);
    i = j + 1;
  }
  return out;
}

namespace {

std::string LagRangesForVerdict(const std::vector<int>& lags) {
  // Keep the first kMaxRangesInVerdict runs.
  std::vector<int> kept;
  int runs = 0;
  for (std::size_t i = 0; i < lags.size(); ++i) {
    if (i == 0 || lags[i] != lags[i - 1] + 1) ++runs;
    if (runs > kMaxRangesInVerdict) break;
    kept.push_back(lags[i]);
  }
  std::string s = FormatLagRanges(kept);
  if (kept.size() < lags.size()) s += ", ...";
  return s;
}

std::string Verdict(const ResidualDiagnostics& d) {
  std::vector<std::string> sentences;
  if (d.white) {
    sentences.push_back(fmt::format(
        "Residuals look white (Ljung-Box p = {:.3g} at {} lags; cumulated periodogram inside its "
        "95% band).",
        d.ljung_box.p_value, d.ljung_box.lags));
  } else {
    std::vector<int> outside;
    for (std::size_t i = 0; i < d.acf.value.size(); ++i)
      if (std::abs(d.acf.value[i]) > d.acf.band) outside.push_back(d.acf.lag[i]);
    std::string s = "Residuals are not white: ";
    if (!outside.empty())
      s += fmt::format("ACF exceeds the band at lag{} {}; ", outside.size() > 1 ? "s" : "",
                       LagRangesForVerdict(outside));
    s += fmt::format("Ljung-Box p = {:.3g} at {} lags", d.ljung_box.p_value, d.ljung_box.lags);
    if (!d.periodogram.inside)
      s += fmt::format(
          "; the cumulated periodogram leaves its 95% band (strongest frequency "
          "{:.3g} cycles per sample)",
          d.periodogram.peak_frequency);
    sentences.push_back(s + ".");
  }
  for (const CrossCorrelogram& c : d.ccf) {
    if (!c.significant) continue;
    std::string s = fmt::format(
        "CCF with {} peaks at lag {}{} (prewhitened input; r = {:.3g}, "
        "95% bound {:.3g})",
        c.input, c.peak_lag > 0 ? "+" : "", c.peak_lag, c.peak, c.peak_bound);
    if (std::abs(c.peak) < kMarginal * c.peak_bound)
      s += ": only just above the bound, possibly chance (1 time in 20 without any effect)";
    else if (c.peak_lag > 0)
      s += fmt::format(
          ": an effect of {} {} sample{} later is not explained - a missing or wrong "
          "delay, or missing dynamics?",
          c.input, c.peak_lag, c.peak_lag > 1 ? "s" : "");
    else if (c.peak_lag == 0)
      s += fmt::format(": a missing direct (same-sample) effect of {}?", c.input);
    else
      s += fmt::format(": the residual leads {} - feedback from the output to the input?", c.input);
    sentences.push_back(s.back() == '?' ? s : s + ".");
  }
  const Normality& nm = d.normality;
  if (nm.sd > kScaleRatio)
    sentences.push_back(
        fmt::format("The standardised residuals have sd {:.3g}: the model's "
                    "predicted variances are too small.",
                    nm.sd));
  else if (nm.sd < 1.0 / kScaleRatio)
    sentences.push_back(
        fmt::format("The standardised residuals have sd {:.3g}: the model's "
                    "predicted variances are too large.",
                    nm.sd));
  if (d.normal) {
    sentences.push_back(
        fmt::format("Normality is not rejected (Jarque-Bera p = {:.3g}).", nm.p_value));
  } else {
    std::string s = fmt::format(
        "Not normal: Jarque-Bera p = {:.3g} (skewness {:.2f}, excess "
        "kurtosis {:.2f})",
        nm.p_value, nm.skewness, nm.excess_kurtosis);
    if (nm.excess_kurtosis > 1.0) s += "; heavy tails: outliers? consider \"robust_huber\"";
    sentences.push_back(s + ".");
  }
  std::string out;
  for (const auto& s : sentences) out += (out.empty() ? "" : " ") + s;
  return out;
}

}  // namespace

Result<ResidualDiagnostics> Diagnose(std::span<const double> z, std::span<const InputSeries> inputs,
                                     const DiagnoseOptions& options) {
  if (std::string why; !options.IsValid(&why)) return InputError("diagnostics options: " + why);
  for ([[maybe_unused]] const InputSeries& in : inputs)
    assert(in.values.size() == z.size() && "inputs cover the same rows as the residuals");

  ResidualDiagnostics d;
  const int N = static_cast<int>(z.size());
  int first = 0, last = N - 1;
  while (first < N && std::isnan(z[first])) ++first;
  while (last >= first && std::isnan(z[last])) --last;
  d.first_row = first;
  d.rows = std::max(0, last - first + 1);
  const std::span<const double> x = z.subspan(first, d.rows);
  const Moments mo = ObservedMoments(x);
  d.n = mo.n;
  if (d.n < kMinResiduals)
    return InputError(
        fmt::format("only {} residual{} observed: at least {} are needed for "
                    "residual diagnostics",
                    d.n, d.n == 1 ? " is" : "s are", kMinResiduals));
  if (!(mo.m2 > 0)) return InputError("the residuals do not vary: no correlation can be computed");

  d.max_lag =
      options.max_lag > 0 ? options.max_lag : std::max(1, std::min(kDefaultMaxLag, d.n / 4));
  if (d.max_lag >= d.n)
    return InputError(fmt::format("max_lag {} needs more than {} observed residuals; there are {}",
                                  d.max_lag, d.max_lag, d.n));
  const int lb_lags = options.ljung_box_lags > 0 ? options.ljung_box_lags
                                                 : std::min(kDefaultLjungBoxLags, d.max_lag);
  if (lb_lags >= d.n)
    return InputError(
        fmt::format("{} Ljung-Box lags need more than {} observed residuals; there "
                    "are {}",
                    lb_lags, lb_lags, d.n));
  if (lb_lags - options.fitted_arma_params < 1)
    return InputError(
        fmt::format("the Ljung-Box test at {} lags with {} fitted ARMA parameters "
                    "has no degrees of freedom",
                    lb_lags, options.fitted_arma_params));

  Correlogram acf = Autocorrelation(x, std::max(d.max_lag, lb_lags));
  d.ljung_box = LjungBoxTest(acf, lb_lags, options.fitted_arma_params);
  acf.lag.resize(d.max_lag);
  acf.value.resize(d.max_lag);
  d.acf = acf;
  d.pacf = PartialAutocorrelation(acf);

  const int K = d.max_lag;
  for (const InputSeries& in : inputs) {
    CrossCorrelogram c;
    c.input = in.name;
    const std::span<const double> u = in.values.subspan(first, d.rows);
    c.constant = !(ObservedMoments(u).m2 > 0);
    if (!c.constant) {
      c.ccf = CrossCorrelation(x, u, K);
      const Prewhitened alpha = Prewhiten(u, std::min(kMaxPrewhiteningOrder, d.n / 10));
      c.prewhitening_ar = alpha.ar;
      c.ccf_prewhitened = CrossCorrelation(x, alpha.values, K);
      const Correlogram& pw = c.ccf_prewhitened;
      int best = -1;
      for (int i = 0; i < static_cast<int>(pw.value.size()); ++i)
        if (!std::isnan(pw.value[i]) &&
            (best < 0 || std::abs(pw.value[i]) > std::abs(pw.value[best])))
          best = i;
      if (best >= 0) {
        c.peak_lag = pw.lag[best];
        c.peak = pw.value[best];
      }
      const boost::math::normal_distribution<double> normal;
      const double z_bonferroni =
          boost::math::quantile(normal, 1.0 - 0.5 * kTestLevel / static_cast<double>(2 * K + 1));
      c.peak_bound = z_bonferroni / std::sqrt(static_cast<double>(d.n));
      c.significant = best >= 0 && std::abs(c.peak) > c.peak_bound;
    }
    d.ccf.push_back(std::move(c));
  }

  d.periodogram = CumulativePeriodogram(x);
  d.normality = NormalityTests(x, options.histogram_bins);
  d.white = d.ljung_box.p_value >= kTestLevel && d.periodogram.inside;
  d.normal = d.normality.p_value >= kTestLevel;
  d.verdict = Verdict(d);
  return d;
}

}  // namespace gb::diagnose
