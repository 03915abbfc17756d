// Sections: 1. parameter paths, fault checks, stepping  2. fuel experiment  3. crankshaft
#include "core/sim/live_dyno.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <fmt/format.h>

#include "core/sim/internal.h"

namespace gb::sim {

// ---- 1. parameter paths, fault checks, stepping ----------------------------------------------

double ParameterPath::At(double t) const {
  if (!(t < t0_ + ramp_s_)) return to_;
  if (t <= t0_) return from_;
  return from_ + (to_ - from_) * ((t - t0_) / ramp_s_);
}

void ParameterPath::MoveTo(double target, double now, double ramp_s) {
  from_ = At(now);
  to_ = target;
  t0_ = now;
  ramp_s_ = ramp_s;
}

namespace {

Status CheckRamp(double ramp_s) {
  if (std::isfinite(ramp_s) && ramp_s >= 0) return Ok{};
  return InputError(
      fmt::format("the ramp must be a finite number of seconds >= 0, not {}", ramp_s));
}

// The factor of a fault on `name`: finite and > 0, or >= 0 where the parameter may vanish.
Status CheckFactor(const char* name, double factor, bool may_vanish) {
  if (std::isfinite(factor) && (factor > 0 || (may_vanish && factor == 0))) return Ok{};
  return InputError(fmt::format("the factor of {} must be a finite number {} 0, not {}", name,
                                may_vanish ? ">=" : ">", factor));
}

// A faulted parameter's new value within kMaxFaultRatio of its nominal value, either way.
Status CheckTarget(const char* name, double target, const ParameterPath& path, double now,
                   double factor) {
  const double ratio = target / path.nominal();
  if (ratio >= 1 / kMaxFaultRatio && ratio <= kMaxFaultRatio) return Ok{};
  return InputError(fmt::format(
      "{} would become {:.6g} ({:.6g} x {}), {:.3g} times its nominal value {:.6g}: a fault may "
      "take it to {:g}..{:g} times that",
      name, target, path.At(now), factor, ratio, path.nominal(), 1 / kMaxFaultRatio,
      kMaxFaultRatio));
}

// The two live dynos' states step alike: `FineStep(record)` takes fine step `i` (the sample at its
// start when `record`), `k` counts the samples given.
template <class State>
void WarmUp(State& s) {
  const std::int64_t end = std::int64_t{s.warmup_samples} * s.e.recording.oversample;
  while (s.i < end) s.FineStep(false);
}

// The sample at fine step i (a sample's time), then the world to the next sample's time.
template <class State>
auto NextSample(State& s) {
  const auto sample = s.FineStep(true);
  for (int j = 1; j < s.e.recording.oversample; ++j) s.FineStep(false);
  ++s.k;
  return sample;
}

}  // namespace

// ---- 2. fuel experiment ----------------------------------------------------------------------

const char* FaultName(FuelFault::Kind kind) {
  switch (kind) {
    case FuelFault::Kind::kTauFF:
      return "tau_ff";
    case FuelFault::Kind::kX:
      return "X";
    case FuelFault::Kind::kSensorDelay:
      return "delay";
    case FuelFault::Kind::kSensorGain:
      return "gain";
  }
  return "?";
}

FuelFaults::FuelFaults(const FuelOperatingPoint& nominal, double max_delay_s)
    : tau_fv_(nominal.tau_fv),
      max_delay_s_(max_delay_s),
      tau_ff_(nominal.tau_ff),
      X_(nominal.X),
      delay_(nominal.delay_s),
      Kb_(nominal.Kb) {}

Status FuelFaults::Inject(const FuelFault& f, double now) {
  using Kind = FuelFault::Kind;
  const bool may_vanish = f.kind == Kind::kX || f.kind == Kind::kSensorDelay;
  if (auto st = CheckFactor(FaultName(f.kind), f.factor, may_vanish); !st) return st;
  if (auto st = CheckRamp(f.ramp_s); !st) return st;
  ParameterPath& path = f.kind == Kind::kTauFF         ? tau_ff_
                        : f.kind == Kind::kX           ? X_
                        : f.kind == Kind::kSensorDelay ? delay_
                                                       : Kb_;
  const double target = path.At(now) * f.factor;
  if (f.kind == Kind::kX && target > 1)
    return InputError(fmt::format("X would become {:.6g} ({:.6g} x {}): it must stay within [0, 1]",
                                  target, path.At(now), f.factor));
  if (f.kind == Kind::kSensorDelay && target > max_delay_s_)
    return InputError(
        fmt::format("the sensor delay would become {:.6g} s ({:.6g} s x {}), longer "
                    "than the {:.6g} s the delay line holds",
                    target, path.At(now), f.factor, max_delay_s_));
  if (f.kind == Kind::kTauFF || f.kind == Kind::kSensorGain)
    if (auto st = CheckTarget(FaultName(f.kind), target, path, now, f.factor); !st) return st;
  path.MoveTo(target, now, f.ramp_s);
  return Ok{};
}

Status FuelFaults::Clear(double now, double ramp_s) {
  if (auto st = CheckRamp(ramp_s); !st) return st;
  for (ParameterPath* path : {&tau_ff_, &X_, &delay_, &Kb_})
    path->MoveTo(path->nominal(), now, ramp_s);
  return Ok{};
}

FuelTruth FuelFaults::At(double t) const {
  return {tau_fv_, tau_ff_.At(t), X_.At(t), delay_.At(t), Kb_.At(t)};
}

namespace {

// The fuel film of eq. 13 on the fine grid, at the film parameters τ_ff and X.
internal::FineSystem FuelFilm(const FuelOperatingPoint& p, double tau_ff, double X, double h) {
  Eigen::MatrixXd A(2, 2), B(2, 1);
  A << -1 / p.tau_fv, 0, 0, -1 / tau_ff;
  B << (1 - X) / p.tau_fv, X / tau_ff;
  Eigen::VectorXd sigma2(2);
  sigma2 << p.s11, p.s12;
  return internal::FineSystem(A, B, sigma2, h);
}

}  // namespace

struct LiveFuelDyno::State {
  explicit State(const FuelExperiment& experiment);
  double Now() const { return internal::FineTime(i, warmup_samples, e.recording); }
  std::size_t Slot(std::int64_t j) const {
    const auto n = static_cast<std::int64_t>(flow.size());
    return static_cast<std::size_t>((j % n + n) % n);
  }
  // Fine step i: the sample at its start when `record`, then the world over [t_i, t_i + h).
  FuelSample FineStep(bool record);

