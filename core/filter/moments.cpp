#include "core/filter/moments.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <type_traits>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <fmt/format.h>

#include "core/filter/discretize.h"

namespace gb::filter {

using Program = model::NonlinearModel::Program;

namespace {

// m = a b for n x n column-major matrices, column by column: m_·j = Σ_k a_·k b_kj, summed over
// k in order. The moment equations' products are this small (7 x 7 for the engine model):
// Eigen's blocked product packed and unpacked its operands for every one, a third of the
// filter's time on the engine model, and a loop over a size known only at run time neither
// keeps the column in registers nor vectorises (docs/benchmarks.md, issue 37). With the size
// fixed at compile time it does both; every size sums in the same order.
template <std::ptrdiff_t N>
void MultiplyFixed(const double* a, const double* b, double* m) {
  for (std::ptrdiff_t j = 0; j < N; ++j) {
    double column[N];
    for (std::ptrdiff_t i = 0; i < N; ++i) column[i] = a[i] * b[j * N];
    for (std::ptrdiff_t k = 1; k < N; ++k)
      for (std::ptrdiff_t i = 0; i < N; ++i) column[i] += a[k * N + i] * b[j * N + k];
    for (std::ptrdiff_t i = 0; i < N; ++i) m[j * N + i] = column[i];
  }
}

// A test that every value added is finite, without a branch per value: the exponent field of a
// value is all ones (an infinity or a NaN) exactly when adding one unit to it carries into the
// sign bit.
class FiniteTest {
 public:
  void Add(double v) { carry_ |= (std::bit_cast<std::uint64_t>(v) & kExponent) + kUnit; }
  bool Passed() const { return (carry_ >> 63) == 0; }

 private:
  static constexpr std::uint64_t kExponent = 0x7ff0000000000000ULL, kUnit = 1ULL << 52;
  std::uint64_t carry_ = 0;
};

// True if every value is finite, in one vectorisable pass.
bool AllFinite(std::span<const double> values) {
  FiniteTest finite;
  for (const double v : values) finite.Add(v);
  return finite.Passed();
}

// f(std::integral_constant<std::ptrdiff_t, N>{}) with N = n where n is 1 to 8 (the moment
// equations' sizes fixed at compile time), else with N = 0.
template <class F>
void AtFixedSize(std::ptrdiff_t n, F&& f) {
  using std::integral_constant;
  switch (n) {
    case 1:
      return f(integral_constant<std::ptrdiff_t, 1>{});
    case 2:
      return f(integral_constant<std::ptrdiff_t, 2>{});
    case 3:
      return f(integral_constant<std::ptrdiff_t, 3>{});
    case 4:
      return f(integral_constant<std::ptrdiff_t, 4>{});
    case 5:
      return f(integral_constant<std::ptrdiff_t, 5>{});
    case 6:
      return f(integral_constant<std::ptrdiff_t, 6>{});
    case 7:
      return f(integral_constant<std::ptrdiff_t, 7>{});
    case 8:
      return f(integral_constant<std::ptrdiff_t, 8>{});
    default:
      return f(integral_constant<std::ptrdiff_t, 0>{});
  }
}

void MultiplySquare(const double* a, const double* b, double* m, int n) {
  AtFixedSize(n, [&](auto size) {
    constexpr std::ptrdiff_t N = decltype(size)::value;
    if constexpr (N > 0) {
      MultiplyFixed<N>(a, b, m);
    } else {
      for (int j = 0; j < n; ++j) {
        double* column = m + static_cast<std::ptrdiff_t>(j) * n;
        const double* b_j = b + static_cast<std::ptrdiff_t>(j) * n;
        for (int i = 0; i < n; ++i) column[i] = a[i] * b_j[0];
        for (int k = 1; k < n; ++k) {
          const double* a_k = a + static_cast<std::ptrdiff_t>(k) * n;
          for (int i = 0; i < n; ++i) column[i] += a_k[i] * b_j[k];
        }
      }
    }
  });
}

// M = P J' for J's structural nonzeros: J row-major, row j's nonzero columns
// columns[begin[j]] .. columns[begin[j + 1] - 1] in increasing order. Each entry of M is summed
// over those k in order, so it is the dense product's sum without its terms P_ik 0 (the same
// value, but for the sign of a zero sum). N as MultiplyFixed's, 0: n at run time.
template <std::ptrdiff_t N>
void MultiplyByJt(const double* P, const double* J, const int* columns, const int* begin, double* M,
                  std::ptrdiff_t n) {
  if constexpr (N > 0) n = N;
  for (std::ptrdiff_t j = 0; j < n; ++j) {
    double* column = M + j * n;
    const double* J_j = J + j * n;
    const int first = begin[j], end = begin[j + 1];
    if (first == end) {
      for (std::ptrdiff_t i = 0; i < n; ++i) column[i] = 0.0;
      continue;
    }
    const double* P_k = P + static_cast<std::ptrdiff_t>(columns[first]) * n;
    const double J_jk = J_j[columns[first]];
    for (std::ptrdiff_t i = 0; i < n; ++i) column[i] = P_k[i] * J_jk;
    for (int r = first + 1; r < end; ++r) {
      const double* P_r = P + static_cast<std::ptrdiff_t>(columns[r]) * n;
      const double J_jr = J_j[columns[r]];
      for (std::ptrdiff_t i = 0; i < n; ++i) column[i] += P_r[i] * J_jr;
    }
  }
}

// M = A J for J's structural nonzeros: A column-major n x n, J row-major, column c's nonzero rows
// rows[begin[c]] .. rows[begin[c + 1] - 1] in increasing order; each entry summed over those k in
// order. N as MultiplyFixed's, 0: n at run time.
template <std::ptrdiff_t N>
void MultiplyByJ(const double* A, const double* J, const int* rows, const int* begin, double* M,
                 std::ptrdiff_t n) {
  if constexpr (N > 0) n = N;
  for (std::ptrdiff_t c = 0; c < n; ++c) {
    double* column = M + c * n;
    for (std::ptrdiff_t i = 0; i < n; ++i) column[i] = 0.0;
    for (int r = begin[c]; r < begin[c + 1]; ++r) {
      const double* A_k = A + static_cast<std::ptrdiff_t>(rows[r]) * n;
      const double J_kc = J[static_cast<std::ptrdiff_t>(rows[r]) * n + c];
      for (std::ptrdiff_t i = 0; i < n; ++i) column[i] += A_k[i] * J_kc;
    }
  }
}

// MultiplyByJ at a size fixed at compile time where n is 1 to 8 (the columns' loops unrolled).
void MultiplyByJSized(const double* A, const double* J, const int* rows, const int* begin,
                      double* M, std::ptrdiff_t n) {
  AtFixedSize(n, [&](auto size) { MultiplyByJ<decltype(size)::value>(A, J, rows, begin, M, n); });
}

}  // namespace

double SpectralRadiusBound(Eigen::MatrixXd* scaled) {
  Eigen::MatrixXd& A = *scaled;
  const Eigen::Index n = A.rows();
  for (int sweep = 0; sweep < 4; ++sweep) {
    for (Eigen::Index i = 0; i < n; ++i) {
      double row = 0.0, column = 0.0;
      for (Eigen::Index j = 0; j < n; ++j) {
        if (j == i) continue;
        row += std::abs(A(i, j));
        column += std::abs(A(j, i));
      }
      if (!(row > 0.0 && column > 0.0)) continue;
      // Row i divided by f = 2^e and column i multiplied by it: both sums come near
      // sqrt(row column). At most 2^±32 a step, so that no entry overflows or underflows.
      const double half_log = 0.5 * (std::log2(row) - std::log2(column));
      const int e = static_cast<int>(std::lround(std::clamp(half_log, -32.0, 32.0)));
      if (e == 0) continue;
      A.row(i) *= std::ldexp(1.0, -e);
      A.col(i) *= std::ldexp(1.0, e);
    }
  }
  const double rows = A.cwiseAbs().rowwise().sum().maxCoeff();
  const double columns = A.cwiseAbs().colwise().sum().maxCoeff();
  return std::min(rows, columns);
}

// The moment equations over one sample interval: z = [x̂; lower triangle of P, column by column],
// and with `transition` also Φ (column-major), dΦ/dt = J Φ from Φ = I.
class MomentPropagator::Moments final : public ode::AdjointSystem {
 public:
  Moments(const model::NonlinearModel& model, std::span<const double> theta, bool transition,
          const model::NonlinearSensitivity* sens, std::span<const int> free)
      : model_(model),
        n_(model.n_states()),
        transition_(transition),
        sens_(sens),
        free_(free.begin(), free.end()),
        m_(model.n_inputs()),
        time_slot_(model.time_slot()),
        slots_(model.n_slots(), 0.0),
        out_(model.dynamics_size()),
        packed_(n_, n_),
        J_(n_, n_),
        P_(n_, n_),
        M_(n_, n_),
        M2_(n_, n_) {
    std::copy(theta.begin(), theta.end(), slots_.begin() + model.parameter_slot());
    int k = n_;
    for (int b = 0; b < n_; ++b)
      for (int a = b; a < n_; ++a) packed_(a, b) = packed_(b, a) = k++;
    // J's structural nonzeros, row by row: every entry but a derivative that is the constant 0.
    j_begin_.push_back(0);
    for (int j = 0; j < n_; ++j) {
      for (int c = 0; c < n_; ++c) {
        const expr::ExprPtr& e =
            model.Entry(model::NonlinearModel::Program::kDynamics, Z(n_ + j * n_ + c));
        if (!(e->op == expr::Op::kConst && e->value == 0.0)) j_columns_.push_back(c);
      }
      j_begin_.push_back(static_cast<int>(j_columns_.size()));
    }
    // The sparse product pays an indirection per term: worth it below about 3/4 full.
    sparse_j_ = 4 * j_columns_.size() <= 3 * Z(n_) * Z(n_);
    if (sens_) {
      // J's structural nonzeros by column, for Vjp's Λ J.
      j_column_begin_.assign(Z(n_) + 1, 0);
      for (const int c : j_columns_) ++j_column_begin_[Z(c) + 1];
      for (int c = 0; c < n_; ++c) j_column_begin_[Z(c) + 1] += j_column_begin_[Z(c)];
      j_rows_.resize(j_columns_.size());
      std::vector<int> next(j_column_begin_.begin(), j_column_begin_.end() - 1);
      for (int j = 0; j < n_; ++j)
        for (int r = j_begin_[Z(j)]; r < j_begin_[Z(j) + 1]; ++r)
          j_rows_[Z(next[Z(j_columns_[Z(r)])]++)] = j;
      ClassifyNonzeros();
      dense_ = sens_->dynamics().Zeroed();
      scratch_.resize(sens_->dynamics().nonzeros());
      dJ_.resize(n_, n_);
      SP_.resize(n_, n_);
      dsigma_.resize(n_);
    }
  }

