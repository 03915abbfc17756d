// Edits of the model's parameters as the Parameters view emits them, applied through core:
// the edited model is written with model::ToJson and read back with model::ParseModel, so an
// edit is accepted exactly when the same change made in the model file would be, and refused
// with the parser's reason otherwise ("the start value 2 is outside the bounds [0.005, 1]").
// Pure functions of a ModelSpec; AppState applies the result (ApplyParameterEdits).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/estimate/estimate.h"
#include "core/model/model.h"
#include "core/model/model_structure.h"
#include "core/util/json.h"
#include "core/util/result.h"

namespace gb::ui {

enum class ParameterField { kValue, kLower, kUpper, kFixed };
std::string_view FieldText(ParameterField field);  // "start value", "lower bound", ...

struct ParameterEdit {
  std::string parameter;
  ParameterField field = ParameterField::kValue;
  std::optional<double> number;  // value / lower / upper; absent lower/upper: unbounded
  bool fixed = false;            // kFixed
  std::string text;              // as the user typed it (for messages)
};

// Reads what the user typed into a value or bound cell: a number ("1e-3"), or for a bound an
// empty cell (no bound). Refuses anything else with a reason.
Result<ParameterEdit> ParseParameterEdit(const std::string& parameter, ParameterField field,
                                         const std::string& text);

// The model with the edit applied, or why the edit is refused (the message only; the caller
// knows which cell it came from).
Result<model::ModelSpec> ApplyParameterEdit(const model::ModelSpec& spec,
                                            const ParameterEdit& edit);

// An edit of one formula of the model, as the Equations view emits it. `path` is the formula's
// JSON path in the model file: "drift.S", "diffusion.S", "initial_state.S" for a state S,
// "observation.O", "measurement_variance.O" for an output O, "initial_covariance.S" when the
// initial covariance is explicit; or one of the EKF's options,
// "ekf.ode" (auto, explicit, bdf), "ekf.rtol", "ekf.atol" (numbers), "ekf.iterations" (a whole
// number), with the text as the user typed it.
struct FormulaEdit {
  std::string path;
  std::string text;  // the new expression
};

// The model with the formula at edit.path replaced, validated exactly as the model file would
// be; refused with the parser's Error otherwise (Error::path names the formula and
// Error::expr_col the 1-based column in edit.text where the expression is wrong).
Result<model::ModelSpec> ApplyFormulaEdit(const model::ModelSpec& spec, const FormulaEdit& edit);

// The JSON value the edit writes at its path (a string for a formula and for ekf.ode, a number
// for the other options); refused when an option's text is not a number.
Result<Json> FormulaEditValue(const FormulaEdit& edit);

// A change of the model's structure or options, as the Equations view emits it: applied to the
// project's model JSON by core/model/model_structure.h, and accepted when the result parses and
// compiles for one of the filters (as a formula edit is).
enum class StructureEditKind {
  kAdd,                   // a state, input or output `name` (`what`)
  kRename,                // `name` (`what`) to `text`
  kDelete,                // `name` (`what`)
  kAddParameter,          // `parameter`
  kModelName,             // `text`
  kInputHold,             // `hold`
  kInitialCovariance,     // `covariance`
  kParameterUnit,         // of parameter `name`: `text` ("" removes it)
  kParameterDescription,  // of parameter `name`: `text` ("" removes it)
  kParameterPrior,        // of parameter `name`: `prior` (absent removes it)
};
struct StructureEdit {
  StructureEditKind kind = StructureEditKind::kAdd;
  model::NameKind what = model::NameKind::kParameter;
  std::string name;
  std::string text;
  model::Parameter parameter;
  model::InputHold hold = model::InputHold::kZoh;
  model::InitialCovariance covariance = model::InitialCovariance::kCtsm;
  std::optional<model::Parameter::Prior> prior;
  // The control the edit came from (e.g. "parameters.k.unit", "add.state"): a refusal is shown
  // beside it.
  std::string control;
};

// The edited model file and the model it parses to.
struct EditedModel {
  Json json;
  model::ModelSpec spec;
};
// `model_json` with the edit applied (`source` names the model in the parser's errors), or why
// the edit is refused ("cannot delete parameter 'k': drift.T uses it").
Result<EditedModel> ApplyStructureEdit(const Json& model_json, const std::string& source,
                                       const StructureEdit& edit);

// Reads a prior typed as its mean and sd: both empty is no prior; otherwise both must be
// numbers and sd > 0.
Result<std::optional<model::Parameter::Prior>> ParsePrior(const std::string& mean,
                                                          const std::string& sd);

// The name an "unknown name 'k0'" refusal of the model's parser is about, if it is one.
std::optional<std::string> UnknownName(const Error& error);

// The model with every free parameter's start value set to its estimate in `summary` (matched
// by name; fixed parameters and names the fit does not know are left alone); with `optimum` > 0,
// to its value at that one of the summary's distinct optima (EstimateSummary::optima) instead.
Result<model::ModelSpec> UseEstimatesAsStart(const model::ModelSpec& spec,
                                             const estimate::EstimateSummary& summary,
                                             std::size_t optimum = 0);

}  // namespace gb::ui
