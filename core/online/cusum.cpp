// Sections: constants; increments and normal probabilities; the tilt; Gauss-Legendre rules and
// the Lagrange basis; pieces; the cycle equation and the ARL; thresholds; design and report; the
// detector. The method and its reasons are in the header.
#include "core/online/cusum.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/tools/toms748_solve.hpp>
#include <fmt/format.h>

namespace gb::online {
namespace {

constexpr int kMinNodes = 2;
constexpr int kMaxNodes = 64;
// |u| beyond this carries probability below 1.3e-15: the integrals in u stop there.
constexpr double kTail = 8.0;
// Inner Gauss-Legendre rule: on u-intervals at most kInnerWidth wide, kInnerExtra nodes more
// than the polynomials in u need (degree n - 1 for the mean tests, 2n - 2 for the variance test).
constexpr double kInnerWidth = 1.0;
constexpr int kInnerExtra = 8;
// On u-intervals narrower than kNarrowWidth φ is nearly constant: kNarrowExtra nodes more suffice.
constexpr double kNarrowWidth = 0.05;
constexpr int kNarrowExtra = 2;
// Pieces of [0, h] at most kMaxPieceWidth wide, and at most kWidthPerScale SDs of the increment.
constexpr double kMaxPieceWidth = 1.0;
constexpr double kWidthPerScale = 2.0;
// The variance test's N and G are not smooth at k d, k = 1, 2, ...: there they behave like
// (k d - s)^{k/2} (the jump at 0 that ends a cycle, seen through the χ²₁ pole, convolved k times).
// Pieces break at k d for k <= kBreaks (beyond, the power is smooth enough for the polynomials);
// below d and 3d, where it is a half power, they shrink geometrically towards the break point
// (kGrading^layers d: 6e-6 d below d).
constexpr int kBreaks = 8;
constexpr double kGrading = 0.3;
constexpr int kLayersBelowD = 10;
constexpr int kLayersBelow3D = 3;
// Pieces beyond break points and grading are at least h / kMaxPieces wide (bounds the cost).
constexpr int kMaxPieces = 200;

// Threshold search: TOMS 748 to 2^(1 - kRootBits) relative in h (about 1e-8 in the ARL).
constexpr int kRootBits = 30;
constexpr std::uintmax_t kRootIterations = 100;
constexpr double kSmallestThreshold = 1e-9;
// Targets this close to the ARL0 of h -> 0+ are refused (h would underflow the search).
constexpr double kShortestMargin = 1e-6;
constexpr double kSecondsPerHour = 3600.0;
// The tilt's root is refused this close (relatively) to its pole; exp(x) overflows above this x.
constexpr double kTiltPole = 1e-12;
constexpr double kLogOverflow = 700.0;

// ---- increments and normal probabilities --------------------------------------------------------

// a0 + a1 u + a2 u².
struct Quadratic {
  double a0 = 0.0, a1 = 0.0, a2 = 0.0;
  double operator()(double u) const { return a0 + u * (a1 + u * a2); }
  double Mean() const { return a0 + a2; }  // for u ~ N(0, 1)
  double Sd() const { return std::sqrt(a1 * a1 + 2.0 * a2 * a2); }
  double Min() const { return a2 > 0.0 ? a0 - a1 * a1 / (4.0 * a2) : -kInfinity; }
  static constexpr double kInfinity = std::numeric_limits<double>::infinity();
};

// q(mean + sd u): the same increment for u ~ N(0, 1) when its argument is N(mean, sd²).
Quadratic Compose(const Quadratic& q, double mean, double sd) {
  return {q(mean), (q.a1 + 2.0 * q.a2 * mean) * sd, q.a2 * sd * sd};
}

Quadratic IncrementInZ(const CusumChange& change) {
  const double d = change.size;
  switch (change.kind) {
    case CusumKind::kMeanUp:
      return {-0.5 * d * d, d, 0.0};
    case CusumKind::kMeanDown:
      return {-0.5 * d * d, -d, 0.0};
    case CusumKind::kVarianceUp:
      return {-0.5 * std::log(d), 0.0, 0.5 * (1.0 - 1.0 / d)};
  }
  return {};
}

const boost::math::normal kStandardNormal;

double Phi(double x) {
  if (std::isinf(x)) return x > 0 ? 1.0 : 0.0;
  return boost::math::cdf(kStandardNormal, x);
}
double PhiComplement(double x) {
  if (std::isinf(x)) return x > 0 ? 0.0 : 1.0;
  return boost::math::cdf(boost::math::complement(kStandardNormal, x));
}

struct Interval {
  double a = 0.0, b = 0.0;
};

// P(a <= u <= b) for u ~ N(0, 1), without cancellation in either tail.
double NormalMass(Interval i) {
  return i.a >= 0.0 ? PhiComplement(i.a) - PhiComplement(i.b) : Phi(i.b) - Phi(i.a);
}

// {u : lo < q(u) <= hi} as at most two intervals (end points do not matter: q has no flat part).
int Preimage(const Quadratic& q, double lo, double hi, std::array<Interval, 2>& out) {
  if (!(lo < hi)) return 0;
  if (q.a2 == 0.0) {
    const double ua = (lo - q.a0) / q.a1, ub = (hi - q.a0) / q.a1;
    out[0] = {std::min(ua, ub), std::max(ua, ub)};
    return 1;
  }
  assert(q.a2 > 0.0);
  const double vertex = -q.a1 / (2.0 * q.a2);
  if (hi <= q.Min()) return 0;
  const double r_hi = std::sqrt((hi - q.Min()) / q.a2);
  if (lo <= q.Min()) {
    out[0] = {vertex - r_hi, vertex + r_hi};
    return 1;
  }
  const double r_lo = std::sqrt((lo - q.Min()) / q.a2);
  out[0] = {vertex - r_hi, vertex - r_lo};
  out[1] = {vertex + r_lo, vertex + r_hi};
  return 2;
}

// P(q(u) > t).
double Tail(const Quadratic& q, double t) {
  std::array<Interval, 2> intervals;
  const int found = Preimage(q, t, Quadratic::kInfinity, intervals);
  double mass = 0.0;
  for (int k = 0; k < found; ++k) mass += NormalMass(intervals[k]);
  return mass;
}

// ---- the tilt -----------------------------------------------------------------------------------

// The θ > 0 with E[exp(θ q(u))] = 1, for a q of negative mean. log E[exp(θ q)] = ψ(θ) =
// θ a0 - ½ log(1 - 2θ a2) + θ² a1² / (2 (1 - 2θ a2)) is convex with ψ(0) = 0, so ψ(θ)/θ rises
// from the mean of q at 0+ to +∞ at θ = 1/(2 a2): one root. None when it lies within kTiltPole of
// that pole (the tilted variance 1/(1 - 2θ a2) would exceed 1/kTiltPole): then an alarm needs
// |u| beyond about 5 and the ARL is taken as +∞.
std::optional<double> Tilt(const Quadratic& q) {
  assert(q.Mean() < 0.0);
  if (q.a2 == 0.0) return -2.0 * q.a0 / (q.a1 * q.a1);
  const auto psi_over_theta = [&q](double theta) {
    if (theta == 0.0) return q.Mean();
    const double g = 1.0 - 2.0 * theta * q.a2;
    return q.a0 - std::log1p(-2.0 * theta * q.a2) / (2.0 * theta) + theta * q.a1 * q.a1 / (2.0 * g);
  };
  const double top = (1.0 - kTiltPole) / (2.0 * q.a2);
  const double at_top = psi_over_theta(top);
  if (!(at_top > 0.0)) return std::nullopt;
  std::uintmax_t iterations = kRootIterations;
  const auto [lo, hi] = boost::math::tools::toms748_solve(
      psi_over_theta, 0.0, top, q.Mean(), at_top,
      boost::math::tools::eps_tolerance<double>(std::numeric_limits<double>::digits - 1),
      iterations);
  return 0.5 * (lo + hi);
}

// ---- Gauss-Legendre rules and the Lagrange basis ------------------------------------------------

// Gauss-Legendre nodes (ascending) and weights on [-1, 1], by Newton's method on P_n.
struct Rule {
  std::vector<double> x, w;
};

Rule GaussLegendre(int n) {
  Rule rule{std::vector<double>(n), std::vector<double>(n)};
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double x = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int iteration = 0; iteration < 100; ++iteration) {
      double p0 = 1.0, p1 = x;  // P_{k-1}, P_k
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      const double step = p1 / dp;
      x -= step;
      if (std::abs(step) < 1e-16) break;
    }
    rule.x[n - 1 - i] = x;
    rule.x[i] = -x;
    rule.w[n - 1 - i] = rule.w[i] = 2.0 / ((1.0 - x * x) * dp * dp);
  }
  return rule;
}

