// One step of the linear Kalman filter (kalman.h) with, optionally, the forward sensitivities of
// its state and covariance (score.h) and the Fisher information of its observations: the one
// update that the filter loop, the score loop (linear_loops.h) and the recursive estimator
// (core/online/recursive.h) all run. Not part of the public API. Templated on the state dimension
// NX (1..kMaxFixedStates with fixed-size matrices, or Eigen::Dynamic).
//
// Scalar measurement update with observation y of output o at state index j (c = C_o; d = ∂/∂θ_i,
// one set per θ_i, none for the filter alone):
//
//   ŷ = c x + d_o + D_o u_j                 dŷ = dc x + c dx + dd_o + dD_o u_j
//   k = P c'                                dk = dP c' + P dc'
//   R = c k + S_o                           dR = dc k + c dk + dS_o
//   ε = y - ŷ                               dε = -dŷ
//   x <- x + k ε/R                          dx <- dx + dk ε/R + k (dε - ε dR/R)/R
//   P <- P - k k'/R                         dP <- dP - (dk k' + k dk')/R + k k' dR/R²
//
// added up over the index's p_j updates (TermSums, and TermScores for the sensitivities) for its
// log-likelihood term (internal.h):
//
//   log det R_j = Σ log R      r² = Σ ε²/R      ℓ_j = -(½ (log det R_j + p_j log 2π) + ρ(r²))
//   Σ dR/R      Σ d(ε²/R) = Σ (2 ε dε - ε² dR/R)/R       dℓ_j = -(½ Σ dR/R + ρ' Σ d(ε²/R))
//   information (Fisher's, expected):  I_j = Σ dε dε'/R + ½ dR dR'/R²
//
// Time update over Δ_j with the exact discretisation (discretize.h), every new value from the old
// x and P (the covariances first, then the means):
//
//   x' = Φ x + Γ0 u_j + Γ1 u_{j+1} + g      dx' = dΦ x + Φ dx + dΓ0 u_j + dΓ1 u_{j+1} + dg
//   P' = Φ P Φ' + Q                         dP' = Φ dP Φ' + T + T' + dQ,   T = dΦ P Φ'
//   (P' and every dP' symmetrised; Γ1 only with first-order hold)
//
// Steady state (kalman.h): once a step returns P and every dP_i to their values at its start, bit
// for bit, every later step with the same observed outputs and the same interval repeats its
// k, R, dk_i and dR_i; SteadyReplay records them and replays them while that holds, so that only
// the means and their sensitivities are updated. Identical to the full recursion, not an
// approximation. Fixed sizes and at most 64 outputs only.
//
// The arithmetic (the grouping of every sum and product) is the one the results were verified
// with; a change here changes results in the last bits.
//
// Speed: in its steady state a 2-state step is a few dozen flops, so what the loop carries from
// one index to the next (x̂, P, the sums) is the loop's own (LinearState, TermSums), every update
// is inlined, and nothing in the loop calls a function: a call, or an object whose address a call
// takes, puts those values in memory on the loop's critical chain (bench/loglik_bench,
// docs/benchmarks.md).
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <span>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

#include "core/filter/internal.h"
#include "core/model/linear_model.h"

namespace gb::filter::internal {

// Σ log R over many R > 0 with one log at the end: the product is kept as mantissa × 2^exponent,
// renormalised after every factor by moving the exponent bits out (no overflow or underflow for
// any normal R). Rounding: one relative error per factor, as summing the logs would give.
class LogProduct {
 public:
  [[gnu::always_inline]] void Multiply(double r) {
    if (r < kTiny || r > kHuge) {  // far outside the normal range: take the log directly
      direct_ += std::log(r);
      return;
    }
    mantissa_ *= r;
    const auto bits = std::bit_cast<std::uint64_t>(mantissa_);
    exponent_ += static_cast<std::int64_t>((bits >> 52) & 0x7ff) - 1023;
    mantissa_ =
        std::bit_cast<double>((bits & ~(std::uint64_t{0x7ff} << 52)) | (std::uint64_t{1023} << 52));
  }
  [[gnu::always_inline]] double Log() const {
    return std::log(mantissa_) + exponent_ * kLn2 + direct_;
  }

