// Sections: 1. Table 2 and the delay relation  2. fuel experiment  3. crankshaft  4. square wave
// The fuel and crankshaft records are the live dynos (live_dyno.h) run for their duration; the
// fine grid's pieces they share with the square wave are in internal.h.
#include "core/sim/dyno.h"

#include <cmath>

#include <Eigen/Core>
#include <fmt/format.h>

#include "core/sim/internal.h"
#include "core/sim/live_dyno.h"
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

// ---- 2. fuel experiment ----------------------------------------------------------------------

bool FuelExperiment::IsValid(std::string* why) const {
  return internal::ValidFuelSetup(*this, why) && internal::ValidDuration(duration, recording, why);
}

std::vector<std::string> FuelExperimentComments(const FuelExperiment& e) {
  const FuelOperatingPoint& p = e.point;
  const RecordingOptions& r = e.recording;
  return {
      fmt::format("greybench virtual dyno: fuel experiment at operating point {} (SIMULATED, not "
                  "measured)",
                  p.name),
      fmt::format("operating point: n = {} rpm, alpha = {} deg", p.speed_rpm, p.throttle_deg),
      fmt::format("truth: tau_fv = {} s, tau_ff = {} s, X = {}, Kb = {} s/g, s11 = {}, s12 = {}, "
                  "s2 = {}, delay = {} s ({} samples)",
                  p.tau_fv, p.tau_ff, p.X, p.Kb, p.s11, p.s12, p.s2, p.delay_s,
                  p.delay_s / r.sample_time),
      fmt::format(
          "input: fuel bias {:.6g} g/s (= 1/Kb) +/- {} % PRBS of order {}, bit period {} s, "
          "seed {}",
          1.0 / p.Kb, 100 * e.amplitude, e.prbs_order, e.bit_period, e.seed),
      "recording: " + internal::RecordingText(r),
      fmt::format("greybench: {{\"operating_point\": {{\"name\": \"{}\", \"n_rpm\": {}, "
                  "\"alpha_deg\": {}}}}}",
                  p.name, p.speed_rpm, p.throttle_deg)};
}

Result<Record> RunFuelExperiment(const FuelExperiment& e) {
  std::string why;
  if (!e.IsValid(&why)) return InputError("fuel experiment: " + why);
  auto dyno = LiveFuelDyno::Create(e);
  if (!dyno) return dyno.error();
  const int n_samples = internal::SampleCount(e.duration, e.recording);
  Record rec;
  rec.names = {"t", "mfi", "ilambda"};
  rec.columns.assign(3, {});
  for (auto& c : rec.columns) c.reserve(n_samples);
  for (int k = 0; k < n_samples; ++k) {
    const FuelSample s = dyno->Next();
    rec.columns[0].push_back(s.t);
    rec.columns[1].push_back(s.mfi);
    rec.columns[2].push_back(s.ilambda);
  }
  rec.comments = FuelExperimentComments(e);
  if (auto st = internal::CheckFinite(rec, "fuel experiment"); !st) return st.error();
  return rec;
}

// ---- 3. crankshaft ---------------------------------------------------------------------------

bool CrankshaftExperiment::IsValid(std::string* why) const {
  return internal::ValidCrankshaftSetup(*this, why) &&
         internal::ValidDuration(duration, recording, why);
}

Result<Record> RunCrankshaftExperiment(const CrankshaftExperiment& e) {
  std::string why;
  if (!e.IsValid(&why)) return InputError("crankshaft experiment: " + why);
  auto dyno = LiveCrankshaftDyno::Create(e);
  if (!dyno) return dyno.error();
  const int n_samples = internal::SampleCount(e.duration, e.recording);
  Record rec;
  rec.names = {"t", "theta", "Tl", "N", "Pman"};
  rec.columns.assign(5, {});
  for (int k = 0; k < n_samples; ++k) {
    const CrankshaftSample s = dyno->Next();
    for (int c = 0; const double v : {s.t, s.theta, s.Tl, s.N, s.Pman})
      rec.columns[c++].push_back(v);
  }
  const CrankshaftPoint& p = e.point;
  rec.comments = {
      "greybench virtual dyno: crankshaft experiment, eq. 15-16 (SIMULATED, not measured)",
      fmt::format("truth: tau_f = {} s, Je = {}, Gp = {}, Kn = {}, Ktheta = {}, s1 = {}, s21 = {}, "
                  "s22 = {}",
                  p.tau_f, p.Je, p.Gp, p.Kn, p.Ktheta, p.s1, p.s21, p.s22),
      fmt::format("inputs (deviations from the bias): throttle +/- {} deg PRBS order {}, bit {} s; "
                  "load {}",
                  e.throttle_amplitude, e.prbs_order, e.bit_period,
                  e.perturb_load
                      ? fmt::format("+/- {} N m PRBS, bit {} s", e.load_amplitude, 2 * e.bit_period)
                      : std::string("held constant")),
      "recording: " + internal::RecordingText(e.recording)};
  if (auto st = internal::CheckFinite(rec, "crankshaft experiment"); !st) return st.error();
  return rec;
}

