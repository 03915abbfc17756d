// The condition monitor (core/online/monitor.h) on the live virtual dyno: its false-alarm rate on
// stationary data, a clogging injector (τ_ff × 1.5) found and named, and the reference read back
// from a result file.
#include "core/online/monitor.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "core/estimate/estimate.h"
#include "core/project/problem.h"
#include "core/sim/live_dyno.h"
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
  auto read = LoadReference(path, f.problem.spec());
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
  auto bad = LoadReference(path, f.problem.spec());
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().path, "correlation.matrix[1][0]") << bad.error().ToString();
}

}  // namespace
}  // namespace gb::online
