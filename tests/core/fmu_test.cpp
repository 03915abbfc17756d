// The FMU export (core/fmu/fmu.h), driven as an importer drives it: the archive unpacked by
// Python's zipfile, the binary loaded with dlopen, the FMI 2.0 call sequence of Model Exchange
// and of Co-Simulation, checked against the closed form of a first-order lag
// (x(t) = b u / a + (x0 - b u / a) e^{-a t}), and illegal call orders refused with a logged
// message. modelDescription.xml is checked against the standard's schema where xmllint and the
// schema are on the machine (GREYBENCH_FMI_SCHEMA, else ../shared/fmi/fmi2/schema beside the
// source tree).
#include "core/fmu/fmu.h"

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <dlfcn.h>
#include <gtest/gtest.h>

#include "core/filter/ekf.h"
#include "core/fmu/fmi2/fmi2Functions.h"
#include "core/util/json.h"

namespace gb::fmu {
namespace {

namespace fs = std::filesystem;

// dx = (b u - a x) dt, y = c x, with a sqrt-free nonlinear second state z' = x - z^3 / 3 for the
// dependencies.
constexpr const char* kLag = R"({
  "greybench_model": 1,
  "name": "First-order lag",
  "states": ["x", "z"],
  "inputs": ["u"],
  "outputs": ["y", "w"],
  "parameters": {
    "a": {"value": 2.0, "unit": "1/s", "description": "the lag's rate"},
    "b": {"value": 3.0},
    "c": {"value": 0.5},
    "s": {"value": 0.1},
    "x0": {"value": 0.25}
  },
  "drift": {"x": "b*u - a*x", "z": "x - z^3/3"},
  "diffusion": {"x": "s"},
  "observation": {"y": "c*x", "w": "z + u"},
  "measurement_variance": {"y": "0.01", "w": "0.01"},
  "initial_state": {"x": "x0", "z": "0"},
  "ekf": {"rtol": 1e-10, "atol": 1e-12}
})";

model::NonlinearModel Lag() {
  auto spec = model::ParseModel(Json::parse(kLag), "lag.json");
  EXPECT_TRUE(spec.ok()) << spec.error().ToString();
  return *model::NonlinearModel::Compile(*spec);
}

struct Logged {
  std::vector<std::string> messages;
};

void Logger(fmi2ComponentEnvironment env, fmi2String, fmi2Status, fmi2String, fmi2String format,
            ...) {
  char text[1024];
  va_list args;
  va_start(args, format);
  vsnprintf(text, sizeof text, format, args);
  va_end(args);
  static_cast<Logged*>(env)->messages.emplace_back(text);
}

