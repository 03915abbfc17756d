// The error-controlled ODE solver (core/ode/ode.h) against independent references:
//   - its explicit method takes Boost.Odeint's Dormand-Prince 5(4) steps under Odeint's step-size
//     control, bit for bit (the steps, the states and the evaluation counts), on a size the
//     solver has a fixed-size loop for and on one it has not;
//   - it converges to a closed form (a linear oscillator) at the order of its tolerance;
//   - a right-hand side that is not finite shortens the step, and one that stays so is reported.
#include "core/ode/ode.h"

#include <cmath>
#include <vector>

#include <boost/numeric/odeint/stepper/controlled_runge_kutta.hpp>
#include <boost/numeric/odeint/stepper/runge_kutta_dopri5.hpp>
#include <gtest/gtest.h>

namespace gb::ode {
namespace {

// Van der Pol (z0, z1) driven by sin t, with size - 2 components decaying towards z0 at rates
// 1, 2, 3, ...
class Driven final : public OdeSystem {
 public:
  explicit Driven(int size) : size_(size) {}
  int size() const override { return size_; }
  bool Rhs(double t, std::span<const double> z, std::span<double> dz) override {
    ++calls;
    dz[0] = z[1];
    dz[1] = 3.0 * (1.0 - z[0] * z[0]) * z[1] - z[0] + std::sin(t);
    for (int i = 2; i < size_; ++i) dz[i] = (i - 1) * (z[0] - z[i]);
    return true;
  }
  void Jacobian(double, std::span<const double>, std::span<double>) override {}
  long calls = 0;

 private:
  int size_;
};

model::EkfOptions Explicit(double rtol, double atol) {
  model::EkfOptions o;
  o.method = model::OdeMethod::kExplicit;
  o.rtol = rtol;
  o.atol = atol;
  return o;
}

// Odeint's controlled Dormand-Prince over [t0, t1] as OdeSolver drives its explicit method: the
// first step the proposal of the last interval's first step (else the whole interval), the last
// step cut to land on t1; the first step's proposal is kept for the next interval unless that
// step was cut below half of it to land on t1. Appends (t, Δt) per accepted step to *log.
struct OdeintRun {
  using State = std::vector<double>;
  using Dopri5 = boost::numeric::odeint::runge_kutta_dopri5<State>;
  using Checker = boost::numeric::odeint::default_error_checker<double, Dopri5::algebra_type,
                                                                Dopri5::operations_type>;
  boost::numeric::odeint::controlled_runge_kutta<Dopri5, Checker> stepper;
  double first_step = 0.0;

  OdeintRun(double rtol, double atol) : stepper(Checker(atol, rtol)) {}

