// Sections: 1. the model's functions  2. steady states and points  3. the experiment
#include "core/sim/engine.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "core/sim/internal.h"
#include "core/sim/random.h"

namespace gb::sim {

// ---- 1. the model's functions -----------------------------------------------------------------

namespace {

using C = EngineConstants;

constexpr double kDegree = std::numbers::pi / 180;

// The speed controller of EngineExperiment::hold_speed: N m per rpm, and per rpm s. With J_e =
// 0.08 N m s/rpm the closed loop's poles are near -10 and -2.5 rad/s.
constexpr double kSpeedP = 1.0;
constexpr double kSpeedI = 2.0;

// ψ(r) = sqrt(r^(2/κ) - r^((κ+1)/κ)) at max(r, r_c).
double Psi(double r) {
  const double rc = std::pow(2 / (C::kKappa + 1), C::kKappa / (C::kKappa - 1));
  r = std::max(r, rc);
  return std::sqrt(std::pow(r, 2 / C::kKappa) - std::pow(r, (C::kKappa + 1) / C::kKappa));
}

double CriticalPsi() {
  static const double kPsi = Psi(0);
  return kPsi;
}

}  // namespace

std::vector<std::pair<std::string, double>> EngineTruth::Named() const {
  return {{"Cth", Cth}, {"ev", ev}, {"Vi", Vi},         {"Je", Je},         {"eta", eta},
          {"f0", f0},   {"f1", f1}, {"tau_fv", tau_fv}, {"tau_ff", tau_ff}, {"X60", X60},
          {"dX", dX},   {"cd", cd}, {"sp", sp},         {"sn", sn},         {"sfv", sfv},
          {"sff", sff}, {"rp", rp}, {"rn", rn},         {"rl", rl}};
}

double ThrottleFlow(const EngineTruth& e, double alpha_deg, double p) {
  const double r = std::clamp(p / C::kAmbientKPa, 0.0, 1.0);
  return e.Cth * (1 - std::cos(alpha_deg * kDegree)) * Psi(r) / CriticalPsi();
}

double PortAirFlow(const EngineTruth& e, double p, double n) {
  return e.ev * C::kDisplacementL * n * p / (120 * C::kRT);
}

EngineState EngineDrift(const EngineTruth& e, const EngineState& x, const EngineInput& u) {
  const double map = PortAirFlow(e, x.p, x.n);
  const double X = e.X60 + e.dX * (x.p - 60) / 10;
  const double omega = std::numbers::pi * x.n / 30;
  const double torque = e.eta * C::kHeatingValue * (x.mfv + x.mff) / omega;
  const double friction = e.f0 + e.f1 * x.n / 1000;
  const double pumping = C::kDisplacementL * (C::kAmbientKPa - x.p) / (4 * std::numbers::pi);
  EngineState d;
  d.p = C::kRT / e.Vi * (ThrottleFlow(e, u.alpha, x.p) - map);
  d.n = (torque - friction - pumping - u.Tl) / e.Je;
  d.mfv = ((1 - X) * u.mfi - x.mfv) / e.tau_fv;
  d.mff = (X * u.mfi - x.mff) / e.tau_ff;
  return d;
}

double PortInverseLambda(const EngineTruth& e, const EngineState& x) {
  return C::kStoichiometric * (x.mfv + x.mff) / PortAirFlow(e, x.p, x.n);
}

// ---- 2. steady states and points --------------------------------------------------------------

Result<EngineSteady> EngineSteadyState(const EngineTruth& e, double n_rpm, double alpha_deg) {
  if (!(n_rpm >= 300 && n_rpm <= 10000))
    return InputError(fmt::format("the speed must be 300..10000 rpm, not {}", n_rpm));
  if (!(alpha_deg > 0 && alpha_deg <= 90))
    return InputError(fmt::format("the throttle angle must be in (0, 90] deg, not {}", alpha_deg));
  // m_at - m_ap falls with p from m_at(0) > 0 to -m_ap(p_a) < 0: bisection finds its root.
  double lo = 0, hi = C::kAmbientKPa;
  for (int it = 0; it < 200 && hi - lo > 1e-13 * C::kAmbientKPa; ++it) {
    const double mid = 0.5 * (lo + hi);
    (ThrottleFlow(e, alpha_deg, mid) - PortAirFlow(e, mid, n_rpm) > 0 ? lo : hi) = mid;
  }
  EngineSteady s;
  s.x.p = 0.5 * (lo + hi);
  s.x.n = n_rpm;
  s.u.alpha = alpha_deg;
  s.u.mfi = PortAirFlow(e, s.x.p, n_rpm) / C::kStoichiometric;
  const double X = e.X60 + e.dX * (s.x.p - 60) / 10;
  if (!(X >= 0 && X <= 1))
    return InputError(fmt::format("the film fraction X is {} at {} rpm, {} deg (outside 0..1)", X,
                                  n_rpm, alpha_deg));
  s.x.mfv = (1 - X) * s.u.mfi;
  s.x.mff = X * s.u.mfi;
  // The load that balances the torques: the drift of n with T_l = 0, times J_e.
  s.u.Tl = EngineDrift(e, s.x, s.u).n * e.Je;
  if (!(s.u.Tl > 0))
    return InputError(fmt::format(
        "the engine makes no net torque at {} rpm, {} deg (it would need a load of {:.3g} N m)",
        n_rpm, alpha_deg, s.u.Tl));
  return s;
}

std::vector<EnginePoint> PaperEnginePoints() {
  std::vector<EnginePoint> points;
  for (const auto& f : PaperFuelPoints()) points.push_back({f.name, f.speed_rpm, f.throttle_deg});
  return points;
}

Result<EnginePoint> ParseEnginePoint(const std::string& text) {
  for (const auto& p : PaperEnginePoints())
    if (p.name == text) return p;
  EnginePoint p;
  bool has_n = false, has_alpha = false;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    const std::size_t eq = item.find('=');
    double v = 0;
    std::size_t used = 0;
    bool number = false;
    if (eq != std::string::npos) {
      try {
        v = std::stod(item.substr(eq + 1), &used);
        number = used == item.size() - eq - 1 && std::isfinite(v);
      } catch (const std::exception&) {
        number = false;
      }
    }
    const std::string key = eq == std::string::npos ? item : item.substr(0, eq);
    if (!number || (key != "n" && key != "alpha"))
      return InputError(
          fmt::format("operating point '{}': expected a Table 2 point (f1 f2 f3 f4 f7 f8) or "
                      "n=RPM,alpha=DEG; '{}' is not one of those",
                      text, item));
    if (key == "n" ? has_n : has_alpha)
      return InputError(fmt::format("operating point '{}': {} is given twice", text, key));
    (key == "n" ? p.speed_rpm : p.throttle_deg) = v;
    (key == "n" ? has_n : has_alpha) = true;
    start = comma + 1;
  }
  if (!has_n || !has_alpha)
    return InputError(fmt::format("operating point '{}': give both n (rpm) and alpha (deg)", text));
  p.name = fmt::format("n{:g}_a{:g}", p.speed_rpm, p.throttle_deg);
  return p;
}