// The FMU exported, unpacked and loaded.
class Fmu {
 public:
  explicit Fmu(const std::string& name, Interface interface = Interface::kBoth)
      : Fmu(name, Lag(), [interface] {
          FmuOptions options;
          options.interface = interface;
          return options;
        }()) {}
  Fmu(const std::string& name, const model::NonlinearModel& model, const FmuOptions& options) {
    dir_ = fs::path(::testing::TempDir()) / ("gb-fmu-test-" + name);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    path_ = (dir_ / "lag.fmu").string();
    status_ = ExportFmu(model, model.spec().Values(), options, path_);
    if (!status_.ok()) return;
    const std::string unpack =
        "python3 -c \"import zipfile,sys; zipfile.ZipFile(sys.argv[1])"
        ".extractall(sys.argv[2])\" '" +
        path_ + "' '" + (dir_ / "unpacked").string() + "'";
    if (std::system(unpack.c_str()) != 0) return;
    const fs::path so = dir_ / "unpacked" / "binaries" / "linux64" / "First_order_lag.so";
    handle_ = dlopen(so.c_str(), RTLD_NOW | RTLD_LOCAL);
    std::ifstream xml(dir_ / "unpacked" / "modelDescription.xml");
    description_.assign(std::istreambuf_iterator<char>(xml), std::istreambuf_iterator<char>());
    const auto at = description_.find("guid=\"");
    if (at != std::string::npos)
      guid_ = description_.substr(at + 6, description_.find('"', at + 6) - at - 6);
  }
  ~Fmu() {
    if (handle_) dlclose(handle_);
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  template <class F>
  F* Get(const char* name) const {
    return reinterpret_cast<F*>(dlsym(handle_, name));
  }
  bool loaded() const { return handle_ != nullptr; }
  const Status& status() const { return status_; }
  const std::string& description() const { return description_; }
  const std::string& guid() const { return guid_; }
  const fs::path& dir() const { return dir_; }

  fmi2Component Instantiate(fmi2Type type, Logged* logged, const char* guid = nullptr) const {
    callbacks_ = {&Logger, &std::calloc, &std::free, nullptr, logged};
    return Get<fmi2InstantiateTYPE>("fmi2Instantiate")("lag", type, guid ? guid : guid_.c_str(), "",
                                                       &callbacks_, fmi2False, fmi2False);
  }

 private:
  fs::path dir_;
  std::string path_, description_, guid_;
  Status status_ = Ok{};
  void* handle_ = nullptr;
  mutable fmi2CallbackFunctions callbacks_{};
};

// Value references: x, z, der(x), der(z), u, y, w, a, b, c, s, x0.
constexpr fmi2ValueReference kX = 0, kU = 4, kY = 5, kW = 6, kA = 7, kB = 8;

double LagClosedForm(double a, double b, double u, double x0, double t) {
  const double steady = b * u / a;
  return steady + (x0 - steady) * std::exp(-a * t);
}

TEST(Fmu, ModelExchangeGivesTheModelsDerivativesAndOutputs) {
  Fmu fmu("me");
  ASSERT_TRUE(fmu.status().ok()) << fmu.status().error().ToString();
  ASSERT_TRUE(fmu.loaded()) << dlerror();
  Logged logged;
  fmi2Component c = fmu.Instantiate(fmi2ModelExchange, &logged);
  ASSERT_NE(c, nullptr);
  auto set_real = fmu.Get<fmi2SetRealTYPE>("fmi2SetReal");
  auto get_real = fmu.Get<fmi2GetRealTYPE>("fmi2GetReal");
  const double u = 1.5;
  ASSERT_EQ(set_real(c, &kU, 1, &u), fmi2OK);
  ASSERT_EQ(
      fmu.Get<fmi2SetupExperimentTYPE>("fmi2SetupExperiment")(c, fmi2False, 0, 0, fmi2False, 0),
      fmi2OK);
  ASSERT_EQ(fmu.Get<fmi2EnterInitializationModeTYPE>("fmi2EnterInitializationMode")(c), fmi2OK);
  ASSERT_EQ(fmu.Get<fmi2ExitInitializationModeTYPE>("fmi2ExitInitializationMode")(c), fmi2OK);
  fmi2EventInfo info{};
  auto new_discrete = fmu.Get<fmi2NewDiscreteStatesTYPE>("fmi2NewDiscreteStates");
  ASSERT_EQ(new_discrete(c, &info), fmi2OK);
  EXPECT_FALSE(info.newDiscreteStatesNeeded);
  EXPECT_FALSE(info.valuesOfContinuousStatesChanged);
  ASSERT_EQ(fmu.Get<fmi2EnterContinuousTimeModeTYPE>("fmi2EnterContinuousTimeMode")(c), fmi2OK);
  // The importer integrates: classical Runge-Kutta on a fine grid.
  auto set_time = fmu.Get<fmi2SetTimeTYPE>("fmi2SetTime");
  auto set_states = fmu.Get<fmi2SetContinuousStatesTYPE>("fmi2SetContinuousStates");
  auto derivatives = fmu.Get<fmi2GetDerivativesTYPE>("fmi2GetDerivatives");
  auto completed = fmu.Get<fmi2CompletedIntegratorStepTYPE>("fmi2CompletedIntegratorStep");
  double x[2];
  ASSERT_EQ(fmu.Get<fmi2GetContinuousStatesTYPE>("fmi2GetContinuousStates")(c, x, 2), fmi2OK);
  EXPECT_EQ(x[0], 0.25);  // the start: x0 at the estimates
  EXPECT_EQ(x[1], 0.0);
  auto f = [&](double t, const double* at, double* dx) {
    ASSERT_EQ(set_time(c, t), fmi2OK);
    ASSERT_EQ(set_states(c, at, 2), fmi2OK);
    ASSERT_EQ(derivatives(c, dx, 2), fmi2OK);
  };
  const double h = 1e-3;
  double t = 0.0;
  for (int step = 0; step < 1000; ++step) {
    double k1[2], k2[2], k3[2], k4[2], y[2];
    f(t, x, k1);
    for (int i = 0; i < 2; ++i) y[i] = x[i] + 0.5 * h * k1[i];
    f(t + 0.5 * h, y, k2);
    for (int i = 0; i < 2; ++i) y[i] = x[i] + 0.5 * h * k2[i];
    f(t + 0.5 * h, y, k3);
    for (int i = 0; i < 2; ++i) y[i] = x[i] + h * k3[i];
    f(t + h, y, k4);
    for (int i = 0; i < 2; ++i) x[i] += h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
    t += h;
    ASSERT_EQ(set_time(c, t), fmi2OK);
    ASSERT_EQ(set_states(c, x, 2), fmi2OK);
    fmi2Boolean event = fmi2True, stop = fmi2True;
    ASSERT_EQ(completed(c, fmi2True, &event, &stop), fmi2OK);
    EXPECT_FALSE(event);
  }
  const double expected = LagClosedForm(2.0, 3.0, u, 0.25, 1.0);
  EXPECT_NEAR(x[0], expected, 1e-11);
  double y[2];
  const fmi2ValueReference outputs[2] = {kY, kW};
  ASSERT_EQ(get_real(c, outputs, 2, y), fmi2OK);
  EXPECT_NEAR(y[0], 0.5 * expected, 1e-11);
  EXPECT_EQ(y[1], x[1] + u);
  // A tunable parameter set in Event Mode takes effect.
  ASSERT_EQ(fmu.Get<fmi2EnterEventModeTYPE>("fmi2EnterEventMode")(c), fmi2OK);
  const double a = 4.0;
  ASSERT_EQ(set_real(c, &kA, 1, &a), fmi2OK);
  double dx[2];
  ASSERT_EQ(derivatives(c, dx, 2), fmi2OK);
  EXPECT_DOUBLE_EQ(dx[0], 3.0 * u - 4.0 * x[0]);
  // The derivatives jumped: the event asks the importer to restart its integrator (fmusim's
  // CVODE restarts on valuesOfContinuousStatesChanged and on nothing else), once.
  ASSERT_EQ(new_discrete(c, &info), fmi2OK);
  EXPECT_TRUE(info.valuesOfContinuousStatesChanged);
  ASSERT_EQ(new_discrete(c, &info), fmi2OK);
  EXPECT_FALSE(info.valuesOfContinuousStatesChanged);
  // An input stepped in Continuous-Time Mode, just before the importer's event (as fmusim
  // sets a stepped input), asks for the same; an input set to the value it has does not.
  ASSERT_EQ(fmu.Get<fmi2EnterContinuousTimeModeTYPE>("fmi2EnterContinuousTimeMode")(c), fmi2OK);
  const double stepped = 2.5;
  ASSERT_EQ(set_real(c, &kU, 1, &stepped), fmi2OK);
  ASSERT_EQ(fmu.Get<fmi2EnterEventModeTYPE>("fmi2EnterEventMode")(c), fmi2OK);
  ASSERT_EQ(set_real(c, &kU, 1, &stepped), fmi2OK);
  ASSERT_EQ(new_discrete(c, &info), fmi2OK);
  EXPECT_TRUE(info.valuesOfContinuousStatesChanged);
  ASSERT_EQ(set_real(c, &kU, 1, &stepped), fmi2OK);
  ASSERT_EQ(new_discrete(c, &info), fmi2OK);
  EXPECT_FALSE(info.valuesOfContinuousStatesChanged);
  ASSERT_EQ(fmu.Get<fmi2TerminateTYPE>("fmi2Terminate")(c), fmi2OK);
  fmu.Get<fmi2FreeInstanceTYPE>("fmi2FreeInstance")(c);
  EXPECT_TRUE(logged.messages.empty()) << logged.messages.front();
}

TEST(Fmu, CoSimulationStepsAtTheModelsTolerance) {
  Fmu fmu("cs");
  ASSERT_TRUE(fmu.status().ok()) << fmu.status().error().ToString();
  ASSERT_TRUE(fmu.loaded()) << dlerror();
  Logged logged;
  fmi2Component c = fmu.Instantiate(fmi2CoSimulation, &logged);
  ASSERT_NE(c, nullptr);
  auto set_real = fmu.Get<fmi2SetRealTYPE>("fmi2SetReal");
  auto get_real = fmu.Get<fmi2GetRealTYPE>("fmi2GetReal");
  auto do_step = fmu.Get<fmi2DoStepTYPE>("fmi2DoStep");
  const double b = 5.0;
  ASSERT_EQ(set_real(c, &kB, 1, &b), fmi2OK);  // a parameter set before initialisation
  ASSERT_EQ(
      fmu.Get<fmi2SetupExperimentTYPE>("fmi2SetupExperiment")(c, fmi2False, 0, 0, fmi2False, 0),
      fmi2OK);
  ASSERT_EQ(fmu.Get<fmi2EnterInitializationModeTYPE>("fmi2EnterInitializationMode")(c), fmi2OK);
  ASSERT_EQ(fmu.Get<fmi2ExitInitializationModeTYPE>("fmi2ExitInitializationMode")(c), fmi2OK);
  // The input steps from 0 to 1 at t = 0.5 (held over each communication step).
  double t = 0.0;
  const double step = 0.05;
  for (int k = 0; k < 40; ++k) {
    const double u = t < 0.5 - 1e-12 ? 0.0 : 1.0;
    ASSERT_EQ(set_real(c, &kU, 1, &u), fmi2OK);
    ASSERT_EQ(do_step(c, t, step, fmi2True), fmi2OK);
    t += step;
    double x = 0.0;
    ASSERT_EQ(get_real(c, &kX, 1, &x), fmi2OK);
    const double expected =
        t <= 0.5 + 1e-12
            ? LagClosedForm(2.0, b, 0.0, 0.25, t)
            : LagClosedForm(2.0, b, 1.0, LagClosedForm(2.0, b, 0.0, 0.25, 0.5), t - 0.5);
    EXPECT_NEAR(x, expected, 1e-9 * (1.0 + std::abs(expected))) << "t = " << t;
  }
  ASSERT_EQ(fmu.Get<fmi2TerminateTYPE>("fmi2Terminate")(c), fmi2OK);
  // A reset instance is as instantiated: the states, inputs and parameters at their starts.
  ASSERT_EQ(fmu.Get<fmi2ResetTYPE>("fmi2Reset")(c), fmi2OK);
  ASSERT_EQ(fmu.Get<fmi2EnterInitializationModeTYPE>("fmi2EnterInitializationMode")(c), fmi2OK);
  double start[3];
  const fmi2ValueReference starts[3] = {kX, kU, kB};
  ASSERT_EQ(get_real(c, starts, 3, start), fmi2OK);
  EXPECT_EQ(start[0], 0.25);
  EXPECT_EQ(start[1], 0.0);
  EXPECT_EQ(start[2], 3.0);
  ASSERT_EQ(fmu.Get<fmi2ExitInitializationModeTYPE>("fmi2ExitInitializationMode")(c), fmi2OK);
  ASSERT_EQ(fmu.Get<fmi2TerminateTYPE>("fmi2Terminate")(c), fmi2OK);
  fmu.Get<fmi2FreeInstanceTYPE>("fmi2FreeInstance")(c);
  EXPECT_TRUE(logged.messages.empty()) << logged.messages.front();
}

TEST(Fmu, IllegalCallOrdersAreRefusedWithAMessage) {
  Fmu fmu("illegal");
  ASSERT_TRUE(fmu.status().ok()) << fmu.status().error().ToString();
  ASSERT_TRUE(fmu.loaded()) << dlerror();
  Logged logged;
  EXPECT_EQ(fmu.Instantiate(fmi2ModelExchange, &logged, "{not-this-fmu}"), nullptr);
  ASSERT_FALSE(logged.messages.empty());
  EXPECT_NE(logged.messages.back().find("guid"), std::string::npos) << logged.messages.back();

  fmi2Component c = fmu.Instantiate(fmi2ModelExchange, &logged);
  ASSERT_NE(c, nullptr);
  double dx[2];
  EXPECT_EQ(fmu.Get<fmi2GetDerivativesTYPE>("fmi2GetDerivatives")(c, dx, 2), fmi2Error);
  EXPECT_NE(logged.messages.back().find("fmi2GetDerivatives: not allowed in Instantiated"),
            std::string::npos)
      << logged.messages.back();
  EXPECT_EQ(fmu.Get<fmi2DoStepTYPE>("fmi2DoStep")(c, 0.0, 0.1, fmi2True), fmi2Error);
  EXPECT_NE(logged.messages.back().find("fmi2DoStep: not allowed"), std::string::npos)
      << logged.messages.back();
  const double v = 1.0;
  EXPECT_EQ(fmu.Get<fmi2SetRealTYPE>("fmi2SetReal")(c, &kY, 1, &v), fmi2Error);
  EXPECT_NE(logged.messages.back().find("never set"), std::string::npos);
  const fmi2ValueReference nowhere = 99;
  double out = 0.0;
  ASSERT_EQ(fmu.Get<fmi2EnterInitializationModeTYPE>("fmi2EnterInitializationMode")(c), fmi2OK);
  EXPECT_EQ(fmu.Get<fmi2GetRealTYPE>("fmi2GetReal")(c, &nowhere, 1, &out), fmi2Error);
  EXPECT_NE(logged.messages.back().find("no variable has value reference 99"), std::string::npos);
  EXPECT_EQ(fmu.Get<fmi2SetContinuousStatesTYPE>("fmi2SetContinuousStates")(c, dx, 2), fmi2Error);
  EXPECT_EQ(fmu.Get<fmi2EnterInitializationModeTYPE>("fmi2EnterInitializationMode")(c), fmi2Error);
  fmu.Get<fmi2FreeInstanceTYPE>("fmi2FreeInstance")(c);

  // Exported for Model Exchange only: Co-Simulation is refused at instantiation.
  Fmu me_only("me-only", Interface::kModelExchange);
  ASSERT_TRUE(me_only.loaded());
  Logged refused;
  EXPECT_EQ(me_only.Instantiate(fmi2CoSimulation, &refused), nullptr);
  ASSERT_FALSE(refused.messages.empty());
  EXPECT_NE(me_only.description().find("<ModelExchange"), std::string::npos);
  EXPECT_EQ(me_only.description().find("<CoSimulation"), std::string::npos);
}

TEST(Fmu, ModelDescriptionListsTheVariablesAndTheirDependencies) {
  const model::NonlinearModel model = Lag();
  auto sources = MakeFmuSources(model, model.spec().Values(), {});
  ASSERT_TRUE(sources) << sources.error().ToString();
  const std::string& d = sources->model_description;
  EXPECT_EQ(sources->identifier, "First_order_lag");
  EXPECT_NE(d.find("name=\"a\" valueReference=\"7\" causality=\"parameter\" "
                   "variability=\"tunable\" initial=\"exact\" description=\"the lag&apos;s rate\""),
            std::string::npos)
      << d;
  EXPECT_NE(d.find("<Real start=\"2\" unit=\"1/s\"/>"), std::string::npos);
  EXPECT_NE(d.find("<Unit name=\"1/s\"/>"), std::string::npos);
  EXPECT_NE(d.find("name=\"der(x)\" valueReference=\"2\""), std::string::npos);
  EXPECT_NE(d.find("<Real derivative=\"1\"/>"), std::string::npos);
  // der(x) = b u - a x: x (index 1) and u (index 5); der(z) = x - z^3/3: x and z;
  // y = c x: x; w = z + u: z and u.
  EXPECT_NE(d.find("<Unknown index=\"3\" dependencies=\"1 5\"/>"), std::string::npos) << d;
  EXPECT_NE(d.find("<Unknown index=\"4\" dependencies=\"1 2\"/>"), std::string::npos) << d;
  EXPECT_NE(d.find("<Unknown index=\"6\" dependencies=\"1\"/>"), std::string::npos) << d;
  EXPECT_NE(d.find("<Unknown index=\"7\" dependencies=\"2 5\"/>"), std::string::npos) << d;
  // The same model and values give the same guid; other values another.
  std::vector<double> other = model.spec().Values();
  other[0] = 2.5;
  EXPECT_EQ(MakeFmuSources(model, model.spec().Values(), {})->guid, sources->guid);
  EXPECT_NE(MakeFmuSources(model, other, {})->guid, sources->guid);
  // Bad input is refused with the reason.
  FmuOptions bad;
  bad.identifier = "9lives";
  auto refused = MakeFmuSources(model, model.spec().Values(), bad);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("not a C identifier"), std::string::npos);
  other[1] = std::nan("");
  auto not_finite = MakeFmuSources(model, other, {});
  ASSERT_FALSE(not_finite);
  EXPECT_NE(not_finite.error().message.find("parameter b"), std::string::npos);
}

