#include "core/fmu/fmu.h"

#include <atomic>
#include <cassert>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <unistd.h>

#include "core/expr/expr.h"
#include "core/expr/native.h"
#include "core/fmu/embedded.h"
#include "core/model/linear_model.h"
#include "core/report/figure.h"
#include "core/util/file.h"
#include "core/util/hash.h"
#include "core/util/zip.h"

namespace gb::fmu {
namespace {

namespace fs = std::filesystem;
using Program = model::NonlinearModel::Program;

// A C string literal of a name (identifiers only: no escapes needed).
std::string CString(const std::string& s) { return "\"" + s + "\""; }

// The 1-based indices (in ModelVariables) of the states and inputs `e` depends on: those whose
// partial derivative is not identically zero.
std::string Dependencies(const expr::ExprPtr& e, const model::ModelSpec& spec) {
  std::set<std::string> used;
  expr::CollectNames(e, &used);
  const std::size_t n = spec.states.size();
  std::string out;
  auto add = [&](const std::string& name, std::size_t index) {
    if (!used.count(name)) return;
    double value = 0.0;
    if (expr::IsConstant(expr::Simplify(expr::Differentiate(e, name)), &value) && value == 0.0)
      return;
    out += (out.empty() ? "" : " ") + std::to_string(index);
  };
  for (std::size_t i = 0; i < n; ++i) add(spec.states[i], i + 1);
  for (std::size_t i = 0; i < spec.inputs.size(); ++i) add(spec.inputs[i], 2 * n + i + 1);
  return out;
}

}  // namespace

Result<FmuOptions> VirtualSensorOptions(const model::NonlinearModel& model,
                                        std::span<const double> theta,
                                        std::span<const int> delays) {
  const model::ModelSpec& spec = model.spec();
  const std::size_t n = spec.states.size(), p = spec.outputs.size();
  FmuOptions options;
  options.virtual_sensor = true;
  options.interface = Interface::kCoSimulation;
  if (spec.ekf.iterations > 1)
    return InputError(fmt::format(
        "a virtual sensor runs the extended Kalman filter, not the iterated one (ekf.iterations "
        "{}): set \"iterations\" to 1 to export it",
        spec.ekf.iterations));
  options.initial_covariance_kind = spec.initial_covariance;
  for (std::size_t o = 0; o < p; ++o) {
    const int d = o < delays.size() && delays[o] >= 0 ? delays[o] : spec.output_delay[o].min;
    if (d < 0 || d > 10000)
      return InputError(
          fmt::format("output {}: a delay of {} samples is not exported (0 to "
                      "10000)",
                      spec.outputs[o], d));
    options.delays.push_back(d);
  }
  if (spec.initial_covariance == model::InitialCovariance::kExplicit) {
    std::vector<double> slots(static_cast<std::size_t>(model.n_slots()), 0.0);
    std::copy(theta.begin(), theta.end(), slots.begin() + model.parameter_slot());
    std::vector<double> initial(model.initial_size());
    model.Initial(slots, initial);
    options.initial_covariance.assign(n * n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      const double v = initial[n + i];
      if (!std::isfinite(v) || v < 0.0)
        return InputError(
            fmt::format("the initial variance of {} is {}: not a variance", spec.states[i], v));
      options.initial_covariance[i * n + i] = v;
    }
  }
  if (model::LinearModel::Compile(spec)) {
    options.rtol = 1e-10;
    options.atol = 1e-12;
  }
  return options;
}

const char* InterfaceName(Interface interface) {
  switch (interface) {
    case Interface::kModelExchange:
      return "Model Exchange";
    case Interface::kCoSimulation:
      return "Co-Simulation";
    case Interface::kBoth:
      break;
  }
  return "Model Exchange and Co-Simulation";
}

std::string DelayNote(const model::ModelSpec& spec, std::span<const int> delays) {
  std::string delayed;
  for (std::size_t o = 0; o < delays.size() && o < spec.outputs.size(); ++o)
    if (delays[o] > 0)
      delayed += fmt::format("{}{} by {} sample{}", delayed.empty() ? "" : ", ", spec.outputs[o],
                             delays[o], delays[o] == 1 ? "" : "s");
  if (delayed.empty()) return "";
  return "the fit delays " + delayed +
         "; the FMU's outputs are not delayed (add the delay after the output in the importer)";
}

std::string IdentifierOf(const std::string& name) {
  std::string id;
  for (const char c : name) id += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  if (id.empty()) return "model";
  if (std::isdigit(static_cast<unsigned char>(id.front()))) id.insert(id.begin(), '_');
  return id;
}

Result<FmuSources> MakeFmuSources(const model::NonlinearModel& model, std::span<const double> theta,
                                  const FmuOptions& options) {
  const model::ModelSpec& spec = model.spec();
  const std::size_t n = spec.states.size(), m = spec.inputs.size(), p = spec.outputs.size(),
                    k = spec.parameters.size();
  assert(theta.size() == k && "one value per parameter");
  const bool sensor = options.virtual_sensor;
  const double rtol = options.rtol > 0.0 ? options.rtol : spec.ekf.rtol;
  const double atol = options.atol > 0.0 ? options.atol : spec.ekf.atol;
  FmuSources out;
  out.identifier = options.identifier.empty() ? IdentifierOf(spec.name) : options.identifier;
  if (!model::IsIdentifier(out.identifier))
    return InputError(fmt::format(
        "the FMU's model identifier '{}' is not a C identifier (letters, digits and '_', not "
        "starting with a digit)",
        out.identifier));
  // The inputs, outputs and parameters keep their names: they are the FMU's interface. A state
  // named like one of them (an output y = N of a state N) takes a suffix: N_state.
  std::vector<std::string> state_var = spec.states;
  {
    std::set<std::string> interface_names(spec.inputs.begin(), spec.inputs.end());
    interface_names.insert(spec.outputs.begin(), spec.outputs.end());
    for (const auto& q : spec.parameters) interface_names.insert(q.name);
    std::set<std::string> taken = interface_names;
    taken.insert(spec.states.begin(), spec.states.end());
    for (auto& name : state_var) {
      if (!interface_names.count(name)) continue;
      const std::string base = name + "_state";
      name = base;
      for (int k = 2; taken.count(name); ++k) name = base + std::to_string(k);
      taken.insert(name);
    }
  }
  {
    std::map<std::string, std::string> seen;
    auto claim = [&](const std::string& name, const std::string& what) -> Status {
      auto [it, fresh] = seen.emplace(name, what);
      if (!fresh)
        return InputError(
            fmt::format("'{}' names both {} and {}: an FMU's variables need names of their own",
                        name, it->second, what));
      return Ok{};
    };
    if (!sensor) {
      for (const auto& s : state_var) {
        if (auto c = claim(s, "a state"); !c) return c.error();
        if (auto c = claim("der(" + s + ")", "a derivative"); !c) return c.error();
      }
    } else {
      for (const auto& s : spec.states)
        for (const char* suffix : {"_filtered", "_filtered_sd", "_predicted", "_predicted_sd"})
          if (auto c = claim(s + suffix, "a filtered state"); !c) return c.error();
      for (const auto& y : spec.outputs)
        for (const char* suffix : {"_pred", "_sd", "_residual", "_valid"})
          if (auto c = claim(y + suffix, "a filter's output"); !c) return c.error();
      if (auto c = claim("ready", "the filter's readiness"); !c) return c.error();
    }
    for (const auto& u : spec.inputs)
      if (auto c = claim(u, "an input"); !c) return c.error();
    for (const auto& y : spec.outputs)
      if (auto c = claim(y, sensor ? "a measurement" : "an output"); !c) return c.error();
    for (const auto& q : spec.parameters)
      if (auto c = claim(q.name, "a parameter"); !c) return c.error();
  }
  for (std::size_t i = 0; i < k; ++i)
    if (!std::isfinite(theta[i]))
      return InputError(fmt::format("parameter {} is {}: an FMU's start values must be finite",
                                    spec.parameters[i].name, theta[i]));

  // The states' start: given, or the model's initial state at θ.
  std::vector<double> slots(static_cast<std::size_t>(model.n_slots()), 0.0);
  std::copy(theta.begin(), theta.end(), slots.begin() + model.parameter_slot());
  std::vector<double> x0 = options.initial_state;
  if (x0.empty()) {
    std::vector<double> initial(model.initial_size());
    model.Initial(slots, initial);
    x0.assign(initial.begin(), initial.begin() + static_cast<std::ptrdiff_t>(n));
  }
  if (x0.size() != n)
    return InputError(fmt::format("{} initial states given, the model has {}", x0.size(), n));
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(x0[i]))
      return InputError(
          fmt::format("the initial state of {} is {}: an FMU's start values must "
                      "be finite",
                      spec.states[i], x0[i]));