// Lagrange basis at the nodes of `rule`, evaluated by the barycentric formula.
class LagrangeBasis {
 public:
  explicit LagrangeBasis(const Rule& rule) : x_(rule.x), c_(rule.x.size()) {
    for (std::size_t j = 0; j < x_.size(); ++j)
      c_[j] = (j % 2 == 0 ? 1.0 : -1.0) * std::sqrt((1.0 - x_[j] * x_[j]) * rule.w[j]);
  }
  // ℓ_j(t) for all j into `out`.
  void Evaluate(double t, double* out) const {
    const double scale = Terms(t, out);
    for (std::size_t j = 0; j < x_.size(); ++j) out[j] *= scale;
  }
  // ℓ_j(t) = scale · out[j]: the barycentric terms into `out`, and the factor (1 / their sum)
  // returned, for callers that can fold it into a weight of their own.
  double Terms(double t, double* out) const {
    const std::size_t n = x_.size();
    double sum = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
      const double diff = t - x_[j];
      if (diff == 0.0) {
        std::fill(out, out + n, 0.0);
        out[j] = 1.0;
        return 1.0;
      }
      out[j] = c_[j] / diff;
      sum += out[j];
    }
    return 1.0 / sum;
  }

 private:
  std::vector<double> x_, c_;
};