 private:
  static constexpr double kTiny = 1e-290, kHuge = 1e290;
  static constexpr double kLn2 = 0.69314718055994530941723212145818;
  double mantissa_ = 1.0;  // in [1, 2) after every Multiply
  std::int64_t exponent_ = 0;
  double direct_ = 0.0;
};

// What the scalar updates of one state index add up (Begin() before the first). Scalars only,
// so that a loop's sums stay in registers.
struct TermSums {
  int p_j = 0;               // scalar observations
  double logdet = 0;         // Σ log R (0 while `product` takes them)
  double r2 = 0;             // Σ ε²/R
  bool use_product = false;  // every R is multiplied into `product` instead (one log at the end)
  LogProduct product;

  [[gnu::always_inline]] void Begin() {
    p_j = 0;
    logdet = r2 = 0.0;
  }
};

// What the sensitivities of one state index's scalar updates add up, beside its TermSums
// (Begin() with theirs).
struct TermScores {
  Eigen::VectorXd d_logdet, d_r2;  // Σ dR/R, Σ d(ε²/R) (k)
  Eigen::MatrixXd information;     // I_j (k x k), when with_information
  bool with_information = false;
  Eigen::VectorXd deps, dR;  // workspace: the update's dε_i, dR_i

  TermScores() = default;
  TermScores(int k, bool with_info)
      : d_logdet(k), d_r2(k), with_information(with_info), deps(k), dR(k) {
    if (with_info) information.resize(k, k);
  }
  void Begin() {
    d_logdet.setZero();
    d_r2.setZero();
    if (with_information) information.setZero();
  }
  // dℓ_j/dθ into *d_term (k), for ρ'(r²) = d_rho (LoglikTerm).
  void TermScore(double d_rho, Eigen::VectorXd* d_term) const {
    d_term->resize(d_logdet.size());
    for (Eigen::Index i = 0; i < d_logdet.size(); ++i)
      (*d_term)(i) = TermDerivative(d_logdet(i), d_r2(i), d_rho);
  }
};

// The filter's state at a state index: x̂, its covariance, and their sensitivities. Held by the
// loop (a local there, so that x̂ and P can stay in registers), stepped by LinearStep.
template <int NX>
struct LinearState {
  using Mat = Eigen::Matrix<double, NX, NX>;
  using Vec = Eigen::Matrix<double, NX, 1>;

  Vec x;                // x̂
  Mat P;                // its covariance
  std::vector<Vec> dx;  // ∂x̂/∂θ_i (k)
  std::vector<Mat> dP;  // ∂P/∂θ_i (k)

  // Inlined, so that no call outside the loop's function takes the state's address (which
  // would keep x̂ in memory through the loop).
  LinearState() = default;
  LinearState(const LinearState&) = default;
  LinearState(LinearState&&) noexcept = default;
  LinearState& operator=(const LinearState&) = default;
  LinearState& operator=(LinearState&&) noexcept = default;
  [[gnu::always_inline]] ~LinearState() = default;
};

template <int NX>
class SteadyReplay;

// The model's observation equation held at size NX, and the step's workspace (no allocation per
// step), for stepping a LinearState.
template <int NX>
class LinearStep {
 public:
  using Mat = Eigen::Matrix<double, NX, NX>;
  using Vec = Eigen::Matrix<double, NX, 1>;
  using Row = Eigen::Matrix<double, 1, NX>;
  using State = LinearState<NX>;

  LinearStep() = default;
  // For the model ss and its derivatives dss (k = dss.size(); none for the filter alone).
  LinearStep(const model::StateSpace& ss, std::span<const model::StateSpace> dss) {
    SetModel(ss, dss);
  }

