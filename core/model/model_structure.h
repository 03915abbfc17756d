// Edits of a model's structure, as pure functions on the model file's JSON (section 2 of the
// user guide): adding, renaming and deleting states, inputs, outputs and parameters; the
// model's name, input hold and initial covariance; a parameter's unit, description and prior;
// and two models to start from (a blank one, and one generated from a dataset's columns).
//
// Every function returns the edited JSON only when ParseModel accepts it, and otherwise an Error
// whose message says what is wrong in the user's words ("cannot delete parameter 'k': drift.T
// uses it"). The JSON is edited where it stands: keys the parser does not model ("description",
// "time_unit") and every formula the edit does not concern keep their text, and a rename rewrites
// a formula only where a whole name is the renamed one (k, not k1; `exp(k)` becomes `exp(k2)`;
// the digits of `1e5` are never a name).
//
// Names: states, inputs and parameters share one namespace (a formula cannot tell them apart);
// outputs are data columns and may share a state's name but not an input's. A name is an
// identifier ([A-Za-z_][A-Za-z0-9_]*) that is not a function of the expression language (exp,
// log, ...). `t` is the time unless something is named `t`, so a state, input or parameter is
// not given the name `t` while a formula uses the time.
//
// What an added name brings with it:
//   state x     drift.x = "0", diffusion.x = "0", initial_state.x = "0" (and, with an explicit
//               initial covariance, initial_covariance.x = "1"); the user writes the formulas.
//   input u     nothing: it is a data column that formulas may now use.
//   output y    observation.y = the first state ("0" when the model has none: it always has one),
//               measurement_variance.y = "1".
//   parameter   the Parameter given (value, bounds, fixed, unit, description, prior).
// A deleted state takes its drift, diffusion, initial state and initial variance with it; a
// deleted output its observation, measurement variance and delay. A delete is refused while
// another formula names the deleted name, and so is deleting the last state or output (a model
// has at least one of each).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/model/model.h"
#include "core/util/json_fwd.h"
#include "core/util/result.h"

namespace gb::model {

enum class NameKind { kState, kInput, kOutput, kParameter };
const char* NameKindText(NameKind kind);  // "state", "input", "output", "parameter"

// Every name of `kind` in the model JSON, in file order (empty when the key is missing).
std::vector<std::string> NamesOf(const Json& model, NameKind kind);

// Why `name` cannot be a new name of `kind` in `model` ("" when it can): empty, not an
// identifier, a function's name, already taken, or `t` while a formula uses the time.
// `except` is a name of the same kind that is being renamed (it does not count as taken).
std::string NameProblem(const Json& model, NameKind kind, const std::string& name,
                        const std::string& except = "");

// `text` with every whole name `from` replaced by `to`, everything else as it was. Numbers
// (1e5, 2.5E-3) are skipped as the expression lexer reads them.
std::string RenameInFormula(const std::string& text, const std::string& from,
                            const std::string& to);

// The JSON paths of the formulas that name `name`, in file order ("drift.T",
// "measurement_variance.y"); `t`, the time, counts as a name.
std::vector<std::string> FormulasUsing(const Json& model, const std::string& name);

// Adds a state, input or output with the formulas above (not a parameter: AddParameter).
Result<Json> AddName(const Json& model, NameKind kind, const std::string& name);
// Adds `parameter` at the end of "parameters".
Result<Json> AddParameter(const Json& model, const Parameter& parameter);
// Renames `from` to `to`: the list entry (a parameter keeps its place), the keys of its own
// formulas (drift, diffusion, initial_state, initial_covariance for a state; observation,
// measurement_variance, output_delay for an output) and, for a state, input or parameter,
// every formula that names it.
Result<Json> RenameName(const Json& model, NameKind kind, const std::string& from,
                        const std::string& to);
// Deletes `name` and its own formulas; refused while another formula names it.
Result<Json> DeleteName(const Json& model, NameKind kind, const std::string& name);

// The model's "name" (any text; "" removes the key).
Result<Json> SetModelName(const Json& model, const std::string& name);
Result<Json> SetInputHold(const Json& model, InputHold hold);
// kCtsm and kStationary write the word; kExplicit an object of per-state variances, keeping the
// ones already there and "1" for the others.
Result<Json> SetInitialCovariance(const Json& model, InitialCovariance mode);
// A parameter's "unit" or "description" ("" removes it).
enum class ParameterText { kUnit, kDescription };
Result<Json> SetParameterText(const Json& model, const std::string& parameter, ParameterText field,
                              const std::string& text);
// A parameter's prior (absent: removed).
Result<Json> SetParameterPrior(const Json& model, const std::string& parameter,
                               const std::optional<Parameter::Prior>& prior);

// The blank model the workbench starts from: the smallest model that parses, a random walk
// observed with noise,
//   dx = 0 dt + sigma_x dω,   y_k = x_k + e_k,   e_k ~ N(0, sigma_y^2),   x(t0) = 0,
// with sigma_x = sigma_y = 0.1 in [0, 100]. The user renames x and y, adds inputs and writes
// the drift. `name` becomes the model's name.
Json BlankModel(const std::string& name);

// What the generated model knows about a column: its name and, when known, its first value and
// standard deviation (for start values); `duration` is the data's time span in its time unit.
struct ColumnSummary {
  std::string name;
  std::optional<double> first;
  std::optional<double> sd;
};
struct ColumnsModelRequest {
  std::string name;                    // the model's name
  std::vector<ColumnSummary> inputs;   // one input each
  std::vector<ColumnSummary> outputs;  // at least one; one output and one state each
  std::optional<double> duration;
};
// A first-order start for data with these columns: for each output y (state x_y, in that
// column's order), with inputs u1..un,
//   dx_y = (-x_y + b_y_u1*u1 + ... + b_y_un*un)/tau_y dt + sigma_y dω
//   y_k  = x_y + e_k,   e_k ~ N(0, e_y^2),   x_y(t0) = x0_y
// Starts: tau_y = duration/10 (1 without one) in [tau/1000, tau*1000]; the gains 0, unbounded;
// x0_y = the output's first value (0 without one), unbounded; sigma_y and e_y = sd/10 in
// [0, 100 sd] (sd = 1 without one). Refused when a column's name cannot name an input or output
// (it is not an identifier, a function's name, or listed twice); the message names the column.
Result<Json> ModelFromColumns(const ColumnsModelRequest& request);

}  // namespace gb::model
