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
// "observation.O", "measurement_variance.O" for an output O; or one of the EKF's options,
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

// The model with every free parameter's start value set to its estimate in `summary` (matched
// by name; fixed parameters and names the fit does not know are left alone); with `optimum` > 0,
// to its value at that one of the summary's distinct optima (EstimateSummary::optima) instead.
Result<model::ModelSpec> UseEstimatesAsStart(const model::ModelSpec& spec,
                                             const estimate::EstimateSummary& summary,
                                             std::size_t optimum = 0);

}  // namespace gb::ui