// ---- 4. square wave --------------------------------------------------------------------------

Result<Record> RunSquareWaveTest(const SquareWaveTest& e) {
  std::string why;
  if (!internal::ValidRecording(e.recording, &why) ||
      !internal::ValidDuration(e.duration, e.recording, &why))
    return InputError("square-wave test: " + why);
  if (!(e.tau_ff > 0 && e.Kb > 0 && e.X >= 0 && e.X <= 1 && e.period > 0 &&
        std::isfinite(e.tau_ff + e.Kb + e.period)))
    return InputError("square-wave test: needs finite τ_ff, K_b, period > 0 and 0 <= X <= 1");
  const RecordingOptions& r = e.recording;
  const double h = r.sample_time / r.oversample;
  const double bias = 1.0 / e.Kb;
  const double delay = ExhaustDelay(e.speed_rpm);
  NormalRng rng(e.seed);
  Eigen::MatrixXd A(1, 1), B(1, 1);
  A << -1 / e.tau_ff;
  B << e.X / e.tau_ff;
  const internal::FineSystem film(A, B, Eigen::VectorXd::Constant(1, e.s12), h);
  internal::AntiAliasFilter filter_u(r, h), filter_y(r, h);
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
  const int n_samples = internal::SampleCount(e.duration, r);
  const long n_fine = static_cast<long>(warmup_samples + n_samples) * r.oversample;
  // The port's 1/λ over the last delay_steps + 1 fine steps (fine step i in port[i % size]).
  std::vector<double> port(static_cast<std::size_t>(delay_steps) + 1, y0);
  const auto slot = [&](long i) { return static_cast<std::size_t>(i) % port.size(); };
  Record rec;
  rec.names = {"t", "mfi", "ilambda"};
  rec.columns.assign(3, {});
  for (long i = 0; i < n_fine; ++i) {
    const double t = internal::FineTime(i, warmup_samples, r);
    const double mfi = level(t);
    port[slot(i)] = e.Kb * ((1 - e.X) * mfi + x(0));  // the vapour path is instantaneous
    const double sensor = port[slot(std::max(0L, i - delay_steps))];
    if (i % r.oversample == 0 && i / r.oversample >= warmup_samples) {
      rec.columns[0].push_back(
          internal::SampleTime(static_cast<int>(i / r.oversample - warmup_samples), r.sample_time));
      rec.columns[1].push_back(filter_u.Output(mfi));
      rec.columns[2].push_back(filter_y.Output(sensor) + std::sqrt(e.s2) * rng.Normal());
    }
    film.Step(x, Eigen::VectorXd::Constant(1, mfi), rng);
    filter_u.Step(mfi, rng);
    filter_y.Step(sensor, rng);
  }
  rec.comments = {
      "greybench virtual dyno: square-wave step test of Fig. 2 (SIMULATED, not measured)",
      fmt::format("operating point: n = {} rpm, alpha = {} deg; instantaneous vapour path",
                  e.speed_rpm, e.throttle_deg),
      fmt::format("truth: tau_ff = {} s, X = {}, Kb = {} s/g, s12 = {}, s2 = {}, delay = {:.4f} s "
                  "(from the delay-speed relation of Fig. 3)",
                  e.tau_ff, e.X, e.Kb, e.s12, e.s2, delay),
      fmt::format("input: fuel {:.6g} g/s +/- {} % square wave, period {} s", bias,
                  100 * e.amplitude, e.period),
      "recording: " + internal::RecordingText(r)};
  if (auto st = internal::CheckFinite(rec, "square-wave test"); !st) return st.error();
  return rec;
}

}  // namespace gb::sim
