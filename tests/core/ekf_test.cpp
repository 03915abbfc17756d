// The extended Kalman filter (core/filter/ekf.h) against independent references:
//   - a linear model through the EKF equals the exact Kalman filter to the ODE tolerance, and
//     converges to it as the tolerance shrinks (zoh and foh, every initial covariance, delays,
//     missing entries, Huber);
//   - a nonlinear model's log-likelihood equals a brute-force EKF written here (classical RK4 on a
//     fine fixed grid, Jacobians by central differences of the drift evaluated as trees);
//   - the compiled Jacobians equal central differences;
//   - a stiff model gives the same likelihood by BDF and by the explicit method;
//   - the iterated EKF's update reaches the MAP of the linearised-prior posterior.
#include "core/filter/ekf.h"

#include <chrono>
#include <cmath>
#include <functional>
#include <random>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "core/expr/expr.h"
#include "core/filter/kalman.h"
#include "core/filter/moments.h"
#include "core/model/linear_model.h"
#include "core/model/nonlinear_model.h"
#include "core/util/json.h"
#include "core/util/sanitizers.h"
#include "tests/core/filter_fixtures.h"

namespace gb::filter {
namespace {

using fixtures::MakeSeries;
using fixtures::RandomSeries;

model::ModelSpec Spec(const char* json_text) {
  auto spec = model::ParseModel(Json::parse(json_text), "test.json");
  EXPECT_TRUE(spec.ok()) << (spec.ok() ? "" : spec.error().ToString());
  return *spec;
}

model::NonlinearModel Nonlinear(model::ModelSpec spec) {
  auto nm = model::NonlinearModel::Compile(std::move(spec));
  EXPECT_TRUE(nm.ok()) << (nm.ok() ? "" : nm.error().ToString());
  return std::move(*nm);
}

double ExactLoglik(const model::ModelSpec& spec, const data::Series& series,
                   const FilterSettings& settings) {
  auto lm = model::LinearModel::Compile(spec);
  EXPECT_TRUE(lm.ok());
  auto ss = lm->Evaluate(spec.Values());
  EXPECT_TRUE(ss.ok());
  auto l = LogLikelihood(*ss, series, settings);
  EXPECT_TRUE(l.ok()) << (l.ok() ? "" : l.error().ToString());
  return l->loglik;
}

double EkfLoglik(const model::ModelSpec& spec, const data::Series& series,
                 const FilterSettings& settings, ode::OdeCounts* counts = nullptr) {
  const model::NonlinearModel nm = Nonlinear(spec);
  auto l = EkfLogLikelihood(nm, spec.Values(), series, settings, nullptr, counts);
  EXPECT_TRUE(l.ok()) << (l.ok() ? "" : l.error().ToString());
  return l.ok() ? l->loglik : NAN;
}

TEST(Ekf, LinearModelEqualsTheExactFilterToTheTolerance) {
  const data::Series series = RandomSeries(400, 2, 0.1, 7);
  struct Case {
    const char* name;
    model::InputHold hold;
    model::InitialCovariance p0;
    std::vector<int> delay;
    std::optional<double> huber;
  };
  const std::vector<Case> cases = {
      {"zoh ctsm", model::InputHold::kZoh, model::InitialCovariance::kCtsm, {}, {}},
      {"foh ctsm", model::InputHold::kFoh, model::InitialCovariance::kCtsm, {}, {}},
      {"zoh stationary", model::InputHold::kZoh, model::InitialCovariance::kStationary, {}, {}},
      {"foh delays 3 and 1, Huber 1.5",
       model::InputHold::kFoh,
       model::InitialCovariance::kCtsm,
       {3, 1},
       1.5},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    model::ModelSpec spec = Spec(fixtures::kTwoOutputModel);
    spec.input_hold = c.hold;
    spec.initial_covariance = c.p0;
    spec.robust_huber = c.huber;
    FilterSettings settings = FilterSettings::FromModel(spec);
    settings.delay = c.delay;
    const double exact = ExactLoglik(spec, series, settings);
    double previous_error = HUGE_VAL;
    for (const double rtol : {1e-6, 1e-8, 1e-10}) {
      spec.ekf.rtol = rtol;
      spec.ekf.atol = rtol * 1e-2;
      const double ekf = EkfLoglik(spec, series, settings);
      const double error = std::abs(ekf - exact) / std::abs(exact);
      if (rtol == 1e-8) {
        EXPECT_LT(error, 1e-6);  // the default tolerances
      }
      EXPECT_LT(error, std::max(100 * rtol, 1e-12));
      EXPECT_LE(error, previous_error * 1.5 + 1e-13);
      previous_error = error;
    }
  }
}

// The stiffness test's bound of the spectral radius against Eigen's eigenvalues: never below ρ,
// on random matrices whose rows and columns are in units 10⁻⁴ to 10⁴ apart (D A D⁻¹), and within
// a small factor of it on the engine model's Padé chain at 5 000 rpm, whose plain row-sum norm
// is 2·10⁴ times ρ. (On a general matrix no norm is near ρ: a nilpotent one has ρ = 0.)
TEST(Ekf, SpectralRadiusBoundIsAboveTheRadiusAndNearIt) {
  auto radius = [](const Eigen::MatrixXd& A) {
    return Eigen::EigenSolver<Eigen::MatrixXd>(A, false).eigenvalues().cwiseAbs().maxCoeff();
  };
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 2 + trial % 7;
    Eigen::MatrixXd A(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) A(i, j) = trial % 3 == 0 && unit(rng) < 0 ? 0.0 : unit(rng);
    Eigen::VectorXd d(n);
    for (int i = 0; i < n; ++i) d(i) = std::pow(10.0, 4.0 * unit(rng));
    A = d.asDiagonal() * A * d.cwiseInverse().asDiagonal();
    Eigen::MatrixXd scaled = A;
    const double bound = SpectralRadiusBound(&scaled);
    // D⁻¹ A D has A's eigenvalues; computed from it they are the more accurate (Eigen's solver
    // does not balance, and A's spread of units costs it up to 10⁻³ relative here).
    const double rho = radius(scaled);
    EXPECT_NEAR(radius(A), rho, 1e-2 * rho);
    EXPECT_GE(bound, rho - 1e-9 * (rho + bound)) << A;
  }
  // z1' = z2, z2' = z3, z3' = 120 / T³ (u - z1 - T z2 / 2 - T² z3 / 10), T = c_d / n.
  const double T = 171.84 / 5000.0;
  Eigen::MatrixXd pade = Eigen::MatrixXd::Zero(3, 3);
  pade(0, 1) = pade(1, 2) = 1.0;
  pade(2, 0) = -120.0 / (T * T * T);
  pade(2, 1) = -60.0 / (T * T);
  pade(2, 2) = -12.0 / T;
  Eigen::MatrixXd scaled = pade;
  const double rho = radius(pade);
  EXPECT_NEAR(rho * T, 5.1, 0.2);  // the [3/3] Padé's poles, |s| T = 4.6 and 5.1
  EXPECT_GT(pade.cwiseAbs().rowwise().sum().maxCoeff(), 1e4 * rho);
  EXPECT_LT(SpectralRadiusBound(&scaled), 5.0 * rho);  // 4.1 ρ
}

// A lightly damped oscillator observed in its position. Its velocity's mean crosses zero, and the
// covariance of position and velocity (d var(x1) / 2 dt) stays near zero, so an error test scaled
// by |z_i| would fall to atol there and its steps would grow as atol shrinks. Scaled by the
// moments' own sizes (sqrt(x̂_i² + P_ii) for a mean, sqrt(P_aa P_bb) for a covariance), the
// steps do not depend on atol once it is far below them (with |z_i| a nonlinear variant of this
// case took 27 % more evaluations at atol 1e-14 than at 1e-8; now 6 %), and log L stays within
// the tolerance of the exact filter's.
TEST(Ekf, ErrorTestMeasuresTheMomentsAgainstTheirOwnSize) {
  model::ModelSpec spec = Spec(R"json({
    "greybench_model": 1,
    "states": ["x1", "x2"], "inputs": ["u1", "u2"], "outputs": ["y"],
    "parameters": {"w": 3.0, "z": 0.05, "s": 0.4, "r": 0.01},
    "drift": {"x1": "x2", "x2": "-w^2*x1 - 2*z*w*x2 + u1 + 0.5*u2"},
    "diffusion": {"x1": "0.01", "x2": "s"},
    "observation": {"y": "x1"},
    "measurement_variance": {"y": "r"},
    "initial_state": {"x1": "0", "x2": "0"}
  })json");
  const data::Series series = RandomSeries(400, 1, 0.1, 11);
  const FilterSettings settings = FilterSettings::FromModel(spec);
  const double exact = ExactLoglik(spec, series, settings);
  spec.ekf.rtol = 1e-6;
  std::vector<long> rhs;
  for (const double atol : {1e-8, 1e-14}) {
    SCOPED_TRACE(::testing::Message() << "atol " << atol);
    spec.ekf.atol = atol;
    ode::OdeCounts counts;
    const double ekf = EkfLoglik(spec, series, settings, &counts);
    EXPECT_LT(std::abs(ekf - exact) / std::abs(exact), 1e-6);
    // Each interval begins with the step its predecessor's first step proposed (after an
    // update, as this one does), not its last step's: half the intervals' first steps were
    // rejected that way.
    EXPECT_LT(counts.rejected, counts.intervals / 5);
    rhs.push_back(counts.rhs);
  }
  EXPECT_LT(rhs[1], 1.1 * rhs[0]) << rhs[0] << " evaluations at atol 1e-8, " << rhs[1]
                                  << " at 1e-14";
}