  // The observation equation of ss and dss (a model evaluated anew).
  void SetModel(const model::StateSpace& ss, std::span<const model::StateSpace> dss) {
    n_ = ss.n_states();
    const int p = ss.n_outputs();
    m_ = ss.n_inputs();
    k_ = static_cast<int>(dss.size());
    C_.resize(p);
    dC_.resize(static_cast<std::size_t>(p) * k_);
    for (int o = 0; o < p; ++o) {
      C_[o] = ss.C.row(o);
      for (int i = 0; i < k_; ++i) dC_[static_cast<std::size_t>(o) * k_ + i] = dss[i].C.row(o);
    }
    d_ = ss.d;
    S_ = ss.S;
    D_ = ss.D;
    has_D_ = m_ > 0 && D_.cwiseAbs().maxCoeff() != 0.0;
    dd_.resize(p, k_);
    dS_.resize(p, k_);
    dD_.resize(k_);
    for (int i = 0; i < k_; ++i) {
      dd_.col(i) = dss[i].d;
      dS_.col(i) = dss[i].S;
      dD_[i] = dss[i].D;
    }
    if constexpr (NX == Eigen::Dynamic) {
      PCt_.resize(n_);
      dPCt_.resize(n_);
      x_next_.resize(n_);
      PhiP_.resize(n_, n_);
      PhidP_.resize(n_, n_);
      T_.resize(n_, n_);
    }
  }

  // The scalar update of *s with observation y of output o; u: the inputs at the state index
  // (m); kScores: with the sensitivities, added up in *scores (with the information when it
  // asks for it). Adds to *sums; with `replay` (SteadyReplay::Begin called for this index),
  // records or replays k, R, dk_i, dR_i. Returns false, changing nothing, when R is not positive
  // (*R says what it is); *eps (when given): ε.
  template <bool kScores>
  bool MeasurementUpdate(int o, double y, const double* u, State* s, SteadyReplay<NX>* replay,
                         TermSums* sums, TermScores* scores, double* R_out,
                         double* eps_out = nullptr);

  // The time update of *s with the discretisation d of the interval and its derivatives dd[i]
  // (k of them); u0, u1: the inputs at both ends (m each; u1 read with first-order hold only).
  // With `replay`: P and dP are not updated (the steady state repeats them). kScores: with the
  // sensitivities.
  template <bool kScores, class Disc>
  void TimeUpdate(const Disc& d, const Disc* dd, const double* u0, const double* u1, bool foh,
                  bool replay, State* s);

  // The means' part of both updates, which is all a step of the steady state changes (the gain
  // P c' = PCt and R recorded by SteadyReplay): ε = y - ŷ of output o; then the correction
  // x <- x + PCt ε/R with its term's sums; and x <- Φ x + g + Γ0 u0 (+ Γ1 u1).
  [[gnu::always_inline]] double Innovation(int o, double y, const double* u, const Vec& x) const {
    double yhat = C_[o].dot(x) + d_(o);
    if (has_D_)
      for (int l = 0; l < m_; ++l) yhat += D_(o, l) * u[l];
    return y - yhat;
  }
  [[gnu::always_inline]] static void Correct(double eps, const Vec& PCt, double R, Vec* x,
                                             TermSums* sums) {
    x->noalias() += PCt * (eps / R);  // first: x̂ is on the loop's critical chain
    if (sums->use_product)
      sums->product.Multiply(R);
    else
      sums->logdet += std::log(R);
    sums->r2 += eps * eps / R;
    ++sums->p_j;
  }
  template <class Disc>
  [[gnu::always_inline]] void AdvanceMean(const Disc& d, const double* u0, const double* u1,
                                          bool foh, Vec* x) {
    Vec x_next_local;
    Vec& x_next = Work(x_next_, x_next_local);
    x_next.noalias() = d.Phi * *x;
    x_next += d.g;
    if (m_ > 0) AddInputs(d.Gamma0, d.Gamma1, u0, u1, foh, &x_next);
    *x = x_next;
  }

  const Row& c(int o) const { return C_[o]; }
  // The model's derivatives along θ_i: of row o of C, of d_o, of D (p x m).
  const Row& dc(int o, int i) const { return dC_[static_cast<std::size_t>(o) * k_ + i]; }
  double dd(int o, int i) const { return dd_(o, i); }
  double dS(int o, int i) const { return dS_(o, i); }
  const Eigen::MatrixXd& dD(int i) const { return dD_[i]; }
  double S(int o) const { return S_(o); }

