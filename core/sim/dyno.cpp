// Sections: 1. Table 2 and the delay relation  2. the continuous world on a fine grid (linear
//           systems, Butterworth filters)  3. fuel experiment  4. crankshaft  5. square wave
#include "core/sim/dyno.h"

#include <cmath>
#include <numbers>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "core/design/prbs.h"
#include "core/filter/discretize.h"
#include "core/sim/random.h"

namespace gb::sim {

// ---- 1. Table 2 and the delay relation ---------------------------------------------------------

const std::vector<FuelOperatingPoint>& PaperFuelPoints() {
  // n rpm, α deg, Δt s, τ_fv s, τ_ff s, X, σ11² (·1e-2), σ12² (·1e-3), σ2² (·1e-4), K_b s/g.
  static const std::vector<FuelOperatingPoint> kPoints = {
      {"f1", 2931, 29.5, 0.0625, 0.0750, 0.375, 0.175, 0.1098e-2, 0.3910e-3, 1.2570e-4, 0.8421},
      {"f2", 3562, 32.8, 0.0375, 0.0788, 0.338, 0.184, 0.3591e-2, 0.1266e-3, 1.2190e-4, 0.7211},
      {"f3", 2655, 24.8, 0.0750, 0.0902, 0.211, 0.073, 0.0751e-2, 1.2010e-3, 0.8106e-4, 1.1937},
      {"f4", 3275, 29.2, 0.0500, 0.0916, 0.275, 0.150, 0.1978e-2, 2.4760e-3, 0.6732e-4, 0.8568},
      {"f7", 3201, 36.5, 0.0375, 0.0799, 0.288, 0.218, 1.6750e-2, 0.2281e-3, 0.2091e-4, 0.6495},
      {"f8", 2676, 24.7, 0.0750, 0.0928, 0.289, 0.067, 0.1333e-2, 0.6240e-3, 0.7682e-4, 1.1609},
  };
  return kPoints;
}

Result<FuelOperatingPoint> FindFuelPoint(const std::string& name) {
  std::string names;
  for (const auto& p : PaperFuelPoints()) {
    if (p.name == name) return p;
    names += (names.empty() ? "" : ", ") + p.name;
  }
  return InputError(fmt::format("no operating point '{}' (the paper's are {})", name, names));
}

double ExhaustDelay(double speed_rpm) {
  // Least squares of Δt = c / n over Table 2: c = Σ (Δt_i / n_i) / Σ (1 / n_i²).
  double num = 0, den = 0;
  for (const auto& p : PaperFuelPoints()) {
    num += p.delay_s / p.speed_rpm;
    den += 1.0 / (p.speed_rpm * p.speed_rpm);
  }
  return num / den / speed_rpm;
}

// ---- 2. the continuous world on a fine grid --------------------------------------------------

namespace {

// dx = (A x + B u) dt + diag(σ) dω over steps h with u held: exact discretisation and a factor
// of Q for the noise.
class FineSystem {
 public:
  FineSystem(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::VectorXd& sigma2,
             double h) {
    const auto d = filter::Discretize(A, B, Eigen::VectorXd::Zero(A.rows()), sigma2, h,
                                      model::InputHold::kZoh);
    phi_ = d.Phi;
    gamma_ = d.Gamma0;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(d.Q);
    q_factor_ = es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
    noisy_ = sigma2.maxCoeff() > 0;
    // Steady state for a constant input: x = -A⁻¹ B u.
    steady_ = -A.fullPivLu().solve(B);
  }
  Eigen::VectorXd Steady(const Eigen::VectorXd& u) const { return steady_ * u; }
  void Step(Eigen::VectorXd& x, const Eigen::VectorXd& u, NormalRng& rng) const {
    Eigen::VectorXd next = phi_ * x + gamma_ * u;
    if (noisy_) {
      Eigen::VectorXd z(q_factor_.cols());
      for (Eigen::Index i = 0; i < z.size(); ++i) z(i) = rng.Normal();
      next += q_factor_ * z;
    }
    x = next;
  }