// Two tanks in cascade with orifice outflow, a time-varying inflow, a diffusion that grows with
// the level, a nonlinear observation and a measurement variance that depends on the input.
const char* const kTanks = R"json({
  "greybench_model": 1,
  "states": ["h1", "h2"], "inputs": ["u"], "outputs": ["y1", "y2"],
  "parameters": {"k": 0.6, "a1": 0.5, "a2": 0.4, "s1": 0.05, "s2": 0.03, "r1": 0.01, "r2": 0.02,
                 "h10": 1.0, "h20": 1.5},
  "drift": {"h1": "k*u*(1 + 0.1*sin(0.3*t)) - a1*sqrt(h1)",
            "h2": "a1*sqrt(h1) - a2*sqrt(h2)"},
  "diffusion": {"h1": "s1*(1 + 0.2*h1)", "h2": "s2"},
  "observation": {"y1": "h2 + 0.1*h2^2", "y2": "h1"},
  "measurement_variance": {"y1": "r1*(1 + 0.5*u^2)", "y2": "r2"},
  "initial_state": {"h1": "h10", "h2": "h20"}
})json";

// Evaluates the model's formulas as trees (no tape, no symbolic derivative).
struct TreeModel {
  const model::ModelSpec& spec;
  std::vector<double> theta;
  double Eval(const model::Formula& f, const Eigen::VectorXd& x, const Eigen::VectorXd& u,
              double t) const {
    return expr::EvaluateTree(f.expr, [&](const std::string& name) {
      if (int i = spec.StateIndex(name); i >= 0) return x(i);
      if (int i = spec.InputIndex(name); i >= 0) return u(i);
      if (int i = spec.ParameterIndex(name); i >= 0) return theta[i];
      return t;
    });
  }
  Eigen::VectorXd Vector(const std::vector<model::Formula>& fs, const Eigen::VectorXd& x,
                         const Eigen::VectorXd& u, double t) const {
    Eigen::VectorXd v(static_cast<Eigen::Index>(fs.size()));
    for (std::size_t i = 0; i < fs.size(); ++i)
      v(static_cast<Eigen::Index>(i)) = Eval(fs[i], x, u, t);
    return v;
  }
  // ∂v/∂x by central differences.
  Eigen::MatrixXd Jacobian(const std::vector<model::Formula>& fs, const Eigen::VectorXd& x,
                           const Eigen::VectorXd& u, double t) const {
    Eigen::MatrixXd J(static_cast<Eigen::Index>(fs.size()), x.size());
    for (Eigen::Index j = 0; j < x.size(); ++j) {
      const double h = 1e-6 * std::max(1.0, std::abs(x(j)));
      Eigen::VectorXd a = x, b = x;
      a(j) += h;
      b(j) -= h;
      J.col(j) = (Vector(fs, a, u, t) - Vector(fs, b, u, t)) / (2 * h);
    }
    return J;
  }
};

