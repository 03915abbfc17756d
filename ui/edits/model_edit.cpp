#include "ui/edits/model_edit.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <utility>

#include <fmt/format.h>

#include "core/model/linear_model.h"
#include "core/model/nonlinear_model.h"
#include "core/util/json.h"

namespace gb::ui {
namespace {

std::string Trim(const std::string& text) {
  const std::size_t a = text.find_first_not_of(" \t");
  if (a == std::string::npos) return "";
  const std::size_t b = text.find_last_not_of(" \t");
  return text.substr(a, b - a + 1);
}

// The model a formula edit or a structure edit leaves must compile for one of the filters: the
// exact one when it is linear, else the extended one.
Status Compiles(const model::ModelSpec& spec) {
  if (model::LinearModel::Compile(spec)) return Ok{};
  Result<model::NonlinearModel> nonlinear = model::NonlinearModel::Compile(spec);
  if (!nonlinear) return nonlinear.error();
  return Ok{};
}

// Round-trips the edited model through the file format's validation.
Result<model::ModelSpec> Validate(const model::ModelSpec& edited) {
  Result<model::ModelSpec> parsed = model::ParseModel(model::ToJson(edited), edited.source);
  if (!parsed) return InputError(parsed.error().message);
  return parsed;
}

}  // namespace

std::string_view FieldText(ParameterField field) {
  switch (field) {
    case ParameterField::kValue:
      return "start value";
    case ParameterField::kLower:
      return "lower bound";
    case ParameterField::kUpper:
      return "upper bound";
    case ParameterField::kFixed:
      return "fixed";
  }
  return "";
}

Result<ParameterEdit> ParseParameterEdit(const std::string& parameter, ParameterField field,
                                         const std::string& text) {
  ParameterEdit edit;
  edit.parameter = parameter;
  edit.field = field;
  edit.text = text;
  const std::string t = Trim(text);
  if (t.empty()) {
    if (field == ParameterField::kValue) return InputError("a start value is required");
    return edit;  // no bound
  }
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  if (end == t.c_str() || *end != '\0') return InputError("'" + t + "' is not a number");
  if (errno == ERANGE || !std::isfinite(v)) return InputError("'" + t + "' is not a finite number");
  edit.number = v;
  return edit;
}

Result<model::ModelSpec> ApplyParameterEdit(const model::ModelSpec& spec,
                                            const ParameterEdit& edit) {
  const int i = spec.ParameterIndex(edit.parameter);
  if (i < 0) return InputError("the model has no parameter '" + edit.parameter + "'");
  model::ModelSpec edited = spec;
  model::Parameter& p = edited.parameters[static_cast<std::size_t>(i)];
  switch (edit.field) {
    case ParameterField::kValue:
      if (!edit.number) return InputError("a start value is required");
      p.value = *edit.number;
      break;
    case ParameterField::kLower:
      p.lower = edit.number;
      break;
    case ParameterField::kUpper:
      p.upper = edit.number;
      break;
    case ParameterField::kFixed:
      p.fixed = edit.fixed;
      break;
  }
  return Validate(edited);
}

Result<model::ModelSpec> ApplyFormulaEdit(const model::ModelSpec& spec, const FormulaEdit& edit) {
  const std::size_t dot = edit.path.find('.');
  const std::string section = edit.path.substr(0, dot);
  const std::string name = dot == std::string::npos ? "" : edit.path.substr(dot + 1);
  const bool of_state = section == "drift" || section == "diffusion" ||
                        section == "initial_state" ||
                        (section == "initial_covariance" &&
                         spec.initial_covariance == model::InitialCovariance::kExplicit);
  const bool of_output = section == "observation" || section == "measurement_variance";
  const bool option = section == "ekf" &&
                      (name == "ode" || name == "rtol" || name == "atol" || name == "iterations");
  const std::vector<std::string>& names = of_state ? spec.states : spec.outputs;
  if (!option &&
      ((!of_state && !of_output) || std::find(names.begin(), names.end(), name) == names.end())) {
    return InputError("'" + edit.path + "' is not a formula of the model");
  }
  Result<Json> value = FormulaEditValue(edit);
  if (!value) return value.error();
  Json j = model::ToJson(spec);
  j[section][name] = *value;
  // The parser's Error as it is: its path and expression column point into edit.text.
  Result<model::ModelSpec> parsed = model::ParseModel(j, spec.source);
  if (!parsed) return parsed;
  // A formula that parses compiles for one of the filters (the extended one refuses only
  // expressions too deep to compile).
  if (Status s = Compiles(*parsed); !s) return s.error();
  return parsed;
}

Result<Json> FormulaEditValue(const FormulaEdit& edit) {
  if (edit.path != "ekf.rtol" && edit.path != "ekf.atol" && edit.path != "ekf.iterations")
    return Json(edit.text);
  std::string t = edit.text;
  while (!t.empty() && std::isspace(static_cast<unsigned char>(t.back()))) t.pop_back();
  while (!t.empty() && std::isspace(static_cast<unsigned char>(t.front()))) t.erase(t.begin());
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(t.c_str(), &end);
  Error bad = InputError("'" + edit.text + "' is not a number");
  bad.path = edit.path;
  if (t.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v)) return bad;
  if (edit.path == "ekf.iterations") {
    if (v != std::floor(v) || std::abs(v) > 1e9) {
      bad.message = "'" + edit.text + "' is not a whole number";
      return bad;
    }
    return Json(static_cast<long>(v));
  }
  return Json(v);
}