  int moments_size() const { return n_ + n_ * (n_ + 1) / 2; }
  // Where the sensitivities' blocks begin (one of moments_size() per free parameter).
  int sensitivity_offset() const { return moments_size() + (transition_ ? n_ * n_ : 0); }
  int n_free() const { return static_cast<int>(free_.size()); }
  int size() const override { return sensitivity_offset() + n_free() * moments_size(); }
  int controlled_size() const override { return sensitivity_offset(); }
  // The error test's scale: sqrt(x̂_i² + P_ii) for a mean (the state's root mean square, which
  // keeps the scale of its spread where the mean crosses zero), and for a covariance P_ab the bound
  // sqrt(P_aa P_bb) on its size (Cauchy-Schwarz), so that its error is measured against the
  // variances it is made of, not against its own value, which is near zero whenever the two
  // states are nearly uncorrelated (as a state and its own derivative are: cov(z, z') =
  // d var(z) / 2 dt): the test on P_ab is then one on the correlation. Φ (transition): |Φ_ij|.
  void Magnitudes(std::span<const double> z, std::span<double> m) const override {
    for (int i = 0; i < n_; ++i) m[i] = std::sqrt(z[i] * z[i] + std::abs(z[packed_(i, i)]));
    for (int b = 0; b < n_; ++b) {
      const double var_b = std::abs(z[packed_(b, b)]);
      m[packed_(b, b)] = var_b;
      for (int a = b + 1; a < n_; ++a)
        m[packed_(a, b)] = std::sqrt(std::abs(z[packed_(a, a)]) * var_b);
    }
    for (std::size_t i = static_cast<std::size_t>(moments_size()); i < m.size(); ++i)
      m[i] = std::abs(z[i]);
  }

  // The inputs over [t0, t0 + dt]: u0 (zoh), or from u0 to u1 (foh; u1 may be null for zoh).
  void SetInterval(const double* u0, const double* u1, double t0, double dt) {
    u0_ = u0;
    u1_ = u1;
    t0_ = t0;
    dt_ = dt;
  }

