// The condition monitor (core/online/monitor.h) on the live virtual dyno: its false-alarm rate on
// stationary data, a clogging injector (τ_ff × 1.5) found and named, and the reference read back
// from a result file.
#include "core/online/monitor.h"

#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "core/data/write_csv.h"
#include "core/estimate/estimate.h"
#include "core/project/problem.h"
#include "core/project/result_file.h"
#include "core/sim/live_dyno.h"
#include "core/util/json.h"
#include "core/util/sanitizers.h"

namespace gb::online {
namespace {

const std::string kAssets = std::string(GREYBENCH_SOURCE_DIR) + "/assets/";

struct Fitted {
  project::Problem problem;
  estimate::EstimateSummary summary;
};

// The batch fit of the bundled f1 record (the dyno with seed 1): the reference.
const Fitted& FuelReference() {
  static const Fitted f = [] {
    auto spec = model::LoadModelFile(kAssets + "models/fuel_film.json");
    // Under the sanitizers the delay is held at its estimate (5) and no extra starts are made:
    // the same reference in a fraction of the fits (the delay profile has its own tests).
    if (kSanitized) spec->output_delay[0] = {5, 5};
    auto problem = project::LoadProblem(std::move(*spec), {kAssets + "data/fuel_f1.csv"});
    auto lik = project::MakeLikelihood(*problem);
    estimate::EstimateOptions options;
    if (kSanitized) options.starts_on_bound = 0;
    auto s = estimate::Estimate(*lik, options);
    return Fitted{std::move(*problem), std::move(*s)};
  }();
  return f;
}

struct Watched {
  std::vector<MonitorAlarm> alarms;
  std::vector<double> alarm_t;
  MonitorUpdate last;
};

// The live dyno at f1 (`seed`), watched for `seconds`; `fault` injected at `fault_t` if given.
Watched Watch(const MonitorOptions& options, std::uint64_t seed, double seconds,
              const std::optional<sim::FuelFault>& fault = {}, double fault_t = 0) {
  const Fitted& f = FuelReference();
  auto monitor =
      Monitor::Create(*f.problem.model, ReferenceFromSummary(f.summary, f.problem.spec()), options);
  EXPECT_TRUE(monitor) << monitor.error().ToString();
  sim::FuelExperiment e;
  e.point = *sim::FindFuelPoint("f1");
  e.seed = seed;
  auto dyno = sim::LiveFuelDyno::Create(e);
  EXPECT_TRUE(dyno) << dyno.error().ToString();
  Watched run;
  bool injected = false;
  while (dyno->Time() < seconds) {
    if (fault && !injected && dyno->Time() >= fault_t) {
      EXPECT_TRUE(dyno->Inject(*fault));
      injected = true;
    }
    const sim::FuelSample s = dyno->Next();
    Sample row;
    row.t = s.t;
    row.u = {s.mfi};
    row.y = {s.ilambda};
    auto ups = monitor->Push(row);
    EXPECT_TRUE(ups) << ups.error().ToString();
    for (MonitorUpdate& u : *ups) {
      for (const MonitorAlarm& a : u.alarms) {
        run.alarms.push_back(a);
        run.alarm_t.push_back(u.estimate.t);
      }
      run.last = std::move(u);
    }
  }
  return run;
}

// On stationary data (another seed than the reference's record, so the reference carries its own
// estimation error), the alarms come at or below the rate set: measured over an hour at a rate
// set high enough to count (20 per hour).
TEST(Monitor, OnStationaryDataTheFalseAlarmRateIsAtMostTheRateSet) {
  MonitorOptions o;
  o.false_alarms_per_hour = 20;
  const double hours = kSanitized ? 0.03 : 1.0;
  const Watched run = Watch(o, 5, 3600 * hours);
  const double expected = o.false_alarms_per_hour * hours;
  RecordProperty("alarms", static_cast<int>(run.alarms.size()));
  EXPECT_LE(static_cast<double>(run.alarms.size()), expected + 3.0 * std::sqrt(expected));
}

// An injector that clogs: τ_ff × 1.5 at t = 100 s. Tracking τ_ff and X, the score test names
// τ_ff (up) within a minute and a half, nothing alarms before the fault, and the recursive
// estimate has followed to the new value (within 3 of its SDs) by the end.
TEST(Monitor, ACloggingInjectorIsFoundAndNamedWithinTheDocumentedTime) {
  MonitorOptions o;
  o.recursive.track = {"tau_ff", "X"};
  const sim::FuelFault fault{sim::FuelFault::Kind::kTauFF, 1.5, 0.0};
  const double seconds = kSanitized ? 200 : 250;
  const Watched run = Watch(o, 1, seconds, fault, 100.0);
  std::optional<double> found;
  for (std::size_t i = 0; i < run.alarms.size(); ++i) {
    EXPECT_GE(run.alarm_t[i], 100.0) << run.alarms[i].message;
    if (!found && run.alarms[i].what == "tau_ff: up") found = run.alarm_t[i];
  }
  ASSERT_TRUE(found) << "τ_ff × 1.5 was not alarmed in " << seconds - 100 << " s";
  RecordProperty("delay_s", fmt::format("{:.1f}", *found - 100.0));
  EXPECT_LT(*found - 100.0, 90.0);
  const double truth = 1.5 * sim::FindFuelPoint("f1")->tau_ff;
  EXPECT_LT(std::abs(run.last.estimate.theta[0] - truth), 3.0 * run.last.estimate.sd[0])
      << run.last.estimate.theta[0] << " ± " << run.last.estimate.sd[0] << ", truth " << truth;
}

// A result file read back as a reference equals the summary it was written from.
TEST(Monitor, AReferenceReadFromAResultFileIsTheSummarysOwn) {
  const Fitted& f = FuelReference();
  const std::string path = ::testing::TempDir() + "monitor_reference.json";
  {
    std::FILE* out = std::fopen(path.c_str(), "w");
    ASSERT_NE(out, nullptr);
    std::fputs(f.summary.ToJson().dump().c_str(), out);
    std::fclose(out);
  }
  auto read = project::LoadReference(path, f.problem.spec());
  ASSERT_TRUE(read) << read.error().ToString();
  const Reference direct = ReferenceFromSummary(f.summary, f.problem.spec());
  EXPECT_EQ(read->delay, direct.delay);
  EXPECT_EQ(read->free, direct.free);
  EXPECT_EQ(read->n_obs, direct.n_obs);
  for (std::size_t i = 0; i < direct.theta.size(); ++i)
    EXPECT_NEAR(read->theta[i], direct.theta[i], 1e-12 * std::abs(direct.theta[i]));
  ASSERT_EQ(read->covariance.rows(), direct.covariance.rows());
  for (Eigen::Index a = 0; a < direct.covariance.rows(); ++a)
    for (Eigen::Index b = 0; b < direct.covariance.cols(); ++b)
      EXPECT_NEAR(read->covariance(a, b), direct.covariance(a, b),
                  1e-9 * std::sqrt(direct.covariance(a, a) * direct.covariance(b, b)));
  // A broken correlation matrix is named by its JSON path.
  Json j = f.summary.ToJson();
  j["correlation"]["matrix"][1][0] = 2.0;
  {
    std::FILE* out = std::fopen(path.c_str(), "w");
    std::fputs(j.dump().c_str(), out);
    std::fclose(out);
  }
  auto bad = project::LoadReference(path, f.problem.spec());
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().path, "correlation.matrix[1][0]") << bad.error().ToString();
}

// ---- the score tests' calibration on data simulated from the reference -------------------------

// A scalar Ornstein-Uhlenbeck process driven by a random binary input, observed in noise, one
// row per second:  dx = (-a x + b u) dt + s dω,  y = x + e,  e ~ N(0, r).  Its two variance
// parameters have scores of (z² - 1) kind, far from normal row by row (skewness √8).
constexpr const char* kOuModel = R"json({
  "greybench_model": 1,
  "states": ["x"], "inputs": ["u"], "outputs": ["y"],
  "parameters": {"a": {"value": 0.5, "lower": 0.01, "upper": 10},
                 "b": {"value": 1.0, "lower": -10, "upper": 10},
                 "s": {"value": 0.6, "lower": 0.001, "upper": 10},
                 "r": {"value": 0.2, "lower": 0.0001, "upper": 10}},
  "drift": {"x": "-a*x + b*u"},
  "diffusion": {"x": "s"},
  "observation": {"y": "x"},
  "measurement_variance": {"y": "r"}
})json";