// ---- pieces -------------------------------------------------------------------------------------

struct Piece {
  double left = 0.0, right = 0.0;
};

// Break points 0 < .. < h: k d (graded below d and 3d), then pieces no wider than `width`.
std::vector<Piece> MakePieces(double h, double d, double width) {
  std::vector<double> breaks{0.0};
  const auto add = [&breaks, h](double x) {
    if (x > breaks.back() + 1e-12 * h && x < h * (1.0 - 1e-12)) breaks.push_back(x);
  };
  if (d > 0.0) {
    for (int k = 1; k <= kBreaks; ++k) {
      const int layers = k == 1 ? kLayersBelowD : k == 3 ? kLayersBelow3D : 0;
      for (int l = 1; l <= layers; ++l) add(k * d - d * std::pow(kGrading, l));
      add(k * d);
    }
  }
  breaks.push_back(h);
  std::vector<Piece> pieces;
  for (std::size_t b = 0; b + 1 < breaks.size(); ++b) {
    const double gap = breaks[b + 1] - breaks[b];
    const int count = std::max(1, static_cast<int>(std::ceil(gap / width - 1e-9)));
    for (int i = 0; i < count; ++i)
      pieces.push_back({breaks[b] + gap * i / count, breaks[b] + gap * (i + 1) / count});
  }
  return pieces;
}

// ---- the cycle equation and the ARL -------------------------------------------------------------