 private:
  Eigen::MatrixXd phi_, gamma_, q_factor_, steady_;
  bool noisy_ = false;
};

// A Butterworth low-pass of even order as a cascade of second-order sections
//   x1' = x2,  x2' = ωc² (u - x1) - 2 ζ_k ωc x2,  y = x1,   ζ_k = sin((2k - 1) π / (2 N)),
// with unit gain at DC. Order 0 (cut-off <= 0) passes the signal through.
class AntiAliasFilter {
 public:
  AntiAliasFilter(const RecordingOptions& o, double h) : pass_(o.filter_hz <= 0) {
    if (pass_) return;
    const int n = o.filter_order;
    const double wc = 2 * std::numbers::pi * o.filter_hz;
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(n, 1);
    for (int k = 0; k < n / 2; ++k) {
      const double zeta = std::sin((2 * k + 1) * std::numbers::pi / (2 * n));
      const int i = 2 * k;
      A(i, i + 1) = 1;
      A(i + 1, i) = -wc * wc;
      A(i + 1, i + 1) = -2 * zeta * wc;
      if (k == 0) B(i + 1, 0) = wc * wc;
      else A(i + 1, i - 2) = wc * wc;  // input of this section: output of the previous one
    }
    system_ = std::make_unique<FineSystem>(A, B, Eigen::VectorXd::Zero(n), h);
    x_ = Eigen::VectorXd::Zero(n);
  }
  void Reset(double u) {
    if (!pass_) x_ = system_->Steady(Eigen::VectorXd::Constant(1, u));
  }
  // Advances one fine step with input u held; returns the output at the end of the step.
  double Step(double u, NormalRng& rng) {
    if (pass_) return u;
    system_->Step(x_, Eigen::VectorXd::Constant(1, u), rng);
    return x_(x_.size() - 2);
  }
  double Output(double u_if_passing) const { return pass_ ? u_if_passing : x_(x_.size() - 2); }

