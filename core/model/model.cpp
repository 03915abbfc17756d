// Sections: 1. helpers for errors and JSON types  2. names and parameters  3. expressions
//           4. options (delays, initial covariance, hold, Huber)  5. ParseModel  6. ToJson/Save
//           7. SetParameter, Suggest
#include "core/model/model.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <set>

#include <fmt/format.h>

#include "core/util/file.h"
#include "core/util/json.h"

namespace gb::model {
namespace {

// ---- 1. helpers -------------------------------------------------------------------------------

class Parser {
 public:
  explicit Parser(std::string source) : source_(std::move(source)) {}

  Error Fail(const std::string& path, std::string message, int expr_col = 0) const {
    Error e = InputError(std::move(message));
    e.file = source_;
    e.path = path;
    e.expr_col = expr_col;
    return e;
  }

  const std::string& source() const { return source_; }

 private:
  std::string source_;
};

std::string JsonTypeName(const Json& j) {
  switch (j.type()) {
    case Json::value_t::null:
      return "null";
    case Json::value_t::boolean:
      return "true/false";
    case Json::value_t::string:
      return "a string";
    case Json::value_t::array:
      return "a list";
    case Json::value_t::object:
      return "an object";
    default:
      return "a number";
  }
}

const std::set<std::string>& ReservedNames() {
  static const std::set<std::string> kReserved = {"exp",  "log", "sqrt", "sin", "cos", "tan",
                                                  "tanh", "abs", "pow",  "min", "max", "sign"};
  return kReserved;
}

int IndexOf(const std::vector<std::string>& v, const std::string& name) {
  auto it = std::find(v.begin(), v.end(), name);
  return it == v.end() ? -1 : static_cast<int>(it - v.begin());
}

std::string JoinNames(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : ", ") + s;
  return out.empty() ? "(none)" : out;
}

// ---- 2. names and parameters -----------------------------------------------------------------

Result<std::vector<std::string>> ReadNames(const Parser& p, const Json& j, const std::string& key,
                                           bool required) {
  std::vector<std::string> names;
  if (!j.contains(key)) {
    if (required) return p.Fail(key, "missing: the model must list its " + key);
    return names;
  }
  const auto& a = j[key];
  if (!a.is_array()) return p.Fail(key, "expected a list of names, found " + JsonTypeName(a));
  for (std::size_t i = 0; i < a.size(); ++i) {
    const std::string path = fmt::format("{}[{}]", key, i);
    if (!a[i].is_string()) return p.Fail(path, "expected a name, found " + JsonTypeName(a[i]));
    std::string name = a[i].get<std::string>();
    if (!IsIdentifier(name))
      return p.Fail(path, fmt::format("'{}' is not a valid name (letters, digits and _, not "
                                      "starting with a digit)",
                                      name));
    if (ReservedNames().count(name))
      return p.Fail(path, fmt::format("'{}' is the name of a function and cannot name a {}", name,
                                      key.substr(0, key.size() - 1)));
    if (IndexOf(names, name) >= 0)
      return p.Fail(path, fmt::format("'{}' is listed twice in {}", name, key));
    names.push_back(std::move(name));
  }
  if (required && names.empty()) return p.Fail(key, "the model needs at least one entry in " + key);
  return names;
}

Result<double> ReadNumber(const Parser& p, const Json& v, const std::string& path) {
  if (!v.is_number()) return p.Fail(path, "expected a number, found " + JsonTypeName(v));
  const double x = v.get<double>();
  if (!std::isfinite(x)) return p.Fail(path, "expected a finite number");
  return x;
}

Result<Parameter> ReadParameter(const Parser& p, const std::string& name, const Json& v) {
  const std::string base = "parameters." + name;
  Parameter par;
  par.name = name;
  if (v.is_number()) {  // shorthand: "k": 0.5
    auto x = ReadNumber(p, v, base);
    if (!x) return x.error();
    par.value = *x;
    return par;
  }
  if (!v.is_object())
    return p.Fail(base,
                  "expected an object like {\"value\": 1, \"lower\": 0, \"upper\": 10}, "
                  "found " +
                      JsonTypeName(v));
  static const std::set<std::string> kKeys = {"value", "lower",       "upper", "fixed",
                                              "unit",  "description", "prior"};
  for (auto it = v.begin(); it != v.end(); ++it) {
    if (!kKeys.count(it.key()))
      return p.Fail(base + "." + it.key(),
                    "unknown field (a parameter has value, lower, upper, "
                    "fixed, unit, description, prior)");
  }
  if (!v.contains("value")) return p.Fail(base, "the parameter has no \"value\"");
  auto value = ReadNumber(p, v["value"], base + ".value");
  if (!value) return value.error();
  par.value = *value;
  for (const char* key : {"lower", "upper"}) {
    if (!v.contains(key) || v[key].is_null()) continue;
    auto x = ReadNumber(p, v[key], base + "." + key);
    if (!x) return x.error();
    (std::string(key) == "lower" ? par.lower : par.upper) = *x;
  }
  if (v.contains("fixed")) {
    if (!v["fixed"].is_boolean())
      return p.Fail(base + ".fixed", "expected true or false, found " + JsonTypeName(v["fixed"]));
    par.fixed = v["fixed"].get<bool>();
  }
  for (const char* key : {"unit", "description"}) {
    if (!v.contains(key)) continue;
    if (!v[key].is_string())
      return p.Fail(base + "." + key, "expected a string, found " + JsonTypeName(v[key]));
    (std::string(key) == "unit" ? par.unit : par.description) = v[key].get<std::string>();
  }
  if (v.contains("prior") && !v["prior"].is_null()) {
    const Json& pr = v["prior"];
    const std::string path = base + ".prior";
    if (!pr.is_object())
      return p.Fail(
          path, "expected an object like {\"mean\": 0.1, \"sd\": 0.02}, found " + JsonTypeName(pr));
    for (auto it = pr.begin(); it != pr.end(); ++it)
      if (it.key() != "mean" && it.key() != "sd")
        return p.Fail(path + "." + it.key(), "unknown field (a prior has mean and sd)");
    for (const char* key : {"mean", "sd"})
      if (!pr.contains(key)) return p.Fail(path, fmt::format("the prior has no \"{}\"", key));
    auto mean = ReadNumber(p, pr["mean"], path + ".mean");
    if (!mean) return mean.error();
    auto sd = ReadNumber(p, pr["sd"], path + ".sd");
    if (!sd) return sd.error();
    if (!(*sd > 0))
      return p.Fail(path + ".sd", fmt::format("the prior's sd must be > 0, found {}", *sd));
    par.prior = Parameter::Prior{*mean, *sd};
  }
  if (par.lower && par.upper && !(*par.lower < *par.upper))
    return p.Fail(base, fmt::format("the bounds are inverted or empty: lower {} is not below "
                                    "upper {}",
                                    *par.lower, *par.upper));
  if (!par.fixed &&
      ((par.lower && par.value < *par.lower) || (par.upper && par.value > *par.upper)))
    return p.Fail(base + ".value",
                  fmt::format("the start value {} is outside the bounds [{}, {}]", par.value,
                              par.lower ? fmt::format("{}", *par.lower) : "-inf",
                              par.upper ? fmt::format("{}", *par.upper) : "inf"));
  return par;
}

// ---- 3. expressions --------------------------------------------------------------------------

constexpr const char* kTimeName = "t";  // the time, in expressions

struct NameTable {
  std::set<std::string> known;   // states, inputs and parameters
  std::vector<std::string> all;  // for suggestions
  std::set<std::string> states_inputs;
};

Result<Formula> ReadFormula(const Parser& p, const Json& v, const std::string& path,
                            const NameTable& names, const std::set<std::string>& allowed,
                            const std::string& allowed_what) {
  Formula f;
  f.path = path;
  if (v.is_number()) {
    auto x = ReadNumber(p, v, path);
    if (!x) return x.error();
    f.text = fmt::format("{}", *x);
  } else if (v.is_string()) {
    f.text = v.get<std::string>();
  } else {
    return p.Fail(path, "expected an expression (a string), found " + JsonTypeName(v));
  }
  auto parsed = expr::Parse(f.text);
  if (!parsed) {
    Error e = parsed.error();
    e.file = p.source();
    e.path = path;
    return e;
  }
  f.expr = *parsed;
  std::set<std::string> used;
  expr::CollectNames(f.expr, &used);
  std::set<std::string> unknown;
  std::set<std::string> not_allowed;
  for (const auto& n : used) {
    if (!names.known.count(n))
      unknown.insert(n);
    else if (!allowed.count(n))
      not_allowed.insert(n);
  }
  if (!unknown.empty()) {
    const expr::Node* node = expr::FindFirstVariable(f.expr, unknown);
    std::string msg = fmt::format("unknown name '{}'", node->name);
    if (auto s = Suggest(node->name, names.all))
      msg += fmt::format(" (did you mean '{}'?)", *s);
    else
      msg += " (not a state, input or parameter of the model)";
    return p.Fail(path, msg, node->column);
  }
  if (!not_allowed.empty()) {
    const expr::Node* node = expr::FindFirstVariable(f.expr, not_allowed);
    return p.Fail(path,
                  fmt::format("'{}' cannot appear here: {} may only use {}", node->name,
                              path.substr(0, path.find('.')), allowed_what),
                  node->column);
  }
  return f;
}

// Reads an object of expressions keyed by `keys` (states or outputs).
Result<std::vector<Formula>> ReadFormulaMap(const Parser& p, const Json& j, const std::string& key,
                                            const std::vector<std::string>& keys,
                                            const std::string& keys_what, bool required_each,
                                            const std::string& default_text, const NameTable& names,
                                            const std::set<std::string>& allowed,
                                            const std::string& allowed_what) {
  std::vector<Formula> out(keys.size());
  Json obj = Json::object();
  if (j.contains(key)) {
    obj = j[key];
    if (!obj.is_object())
      return p.Fail(key,
                    fmt::format("expected an object mapping each {} to an expression, found {}",
                                keys_what, JsonTypeName(obj)));
  } else if (required_each && !keys.empty()) {
    return p.Fail(key,
                  fmt::format("missing: the model needs an expression for each {}", keys_what));
  }
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    if (IndexOf(keys, it.key()) < 0) {
      std::string msg = fmt::format("'{}' is not a {} of the model", it.key(), keys_what);
      if (auto s = Suggest(it.key(), keys))
        msg += fmt::format(" (did you mean '{}'?)", *s);
      else
        msg += fmt::format(" (they are: {})", JoinNames(keys));
      return p.Fail(key + "." + it.key(), msg);
    }
  }
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const std::string path = key + "." + keys[i];
    if (!obj.contains(keys[i])) {
      if (required_each)
        return p.Fail(key, fmt::format("no expression for {} '{}'", keys_what, keys[i]));
      auto f = ReadFormula(p, default_text, path, names, allowed, allowed_what);
      if (!f) return f.error();
      out[i] = std::move(*f);
      continue;
    }
    auto f = ReadFormula(p, obj[keys[i]], path, names, allowed, allowed_what);
    if (!f) return f.error();
    out[i] = std::move(*f);
  }
  return out;
}