  // The C: f and h (the first n and p entries of the dynamics and measurement programs); the
  // virtual sensor's filter takes the whole of both (f, J, σ and h, H, S).
  expr::NativeCode::Program drift, observation;
  for (std::size_t i = 0; i < (sensor ? model.dynamics_size() : n); ++i)
    drift.exprs.push_back(model.Entry(Program::kDynamics, i));
  for (std::size_t o = 0; o < (sensor ? model.measurement_size() : p); ++o)
    observation.exprs.push_back(model.Entry(Program::kMeasurement, o));
  const std::vector<expr::NativeCode::Program> programs = {drift, observation};
  if (sensor && options.delays.size() != p)
    return InputError(
        fmt::format("{} output delays given, the model has {} outputs", options.delays.size(), p));
  if (sensor && options.initial_covariance_kind == model::InitialCovariance::kExplicit &&
      options.initial_covariance.size() != n * n)
    return InputError(
        fmt::format("an initial covariance of {} entries given, the model has {} "
                    "states",
                    options.initial_covariance.size(), n));
  auto generated = expr::NativeCode::Source(
      programs, [&model](const std::string& name) { return model.SlotOf(name); });
  if (!generated) return generated.error();

  // modelDescription.xml (its guid filled in last, from a hash of everything else).
  const bool me = !sensor && options.interface != Interface::kCoSimulation;
  const bool cs = sensor || options.interface != Interface::kModelExchange;
  std::set<std::string> units;
  for (const model::Parameter& q : spec.parameters)
    if (!q.unit.empty()) units.insert(q.unit);
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"" << report::XmlEscape(spec.name)
    << "\"\n"
    << "  guid=\"@GUID@\"\n"
    << "  description=\"" << report::XmlEscape(spec.name)
    << (sensor ? ": a virtual sensor, the extended Kalman filter of a stochastic grey-box model "
                 "at its estimates\"\n"
               : ": the deterministic part of a stochastic grey-box model at its estimates\"\n")
    << "  generationTool=\"greybench\" variableNamingConvention=\"structured\""
    << " numberOfEventIndicators=\"0\">\n";
  if (me)
    x << "  <ModelExchange modelIdentifier=\"" << out.identifier
      << "\" canGetAndSetFMUstate=\"false\" canSerializeFMUstate=\"false\""
      << " providesDirectionalDerivative=\"false\">\n"
      << "    <SourceFiles><File name=\"" << out.identifier << ".c\"/></SourceFiles>\n"
      << "  </ModelExchange>\n";
  if (cs)
    x << "  <CoSimulation modelIdentifier=\"" << out.identifier
      << "\" canHandleVariableCommunicationStepSize=\"true\" canInterpolateInputs=\"true\""
      << " maxOutputDerivativeOrder=\"0\" canGetAndSetFMUstate=\"false\""
      << " canSerializeFMUstate=\"false\" providesDirectionalDerivative=\"false\">\n"
      << "    <SourceFiles><File name=\"" << out.identifier << ".c\"/></SourceFiles>\n"
      << "  </CoSimulation>\n";
  if (!units.empty()) {
    x << "  <UnitDefinitions>\n";
    for (const std::string& u : units) x << "    <Unit name=\"" << report::XmlEscape(u) << "\"/>\n";
    x << "  </UnitDefinitions>\n";
  }
  x << "  <LogCategories>\n    <Category name=\"logStatusError\" description=\"refused calls "
       "and values that are not finite\"/>\n  </LogCategories>\n"
    << "  <DefaultExperiment tolerance=\"" << report::ShortestDouble(rtol) << "\"/>\n"
    << "  <ModelVariables>\n";
  auto variable = [&x](const std::string& name, std::size_t vr, const char* causality,
                       const char* variability, const char* initial, const std::string& description,
                       const std::string& real, const char* type = "Real") {
    x << "    <ScalarVariable name=\"" << report::XmlEscape(name) << "\" valueReference=\"" << vr
      << "\" causality=\"" << causality << "\" variability=\"" << variability << "\"";
    if (*initial) x << " initial=\"" << initial << "\"";
    if (!description.empty()) x << " description=\"" << report::XmlEscape(description) << "\"";
    x << ">\n      <" << type << real << "/>\n    </ScalarVariable>\n";
  };
  auto parameters = [&](std::size_t vr) {
    for (std::size_t i = 0; i < k; ++i) {
      const model::Parameter& q = spec.parameters[i];
      std::string real = " start=\"" + report::ShortestDouble(theta[i]) + "\"";
      if (!q.unit.empty()) real += " unit=\"" + report::XmlEscape(q.unit) + "\"";
      variable(q.name, vr++, "parameter", "tunable", "exact",
               q.description.empty() ? (q.fixed ? "fixed in the fit" : "estimate") : q.description,
               real);
    }
  };
  if (!sensor) {
    std::size_t vr = 0;
    for (std::size_t i = 0; i < n; ++i)
      variable(state_var[i], vr++, "local", "continuous", "exact",
               state_var[i] == spec.states[i]
                   ? "state"
                   : fmt::format("state {} of the model (a variable of the interface has its name)",
                                 spec.states[i]),
               " start=\"" + report::ShortestDouble(x0[i]) + "\"");
    for (std::size_t i = 0; i < n; ++i)
      variable("der(" + state_var[i] + ")", vr++, "local", "continuous", "", "",
               " derivative=\"" + std::to_string(i + 1) + "\"");
    for (std::size_t i = 0; i < m; ++i)
      variable(spec.inputs[i], vr++, "input", "continuous", "", "input", " start=\"0\"");
    for (std::size_t o = 0; o < p; ++o)
      variable(spec.outputs[o], vr++, "output", "continuous", "", "output (the observation h)", "");
    parameters(vr);
    x << "  </ModelVariables>\n  <ModelStructure>\n";
    if (p > 0) {
      x << "    <Outputs>\n";
      for (std::size_t o = 0; o < p; ++o)
        x << "      <Unknown index=\"" << 2 * n + m + o + 1 << "\" dependencies=\""
          << Dependencies(observation.exprs[o], spec) << "\"/>\n";
      x << "    </Outputs>\n";
    }
    x << "    <Derivatives>\n";
    for (std::size_t i = 0; i < n; ++i)
      x << "      <Unknown index=\"" << n + i + 1 << "\" dependencies=\""
        << Dependencies(drift.exprs[i], spec) << "\"/>\n";
    x << "    </Derivatives>\n    <InitialUnknowns>\n";
    for (std::size_t i = 0; i < n; ++i) x << "      <Unknown index=\"" << n + i + 1 << "\"/>\n";
    for (std::size_t o = 0; o < p; ++o)
      x << "      <Unknown index=\"" << 2 * n + m + o + 1 << "\"/>\n";
    x << "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n";
  } else {
    // Real: u, y; the filter's outputs; the parameters. Boolean (value references of their
    // own): each measurement's validity, ready. sensor.c's header says what each output is.
    std::size_t vr = 0;
    for (std::size_t i = 0; i < m; ++i)
      variable(spec.inputs[i], vr++, "input", "continuous", "", "input", " start=\"0\"");
    for (std::size_t o = 0; o < p; ++o)
      variable(spec.outputs[o], vr++, "input", "continuous", "",
               "measurement of output " + spec.outputs[o] + " (used where " + spec.outputs[o] +
                   "_valid is true)",
               " start=\"0\"");
    const std::pair<const char*, const char*> state_outputs[] = {
        {"_filtered", "filtered state x_{j|j} of the newest sample the filter has used"},
        {"_filtered_sd", "its standard deviation"},
        {"_predicted", "state at the end of the step, predicted from every measurement so far"},
        {"_predicted_sd", "its standard deviation"}};
    for (const auto& [suffix, what] : state_outputs)
      for (std::size_t i = 0; i < n; ++i)
        variable(spec.states[i] + suffix, vr++, "output", "discrete", "calculated", what, "");
    const std::pair<const char*, const char*> output_outputs[] = {
        {"_pred", "one-step prediction of the next measurement"},
        {"_sd", "its standard deviation, with the measurement noise"},
        {"_residual",
         "innovation of the newest measurement the filter has used (0 where not "
         "valid)"}};
    for (const auto& [suffix, what] : output_outputs)
      for (std::size_t o = 0; o < p; ++o)
        variable(spec.outputs[o] + suffix, vr++, "output", "discrete", "calculated", what, "");
    const std::size_t real_outputs = vr;
    parameters(vr);
    for (std::size_t o = 0; o < p; ++o)
      variable(spec.outputs[o] + "_valid", o, "input", "discrete", "",
               "whether " + spec.outputs[o] + " is measured at this sample", " start=\"true\"",
               "Boolean");
    variable("ready", p, "output", "discrete", "calculated",
             "true once the filter has used its first sample", "", "Boolean");
    // Outputs: every Real output, then ready (the ModelVariables' 1-based order: the Reals,
    // the parameters, the Booleans). None depends on an input directly: a step's outputs come
    // from the inputs set before it.
    std::vector<std::size_t> outputs;
    for (std::size_t i = m + p; i < real_outputs; ++i) outputs.push_back(i + 1);
    outputs.push_back(real_outputs + k + p + 1);
    x << "  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n";
    for (const std::size_t index : outputs)
      x << "      <Unknown index=\"" << index << "\" dependencies=\"\"/>\n";
    x << "    </Outputs>\n    <InitialUnknowns>\n";
    for (const std::size_t index : outputs)
      x << "      <Unknown index=\"" << index << "\" dependencies=\"\"/>\n";
    x << "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n";
  }