// The EKF written plainly: the moment equations by classical RK4 on `substeps` equal steps per
// interval with full matrices, the measurement update in vector form, zoh inputs, P0 "ctsm".
double BruteForceEkf(const model::ModelSpec& spec, const data::Series& series, int substeps) {
  const TreeModel tm{spec, spec.Values()};
  const int n = static_cast<int>(spec.states.size());
  const int N = static_cast<int>(series.size());
  Eigen::VectorXd x0 =
      tm.Vector(spec.initial_state, Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(1), 0.0);
  auto rhs = [&](double t, const Eigen::VectorXd& u, const Eigen::VectorXd& x,
                 const Eigen::MatrixXd& P, Eigen::VectorXd* dx, Eigen::MatrixXd* dP) {
    *dx = tm.Vector(spec.drift, x, u, t);
    const Eigen::MatrixXd J = tm.Jacobian(spec.drift, x, u, t);
    const Eigen::VectorXd sigma = tm.Vector(spec.diffusion, x, u, t);
    *dP = J * P + P * J.transpose();
    dP->diagonal() += sigma.array().square().matrix();
  };
  auto propagate = [&](int j, Eigen::VectorXd* x, Eigen::MatrixXd* P) {
    const Eigen::VectorXd u = series.U.col(j);
    const double h = (series.time[j + 1] - series.time[j]) / substeps;
    double t = series.time[j];
    for (int s = 0; s < substeps; ++s) {
      Eigen::VectorXd k1, k2, k3, k4;
      Eigen::MatrixXd l1, l2, l3, l4;
      rhs(t, u, *x, *P, &k1, &l1);
      rhs(t + h / 2, u, *x + h / 2 * k1, *P + h / 2 * l1, &k2, &l2);
      rhs(t + h / 2, u, *x + h / 2 * k2, *P + h / 2 * l2, &k3, &l3);
      rhs(t + h, u, *x + h * k3, *P + h * l3, &k4, &l4);
      *x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
      *P += h / 6 * (l1 + 2 * l2 + 2 * l3 + l4);
      t += h;
    }
  };
  Eigen::VectorXd x = x0;
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(n, n);
  propagate(0, &x, &P);  // "ctsm": the covariance over the first interval, from the prior mean
  x = x0;
  double loglik = 0.0;
  for (int j = 0; j < N; ++j) {
    std::vector<int> seen;
    for (int o = 0; o < series.Y.rows(); ++o)
      if (!std::isnan(series.Y(o, j))) seen.push_back(o);
    if (!seen.empty()) {
      const Eigen::VectorXd u = series.U.col(j);
      const double t = series.time[j];
      const Eigen::VectorXd h = tm.Vector(spec.observation, x, u, t);
      const Eigen::MatrixXd H = tm.Jacobian(spec.observation, x, u, t);
      const Eigen::VectorXd S = tm.Vector(spec.measurement_variance, x, u, t);
      const int p = static_cast<int>(seen.size());
      Eigen::MatrixXd Hs(p, n);
      Eigen::VectorXd eps(p), Ss(p);
      for (int i = 0; i < p; ++i) {
        Hs.row(i) = H.row(seen[i]);
        eps(i) = series.Y(seen[i], j) - h(seen[i]);
        Ss(i) = S(seen[i]);
      }
      Eigen::MatrixXd R = Hs * P * Hs.transpose();
      R.diagonal() += Ss;
      const Eigen::LLT<Eigen::MatrixXd> llt(R);
      const Eigen::MatrixXd L = llt.matrixL();
      loglik -= 0.5 * (2 * L.diagonal().array().log().sum() + eps.dot(llt.solve(eps)) +
                       p * std::log(2 * M_PI));
      const Eigen::MatrixXd K = P * Hs.transpose() * llt.solve(Eigen::MatrixXd::Identity(p, p));
      x += K * eps;
      P -= K * R * K.transpose();
    }
    if (j + 1 < N) propagate(j, &x, &P);
  }
  return loglik;
}