// The virtual sensor against greybench's own extended Kalman filter (EkfRunFilter's trace) on a
// record of the lag with w delayed by 2 samples and measurements missing: after the step from
// row k the filtered states are x_{j|j} of j = k - 2, the innovations those of rows j + d_o, the
// predictions those of row k + 1 from every measurement given so far (the same integrator's
// steps: to rounding).
TEST(Fmu, VirtualSensorIsGreybenchsFilter) {
  auto spec = model::ParseModel(Json::parse(kLag), "lag.json");
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  spec->output_delay[1] = {2, 2};
  const model::NonlinearModel model = *model::NonlinearModel::Compile(*spec);
  const std::vector<double> theta = spec->Values();
  auto options = VirtualSensorOptions(model, theta, std::vector<int>{-1, -1});
  ASSERT_TRUE(options) << options.error().ToString();
  EXPECT_EQ(options->delays, (std::vector<int>{0, 2}));
  Fmu fmu("sensor", model, *options);
  ASSERT_TRUE(fmu.status().ok()) << fmu.status().error().ToString();
  ASSERT_TRUE(fmu.loaded()) << dlerror();

  const int N = 120, D = 2;
  data::Series series;
  series.U.resize(1, N);
  series.Y.resize(2, N);
  for (int k = 0; k < N; ++k) {
    const double t = 0.05 * k + 0.001 * (k % 3);  // uneven intervals
    series.time.push_back(t);
    series.U(0, k) = (k / 15) % 2 ? 1.0 : -0.5;
    series.Y(0, k) = 0.5 * (0.4 + 0.3 * std::sin(0.7 * k));
    series.Y(1, k) = 0.2 * std::cos(0.3 * k) + series.U(0, k);
  }
  series.Y(0, 30) = series.Y(1, 31) = series.Y(0, 60) = std::nan("");  // missing
  series.intervals = data::GroupIntervals(series.time);
  filter::FilterSettings settings = filter::FilterSettings::FromModel(*spec);
  filter::FilterTrace trace;
  auto run = filter::EkfRunFilter(model, theta, series, settings, &trace);
  ASSERT_TRUE(run) << run.error().ToString();

  Logged logged;
  fmi2Component c = fmu.Instantiate(fmi2CoSimulation, &logged);
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(fmu.Instantiate(fmi2ModelExchange, &logged), nullptr);  // Co-Simulation only
  auto set_real = fmu.Get<fmi2SetRealTYPE>("fmi2SetReal");
  auto get_real = fmu.Get<fmi2GetRealTYPE>("fmi2GetReal");
  auto set_bool = fmu.Get<fmi2SetBooleanTYPE>("fmi2SetBoolean");
  auto get_bool = fmu.Get<fmi2GetBooleanTYPE>("fmi2GetBoolean");
  auto do_step = fmu.Get<fmi2DoStepTYPE>("fmi2DoStep");
  ASSERT_EQ(
      fmu.Get<fmi2SetupExperimentTYPE>("fmi2SetupExperiment")(c, fmi2False, 0, 0, fmi2False, 0),
      fmi2OK);
  ASSERT_EQ(fmu.Get<fmi2EnterInitializationModeTYPE>("fmi2EnterInitializationMode")(c), fmi2OK);
  ASSERT_EQ(fmu.Get<fmi2ExitInitializationModeTYPE>("fmi2ExitInitializationMode")(c), fmi2OK);
  // Real value references: u; y, w; x, z filtered, their sd; predicted, their sd; y, w
  // predictions, their sd, innovations; parameters. Boolean: y_valid, w_valid, ready.
  const fmi2ValueReference kUIn = 0, kMeasured[2] = {1, 2}, kFiltered[2] = {3, 4},
                           kFilteredSd[2] = {5, 6}, kPred[2] = {11, 12}, kSd[2] = {13, 14},
                           kResidual[2] = {15, 16}, kValid[2] = {0, 1}, kReady = 2;
  // Bad calls: an output set, a validity flag that is not one.
  const double value = 1.0;
  EXPECT_EQ(set_real(c, &kFiltered[0], 1, &value), fmi2Error);
  const fmi2Boolean yes = fmi2True;
  EXPECT_EQ(set_bool(c, &kReady, 1, &yes), fmi2Error);
  logged.messages.clear();
  int compared = 0, cut_compared = 0;
  for (int k = 0; k < N; ++k) {
    const double h = k + 1 < N ? series.time[k + 1] - series.time[k] : 0.05;
    ASSERT_EQ(set_real(c, &kUIn, 1, &series.U(0, k)), fmi2OK);
    for (int o = 0; o < 2; ++o) {
      const bool valid = std::isfinite(series.Y(o, k));
      const double y = valid ? series.Y(o, k) : 0.0;
      const fmi2Boolean flag = valid ? fmi2True : fmi2False;
      ASSERT_EQ(set_real(c, &kMeasured[o], 1, &y), fmi2OK);
      ASSERT_EQ(set_bool(c, &kValid[o], 1, &flag), fmi2OK);
    }
    ASSERT_EQ(do_step(c, series.time[k], h, fmi2True), fmi2OK) << "row " << k;
    fmi2Boolean ready = fmi2False;
    ASSERT_EQ(get_bool(c, &kReady, 1, &ready), fmi2OK);
    EXPECT_EQ(ready == fmi2True, k >= D) << "row " << k;
    if (k < D) continue;
    const int j = k - D;
    for (int i = 0; i < 2; ++i) {
      double x = 0.0, sd = 0.0;
      ASSERT_EQ(get_real(c, &kFiltered[i], 1, &x), fmi2OK);
      ASSERT_EQ(get_real(c, &kFilteredSd[i], 1, &sd), fmi2OK);
      EXPECT_NEAR(x, trace.x_filt(i, j), 1e-10 * (1.0 + std::abs(x))) << "row " << k;
      EXPECT_NEAR(sd, std::sqrt(trace.P_filt[j](i, i)), 1e-10) << "row " << k;
    }
    for (int o = 0; o < 2; ++o) {
      const int row = j + options->delays[o];
      double residual = 0.0;
      ASSERT_EQ(get_real(c, &kResidual[o], 1, &residual), fmi2OK);
      const double expected = std::isfinite(series.Y(o, row))
                                  ? series.Y(o, row) - trace.y_pred(o, row)
                                  : 0.0;  // not valid
      EXPECT_NEAR(residual, expected, 1e-10) << "output " << o << ", row " << row;
      // w's prediction of row k + 1 is the filter's (state k - 1, before its measurements).
      // y's (state k + 1) uses every measurement that has arrived, which the filter's own does
      // not: the w of rows k + 1 and k + 2 belong to states k - 1 and k but have not arrived.
      // It is the filter's prediction on the record cut after row k (every later measurement
      // missing), checked at a few rows.
      if (k + 1 >= N) continue;
      double pred = 0.0, sd = 0.0;
      ASSERT_EQ(get_real(c, &kPred[o], 1, &pred), fmi2OK);
      ASSERT_EQ(get_real(c, &kSd[o], 1, &sd), fmi2OK);
      if (o == 1) {
        EXPECT_NEAR(pred, trace.y_pred(o, k + 1), 1e-10) << "row " << k + 1;
        EXPECT_NEAR(sd, std::sqrt(trace.y_var(o, k + 1)), 1e-10);
      } else if (k % 20 == 7) {
        data::Series cut = series;
        cut.Y.rightCols(N - k - 1).setConstant(std::nan(""));
        filter::FilterTrace now;
        ASSERT_TRUE(filter::EkfRunFilter(model, theta, cut, settings, &now));
        EXPECT_NEAR(pred, now.y_pred(o, k + 1), 1e-10) << "row " << k + 1;
        EXPECT_NEAR(sd, std::sqrt(now.y_var(o, k + 1)), 1e-10);
        ++cut_compared;
      }
    }
    ++compared;
  }
  EXPECT_EQ(compared, N - D);
  EXPECT_EQ(cut_compared, 6);
  ASSERT_EQ(fmu.Get<fmi2TerminateTYPE>("fmi2Terminate")(c), fmi2OK);
  fmu.Get<fmi2FreeInstanceTYPE>("fmi2FreeInstance")(c);
  EXPECT_TRUE(logged.messages.empty()) << logged.messages.front();
}