// `rows` rows of the model at `theta` (ModelSpec order), exactly: the transition of one second
// with the input held, the state started from its stationary law for the first input.
std::vector<Sample> SimulateOu(const model::ModelSpec& spec, const std::vector<double>& theta,
                               int rows, std::uint64_t seed) {
  const double a = theta[spec.ParameterIndex("a")], b = theta[spec.ParameterIndex("b")];
  const double s = theta[spec.ParameterIndex("s")], r = theta[spec.ParameterIndex("r")];
  const double phi = std::exp(-a), stationary = s * s / (2.0 * a);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::bernoulli_distribution flip(0.2);
  double u = 1.0, x = b * u / a + std::sqrt(stationary) * normal(rng);
  std::vector<Sample> out;
  for (int k = 0; k < rows; ++k) {
    Sample row;
    row.t = k;
    row.u = {u};
    row.y = {x + std::sqrt(r) * normal(rng)};
    row.line = k + 2;
    out.push_back(std::move(row));
    x = phi * x + b * u * (1.0 - phi) / a + std::sqrt(stationary * (1.0 - phi * phi)) * normal(rng);
    if (flip(rng)) u = -u;
  }
  return out;
}

// The batch fit of 3000 rows of the model at its own values: the reference.
const Fitted& OuReference() {
  static const Fitted f = [] {
    auto spec = model::ParseModel(Json::parse(kOuModel), "ou.json");
    EXPECT_TRUE(spec) << spec.error().ToString();
    const std::vector<Sample> rows = SimulateOu(*spec, spec->Values(), 3000, 11);
    std::vector<double> t, u, y;
    for (const Sample& r : rows) {
      t.push_back(r.t);
      u.push_back(r.u[0]);
      y.push_back(r.y[0]);
    }
    const std::vector<data::CsvColumn> columns{{"t", t}, {"u", u}, {"y", y}};
    auto d = data::ParseCsv(data::FormatCsv(columns), "ou.csv");
    EXPECT_TRUE(d) << d.error().ToString();
    auto problem = project::MakeProblem(std::move(*spec), {*d});
    EXPECT_TRUE(problem) << problem.error().ToString();
    auto lik = project::MakeLikelihood(*problem);
    auto s = estimate::Estimate(*lik, {});
    EXPECT_TRUE(s && s->converged);
    return Fitted{std::move(*problem), std::move(*s)};
  }();
  return f;
}