// ---- 4. options ------------------------------------------------------------------------------

Result<DelaySpec> ReadDelay(const Parser& p, const Json& v, const std::string& path) {
  auto whole = [&](const Json& x, const std::string& at) -> Result<int> {
    if (!x.is_number_integer() &&
        !(x.is_number() && std::floor(x.get<double>()) == x.get<double>()))
      return p.Fail(at, "expected a whole number of samples, found " +
                            (x.is_number() ? fmt::format("{}", x.get<double>()) : JsonTypeName(x)));
    const double d = x.get<double>();
    if (d < 0) return p.Fail(at, fmt::format("a delay cannot be negative ({})", d));
    if (d > 1e6) return p.Fail(at, fmt::format("a delay of {} samples is not plausible", d));
    return static_cast<int>(d);
  };
  DelaySpec d;
  if (v.is_number()) {
    auto x = whole(v, path);
    if (!x) return x.error();
    d.min = d.max = *x;
    return d;
  }
  if (!v.is_object())
    return p.Fail(path, "expected a whole number of samples or {\"min\": a, \"max\": b}, found " +
                            JsonTypeName(v));
  for (auto it = v.begin(); it != v.end(); ++it)
    if (it.key() != "min" && it.key() != "max")
      return p.Fail(path + "." + it.key(), "unknown field (a delay range has min and max)");
  if (!v.contains("min") || !v.contains("max"))
    return p.Fail(path, "a delay range needs both \"min\" and \"max\"");
  auto lo = whole(v["min"], path + ".min");
  if (!lo) return lo.error();
  auto hi = whole(v["max"], path + ".max");
  if (!hi) return hi.error();
  if (*hi < *lo) return p.Fail(path, fmt::format("max {} is below min {}", *hi, *lo));
  d.min = *lo;
  d.max = *hi;
  return d;
}