// Collocation of  v(s) = b(s) + ∫_{0 < s + q(u) <= h} v(s + q(u)) φ(u) du  (one cycle of the
// CUSUM: it ends when S leaves (0, h]), factored once and solved for any b given at the nodes.
class CycleEquation {
 public:
  CycleEquation(const Quadratic& q, const std::vector<Piece>& pieces, int n)
      : pieces_(pieces), n_(n), rule_(GaussLegendre(n)) {
    const LagrangeBasis basis(rule_);
    const int size = static_cast<int>(pieces.size()) * n;
    // The polynomials in u have degree n - 1 (mean tests) or 2n - 2 (variance test).
    const int exact_nodes = q.a2 > 0.0 ? n : (n + 1) / 2;
    const Rule wide = GaussLegendre(exact_nodes + kInnerExtra);
    const Rule narrow = GaussLegendre(exact_nodes + kNarrowExtra);
    at_zero_.resize(n);
    basis.Evaluate(-1.0, at_zero_.data());  // v(0) from the first piece

    // Filled row by row (row-major keeps the scattered updates of a row in one place).
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> A =
        Eigen::MatrixXd::Identity(size, size);
    std::vector<double> ell(n);
    std::array<Interval, 2> intervals;
    for (int row = 0; row < size; ++row) {
      const double s = Node(row);
      double* a_row = A.row(row).data();  // contiguous (row-major)
      for (std::size_t r = 0; r < pieces.size(); ++r) {
        const double mid = 0.5 * (pieces[r].left + pieces[r].right);
        const double half = 0.5 * (pieces[r].right - pieces[r].left);
        const int found = Preimage(q, pieces[r].left - s, pieces[r].right - s, intervals);
        for (int k = 0; k < found; ++k) {
          const double a = std::max(intervals[k].a, -kTail);
          const double b = std::min(intervals[k].b, kTail);
          if (!(a < b)) continue;
          const int parts = static_cast<int>(std::ceil((b - a) / kInnerWidth));
          const double part = (b - a) / parts;
          const Rule& inner = part < kNarrowWidth ? narrow : wide;
          for (int m = 0; m < parts; ++m) {
            for (std::size_t g = 0; g < inner.x.size(); ++g) {
              const double u = a + part * (m + 0.5 + 0.5 * inner.x[g]);
              const double weight = 0.5 * part * inner.w[g] * std::exp(-0.5 * u * u) /
                                    std::sqrt(2.0 * std::numbers::pi);
              const double scale =
                  basis.Terms(std::clamp((s + q(u) - mid) / half, -1.0, 1.0), ell.data());
              const double scaled = weight * scale;
              double* a = a_row + r * n;
              for (int j = 0; j < n; ++j) a[j] -= scaled * ell[j];
            }
          }
        }
      }
    }
    lu_.compute(A);
  }

  int size() const { return static_cast<int>(pieces_.size()) * n_; }
  double Node(int index) const {
    const Piece& p = pieces_[index / n_];
    return 0.5 * (p.left + p.right) + 0.5 * (p.right - p.left) * rule_.x[index % n_];
  }
  // v(0) for b given at the nodes.
  double SolveAtZero(const Eigen::VectorXd& b) const {
    const Eigen::VectorXd v = lu_.solve(b);
    double at_zero = 0.0;
    for (int j = 0; j < n_; ++j) at_zero += at_zero_[j] * v(j);
    return at_zero;
  }

 private:
  std::vector<Piece> pieces_;
  int n_;
  Rule rule_;
  std::vector<double> at_zero_;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu_;
};