// ---- 3. the experiment ------------------------------------------------------------------------

bool EngineExperiment::IsValid(std::string* why) const {
  auto fail = [&](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (!internal::ValidRecording(recording, why)) return false;
  if (!(recording.sample_time / recording.oversample <= kMaxEngineStep))
    return fail(
        fmt::format("the simulated world's step, the sample time {} s / oversample {}, "
                    "must be at most {} s for the engine (oversample at least {:.0f})",
                    recording.sample_time, recording.oversample, kMaxEngineStep,
                    std::ceil(recording.sample_time / kMaxEngineStep - 1e-9)));
  if (!internal::ValidDuration(duration, recording, why)) return false;
  if (path.empty()) return fail("the experiment needs at least one operating point");
  if (path.size() > 1 && !(hold_s >= 0 && ramp_s > 0 && std::isfinite(hold_s + ramp_s)))
    return fail("a sweep needs a hold >= 0 s and a ramp > 0 s");
  if (!(fuel_amplitude >= 0 && fuel_amplitude < 1))
    return fail("the fuel amplitude must be a fraction in [0, 1)");
  if (!(throttle_amplitude >= 0 && throttle_amplitude <= 10))
    return fail("the throttle amplitude must be 0..10 deg");
  for (int order : {fuel_order, throttle_order})
    if (order < design::kMinPrbsOrder || order > design::kMaxPrbsOrder)
      return fail(fmt::format("the PRBS orders must be {}..{}", design::kMinPrbsOrder,
                              design::kMaxPrbsOrder));
  if (!(fuel_bit >= recording.sample_time && throttle_bit >= recording.sample_time))
    return fail("the bit periods must be >= the sample time");
  const EngineTruth& t = truth;
  if (!(t.Cth > 0 && t.ev > 0 && t.Vi > 0 && t.Je > 0 && t.eta > 0 && t.tau_fv > 0 &&
        t.tau_ff > 0 && t.cd >= 0 && t.sp >= 0 && t.sn >= 0 && t.sfv >= 0 && t.sff >= 0 &&
        t.rp >= 0 && t.rn >= 0 && t.rl >= 0))
    return fail("the engine's values must be positive (the noise and c_d >= 0)");
  for (const auto& p : path) {
    auto s = EngineSteadyState(truth, p.speed_rpm, p.throttle_deg);
    if (!s) return fail(fmt::format("operating point {}: {}", p.name, s.error().message));
  }
  return true;
}

namespace {

// The operating point the dyno holds at time t >= 0: along the path, `hold` at each point and
// `ramp` to the next; after the last point it stays there.
struct PathPosition {
  std::size_t from = 0;
  double fraction = 0;  // 0: at `from`; in (0, 1): on the ramp to from + 1
};

PathPosition PositionAt(const EngineExperiment& e, double t) {
  if (e.path.size() == 1 || t <= 0) return {};
  const double leg = e.hold_s + e.ramp_s;
  const double legs = std::floor(t / leg);  // compared before the cast: a tiny leg gives 1e300
  if (!(legs + 1 < static_cast<double>(e.path.size()))) return {e.path.size() - 1, 0};
  const auto i = static_cast<std::size_t>(legs);
  const double into = t - static_cast<double>(i) * leg;
  return {i, into <= e.hold_s ? 0 : (into - e.hold_s) / e.ramp_s};
}

std::string PathText(const EngineExperiment& e) {
  std::string text;
  for (const auto& p : e.path)
    text += fmt::format("{}{} ({} rpm, {} deg)", text.empty() ? "" : " -> ", p.name, p.speed_rpm,
                        p.throttle_deg);
  return text;
}

std::vector<std::string> EngineComments(const EngineExperiment& e) {
  std::string truth;
  for (const auto& [name, value] : e.truth.Named())
    truth += fmt::format("{}{} = {}", truth.empty() ? "" : ", ", name, value);
  std::vector<std::string> c = {
      "greybench virtual dyno: the nonlinear mean-value engine (SIMULATED, not measured)",
      "path: " + PathText(e) +
          (e.path.size() > 1 ? fmt::format(", {} s at each point, {} s ramps", e.hold_s, e.ramp_s)
                             : ""),
      "truth: " + truth,
      fmt::format("inputs: throttle +/- {} deg PRBS of order {}, bit period {} s; fuel of lambda "
                  "= 1 +/- {} % PRBS of order {}, bit period {} s; {}; seed {}",
                  e.throttle_amplitude, e.throttle_order, e.throttle_bit, 100 * e.fuel_amplitude,
                  e.fuel_order, e.fuel_bit,
                  e.hold_speed ? "the dyno holds the speed (PI on the load)"
                               : "the dyno holds the load of the steady state",
                  e.seed),
      "recording: " + internal::RecordingText(e.recording)};
  if (e.sensor_delay == EngineExperiment::SensorDelay::kPade)
    c.push_back(
        "lambda sensor: the [3/3] Pade approximant of the transport delay c_d / n (the "
        "models' sensor), not an exact delay");
  if (e.path.size() == 1)
    c.push_back(
        fmt::format("greybench: {{\"operating_point\": {{\"name\": \"{}\", \"n_rpm\": {}, "
                    "\"alpha_deg\": {}}}}}",
                    e.path[0].name, e.path[0].speed_rpm, e.path[0].throttle_deg));
  return c;
}

// The λ sensor as the models' [3/3] Padé approximant of the delay D:
//   z1 = v / den(sD), z2 = z1', z3 = z1'',  y = 2 z1 - v + D²/5 z3,
//   den(x) = 1 + x/2 + x²/10 + x³/120,
// the realisation of engine_mvem.json. A step of h runs RK4 with v linear from v0 to v1 and D
// held, in substeps of at most 0.05 / |λ|max (den's roots have |x| <= 5.1 / D): at 80 Hz with a
// single step per sample the sensor's value is within 1e-8 of the exact solution (engine_test).
class PadeSensor {
 public:
  explicit PadeSensor(double v) : z_{v, 0, 0} {}

  double Output(double v, double D) const {
    return D > kNoDelay ? 2 * z_[0] - v + D * D / 5 * z_[2] : v;
  }

  void Step(double v0, double v1, double D, double h) {
    if (D <= kNoDelay) {
      z_ = {v1, 0, 0};
      return;
    }
    const double c = 120 / (D * D * D);
    auto f = [&](const std::array<double, 3>& z, double v) {
      return std::array<double, 3>{z[1], z[2], c * (v - z[0] - D / 2 * z[1] - D * D / 10 * z[2])};
    };
    const int m = std::max(1, static_cast<int>(std::ceil(5.1 * h / D / 0.05)));
    const double dt = h / m;
    for (int j = 0; j < m; ++j) {
      const double va = v0 + (v1 - v0) * j / m;
      const double vm = v0 + (v1 - v0) * (j + 0.5) / m;
      const double vb = v0 + (v1 - v0) * (j + 1.0) / m;
      const auto k1 = f(z_, va);
      const auto k2 = f(Plus(z_, k1, dt / 2), vm);
      const auto k3 = f(Plus(z_, k2, dt / 2), vm);
      const auto k4 = f(Plus(z_, k3, dt), vb);
      for (int q = 0; q < 3; ++q) z_[q] += dt / 6 * (k1[q] + 2 * k2[q] + 2 * k3[q] + k4[q]);
    }
  }

 private:
  static constexpr double kNoDelay = 1e-9;  // s: below it the sensor shows the port's value
  static std::array<double, 3> Plus(const std::array<double, 3>& z, const std::array<double, 3>& k,
                                    double a) {
    return {z[0] + a * k[0], z[1] + a * k[1], z[2] + a * k[2]};
  }
  std::array<double, 3> z_;
};

}  // namespace

Result<Record> RunEngineExperiment(const EngineExperiment& e) {
  std::string why;
  if (!e.IsValid(&why)) return InputError("engine experiment: " + why);
  const EngineTruth& truth = e.truth;
  const RecordingOptions& r = e.recording;
  const double h = r.sample_time / r.oversample;
  const double sqrt_h = std::sqrt(h);

  // The steady state of every point, and the target between them.
  std::vector<EngineSteady> steady;
  for (const auto& p : e.path)
    steady.push_back(*EngineSteadyState(truth, p.speed_rpm, p.throttle_deg));
  auto target = [&](double t) {
    const PathPosition at = PositionAt(e, t);
    if (at.fraction == 0) return steady[at.from];
    const EnginePoint& a = e.path[at.from];
    const EnginePoint& b = e.path[at.from + 1];
    const double n = a.speed_rpm + at.fraction * (b.speed_rpm - a.speed_rpm);
    const double alpha = a.throttle_deg + at.fraction * (b.throttle_deg - a.throttle_deg);
    auto s = EngineSteadyState(truth, n, alpha);
    // Between two valid points the torque may dip below 0: hold the nearer point's load.
    return s ? *s : steady[at.fraction < 0.5 ? at.from : at.from + 1];
  };

  NormalRng rng(e.seed);
  internal::PrbsLevel fuel_prbs(e.fuel_order, e.fuel_bit, static_cast<std::uint32_t>(e.seed));
  internal::PrbsLevel throttle_prbs(e.throttle_order, e.throttle_bit,
                                    static_cast<std::uint32_t>(e.seed * 7919 + 17));
  std::vector<internal::AntiAliasFilter> filters;
  filters.reserve(6);
  for (int c = 0; c < 6; ++c) filters.emplace_back(r, h);

  // The delay line: the port's 1/λ at every fine step over the longest delay (at 300 rpm) + 1 s.
  const double max_delay = truth.cd / 300 + 1;
  std::vector<double> line(static_cast<std::size_t>(std::ceil(max_delay / h)) + 2);
  auto slot = [&](std::int64_t j) {
    const auto n = static_cast<std::int64_t>(line.size());
    return static_cast<std::size_t>((j % n + n) % n);
  };

  EngineSteady start = steady[0];
  EngineState x = start.x;
  const double v0 = PortInverseLambda(truth, x);
  std::fill(line.begin(), line.end(), v0);
  const bool pade = e.sensor_delay == EngineExperiment::SensorDelay::kPade;
  PadeSensor pade_sensor(v0);
  const double start_values[6] = {start.u.alpha, start.u.mfi, start.u.Tl, x.n, x.p, v0};
  for (int c = 0; c < 6; ++c) filters[c].Reset(start_values[c]);

  // Warm-up at the first point (10 rotational time constants' worth of noise and filters).
  const auto warmup_samples = static_cast<int>(std::ceil(40.0 / r.sample_time));
  const int n_samples = internal::SampleCount(e.duration, r);
  const std::int64_t n_fine = (std::int64_t{warmup_samples} + n_samples) * r.oversample;

  Record rec;
  rec.names = {"t", "alpha", "mfi", "Tl", "N", "Pman", "ilambda"};
  rec.columns.assign(rec.names.size(), {});
  for (auto& c : rec.columns) c.reserve(static_cast<std::size_t>(n_samples));
  const double noise_sd[3] = {std::sqrt(truth.rn), std::sqrt(truth.rp), std::sqrt(truth.rl)};

  EngineSteady now = start;
  double speed_integral = 0;  // ∫ (n - n_target) dt, for hold_speed
  for (std::int64_t i = 0; i < n_fine; ++i) {
    const double t = internal::FineTime(i, warmup_samples, r);
    if (i % r.oversample == 0 && t > 0) now = target(t);  // the target moves at the sample rate
    EngineInput u = now.u;
    if (e.hold_speed) {
      // PI on the speed error: the load rises when the engine runs fast.
      const double error = x.n - now.x.n;
      u.Tl += kSpeedP * error + kSpeedI * speed_integral;
      speed_integral += error * h;
    }
    if (t >= 0) {
      u.alpha += e.throttle_amplitude * throttle_prbs.At(t);
      u.mfi *= 1 + e.fuel_amplitude * fuel_prbs.At(t);
    }
    // The sensor reads the port's value Δt = c_d / n ago, between two fine steps (or through
    // the approximant of that delay).
    const double delay = truth.cd / std::max(x.n, 300.0);
    double sensor = 0;
    if (pade) {
      sensor = pade_sensor.Output(line[slot(i)], delay);
    } else {
      const double lag = std::clamp(delay / h, 0.0, static_cast<double>(line.size() - 2));
      const auto whole = static_cast<std::int64_t>(std::floor(lag));
      const double part = lag - static_cast<double>(whole);
      sensor = (1 - part) * line[slot(i - whole)] + part * line[slot(i - whole - 1)];
    }
    const double channels[6] = {u.alpha, u.mfi, u.Tl, x.n, x.p, sensor};
    if (i % r.oversample == 0 && t >= -1e-9) {
      const std::int64_t k = static_cast<std::int64_t>(rec.columns[0].size());
      rec.columns[0].push_back(internal::SampleTime(k, r.sample_time));
      for (int c = 0; c < 6; ++c) {
        double value = filters[c].Output(channels[c]);
        if (c >= 3) value += noise_sd[c - 3] * rng.Normal();
        rec.columns[c + 1].push_back(value);
      }
    }
    for (int c = 0; c < 6; ++c) filters[c].Step(channels[c], rng);
    const EngineState d = EngineDrift(truth, x, u);
    x.p += d.p * h + truth.sp * sqrt_h * rng.Normal();
    x.n += d.n * h + truth.sn * sqrt_h * rng.Normal();
    x.mfv += d.mfv * h + truth.sfv * sqrt_h * rng.Normal();
    x.mff += d.mff * h + truth.sff * sqrt_h * rng.Normal();
    x.p = std::clamp(x.p, 1e-3, C::kAmbientKPa);
    line[slot(i + 1)] = PortInverseLambda(truth, x);
    if (pade) pade_sensor.Step(line[slot(i)], line[slot(i + 1)], delay, h);
  }
  rec.comments = EngineComments(e);
  if (auto st = internal::CheckFinite(rec, "engine experiment"); !st) return st.error();
  return rec;
}

}  // namespace gb::sim