// The "ekf" object: {"ode": ..., "rtol": ..., "atol": ..., "iterations": ...}, every key optional.
Result<EkfOptions> ReadEkfOptions(const Parser& p, const Json& v) {
  if (!v.is_object()) return p.Fail("ekf", "expected an object, found " + JsonTypeName(v));
  EkfOptions o;
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string path = "ekf." + it.key();
    if (it.key() == "ode") {
      const std::string s = it.value().is_string() ? it.value().get<std::string>() : "";
      if (s == "auto")
        o.method = OdeMethod::kAuto;
      else if (s == "explicit")
        o.method = OdeMethod::kExplicit;
      else if (s == "bdf")
        o.method = OdeMethod::kBdf;
      else
        return p.Fail(path, "expected \"auto\", \"explicit\" or \"bdf\"");
    } else if (it.key() == "rtol" || it.key() == "atol") {
      auto x = ReadNumber(p, it.value(), path);
      if (!x) return x.error();
      if (!(*x > 0) || *x >= 1)
        return p.Fail(path, fmt::format("a tolerance is a positive number below 1, not {}", *x));
      (it.key() == "rtol" ? o.rtol : o.atol) = *x;
    } else if (it.key() == "iterations") {
      const Json& x = it.value();
      if (!x.is_number_integer() || x.get<std::int64_t>() < 1 || x.get<std::int64_t>() > 100)
        return p.Fail(path, "expected a whole number from 1 (the EKF) to 100 (the iterated EKF)");
      o.iterations = static_cast<int>(x.get<std::int64_t>());
    } else {
      std::string msg = fmt::format("unknown key '{}'", it.key());
      if (auto s = Suggest(it.key(), {"ode", "rtol", "atol", "iterations"}))
        msg += fmt::format(" (did you mean '{}'?)", *s);
      return p.Fail(path, msg);
    }
  }
  return o;
}

}  // namespace