 private:
  bool pass_;
  std::unique_ptr<FineSystem> system_;
  Eigen::VectorXd x_;
};

bool ValidRecording(const RecordingOptions& r, std::string* why) {
  auto fail = [&](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (!(r.sample_time > 0)) return fail("the sample time must be positive");
  if (r.oversample < 1 || r.oversample > 1000) return fail("oversample must be 1..1000");
  if (r.filter_hz > 0 && (r.filter_order < 2 || r.filter_order > 8 || r.filter_order % 2))
    return fail("the filter order must be even, 2..8");
  if (r.filter_hz > 0 && r.filter_hz * r.sample_time > 0.25 * r.oversample)
    return fail("the filter cut-off must lie below a quarter of the fine grid's rate");
  return true;
}

// Time of fine step i (negative during the warm-up).
double FineTime(long i, int warmup_samples, const RecordingOptions& r) {
  return (static_cast<double>(i) / r.oversample - warmup_samples) * r.sample_time;
}

double SampleTime(int k, double ts) {
  const double rate = 1.0 / ts;
  return std::abs(rate - std::round(rate)) < 1e-9 * rate ? k / std::round(rate) : k * ts;
}

std::string RecordingText(const RecordingOptions& r) {
  return r.filter_hz > 0
             ? fmt::format("every channel through a {}th-order Butterworth low-pass at {} Hz, "
                           "sampled every {} s (simulated on a {} s grid)",
                           r.filter_order, r.filter_hz, r.sample_time, r.sample_time / r.oversample)
             : fmt::format("no anti-alias filter, sampled every {} s", r.sample_time);
}

// A PRBS level at time t >= 0: -1 or +1.
struct PrbsSignal {
  std::vector<std::uint8_t> bits;
  double bit_period;
  double At(double t) const {
    const auto i = static_cast<std::size_t>(std::floor(t / bit_period + 1e-9));
    return bits[std::min(i, bits.size() - 1)] ? 1.0 : -1.0;
  }
};

PrbsSignal MakeSignal(int order, double bit_period, double duration, std::uint32_t seed) {
  const auto n = static_cast<std::size_t>(std::ceil(duration / bit_period)) + 2;
  return {design::PrbsBits(order, seed, n), bit_period};
}

}  // namespace

// ---- 3. fuel experiment ----------------------------------------------------------------------

bool FuelExperiment::IsValid(std::string* why) const {
  auto fail = [&](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (!ValidRecording(recording, why)) return false;
  const auto& p = point;
  if (!(p.tau_fv > 0 && p.tau_ff > 0 && p.Kb > 0 && p.X >= 0 && p.X <= 1 && p.delay_s >= 0 &&
        p.s11 >= 0 && p.s12 >= 0 && p.s2 >= 0))
    return fail("the operating point needs τ_fv, τ_ff, K_b > 0, 0 <= X <= 1 and variances >= 0");
  if (prbs_order < design::kMinPrbsOrder || prbs_order > design::kMaxPrbsOrder)
    return fail(fmt::format("the PRBS order must be {}..{}", design::kMinPrbsOrder,
                            design::kMaxPrbsOrder));
  if (!(bit_period >= recording.sample_time)) return fail("the bit period must be >= the sample time");
  if (!(duration > 0) || duration / recording.sample_time > 1e7)
    return fail("the duration must be positive and give at most 10 million samples");
  if (!(amplitude > 0 && amplitude < 1)) return fail("the amplitude must be a fraction in (0, 1)");
  return true;
}

Result<Record> RunFuelExperiment(const FuelExperiment& e) {
  std::string why;
  if (!e.IsValid(&why)) return InputError("fuel experiment: " + why);
  const FuelOperatingPoint& p = e.point;
  const RecordingOptions& r = e.recording;
  const double h = r.sample_time / r.oversample;
  const double bias = 1.0 / p.Kb;
  NormalRng rng(e.seed);

  Eigen::MatrixXd A(2, 2), B(2, 1);
  A << -1 / p.tau_fv, 0, 0, -1 / p.tau_ff;
  B << (1 - p.X) / p.tau_fv, p.X / p.tau_ff;
  Eigen::VectorXd sigma2(2);
  sigma2 << p.s11, p.s12;
  const FineSystem film(A, B, sigma2, h);
  AntiAliasFilter filter_u(r, h), filter_y(r, h);

  // Warm-up at the bias so that noise and filters are in their stationary state at t = 0.
  const int warmup_samples = static_cast<int>(std::ceil(std::max(2.0, 10 * p.tau_ff) / r.sample_time));
  const int n_samples = static_cast<int>(std::ceil(e.duration / r.sample_time - 1e-9));
  const long delay_steps = std::lround(p.delay_s / h);
  const long n_fine = static_cast<long>(warmup_samples + n_samples) * r.oversample;
  const PrbsSignal prbs = MakeSignal(e.prbs_order, e.bit_period, e.duration,
                                     static_cast<std::uint32_t>(e.seed));

  Eigen::VectorXd x = film.Steady(Eigen::VectorXd::Constant(1, bias));
  filter_u.Reset(bias);
  filter_y.Reset(p.Kb * x.sum());
  // 1/λ at the port on the fine grid; the sensor at step i reads step i - delay_steps.
  std::vector<double> port(static_cast<std::size_t>(n_fine) + 1);
  port[0] = p.Kb * x.sum();
  Record rec;
  rec.names = {"t", "mfi", "ilambda"};
  rec.columns.assign(3, {});
  for (auto& c : rec.columns) c.reserve(n_samples);
  for (long i = 0; i < n_fine; ++i) {
    const double t = FineTime(i, warmup_samples, r);
    const double mfi = t < 0 ? bias : bias * (1 + e.amplitude * prbs.At(t));
    const double sensor = port[std::max(0L, i - delay_steps)];
    // A sample at t_k records the channels at t_k: the input as applied from t_k on.
    if (i % r.oversample == 0 && i / r.oversample >= warmup_samples) {
      rec.columns[0].push_back(SampleTime(static_cast<int>(i / r.oversample - warmup_samples),
                                          r.sample_time));
      rec.columns[1].push_back(filter_u.Output(mfi));
      rec.columns[2].push_back(filter_y.Output(sensor) + std::sqrt(p.s2) * rng.Normal());
    }
    film.Step(x, Eigen::VectorXd::Constant(1, mfi), rng);
    port[i + 1] = p.Kb * x.sum();
    filter_u.Step(mfi, rng);
    filter_y.Step(sensor, rng);
  }
  rec.comments = {
      fmt::format("greybench virtual dyno: fuel experiment at operating point {} (SIMULATED, not "
                  "measured)", p.name),
      fmt::format("operating point: n = {} rpm, alpha = {} deg", p.speed_rpm, p.throttle_deg),
      fmt::format("truth: tau_fv = {} s, tau_ff = {} s, X = {}, Kb = {} s/g, s11 = {}, s12 = {}, "
                  "s2 = {}, delay = {} s ({} samples)",
                  p.tau_fv, p.tau_ff, p.X, p.Kb, p.s11, p.s12, p.s2, p.delay_s,
                  p.delay_s / r.sample_time),
      fmt::format("input: fuel bias {:.6g} g/s (= 1/Kb) +/- {} % PRBS of order {}, bit period {} s, "
                  "seed {}", bias, 100 * e.amplitude, e.prbs_order, e.bit_period, e.seed),
      "recording: " + RecordingText(r),
      fmt::format("greybench: {{\"operating_point\": {{\"name\": \"{}\", \"n_rpm\": {}, "
                  "\"alpha_deg\": {}}}}}", p.name, p.speed_rpm, p.throttle_deg)};
  return rec;
}

// ---- 4. crankshaft ---------------------------------------------------------------------------

bool CrankshaftExperiment::IsValid(std::string* why) const {
  auto fail = [&](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (!ValidRecording(recording, why)) return false;
  const auto& p = point;
  if (!(p.tau_f > 0 && p.Je > 0 && p.Gp > 0 && p.s1 >= 0 && p.s21 >= 0 && p.s22 >= 0))
    return fail("the crankshaft needs τ_f, J_e, G_p > 0 and variances >= 0");
  if (prbs_order < design::kMinPrbsOrder || prbs_order > design::kMaxPrbsOrder)
    return fail("the PRBS order is out of range");
  if (!(duration > 0) || duration / recording.sample_time > 1e7)
    return fail("the duration must be positive and give at most 10 million samples");
  return true;
}

Result<Record> RunCrankshaftExperiment(const CrankshaftExperiment& e) {
  std::string why;
  if (!e.IsValid(&why)) return InputError("crankshaft experiment: " + why);
  const CrankshaftPoint& p = e.point;
  const RecordingOptions& r = e.recording;
  const double h = r.sample_time / r.oversample;
  NormalRng rng(e.seed);
  // dN = (-1/τ_f - G_p K_n/J_e) N dt + (G_p K_θ/J_e) θ dt - (1/J_e) T_l dt + σ1 dω (deviations).
  Eigen::MatrixXd A(1, 1), B(1, 2);
  A << -1 / p.tau_f - p.Gp * p.Kn / p.Je;
  B << p.Gp * p.Ktheta / p.Je, -1 / p.Je;
  const FineSystem shaft(A, B, Eigen::VectorXd::Constant(1, p.s1), h);
  AntiAliasFilter f_theta(r, h), f_load(r, h), f_speed(r, h), f_pman(r, h);
  for (auto* f : {&f_theta, &f_load, &f_speed, &f_pman}) f->Reset(0.0);

  const int warmup_samples = static_cast<int>(std::ceil(10 * p.tau_f / r.sample_time));
  const int n_samples = static_cast<int>(std::ceil(e.duration / r.sample_time - 1e-9));
  const long n_fine = static_cast<long>(warmup_samples + n_samples) * r.oversample;
  const PrbsSignal throttle = MakeSignal(e.prbs_order, e.bit_period, e.duration,
                                         static_cast<std::uint32_t>(e.seed));
  const PrbsSignal load = MakeSignal(std::max(design::kMinPrbsOrder, e.prbs_order - 1),
                                     2 * e.bit_period, e.duration,
                                     static_cast<std::uint32_t>(e.seed * 7 + 3));
  Eigen::VectorXd x = Eigen::VectorXd::Zero(1);
  Record rec;
  rec.names = {"t", "theta", "Tl", "N", "Pman"};
  rec.columns.assign(5, {});
  for (long i = 0; i < n_fine; ++i) {
    const double t = FineTime(i, warmup_samples, r);
    const double th = t < 0 ? 0.0 : e.throttle_amplitude * throttle.At(t);
    const double tl = (t < 0 || !e.perturb_load) ? 0.0 : e.load_amplitude * load.At(t);
    const double pman = -p.Kn * x(0) + p.Ktheta * th;
    if (i % r.oversample == 0 && i / r.oversample >= warmup_samples) {
      rec.columns[0].push_back(SampleTime(static_cast<int>(i / r.oversample - warmup_samples),
                                          r.sample_time));
      rec.columns[1].push_back(f_theta.Output(th));
      rec.columns[2].push_back(f_load.Output(tl));
      rec.columns[3].push_back(f_speed.Output(x(0)) + std::sqrt(p.s21) * rng.Normal());
      rec.columns[4].push_back(f_pman.Output(pman) + std::sqrt(p.s22) * rng.Normal());
    }
    f_theta.Step(th, rng);
    f_load.Step(tl, rng);
    f_speed.Step(x(0), rng);
    f_pman.Step(pman, rng);
    shaft.Step(x, (Eigen::VectorXd(2) << th, tl).finished(), rng);
  }
  rec.comments = {
      "greybench virtual dyno: crankshaft experiment, eq. 15-16 (SIMULATED, not measured)",
      fmt::format("truth: tau_f = {} s, Je = {}, Gp = {}, Kn = {}, Ktheta = {}, s1 = {}, s21 = {}, "
                  "s22 = {}", p.tau_f, p.Je, p.Gp, p.Kn, p.Ktheta, p.s1, p.s21, p.s22),
      fmt::format("inputs (deviations from the bias): throttle +/- {} deg PRBS order {}, bit {} s; "
                  "load {}", e.throttle_amplitude, e.prbs_order, e.bit_period,
                  e.perturb_load ? fmt::format("+/- {} N m PRBS, bit {} s", e.load_amplitude,
                                               2 * e.bit_period)
                                 : std::string("held constant")),
      "recording: " + RecordingText(r)};
  return rec;
}

// ---- 5. square wave --------------------------------------------------------------------------

Result<Record> RunSquareWaveTest(const SquareWaveTest& e) {
  std::string why;
  if (!ValidRecording(e.recording, &why)) return InputError("square-wave test: " + why);
  if (!(e.tau_ff > 0 && e.Kb > 0 && e.X >= 0 && e.X <= 1 && e.period > 0 && e.duration > 0))
    return InputError("square-wave test: needs τ_ff, K_b, period, duration > 0 and 0 <= X <= 1");
  const RecordingOptions& r = e.recording;
  const double h = r.sample_time / r.oversample;
  const double bias = 1.0 / e.Kb;
  const double delay = ExhaustDelay(e.speed_rpm);
  NormalRng rng(e.seed);
  Eigen::MatrixXd A(1, 1), B(1, 1);
  A << -1 / e.tau_ff;
  B << e.X / e.tau_ff;
  const FineSystem film(A, B, Eigen::VectorXd::Constant(1, e.s12), h);
  AntiAliasFilter filter_u(r, h), filter_y(r, h);
  const double low = bias * (1 - e.amplitude), high = bias * (1 + e.amplitude);
  auto level = [&](double t) {
    if (t < 0) return low;
    const double phase = t / e.period - std::floor(t / e.period + 1e-9);
    return phase < 0.5 - 1e-9 ? low : high;
  };
  Eigen::VectorXd x = film.Steady(Eigen::VectorXd::Constant(1, low));
  const double y0 = e.Kb * ((1 - e.X) * low + x(0));
  filter_u.Reset(low);
  filter_y.Reset(y0);
  const long delay_steps = std::lround(delay / h);
  const int warmup_samples = static_cast<int>(std::ceil(10 * e.tau_ff / r.sample_time));
  const int n_samples = static_cast<int>(std::ceil(e.duration / r.sample_time - 1e-9));
  const long n_fine = static_cast<long>(warmup_samples + n_samples) * r.oversample;
  std::vector<double> port(static_cast<std::size_t>(n_fine) + 1, y0);
  Record rec;
  rec.names = {"t", "mfi", "ilambda"};
  rec.columns.assign(3, {});
  for (long i = 0; i < n_fine; ++i) {
    const double t = FineTime(i, warmup_samples, r);
    const double mfi = level(t);
    port[i] = e.Kb * ((1 - e.X) * mfi + x(0));  // the vapour path is instantaneous
    const double sensor = port[std::max(0L, i - delay_steps)];
    if (i % r.oversample == 0 && i / r.oversample >= warmup_samples) {
      rec.columns[0].push_back(SampleTime(static_cast<int>(i / r.oversample - warmup_samples),
                                          r.sample_time));
      rec.columns[1].push_back(filter_u.Output(mfi));
      rec.columns[2].push_back(filter_y.Output(sensor) + std::sqrt(e.s2) * rng.Normal());
    }
    film.Step(x, Eigen::VectorXd::Constant(1, mfi), rng);
    filter_u.Step(mfi, rng);
    filter_y.Step(sensor, rng);
  }
  rec.comments = {
      "greybench virtual dyno: square-wave step test of Fig. 2 (SIMULATED, not measured)",
      fmt::format("operating point: n = {} rpm, alpha = {} deg; instantaneous vapour path", e.speed_rpm,
                  e.throttle_deg),
      fmt::format("truth: tau_ff = {} s, X = {}, Kb = {} s/g, s12 = {}, s2 = {}, delay = {:.4f} s "
                  "(from the delay-speed relation of Fig. 3)", e.tau_ff, e.X, e.Kb, e.s12, e.s2, delay),
      fmt::format("input: fuel {:.6g} g/s +/- {} % square wave, period {} s", bias,
                  100 * e.amplitude, e.period),
      "recording: " + RecordingText(r)};
  return rec;
}

}  // namespace gb::sim