// Data from the model itself: Euler-Maruyama on a fine grid, a PRBS-like input, 10 % missing.
data::Series SimulateTanks(const model::ModelSpec& spec, int N, double dt, unsigned seed) {
  const TreeModel tm{spec, spec.Values()};
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> unit;
  std::vector<double> t(N);
  Eigen::MatrixXd U(1, N), Y(2, N);
  Eigen::VectorXd x =
      tm.Vector(spec.initial_state, Eigen::VectorXd::Zero(2), Eigen::VectorXd::Zero(1), 0.0);
  const int fine = 50;
  for (int k = 0; k < N; ++k) {
    t[k] = k * dt;
    U(0, k) = (k / 7) % 3 == 0 ? 0.4 : 1.0;
    const Eigen::VectorXd u = U.col(k);
    const Eigen::VectorXd S = tm.Vector(spec.measurement_variance, x, u, t[k]);
    const Eigen::VectorXd h = tm.Vector(spec.observation, x, u, t[k]);
    for (int o = 0; o < 2; ++o)
      Y(o, k) = unit(rng) < 0.1 ? std::numeric_limits<double>::quiet_NaN()
                                : h(o) + std::sqrt(S(o)) * normal(rng);
    for (int s = 0; s < fine; ++s) {
      const double ts = t[k] + s * dt / fine;
      const Eigen::VectorXd f = tm.Vector(spec.drift, x, u, ts);
      const Eigen::VectorXd sigma = tm.Vector(spec.diffusion, x, u, ts);
      for (int i = 0; i < 2; ++i)
        x(i) =
            std::max(1e-3, x(i) + f(i) * dt / fine + sigma(i) * std::sqrt(dt / fine) * normal(rng));
    }
  }
  return MakeSeries(t, U, Y);
}