bool IsIdentifier(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

bool IsFunctionName(const std::string& s) { return ReservedNames().count(s) > 0; }

// ---- ModelSpec accessors ---------------------------------------------------------------------

int ModelSpec::ParameterIndex(const std::string& n) const {
  for (std::size_t i = 0; i < parameters.size(); ++i)
    if (parameters[i].name == n) return static_cast<int>(i);
  return -1;
}
int ModelSpec::StateIndex(const std::string& n) const { return IndexOf(states, n); }
int ModelSpec::InputIndex(const std::string& n) const { return IndexOf(inputs, n); }
int ModelSpec::OutputIndex(const std::string& n) const { return IndexOf(outputs, n); }

std::vector<double> ModelSpec::Values() const {
  std::vector<double> v;
  v.reserve(parameters.size());
  for (const auto& par : parameters) v.push_back(par.value);
  return v;
}

bool ModelSpec::HasDelayScan() const {
  return std::any_of(output_delay.begin(), output_delay.end(),
                     [](const DelaySpec& d) { return d.IsScan(); });
}

// ---- 5. ParseModel ---------------------------------------------------------------------------

const char* OdeMethodName(OdeMethod m) {
  switch (m) {
    case OdeMethod::kExplicit:
      return "explicit";
    case OdeMethod::kBdf:
      return "bdf";
    case OdeMethod::kAuto:
      break;
  }
  return "auto";
}

Result<ModelSpec> ParseModel(const Json& j, const std::string& source) {
  const Parser p(source);
  if (!j.is_object())
    return p.Fail("", "a model file holds a JSON object, found " + JsonTypeName(j));
  if (!j.contains("greybench_model"))
    return p.Fail("", "not a greybench model: the key \"greybench_model\": 1 is missing");
  if (!j["greybench_model"].is_number_integer() || j["greybench_model"].get<std::int64_t>() != 1)
    return p.Fail("greybench_model", "unsupported model version (this greybench reads version 1)");

  static const std::set<std::string> kKeys = {"greybench_model",
                                              "name",
                                              "description",
                                              "states",
                                              "inputs",
                                              "outputs",
                                              "parameters",
                                              "drift",
                                              "diffusion",
                                              "observation",
                                              "measurement_variance",
                                              "output_delay",
                                              "initial_state",
                                              "initial_covariance",
                                              "input_hold",
                                              "robust_huber",
                                              "time_unit",
                                              "ekf"};
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (kKeys.count(it.key())) continue;
    std::string msg = fmt::format("unknown key '{}'", it.key());
    if (auto s = Suggest(it.key(), {kKeys.begin(), kKeys.end()}))
      msg += fmt::format(" (did you mean '{}'?)", *s);
    return p.Fail(it.key(), msg);
  }

  ModelSpec m;
  m.source = source;
  if (j.contains("name")) {
    if (!j["name"].is_string())
      return p.Fail("name", "expected a string, found " + JsonTypeName(j["name"]));
    m.name = j["name"].get<std::string>();
  }
  {
    auto states = ReadNames(p, j, "states", true);
    if (!states) return states.error();
    m.states = std::move(*states);
    auto inputs = ReadNames(p, j, "inputs", false);
    if (!inputs) return inputs.error();
    m.inputs = std::move(*inputs);
    auto outputs = ReadNames(p, j, "outputs", true);
    if (!outputs) return outputs.error();
    m.outputs = std::move(*outputs);
  }

  // Parameters, in file order: θ vectors follow this order.
  if (j.contains("parameters")) {
    const auto& ps = j["parameters"];
    if (!ps.is_object())
      return p.Fail("parameters", "expected an object of parameters, found " + JsonTypeName(ps));
    for (auto it = ps.begin(); it != ps.end(); ++it) {
      const std::string path = "parameters." + it.key();
      if (!IsIdentifier(it.key()))
        return p.Fail(path, fmt::format("'{}' is not a valid name (letters, digits and _, not "
                                        "starting with a digit)",
                                        it.key()));
      if (ReservedNames().count(it.key()))
        return p.Fail(path, fmt::format("'{}' is the name of a function and cannot name a "
                                        "parameter",
                                        it.key()));
      auto par = ReadParameter(p, it.key(), it.value());
      if (!par) return par.error();
      m.parameters.push_back(std::move(*par));
    }
  }

  // One namespace for states, inputs and parameters; outputs are data columns and may share a
  // state's name, but not an input's (one column cannot be both).
  NameTable names;
  auto claim = [&](const std::string& n, const std::string& path, const char* what) -> Status {
    if (!names.known.insert(n).second)
      return p.Fail(path, fmt::format("'{}' is used twice: as a {} and as another state, input or "
                                      "parameter",
                                      n, what));
    names.all.push_back(n);
    return Ok{};
  };
  for (std::size_t i = 0; i < m.states.size(); ++i)
    if (auto s = claim(m.states[i], fmt::format("states[{}]", i), "state"); !s) return s.error();
  for (std::size_t i = 0; i < m.inputs.size(); ++i)
    if (auto s = claim(m.inputs[i], fmt::format("inputs[{}]", i), "input"); !s) return s.error();
  for (const auto& par : m.parameters)
    if (auto s = claim(par.name, "parameters." + par.name, "parameter"); !s) return s.error();
  // The time, unless the model names something `t`.
  const bool time_free = !names.known.count(kTimeName);
  if (time_free) names.known.insert(kTimeName);
  for (std::size_t i = 0; i < m.outputs.size(); ++i)
    if (IndexOf(m.inputs, m.outputs[i]) >= 0)
      return p.Fail(fmt::format("outputs[{}]", i),
                    fmt::format("'{}' is both an input and an output", m.outputs[i]));

  std::set<std::string> params_only;
  for (const auto& par : m.parameters) params_only.insert(par.name);
  const std::set<std::string>& everything = names.known;  // with t when it is the time
  std::set<std::string> params_inputs = params_only;
  params_inputs.insert(m.inputs.begin(), m.inputs.end());
  if (time_free) params_inputs.insert(kTimeName);
  const char* everything_what =
      time_free ? "states, inputs, parameters and the time t" : "states, inputs and parameters";

  auto drift = ReadFormulaMap(p, j, "drift", m.states, "state", true, "0", names, everything,
                              everything_what);
  if (!drift) return drift.error();
  m.drift = std::move(*drift);
  auto diffusion = ReadFormulaMap(p, j, "diffusion", m.states, "state", false, "0", names,
                                  everything, everything_what);
  if (!diffusion) return diffusion.error();
  m.diffusion = std::move(*diffusion);
  auto observation = ReadFormulaMap(p, j, "observation", m.outputs, "output", true, "0", names,
                                    everything, everything_what);
  if (!observation) return observation.error();
  m.observation = std::move(*observation);
  auto variance = ReadFormulaMap(
      p, j, "measurement_variance", m.outputs, "output", true, "0", names, params_inputs,
      time_free ? "inputs, parameters and the time t" : "inputs and parameters");
  if (!variance) return variance.error();
  m.measurement_variance = std::move(*variance);
  auto x0 = ReadFormulaMap(p, j, "initial_state", m.states, "state", false, "0", names, params_only,
                           "parameters");
  if (!x0) return x0.error();
  m.initial_state = std::move(*x0);

  if (j.contains("initial_covariance")) {
    const auto& ic = j["initial_covariance"];
    if (ic.is_string()) {
      const std::string s = ic.get<std::string>();
      if (s == "ctsm")
        m.initial_covariance = InitialCovariance::kCtsm;
      else if (s == "stationary")
        m.initial_covariance = InitialCovariance::kStationary;
      else
        return p.Fail("initial_covariance", fmt::format("unknown value '{}' (use \"ctsm\", "
                                                        "\"stationary\" or an object of variances)",
                                                        s));
    } else if (ic.is_object()) {
      m.initial_covariance = InitialCovariance::kExplicit;
      auto v = ReadFormulaMap(p, j, "initial_covariance", m.states, "state", true, "0", names,
                              params_only, "parameters");
      if (!v) return v.error();
      m.initial_variance = std::move(*v);
    } else {
      return p.Fail("initial_covariance",
                    "expected \"ctsm\", \"stationary\" or an object of "
                    "per-state variances, found " +
                        JsonTypeName(ic));
    }
  }

  m.output_delay.assign(m.outputs.size(), DelaySpec{});
  if (j.contains("output_delay")) {
    const auto& od = j["output_delay"];
    if (!od.is_object())
      return p.Fail("output_delay",
                    "expected an object mapping outputs to delays, found " + JsonTypeName(od));
    for (auto it = od.begin(); it != od.end(); ++it) {
      const int o = IndexOf(m.outputs, it.key());
      if (o < 0)
        return p.Fail("output_delay." + it.key(),
                      fmt::format("'{}' is not an output of the model (they are: {})", it.key(),
                                  JoinNames(m.outputs)));
      auto d = ReadDelay(p, it.value(), "output_delay." + it.key());
      if (!d) return d.error();
      m.output_delay[o] = *d;
    }
  }

  if (j.contains("input_hold")) {
    const auto& h = j["input_hold"];
    const std::string s = h.is_string() ? h.get<std::string>() : "";
    if (s == "zoh")
      m.input_hold = InputHold::kZoh;
    else if (s == "foh")
      m.input_hold = InputHold::kFoh;
    else
      return p.Fail("input_hold", "expected \"zoh\" or \"foh\"");
  }

  if (j.contains("robust_huber") && !j["robust_huber"].is_null()) {
    auto c = ReadNumber(p, j["robust_huber"], "robust_huber");
    if (!c) return c.error();
    if (*c <= 0)
      return p.Fail("robust_huber",
                    fmt::format("the Huber threshold must be positive, not {}", *c));
    m.robust_huber = *c;
  }

  if (j.contains("ekf")) {
    auto ekf = ReadEkfOptions(p, j["ekf"]);
    if (!ekf) return ekf.error();
    m.ekf = *ekf;
  }
  return m;
}