  // Evaluates the dynamics at (x, u(t), t) into out_ and J_; false (and failure() set) if not
  // finite.
  bool EvaluateAt(double t, const double* x) {
    if (!EvaluateDynamics(t, x)) return false;
    SetJ();
    return true;
  }
  // The same without J_ (the moment equations alone read J from out_).
  bool EvaluateDynamics(double t, const double* x) {
    SetSlots(t, x);
    model_.Dynamics(slots_, out_);
    if (AllFinite(out_)) return true;
    NameNotFinite();
    return false;
  }
  // The slots at (t, x): x, u(t) and t; N > 0 the state count at compile time (the copy then is
  // a few moves, not a call of memmove).
  template <std::ptrdiff_t N = 0>
  void SetSlots(double t, const double* x) {
    const std::ptrdiff_t n = N > 0 ? N : n_;
    double* __restrict slots = slots_.data();
    for (std::ptrdiff_t i = 0; i < n; ++i) slots[i] = x[i];
    const double* __restrict u0 = u0_;
    if (u1_) {
      const double* __restrict u1 = u1_;
      const double s = (t - t0_) / dt_;
      for (int i = 0; i < m_; ++i) slots[n + i] = u0[i] + s * (u1[i] - u0[i]);
    } else {
      for (int i = 0; i < m_; ++i) slots[n + i] = u0[i];
    }
    slots[time_slot_] = t;
  }
  // J as the dynamics program wrote it into out_, row by row: J' column by column.
  const double* JRowMajor() const { return out_.data() + n_; }
  void SetJ() {
    for (int i = 0; i < n_; ++i)
      for (int j = 0; j < n_; ++j) J_(i, j) = out_[n_ + i * n_ + j];
  }

  // A retrace keeps the dynamics program's output at each stage for Vjp there.
  void Retrace(int stages) override {
    retrace_stages_ = stages;
    retrace_next_ = 0;
    retrace_out_.resize(static_cast<std::size_t>(stages) * out_.size());
  }

  bool Rhs(double t, std::span<const double> z, std::span<double> dz) override {
    return (this->*rhs_)(t, z.data(), dz.data());
  }
  // Rhs for N states (N > 0: known at compile time, for 1 to 8 states; 0: n_).
  template <std::ptrdiff_t N>
  bool RhsOf(double t, const double* z, double* dz) {
    SetSlots<N>(t, z);
    model_.Dynamics(slots_, out_);
    if (retrace_next_ < retrace_stages_) {
      std::copy(out_.begin(), out_.end(),
                retrace_out_.begin() + static_cast<std::ptrdiff_t>(Z(retrace_next_++)) *
                                           static_cast<std::ptrdiff_t>(out_.size()));
    }
    // The moments' derivatives, tested for finiteness as they are made: a value of f, J or σ
    // that is not finite makes one of them not finite (each is a sum of products that takes
    // every entry), so the dynamics' own output needs no second pass, which read back the model
    // code's stores in wider loads than they were written and stalled (issue 37).
    if (!MomentsRhs<N>(z, dz)) {
      NameNotFinite();
      return false;
    }
    if (!transition_ && free_.empty()) return true;
    SetJ();
    const auto size = static_cast<std::size_t>(this->size());
    if (transition_) {
      const Eigen::Map<const Eigen::MatrixXd> Phi(z + moments_size(), n_, n_);
      Eigen::Map<Eigen::MatrixXd>(dz + moments_size(), n_, n_).noalias() = J_ * Phi;
    }
    if (free_.empty()) return true;
    Unpack({z, size}, &P_);
    return SensitivityRhs({z, size}, {dz, size});
  }
  using RhsFunction = bool (Moments::*)(double, const double*, double*);
  static RhsFunction RhsFor(int n) {
    switch (n) {
      case 1:
        return &Moments::RhsOf<1>;
      case 2:
        return &Moments::RhsOf<2>;
      case 3:
        return &Moments::RhsOf<3>;
      case 4:
        return &Moments::RhsOf<4>;
      case 5:
        return &Moments::RhsOf<5>;
      case 6:
        return &Moments::RhsOf<6>;
      case 7:
        return &Moments::RhsOf<7>;
      case 8:
        return &Moments::RhsOf<8>;
      default:
        return &Moments::RhsOf<0>;
    }
  }

  // dx̂ = f and the packed dP = J P + P J' + diag σ² from the dynamics in out_, with
  // M = P J' = (J P)' from J as the program writes it, row by row (J' column by column), so that
  // no copy of J is made: M(b, a) = (J P)_ab (P is symmetric); each entry of M is summed over k
  // in order at every size. False if a value is not finite. N as RhsOf's.
  template <std::ptrdiff_t N>
  bool MomentsRhs(const double* z, double* dz) {
    const std::ptrdiff_t n = N > 0 ? N : n_;
    // P and M on the stack for a fixed size, in the members' storage otherwise.
    double P_fixed[N > 0 ? N * N : 1], M_fixed[N > 0 ? N * N : 1];
    double* P = N > 0 ? P_fixed : P_.data();
    double* M = N > 0 ? M_fixed : M_.data();
    FiniteTest finite;
    const double* packed = z + n;  // packed_'s order
    for (std::ptrdiff_t b = 0; b < n; ++b) {
      for (std::ptrdiff_t a = b; a < n; ++a) {
        finite.Add(*packed);  // (a sparse J's product may not take every entry of P)
        P[b * n + a] = P[a * n + b] = *packed++;
      }
    }
    if (sparse_j_) {
      MultiplyByJt<N>(P, JRowMajor(), j_columns_.data(), j_begin_.data(), M, n);
    } else if constexpr (N > 0) {
      MultiplyFixed<N>(P, JRowMajor(), M);
    } else {
      MultiplySquare(P, JRowMajor(), M, n_);
    }
    const double* f = out_.data();
    const double* sigma = f + n + n * n;
    for (std::ptrdiff_t i = 0; i < n; ++i) finite.Add(dz[i] = f[i]);
    double* d = dz + n;
    for (std::ptrdiff_t b = 0; b < n; ++b) {
      finite.Add(*d++ = M[b * n + b] + M[b * n + b] + sigma[b] * sigma[b]);
      for (std::ptrdiff_t a = b + 1; a < n; ++a) finite.Add(*d++ = M[a * n + b] + M[b * n + a]);
    }
    return finite.Passed();
  }
  // After MomentsRhs found a value that is not finite: the dynamics' entry that is not, into
  // failure() (none when they are all finite and the products overflowed).
  void NameNotFinite() {
    for (std::size_t k = 0; k < out_.size(); ++k) {
      if (!std::isfinite(out_[k])) {
        failure_ = model_.NotFinite(Program::kDynamics, k, out_[k], slots_);
        return;
      }
    }
  }