struct Count {
  std::vector<long> alarms;  // per tracked parameter
  double hours = 0;
};

// Parameter alarms of a monitor of the reference over `rows` rows simulated from it; with
// `design`, the monitor after them.
Count ParameterAlarms(const MonitorOptions& options, int rows, std::uint64_t seed,
                      std::optional<Monitor>* design = nullptr) {
  const Fitted& f = OuReference();
  const Reference ref = ReferenceFromSummary(f.summary, f.problem.spec());
  auto monitor = Monitor::Create(f.problem.spec(), ref, options);
  EXPECT_TRUE(monitor) << monitor.error().ToString();
  Count c;
  c.alarms.assign(monitor->reference_values().size(), 0);
  const std::vector<std::string>& names = monitor->estimator().tracked_names();
  for (const Sample& row : SimulateOu(f.problem.spec(), ref.theta, rows, seed)) {
    auto ups = monitor->Push(row);
    EXPECT_TRUE(ups) << ups.error().ToString();
    for (const MonitorUpdate& u : *ups)
      for (const MonitorAlarm& a : u.alarms)
        if (a.kind == MonitorAlarm::Kind::kParameter)
          for (std::size_t p = 0; p < names.size(); ++p)
            if (a.what.rfind(names[p] + ":", 0) == 0) ++c.alarms[p];
  }
  c.hours = rows / 3600.0;
  if (design) design->emplace(std::move(*monitor));
  return c;
}