TEST(Fmu, VirtualSensorOptionsRefuseTheIteratedFilter) {
  auto spec = model::ParseModel(Json::parse(kLag), "lag.json");
  ASSERT_TRUE(spec.ok());
  model::ModelSpec iterated = *spec;
  iterated.ekf.iterations = 3;
  auto refused = VirtualSensorOptions(*model::NonlinearModel::Compile(iterated), spec->Values(),
                                      std::vector<int>{0, 0});
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("not the iterated one"), std::string::npos);
}

TEST(Fmu, AStateNamedLikeAnOutputIsRenamedAndTheInterfaceKeepsItsNames) {
  // The crankshaft's shape: the state N is also measured as the output N.
  auto spec = model::ParseModel(Json::parse(R"({
    "greybench_model": 1, "name": "speed",
    "states": ["N", "N_state"], "inputs": ["u"], "outputs": ["N"],
    "parameters": {"a": {"value": 1.0}, "s": {"value": 0.1}},
    "drift": {"N": "u - a*N", "N_state": "N - N_state"}, "diffusion": {"N": "s"},
    "observation": {"N": "N"}, "measurement_variance": {"N": "0.01"},
    "initial_state": {"N": "0", "N_state": "0"}})"),
                                "speed.json");
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  const auto model = *model::NonlinearModel::Compile(*spec);
  auto sources = MakeFmuSources(model, model.spec().Values(), {});
  ASSERT_TRUE(sources) << sources.error().ToString();
  const std::string& d = sources->model_description;
  // N_state is taken by the model's second state: the first becomes N_state2.
  EXPECT_NE(d.find("name=\"N_state2\" valueReference=\"0\" causality=\"local\""), std::string::npos)
      << d;
  EXPECT_NE(d.find("description=\"state N of the model (a variable of the interface has its "
                   "name)\""),
            std::string::npos);
  EXPECT_NE(d.find("name=\"N_state\" valueReference=\"1\""), std::string::npos);
  EXPECT_NE(d.find("name=\"der(N_state2)\" valueReference=\"2\""), std::string::npos);
  EXPECT_NE(d.find("name=\"N\" valueReference=\"5\" causality=\"output\""), std::string::npos);
}