 private:
  // Γ0 u0 + Γ1 u1 (the latter only with first-order hold), added to *out.
  template <class InMat>
  [[gnu::always_inline]] void AddInputs(const InMat& Gamma0, const InMat& Gamma1, const double* u0,
                                        const double* u1, bool foh, Vec* out) const {
    if (m_ == 1) {  // the common case, without a dynamic-size product
      // At fixed sizes the column as a fixed vector first: the same sums, in the same vector
      // operation as the correction's (a column block's GCC may leave a call, on the critical
      // chain of x̂).
      using Col = std::conditional_t<NX == Eigen::Dynamic, decltype(Gamma0.col(0)), Vec>;
      out->noalias() += Col(Gamma0.col(0)) * u0[0];
      if (foh) out->noalias() += Col(Gamma1.col(0)) * u1[0];
      return;
    }
    out->noalias() += Gamma0 * Eigen::Map<const Eigen::VectorXd>(u0, m_);
    if (foh) out->noalias() += Gamma1 * Eigen::Map<const Eigen::VectorXd>(u1, m_);
  }
  // A workspace: at fixed sizes the caller's local (nothing that outlives the update is written
  // on the loop's critical chain), at dynamic size the step's member (sized once).
  template <class T>
  [[gnu::always_inline]] static T& Work(T& member, T& local) {
    if constexpr (NX == Eigen::Dynamic)
      return member;
    else
      return local;
  }

  int n_ = 0, m_ = 0, k_ = 0;
  std::vector<Row> C_, dC_;  // rows of C and of every dC_i (dC_[o * k + i])
  Eigen::VectorXd d_, S_;
  Eigen::MatrixXd D_;
  bool has_D_ = false;       // some entry of D is not zero
  Eigen::MatrixXd dd_, dS_;  // p x k
  std::vector<Eigen::MatrixXd> dD_;
  Vec PCt_, dPCt_, x_next_;  // dynamic size only (Work)
  Mat PhiP_, PhidP_, T_;
};

// The steady-state replay (above) of a loop over state indices. Per index: Begin (before its
// measurement updates, which record or replay), then End after its time update.
//
// In floating point the recursion does not always settle on one step. Each of its parts repeats
// on its own: P (its recursion reads nothing else), and each dP_i with P (its recursion reads P
// and itself only), and they end in cycles of a few steps whose values differ in their last bits
// (the fuel film with its measurement variance at 1e-9: 2 to 12 steps; building 3 at CTSM-R's
// estimates: P in 2, its dP_i in 2 to 12 and one in more than 16, so that P and all its dP_i
// together repeat only after 120 steps; docs/benchmarks.md). So the last kMaxPeriod steps are
// kept, and each part's period is found on its own: the L after which it is back at what it was
// at the start of the step L - 1 before (L = 1: of itself; for a dP_i, with P, so L is a
// multiple of P's). Once every part has one, the
// next steps are replayed, each part from its own cycle, while they observe the outputs and use
// the interval the cycles were recorded with (one for all: periods are looked for only over a
// run of steps that all had them). Identical to the full recursion, as the one-step case is:
// each part's recorded values are a function of its own state and of P's, which repeat. A step
// that differs takes P and the dP_i from the records its parts would have replayed (their values
// at its start, which the replay does not update), and the full recursion resumes there.
template <int NX>
class SteadyReplay {
 public:
  using Mat = typename LinearState<NX>::Mat;
  using Vec = typename LinearState<NX>::Vec;

  // The longest period looked for (fewer where a step's record is large: kRecordBudget doubles
  // in all); a power of two, as the ring's size is.
  static constexpr int kMaxPeriod = 64;
  static constexpr std::size_t kRecordBudget = std::size_t{1} << 16;

  // One step's record: P and the dP_i at its start, and of its q-th scalar update k = P c' and
  // R, and dk_i, dR_i at [q * k + i] (in the replay's own arrays, allocated once for the whole
  // ring). Its outputs and interval are the run's (mask_, group_).
  struct Record {
    Mat P_start;
    Mat* dP_start = nullptr;  // k
    Vec* PCt = nullptr;       // p
    double* R = nullptr;      // p
    Vec* dPCt = nullptr;      // p k
    double* dR = nullptr;     // p k
  };