// L(0) = N(0) / P(0) (Page 1954): one cycle from 0 lasts N(0) samples on average and ends with an
// alarm with probability P(0); cycles that end at 0 restart from 0. N solves the cycle equation
// with b = 1; P with b(s) = P(q > h - s). When q drifts down, P(0) is tiny (about 1/ARL) and is
// taken instead under the tilted law dP_θ = exp(θ q) dP, E[exp(θ q)] = 1 (Wald's likelihood-ratio
// identity; for the LLR in control θ = 1 and P_θ is the alternative):
//   P(0) = exp(-θ h) G(0),   G(s) = E_θ[exp(-θ (S_τ - h)); S_τ > h | S_0 = s],
// G solving the cycle equation under P_θ with b(s) = exp(θ (h - s)) P(q > h - s). G(0) is of
// order one, so P(0) keeps its relative precision however large the ARL.
double SolveArl(const Quadratic& q, double h, int n) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  const bool drifts_down = q.Mean() < 0.0;
  double theta = 0.0;
  if (drifts_down) {
    const std::optional<double> tilt = Tilt(q);
    // exp(θ h) > 1e304 (beyond double range), or no tilt: alarms are astronomically rare.
    if (!tilt || *tilt * h > kLogOverflow) return kInfinity;
    theta = *tilt;
  }
  // u ~ N(0, 1) under P; under P_θ, u ~ N(θ a1 v, v) with v = 1 / (1 - 2θ a2).
  const double v = 1.0 / (1.0 - 2.0 * theta * q.a2);
  const Quadratic tilted = Compose(q, theta * q.a1 * v, std::sqrt(v));
  const double scale = std::min(q.Sd(), drifts_down ? tilted.Sd() : q.Sd());
  const double width = std::max(h / kMaxPieces, std::min(kMaxPieceWidth, kWidthPerScale * scale));
  const std::vector<Piece> pieces = MakePieces(h, q.a2 > 0.0 ? -q.Min() : 0.0, width);

  const CycleEquation cycle(q, pieces, n);
  const double length = cycle.SolveAtZero(Eigen::VectorXd::Ones(cycle.size()));
  Eigen::VectorXd b(cycle.size());
  if (!drifts_down) {
    for (int i = 0; i < cycle.size(); ++i) b(i) = Tail(q, h - cycle.Node(i));
    return length / cycle.SolveAtZero(b);
  }
  const CycleEquation tilted_cycle(tilted, pieces, n);
  for (int i = 0; i < cycle.size(); ++i) {
    const double s = cycle.Node(i);
    b(i) = std::exp(theta * (h - s)) * Tail(q, h - s);
  }
  return length * std::exp(theta * h) / tilted_cycle.SolveAtZero(b);
}

}  // namespace

const char* CusumKindName(CusumKind kind) {
  switch (kind) {
    case CusumKind::kMeanUp:
      return "mean up";
    case CusumKind::kMeanDown:
      return "mean down";
    case CusumKind::kVarianceUp:
      return "variance up";
  }
  return "?";
}

bool CusumChange::IsValid(std::string* why) const {
  const bool mean = kind != CusumKind::kVarianceUp;
  if (mean && !(size >= kMinMeanShift && std::isfinite(size))) {
    if (why)
      *why = fmt::format("the mean shift δ must be at least {} and finite (is {})", kMinMeanShift,
                         size);
    return false;
  }
  if (!mean && !(size >= kMinVarianceRatio && std::isfinite(size))) {
    if (why)
      *why = fmt::format("the variance ratio ρ must be at least {} and finite (is {})",
                         kMinVarianceRatio, size);
    return false;
  }
  return true;
}

double CusumIncrement(const CusumChange& change, double z) { return IncrementInZ(change)(z); }

bool ArlOptions::IsValid(std::string* why) const {
  if (nodes_per_piece < kMinNodes || nodes_per_piece > kMaxNodes) {
    if (why)
      *why = fmt::format("nodes_per_piece must be {} .. {} (is {})", kMinNodes, kMaxNodes,
                         nodes_per_piece);
    return false;
  }
  return true;
}

double AverageRunLength(const CusumChange& change, double h, const Innovations& truth,
                        const ArlOptions& options) {
  assert(change.IsValid(nullptr) && options.IsValid(nullptr));
  assert(h > 0.0 && h <= 500.0 && truth.variance > 0.0 && std::isfinite(truth.mean));
  const Quadratic q = Compose(IncrementInZ(change), truth.mean, std::sqrt(truth.variance));
  return SolveArl(q, h, options.nodes_per_piece);
}

// ---- thresholds ---------------------------------------------------------------------------------

