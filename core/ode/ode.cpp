#include "core/ode/ode.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include <boost/numeric/odeint/stepper/controlled_runge_kutta.hpp>
#include <boost/numeric/odeint/stepper/runge_kutta_dopri5.hpp>
#include <cvode/cvode.h>
#include <fmt/format.h>
#include <nvector/nvector_serial.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

namespace gb::ode {
namespace {

constexpr long kMaxSteps = 100000;          // per interval
constexpr double kMinStepFraction = 1e-14;  // of the interval

using State = std::vector<double>;
namespace odeint = boost::numeric::odeint;
using Dopri5 = odeint::runge_kutta_dopri5<State>;

// Odeint's default error test (|err_i| / (atol + rtol (|x_i| + Δt |dx_i/dt|)), the largest over
// i) on the first `controlled` components only: the others (sensitivities) ride along on the
// steps the moments need, as CVODES does by default for its sensitivities.
class PartialErrorChecker {
 public:
  using value_type = double;
  using algebra_type = odeint::range_algebra;
  using operations_type = odeint::default_operations;

  PartialErrorChecker(double atol, double rtol, std::size_t controlled)
      : atol_(atol), rtol_(rtol), controlled_(controlled) {}

  template <class St, class Deriv, class Err, class Time>
  double error(algebra_type& /*algebra*/, const St& x_old, const Deriv& dxdt_old, Err& x_err,
               Time dt) const {
    double worst = 0.0;
    for (std::size_t i = 0; i < controlled_; ++i) {
      const double scale =
          atol_ + rtol_ * (std::abs(x_old[i]) + std::abs(dt) * std::abs(dxdt_old[i]));
      worst = std::max(worst, std::abs(x_err[i]) / scale);
    }
    return worst;
  }