  // Disabled (never replays) unless `enabled`, the size is fixed and p <= 64; k sensitivities.
  SteadyReplay(bool enabled, int n, int p, int k)
      : enabled_(enabled && NX != Eigen::Dynamic && p <= 64), k_(k) {
    if (!enabled_) return;
    const std::size_t size =
        static_cast<std::size_t>(n) * n * (1 + k) + static_cast<std::size_t>(n + 1) * p * (1 + k);
    const auto fit = static_cast<int>(kRecordBudget / std::max<std::size_t>(size, 1));
    ring_.resize(std::bit_floor(static_cast<unsigned>(std::clamp(fit, 1, kMaxPeriod))));
    const std::size_t steps = ring_.size(), pk = static_cast<std::size_t>(p) * k;
    dP_store_.assign(steps * k, Mat::Zero(n, n));
    PCt_store_.assign(steps * p, Vec::Zero(n));
    R_store_.assign(steps * p, 0.0);
    dPCt_store_.assign(steps * pk, Vec::Zero(n));
    dR_store_.assign(steps * pk, 0.0);
    for (std::size_t t = 0; t < steps; ++t) {
      Record& r = ring_[t];
      r.P_start = Mat::Zero(n, n);
      r.dP_start = dP_store_.data() + t * k;
      r.PCt = PCt_store_.data() + t * p;
      r.R = R_store_.data() + t * p;
      r.dPCt = dPCt_store_.data() + t * pk;
      r.dR = dR_store_.data() + t * pk;
    }
    keys_.assign(steps * (k + 1), 0);
    period_.assign(k + 1, 0);
    phase_.assign(k + 1, 0);
    source_.assign(k + 1, nullptr);
  }
  // The records point into the replay's own arrays.
  SteadyReplay(const SteadyReplay&) = delete;
  SteadyReplay& operator=(const SteadyReplay&) = delete;

