// Sections: 1. names in formulas  2. checks  3. add, rename, delete  4. options and parameter
//           fields  5. models to start from
#include "core/model/model_structure.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <functional>

#include <fmt/format.h>

#include "core/util/json.h"

namespace gb::model {
namespace {

// The formula maps of a model file, keyed by state or output.
constexpr const char* kStateFormulas[] = {"drift", "diffusion", "initial_state",
                                          "initial_covariance"};
constexpr const char* kOutputKeys[] = {"observation", "measurement_variance", "output_delay"};
constexpr const char* kFormulaMaps[] = {"drift",         "diffusion",
                                        "observation",   "measurement_variance",
                                        "initial_state", "initial_covariance"};
constexpr const char* kTheTime = "t";

const char* ListKey(NameKind kind) {
  switch (kind) {
    case NameKind::kState:
      return "states";
    case NameKind::kInput:
      return "inputs";
    case NameKind::kOutput:
      return "outputs";
    case NameKind::kParameter:
      return "parameters";
  }
  return "";
}

// ---- 1. names in formulas --------------------------------------------------------------------

bool IsDigit(char c) { return c >= '0' && c <= '9'; }
bool IsNameStart(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool IsNameChar(char c) { return IsNameStart(c) || IsDigit(c); }

// Calls visit(start, length) for every name in `text`, reading numbers as core/expr's lexer does
// (digits ['.' digits] [e|E [+|-] digits]), so the `e5` of `1e5` is not a name.
void ForEachName(const std::string& text,
                 const std::function<void(std::size_t, std::size_t)>& visit) {
  const auto at = [&](std::size_t i) { return i < text.size() ? text[i] : '\0'; };
  std::size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    if (IsDigit(c) || (c == '.' && IsDigit(at(i + 1)))) {
      while (IsDigit(at(i))) ++i;
      if (at(i) == '.') {
        ++i;
        while (IsDigit(at(i))) ++i;
      }
      if (at(i) == 'e' || at(i) == 'E') {
        std::size_t j = i + 1;
        if (at(j) == '+' || at(j) == '-') ++j;
        if (IsDigit(at(j))) {
          i = j;
          while (IsDigit(at(i))) ++i;
        }
      }
      continue;
    }
    if (IsNameStart(c)) {
      const std::size_t start = i;
      while (IsNameChar(at(i))) ++i;
      visit(start, i - start);
      continue;
    }
    ++i;
  }
}

bool FormulaNames(const Json& value, const std::string& name) {
  if (!value.is_string()) return false;
  const std::string& text = value.get_ref<const std::string&>();
  bool found = false;
  ForEachName(text, [&](std::size_t start, std::size_t n) {
    found = found || (n == name.size() && text.compare(start, n, name) == 0);
  });
  return found;
}

// A copy of `object` with the key `from` renamed `to` in its place.
Json RenameKey(const Json& object, const std::string& from, const std::string& to) {
  Json out = Json::object();
  for (auto it = object.begin(); it != object.end(); ++it)
    out[it.key() == from ? to : it.key()] = it.value();
  return out;
}

// ---- 2. checks -------------------------------------------------------------------------------

// The edited model if ParseModel accepts it, else the parser's reason.
Result<Json> Checked(Json edited) {
  Result<ModelSpec> parsed = ParseModel(edited, "");
  if (!parsed) return InputError(parsed.error().ToString());
  return edited;
}

Result<Json> Refuse(const std::string& message) { return InputError(message); }

// "drift.T", "drift.T and diffusion.T", "drift.T, diffusion.T and 2 more".
std::string ListPaths(const std::vector<std::string>& paths) {
  if (paths.size() == 1) return paths[0];
  if (paths.size() == 2) return paths[0] + " and " + paths[1];
  return fmt::format("{}, {} and {} more", paths[0], paths[1], paths.size() - 2);
}

bool Contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

// The formula paths that belong to `name` itself (deleted with it).
bool OwnFormula(NameKind kind, const std::string& name, const std::string& path) {
  const std::size_t dot = path.find('.');
  if (path.substr(dot + 1) != name) return false;
  const std::string section = path.substr(0, dot);
  if (kind == NameKind::kState)
    return std::any_of(std::begin(kStateFormulas), std::end(kStateFormulas),
                       [&](const char* k) { return section == k; });
  if (kind == NameKind::kOutput)
    return std::any_of(std::begin(kOutputKeys), std::end(kOutputKeys),
                       [&](const char* k) { return section == k; });
  return false;
}

// "a state", "an input".
std::string WithArticle(NameKind kind) {
  const std::string what = NameKindText(kind);
  return (kind == NameKind::kInput || kind == NameKind::kOutput ? "an " : "a ") + what;
}

}  // namespace

const char* NameKindText(NameKind kind) {
  switch (kind) {
    case NameKind::kState:
      return "state";
    case NameKind::kInput:
      return "input";
    case NameKind::kOutput:
      return "output";
    case NameKind::kParameter:
      return "parameter";
  }
  return "";
}

std::vector<std::string> NamesOf(const Json& model, NameKind kind) {
  std::vector<std::string> names;
  if (!model.is_object() || !model.contains(ListKey(kind))) return names;
  const Json& list = model[ListKey(kind)];
  if (kind == NameKind::kParameter) {
    if (list.is_object())
      for (auto it = list.begin(); it != list.end(); ++it) names.push_back(it.key());
    return names;
  }
  if (list.is_array())
    for (const Json& v : list)
      if (v.is_string()) names.push_back(v.get<std::string>());
  return names;
}

std::string NameProblem(const Json& model, NameKind kind, const std::string& name,
                        const std::string& except) {
  const char* what = NameKindText(kind);
  if (name.empty()) return fmt::format("a {} needs a name", what);
  if (!IsIdentifier(name))
    return fmt::format(
        "'{}' is not a valid name (letters, digits and _, not starting with a "
        "digit)",
        name);
  if (IsFunctionName(name))
    return fmt::format("'{}' is the name of a function and cannot name {}", name,
                       WithArticle(kind));
  if (name == except) return "";
  auto taken_as = [&](NameKind k) {
    return Contains(NamesOf(model, k), name)
               ? fmt::format("'{}' is already the name of {}", name, WithArticle(k))
               : std::string();
  };
  if (kind == NameKind::kOutput) {
    for (NameKind k : {NameKind::kOutput, NameKind::kInput})
      if (std::string why = taken_as(k); !why.empty()) return why;
    return "";
  }
  for (NameKind k : {NameKind::kState, NameKind::kInput, NameKind::kParameter})
    if (std::string why = taken_as(k); !why.empty()) return why;
  if (kind == NameKind::kInput)
    if (std::string why = taken_as(NameKind::kOutput); !why.empty()) return why;
  if (name == kTheTime) {
    const std::vector<std::string> uses = FormulasUsing(model, kTheTime);
    if (!uses.empty())
      return fmt::format("'t' is the time in {}; {} named t would take its place there",
                         ListPaths(uses), WithArticle(kind));
  }
  return "";
}

std::string RenameInFormula(const std::string& text, const std::string& from,
                            const std::string& to) {
  std::string out;
  std::size_t copied = 0;
  ForEachName(text, [&](std::size_t start, std::size_t n) {
    if (n != from.size() || text.compare(start, n, from) != 0) return;
    out.append(text, copied, start - copied);
    out += to;
    copied = start + n;
  });
  out.append(text, copied, std::string::npos);
  return out;
}

std::vector<std::string> FormulasUsing(const Json& model, const std::string& name) {
  std::vector<std::string> paths;
  if (!model.is_object()) return paths;
  for (const char* section : kFormulaMaps) {
    if (!model.contains(section) || !model[section].is_object()) continue;
    const Json& map = model[section];
    for (auto it = map.begin(); it != map.end(); ++it)
      if (FormulaNames(it.value(), name)) paths.push_back(std::string(section) + "." + it.key());
  }
  return paths;
}

// ---- 3. add, rename, delete ------------------------------------------------------------------

Result<Json> AddName(const Json& model, NameKind kind, const std::string& name) {
  assert(kind != NameKind::kParameter && "AddName: parameters are added by AddParameter");
  if (std::string why = NameProblem(model, kind, name); !why.empty())
    return Refuse(fmt::format("cannot add {} '{}': {}", NameKindText(kind), name, why));
  Json j = model;
  j[ListKey(kind)].push_back(name);
  if (kind == NameKind::kState) {
    j["drift"][name] = "0";
    j["diffusion"][name] = "0";
    j["initial_state"][name] = "0";
    if (j.contains("initial_covariance") && j["initial_covariance"].is_object())
      j["initial_covariance"][name] = "1";
  } else if (kind == NameKind::kOutput) {
    const std::vector<std::string> states = NamesOf(model, NameKind::kState);
    j["observation"][name] = states.empty() ? "0" : states.front();
    j["measurement_variance"][name] = "1";
  }
  return Checked(std::move(j));
}

Result<Json> AddParameter(const Json& model, const Parameter& parameter) {
  const std::string& name = parameter.name;
  if (std::string why = NameProblem(model, NameKind::kParameter, name); !why.empty())
    return Refuse(fmt::format("cannot add parameter '{}': {}", name, why));
  Json j = model;
  if (!j.contains("parameters") || !j["parameters"].is_object()) j["parameters"] = Json::object();
  j["parameters"][name] = ParametersToJson({parameter})[name];
  Result<Json> checked = Checked(std::move(j));
  if (!checked)
    return Refuse(fmt::format("cannot add parameter '{}': {}", name, checked.error().message));
  return checked;
}

Result<Json> RenameName(const Json& model, NameKind kind, const std::string& from,
                        const std::string& to) {
  const char* what = NameKindText(kind);
  if (!Contains(NamesOf(model, kind), from))
    return Refuse(fmt::format("the model has no {} '{}'", what, from));
  if (from == to) return Checked(model);
  if (std::string why = NameProblem(model, kind, to, from); !why.empty())
    return Refuse(fmt::format("cannot rename {} '{}' to '{}': {}", what, from, to, why));
  Json j = model;
  if (kind == NameKind::kParameter) {
    j["parameters"] = RenameKey(model["parameters"], from, to);
  } else {
    for (Json& v : j[ListKey(kind)])
      if (v == from) v = to;
  }
  if (kind == NameKind::kState || kind == NameKind::kOutput) {
    for (const char* section :
         kind == NameKind::kState
             ? std::vector<const char*>(std::begin(kStateFormulas), std::end(kStateFormulas))
             : std::vector<const char*>(std::begin(kOutputKeys), std::end(kOutputKeys))) {
      if (j.contains(section) && j[section].is_object())
        j[section] = RenameKey(j[section], from, to);
    }
  }
  // Outputs are data columns: no formula names one (a state of the same name is another thing).
  if (kind != NameKind::kOutput) {
    for (const char* section : kFormulaMaps) {
      if (!j.contains(section) || !j[section].is_object()) continue;
      for (auto it = j[section].begin(); it != j[section].end(); ++it)
        if (it.value().is_string())
          it.value() = RenameInFormula(it.value().get<std::string>(), from, to);
    }
  }
  Result<Json> checked = Checked(std::move(j));
  if (!checked)
    return Refuse(
        fmt::format("cannot rename {} '{}' to '{}': {}", what, from, to, checked.error().message));
  return checked;
}

Result<Json> DeleteName(const Json& model, NameKind kind, const std::string& name) {
  const char* what = NameKindText(kind);
  const std::vector<std::string> names = NamesOf(model, kind);
  if (!Contains(names, name)) return Refuse(fmt::format("the model has no {} '{}'", what, name));
  if ((kind == NameKind::kState || kind == NameKind::kOutput) && names.size() == 1)
    return Refuse(
        fmt::format("cannot delete {} '{}': the model needs at least one {}", what, name, what));
  if (kind != NameKind::kOutput) {
    std::vector<std::string> uses = FormulasUsing(model, name);
    std::erase_if(uses, [&](const std::string& path) { return OwnFormula(kind, name, path); });
    if (!uses.empty())
      return Refuse(fmt::format("cannot delete {} '{}': {} {} it", what, name, ListPaths(uses),
                                uses.size() == 1 ? "uses" : "use"));
  }
  Json j = model;
  if (kind == NameKind::kParameter) {
    j["parameters"].erase(name);
  } else {
    Json list = Json::array();
    for (const Json& v : j[ListKey(kind)])
      if (v != name) list.push_back(v);
    j[ListKey(kind)] = std::move(list);
  }
  if (kind == NameKind::kState || kind == NameKind::kOutput) {
    for (const char* section :
         kind == NameKind::kState
             ? std::vector<const char*>(std::begin(kStateFormulas), std::end(kStateFormulas))
             : std::vector<const char*>(std::begin(kOutputKeys), std::end(kOutputKeys))) {
      if (j.contains(section) && j[section].is_object()) j[section].erase(name);
    }
  }
  Result<Json> checked = Checked(std::move(j));
  if (!checked)
    return Refuse(fmt::format("cannot delete {} '{}': {}", what, name, checked.error().message));
  return checked;
}

// ---- 4. options and parameter fields ---------------------------------------------------------

Result<Json> SetModelName(const Json& model, const std::string& name) {
  Json j = model;
  if (name.empty()) {
    j.erase("name");
  } else if (j.contains("name")) {
    j["name"] = name;
  } else {
    // The name reads best near the top of the file, after the version key.
    Json out = Json::object();
    for (auto it = model.begin(); it != model.end(); ++it) {
      out[it.key()] = it.value();
      if (it.key() == "greybench_model") out["name"] = name;
    }
    if (!out.contains("name")) out["name"] = name;
    j = std::move(out);
  }
  return Checked(std::move(j));
}

Result<Json> SetInputHold(const Json& model, InputHold hold) {
  Json j = model;
  j["input_hold"] = hold == InputHold::kZoh ? "zoh" : "foh";
  return Checked(std::move(j));
}

Result<Json> SetInitialCovariance(const Json& model, InitialCovariance mode) {
  Json j = model;
  switch (mode) {
    case InitialCovariance::kCtsm:
      j["initial_covariance"] = "ctsm";
      break;
    case InitialCovariance::kStationary:
      j["initial_covariance"] = "stationary";
      break;
    case InitialCovariance::kExplicit: {
      const Json before =
          model.contains("initial_covariance") ? model["initial_covariance"] : Json();
      Json variances = Json::object();
      for (const std::string& x : NamesOf(model, NameKind::kState))
        variances[x] = before.is_object() && before.contains(x) ? before[x] : Json("1");
      j["initial_covariance"] = std::move(variances);
      break;
    }
  }
  return Checked(std::move(j));
}

namespace {

// The parameter's JSON object (a number shorthand becomes {"value": v}), or why there is none.
Result<Json> ParameterObject(const Json& model, const std::string& parameter) {
  if (!Contains(NamesOf(model, NameKind::kParameter), parameter))
    return Refuse(fmt::format("the model has no parameter '{}'", parameter));
  const Json& p = model["parameters"][parameter];
  if (p.is_number()) return Json{{"value", p}};
  return p;
}

}  // namespace

Result<Json> SetParameterText(const Json& model, const std::string& parameter, ParameterText field,
                              const std::string& text) {
  Result<Json> p = ParameterObject(model, parameter);
  if (!p) return p;
  const char* key = field == ParameterText::kUnit ? "unit" : "description";
  if (text.empty()) {
    p->erase(key);
  } else {
    (*p)[key] = text;
  }
  Json j = model;
  j["parameters"][parameter] = std::move(*p);
  return Checked(std::move(j));
}

Result<Json> SetParameterPrior(const Json& model, const std::string& parameter,
                               const std::optional<Parameter::Prior>& prior) {
  Result<Json> p = ParameterObject(model, parameter);
  if (!p) return p;
  if (prior) {
    if (!std::isfinite(prior->mean) || !std::isfinite(prior->sd))
      return Refuse(fmt::format("the prior of '{}' needs finite numbers", parameter));
    if (!(prior->sd > 0))
      return Refuse(fmt::format("the prior's sd must be > 0, found {}", prior->sd));
    (*p)["prior"] = {{"mean", prior->mean}, {"sd", prior->sd}};
  } else {
    p->erase("prior");
  }
  Json j = model;
  j["parameters"][parameter] = std::move(*p);
  return Checked(std::move(j));
}

// ---- 5. models to start from -----------------------------------------------------------------

Json BlankModel(const std::string& name) {
  Json j = Json::object();
  j["greybench_model"] = 1;
  if (!name.empty()) j["name"] = name;
  j["states"] = {"x"};
  j["inputs"] = Json::array();
  j["outputs"] = {"y"};
  j["parameters"] = {
      {"sigma_x",
       {{"value", 0.1}, {"lower", 0.0}, {"upper", 100.0}, {"description", "diffusion of x"}}},
      {"sigma_y",
       {{"value", 0.1},
        {"lower", 0.0},
        {"upper", 100.0},
        {"description", "measurement noise of y (standard deviation)"}}}};
  j["drift"] = {{"x", "0"}};
  j["diffusion"] = {{"x", "sigma_x"}};
  j["observation"] = {{"y", "x"}};
  j["measurement_variance"] = {{"y", "sigma_y^2"}};
  j["initial_state"] = {{"x", "0"}};
  j["initial_covariance"] = "ctsm";
  j["input_hold"] = "zoh";
  return j;
}

Result<Json> ModelFromColumns(const ColumnsModelRequest& request) {
  if (request.outputs.empty())
    return Refuse("a model needs at least one output: choose an output column");
  std::vector<std::string> seen;
  for (const auto* group : {&request.inputs, &request.outputs}) {
    const char* what = group == &request.inputs ? "an input" : "an output";
    for (const ColumnSummary& c : *group) {
      if (!IsIdentifier(c.name))
        return Refuse(
            fmt::format("column '{}' cannot be {}: a model's names are letters, digits "
                        "and _, not starting with a digit",
                        c.name, what));
      if (IsFunctionName(c.name))
        return Refuse(
            fmt::format("column '{}' cannot be {}: it is the name of a function", c.name, what));
      if (Contains(seen, c.name)) return Refuse(fmt::format("column '{}' is chosen twice", c.name));
      seen.push_back(c.name);
    }
  }
  const double tau = request.duration && *request.duration > 0 ? *request.duration / 10 : 1.0;
  Json j = Json::object();
  j["greybench_model"] = 1;
  if (!request.name.empty()) j["name"] = request.name;
  Json states = Json::array(), inputs = Json::array(), outputs = Json::array();
  for (const ColumnSummary& u : request.inputs) inputs.push_back(u.name);
  Json parameters = Json::object(), drift = Json::object(), diffusion = Json::object(),
       observation = Json::object(), variance = Json::object(), x0 = Json::object();
  for (const ColumnSummary& y : request.outputs) {
    const std::string x = "x_" + y.name;
    states.push_back(x);
    outputs.push_back(y.name);
    const double sd = y.sd && std::isfinite(*y.sd) && *y.sd > 0 ? *y.sd : 1.0;
    const std::string tau_name = "tau_" + y.name;
    parameters[tau_name] = {{"value", tau},
                            {"lower", tau / 1000},
                            {"upper", tau * 1000},
                            {"description", "time constant of " + x}};
    std::string inflow = "-" + x;
    for (const ColumnSummary& u : request.inputs) {
      const std::string b = "b_" + y.name + "_" + u.name;
      parameters[b] = {{"value", 0.0}, {"description", "gain from " + u.name + " to " + x}};
      inflow += " + " + b + "*" + u.name;
    }
    const std::string sigma = "sigma_" + y.name, e = "e_" + y.name, x0_name = "x0_" + y.name;
    parameters[sigma] = {{"value", sd / 10},
                         {"lower", 0.0},
                         {"upper", 100 * sd},
                         {"description", "diffusion of " + x}};
    parameters[e] = {{"value", sd / 10},
                     {"lower", 0.0},
                     {"upper", 100 * sd},
                     {"description", "measurement noise of " + y.name + " (standard deviation)"}};
    const double first = y.first && std::isfinite(*y.first) ? *y.first : 0.0;
    parameters[x0_name] = {{"value", first}, {"description", "initial value of " + x}};
    drift[x] = request.inputs.empty() ? inflow + "/" + tau_name : "(" + inflow + ")/" + tau_name;
    diffusion[x] = sigma;
    observation[y.name] = x;
    variance[y.name] = e + "^2";
    x0[x] = x0_name;
  }
  j["states"] = std::move(states);
  j["inputs"] = std::move(inputs);
  j["outputs"] = std::move(outputs);
  j["parameters"] = std::move(parameters);
  j["drift"] = std::move(drift);
  j["diffusion"] = std::move(diffusion);
  j["observation"] = std::move(observation);
  j["measurement_variance"] = std::move(variance);
  j["initial_state"] = std::move(x0);
  j["initial_covariance"] = "ctsm";
  j["input_hold"] = "zoh";
  return Checked(std::move(j));
}

}  // namespace gb::model