 private:
  double atol_, rtol_;
  std::size_t controlled_;
};

using Controlled = odeint::controlled_runge_kutta<Dopri5, PartialErrorChecker>;

// CVODE's name of a return flag ("CV_TOO_MUCH_WORK"); CVodeGetReturnFlagName allocates it.
std::string FlagName(int flag) {
  char* name = CVodeGetReturnFlagName(flag);
  std::string copy = name ? name : fmt::format("flag {}", flag);
  free(name);  // NOLINT(cppcoreguidelines-no-malloc): SUNDIALS allocates it with malloc
  return copy;
}

}  // namespace

// ---- explicit: Dormand-Prince 5(4) ------------------------------------------------------------

struct OdeSolver::Explicit {
  Explicit(double atol, double rtol, int size, int controlled)
      : stepper(PartialErrorChecker(atol, rtol, static_cast<std::size_t>(controlled))),
        x(size),
        dxdt(size),
        x_new(size),
        dxdt_new(size) {}
  Controlled stepper;
  State x, dxdt, x_new, dxdt_new;
  double dt_hint = 0.0;  // the step size the last interval ended with (0: none yet)
};

Status OdeSolver::AdvanceExplicit(OdeSystem& system, double t0, double t1, std::span<double> z) {
  if (!explicit_)
    explicit_ =
        std::make_unique<Explicit>(options_.atol, options_.rtol, size_, system.controlled_size());
  Explicit& e = *explicit_;
  bool finite = true;
  auto rhs = [&](const State& x, State& dxdt, double t) {
    ++counts_.rhs;
    if (!system.Rhs(t, x, dxdt)) finite = false;
  };
  std::copy(z.begin(), z.end(), e.x.begin());
  const double length = t1 - t0;
  double t = t0;
  rhs(e.x, e.dxdt, t);
  if (!finite) return NumericalError("the moment equations are not finite at the interval's start");
  double dt = e.dt_hint > 0.0 ? std::min(e.dt_hint, length) : length;
  for (long attempt = 0;; ++attempt) {
    if (attempt > kMaxSteps)
      return NumericalError(fmt::format("more than {} steps in one sample interval", kMaxSteps));
    const double left = t1 - t;
    const bool last = dt >= left;
    if (last) dt = left;
    const double dt_tried = dt;
    double t_step = t;
    finite = true;
    const auto result = e.stepper.try_step(rhs, e.x, e.dxdt, t_step, e.x_new, e.dxdt_new, dt);
    if (!finite) {  // the trial step left the domain of the model (a sqrt of a negative level)
      ++counts_.rejected;
      dt = 0.25 * dt_tried;
    } else if (result == odeint::success) {
      ++counts_.steps;
      if (step_log_) {
        step_log_->push_back(t);
        step_log_->push_back(dt_tried);
      }
      std::swap(e.x, e.x_new);
      std::swap(e.dxdt, e.dxdt_new);
      if (last) {
        // Keep the proposal unless the last step was cut short to land on t1.
        if (dt_tried >= 0.5 * e.dt_hint || e.dt_hint == 0.0) e.dt_hint = dt;
        break;
      }
      t = t_step;
      e.dt_hint = dt;
    } else {
      ++counts_.rejected;
    }
    if (!(dt > kMinStepFraction * length))
      return NumericalError(
          fmt::format("the step size fell below {:g} of the sample interval", kMinStepFraction));
  }
  std::copy(e.x.begin(), e.x.end(), z.begin());
  return Ok{};
}

// ---- the discrete adjoint of the explicit steps ------------------------------------------------

namespace {

// Dormand-Prince 5(4)'s tableau (Boost.Odeint's runge_kutta_dopri5): the nodes, the stage
// weights a_ik (k < i) and the fifth-order weights b (b_2 = 0; the seventh stage only estimates
// the error and is the next step's first, so it does not enter the accepted solution).
constexpr int kStages = 6;
constexpr double kC[kStages] = {0.0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1.0};
constexpr double kA[kStages][kStages] = {
    {},
    {1.0 / 5},
    {3.0 / 40, 9.0 / 40},
    {44.0 / 45, -56.0 / 15, 32.0 / 9},
    {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729},
    {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656}};
constexpr double kB[kStages] = {35.0 / 384,     0.0,      500.0 / 1113, 125.0 / 192,
                                -2187.0 / 6784, 11.0 / 84};

}  // namespace

Status ReverseExplicitSteps(AdjointSystem& system, std::span<const double> steps,
                            std::span<const double> z0, std::span<double> z_bar,
                            std::span<double> p_bar) {
  const auto size = static_cast<std::size_t>(system.size());
  assert(z0.size() == size && z_bar.size() == size && steps.size() % 2 == 0);
  const std::size_t n_steps = steps.size() / 2;
  if (n_steps == 0) return Ok{};
  // The stages of every step, recomputed forward: Y[s][i] (size each).
  std::vector<double> Y(n_steps * kStages * size);
  std::vector<double> K(kStages * size);
  std::vector<double> z(z0.begin(), z0.end());
  auto stage = [&](std::size_t s, int i) { return Y.data() + (s * kStages + i) * size; };
  system.Retrace(static_cast<int>(n_steps) * kStages);
  for (std::size_t s = 0; s < n_steps; ++s) {
    const double t = steps[2 * s], h = steps[2 * s + 1];
    for (int i = 0; i < kStages; ++i) {
      double* y = stage(s, i);
      for (std::size_t c = 0; c < size; ++c) {
        double v = z[c];
        for (int k = 0; k < i; ++k) v += h * kA[i][k] * K[k * size + c];
        y[c] = v;
      }
      if (!system.Rhs(t + kC[i] * h, {y, size}, {K.data() + i * size, size})) {
        system.Retrace(0);
        return NumericalError("the moment equations are not finite on a retraced step");
      }
    }
    for (std::size_t c = 0; c < size; ++c) {
      double v = z[c];
      for (int i = 0; i < kStages; ++i) v += h * kB[i] * K[i * size + c];
      z[c] = v;
    }
  }
  // Backwards through the steps: K̄ (the stages' adjoints, kStages x size) and Ȳ.
  std::vector<double> K_bar(kStages * size), Y_bar(size);
  for (std::size_t s = n_steps; s-- > 0;) {
    const double t = steps[2 * s], h = steps[2 * s + 1];
    for (int i = 0; i < kStages; ++i)
      for (std::size_t c = 0; c < size; ++c) K_bar[i * size + c] = h * kB[i] * z_bar[c];
    for (int i = kStages; i-- > 0;) {
      std::fill(Y_bar.begin(), Y_bar.end(), 0.0);
      if (!system.Vjp(static_cast<int>(s) * kStages + i, t + kC[i] * h, {stage(s, i), size},
                      {K_bar.data() + i * size, size}, Y_bar, p_bar))
        return NumericalError(
            "the moment equations' derivatives are not finite on a retraced step");
      for (std::size_t c = 0; c < size; ++c) {
        z_bar[c] += Y_bar[c];
        for (int k = 0; k < i; ++k) K_bar[k * size + c] += h * kA[i][k] * Y_bar[c];
      }
    }
  }
  return Ok{};
}

// ---- BDF: SUNDIALS CVODE ----------------------------------------------------------------------

struct OdeSolver::Bdf {
  SUNContext context = nullptr;
  N_Vector y = nullptr;
  SUNMatrix matrix = nullptr;
  SUNLinearSolver solver = nullptr;
  void* memory = nullptr;
  bool initialised = false;
  OdeSystem* system = nullptr;  // during Advance
  long rhs = 0;

  ~Bdf() {
    if (memory) CVodeFree(&memory);
    if (solver) SUNLinSolFree(solver);
    if (matrix) SUNMatDestroy(matrix);
    if (y) N_VDestroy(y);
    if (context) SUNContext_Free(&context);
  }

