// Start values from the records' steady states, for a nonlinear model whose starts are far off.
//
// Far from the optimum the extended Kalman filter explains a wrong drift with noise: a flow 27 %
// low makes every innovation large, and maximum likelihood then moves the variances and the
// parameters that can absorb a level (a film's diffusion, an efficiency on its bound) before the
// ones that are wrong; the fit settles in another basin (docs/case-study-mvem.md). What the
// records pin without any filter are their levels. Each record is cut into windows (5 s); in
// each, the mean of the inputs ū and of the outputs ȳ. For θ the model's steady state at ū,
// f(x, ū, θ) = 0, gives outputs h(x, ū, θ), and the start is
//
//   θ̂_s = argmin Σ_windows Σ_outputs ((h_o(x_ss(θ, ū_w), ū_w, θ) − ȳ_wo) / s_o)²
//
// over the free parameters the steady states depend on (found by perturbing each: time
// constants, volumes, inertias, delays and every noise parameter do not move a steady state and
// keep their starts), s_o the standard deviation of output o over the records. Levenberg-
// Marquardt within the bounds, with the Jacobian from forward differences; each window's steady
// state is solved by damped Newton from its last solution (model::SteadyStateSolver).
//
// The windows are not steady (inputs carry PRBS, records ramp between points), so the levels are
// those of a nearly linear response around each window's mean: a start, not an estimate. Windows
// whose steady state cannot be found at the starts are left out (and counted).
//
// Levels fix some combinations of the parameters and not others (an engine's efficiency and
// friction, when fuel and speed rise together along λ = 1): at the minimum, a combination whose
// standard error (σ / s_i for the scaled Jacobian's singular value s_i, σ the residuals'
// standard deviation) is above `determined` of the starts is not moved; the fit is repeated from
// the starts along the determined combinations only, and the report counts the others.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/data/dataset.h"
#include "core/filter/likelihood.h"
#include "core/model/nonlinear_model.h"
#include "core/util/json_fwd.h"
#include "core/util/result.h"

namespace gb::estimate {

struct SteadyStartOptions {
  double window_seconds = 5.0;
  int max_iterations = 100;  // Levenberg-Marquardt iterations (each pass)
  // A combination of the parameters is moved when the levels fix it to within this fraction of
  // the starts (its standard error on the scale θ / |start|); the others keep the starts.
  double determined = 0.05;
};

struct SteadyStartResult {
  std::vector<double> theta;  // all parameters: the fitted ones moved, the others as given
  struct Moved {
    std::string name;
    double from = 0.0, to = 0.0;
  };
  std::vector<Moved> fitted;  // the free parameters the steady states depend on, in model order
  double window_seconds = 0.0;
  int windows = 0;            // windows used
  int windows_left_out = 0;   // without a steady state at the starts
  double misfit_start = 0.0;  // RMS of the scaled residuals at the starts
  double misfit = 0.0;        // ... and at the result
  int iterations = 0;
  // Combinations of the fitted parameters the levels left undetermined (kept at the starts).
  int undetermined = 0;
  // "Steady-state start: 5 parameters from 36 windows of length 5, scaled RMS misfit 1.98 ->
  // 0.2094 (14 iterations), 2 combinations of them left at the starts (the levels do not fix
  // them): Cth 100 -> 136.892, ..." (one line, no newline)
  std::string Report() const;
  Json ToJson() const;
};

// Fails when the model has no free parameter the steady states depend on, or no window has a
// steady state at the starts (the message names the first such window and why).
Result<SteadyStartResult> SteadyStart(
    const model::NonlinearModel& model, std::span<const double> theta,
    const std::vector<std::shared_ptr<const data::Series>>& series,
    const SteadyStartOptions& options = {});
// The same on a likelihood's model and records at θ (a linear model is compiled as a nonlinear
// one for it).
Result<SteadyStartResult> SteadyStart(const filter::Likelihood& likelihood,
                                      std::span<const double> theta,
                                      const SteadyStartOptions& options = {});

}  // namespace gb::estimate
