// Sections: 1. set-up and the start  2. one row at a time  3. the held filter
#include "core/online/ekf_stream.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <optional>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "core/filter/discretize.h"
#include "core/filter/ekf_score.h"
#include "core/filter/internal.h"
#include "core/filter/moments.h"
#include "core/model/nonlinear_sensitivity.h"
#include "core/online/internal.h"

namespace gb::online {
namespace {

using internal::kInf;
using internal::kNaN;
constexpr int kNewtonIterations = 100;
constexpr int kNewtonHalvings = 30;

std::size_t Z(int i) { return static_cast<std::size_t>(i); }

// The slowest time constant of dx/dt = J x, max -1/Re λ; +inf when J has an eigenvalue whose real
// part is not negative (or its eigenvalues cannot be found).
double SlowestTimeConstant(const Eigen::MatrixXd& J) {
  const Eigen::ComplexEigenSolver<Eigen::MatrixXd> es(J, false);
  if (es.info() != Eigen::Success || !J.allFinite()) return kInf;
  double slow = 0.0;
  for (Eigen::Index i = 0; i < es.eigenvalues().size(); ++i) {
    const double re = es.eigenvalues()(i).real();
    if (!(re < 0.0)) return kInf;
    slow = std::max(slow, -1.0 / re);
  }
  return slow;
}

}  // namespace

// ---- 1. set-up and the start -----------------------------------------------------------------

struct EkfStream::Impl {
  std::shared_ptr<const model::NonlinearModel> model;
  std::optional<model::NonlinearSensitivity> sensitivity;
  std::vector<double> theta;
  EkfStreamOptions options;
  std::string source;
  int lag = 0;
  // The two rows the propagator works on (column 0: from, column 1: to), and the propagator
  // bound to them (rebuilt when the parameters change).
  data::Series window;
  std::unique_ptr<filter::MomentPropagator> propagator;
  ode::OdeCounts counts_before;  // of the propagators replaced
  ode::OdeCounts counts;

  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  filter::MomentSensitivities ds;
  double slowest = 0.0;
  std::vector<Sample> rows;  // ring of the last lag + 2 rows
  long n_rows = 0;
  int next_index = 0;
  std::vector<double> meas, dmeas;
  filter::internal::ScoreUpdate update;