// A --change so large that one row shows it (here 500 %, about 30 SDs of a row's score for
// every parameter) was tested as such: decided by a few rows' scores, which are far from normal,
// the tests alarmed 90 times as often as designed on data that match the reference (630 times at
// a rate 20 times lower). It is now tested as the change one row shows at 0.1 SD (blocks of 25
// rows at least), and on 200 000 rows simulated from the reference (55 h at one row per second,
// under a second of compute a parameter) the parameter alarms come at most at twice the
// designed rate (half of R; Bonferroni makes it an upper bound), beyond the count's Poisson error
// (3 SDs): overall and for each parameter.
TEST(Monitor, AChangeOneRowShowsIsTestedAtTheDesignedFalseAlarmRate) {
  MonitorOptions o;
  o.false_alarms_per_hour = 1.0;
  o.parameter_change = 5.0;
  const int rows = kSanitized ? 20000 : 200000;
  std::optional<Monitor> design;
  const Count c = ParameterAlarms(o, rows, 77, &design);
  ASSERT_TRUE(design);
  const std::size_t k = c.alarms.size();
  ASSERT_EQ(k, 4u);                                                 // a, b, s and r
  const double designed = 0.5 * o.false_alarms_per_hour * c.hours;  // all parameter tests
  long total = 0;
  for (std::size_t p = 0; p < k; ++p) {
    SCOPED_TRACE(design->estimator().tracked_names()[p]);
    const double asked = o.parameter_change * std::abs(design->reference_values()[p]);
    EXPECT_LT(design->parameter_change()[p], 0.1 * asked);  // tested as a smaller change
    EXPECT_GE(design->parameter_block()[p], 25);
    const double bound = 2.0 * designed / static_cast<double>(k);
    EXPECT_LE(static_cast<double>(c.alarms[p]), bound + 3.0 * std::sqrt(bound));
    total += c.alarms[p];
  }
  RecordProperty("alarms", static_cast<int>(total));
  RecordProperty("designed", fmt::format("{:.1f}", designed));
  EXPECT_LE(static_cast<double>(total), 2.0 * designed + 3.0 * std::sqrt(2.0 * designed));
}

// A change so small that its test's blocks are longer than the false-alarm rate allows between
// two alarms (1 %: blocks of up to 34 000 rows, 9.5 h, at 1 false alarm per hour): the design (at
// the second row, which gives the sample time) says so and what to change, instead of a CUSUM's
// "in-control ARL out of reach". Smaller still (0.01 %: blocks beyond 100 000 rows) it is refused
// at once.
TEST(Monitor, AChangeTooSmallToTestIsRefusedNamingWhatToChange) {
  const Fitted& f = OuReference();
  const Reference ref = ReferenceFromSummary(f.summary, f.problem.spec());
  MonitorOptions o;
  o.false_alarms_per_hour = 1.0;
  o.parameter_change = 0.01;
  auto monitor = Monitor::Create(f.problem.spec(), ref, o);
  ASSERT_TRUE(monitor) << monitor.error().ToString();
  const std::vector<Sample> rows = SimulateOu(f.problem.spec(), f.summary.theta, 2, 1);
  ASSERT_TRUE(monitor->Push(rows[0]));
  auto second = monitor->Push(rows[1]);
  ASSERT_FALSE(second);
  EXPECT_EQ(second.error().kind, ErrorKind::kInput);
  EXPECT_NE(second.error().message.find("ask for a larger change or fewer false alarms"),
            std::string::npos)
      << second.error().ToString();
  o.parameter_change = 1e-4;
  auto tiny = Monitor::Create(f.problem.spec(), ref, o);
  ASSERT_FALSE(tiny);
  EXPECT_NE(tiny.error().message.find("is too small to test"), std::string::npos)
      << tiny.error().ToString();
}

// ---- the reference's correlation matrix ----------------------------------------------------

void WriteJson(const std::string& path, const Json& j) {
  std::FILE* out = std::fopen(path.c_str(), "w");
  ASSERT_NE(out, nullptr);
  std::fputs(j.dump().c_str(), out);
  std::fclose(out);
}

// The OU reference's result file with `edit` applied, read back (for the model it was fitted to).
Result<Reference> EditedReference(const std::function<void(Json&)>& edit) {
  const Fitted& f = OuReference();
  Json j = f.summary.ToJson();
  edit(j);
  // One file per test: ctest runs these tests side by side, each in a process of its own.
  const std::string path = ::testing::TempDir() +
                           ::testing::UnitTest::GetInstance()->current_test_info()->name() +
                           "_monitor_edited_reference.json";
  WriteJson(path, j);
  return project::LoadReference(path, f.problem.spec());
}

// The position of parameter `name` in the result file's correlation matrix.
std::size_t At(const Json& j, const std::string& name) {
  const Json& names = j["correlation"]["names"];
  for (std::size_t n = 0; n < names.size(); ++n)
    if (names[n] == name) return n;
  ADD_FAILURE() << name << " is not in the correlation";
  return 0;
}

// Without its correlation matrix a result with several standard errors would be taken as
// uncorrelated: refused, with what to do. With one standard error there is nothing to correlate.
TEST(MonitorReference, AResultWithStandardErrorsButNoCorrelationIsRefused) {
  auto read = EditedReference([](Json& j) { j.erase("correlation"); });
  ASSERT_FALSE(read);
  EXPECT_EQ(read.error().path, "correlation");
  EXPECT_NE(read.error().message.find("no correlation matrix"), std::string::npos);
  EXPECT_NE(read.error().message.find("run estimate again"), std::string::npos);
  auto one = EditedReference([](Json& j) {
    j.erase("correlation");
    for (const char* name : {"a", "b", "s"}) j["parameters"][name].erase("std_error");
  });
  ASSERT_TRUE(one) << one.error().ToString();
  EXPECT_EQ(one->free.size(), 1u);
}