  // For each free θ_l, with S = ∂x̂/∂θ_l and SP = ∂P/∂θ_l:
  //   dS/dt  = J S + ∂f/∂θ_l
  //   dSP/dt = dJ P + P dJ' + J SP + SP J' + diag(2 σ_i dσ_i)
  // with dJ = Σ_m ∂J/∂x_m S_m + ∂J/∂θ_l and dσ = ∂σ/∂x S + ∂σ/∂θ_l. EvaluateAt has filled the
  // slots, J_ and σ; P_ holds P (Rhs unpacks it).
  bool SensitivityRhs(std::span<const double> z, std::span<double> dz) {
    if (!EvaluateDerivatives()) return false;
    const Eigen::Map<const Eigen::MatrixXd> f_theta(dense_.data(), n_, model_.n_parameters());
    const int ms = moments_size();
    for (int q = 0; q < n_free(); ++q) {
      const int l = free_[q];
      const int base = sensitivity_offset() + q * ms;
      const Eigen::Map<const Eigen::VectorXd> S(z.data() + base, n_);
      DerivativesAlong(l, S);
      Eigen::Map<Eigen::VectorXd>(dz.data() + base, n_).noalias() = J_ * S + f_theta.col(l);
      Unpack(z.subspan(base), &SP_);
      Multiply(dJ_, P_, &M_);
      Multiply(J_, SP_, &M2_);
      for (int b = 0; b < n_; ++b) {
        for (int a = b; a < n_; ++a) {
          double v = (M_(a, b) + M2_(a, b)) + (M_(b, a) + M2_(b, a));
          if (a == b) v += 2.0 * sigma()[a] * dsigma_(a);
          dz[base + packed_(a, b)] = v;
        }
      }
    }
    return true;
  }

  // The derivative program at the slots EvaluateAt filled; false (failure() set) if not finite.
  bool EvaluateDerivatives() {
    sens_->dynamics().Eval(slots_, dense_, scratch_);
    FiniteTest finite;  // the entries are named only after a failure
    for (const std::size_t position : sens_->dynamics().positions()) finite.Add(dense_[position]);
    if (finite.Passed()) return true;
    if (auto bad = sens_->NotFinite(sens_->dynamics(), dense_, slots_)) {
      failure_ = std::move(*bad);
      return false;
    }
    return true;
  }

  // Along θ_l with the state's sensitivity S, from EvaluateDerivatives' values:
  // dJ_ = Σ_m ∂J/∂x_m S_m + ∂J/∂θ_l and dsigma_ = ∂σ/∂x S + ∂σ/∂θ_l.
  void DerivativesAlong(int l, const Eigen::Ref<const Eigen::VectorXd>& S) {
    const model::NonlinearSensitivity& sens = *sens_;
    dJ_ = Eigen::Map<const Eigen::MatrixXd>(dense_.data() + sens.DynJtheta(l), n_, n_);
    for (int m = 0; m < n_; ++m)
      dJ_.noalias() +=
          S(m) * Eigen::Map<const Eigen::MatrixXd>(dense_.data() + sens.DynJx(m), n_, n_);
    dsigma_.noalias() =
        Eigen::Map<const Eigen::MatrixXd>(dense_.data() + sens.DynSigmaX(), n_, n_) * S;
    dsigma_ += Eigen::Map<const Eigen::VectorXd>(
        dense_.data() + sens.DynSigmaTheta() +
            static_cast<std::size_t>(l) * static_cast<std::size_t>(n_),
        n_);
  }

  // λ' ∂F/∂z and λ' ∂F/∂θ (every parameter) at (t, z), for the moment equations alone (neither
  // the transition nor the sensitivities). With λ = [λx; packed λP] and Λ the symmetric matrix of
  // λP (Λ_ab = Λ_ba = λ_ab / 2 off the diagonal, Λ_aa = λ_aa, so that Σ_{a>=b} λ_ab M_ab =
  // <Λ, M> for a symmetric M) and W = Λ P:
  //   ∂/∂x̂_m = (J' λx)_m + 2 <W, ∂J/∂x_m> + Σ_a 2 Λ_aa σ_a ∂σ_a/∂x_m
  //   ∂/∂P   = J' Λ + Λ J  (packed: twice off the diagonal)
  //   ∂/∂θ_l = λx' ∂f/∂θ_l + 2 <W, ∂J/∂θ_l> + Σ_a 2 Λ_aa σ_a ∂σ_a/∂θ_l
  bool Vjp(int stage, double t, std::span<const double> z, std::span<const double> lambda,
           std::span<double> z_bar, std::span<double> theta_bar) override {
    assert(sens_ && free_.empty() && !transition_);
    assert(stage < retrace_next_ && "Rhs has run at the stage");
    SetSlots(t, z.data());
    const auto at = retrace_out_.begin() + static_cast<std::ptrdiff_t>(Z(stage)) *
                                               static_cast<std::ptrdiff_t>(out_.size());
    std::copy(at, at + static_cast<std::ptrdiff_t>(out_.size()), out_.begin());
    SetJ();
    if (!EvaluateDerivatives()) return false;
    Unpack(z, &P_);
    Eigen::MatrixXd& Lambda = SP_;  // workspace
    for (int b = 0; b < n_; ++b) {
      for (int a = b; a < n_; ++a) {
        const double v = lambda[packed_(a, b)];
        Lambda(a, b) = Lambda(b, a) = a == b ? v : 0.5 * v;
      }
    }
    return VjpAt(lambda.first(n_), Lambda, z_bar, theta_bar);
  }