  // The generated part the runtime expects (runtime.c's header says what).
  std::ostringstream c;
  c << "/* " << out.identifier << ": " << spec.name
    << "\n   An FMI 2.0 FMU exported by greybench: the model's generated code, then greybench's "
       "FMI runtime. */\n"
    << "#include \"fmi2Functions.h\"\n"
    << *generated << "\n"
    << "#define GB_N_STATES " << n << "\n#define GB_N_INPUTS " << m << "\n#define GB_N_OUTPUTS "
    << p << "\n#define GB_N_PARAMETERS " << k << "\n#define GB_SLOT_INPUT " << model.input_slot()
    << "\n#define GB_SLOT_PARAMETER " << model.parameter_slot() << "\n#define GB_SLOT_TIME "
    << model.time_slot() << "\n#define GB_RTOL " << fmt::format("{:a}", rtol)
    << "\n#define GB_ATOL " << fmt::format("{:a}", atol) << "\n#define GB_SUPPORTS(type) ("
    << (me && cs ? "1"
        : me     ? "(type) == fmi2ModelExchange"
                 : "(type) == fmi2CoSimulation")
    << ")\n";
  if (!sensor) {
    c << "#define gb_drift gb_program_0\n#define gb_observation gb_program_1\n";
  } else {
    int largest = 0;
    for (const int d : options.delays) largest = std::max(largest, d);
    c << "#define GB_VIRTUAL_SENSOR 1\n#define gb_dynamics gb_program_0\n"
      << "#define gb_measurement gb_program_1\n#define GB_DELAY_MAX " << largest
      << "\n#define GB_FOH " << (spec.input_hold == model::InputHold::kFoh ? 1 : 0)
      << "\n#define GB_P0 "
      << (options.initial_covariance_kind == model::InitialCovariance::kCtsm         ? 1
          : options.initial_covariance_kind == model::InitialCovariance::kStationary ? 2
                                                                                     : 0)
      << "\n";
  }
  auto array = [&c](const char* name, const std::vector<std::string>& values) {
    c << "static const " << name << "[] = {";
    for (std::size_t i = 0; i < values.size(); ++i) c << (i ? ", " : "") << values[i];
    if (values.empty()) c << "0";
    c << "};\n";
  };
  std::vector<std::string> v;
  for (const double t : theta) v.push_back(fmt::format("{:a}", t));
  array("double gb_theta_start", v);
  v.clear();
  for (const double s : x0) v.push_back(fmt::format("{:a}", s));
  array("double gb_x_start", v);
  array("double gb_u_start", std::vector<std::string>(m, "0.0"));
  v.clear();
  for (const auto& s : state_var) v.push_back(CString(s));
  array("char* const gb_state_name", v);
  v.clear();
  for (const auto& y : spec.outputs) v.push_back(CString(y));
  array(sensor ? "char* const gb_measured_name" : "char* const gb_output_name", v);
  if (sensor) {
    v.clear();
    for (const int d : options.delays) v.push_back(std::to_string(d));
    array("int gb_delay", v);
    v.clear();
    for (const double e : options.initial_covariance) v.push_back(fmt::format("{:a}", e));
    if (options.initial_covariance_kind == model::InitialCovariance::kExplicit)
      array("double gb_P0_start", v);
  }
  const std::string description = x.str();
  const std::string body = c.str();
  const std::uint64_t h1 = Fnv1a(description + body), h2 = Fnv1a(body + description + "2");
  out.guid = fmt::format("{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}", h1 >> 32, (h1 >> 16) & 0xffff,
                         h1 & 0xffff, h2 >> 48, h2 & 0xffffffffffffULL);
  out.model_description = description;
  out.model_description.replace(out.model_description.find("@GUID@"), 6, out.guid);
  out.source = body + "#define GB_GUID " + CString(out.guid) + "\n" + embedded::kRuntime;
  if (sensor) out.source += embedded::kSensor;
  return out;
}