namespace {

Result<Json> EditJson(const Json& j, const StructureEdit& e) {
  switch (e.kind) {
    case StructureEditKind::kAdd:
      return model::AddName(j, e.what, e.name);
    case StructureEditKind::kRename:
      return model::RenameName(j, e.what, e.name, e.text);
    case StructureEditKind::kDelete:
      return model::DeleteName(j, e.what, e.name);
    case StructureEditKind::kAddParameter:
      return model::AddParameter(j, e.parameter);
    case StructureEditKind::kModelName:
      return model::SetModelName(j, e.text);
    case StructureEditKind::kInputHold:
      return model::SetInputHold(j, e.hold);
    case StructureEditKind::kInitialCovariance:
      return model::SetInitialCovariance(j, e.covariance);
    case StructureEditKind::kParameterUnit:
      return model::SetParameterText(j, e.name, model::ParameterText::kUnit, e.text);
    case StructureEditKind::kParameterDescription:
      return model::SetParameterText(j, e.name, model::ParameterText::kDescription, e.text);
    case StructureEditKind::kParameterPrior:
      return model::SetParameterPrior(j, e.name, e.prior);
  }
  return InputError("unknown edit");
}

Result<double> ReadNumber(const std::string& what, const std::string& text) {
  const std::string t = Trim(text);
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  if (t.empty() || end == t.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(v))
    return InputError("the prior's " + what + " '" + t + "' is not a number");
  return v;
}

}  // namespace

Result<EditedModel> ApplyStructureEdit(const Json& model_json, const std::string& source,
                                       const StructureEdit& edit) {
  Result<Json> j = EditJson(model_json, edit);
  if (!j) return j.error();
  Result<model::ModelSpec> spec = model::ParseModel(*j, source);
  if (!spec) return spec.error();
  if (Status s = Compiles(*spec); !s) return s.error();
  return EditedModel{std::move(*j), std::move(*spec)};
}

Result<std::optional<model::Parameter::Prior>> ParsePrior(const std::string& mean,
                                                          const std::string& sd) {
  if (Trim(mean).empty() && Trim(sd).empty()) return std::optional<model::Parameter::Prior>();
  Result<double> m = ReadNumber("mean", mean);
  if (!m) return m.error();
  Result<double> s = ReadNumber("sd", sd);
  if (!s) return s.error();
  if (!(*s > 0)) return InputError("the prior's sd must be > 0");
  return std::optional<model::Parameter::Prior>(model::Parameter::Prior{*m, *s});
}

std::optional<std::string> UnknownName(const Error& error) {
  static const std::string kPrefix = "unknown name '";
  if (error.message.rfind(kPrefix, 0) != 0) return std::nullopt;
  const std::size_t end = error.message.find('\'', kPrefix.size());
  if (end == std::string::npos) return std::nullopt;
  return error.message.substr(kPrefix.size(), end - kPrefix.size());
}

Result<model::ModelSpec> UseEstimatesAsStart(const model::ModelSpec& spec,
                                             const estimate::EstimateSummary& summary,
                                             std::size_t optimum) {
  if (optimum > 0 && (optimum >= summary.optima.size() ||
                      summary.optima[optimum].theta.size() != summary.parameters.size()))
    return InputError(fmt::format("the fit has no optimum number {}", optimum + 1));
  model::ModelSpec edited = spec;
  for (std::size_t k = 0; k < summary.parameters.size(); ++k) {
    const estimate::ParameterEstimate& e = summary.parameters[k];
    const double value = optimum > 0 ? summary.optima[optimum].theta[k] : e.estimate;
    if (e.fixed || !std::isfinite(value)) continue;
    const int i = edited.ParameterIndex(e.name);
    if (i < 0 || edited.parameters[static_cast<std::size_t>(i)].fixed) continue;
    if (Status set = model::SetParameter(&edited, e.name, value); !set) {
      return InputError(e.name + ": " + set.error().message);
    }
  }
  return Validate(edited);
}

}  // namespace gb::ui