  // Vjp's terms at the point EvaluateAt and EvaluateDerivatives last took (P_ holding P), with
  // λx and Λ given; adds the packed ∂/∂P into z_bar's P part only when it has one.
  bool VjpAt(std::span<const double> lambda_x, const Eigen::MatrixXd& Lambda,
             std::span<double> z_bar, std::span<double> theta_bar) {
    for (int m = 0; m < n_; ++m) {  // J' λx
      double v = 0.0;
      for (int i = 0; i < n_; ++i) v += J_(i, m) * lambda_x[Z(i)];
      z_bar[Z(m)] += v;
    }
    if (static_cast<int>(z_bar.size()) >= moments_size()) {
      // Λ J by J's nonzeros: (Λ J)_ba = (J' Λ)_ab term by term (Λ is symmetric), so the packed
      // ∂/∂P, (J' Λ + Λ J)_ab, is the same sum either way.
      MultiplyByJSized(Lambda.data(), JRowMajor(), j_rows_.data(), j_column_begin_.data(),
                       M_.data(), n_);
      for (int b = 0; b < n_; ++b)
        for (int a = b; a < n_; ++a)
          z_bar[packed_(a, b)] += a == b ? 2.0 * M_(a, a) : 2.0 * (M_(b, a) + M_(a, b));
    }
    // The terms of the derivative program's nonzero entries (ClassifyNonzeros): each adds its
    // value times a coefficient, [λx | 2 W (column-major) | 2 Λ_aa σ_a], to its target,
    // [∂/∂x̂ | ∂/∂θ].
    const double* s = sigma();
    const std::size_t nn = Z(n_) * Z(n_);
    for (int i = 0; i < n_; ++i) coefficients_[Z(i)] = lambda_x[Z(i)];
    // W = Λ P at the entries a term reads (within J's pattern: a derivative of J is zero where J
    // is), each summed over k in order as the whole product (MultiplySquare) sums it.
    const double* L = Lambda.data();
    const std::ptrdiff_t n = n_;
    for (const std::size_t r : w_entries_) {
      const auto a = static_cast<std::ptrdiff_t>(r) % n, b = static_cast<std::ptrdiff_t>(r) / n;
      const double* P_b = P_.data() + b * n;
      double w = L[a] * P_b[0];
      for (std::ptrdiff_t k = 1; k < n; ++k) w += L[k * n + a] * P_b[k];
      coefficients_[Z(n_) + r] = 2.0 * w;
    }
    for (int a = 0; a < n_; ++a) coefficients_[Z(n_) + nn + Z(a)] = 2.0 * Lambda(a, a) * s[a];
    // Target by target, each summed in the positions' order (as a loop over the positions adding
    // into the targets would sum it, to the bit), in a register rather than through memory.
    for (std::size_t target = 0; target + 1 < target_begin_.size(); ++target) {
      double sum = 0.0;
      for (std::size_t r = target_begin_[target]; r < target_begin_[target + 1]; ++r)
        sum += dense_[term_position_[r]] * coefficients_[term_coefficient_[r]];
      targets_[target] = sum;
    }
    for (int m = 0; m < n_; ++m) z_bar[m] += targets_[Z(m)];
    for (std::size_t l = 0; l < theta_bar.size(); ++l) theta_bar[l] += targets_[Z(n_) + l];
    return true;
  }

  // For each nonzero entry of the derivative program (in its positions' order): which term of
  // Vjp it is, as the target it adds to (x̂_m: m, θ_l: n + l) and the coefficient it is
  // multiplied by (λx_i: i, 2 W_r: n + r, 2 Λ_aa σ_a: n + n² + a). The blocks (nonlinear_
  // sensitivity.h): fθ (i, l) -> θ_l by λx_i; ∂J/∂x_m (r) -> x̂_m by 2 W_r; ∂J/∂θ_l (r) -> θ_l
  // by 2 W_r; ∂σ/∂x (a, m) -> x̂_m and ∂σ/∂θ (a, l) -> θ_l by 2 Λ_aa σ_a.
  void ClassifyNonzeros() {
    const model::NonlinearSensitivity& sens = *sens_;
    const std::size_t n = Z(n_), nn = n * n;
    const std::size_t np = Z(model_.n_parameters());
    const std::span<const std::size_t> positions = sens.dynamics().positions();
    std::vector<std::size_t> target_of(positions.size()), coefficient_of(positions.size());
    for (std::size_t k = 0; k < positions.size(); ++k) {
      const std::size_t pos = positions[k];
      std::size_t target = 0, coefficient = 0;
      if (pos < sens.DynJx(0)) {  // fθ
        target = n + pos / n;
        coefficient = pos % n;
      } else if (pos < sens.DynJtheta(0)) {  // ∂J/∂x_m
        target = (pos - sens.DynJx(0)) / nn;
        coefficient = n + (pos - sens.DynJx(0)) % nn;
      } else if (pos < sens.DynSigmaX()) {  // ∂J/∂θ_l
        target = n + (pos - sens.DynJtheta(0)) / nn;
        coefficient = n + (pos - sens.DynJtheta(0)) % nn;
      } else if (pos < sens.DynSigmaTheta()) {  // ∂σ/∂x
        target = (pos - sens.DynSigmaX()) / n;
        coefficient = n + nn + (pos - sens.DynSigmaX()) % n;
      } else {  // ∂σ/∂θ
        target = n + (pos - sens.DynSigmaTheta()) / n;
        coefficient = n + nn + (pos - sens.DynSigmaTheta()) % n;
      }
      target_of[k] = target;
      coefficient_of[k] = coefficient;
    }
    // The terms grouped by target, in the positions' order within each (a stable counting sort).
    target_begin_.assign(n + np + 1, 0);
    for (const std::size_t t : target_of) ++target_begin_[t + 1];
    for (std::size_t t = 0; t < n + np; ++t) target_begin_[t + 1] += target_begin_[t];
    term_position_.resize(positions.size());
    term_coefficient_.resize(positions.size());
    std::vector<std::size_t> next(target_begin_.begin(), target_begin_.end() - 1);
    for (std::size_t k = 0; k < positions.size(); ++k) {
      const std::size_t r = next[target_of[k]]++;
      term_position_[r] = positions[k];
      term_coefficient_[r] = coefficient_of[k];
    }
    coefficients_.resize(n + nn + n);
    // The entries of W the terms read.
    w_entries_.clear();
    for (const std::size_t c : term_coefficient_)
      if (c >= n && c < n + nn) w_entries_.push_back(c - n);
    std::sort(w_entries_.begin(), w_entries_.end());
    w_entries_.erase(std::unique(w_entries_.begin(), w_entries_.end()), w_entries_.end());
    targets_.resize(n + np);
  }
  static std::size_t Z(int i) { return static_cast<std::size_t>(i); }
  // *M = A B for the moment equations' n x n matrices (n the states), column by column as sums of
  // A's columns: each entry summed over k in order, whatever n is (MultiplySquare).
  static void Multiply(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, Eigen::MatrixXd* M) {
    MultiplySquare(A.data(), B.data(), M->data(), static_cast<int>(A.rows()));
  }