  void Advance(Driven& system, double t0, double t1, State& x, std::vector<double>* log) {
    auto rhs = [&](const State& z, State& dz, double t) { system.Rhs(t, z, dz); };
    State dxdt(x.size()), x_new(x.size()), dxdt_new(x.size());
    rhs(x, dxdt, t0);
    double t = t0, dt = first_step > 0.0 ? std::min(first_step, t1 - t0) : t1 - t0;
    bool first = true;
    for (;;) {
      const double left = t1 - t;
      const bool last = dt >= left;
      if (last) dt = left;
      const double dt_tried = dt;
      double t_step = t;
      if (stepper.try_step(rhs, x, dxdt, t_step, x_new, dxdt_new, dt) ==
          boost::numeric::odeint::success) {
        log->push_back(t);
        log->push_back(dt_tried);
        std::swap(x, x_new);
        std::swap(dxdt, dxdt_new);
        if (first) {
          if (!last || dt_tried >= 0.5 * first_step || first_step == 0.0) first_step = dt;
          first = false;
        }
        if (last) return;
        t = t_step;
      }
    }
  }
};

void ExpectOdeintSteps(int size) {
  SCOPED_TRACE(::testing::Message() << "size " << size);
  const double rtol = 1e-9, atol = 1e-11;
  Driven ours(size), theirs(size);
  OdeSolver solver(Explicit(rtol, atol), size);
  OdeintRun odeint(rtol, atol);
  std::vector<double> log, odeint_log;
  solver.set_step_log(&log);
  std::vector<double> z(size, 0.5), x(size, 0.5);
  z[1] = x[1] = -1.0;
  // Intervals of different lengths, each from a moved state, as the filter's updates move it.
  const double edges[] = {0.0, 0.7, 0.75, 2.5, 2.6, 6.0};
  for (int k = 0; k + 1 < 6; ++k) {
    ASSERT_TRUE(solver.Advance(ours, edges[k], edges[k + 1], z, 0.0).ok());
    odeint.Advance(theirs, edges[k], edges[k + 1], x, &odeint_log);
    for (int i = 0; i < size; ++i) {
      ASSERT_EQ(z[i], x[i]) << "component " << i << " at t = " << edges[k + 1];
      z[i] = x[i] = 1.01 * x[i];
    }
  }
  EXPECT_EQ(log, odeint_log);
  EXPECT_EQ(ours.calls, theirs.calls);
  EXPECT_EQ(solver.counts().rhs, ours.calls);
  EXPECT_GT(solver.counts().rejected, 0) << "the case exercises rejected steps";
  EXPECT_EQ(2 * solver.counts().steps, static_cast<long>(log.size()));
}

TEST(OdeSolver, ExplicitStepsAreOdeintsDormandPrinceBitForBit) {
  ExpectOdeintSteps(5);  // a size with its own fixed-size loops (the moments of 2 states)
  ExpectOdeintSteps(4);  // one without
}

// z'' = -ω² z from (1, 0): z = cos ωt. The global error shrinks with the tolerance.
class Oscillator final : public OdeSystem {
 public:
  int size() const override { return 2; }
  bool Rhs(double, std::span<const double> z, std::span<double> dz) override {
    dz[0] = z[1];
    dz[1] = -4.0 * z[0];
    return true;
  }
  void Jacobian(double, std::span<const double>, std::span<double>) override {}
};

TEST(OdeSolver, ExplicitMethodConvergesToTheClosedFormWithItsTolerance) {
  double previous = 1.0;
  for (const double rtol : {1e-5, 1e-7, 1e-9, 1e-11}) {
    Oscillator system;
    OdeSolver solver(Explicit(rtol, 1e-3 * rtol), 2);
    std::vector<double> z = {1.0, 0.0};
    for (int k = 0; k < 20; ++k)
      ASSERT_TRUE(solver.Advance(system, 0.5 * k, 0.5 * (k + 1), z, 0.0).ok());
    const double error = std::abs(z[0] - std::cos(20.0)) + std::abs(z[1] + 2.0 * std::sin(20.0));
    EXPECT_LT(error, 200.0 * rtol) << "rtol " << rtol;
    EXPECT_LT(error, previous) << "rtol " << rtol;
    previous = error;
  }
}

// z0' = -rate z0 (rate 1: e^-t, stays positive; rate 0 with z0' = -1 instead: reaches zero at
// t = z0(0)), z1' = sqrt(z0), not finite below zero.
class Draining final : public OdeSystem {
 public:
  explicit Draining(bool linear) : linear_(linear) {}
  int size() const override { return 2; }
  bool Rhs(double, std::span<const double> z, std::span<double> dz) override {
    if (z[0] < 0.0) return false;
    dz[0] = linear_ ? -1.0 : -z[0];
    dz[1] = std::sqrt(z[0]);
    return true;
  }
  void Jacobian(double, std::span<const double>, std::span<double>) override {}

 private:
  bool linear_;
};

TEST(OdeSolver, ARightHandSideThatIsNotFiniteShortensTheStep) {
  // One trial step over the whole interval takes a stage below zero; shorter ones do not.
  Draining decay(/*linear=*/false);
  OdeSolver solver(Explicit(1e-10, 1e-12), 2);
  std::vector<double> z = {1.0, 0.0};
  ASSERT_TRUE(solver.Advance(decay, 0.0, 10.0, z, 0.0).ok());
  EXPECT_NEAR(z[0], std::exp(-10.0), 1e-9);
  EXPECT_NEAR(z[1], 2.0 * (1.0 - std::exp(-5.0)), 1e-8);
  EXPECT_GT(solver.counts().rejected, 0);
  // A solution that leaves the domain: the steps shrink to the limit, and that is the reason.
  Draining drain(/*linear=*/true);
  OdeSolver drained(Explicit(1e-10, 1e-12), 2);
  std::vector<double> y = {1.0, 0.0};
  auto s = drained.Advance(drain, 0.0, 2.0, y, 0.0);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("step size fell below"), std::string::npos) << s.error().message;
  // Not finite at the interval's start: reported at once.
  std::vector<double> bad = {-1.0, 0.0};
  auto r = drained.Advance(drain, 0.0, 1.0, bad, 0.0);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("not finite at the interval's start"), std::string::npos)
      << r.error().message;
}

}  // namespace
}  // namespace gb::ode