  int K() const { return static_cast<int>(options.sensitivities.size()); }
  void Rebuild() {
    if (propagator) counts_before += propagator->counts();
    propagator = std::make_unique<filter::MomentPropagator>(
        *model, theta, window, model->spec().input_hold, false,
        sensitivity ? &*sensitivity : nullptr, options.sensitivities);
  }
  // Row `row` into column c of the window.
  void Place(int c, const Sample& row) {
    window.time[c] = row.t;
    for (Eigen::Index i = 0; i < window.U.rows(); ++i) window.U(i, c) = row.u[i];
    window.row_line[c] = row.line;
  }
  Error At(Error e, int line) const {
    if (e.file.empty()) e.file = source;
    if (e.line == 0) e.line = line;
    return e;
  }
  // The model's slots [x | u | θ | t] at `row`, the states from x (size n) or zero.
  std::vector<double> SlotsAt(const Sample& row, const double* x_or_null) const {
    const model::NonlinearModel& m = *model;
    std::vector<double> slots(Z(m.n_slots()), 0.0);
    if (x_or_null) std::copy(x_or_null, x_or_null + m.n_states(), slots.begin());
    std::copy(row.u.begin(), row.u.end(), slots.begin() + m.input_slot());
    std::copy(theta.begin(), theta.end(), slots.begin() + m.parameter_slot());
    slots[Z(m.time_slot())] = row.t;
    return slots;
  }
  Status Start(const Sample& first, const Sample& second);
  bool Equilibrium(const Sample& first);
  Status TimeUpdate(const Sample& from, const Sample& to);
  Result<EkfStep> MeasurementUpdate(int j);
};

Result<EkfStream> EkfStream::Create(std::shared_ptr<const model::NonlinearModel> model,
                                    std::vector<double> theta, EkfStreamOptions options,
                                    std::string source) {
  const int p = model->n_outputs();
  if (static_cast<int>(theta.size()) != model->n_parameters())
    return InputError(fmt::format("{} parameter values for a model with {}", theta.size(),
                                  model->n_parameters()));
  if (options.delay.empty()) options.delay.assign(static_cast<std::size_t>(p), 0);
  if (static_cast<int>(options.delay.size()) != p)
    return InputError(
        fmt::format("{} output delays for a model with {} outputs", options.delay.size(), p));
  auto impl = std::make_unique<Impl>();
  for (int d : options.delay) {
    if (d < 0) return InputError(fmt::format("an output delay of {} samples", d));
    impl->lag = std::max(impl->lag, d);
  }
  if (!options.sensitivities.empty()) {
    auto s = model::NonlinearSensitivity::Compile(*model);
    if (!s) return s.error();
    impl->sensitivity.emplace(std::move(*s));
  }
  impl->model = std::move(model);
  impl->theta = std::move(theta);
  impl->options = std::move(options);
  impl->source = std::move(source);
  const model::NonlinearModel& m = *impl->model;
  impl->window.source = impl->source;
  impl->window.time.assign(2, 0.0);
  impl->window.U.setZero(m.n_inputs(), 2);
  impl->window.Y.setConstant(p, 2, kNaN);
  impl->window.row_line.assign(2, 0);
  impl->window.outputs = m.spec().outputs;
  impl->rows.resize(static_cast<std::size_t>(impl->lag) + 2);
  impl->meas.resize(m.measurement_size());
  if (impl->sensitivity) impl->dmeas = impl->sensitivity->measurement().Zeroed();
  impl->Rebuild();
  return EkfStream(std::move(impl));
}

EkfStream::EkfStream(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
EkfStream::EkfStream(EkfStream&&) noexcept = default;
EkfStream& EkfStream::operator=(EkfStream&&) noexcept = default;
EkfStream::~EkfStream() = default;

Eigen::VectorXd& EkfStream::x() { return impl_->x; }
Eigen::MatrixXd& EkfStream::P() { return impl_->P; }
const Eigen::VectorXd& EkfStream::x() const { return impl_->x; }
const Eigen::MatrixXd& EkfStream::P() const { return impl_->P; }
const model::NonlinearModel& EkfStream::model() const { return *impl_->model; }
const std::vector<double>& EkfStream::theta() const { return impl_->theta; }
double EkfStream::slowest_time_constant() const { return impl_->slowest; }
const ode::OdeCounts& EkfStream::counts() const {
  impl_->counts = impl_->counts_before;
  impl_->counts += impl_->propagator->counts();
  return impl_->counts;
}

void EkfStream::SetParameters(std::span<const double> theta) {
  impl_->theta.assign(theta.begin(), theta.end());
  impl_->Rebuild();
}

// Damped Newton on the leading states for f = 0 at the first row's input, from x0; on success
// x and P hold the equilibrium and, when J is stable there, the stationary covariance, and
// `slowest` the slowest time constant. False when there is no stable equilibrium to start at.
bool EkfStream::Impl::Equilibrium(const Sample& first) {
  const model::NonlinearModel& m = *model;
  const int n = m.n_states();
  const int nd = options.equilibrium_states < 0 ? n : std::min(options.equilibrium_states, n);
  std::vector<double> slots = SlotsAt(first, nullptr);
  std::vector<double> init(m.initial_size());
  m.Initial(slots, init);
  for (int i = 0; i < n; ++i) slots[i] = init[i];
  std::vector<double> dyn(m.dynamics_size());
  auto evaluate = [&](const std::vector<double>& at, double* norm) {
    m.Dynamics(at, dyn);
    double s = 0.0;
    for (std::size_t k = 0; k < dyn.size(); ++k)
      if (!std::isfinite(dyn[k])) return false;
    for (int i = 0; i < nd; ++i) s += dyn[i] * dyn[i];
    *norm = std::sqrt(s);
    return true;
  };
  double norm = 0.0;
  if (!evaluate(slots, &norm)) return false;
  Eigen::MatrixXd J(nd, nd);
  Eigen::VectorXd f(nd);
  bool converged = false;
  for (int it = 0; it < kNewtonIterations && !converged; ++it) {
    for (int i = 0; i < nd; ++i) {
      f(i) = dyn[i];
      for (int k = 0; k < nd; ++k) J(i, k) = dyn[Z(n) + Z(i) * Z(n) + Z(k)];
    }
    const Eigen::FullPivLU<Eigen::MatrixXd> lu(J);
    if (!lu.isInvertible()) return false;
    const Eigen::VectorXd delta = lu.solve(-f);
    double size = 0.0;
    for (int i = 0; i < nd; ++i) size = std::max(size, std::abs(slots[i]));
    std::vector<double> trial = slots;
    bool accepted = false;
    double step = 1.0;
    for (int h = 0; h < kNewtonHalvings && !accepted; ++h, step *= 0.5) {
      for (int i = 0; i < nd; ++i) trial[i] = slots[i] + step * delta(i);
      double trial_norm = 0.0;
      if (evaluate(trial, &trial_norm) && trial_norm < norm * (1.0 - 1e-4 * step) + 1e-300) {
        accepted = true;
        norm = trial_norm;
      }
    }
    if (!accepted) {
      // No decrease: converged if the Newton step is already at rounding level.
      converged = delta.norm() <= 1e-10 * (1.0 + size);
      if (!converged) return false;
      break;
    }
    slots = trial;
    converged = step * delta.norm() <= 1e-12 * (1.0 + size) || norm == 0.0;
  }
  if (!converged || !evaluate(slots, &norm)) return false;
  // Stability and the stationary covariance of the solved block.
  for (int i = 0; i < nd; ++i)
    for (int k = 0; k < nd; ++k) J(i, k) = dyn[Z(n) + Z(i) * Z(n) + Z(k)];
  Eigen::VectorXd sigma2(nd);
  for (int i = 0; i < nd; ++i) {
    const double s = dyn[Z(n) + Z(n) * Z(n) + Z(i)];
    sigma2(i) = s * s;
  }
  const double slow = SlowestTimeConstant(J);
  if (!std::isfinite(slow)) return false;
  Eigen::MatrixXd Pd;
  std::complex<double> bad;
  if (!filter::StationaryCovariance(J, sigma2, &Pd, &bad) || !Pd.allFinite()) return false;
  x = Eigen::Map<const Eigen::VectorXd>(slots.data(), n);
  P = Eigen::MatrixXd::Zero(n, n);
  P.topLeftCorner(nd, nd) = Pd;
  slowest = slow;
  return true;
}

Status EkfStream::Impl::Start(const Sample& first, const Sample& second) {
  const int n = model->n_states();
  const int K = this->K();
  Place(0, first);
  Place(1, second);
  ds.x = Eigen::MatrixXd::Zero(n, K);
  ds.P.assign(static_cast<std::size_t>(K), Eigen::MatrixXd::Zero(n, n));
  if (options.start == RecursiveOptions::Start::kLive && Equilibrium(first)) return Ok{};
  slowest = kInf;
  filter::MomentSensitivities* d = K > 0 ? &ds : nullptr;
  Status s = propagator->Initial(model->spec().initial_covariance, &x, &P, d);
  if (!s && options.start == RecursiveOptions::Start::kLive &&
      model->spec().initial_covariance != model::InitialCovariance::kCtsm)
    s = propagator->Initial(model::InitialCovariance::kCtsm, &x, &P, d);
  if (!s) return s;
  if (K == 0) ds.x.resize(n, 0);
  if (options.start == RecursiveOptions::Start::kModel) {
    // The slowest time constant at x0, for the warm-up of the filters that use this one.
    const std::vector<double> slots = SlotsAt(first, x.data());
    std::vector<double> dyn(model->dynamics_size());
    model->Dynamics(slots, dyn);
    slowest = SlowestTimeConstant(
        Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
            dyn.data() + n, n, n));
  }
  return Ok{};
}

// ---- 2. one row at a time --------------------------------------------------------------------

Status EkfStream::Impl::TimeUpdate(const Sample& from, const Sample& to) {
  Place(0, from);
  Place(1, to);
  return propagator->Advance(0, &x, &P, nullptr, K() > 0 ? &ds : nullptr);
}

Result<EkfStep> EkfStream::Impl::MeasurementUpdate(int j) {
  const model::NonlinearModel& m = *model;
  const int n = m.n_states(), p = m.n_outputs();
  const int K = this->K();
  const std::size_t ring = rows.size();
  const Sample& row_j = rows[static_cast<std::size_t>(j) % ring];
  EkfStep step;
  step.index = j;
  step.t = row_j.t;
  step.line = row_j.line;
  step.innovation.assign(static_cast<std::size_t>(p), kNaN);
  step.innovation_sd.assign(static_cast<std::size_t>(p), kNaN);
  step.score = Eigen::VectorXd::Zero(K);
  step.information = Eigen::MatrixXd::Zero(K, K);
  bool any = false;
  for (int o = 0; o < p && !any; ++o)
    any = !std::isnan(rows[static_cast<std::size_t>(j + options.delay[o]) % ring].y[o]);
  if (!any) return step;
  Place(0, row_j);
  if (Status s = propagator->Measure(0, x, meas); !s) return At(s.error(), row_j.line);
  if (K > 0) {
    if (Status s = propagator->MeasureSensitivities(0, x, dmeas); !s)
      return At(s.error(), row_j.line);
  }
  auto H_row = [&](int o) {
    return Eigen::Map<const Eigen::RowVectorXd>(
        meas.data() + p + static_cast<std::ptrdiff_t>(o) * n, n);
  };
  auto S_of = [&](int o) { return meas[Z(p) + Z(p) * Z(n) + Z(o)]; };
  const filter::internal::MeasurementDerivatives derivatives{sensitivity ? &*sensitivity : nullptr,
                                                             dmeas, p, n};
  update.Begin(x, ds, K);
  double logdet = 0.0, r2 = 0.0;
  for (int o = 0; o < p; ++o) {
    const Sample& row = rows[static_cast<std::size_t>(j + options.delay[o]) % ring];
    const double y = row.y[o];
    if (std::isnan(y)) continue;
    double eps = 0.0, R = 0.0;
    if (!filter::internal::ScalarUpdateWithScores(o, y, meas[o], H_row(o), S_of(o), derivatives,
                                                  options.sensitivities, true, &x, &P, &ds, &update,
                                                  &eps, &R))
      return At(NumericalError(fmt::format(
                    "the innovation variance of output '{}' is {:g}, not positive, at t = {:g}",
                    m.spec().outputs[o], R, row.t)),
                row.line);
    logdet += std::log(R);
    r2 += eps * eps / R;
    step.innovation[o] = eps;
    step.innovation_sd[o] = std::sqrt(R);
    ++step.observed;
  }
  filter::internal::Symmetrize(P);
  double drho = 0.5;
  step.loglik_term =
      filter::internal::LoglikTerm(logdet, step.observed, r2, m.spec().robust_huber, &drho);
  if (K > 0) {
    step.score = -(0.5 * update.dlogdet + drho * update.dr2);
    step.information = update.information;
  }
  if (!std::isfinite(step.loglik_term) || !step.score.allFinite())
    return At(NumericalError(fmt::format(
                  "the filter's log-likelihood term is not finite at t = {:g}", row_j.t)),
              row_j.line);
  return step;
}

Result<std::vector<EkfStep>> EkfStream::Push(const Sample& row) {
  Impl& s = *impl_;
  const model::NonlinearModel& m = *s.model;
  if (static_cast<int>(row.u.size()) != m.n_inputs() ||
      static_cast<int>(row.y.size()) != m.n_outputs())
    return s.At(InputError("a row with the wrong number of inputs or outputs"), row.line);
  const std::size_t ring = s.rows.size();
  if (s.n_rows > 0) {
    const Sample& last = s.rows[static_cast<std::size_t>(s.n_rows - 1) % ring];
    if (!(row.t > last.t))
      return s.At(InputError(fmt::format("time {:g} does not increase (the row before, line {}, "
                                         "has {:g})",
                                         row.t, last.line, last.t)),
                  row.line);
  }
  s.rows[static_cast<std::size_t>(s.n_rows) % ring] = row;
  ++s.n_rows;
  std::vector<EkfStep> out;
  while (s.next_index + s.lag < s.n_rows && s.n_rows >= 2) {
    const int j = s.next_index;
    const Sample& at = s.rows[static_cast<std::size_t>(j) % ring];
    Status st = j == 0 ? s.Start(s.rows[0], s.rows[1])
                       : s.TimeUpdate(s.rows[static_cast<std::size_t>(j - 1) % ring], at);
    if (!st) return s.At(st.error(), at.line);
    auto step = s.MeasurementUpdate(j);
    if (!step) return step.error();
    ++s.next_index;
    out.push_back(std::move(*step));
  }
  return out;
}

RecursiveUpdate ToUpdate(const EkfStep& step) {
  RecursiveUpdate u;
  u.index = step.index;
  u.t = step.t;
  u.line = step.line;
  u.innovation = step.innovation;
  u.innovation_sd = step.innovation_sd;
  u.loglik_term = step.loglik_term;
  u.score.assign(step.score.data(), step.score.data() + step.score.size());
  for (Eigen::Index a = 0; a < step.information.rows(); ++a)
    u.information.push_back(step.information(a, a));
  return u;
}

// ---- 3. the held filter ----------------------------------------------------------------------

Result<HeldEkf> HeldEkf::Create(std::shared_ptr<const model::NonlinearModel> model,
                                const Reference& reference, std::vector<int> tracked,
                                RecursiveOptions::Start start) {
  EkfStreamOptions o;
  o.delay = reference.delay;
  o.sensitivities = tracked;
  o.start = start;
  std::vector<std::string> names;
  names.reserve(tracked.size());
  for (int i : tracked) names.push_back(model->spec().parameters[i].name);
  auto stream =
      EkfStream::Create(std::move(model), reference.theta, std::move(o), reference.source);
  if (!stream) return stream.error();
  return HeldEkf(std::move(*stream), std::move(tracked), std::move(names));
}

Result<std::vector<RecursiveUpdate>> HeldEkf::Push(const Sample& row) {
  auto steps = stream_.Push(row);
  if (!steps) return steps.error();
  std::vector<RecursiveUpdate> out;
  out.reserve(steps->size());
  for (const EkfStep& s : *steps) {
    RecursiveUpdate u = ToUpdate(s);
    for (int i : tracked_) u.theta.push_back(stream_.theta()[i]);
    out.push_back(std::move(u));
  }
  return out;
}

}  // namespace gb::online