  // ∂F/∂z without the terms of ∂J/∂x̂ and ∂σ/∂x̂ (second derivatives): [J 0; 0 L(J)] with
  // L(J) the Lyapunov operator P -> J P + P J' on the lower triangle.
  void Jacobian(double t, std::span<const double> z, std::span<double> jac) override {
    const int N = size();
    std::fill(jac.begin(), jac.end(), 0.0);
    if (!EvaluateAt(t, z.data())) return;
    auto at = [&](int row, int col) -> double& {
      return jac[static_cast<std::size_t>(col) * N + row];
    };
    for (int i = 0; i < n_; ++i)
      for (int j = 0; j < n_; ++j) at(i, j) = J_(i, j);
    // (J P + P J')_ab = Σ_k J_ak P_kb + Σ_k J_bk P_ak; P_cd (c >= d) stands for P_cd and P_dc.
    for (int b = 0; b < n_; ++b) {
      for (int a = b; a < n_; ++a) {
        const int row = packed_(a, b);
        for (int k = 0; k < n_; ++k) {
          at(row, packed_(k, b)) += J_(a, k);
          at(row, packed_(a, k)) += J_(b, k);
        }
      }
    }
    // dΦ_·c/dt = J Φ_·c: J on every column of Φ.
    for (int c = 0; transition_ && c < n_; ++c) {
      const int base = moments_size() + c * n_;
      for (int i = 0; i < n_; ++i)
        for (int j = 0; j < n_; ++j) at(base + i, base + j) = J_(i, j);
    }
    // Each sensitivity block: the same operator on itself (its coupling to x̂ and P left out).
    for (int q = 0; q < n_free(); ++q) {
      const int base = sensitivity_offset() + q * moments_size();
      for (int r = 0; r < moments_size(); ++r)
        for (int c = 0; c < moments_size(); ++c) at(base + r, base + c) = at(r, c);
    }
  }

  // ρ(∂F/∂z) dt at (x, t0) for the solver's choice of method: 2 ρ(J) dt, since the moment
  // equations' linear part has the eigenvalues λ_i + λ_j of J's (infinite if J is not finite).
  // The spectral radius itself, not a norm: a norm grows with the states' units (a row-sum bound
  // counted the mean-value engine's ∂(dz2)/∂mfv = 3200 as a mode of 3200/s, and sent an interval
  // whose fastest mode is 61/s to BDF). The eigenvalues are computed only where the balanced
  // bound (SpectralRadiusBound) does not already settle that the interval is not stiff, and the
  // bound is returned where it does: the solver only compares the figure with its limit, so the
  // choice is the same, and an eigenvalue solver at every interval was a fifth of the engine
  // model's log L.
  double Stiffness(const double* x) {
    if (!EvaluateAt(t0_, x)) return std::numeric_limits<double>::infinity();
    if (!J_.allFinite()) return std::numeric_limits<double>::infinity();
    if (n_ == 1) return 2.0 * std::abs(J_(0, 0)) * dt_;
    balanced_ = J_;
    const double bound = 2.0 * SpectralRadiusBound(&balanced_) * dt_;
    if (bound <= ode::OdeSolver::kStiffLimit) return bound;
    const Eigen::EigenSolver<Eigen::MatrixXd> eig(J_, /*computeEigenvectors=*/false);
    if (eig.info() != Eigen::Success) return 2.0 * J_.cwiseAbs().rowwise().sum().maxCoeff() * dt_;
    return 2.0 * eig.eigenvalues().cwiseAbs().maxCoeff() * dt_;
  }

  // "stationary" P0's sensitivities: J dP + dP J' = -(dJ P + P dJ' + diag(2 σ dσ)) for each free
  // θ_l, dJ and dσ with the initial state's own S = ∂x0/∂θ_l (ds->x). EvaluateAt(x0) has run.
  // Solved through the Kronecker form (I ⊗ J + J ⊗ I) vec dP = -vec Q (n² unknowns).
  bool StationarySensitivities(const Eigen::MatrixXd& P, MomentSensitivities* ds) {
    if (!EvaluateDerivatives()) return false;
    const Eigen::Index n = n_;
    const Eigen::PartialPivLU<Eigen::MatrixXd> lu(LyapunovOperator(J_));
    for (int q = 0; q < n_free(); ++q) {
      DerivativesAlong(free_[q], ds->x.col(q));
      Eigen::MatrixXd Q = dJ_ * P + P * dJ_.transpose();
      for (int i = 0; i < n_; ++i) Q(i, i) += 2.0 * sigma()[i] * dsigma_(i);
      Eigen::VectorXd v = lu.solve(-Eigen::Map<const Eigen::VectorXd>(Q.data(), n * n));
      Eigen::Map<const Eigen::MatrixXd> dP(v.data(), n, n);
      ds->P[q] = 0.5 * (dP + dP.transpose());
    }
    return true;
  }

  void Unpack(std::span<const double> z, Eigen::MatrixXd* P) const {
    const double* packed = z.data() + n_;  // packed_'s order
    for (int b = 0; b < n_; ++b)
      for (int a = b; a < n_; ++a) (*P)(a, b) = (*P)(b, a) = *packed++;
  }
  void Pack(const Eigen::MatrixXd& P, std::span<double> z) const {
    for (int b = 0; b < n_; ++b)
      for (int a = b; a < n_; ++a) z[packed_(a, b)] = 0.5 * (P(a, b) + P(b, a));
  }

  const Eigen::MatrixXd& J() const { return J_; }
  void SetP(const Eigen::MatrixXd& P) { P_ = P; }
  const double* sigma() const { return out_.data() + n_ + static_cast<std::ptrdiff_t>(n_) * n_; }
  const std::optional<Error>& failure() const { return failure_; }
  void clear_failure() { failure_.reset(); }