  FuelExperiment e;
  double h;
  double bias;  // g/s, 1/K_b at the nominal K_b
  int warmup_samples;
  NormalRng rng;
  internal::PrbsLevel prbs;
  FuelFaults faults;
  double film_tau_ff, film_X;  // the values `film` is discretised at
  internal::FineSystem film;
  internal::AntiAliasFilter filter_u, filter_y;
  Eigen::VectorXd x;         // (mfv, mff)
  std::vector<double> flow;  // mfv + mff at the port at fine step j, in flow[Slot(j)]
  std::int64_t i = 0;        // fine steps taken, from the start of the warm-up
  std::int64_t k = 0;        // samples given
};

LiveFuelDyno::State::State(const FuelExperiment& experiment)
    : e(experiment),
      h(e.recording.sample_time / e.recording.oversample),
      bias(1.0 / e.point.Kb),
      // Warm-up at the bias so that noise and filters are in their stationary state at t = 0.
      warmup_samples(static_cast<int>(
          std::ceil(std::max(2.0, 10 * e.point.tau_ff) / e.recording.sample_time))),
      rng(e.seed),
      prbs(e.prbs_order, e.bit_period, static_cast<std::uint32_t>(e.seed)),
      faults(e.point, MaxSensorDelay(e.point)),
      film_tau_ff(e.point.tau_ff),
      film_X(e.point.X),
      film(FuelFilm(e.point, film_tau_ff, film_X, h)),
      filter_u(e.recording, h),
      filter_y(e.recording, h) {
  x = film.Steady(Eigen::VectorXd::Constant(1, bias));
  filter_u.Reset(bias);
  filter_y.Reset(e.point.Kb * x.sum());
  // Before the warm-up the port saw the steady flow (the sensor's first reads reach back there).
  flow.assign(static_cast<std::size_t>(std::lround(MaxSensorDelay(e.point) / h)) + 1, x.sum());
  WarmUp(*this);
}

FuelSample LiveFuelDyno::State::FineStep(bool record) {
  const double t = internal::FineTime(i, warmup_samples, e.recording);
  const double mfi = t < 0 ? bias : bias * (1 + e.amplitude * prbs.At(t));
  const FuelTruth now = faults.At(t);
  const double sensor = now.Kb * flow[Slot(i - std::lround(now.delay_s / h))];
  // A sample at t_k records the channels at t_k: the input as applied from t_k on.
  FuelSample s;
  if (record) {
    s.t = internal::SampleTime(k, e.recording.sample_time);
    s.mfi = filter_u.Output(mfi);
    s.ilambda = filter_y.Output(sensor) + std::sqrt(e.point.s2) * rng.Normal();
  }
  const FuelTruth mid = faults.At(t + 0.5 * h);
  if (mid.tau_ff != film_tau_ff || mid.X != film_X) {
    film_tau_ff = mid.tau_ff;
    film_X = mid.X;
    film = FuelFilm(e.point, film_tau_ff, film_X, h);
  }
  film.Step(x, Eigen::VectorXd::Constant(1, mfi), rng);
  flow[Slot(i + 1)] = x.sum();
  filter_u.Step(mfi, rng);
  filter_y.Step(sensor, rng);
  ++i;
  return s;
}

Result<LiveFuelDyno> LiveFuelDyno::Create(const FuelExperiment& e) {
  std::string why;
  if (!internal::ValidFuelSetup(e, &why)) return InputError("fuel experiment: " + why);
  return LiveFuelDyno(std::make_unique<State>(e));
}

double LiveFuelDyno::MaxSensorDelay(const FuelOperatingPoint& p) {
  return std::max(1.0, 2 * p.delay_s);
}

LiveFuelDyno::LiveFuelDyno(std::unique_ptr<State> state) : s_(std::move(state)) {}
LiveFuelDyno::LiveFuelDyno(LiveFuelDyno&&) noexcept = default;
LiveFuelDyno& LiveFuelDyno::operator=(LiveFuelDyno&&) noexcept = default;
LiveFuelDyno::~LiveFuelDyno() = default;

FuelSample LiveFuelDyno::Next() { return NextSample(*s_); }

double LiveFuelDyno::Time() const {
  return internal::SampleTime(s_->k, s_->e.recording.sample_time);
}
std::int64_t LiveFuelDyno::SampleIndex() const { return s_->k; }
Status LiveFuelDyno::Inject(const FuelFault& f) { return s_->faults.Inject(f, s_->Now()); }
Status LiveFuelDyno::ClearFaults(double ramp_s) { return s_->faults.Clear(s_->Now(), ramp_s); }
FuelTruth LiveFuelDyno::Truth() const { return s_->faults.At(s_->Now()); }
const FuelExperiment& LiveFuelDyno::experiment() const { return s_->e; }

// ---- 3. crankshaft experiment ----------------------------------------------------------------

namespace {

// The crankshaft of eq. 15 on the fine grid, at τ_f and J_e (deviations from the bias):
//   dN = (-1/τ_f - G_p K_n/J_e) N dt + (G_p K_θ/J_e) θ dt - (1/J_e) T_l dt + σ1 dω.
internal::FineSystem Shaft(const CrankshaftPoint& p, double tau_f, double Je, double h) {
  Eigen::MatrixXd A(1, 1), B(1, 2);
  A << -1 / tau_f - p.Gp * p.Kn / Je;
  B << p.Gp * p.Ktheta / Je, -1 / Je;
  return internal::FineSystem(A, B, Eigen::VectorXd::Constant(1, p.s1), h);
}

}  // namespace

struct LiveCrankshaftDyno::State {
  explicit State(const CrankshaftExperiment& experiment);
  double Now() const { return internal::FineTime(i, warmup_samples, e.recording); }
  CrankshaftTruth At(double t) const { return {tau_f.At(t), Je.At(t)}; }
  CrankshaftSample FineStep(bool record);

