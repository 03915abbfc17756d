// On-line change detection for condition monitoring: Page's CUSUM tests on standardised
// innovations, with thresholds designed for a false-alarm rate the user sets.
//
// A Kalman filter run at a reference model gives, per observed output and sample, the standardised
// innovation z = ε/√R, i.i.d. N(0, 1) while the system is unchanged. Each test accumulates the
// log-likelihood ratio of a change against no change:
//   S_0 = 0,   S_t = max(0, S_{t-1} + s(z_t)),   alarm when S_t > h, and then S_t = 0 again,
// with the increments s(z) = log f_1(z) / f_0(z), f_0 = N(0, 1):
//   mean up by δ > 0 (SD units)   s =  δ z - δ²/2                        f_1 = N(+δ, 1)
//   mean down by δ                s = -δ z - δ²/2                        f_1 = N(-δ, 1)
//   variance up by ρ > 1          s = ½ log(1/ρ) + ½ z² (1 - 1/ρ)        f_1 = N(0, ρ)
// The textbook (tabular) CUSUM C_t = max(0, C_{t-1} + z_t - k), alarm when C_t > H, is the mean-up
// test scaled: S_t = δ C_t with k = δ/2, so h = δ H; for δ = 1, k = ½ and h = H. The variance test
// is the CUSUM-S² C_t = max(0, C_{t-1} + z_t² - k) with k = log ρ / (1 - 1/ρ), S_t = ½ (1 - 1/ρ)
// C_t.
//
// Average run length (ARL, in samples). L(s) = E[first t with S_t > h | S_0 = s] solves
//   L(s) = 1 + L(0) F(-s) + ∫_0^h L(x) f(x - s) dx,   0 <= s <= h,
// f, F the density and CDF of s(z) under the true law of z, taken as N(μ, σ²): (0, 1) gives the
// in-control ARL0 = L(0), a change the out-of-control ARL1. f is normal for the mean tests and a
// scaled, shifted χ²₁ (non-central when μ ≠ 0) for the variance test.
//
// How it is computed, and why so:
// - Cycles (Page 1954). From 0, S runs until it leaves (0, h]: after N(0) samples on average, with
//   an alarm with probability P(0), else back at 0. So L(0) = N(0) / P(0), with
//     N(s) = 1 + ∫_0^h N(x) f(x - s) dx,     P(s) = (1 - F(h - s)) + ∫_0^h P(x) f(x - s) dx,
//   which is the same L(0) (L(s) = N(s) + L(0) (1 - P(s)) solves the equation above). The
//   condition of these systems grows like the time to leave (0, h] (tens to thousands of steps),
//   that of the restart equation like the ARL itself: solved directly, an ARL0 of 1e10 came out
//   to only ~1e-5 in double precision.
// - In control P(0) ~ 1/ARL0 is tiny, and solved for directly it would carry an absolute, not a
//   relative, rounding error. So it is taken under the tilted law dP_θ = e^{θ s} dP with
//   E[e^{θ s}] = 1, θ > 0 (Wald's likelihood-ratio identity; for the LLR in control θ = 1 and
//   P_θ is f_1):
//     P(0) = e^{-θ h} G(0),   G(s) = e^{θ (h - s)} (1 - F(h - s)) + ∫_0^h G(x) f_θ(x - s) dx,
//   G(0) = E_θ[e^{-θ (overshoot)}; alarm] being of order one. Hence ARL0 >= e^h (N(0) >= 1 and
//   G(0) <= 1), and log ARL0(h) is nearly linear in h.
// - Quadrature in the innovation, not in x. Nyström with Gauss-Legendre nodes in x needs a smooth
//   kernel, but the χ²₁ density is infinite at its lower end (Nyström then converges slowly and can
//   hit the pole). With z = μ + σ u, u ~ N(0, 1), the increment is a quadratic q(u) and
//     ∫_0^h N(x) f(x - s) dx = ∫_{0 < s + q(u) <= h} N(s + q(u)) φ(u) du,
//   smooth in u, over at most two intervals found in closed form; 1 - F(t) is a normal probability
//   (Boost.Math). N, P and G are polynomials on pieces of [0, h] (Lagrange at n Gauss-Legendre
//   nodes per piece), collocated at those nodes: a dense system of n × pieces unknowns (LU), the
//   inner integrals by Gauss-Legendre in u.
// - Pieces. The mean tests' solutions are analytic; pieces are at most 1 and at most two SDs of the
//   increment wide. The variance test's are not smooth at multiples of d = ½ log ρ, where the
//   cycle's end at 0 is seen through the χ²₁ pole: they behave like (k d - s)^{k/2} just below k d,
//   so pieces break at k d and shrink geometrically towards d and 3d (hp grading).
// - Accuracy: 1e-9 relative or better at the default 12 nodes a piece (1e-12 for the mean tests
//   with δ >= 1), at any ARL: doubling the nodes changes the ARL by less than 1e-8. Published
//   tables are met to their last digit (tests/core/cusum_test.cpp). The cost grows with h / SD(s)
//   (docs/benchmarks.md, "Timings behind the code's limits").
// - Not the Brook-Evans Markov chain: its error is O(1/states²) and Richardson extrapolation
//   assumes a regular error expansion, which the atom at 0 and the χ²₁ pole break.
//
// False-alarm design. The user sets a combined rate r (false alarms per hour) for the m statistics
// that run together (three per output: mean up, mean down, variance up; m = 3p), each updated every
// T_s seconds. A statistic restarts at 0 after its alarm, so its alarms form a renewal process at
// 1/ARL0 per sample. Bonferroni: each gets r/m per hour, i.e.
//   ARL0 = 3600 m / (r T_s)   samples,
// and h solves ARL0(h) = that target (TOMS 748 on log ARL0(h)). The expected number of false
// alarms per hour summed over the m statistics is then r; the rate of samples with at least one
// alarm is at most r (union bound, no independence needed), slightly below it when two alarm at
// the same sample. Missing observations only lower the rates: a statistic not updated cannot alarm.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/util/result.h"