Result<ModelSpec> LoadModelFile(const std::string& path) {
  auto j = ReadJsonFile(path);
  if (!j) return j.error();
  return ParseModel(*j, path);
}

// ---- 6. ToJson / Save ------------------------------------------------------------------------

Json ParametersToJson(const std::vector<Parameter>& parameters) {
  Json ps = Json::object();
  for (const auto& par : parameters) {
    Json v;
    v["value"] = par.value;
    if (par.lower) v["lower"] = *par.lower;
    if (par.upper) v["upper"] = *par.upper;
    if (par.fixed) v["fixed"] = true;
    if (!par.unit.empty()) v["unit"] = par.unit;
    if (!par.description.empty()) v["description"] = par.description;
    if (par.prior) v["prior"] = {{"mean", par.prior->mean}, {"sd", par.prior->sd}};
    ps[par.name] = v;
  }
  return ps;
}

Json ToJson(const ModelSpec& m) {
  Json j;
  j["greybench_model"] = 1;
  if (!m.name.empty()) j["name"] = m.name;
  j["states"] = m.states;
  j["inputs"] = m.inputs;
  j["outputs"] = m.outputs;
  j["parameters"] = ParametersToJson(m.parameters);
  auto put = [](Json* obj, const std::vector<std::string>& keys, const std::vector<Formula>& fs) {
    *obj = Json::object();
    for (std::size_t i = 0; i < keys.size(); ++i) (*obj)[keys[i]] = fs[i].text;
  };
  put(&j["drift"], m.states, m.drift);
  put(&j["diffusion"], m.states, m.diffusion);
  put(&j["observation"], m.outputs, m.observation);
  put(&j["measurement_variance"], m.outputs, m.measurement_variance);
  put(&j["initial_state"], m.states, m.initial_state);
  switch (m.initial_covariance) {
    case InitialCovariance::kCtsm:
      j["initial_covariance"] = "ctsm";
      break;
    case InitialCovariance::kStationary:
      j["initial_covariance"] = "stationary";
      break;
    case InitialCovariance::kExplicit:
      put(&j["initial_covariance"], m.states, m.initial_variance);
      break;
  }
  Json delays = Json::object();
  for (std::size_t o = 0; o < m.outputs.size(); ++o) {
    const auto& d = m.output_delay[o];
    if (d.IsScan())
      delays[m.outputs[o]] = {{"min", d.min}, {"max", d.max}};
    else if (d.min != 0)
      delays[m.outputs[o]] = d.min;
  }
  if (!delays.empty()) j["output_delay"] = delays;
  j["input_hold"] = m.input_hold == InputHold::kZoh ? "zoh" : "foh";
  if (m.robust_huber) j["robust_huber"] = *m.robust_huber;
  if (m.ekf != EkfOptions{}) {
    Json e;
    e["ode"] = OdeMethodName(m.ekf.method);
    e["rtol"] = m.ekf.rtol;
    e["atol"] = m.ekf.atol;
    e["iterations"] = m.ekf.iterations;
    j["ekf"] = e;
  }
  return j;
}

