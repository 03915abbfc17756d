// Model files (user guide §2): the stochastic differential equation
//
//   dx = f(x, u, θ, t) dt + σ(x, u, θ, t) dω   ω: independent standard Wiener processes, one per
//   state y_k = h(x_{k-d}, u_{k-d}, θ, t) + e_k       e_k ~ N(0, S(u, θ, t)), S diagonal, d =
//   output delay
//
// Drift and observation may use states, inputs, parameters and the time `t` (the data's time
// column; a model that names a state, input or parameter `t` means that one instead). The
// diffusion may use the same names: the filter evaluates it at the filtered mean, as CTSM does
// (core/filter/ekf.h). The measurement variance may use inputs, parameters and `t`; the initial
// state and variances only parameters. A model whose f and h are affine in states and inputs,
// with σ and S free of states, inputs and t, is linear and handled exactly (LinearModel);
// every other model goes through the extended Kalman filter (NonlinearModel, core/filter/ekf.h).
//
// `ModelSpec` is the file, parsed and validated: names, parameters with bounds, and every
// expression parsed (with the JSON path it came from, so later errors can point at it).
// Validation catches everything that can be checked without data: JSON types, unknown or
// duplicated names, expression syntax, unknown names inside expressions (with the column),
// inverted bounds, start values outside their bounds, bad delay ranges, bad option values.
// Whether the model is linear is decided by LinearModel::Compile (core/model/linear_model.h).
//
// Errors: `Error{file, path, expr_col, message}`, e.g.
//   fuel.json: drift.mff, column 15: unknown name 'tauff' (did you mean 'tau_ff'?)
#pragma once

#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "core/expr/expr.h"
#include "core/util/json_fwd.h"
#include "core/util/result.h"

namespace gb::model {

struct Parameter {
  std::string name;
  double value = 0.0;           // start value, or the value of a fixed parameter
  std::optional<double> lower;  // absent: unbounded below
  std::optional<double> upper;  // absent: unbounded above
  bool fixed = false;
  std::string unit;
  std::string description;
  // A Gaussian prior N(mean, sd²) on the natural scale: the fit maximises log L + Σ log N(θ|m, s)
  // (a MAP estimate). Absent: maximum likelihood in this parameter.
  struct Prior {
    double mean = 0.0;
    double sd = 1.0;
    // log N(v | mean, sd²), normalised.
    double LogDensity(double v) const {
      const double r = (v - mean) / sd;
      return -0.5 * r * r - std::log(sd) - 0.5 * std::log(2 * std::numbers::pi);
    }
  };
  std::optional<Prior> prior;
};

// An expression together with where it came from.
struct Formula {
  std::string text;
  expr::ExprPtr expr;
  std::string path;  // JSON path, e.g. "drift.mff"
};

// A fixed output delay (min == max) or a range to scan by profile likelihood.
struct DelaySpec {
  int min = 0;
  int max = 0;
  bool IsScan() const { return max > min; }
};

enum class InputHold { kZoh, kFoh };

// How a nonlinear model is filtered (core/filter/ekf.h); a linear model ignores it. The model
// file's optional "ekf" object: {"ode": "auto" | "explicit" | "bdf", "rtol": 1e-8, "atol": 1e-10,
// "iterations": 1}.
enum class OdeMethod {
  kAuto,      // explicit while the interval is not stiff, BDF where it is (ekf.h says how)
  kExplicit,  // Dormand-Prince 5(4) with error control (Boost.Odeint)
  kBdf,       // variable-order BDF with error control (SUNDIALS CVODE), for stiff models
};
const char* OdeMethodName(OdeMethod m);  // "auto", "explicit", "bdf"
struct EkfOptions {
  OdeMethod method = OdeMethod::kAuto;
  double rtol = 1e-8;   // relative tolerance of the moment equations
  double atol = 1e-10;  // absolute tolerance (in the states' units, and their squares for P)
  int iterations = 1;   // measurement update: 1 = the EKF, k > 1 = the iterated EKF (k passes)
  bool operator==(const EkfOptions&) const = default;
};
enum class InitialCovariance { kCtsm, kStationary, kExplicit };

struct ModelSpec {
  std::string source;  // file the model came from ("" if not from a file)
  std::string name;
  std::vector<std::string> states;
  std::vector<std::string> inputs;
  std::vector<std::string> outputs;
  std::vector<Parameter> parameters;  // in file order; θ vectors use this order

  std::vector<Formula> drift;                 // one per state
  std::vector<Formula> diffusion;             // one per state ("0" where the file gives none)
  std::vector<Formula> observation;           // one per output
  std::vector<Formula> measurement_variance;  // one per output
  std::vector<Formula> initial_state;         // one per state ("0" where the file gives none)
  InitialCovariance initial_covariance = InitialCovariance::kCtsm;
  std::vector<Formula> initial_variance;  // one per state when kExplicit (variances)
  std::vector<DelaySpec> output_delay;    // one per output (0 where the file gives none)
  InputHold input_hold = InputHold::kZoh;
  std::optional<double> robust_huber;  // Huber threshold c > 0; absent: Gaussian
  EkfOptions ekf;                      // nonlinear models only

  int ParameterIndex(const std::string& name) const;  // -1 if absent
  int StateIndex(const std::string& name) const;
  int InputIndex(const std::string& name) const;
  int OutputIndex(const std::string& name) const;
  // Start (or fixed) values of all parameters, in order.
  std::vector<double> Values() const;
  bool HasDelayScan() const;
};

// Parses and validates a model object. `source` names the file in errors.
Result<ModelSpec> ParseModel(const Json& j, const std::string& source);
// Reads and parses a model file.
Result<ModelSpec> LoadModelFile(const std::string& path);
// The model as a JSON object that ParseModel reads back to an equal model.
Json ToJson(const ModelSpec& m);
// The "parameters" object of a model file for `parameters` (file order kept).
Json ParametersToJson(const std::vector<Parameter>& parameters);
// Writes the model atomically (pretty-printed JSON).
Status SaveModelFile(const ModelSpec& m, const std::string& path);

// Applies `NAME=VALUE` overrides (the command line's --set). Errors: unknown parameter (with a
// suggestion), a value that is not a number. A value outside the bounds is allowed for a fixed
// parameter and refused for a free one.
Status SetParameter(ModelSpec* m, const std::string& name, double value);

// Whether `s` is an identifier ([A-Za-z_][A-Za-z0-9_]*), as names in a model must be.
bool IsIdentifier(const std::string& s);
// Whether `s` names a function of the expression language (exp, log, ..., and the internal sign),
// which no state, input, output or parameter may be called.
bool IsFunctionName(const std::string& s);

// The closest name in `candidates` to `name` by edit distance, if close enough to suggest.
std::optional<std::string> Suggest(const std::string& name,
                                   const std::vector<std::string>& candidates);

}  // namespace gb::model
