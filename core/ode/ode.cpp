#include "core/ode/ode.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include <cvode/cvode.h>
#include <fmt/format.h>
#include <nvector/nvector_serial.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

namespace gb::ode {
namespace {

constexpr long kMaxSteps = 100000;          // per interval
constexpr double kMinStepFraction = 1e-14;  // of the interval

// CVODE's name of a return flag ("CV_TOO_MUCH_WORK"); CVodeGetReturnFlagName allocates it.
std::string FlagName(int flag) {
  char* name = CVodeGetReturnFlagName(flag);
  std::string copy = name ? name : fmt::format("flag {}", flag);
  free(name);  // NOLINT(cppcoreguidelines-no-malloc): SUNDIALS allocates it with malloc
  return copy;
}

// Dormand-Prince 5(4)'s tableau: the nodes c, the stage weights a_ik (k < i), the fifth-order
// weights b (b_2 = 0; the seventh stage, F at the new point, is the next step's first) and the
// error weights e = b - b̂ (e_7 = -1/40 on the seventh stage).
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
constexpr double kE1 = kB[0] - 5179.0 / 57600, kE3 = kB[2] - 7571.0 / 16695,
                 kE4 = kB[3] - 393.0 / 640, kE5 = kB[4] - -92097.0 / 339200,
                 kE6 = kB[5] - 187.0 / 2100, kE7 = -1.0 / 40;

}  // namespace

void OdeSystem::Magnitudes(std::span<const double> z, std::span<double> m) const {
  for (std::size_t i = 0; i < m.size(); ++i) m[i] = std::abs(z[i]);
}

// ---- explicit: Dormand-Prince 5(4) ------------------------------------------------------------

// The method's own loops, for a size fixed at compile time (N > 0: the moment equations of 1 to
// 7 states) or known at run time (N = 0). A step is the same operations in the same order as
// Boost.Odeint's runge_kutta_dopri5 under its controlled_runge_kutta (each stage
// x + (h a_i1) k_1 + (h a_i2) k_2 + ... summed left to right, the same error norm and step-size
// rules), so it takes the same steps to the last bit (tests/core/ode_test.cpp); Odeint's generic
// loops over std::vector cost a fifth of the 2-state filter's time (docs/benchmarks.md, issue 37).
struct OdeSolver::Explicit {
  Explicit(int size, int controlled)
      : controlled(controlled),
        x(size),
        dxdt(size),
        x_new(size),
        dxdt_new(size),
        stages(static_cast<std::size_t>(size) * 6),
        magnitudes(controlled) {}
  int controlled;  // the system's controlled_size()
  std::vector<double> x, dxdt, x_new, dxdt_new;
  std::vector<double> stages;      // k2..k6 and the trial point, size each
  std::vector<double> magnitudes;  // OdeSystem::Magnitudes at x
  double first_step = 0.0;         // the step the last interval's first step proposed (0: none)
};

namespace {

// One trial step from (t, x) with k1 = F(t, x): x_new, k7 = F(t + h, x_new) and the scaled error
// max_i |err_i| / (atol + rtol (m_i + h |k1_i|)) over the first `controlled` components
// (returned), m the system's magnitudes at x (|x_i| by default). `rhs(t, y, k)` evaluates F and
// returns false where it is not finite; the step then returns a NaN error after its last stage.
// `stages`: 6 size.
template <std::ptrdiff_t N, class Rhs>
double TrialStep(Rhs& rhs, std::ptrdiff_t size, std::ptrdiff_t controlled, double atol, double rtol,
                 double t, double h, const double* x, const double* magnitude, const double* k1,
                 double* x_new, double* k7, double* stages) {
  const std::ptrdiff_t n = N > 0 ? N : size;
  double* k2 = stages;
  double* k3 = k2 + n;
  double* k4 = k3 + n;
  double* k5 = k4 + n;
  double* k6 = k5 + n;
  double* y = k6 + n;
  bool finite = true;
  const double a21 = h * kA[1][0];
  for (std::ptrdiff_t i = 0; i < n; ++i) y[i] = x[i] + a21 * k1[i];
  finite &= rhs(t + h * kC[1], y, k2);
  const double a31 = h * kA[2][0], a32 = h * kA[2][1];
  for (std::ptrdiff_t i = 0; i < n; ++i) y[i] = x[i] + a31 * k1[i] + a32 * k2[i];
  finite &= rhs(t + h * kC[2], y, k3);
  const double a41 = h * kA[3][0], a42 = h * kA[3][1], a43 = h * kA[3][2];
  for (std::ptrdiff_t i = 0; i < n; ++i) y[i] = x[i] + a41 * k1[i] + a42 * k2[i] + a43 * k3[i];
  finite &= rhs(t + h * kC[3], y, k4);
  const double a51 = h * kA[4][0], a52 = h * kA[4][1], a53 = h * kA[4][2], a54 = h * kA[4][3];
  for (std::ptrdiff_t i = 0; i < n; ++i)
    y[i] = x[i] + a51 * k1[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i];
  finite &= rhs(t + h * kC[4], y, k5);
  const double a61 = h * kA[5][0], a62 = h * kA[5][1], a63 = h * kA[5][2], a64 = h * kA[5][3],
               a65 = h * kA[5][4];
  for (std::ptrdiff_t i = 0; i < n; ++i)
    y[i] = x[i] + a61 * k1[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i] + a65 * k5[i];
  finite &= rhs(t + h, y, k6);
  const double b1 = h * kB[0], b3 = h * kB[2], b4 = h * kB[3], b5 = h * kB[4], b6 = h * kB[5];
  for (std::ptrdiff_t i = 0; i < n; ++i)
    x_new[i] = x[i] + b1 * k1[i] + b3 * k3[i] + b4 * k4[i] + b5 * k5[i] + b6 * k6[i];
  finite &= rhs(t + h, x_new, k7);
  if (!finite) return std::numeric_limits<double>::quiet_NaN();
  const double e1 = h * kE1, e3 = h * kE3, e4 = h * kE4, e5 = h * kE5, e6 = h * kE6, e7 = h * kE7;
  double worst = 0.0;
  for (std::ptrdiff_t i = 0; i < controlled; ++i) {
    const double err = e1 * k1[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i] + e7 * k7[i];
    const double scale = atol + rtol * (magnitude[i] + std::abs(h) * std::abs(k1[i]));
    worst = std::max(worst, std::abs(err) / scale);
  }
  return worst;
}

// The step-size rules after a trial step with scaled error `error` (Hairer, Nørsett & Wanner's,
// as Odeint's default_step_adjuster has them): rejected (error > 1), h × max(0.9 error^(-1/3),
// 1/5); accepted, h × 0.9 max(error, 5^-5)^(-1/5) when error < 1/2, else h.
double ShorterStep(double h, double error) {
  return h * std::max(0.9 * std::pow(error, -1.0 / 3), 1.0 / 5);
}
double NextStep(double h, double error) {
  if (!(error < 0.5)) return h;
  return h * (0.9 * std::pow(std::max(std::pow(5.0, -5.0), error), -1.0 / 5));
}

}  // namespace

template <std::ptrdiff_t N>
Status OdeSolver::AdvanceExplicitSized(OdeSystem& system, double t0, double t1,
                                       std::span<double> z) {
  Explicit& e = *explicit_;
  const std::ptrdiff_t size = size_;
  auto rhs = [&](double t, const double* x, double* dxdt) {
    ++counts_.rhs;
    return system.Rhs(t, {x, static_cast<std::size_t>(size)},
                      {dxdt, static_cast<std::size_t>(size)});
  };
  std::copy(z.begin(), z.end(), e.x.begin());
  system.Magnitudes(e.x, e.magnitudes);
  const double length = t1 - t0;
  double t = t0;
  if (!rhs(t, e.x.data(), e.dxdt.data()))
    return NumericalError("the moment equations are not finite at the interval's start");
  double dt = e.first_step > 0.0 ? std::min(e.first_step, length) : length;
  bool first = true;
  for (long attempt = 0;; ++attempt) {
    if (attempt > kMaxSteps)
      return NumericalError(fmt::format("more than {} steps in one sample interval", kMaxSteps));
    const double left = t1 - t;
    const bool last = dt >= left;
    if (last) dt = left;
    const double dt_tried = dt;
    const double error = TrialStep<N>(rhs, size, e.controlled, options_.atol, options_.rtol, t, dt,
                                      e.x.data(), e.magnitudes.data(), e.dxdt.data(),
                                      e.x_new.data(), e.dxdt_new.data(), e.stages.data());
    if (std::isnan(error)) {  // the trial step left the domain of the model (a sqrt of a
                              // negative level)
      ++counts_.rejected;
      dt = 0.25 * dt_tried;
    } else if (!(error > 1.0)) {
      ++counts_.steps;
      if (step_log_) {
        step_log_->push_back(t);
        step_log_->push_back(dt_tried);
      }
      std::swap(e.x, e.x_new);
      std::swap(e.dxdt, e.dxdt_new);
      dt = NextStep(dt_tried, error);
      if (first) {
        // The next interval begins as this one did (after the filter's update, whose transient
        // sets the first steps): with the step this first step proposes, unless it was cut short
        // to land on t1.
        if (!last || dt_tried >= 0.5 * e.first_step || e.first_step == 0.0) e.first_step = dt;
        first = false;
      }
      if (last) break;
      t += dt_tried;
      system.Magnitudes(e.x, e.magnitudes);
    } else {
      ++counts_.rejected;
      dt = ShorterStep(dt_tried, error);
    }
    if (!(dt > kMinStepFraction * length))
      return NumericalError(
          fmt::format("the step size fell below {:g} of the sample interval", kMinStepFraction));
  }
  std::copy(e.x.begin(), e.x.end(), z.begin());
  return Ok{};
}

Status OdeSolver::AdvanceExplicit(OdeSystem& system, double t0, double t1, std::span<double> z) {
  if (!explicit_) explicit_ = std::make_unique<Explicit>(size_, system.controlled_size());
  switch (size_) {  // the moment equations of 1 to 7 states: n + n (n + 1) / 2
    case 2:
      return AdvanceExplicitSized<2>(system, t0, t1, z);
    case 5:
      return AdvanceExplicitSized<5>(system, t0, t1, z);
    case 9:
      return AdvanceExplicitSized<9>(system, t0, t1, z);
    case 14:
      return AdvanceExplicitSized<14>(system, t0, t1, z);
    case 20:
      return AdvanceExplicitSized<20>(system, t0, t1, z);
    case 27:
      return AdvanceExplicitSized<27>(system, t0, t1, z);
    case 35:
      return AdvanceExplicitSized<35>(system, t0, t1, z);
    default:
      return AdvanceExplicitSized<0>(system, t0, t1, z);
  }
}

// ---- the discrete adjoint of the explicit steps ------------------------------------------------

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
  double rtol = 0.0, atol = 0.0;

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
  // The error weights 1 / (rtol m_i + atol), m the system's magnitudes (OdeSystem::Magnitudes)
  // for its controlled components and |y_i| for the rest: CVODE's own scalar tolerances
  // (CVodeSStolerances) where the magnitudes are |y_i|.
  static int Weights(N_Vector y, N_Vector weights, void* user) {
    Bdf& b = *static_cast<Bdf*>(user);
    const auto n = static_cast<std::size_t>(N_VGetLength(y));
    const double* z = N_VGetArrayPointer(y);
    double* w = N_VGetArrayPointer(weights);
    const auto controlled = static_cast<std::size_t>(b.system->controlled_size());
    b.system->Magnitudes({z, n}, {w, controlled});
    for (std::size_t i = controlled; i < n; ++i) w[i] = std::abs(z[i]);
    for (std::size_t i = 0; i < n; ++i) {
      const double tolerance = b.rtol * w[i] + b.atol;
      if (!(tolerance > 0.0)) return -1;
      w[i] = 1.0 / tolerance;
    }
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
    b.rtol = options_.rtol;
    b.atol = options_.atol;
    if (flag >= 0) flag = CVodeWFtolerances(b.memory, &Bdf::Weights);
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