TEST(Ekf, NonlinearModelEqualsABruteForceEkf) {
  const model::ModelSpec spec = Spec(kTanks);
  // Under the sanitizers 50 samples: the same code, a third of the brute force (docs/benchmarks.md,
  // "Timings behind the code's limits").
  const int samples = kSanitized ? 50 : 150;
  const data::Series series = SimulateTanks(spec, samples, 0.5, 3);
  const double reference = BruteForceEkf(spec, series, 400);
  const double reference_coarse = BruteForceEkf(spec, series, 100);
  // RK4's error falls 256-fold from 100 to 400 steps: the reference is settled far below 1e-9.
  ASSERT_LT(std::abs(reference - reference_coarse), 1e-6 * std::abs(reference));
  for (const model::OdeMethod method : {model::OdeMethod::kExplicit, model::OdeMethod::kBdf}) {
    model::ModelSpec s = spec;
    s.ekf.method = method;
    ode::OdeCounts counts;
    const double ekf = EkfLoglik(s, series, FilterSettings::FromModel(s), &counts);
    SCOPED_TRACE(model::OdeMethodName(method));
    EXPECT_NEAR(ekf, reference, 1e-7 * std::abs(reference));
    EXPECT_EQ(counts.intervals, samples);  // the intervals between samples and the first for P0
    EXPECT_EQ(counts.stiff_intervals, method == model::OdeMethod::kBdf ? samples : 0);
  }
}

TEST(Ekf, CompiledJacobiansEqualCentralDifferences) {
  const model::ModelSpec spec = Spec(kTanks);
  const model::NonlinearModel nm = Nonlinear(spec);
  const int n = 2, p = 2;
  std::vector<double> slots(nm.n_slots());
  const std::vector<double> theta = spec.Values();
  std::copy(theta.begin(), theta.end(), slots.begin() + nm.parameter_slot());
  slots[0] = 0.7;
  slots[1] = 1.9;
  slots[nm.input_slot()] = 0.8;
  slots[nm.time_slot()] = 2.5;
  std::vector<double> dyn(nm.dynamics_size()), mea(nm.measurement_size());
  nm.Dynamics(slots, dyn);
  nm.Measurement(slots, mea);
  for (int j = 0; j < n; ++j) {
    std::vector<double> up = slots, down = slots;
    const double h = 1e-6;
    up[j] += h;
    down[j] -= h;
    std::vector<double> dyn_up(dyn.size()), dyn_down(dyn.size()), mea_up(mea.size()),
        mea_down(mea.size());
    nm.Dynamics(up, dyn_up);
    nm.Dynamics(down, dyn_down);
    nm.Measurement(up, mea_up);
    nm.Measurement(down, mea_down);
    for (int i = 0; i < n; ++i)
      EXPECT_NEAR(dyn[n + i * n + j], (dyn_up[i] - dyn_down[i]) / (2 * h), 1e-8) << i << j;
    for (int o = 0; o < p; ++o)
      EXPECT_NEAR(mea[p + o * n + j], (mea_up[o] - mea_down[o]) / (2 * h), 1e-8) << o << j;
  }
  // The entries' values against the formulas evaluated as trees.
  const TreeModel tm{spec, theta};
  const Eigen::VectorXd x = Eigen::Vector2d(0.7, 1.9), u = Eigen::VectorXd::Constant(1, 0.8);
  const Eigen::VectorXd f = tm.Vector(spec.drift, x, u, 2.5);
  const Eigen::VectorXd sigma = tm.Vector(spec.diffusion, x, u, 2.5);
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(dyn[i], f(i));
    EXPECT_EQ(dyn[n + n * n + i], sigma(i));
  }
}