// Each way a correlation matrix can be broken is refused with its JSON path.
TEST(MonitorReference, ABrokenCorrelationMatrixIsRefusedWithItsJsonPath) {
  struct Case {
    const char* what;
    std::function<void(Json&)> edit;
    std::string path;
    const char* says;
  };
  const std::vector<Case> cases{
      {"a parameter with an SE left out",
       [](Json& j) {
         const std::size_t r = At(j, "r");
         j["correlation"]["names"].erase(r);
         j["correlation"]["matrix"].erase(r);
         for (Json& row : j["correlation"]["matrix"]) row.erase(r);
       },
       "correlation.names", "'r' has a standard error but is not in the correlation matrix"},
      {"a name twice", [](Json& j) { j["correlation"]["names"][At(j, "b")] = "a"; },
       "correlation.names[", "'a' is listed twice"},
      {"a short row", [](Json& j) { j["correlation"]["matrix"][1].erase(0); },
       "correlation.matrix[1]", "expected 4 numbers"},
      {"a missing row", [](Json& j) { j["correlation"]["matrix"].erase(3); }, "correlation.matrix",
       "expected 4 rows"},
      {"asymmetric", [](Json& j) { j["correlation"]["matrix"][2][0] = 0.5; },
       "correlation.matrix[2][0]", "a correlation matrix is symmetric"},
      {"a diagonal other than 1", [](Json& j) { j["correlation"]["matrix"][1][1] = 0.9; },
       "correlation.matrix[1][1]", "with itself is 1"},
      {"not positive semi-definite (pairwise fine: a~b, b~s, s~-a)",
       [](Json& j) {
         Json& m = j["correlation"]["matrix"];
         const std::size_t a = At(j, "a"), b = At(j, "b"), s = At(j, "s");
         m[a][b] = m[b][a] = 0.9;
         m[b][s] = m[s][b] = 0.9;
         m[a][s] = m[s][a] = -0.9;
       },
       "correlation.matrix", "is not positive semi-definite"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    auto read = EditedReference(c.edit);
    ASSERT_FALSE(read);
    EXPECT_EQ(read.error().path.rfind(c.path, 0), 0u) << read.error().ToString();
    EXPECT_NE(read.error().message.find(c.says), std::string::npos) << read.error().ToString();
    EXPECT_NE(read.error().file.find("monitor_edited_reference.json"), std::string::npos);
  }
}

// A singular correlation (positive semi-definite, rank-deficient: here a and b perfectly
// correlated) says a combination of parameters is known exactly. linearise can use it (the
// delta method needs no inverse), so it is read; a monitor tracking a and b, or a alone with b
// held (its variance given b is then 0), refuses, naming them; tracking s and r it runs.
TEST(MonitorReference, ASingularCorrelationRefusesTrackingTheParametersInvolved) {
  const auto singular = [](Json& j) {
    Json& m = j["correlation"]["matrix"];
    for (Json& row : m)
      for (Json& v : row) v = 0.0;
    for (std::size_t d = 0; d < m.size(); ++d) m[d][d] = 1.0;
    const std::size_t a = At(j, "a"), b = At(j, "b");
    m[a][b] = m[b][a] = 1.0;
  };
  auto read = EditedReference(singular);
  ASSERT_TRUE(read) << read.error().ToString();
  const Fitted& f = OuReference();
  for (const auto& [track, refused] :
       {std::pair<std::vector<std::string>, std::string>{{}, "a and b"},
        {{"a"}, "a"},
        {{"a", "s"}, "a"},
        {{"s", "r"}, ""}}) {
    SCOPED_TRACE(track.empty() ? "all" : track[0]);
    MonitorOptions o;
    o.recursive.track = track;
    auto m = Monitor::Create(f.problem.spec(), *read, o);
    if (refused.empty()) {
      EXPECT_TRUE(m) << m.error().ToString();
      continue;
    }
    ASSERT_FALSE(m);
    EXPECT_EQ(m.error().path, "correlation");
    EXPECT_NE(m.error().message.find("make " + refused + " linearly dependent"), std::string::npos)
        << m.error().ToString();
  }
}

}  // namespace
}  // namespace gb::online