  bool enabled() const { return enabled_; }
  bool replaying() const { return replaying_; }
  // Whether an index observing `mask` over interval `group` repeats the cycles' next step; if
  // so, it becomes the current one (Gain, R).
  [[gnu::always_inline]] bool Holds(std::uint64_t mask, int group) {
    if (!replaying_ || mask != mask_ || group != group_) return false;
    Advance();
    return true;
  }
  // Replaying, from the step after End began it (before the first Begin that replays): the
  // outputs and interval the cycles were recorded with, each part's period (c = 0: P, 1 + i:
  // dP_i), and the record part c's values of the t-th replayed step are in (t = 0: the first;
  // P's: PCt, R; dP_i's: its dk_i and dR_i of the q-th update, at At(q, i)).
  std::uint64_t mask() const { return mask_; }
  int group() const { return group_; }
  int Period(int c) const { return period_[c]; }
  const Record& PartStep(int c, long t) const {
    return ring_[Slot(base_ - period_[c] + t % period_[c])];
  }
  std::size_t At(int q, int i) const { return static_cast<std::size_t>(q) * k_ + i; }
  // The current step's q-th scalar update: its gain P c' and R; and P at its start.
  const Vec& Gain(int q) const { return p_source_->PCt[q]; }
  const Mat& PStart() const { return p_source_->P_start; }
  double R(int q) const { return p_source_->R[q]; }
  // This index observes `mask` and its time update uses the interval `group` (-1: none); *P,
  // *dP at its start. It replays the cycles' next step when they are replaying and it has their
  // outputs and interval; otherwise *P and *dP are set to their values at the start of this index
  // (the replay leaves them behind) and the step is recorded from here.
  [[gnu::always_inline]] void Begin(std::uint64_t mask, int group, Mat* P, std::vector<Mat>* dP) {
    if (!enabled_) return;
    if (replaying_) {
      if (mask == mask_ && group == group_) {
        Advance();
        return;
      }
      *P = ring_[Slot(SourceStep(0))].P_start;
      for (int i = 0; i < k_; ++i)
        (*dP)[i] = ring_[Slot(SourceStep(joint_ ? 0 : i + 1))].dP_start[i];
      replaying_ = false;
    }
    if (mask != mask_ || group != group_ || run_ == 0) {  // a new run: the periods anew
      mask_ = mask;
      group_ = group;
      run_ = 0;
      std::fill(period_.begin(), period_.end(), 0);
      found_ = 0;
    }
    Record& r = ring_[Slot(recorded_)];
    r.P_start = *P;
    for (int i = 0; i < k_; ++i) r.dP_start[i] = (*dP)[i];
    Key(0, recorded_) = Fingerprint(*P);
    for (int i = 0; i < k_; ++i) Key(i + 1, recorded_) = Fingerprint((*dP)[i]);
    current_ = &r;
  }
  // After the index's time update: each part without a period yet is compared with its values
  // at the start of this step and of the steps before it in the run, up to kMaxPeriod; once
  // every part has a period, the next index replays.
  [[gnu::always_inline]] void End(const Mat& P, const std::vector<Mat>& dP) {
    if (!enabled_ || replaying_) return;
    const long s = recorded_++;
    run_ = std::min<long>(run_ + 1, static_cast<long>(ring_.size()));
    if (period_[0] == 0) {
      // Until P settles, its fingerprint matches none kept: one pass without an early exit (vector
      // compares) says so, where the ordered search stopped at every step of the ring. (P's
      // first entry, the key before, settles long before the others on a slow filter.)
      const std::uint32_t key = Fingerprint(P);
      if (!AnyKeyEquals(0, key)) return;
      for (long L = 1; L <= run_; ++L) {
        if (key != Key(0, s - L + 1) || P != ring_[Slot(s - L + 1)].P_start) continue;
        period_[0] = static_cast<int>(L);
        ++found_;
        break;
      }
      if (period_[0] == 0) return;
    }
    for (int i = 0; i < k_; ++i) {
      if (period_[i + 1] != 0) continue;
      const std::uint32_t key = Fingerprint(dP[i]);
      if (!AnyKeyEquals(i + 1, key)) continue;
      for (long L = period_[0]; L <= run_; L += period_[0]) {
        if (key != Key(i + 1, s - L + 1)) continue;
        const Record& r = ring_[Slot(s - L + 1)];
        if (dP[i] == r.dP_start[i] && P == r.P_start) {
          period_[i + 1] = static_cast<int>(L);
          ++found_;
          break;
        }
      }
    }
    if (found_ < k_ + 1) return;
    // Every part repeats. Where their common period fits in the ring, the steps are replayed
    // as one cycle once the whole state is back where it was that period before (within that
    // period's steps after the last part's cycle began), read from one record per step;
    // otherwise each part from its own.
    long common = 1;
    for (int c = 0; c <= k_ && common <= static_cast<long>(ring_.size()); ++c)
      common = std::lcm(common, long{period_[c]});  // < ring size * kMaxPeriod: no overflow
    joint_ = common <= static_cast<long>(ring_.size());
    if (joint_) {
      if (common > run_) return;
      const Record& r = ring_[Slot(s - common + 1)];
      if (P != r.P_start) return;
      for (int i = 0; i < k_; ++i)
        if (dP[i] != r.dP_start[i]) return;
      std::fill(period_.begin(), period_.end(), static_cast<int>(common));
    }
    replaying_ = true;
    base_ = recorded_;
    std::fill(phase_.begin(), phase_.end(), 0);
    fixed_ = false;
  }