// A fast first-order sensor on a slow tank: the mode at -1/tau is 500 times faster than the
// sample interval. BDF and the explicit method agree, and `auto` hands the intervals to BDF.
TEST(Ekf, StiffModelGivesTheSameLikelihoodByBdfAndExplicit) {
  const char* const kStiff = R"json({
    "greybench_model": 1,
    "states": ["h", "m"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {"k": 0.6, "a": 0.5, "tau": 0.002, "s": 0.05, "r": 0.01},
    "drift": {"h": "k*u - a*sqrt(h)", "m": "(h - m)/tau"},
    "diffusion": {"h": "s", "m": "0.01"},
    "observation": {"y": "m"},
    "measurement_variance": {"y": "r"},
    "initial_state": {"h": "1", "m": "1"}
  })json";
  const model::ModelSpec spec = Spec(kStiff);
  data::Series series = SimulateTanks(Spec(kTanks), 120, 0.5, 5);
  series.Y = series.Y.row(0).eval();
  model::ModelSpec tight = spec;
  tight.ekf.method = model::OdeMethod::kExplicit;
  tight.ekf.rtol = 1e-12;
  tight.ekf.atol = 1e-14;
  const double reference = EkfLoglik(tight, series, FilterSettings::FromModel(tight));
  double results[3];
  ode::OdeCounts counts[3];
  int i = 0;
  for (const auto method :
       {model::OdeMethod::kExplicit, model::OdeMethod::kBdf, model::OdeMethod::kAuto}) {
    model::ModelSpec s = spec;
    s.ekf.method = method;
    results[i] = EkfLoglik(s, series, FilterSettings::FromModel(s), &counts[i]);
    EXPECT_NEAR(results[i], reference, 1e-6 * std::abs(reference)) << model::OdeMethodName(method);
    ++i;
  }
  EXPECT_EQ(results[2], results[1]);
  EXPECT_EQ(counts[2].stiff_intervals, counts[2].intervals);
  // The explicit method needs hundreds of steps per interval for stability alone (measured: 14
  // times BDF's evaluations, 2.4 times its time).
  EXPECT_GT(counts[0].rhs, 5 * counts[1].rhs);
}

// With many passes, the iterated EKF's filtered mean is the mode of the posterior
//   p(x | y) ∝ N(x; x̂⁻, P⁻) N(y; h(x), S):  P⁻⁻¹ (x - x̂⁻) = H(x)' S⁻¹ (y - h(x)).
TEST(Ekf, IteratedUpdateReachesThePosteriorMode) {
  model::ModelSpec spec = Spec(kTanks);
  spec.observation[0] = {"h2^3", *expr::Parse("h2^3"), "observation.y1"};
  spec.measurement_variance[0] = {"r1", *expr::Parse("r1"), "measurement_variance.y1"};
  data::Series series = SimulateTanks(spec, 40, 0.5, 9);
  series.Y.row(1).setConstant(std::numeric_limits<double>::quiet_NaN());  // y1 = h2³ alone
  spec.ekf.iterations = 50;
  const model::NonlinearModel nm = Nonlinear(spec);
  FilterTrace trace;
  ASSERT_TRUE(EkfRunFilter(nm, spec.Values(), series, FilterSettings::FromModel(spec), &trace));
  FilterTrace plain_trace;
  model::ModelSpec plain = spec;
  plain.ekf.iterations = 1;
  ASSERT_TRUE(EkfRunFilter(Nonlinear(plain), spec.Values(), series,
                           FilterSettings::FromModel(plain), &plain_trace));
  const double r1 = spec.Values()[spec.ParameterIndex("r1")];
  int moved = 0;
  for (int j = 0; j < 40; ++j) {
    const double y = series.Y(0, j);
    if (std::isnan(y)) continue;
    const Eigen::VectorXd x = trace.x_filt.col(j), prior = trace.x_pred.col(j);
    const Eigen::MatrixXd& P = trace.P_pred[j];
    const double h = std::pow(x(1), 3);
    const Eigen::Vector2d H(0.0, 3 * x(1) * x(1));
    const Eigen::VectorXd residual = P.ldlt().solve(x - prior) - H * (y - h) / r1;
    EXPECT_LT(residual.norm(), 1e-6 * (1 + P.ldlt().solve(x - prior).norm())) << j;
    if ((x - plain_trace.x_filt.col(j)).norm() > 1e-6) ++moved;
  }
  EXPECT_GT(moved, 10);  // the iterations do change the update of a cubic observation
}

}  // namespace
}  // namespace gb::filter