Status SaveModelFile(const ModelSpec& m, const std::string& path) {
  return WriteFileAtomic(path, ToJson(m).dump(1) + "\n");
}

// ---- 7. SetParameter, Suggest ----------------------------------------------------------------

Status SetParameter(ModelSpec* m, const std::string& name, double value) {
  const int i = m->ParameterIndex(name);
  if (i < 0) {
    std::vector<std::string> names;
    for (const auto& par : m->parameters) names.push_back(par.name);
    std::string msg = fmt::format("--set {}: the model has no parameter '{}'", name, name);
    if (auto s = Suggest(name, names)) msg += fmt::format(" (did you mean '{}'?)", *s);
    Error e = InputError(msg);
    e.file = m->source;
    return e;
  }
  Parameter& par = m->parameters[i];
  if (!std::isfinite(value)) {
    Error e = InputError(fmt::format("--set {}: the value must be a finite number", name));
    return e;
  }
  if (!par.fixed && ((par.lower && value < *par.lower) || (par.upper && value > *par.upper))) {
    Error e = InputError(fmt::format("--set {}={}: outside the parameter's bounds [{}, {}]", name,
                                     value, par.lower ? fmt::format("{}", *par.lower) : "-inf",
                                     par.upper ? fmt::format("{}", *par.upper) : "inf"));
    return e;
  }
  par.value = value;
  return Ok{};
}

std::optional<std::string> Suggest(const std::string& name,
                                   const std::vector<std::string>& candidates) {
  auto distance = [](const std::string& a, const std::string& b) {
    std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
      cur[0] = i;
      for (std::size_t j = 1; j <= b.size(); ++j) {
        const std::size_t sub =
            prev[j - 1] + (std::tolower(a[i - 1]) == std::tolower(b[j - 1]) ? 0 : 1);
        cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
      }
      std::swap(prev, cur);
    }
    return prev[b.size()];
  };
  std::optional<std::string> best;
  std::size_t best_d = 0;
  for (const auto& c : candidates) {
    const std::size_t d = distance(name, c);
    if (!best || d < best_d) {
      best = c;
      best_d = d;
    }
  }
  const std::size_t limit = std::max<std::size_t>(1, name.size() / 3);
  if (best && best_d <= limit) return best;
  return std::nullopt;
}

}  // namespace gb::model