Result<double> ThresholdForArl0(const CusumChange& change, double arl0, const ArlOptions& options) {
  std::string why;
  if (!change.IsValid(&why) || !options.IsValid(&why)) return InputError(why);
  const Quadratic q = IncrementInZ(change);
  // As h -> 0+ the test alarms at its first positive increment.
  const double shortest = 1.0 / Tail(q, 0.0);
  if (!(arl0 > shortest * (1.0 + kShortestMargin)))
    return InputError(fmt::format(
        "an in-control ARL of {:.4g} samples is out of reach of the {} test ({} = {}): even "
        "with the smallest threshold it alarms every {:.4g} samples on average",
        arl0, CusumKindName(change.kind), change.kind == CusumKind::kVarianceUp ? "ρ" : "δ",
        change.size, shortest));
  if (!(arl0 <= kMaxArl0))
    return InputError(
        fmt::format("an in-control ARL of {:.4g} samples is above the {:.0e} this "
                    "design accepts",
                    arl0, kMaxArl0));
  const int n = options.nodes_per_piece;
  const auto f = [&](double h) { return std::log(SolveArl(q, h, n) / arl0); };
  // ARL0(h) >= e^h (see the header), and log ARL0 rises by about 1 per unit of h.
  double hi = std::log(arl0), f_hi = f(hi);
  double lo = std::max(0.5 * hi, hi - 2.0), f_lo = f(lo);
  while (f_lo >= 0.0) {
    hi = lo;
    f_hi = f_lo;
    lo = std::max(0.5 * lo, lo - 4.0);
    if (lo < kSmallestThreshold)
      return NumericalError(
          fmt::format("no threshold found for an in-control ARL of {:.4g}", arl0));
    f_lo = f(lo);
  }
  if (f_hi == 0.0) return hi;
  std::uintmax_t iterations = kRootIterations;
  const auto [a, b] = boost::math::tools::toms748_solve(
      f, lo, hi, f_lo, f_hi, boost::math::tools::eps_tolerance<double>(kRootBits), iterations);
  return 0.5 * (a + b);
}

// ---- design and report --------------------------------------------------------------------------

bool CusumOptions::IsValid(std::string* why) const {
  const auto fail = [why](std::string message) {
    if (why) *why = std::move(message);
    return false;
  };
  if (outputs < 1) return fail(fmt::format("outputs must be at least 1 (is {})", outputs));
  if (!(sample_time > 0.0 && std::isfinite(sample_time)))
    return fail(fmt::format("the sample time must be positive (is {} s)", sample_time));
  if (!(false_alarms_per_hour > 0.0 && std::isfinite(false_alarms_per_hour)))
    return fail(fmt::format("the false-alarm rate must be positive (is {} per hour)",
                            false_alarms_per_hour));
  if (!CusumChange{CusumKind::kMeanUp, mean_shift}.IsValid(why)) return false;
  if (!CusumChange{CusumKind::kVarianceUp, variance_ratio}.IsValid(why)) return false;
  return arl.IsValid(why);
}

Result<CusumDesign> DesignCusum(const CusumOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) return InputError(why);
  CusumDesign design;
  design.outputs = options.outputs;
  design.statistics = kCusumKinds * options.outputs;
  design.sample_time = options.sample_time;
  design.false_alarms_per_hour = options.false_alarms_per_hour;
  design.mean_shift = options.mean_shift;
  design.variance_ratio = options.variance_ratio;
  design.arl0 =
      kSecondsPerHour * design.statistics / (options.false_alarms_per_hour * options.sample_time);
  const CusumChange mean{CusumKind::kMeanUp, options.mean_shift};
  const CusumChange variance{CusumKind::kVarianceUp, options.variance_ratio};
  const auto explain = [&](const Error& error) {
    return InputError(fmt::format(
        "{} false alarms per hour over {} statistics sampled every {} s asks each for an "
        "in-control ARL of {:.4g} samples, but {}",
        options.false_alarms_per_hour, design.statistics, options.sample_time, design.arl0,
        error.message));
  };
  const Result<double> h_mean = ThresholdForArl0(mean, design.arl0, options.arl);
  if (!h_mean) return explain(h_mean.error());
  const Result<double> h_variance = ThresholdForArl0(variance, design.arl0, options.arl);
  if (!h_variance) return explain(h_variance.error());
  design.h_mean = *h_mean;
  design.h_variance = *h_variance;
  design.arl1_mean = AverageRunLength(mean, design.h_mean, {options.mean_shift, 1.0}, options.arl);
  design.arl1_variance =
      AverageRunLength(variance, design.h_variance, {0.0, options.variance_ratio}, options.arl);
  return design;
}

