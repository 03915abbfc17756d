// The linearised model of a nonlinear one at an operating point (the paper's eq. 13-16 are such
// linearisations of the mean-value engine):
//
//   d(δx) = (A δx + B δu) dt,   δy = C δx + D δu,   A = ∂f/∂x, B = ∂f/∂u, C = ∂h/∂x, D = ∂h/∂u
//
// at a steady state (f = 0). The operating point is given by values of some states, inputs and
// outputs ("N=2931,alpha=29.5,ilambda=1"); the other states and inputs are solved for from f = 0
// and h_o = value for each output given (exactly as many unknowns as equations: the number of
// states plus the outputs given). A, B, C and D are the symbolic derivatives (expr::Differentiate)
// evaluated there.
//
// Quantities: named expressions of the entries (A_p_n is ∂f_p/∂n, B_mff_mfi, C_ilambda_mfv, ...),
// of the point's states, inputs and outputs, and of the parameters, e.g. the fuel film's
// "tau_ff": "-1/A_mff_mff" or "Kb": "-C_ilambda_mfv" (the Padé approximant of the delay passes -v
// straight through); they name what a linear model fitted at one point estimates, so that the two
// can be compared.
//
// Uncertainty (the delta method): with the covariance Σ of the free parameters' estimates, each
// entry and quantity g gets the standard error sqrt(∇g' Σ ∇g), ∇g by central differences of the
// whole chain (steady state, derivatives, quantity) in each free parameter.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/model/nonlinear_model.h"
#include "core/util/result.h"

namespace gb::model {

// NAME=VALUE pairs naming states, inputs or outputs of `spec`. Errors say which item is wrong
// (an empty text or item, an unknown name, with a suggestion; a value that is not a finite
// number; a name given twice).
Result<std::vector<std::pair<std::string, double>>> ParseOperatingPoint(const std::string& text,
                                                                        const ModelSpec& spec);

struct Quantity {
  std::string name;
  std::string text;  // the expression
};
// NAME=EXPRESSION: NAME letters, digits and _ (not first a digit); the expression may itself
// contain '=' nowhere and names what is described above. Errors: no '=', a NAME that is not a
// name, an empty or unparsable expression.
Result<Quantity> ParseQuantity(const std::string& text);

struct Linearisation {
  Eigen::VectorXd x, u, y;  // the steady state, its inputs and outputs
  Eigen::MatrixXd A, B, C, D;
  std::vector<double> quantities;  // in the order asked for
  // With a covariance: the standard errors of each entry and quantity (NaN without one).
  Eigen::MatrixXd se_A, se_B, se_C, se_D;
  Eigen::VectorXd se_x, se_u;
  std::vector<double> se_quantities;
};

struct LinearisationOptions {
  std::vector<Quantity> quantities;
  // The covariance of the free parameters' estimates (natural scale), in the order of `free`
  // (indices into the model's parameters). Empty: no standard errors.
  std::vector<int> free;
  Eigen::MatrixXd covariance;
};

// Ok, or an input Error naming the first drift or observation formula (file and JSON path) that
// uses the time t: a model that changes with time has no steady state (f = 0 would hold at one
// time, not at all times).
Status CheckTimeInvariant(const ModelSpec& spec);

// The steady state and its linearisation at θ (all parameters, natural scale). Fails (input
// Errors) when the model's drift or observation uses the time t (a model that changes with time
// has no steady state; the Error names the formula), when the point does not fix the right number
// of values, when no steady state is found (the message says how close it came), or when a
// quantity does not compile (unknown name, with a suggestion) or is named twice; and (a numerical
// Error) when a value of the result or, with a covariance, a standard error is not finite (NaN or
// ±inf: a quantity that divides by 0 at the point), naming it.
Result<Linearisation> Linearise(const NonlinearModel& model, std::span<const double> theta,
                                const std::vector<std::pair<std::string, double>>& point,
                                const LinearisationOptions& options = {});

// Steady states f(x, u, θ) = 0 with every input given, for many inputs and parameter values:
// the derivatives are compiled once, and each solve is Linearise's damped Newton from a guess
// (the last solution at a nearby point is a good one). Make refuses a model whose drift or
// observation uses the time t, as Linearise does.
class SteadyStateSolver {
 public:
  static Result<SteadyStateSolver> Make(const NonlinearModel& model);
  SteadyStateSolver(SteadyStateSolver&&) noexcept;
  SteadyStateSolver& operator=(SteadyStateSolver&&) noexcept;
  ~SteadyStateSolver();

  // The model's initial state at θ: a first guess.
  Eigen::VectorXd InitialState(std::span<const double> theta) const;
  // The steady state from `guess` at inputs u and parameters θ (all, natural scale), and with
  // `y` the outputs h(x, u, θ) there. Fails when Newton finds none (the message says how close
  // it came) or the equations are singular there.
  Result<Eigen::VectorXd> Solve(std::span<const double> theta, const Eigen::VectorXd& u,
                                const Eigen::VectorXd& guess, Eigen::VectorXd* y = nullptr);

 private:
  struct Impl;
  explicit SteadyStateSolver(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace gb::model