 private:
  const model::NonlinearModel& model_;
  const int n_;
  const bool transition_;
  const model::NonlinearSensitivity* sens_;
  const std::vector<int> free_;
  const int m_;
  const int time_slot_;
  std::vector<double> dense_, scratch_;  // the sensitivity program's output
  // The derivative program's nonzero terms grouped by their target (ClassifyNonzeros): target t's
  // terms are r in [target_begin_[t], target_begin_[t + 1]), each the value at term_position_[r]
  // times coefficient term_coefficient_[r].
  std::vector<std::size_t> target_begin_, term_position_, term_coefficient_;
  std::vector<double> coefficients_, targets_;  // Vjp's workspace
  std::vector<std::size_t> w_entries_;          // W's entries (column-major) a term reads
  int retrace_stages_ = 0, retrace_next_ = 0;   // Retrace
  std::vector<double> retrace_out_;             // the dynamics at each retraced stage
  Eigen::MatrixXd dJ_, SP_;
  Eigen::VectorXd dsigma_;
  std::vector<double> slots_;
  std::vector<double> out_;
  Eigen::MatrixXi packed_;
  std::vector<int> j_columns_, j_begin_;      // J's structural nonzeros by row (MultiplyByJt)
  std::vector<int> j_rows_, j_column_begin_;  // and by column (MultiplyByJ)
  bool sparse_j_ = false;
  Eigen::MatrixXd balanced_;  // Stiffness's scratch (SpectralRadiusBound scales it)
  Eigen::MatrixXd J_, P_, M_, M2_;
  const double* u0_ = nullptr;
  const double* u1_ = nullptr;
  double t0_ = 0.0, dt_ = 1.0;
  std::optional<Error> failure_;
  RhsFunction rhs_ = RhsFor(n_);
};

MomentPropagator::MomentPropagator(const model::NonlinearModel& model,
                                   std::span<const double> theta, const data::Series& series,
                                   model::InputHold hold, bool transition,
                                   const model::NonlinearSensitivity* sensitivity,
                                   std::span<const int> free)
    : model_(model),
      series_(series),
      theta_(theta.begin(), theta.end()),
      foh_(hold == model::InputHold::kFoh),
      transition_(transition),
      sensitivity_(sensitivity),
      free_(free.begin(), free.end()),
      moments_(std::make_unique<Moments>(model, theta_, transition, sensitivity, free)),
      solver_(std::make_unique<ode::OdeSolver>(model.spec().ekf, moments_->size())),
      z_(moments_->size()),
      slots_(model.n_slots(), 0.0) {
  assert(static_cast<int>(theta.size()) == model.n_parameters());
  assert(series.U.rows() == model.n_inputs() && series.Y.rows() == model.n_outputs());
  assert((sensitivity != nullptr || free.empty()) && "sensitivities need the model's derivatives");
  std::copy(theta.begin(), theta.end(), slots_.begin() + model.parameter_slot());
}

MomentPropagator::~MomentPropagator() = default;

const ode::OdeCounts& MomentPropagator::counts() const { return solver_->counts(); }

Status MomentPropagator::Advance(int j, Eigen::VectorXd* x, Eigen::MatrixXd* P,
                                 Eigen::MatrixXd* Phi, MomentSensitivities* ds) {
  const int n = model_.n_states(), m = model_.n_inputs();
  const bool transition = transition_;
  const int K = static_cast<int>(free_.size());
  assert((K == 0 || (ds && ds->x.cols() == K && static_cast<int>(ds->P.size()) == K)) &&
         "the sensitivities of every free parameter");
  const int ms = moments_->moments_size();
  const double* U = series_.U.data();
  const double* u0 = U + static_cast<std::size_t>(j) * m;
  moments_->SetInterval(u0, foh_ ? u0 + m : nullptr, series_.time[j],
                        series_.time[j + 1] - series_.time[j]);
  std::copy(x->data(), x->data() + n, z_.begin());
  moments_->Pack(*P, z_);
  if (transition) {
    Eigen::Map<Eigen::MatrixXd>(z_.data() + moments_->moments_size(), n, n).setIdentity();
  }
  for (int q = 0; q < K; ++q) {
    const std::span<double> block =
        std::span<double>(z_).subspan(moments_->sensitivity_offset() + q * ms);
    std::copy(ds->x.col(q).data(), ds->x.col(q).data() + n, block.begin());
    moments_->Pack(ds->P[q], block);
  }
  const double stiffness =
      model_.spec().ekf.method == model::OdeMethod::kAuto ? moments_->Stiffness(z_.data()) : 0.0;
  moments_->clear_failure();
  auto s = solver_->Advance(*moments_, series_.time[j], series_.time[j + 1], z_, stiffness);
  if (!s) {
    // The model's own reason (an entry not finite where the solver tried it) says more than
    // the solver's.
    const std::string why = moments_->failure() ? moments_->failure()->message : s.error().message;
    return data::AtRow(NumericalError(fmt::format(
                           "the moment equations could not be integrated from row {} (t = {:g}) to "
                           "the next: {}",
                           j + 1, series_.time[j], why)),
                       series_, j);
  }
  *x = Eigen::Map<const Eigen::VectorXd>(z_.data(), n);
  moments_->Unpack(z_, P);
  if (Phi && transition)
    *Phi = Eigen::Map<const Eigen::MatrixXd>(z_.data() + moments_->moments_size(), n, n);
  for (int q = 0; q < K; ++q) {
    const std::span<const double> block =
        std::span<const double>(z_).subspan(moments_->sensitivity_offset() + q * ms);
    ds->x.col(q) = Eigen::Map<const Eigen::VectorXd>(block.data(), n);
    moments_->Unpack(block, &ds->P[q]);
  }
  return Ok{};
}

void MomentPropagator::set_step_log(std::vector<double>* log) { solver_->set_step_log(log); }

int MomentPropagator::moments_size() const { return moments_->moments_size(); }

void MomentPropagator::Pack(const Eigen::VectorXd& x, const Eigen::MatrixXd& P,
                            std::span<double> z) const {
  std::copy(x.data(), x.data() + x.size(), z.begin());
  moments_->Pack(P, z);
}

void MomentPropagator::Unpack(std::span<const double> z, Eigen::VectorXd* x,
                              Eigen::MatrixXd* P) const {
  const int n = model_.n_states();
  *x = Eigen::Map<const Eigen::VectorXd>(z.data(), n);
  P->resize(n, n);
  moments_->Unpack(z, P);
}

Status MomentPropagator::ReverseAdvance(int j, std::span<const double> z0,
                                        std::span<const double> steps, std::span<double> z_bar,
                                        std::span<double> theta_bar) {
  assert(sensitivity_ && free_.empty() && !transition_);
  const int m = model_.n_inputs();
  const double* u0 = series_.U.data() + static_cast<std::size_t>(j) * m;
  moments_->SetInterval(u0, foh_ ? u0 + m : nullptr, series_.time[j],
                        series_.time[j + 1] - series_.time[j]);
  moments_->clear_failure();
  auto s = ode::ReverseExplicitSteps(*moments_, steps, z0, z_bar, theta_bar);
  if (!s) {
    const std::string why = moments_->failure() ? moments_->failure()->message : s.error().message;
    return data::AtRow(
        NumericalError(fmt::format("the adjoint of the moment equations from row {} (t = {:g}) "
                                   "to the next could not be computed: {}",
                                   j + 1, series_.time[j], why)),
        series_, j);
  }
  return Ok{};
}

Status MomentPropagator::StationaryAdjoint(const Eigen::VectorXd& x0, const Eigen::MatrixXd& P0,
                                           const Eigen::MatrixXd& P0_bar, Eigen::VectorXd* x0_bar,
                                           std::span<double> theta_bar) {
  assert(sensitivity_ && free_.empty() && !transition_);
  const Eigen::Index n = model_.n_states();
  moments_->SetInterval(series_.U.data(), nullptr, series_.time[0], 1.0);
  if (!moments_->EvaluateAt(series_.time[0], x0.data()) || !moments_->EvaluateDerivatives())
    return data::AtRow(*moments_->failure(), series_, 0);
  // J' Y + Y J = P0_bar: the Lyapunov operator's Kronecker form (discretize.h), transposed.
  const Eigen::VectorXd v = Eigen::PartialPivLU<Eigen::MatrixXd>(LyapunovOperator(moments_->J()))
                                .transpose()
                                .solve(Eigen::Map<const Eigen::VectorXd>(P0_bar.data(), n * n));
  const Eigen::Map<const Eigen::MatrixXd> Y(v.data(), n, n);
  const Eigen::MatrixXd minus_Y = -0.5 * (Y + Y.transpose());
  moments_->SetP(P0);
  const std::vector<double> zero(static_cast<std::size_t>(n), 0.0);
  moments_->VjpAt(zero, minus_Y, {x0_bar->data(), static_cast<std::size_t>(n)}, theta_bar);
  return Ok{};
}

Status MomentPropagator::InitialDerivatives(std::span<double> dense) {
  const auto& program = sensitivity_->initial();
  std::vector<double> scratch(program.nonzeros());
  program.Eval(slots_, dense, scratch);
  if (auto bad = sensitivity_->NotFinite(program, dense, slots_)) return *bad;
  return Ok{};
}

Status MomentPropagator::Initial(model::InitialCovariance kind, Eigen::VectorXd* x,
                                 Eigen::MatrixXd* P, MomentSensitivities* ds) {
  const int n = model_.n_states();
  const int K = static_cast<int>(free_.size());
  std::vector<double> initial(model_.initial_size());
  model_.Initial(slots_, initial);
  for (std::size_t k = 0; k < initial.size(); ++k) {
    if (!std::isfinite(initial[k]))
      return model_.NotFinite(Program::kInitial, k, initial[k], slots_);
  }
  *x = Eigen::Map<const Eigen::VectorXd>(initial.data(), n);
  P->setZero(n, n);
  std::vector<double> dense;
  if (K > 0) {
    assert(ds && "the sensitivities of every free parameter");
    const auto& program = sensitivity_->initial();
    dense = program.Zeroed();
    std::vector<double> scratch(program.nonzeros());
    program.Eval(slots_, dense, scratch);
    if (auto bad = sensitivity_->NotFinite(program, dense, slots_)) return *bad;
    ds->x.resize(n, K);
    ds->P.assign(K, Eigen::MatrixXd::Zero(n, n));
    for (int q = 0; q < K; ++q)
      ds->x.col(q) = Eigen::Map<const Eigen::VectorXd>(
          dense.data() + static_cast<std::ptrdiff_t>(free_[q]) * n, n);
  }
  switch (kind) {
    case model::InitialCovariance::kCtsm: {
      // The covariance gathered over the first interval from zero, the mean starting at x0.
      Eigen::VectorXd moved = *x;
      if (K == 0) return Advance(0, &moved, P);
      const Eigen::MatrixXd x0_theta = ds->x;
      auto s = Advance(0, &moved, P, nullptr, ds);
      ds->x = x0_theta;
      return s;
    }
    case model::InitialCovariance::kStationary: {
      moments_->SetInterval(series_.U.data(), nullptr, series_.time[0], 1.0);
      if (!moments_->EvaluateAt(series_.time[0], x->data()))
        return data::AtRow(*moments_->failure(), series_, 0);
      Eigen::VectorXd sigma2(n);
      for (int i = 0; i < n; ++i) sigma2(i) = moments_->sigma()[i] * moments_->sigma()[i];
      std::complex<double> bad;
      if (!StationaryCovariance(moments_->J(), sigma2, P, &bad))
        return NumericalError(fmt::format(
            "initial_covariance \"stationary\" needs a stable linearisation at the initial "
            "state, but ∂f/∂x has the eigenvalue {:.6g}{:+.6g}i there (real part not negative); "
            "use \"ctsm\" or explicit variances",
            bad.real(), bad.imag()));
      if (K > 0 && !moments_->StationarySensitivities(*P, ds))
        return data::AtRow(*moments_->failure(), series_, 0);
      return Ok{};
    }
    case model::InitialCovariance::kExplicit:
      for (int i = 0; i < n; ++i) {
        if (initial[n + i] < 0)
          return NumericalError(
              fmt::format("{} = {:g} is negative at these parameter values (a "
                          "variance)",
                          model_.spec().initial_variance[i].path, initial[n + i]));
        (*P)(i, i) = initial[n + i];
      }
      for (int q = 0; q < K; ++q)
        ds->P[q].diagonal() = Eigen::Map<const Eigen::VectorXd>(
            dense.data() + sensitivity_->InitP0theta() + static_cast<std::size_t>(free_[q]) * n, n);
      return Ok{};
  }
  return Ok{};
}

Status MomentPropagator::MeasureSensitivities(int j, const Eigen::VectorXd& x,
                                              std::span<double> dense) {
  const int n = model_.n_states(), m = model_.n_inputs();
  std::copy(x.data(), x.data() + n, slots_.begin());
  const double* u = series_.U.data() + static_cast<std::size_t>(j) * m;
  for (int i = 0; i < m; ++i) slots_[n + i] = u[i];
  slots_[model_.time_slot()] = series_.time[j];
  const auto& program = sensitivity_->measurement();
  measure_scratch_.resize(program.nonzeros());
  program.Eval(slots_, dense, measure_scratch_);
  if (auto bad = sensitivity_->NotFinite(program, dense, slots_))
    return data::AtRow(*bad, series_, j);
  return Ok{};
}

Status MomentPropagator::Measure(int j, const Eigen::VectorXd& x, std::span<double> out) {
  const int n = model_.n_states(), m = model_.n_inputs();
  std::copy(x.data(), x.data() + n, slots_.begin());
  const double* u = series_.U.data() + static_cast<std::size_t>(j) * m;
  for (int i = 0; i < m; ++i) slots_[n + i] = u[i];
  slots_[model_.time_slot()] = series_.time[j];
  model_.Measurement(slots_, out);
  for (std::size_t k = 0; k < out.size(); ++k) {
    if (!std::isfinite(out[k]))
      return data::AtRow(model_.NotFinite(Program::kMeasurement, k, out[k], slots_), series_, j);
  }
  return Ok{};
}

}  // namespace gb::filter