std::string CusumDesign::Report() const {
  const auto duration = [this](double samples) {
    const double seconds = samples * sample_time;
    if (seconds < 120.0) return fmt::format("{:.3g} s", seconds);
    if (seconds < 2.0 * kSecondsPerHour) return fmt::format("{:.3g} min", seconds / 60.0);
    return fmt::format("{:.3g} h", seconds / kSecondsPerHour);
  };
  return fmt::format(
      "CUSUM tests on {} output(s): mean up, mean down and variance up each, {} statistics, one "
      "sample every {} s.\n"
      "False alarms: at most {} per hour in all, {:.3g} per hour per statistic (Bonferroni): an "
      "in-control ARL of {:.4g} samples ({}) each.\n"
      "Mean tests: δ = {} SD, h = {:.4f} (tabular CUSUM k = {}, H = {:.4f}); a mean shift of δ "
      "is alarmed after {:.3g} samples ({}) on average.\n"
      "Variance test: ρ = {}, h = {:.4f}; a variance ratio of ρ is alarmed after {:.3g} samples "
      "({}) on average.",
      outputs, statistics, sample_time, false_alarms_per_hour, false_alarms_per_hour / statistics,
      arl0, duration(arl0), mean_shift, h_mean, 0.5 * mean_shift, h_mean / mean_shift, arl1_mean,
      duration(arl1_mean), variance_ratio, h_variance, arl1_variance, duration(arl1_variance));
}

// ---- the detector -------------------------------------------------------------------------------

CusumDetector::CusumDetector(const CusumDesign& design) : design_(design) {
  assert(design.outputs >= 1 && design.h_mean > 0.0 && design.h_variance > 0.0);
  const std::array<CusumChange, kCusumKinds> changes{
      CusumChange{CusumKind::kMeanUp, design.mean_shift},
      CusumChange{CusumKind::kMeanDown, design.mean_shift},
      CusumChange{CusumKind::kVarianceUp, design.variance_ratio}};
  for (int k = 0; k < kCusumKinds; ++k) {
    assert(changes[k].IsValid(nullptr));
    const Quadratic q = IncrementInZ(changes[k]);
    increment_[k] = {q.a0, q.a1, q.a2};
  }
  h_ = {design.h_mean, design.h_mean, design.h_variance};
  s_.assign(design.outputs, {});
  alarms_.assign(design.outputs, {});
}

CusumAlarms CusumDetector::Update(int output, double z) {
  assert(output >= 0 && output < design_.outputs);
  CusumAlarms raised;
  if (std::isnan(z)) return raised;
  std::array<double, kCusumKinds>& s = s_[output];
  for (int k = 0; k < kCusumKinds; ++k) {
    const auto& [a0, a1, a2] = increment_[k];
    // a2 = 0 is skipped rather than multiplied: ∞ · 0 would turn an infinite z into no alarm.
    const double increment = a2 == 0.0 ? a0 + a1 * z : a0 + z * (a1 + z * a2);
    s[k] = std::max(0.0, s[k] + increment);
    if (s[k] > h_[k]) {
      raised.alarm[raised.count++] = {output, static_cast<CusumKind>(k), s[k] / h_[k]};
      s[k] = 0.0;
      ++alarms_[output][k];
      ++total_alarms_;
    }
  }
  return raised;
}

void CusumDetector::Reset() {
  for (auto& s : s_) s.fill(0.0);
  for (auto& a : alarms_) a.fill(0);
  total_alarms_ = 0;
}

double CusumDetector::Statistic(int output, CusumKind kind) const {
  assert(output >= 0 && output < design_.outputs);
  const int k = static_cast<int>(kind);
  return s_[output][k] / h_[k];
}

long long CusumDetector::AlarmCount(int output, CusumKind kind) const {
  assert(output >= 0 && output < design_.outputs);
  return alarms_[output][static_cast<int>(kind)];
}

}  // namespace gb::online