  CrankshaftExperiment e;
  double h;
  int warmup_samples;
  NormalRng rng;
  internal::PrbsLevel throttle, load;
  ParameterPath tau_f, Je;
  CrankshaftTruth shaft_at;  // the values `shaft` is discretised at
  internal::FineSystem shaft;
  internal::AntiAliasFilter f_theta, f_load, f_speed, f_pman;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(1);  // N
  std::int64_t i = 0;
  std::int64_t k = 0;
};

LiveCrankshaftDyno::State::State(const CrankshaftExperiment& experiment)
    : e(experiment),
      h(e.recording.sample_time / e.recording.oversample),
      warmup_samples(static_cast<int>(std::ceil(10 * e.point.tau_f / e.recording.sample_time))),
      rng(e.seed),
      throttle(e.prbs_order, e.bit_period, static_cast<std::uint32_t>(e.seed)),
      load(std::max(design::kMinPrbsOrder, e.prbs_order - 1), 2 * e.bit_period,
           static_cast<std::uint32_t>(e.seed * 7 + 3)),
      tau_f(e.point.tau_f),
      Je(e.point.Je),
      shaft_at{e.point.tau_f, e.point.Je},
      shaft(Shaft(e.point, shaft_at.tau_f, shaft_at.Je, h)),
      f_theta(e.recording, h),
      f_load(e.recording, h),
      f_speed(e.recording, h),
      f_pman(e.recording, h) {
  for (auto* f : {&f_theta, &f_load, &f_speed, &f_pman}) f->Reset(0.0);
  WarmUp(*this);
}

CrankshaftSample LiveCrankshaftDyno::State::FineStep(bool record) {
  const CrankshaftPoint& p = e.point;
  const double t = internal::FineTime(i, warmup_samples, e.recording);
  const double th = t < 0 ? 0.0 : e.throttle_amplitude * throttle.At(t);
  const double tl = (t < 0 || !e.perturb_load) ? 0.0 : e.load_amplitude * load.At(t);
  const double pman = -p.Kn * x(0) + p.Ktheta * th;
  CrankshaftSample s;
  if (record) {
    s.t = internal::SampleTime(k, e.recording.sample_time);
    s.theta = f_theta.Output(th);
    s.Tl = f_load.Output(tl);
    s.N = f_speed.Output(x(0)) + std::sqrt(p.s21) * rng.Normal();
    s.Pman = f_pman.Output(pman) + std::sqrt(p.s22) * rng.Normal();
  }
  f_theta.Step(th, rng);
  f_load.Step(tl, rng);
  f_speed.Step(x(0), rng);
  f_pman.Step(pman, rng);
  const CrankshaftTruth mid = At(t + 0.5 * h);
  if (mid.tau_f != shaft_at.tau_f || mid.Je != shaft_at.Je) {
    shaft_at = mid;
    shaft = Shaft(p, shaft_at.tau_f, shaft_at.Je, h);
  }
  shaft.Step(x, (Eigen::VectorXd(2) << th, tl).finished(), rng);
  ++i;
  return s;
}

Result<LiveCrankshaftDyno> LiveCrankshaftDyno::Create(const CrankshaftExperiment& e) {
  std::string why;
  if (!internal::ValidCrankshaftSetup(e, &why)) return InputError("crankshaft experiment: " + why);
  return LiveCrankshaftDyno(std::make_unique<State>(e));
}

LiveCrankshaftDyno::LiveCrankshaftDyno(std::unique_ptr<State> state) : s_(std::move(state)) {}
LiveCrankshaftDyno::LiveCrankshaftDyno(LiveCrankshaftDyno&&) noexcept = default;
LiveCrankshaftDyno& LiveCrankshaftDyno::operator=(LiveCrankshaftDyno&&) noexcept = default;
LiveCrankshaftDyno::~LiveCrankshaftDyno() = default;

CrankshaftSample LiveCrankshaftDyno::Next() { return NextSample(*s_); }

double LiveCrankshaftDyno::Time() const {
  return internal::SampleTime(s_->k, s_->e.recording.sample_time);
}
std::int64_t LiveCrankshaftDyno::SampleIndex() const { return s_->k; }

Status LiveCrankshaftDyno::Inject(const CrankshaftFault& f) {
  const bool tau = f.kind == CrankshaftFault::Kind::kTauF;
  if (auto st = CheckFactor(tau ? "tau_f" : "Je", f.factor, false); !st) return st;
  if (auto st = CheckRamp(f.ramp_s); !st) return st;
  ParameterPath& path = tau ? s_->tau_f : s_->Je;
  const double now = s_->Now();
  const double target = path.At(now) * f.factor;
  if (auto st = CheckTarget(tau ? "tau_f" : "Je", target, path, now, f.factor); !st) return st;
  path.MoveTo(target, now, f.ramp_s);
  return Ok{};
}

Status LiveCrankshaftDyno::ClearFaults(double ramp_s) {
  if (auto st = CheckRamp(ramp_s); !st) return st;
  const double now = s_->Now();
  for (ParameterPath* path : {&s_->tau_f, &s_->Je}) path->MoveTo(path->nominal(), now, ramp_s);
  return Ok{};
}

CrankshaftTruth LiveCrankshaftDyno::Truth() const { return s_->At(s_->Now()); }
const CrankshaftExperiment& LiveCrankshaftDyno::experiment() const { return s_->e; }

}  // namespace gb::sim