Status ExportFmu(const model::NonlinearModel& model, std::span<const double> theta,
                 const FmuOptions& options, const std::string& path) {
  auto sources = MakeFmuSources(model, theta, options);
  if (!sources) return sources.error();
  // A private folder for the build: the source, the headers and the library.
  static std::atomic<int> counter{0};
  std::error_code ec;
  const fs::path dir =
      fs::temp_directory_path(ec) / fmt::format("greybench-fmu-{}-{}", getpid(), counter++);
  if (ec || !fs::create_directories(dir, ec))
    return FileError(dir.string(), "cannot create a folder to build the FMU in");
  struct Cleanup {
    fs::path dir;
    ~Cleanup() {
      std::error_code ignored;
      fs::remove_all(dir, ignored);
    }
  } cleanup{dir};
  const std::string id = sources->identifier;
  const std::pair<const char*, const char*> headers[] = {
      {"fmi2TypesPlatform.h", embedded::kTypesPlatform},
      {"fmi2FunctionTypes.h", embedded::kFunctionTypes},
      {"fmi2Functions.h", embedded::kFunctions}};
  for (const auto& [name, text] : headers) {
    if (auto s = WriteFileAtomic((dir / name).string(), text); !s) return s.error();
  }
  const fs::path c_file = dir / (id + ".c"), library = dir / (id + ".so"), log = dir / "cc.log";
  if (auto s = WriteFileAtomic(c_file.string(), sources->source); !s) return s.error();
  const std::vector<std::string> flags = {
      "-O2", "-fPIC", "-shared", "-fvisibility=hidden", "-std=c99", "-I" + dir.string(), "-w"};
  bool ran = false;
  if (auto s = expr::RunCCompiler(c_file, library, flags, log, "the FMU's generated C", &ran); !s)
    return NumericalError("FMU export: " + s.error().message);
  std::ifstream in(library, std::ios::binary);
  std::string binary((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) return FileError(library.string(), "cannot read the built library");
  std::vector<ZipEntry> entries = {{"modelDescription.xml", sources->model_description},
                                   {"binaries/linux64/" + id + ".so", binary},
                                   {"sources/" + id + ".c", sources->source}};
  for (const auto& [name, text] : headers)
    entries.push_back({std::string("sources/") + name, text});
  entries.push_back({"sources/LICENSE.txt", embedded::kLicence});
  return WriteZipFile(path, entries);
}

}  // namespace gb::fmu