  static int Rhs(sunrealtype t, N_Vector y, N_Vector dy, void* user) {
    Bdf& b = *static_cast<Bdf*>(user);
    const auto n = static_cast<std::size_t>(N_VGetLength(y));
    ++b.rhs;
    const bool ok = b.system->Rhs(t, {N_VGetArrayPointer(y), n}, {N_VGetArrayPointer(dy), n});
    return ok ? 0 : 1;  // positive: recoverable, CVODE retries with a shorter step
  }
  static int Jacobian(sunrealtype t, N_Vector y, N_Vector /*fy*/, SUNMatrix jac, void* user,
                      N_Vector /*tmp1*/, N_Vector /*tmp2*/, N_Vector /*tmp3*/) {
    Bdf& b = *static_cast<Bdf*>(user);
    const auto n = static_cast<std::size_t>(N_VGetLength(y));
    b.system->Jacobian(t, {N_VGetArrayPointer(y), n}, {SUNDenseMatrix_Data(jac), n * n});
    return 0;
  }
  // CVODE reports failures through its return flags, which Advance turns into messages.
  static void Silent(int, const char*, const char*, char*, void*) {}
};

Status OdeSolver::AdvanceBdf(OdeSystem& system, double t0, double t1, std::span<double> z) {
  if (!bdf_) {
    bdf_ = std::make_unique<Bdf>();
    Bdf& b = *bdf_;
    if (SUNContext_Create(nullptr, &b.context) != 0)
      return NumericalError("the BDF solver could not be created");
    b.y = N_VNew_Serial(size_, b.context);
    b.matrix = SUNDenseMatrix(size_, size_, b.context);
    b.memory = CVodeCreate(CV_BDF, b.context);
    if (!b.y || !b.matrix || !b.memory)
      return NumericalError("the BDF solver could not be created");
    b.solver = SUNLinSol_Dense(b.y, b.matrix, b.context);
    if (!b.solver) return NumericalError("the BDF solver could not be created");
  }
  Bdf& b = *bdf_;
  b.system = &system;
  std::copy(z.begin(), z.end(), N_VGetArrayPointer(b.y));
  int flag = 0;
  if (!b.initialised) {
    flag = CVodeInit(b.memory, &Bdf::Rhs, t0, b.y);
    if (flag >= 0) flag = CVodeSetUserData(b.memory, &b);
    if (flag >= 0) flag = CVodeSetErrHandlerFn(b.memory, &Bdf::Silent, nullptr);
    if (flag >= 0) flag = CVodeSStolerances(b.memory, options_.rtol, options_.atol);
    if (flag >= 0) flag = CVodeSetLinearSolver(b.memory, b.solver, b.matrix);
    if (flag >= 0) flag = CVodeSetJacFn(b.memory, &Bdf::Jacobian);
    if (flag >= 0) flag = CVodeSetMaxNumSteps(b.memory, kMaxSteps);
    if (flag < 0)
      return NumericalError(fmt::format("the BDF solver could not be set up ({})", FlagName(flag)));
    b.initialised = true;
  } else {
    flag = CVodeReInit(b.memory, t0, b.y);
    if (flag < 0)
      return NumericalError(fmt::format("the BDF solver could not restart ({})", FlagName(flag)));
  }
  CVodeSetStopTime(b.memory, t1);
  sunrealtype t_reached = t0;
  b.rhs = 0;
  flag = CVode(b.memory, t1, b.y, &t_reached, CV_NORMAL);
  long steps = 0, failures = 0;
  CVodeGetNumSteps(b.memory, &steps);
  CVodeGetNumErrTestFails(b.memory, &failures);
  counts_.steps += steps;
  counts_.rejected += failures;
  counts_.rhs += b.rhs;
  b.system = nullptr;
  if (flag < 0)
    return NumericalError(
        fmt::format("the BDF solver failed at t = {:g} ({})", t_reached, FlagName(flag)));
  std::copy(N_VGetArrayPointer(b.y), N_VGetArrayPointer(b.y) + size_, z.begin());
  return Ok{};
}

// ---- the choice -------------------------------------------------------------------------------

OdeSolver::OdeSolver(const model::EkfOptions& options, int size) : options_(options), size_(size) {}

OdeSolver::~OdeSolver() = default;

Status OdeSolver::Advance(OdeSystem& system, double t0, double t1, std::span<double> z,
                          double stiffness) {
  assert(static_cast<int>(z.size()) == size_ && system.size() == size_ && t1 > t0);
  ++counts_.intervals;
  bool bdf = options_.method == model::OdeMethod::kBdf;
  if (options_.method == model::OdeMethod::kAuto) bdf = stiffness > kStiffLimit;
  if (!bdf) return AdvanceExplicit(system, t0, t1, z);
  ++counts_.stiff_intervals;
  return AdvanceBdf(system, t0, t1, z);
}

}  // namespace gb::ode