 private:
  friend class LinearStep<NX>;
  std::size_t Slot(long step) const {
    return static_cast<std::size_t>(step) & (ring_.size() - 1);  // the size is a power of two
  }
  // Part c's (0: P, 1 + i: dP_i) Fingerprint at the start of a recorded step; each part's in a
  // ring of its own.
  std::uint32_t& Key(int c, long step) { return keys_[c * ring_.size() + Slot(step)]; }
  // 32 bits that equal matrices share (the same entries give the same bits; -0 is taken as 0,
  // which == compares equal to it).
  static std::uint32_t Fingerprint(const Mat& A) {
    std::uint64_t h = 0;
    for (Eigen::Index i = 0; i < A.size(); ++i)
      h += std::bit_cast<std::uint64_t>(A.data()[i] + 0.0) *
           (0x9E3779B97F4A7C15ull + 2 * static_cast<std::uint64_t>(i));
    return static_cast<std::uint32_t>(h ^ (h >> 32));
  }
  // Whether `key` is part c's at the start of any step in the ring (also of steps before the
  // run: a superset of the candidates, which the ordered search then checks).
  bool AnyKeyEquals(int c, std::uint32_t key) const {
    const std::uint32_t* kept = keys_.data() + c * ring_.size();
    unsigned matches = 0;  // (a sum, which GCC vectorises; a bool's |= it does not)
    for (std::size_t t = 0; t < ring_.size(); ++t) matches += kept[t] == key;
    return matches != 0;
  }
  // The recorded step that part c (0: P, 1 + i: dP_i) repeats next: the step `period` before the
  // first replayed one, on by its phase.
  long SourceStep(int c) const { return base_ - period_[c] + phase_[c]; }
  // The record every part is replayed from (null: each from its own), and dP_i's own.
  const Record* JointSource() const { return joint_ ? p_source_ : nullptr; }
  const Record* PartSource(int i) const { return source_[i + 1]; }
  // The next replayed step: each part's record, then its phase on by one.
  [[gnu::always_inline]] void Advance() {
    if (fixed_) return;  // one record for every part and every step
    if (joint_) {        // one record for every part
      p_source_ = &ring_[Slot(SourceStep(0))];
      if (++phase_[0] == period_[0]) phase_[0] = 0;
      fixed_ = period_[0] == 1;
      return;
    }
    for (int c = 0; c <= k_; ++c) {
      source_[c] = &ring_[Slot(SourceStep(c))];
      if (++phase_[c] == period_[c]) phase_[c] = 0;
    }
    p_source_ = source_[0];
  }