namespace gb::online {

enum class CusumKind { kMeanUp, kMeanDown, kVarianceUp };
inline constexpr int kCusumKinds = 3;

// "mean up", "mean down", "variance up".
const char* CusumKindName(CusumKind kind);

// The change a test is tuned to. Smaller changes need more pieces (their increments are small):
// the bounds keep one ARL integral short (docs/benchmarks.md, "Timings behind the code's
// limits").
inline constexpr double kMinMeanShift = 0.1;
inline constexpr double kMinVarianceRatio = 1.1;
struct CusumChange {
  CusumKind kind = CusumKind::kMeanUp;
  double size = 1.0;  // δ for the mean tests (SD units of z), ρ for the variance test
  bool IsValid(std::string* why) const;
};

// s(z), the log-likelihood-ratio increment above.
double CusumIncrement(const CusumChange& change, double z);

// The law the run lengths are computed under: z ~ N(mean, variance). {0, 1} is in control.
struct Innovations {
  double mean = 0.0;
  double variance = 1.0;
};

struct ArlOptions {
  int nodes_per_piece = 12;  // n, 2 .. 64: Gauss-Legendre collocation nodes on each piece of [0, h]
  bool IsValid(std::string* why) const;
};

// The zero-state ARL L(0), in samples; +∞ when alarms are astronomically rare under `truth` (an
// ARL beyond 1e304, or a tilt within 1e-12 of its pole: e.g. the variance test with ρ = 2 after
// the variance fell 20-fold). Preconditions (asserted): valid change and options, 0 < h <= 500,
// truth.variance > 0. The uniform pieces are at least h/200 wide: when the increment's SD under
// `truth` is below h/400 (e.g. σ < 0.05 for δ = 1 and h = 20) the accuracy above is not assured.
double AverageRunLength(const CusumChange& change, double h, const Innovations& truth = {},
                        const ArlOptions& options = {});

// Targets above this are refused (at 1 kHz, 30 000 years per false alarm).
inline constexpr double kMaxArl0 = 1e15;

// The h with in-control ARL0(h) = arl0, to about 1e-8 relative in the ARL. Errors (kInput): an
// invalid change or options; arl0 not above the ARL0 of h -> 0+, 1 / P(s(z) > 0) (3.2 for
// δ = 1: the test cannot wait longer than its first positive increment); arl0 above kMaxArl0.
Result<double> ThresholdForArl0(const CusumChange& change, double arl0,
                                const ArlOptions& options = {});

// ---- the detector ------------------------------------------------------------------------------

struct CusumOptions {
  int outputs = 1;                       // p; three statistics each, m = 3p
  double sample_time = 1.0 / 80.0;       // T_s, seconds between two samples of one output
  double false_alarms_per_hour = 0.125;  // r, all m statistics together (one per 8 hours)
  double mean_shift = 1.0;               // δ: a one-SD shift of the innovation mean
  double variance_ratio = 2.0;           // ρ: a doubling of the innovation variance
  ArlOptions arl;
  bool IsValid(std::string* why) const;
};

// What DesignCusum chose. Both mean tests share h_mean (their ARLs are mirror images).
struct CusumDesign {
  int outputs = 0;
  int statistics = 0;  // m = 3p
  double sample_time = 0.0;
  double false_alarms_per_hour = 0.0;
  double mean_shift = 0.0;      // δ
  double variance_ratio = 0.0;  // ρ
  double arl0 = 0.0;            // per statistic, samples: 3600 m / (r T_s)
  double h_mean = 0.0;
  double h_variance = 0.0;
  double arl1_mean = 0.0;      // samples to the mean-up alarm after the mean shifts by +δ
  double arl1_variance = 0.0;  // samples to the variance alarm after the variance becomes ρ
  std::string Report() const;  // a few lines for the user
};

// Errors (kInput): invalid options; a rate too high for the tests to reach (ARL0 below
// 1 / P(s(z) > 0)) or so low that ARL0 exceeds kMaxArl0; the message says which and why.
Result<CusumDesign> DesignCusum(const CusumOptions& options);

struct CusumAlarm {
  int output = 0;
  CusumKind kind = CusumKind::kMeanUp;
  double statistic = 0.0;  // S_t / h when it alarmed (> 1)
  const char* name() const { return CusumKindName(kind); }
};

// The alarms one update raised: 0 .. 3, all of the same output. A value: no allocation.
struct CusumAlarms {
  std::array<CusumAlarm, kCusumKinds> alarm{};
  int count = 0;
  bool any() const { return count > 0; }
  const CusumAlarm* begin() const { return alarm.data(); }
  const CusumAlarm* end() const { return alarm.data() + count; }
};

// The 3p statistics of a design, fed one innovation at a time. O(1) per update, no allocation
// after construction.
class CusumDetector {
 public:
  // Precondition (asserted): outputs >= 1, positive thresholds, a valid δ and ρ.
  explicit CusumDetector(const CusumDesign& design);

  // Feeds output `output`'s standardised innovation (0 <= output < p, asserted). NaN is a missing
  // observation: nothing changes. ±∞ (a diverged filter) alarms. A statistic that alarms restarts
  // at 0 and the others go on, which keeps each one's alarms a renewal process at the design rate.
  CusumAlarms Update(int output, double z);

  // All statistics and alarm counts to 0.
  void Reset();

  // S_t / h, in [0, 1] (0 right after an alarm): for plotting.
  double Statistic(int output, CusumKind kind) const;
  long long AlarmCount() const { return total_alarms_; }
  long long AlarmCount(int output, CusumKind kind) const;
  int outputs() const { return design_.outputs; }
  const CusumDesign& design() const { return design_; }

 private:
  CusumDesign design_;
  std::array<std::array<double, 3>, kCusumKinds> increment_{};  // s(z) = a0 + a1 z + a2 z²
  std::array<double, kCusumKinds> h_{};
  std::vector<std::array<double, kCusumKinds>> s_;  // per output
  std::vector<std::array<long long, kCusumKinds>> alarms_;
  long long total_alarms_ = 0;
};

}  // namespace gb::online