TEST(Fmu, ModelDescriptionIsValidAgainstTheStandardsSchema) {
  std::string schema;
  if (const char* env = std::getenv("GREYBENCH_FMI_SCHEMA")) schema = env;
  if (schema.empty())
    schema = (fs::path(GREYBENCH_SOURCE_DIR) / ".." / "shared" / "fmi" / "fmi2" / "schema" /
              "fmi2ModelDescription.xsd")
                 .string();
  if (!fs::exists(schema) || std::system("xmllint --version > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "needs xmllint and the FMI 2.0 schema (" << schema << ")";
  // The model's FMU and its virtual sensor's.
  const model::NonlinearModel model = Lag();
  auto sensor = VirtualSensorOptions(model, model.spec().Values(), std::vector<int>{0, 0});
  ASSERT_TRUE(sensor);
  const Fmu fmus[] = {Fmu("schema"), Fmu("schema-sensor", model, *sensor)};
  for (const Fmu& fmu : fmus) {
    ASSERT_TRUE(fmu.loaded());
    const std::string command = "xmllint --noout --schema '" + schema + "' '" +
                                (fmu.dir() / "unpacked" / "modelDescription.xml").string() +
                                "' > '" + (fmu.dir() / "xmllint.log").string() + "' 2>&1";
    const int status = std::system(command.c_str());
    std::ifstream log(fmu.dir() / "xmllint.log");
    const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    EXPECT_EQ(status, 0) << fmu.dir() << ": " << text;
  }
}

}  // namespace
}  // namespace gb::fmu