  bool enabled_;
  int k_;
  std::vector<Record> ring_;         // the last ring_.size() steps recorded, step s at s % size
  std::vector<std::uint32_t> keys_;  // (Key)
  std::vector<Mat> dP_store_;        // the records' arrays (Record)
  std::vector<Vec> PCt_store_, dPCt_store_;
  std::vector<double> R_store_, dR_store_;
  long recorded_ = 0;  // steps recorded
  // The run: steps observing mask_ over group_ one after the other (up to the ring's size).
  std::uint64_t mask_ = 0;
  int group_ = -1;
  long run_ = 0;
  // Per part (0: P, 1 + i: dP_i): its period (0: none found yet), and while replaying its
  // phase and the record of the current step.
  std::vector<int> period_, phase_;
  std::vector<const Record*> source_;
  int found_ = 0;  // parts with a period
  bool replaying_ = false;
  bool joint_ = false;                // replaying one cycle for all parts (period_[0] steps)
  bool fixed_ = false;                // and that of one step
  const Record* p_source_ = nullptr;  // the record P's values are replayed from
  long base_ = 0;                     // the first replayed step
  Record* current_ = nullptr;         // the step being recorded
};

template <int NX>
template <bool kScores>
[[gnu::always_inline]] inline bool LinearStep<NX>::MeasurementUpdate(
    int o, double y, const double* u, State* s, SteadyReplay<NX>* replay, TermSums* sums,
    TermScores* scores, double* R_out, double* eps_out) {
  Vec PCt_local, dPCt_local;
  Vec& PCt = Work(PCt_, PCt_local);
  Vec& dPCt = Work(dPCt_, dPCt_local);
  Vec& x = s->x;
  Mat& P = s->P;
  const Row& c = C_[o];
  const bool replaying = replay != nullptr && replay->replaying();
  const bool recording = replay != nullptr && replay->enabled() && !replaying;
  const int q = sums->p_j;
  double R;
  if (replaying) {  // this step's P c' and R are those recorded
    PCt = replay->Gain(q);
    R = replay->R(q);
  } else {
    PCt.noalias() = P * c.transpose();
    R = c.dot(PCt) + S_(o);
  }
  *R_out = R;
  if (!(R > 0.0)) return false;
  if (recording) replay->current_->PCt[q] = PCt, replay->current_->R[q] = R;
  const double eps = Innovation(o, y, u, x);
  if (eps_out) *eps_out = eps;
  if constexpr (kScores) {
    // Replaying one cycle for every part: one record for all i.
    const auto* joint = replaying ? replay->JointSource() : nullptr;
    // 1/R once: the sensitivities' updates multiply by it (ten divisions per parameter else).
    const double inv_R = 1.0 / R, eps_R = eps * inv_R;
    for (int i = 0; i < k_; ++i) {
      const Row& dc = dC_[static_cast<std::size_t>(o) * k_ + i];
      double dyhat = dc.dot(x) + c.dot(s->dx[i]) + dd_(o, i);
      for (int l = 0; l < m_; ++l) dyhat += dD_[i](o, l) * u[l];
      double dR;
      if (replaying) {
        const auto* source = joint != nullptr ? joint : replay->PartSource(i);
        dPCt = source->dPCt[replay->At(q, i)];
        dR = source->dR[replay->At(q, i)];
      } else {
        Mat& dP = s->dP[i];
        dPCt.noalias() = dP * c.transpose();
        dPCt.noalias() += P * dc.transpose();
        dR = dc.dot(PCt) + c.dot(dPCt) + dS_(o, i);
        if (recording) {
          replay->current_->dPCt[replay->At(q, i)] = dPCt;
          replay->current_->dR[replay->At(q, i)] = dR;
        }
        dP.noalias() -= (dPCt * PCt.transpose() + PCt * dPCt.transpose()) * inv_R;
        dP.noalias() += PCt * PCt.transpose() * (dR * inv_R * inv_R);
      }
      const double deps = -dyhat;
      const double dR_R = dR * inv_R;
      scores->d_logdet(i) += dR_R;
      scores->d_r2(i) += (2.0 * eps * deps - eps * eps * dR_R) * inv_R;
      s->dx[i].noalias() += dPCt * eps_R + PCt * ((deps - eps * dR_R) * inv_R);
      if (scores->with_information) scores->deps(i) = deps, scores->dR(i) = dR;
    }
    if (scores->with_information && k_ > 0) {
      scores->information.noalias() += scores->deps * scores->deps.transpose() * inv_R;
      scores->information.noalias() += 0.5 * scores->dR * scores->dR.transpose() * (inv_R * inv_R);
    }
  }
  Correct(eps, PCt, R, &x, sums);
  if (!replaying) P.noalias() -= (1.0 / R) * PCt * PCt.transpose();
  return true;
}

template <int NX>
template <bool kScores, class Disc>
[[gnu::always_inline]] inline void LinearStep<NX>::TimeUpdate(const Disc& d, const Disc* dd,
                                                              const double* u0, const double* u1,
                                                              bool foh, bool replay, State* s) {
  if (!replay) {  // the covariances (from the old P)
    Mat PhiP_local, PhidP_local, T_local;
    Mat& PhiP = Work(PhiP_, PhiP_local);
    Mat& P = s->P;
    PhiP.noalias() = d.Phi * P;
    if constexpr (kScores) {
      Mat& PhidP = Work(PhidP_, PhidP_local);
      Mat& T = Work(T_, T_local);
      for (int i = 0; i < k_; ++i) {
        const Disc& di = dd[i];
        Mat& dP = s->dP[i];
        T.noalias() = di.Phi * PhiP.transpose();  // dΦ P Φ' (P symmetric)
        PhidP.noalias() = d.Phi * dP;
        dP.noalias() = PhidP * d.Phi.transpose();
        dP += T + T.transpose() + di.Q;
        Symmetrize(dP);
      }
    }
    P.noalias() = PhiP * d.Phi.transpose();
    P += d.Q;
    Symmetrize(P);
  }
  // The means (the sensitivities from the old x̂).
  if constexpr (kScores) {
    Vec x_next_local;
    Vec& x_next = Work(x_next_, x_next_local);
    for (int i = 0; i < k_; ++i) {
      const Disc& di = dd[i];
      x_next.noalias() = di.Phi * s->x;
      x_next.noalias() += d.Phi * s->dx[i];
      x_next += di.g;
      if (m_ > 0) AddInputs(di.Gamma0, di.Gamma1, u0, u1, foh, &x_next);
      s->dx[i] = x_next;
    }
  }
  AdvanceMean(d, u0, u1, foh, &s->x);
}

}  // namespace gb::filter::internal
