// The operating-point sweep over the six bundled virtual-dyno fuel datasets (assets/data).
#include "core/estimate/sweep.h"

#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include "core/sim/dyno.h"

namespace gb::estimate {
namespace {

const std::string kRoot = GREYBENCH_SOURCE_DIR;

TEST(Sweep, RecoversEveryOperatingPointOfTable2FromTheBundledDynoData) {
  auto spec = model::LoadModelFile(kRoot + "/assets/models/fuel_film.json");
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  std::vector<std::string> files;
  for (const auto& p : sim::PaperFuelPoints()) files.push_back(kRoot + "/assets/data/fuel_" + p.name + ".csv");
  const SweepOptions options;
  auto result = Sweep(*spec, files, options);
  ASSERT_TRUE(result.ok()) << result.error().ToString();
  ASSERT_EQ(result->rows.size(), 6u);
  for (const auto& row : result->rows) {
    const auto truth = *sim::FindFuelPoint(row.point.name);
    EXPECT_EQ(row.point.values.at("n_rpm"), truth.speed_rpm);
    EXPECT_TRUE(row.summary.converged) << row.point.name << ": " << row.summary.message;
    // The delay, exactly.
    EXPECT_NEAR(row.summary.delays[0].estimate * 0.0125, truth.delay_s, 1e-12) << row.point.name;
    // The physical parameters within 3 standard errors. (The noise variances are biased by the
    // anti-alias filters, as docs/case-study.md explains, and are not checked here.)
    const std::map<std::string, double> physical = {
        {"tau_fv", truth.tau_fv}, {"tau_ff", truth.tau_ff}, {"X", truth.X}, {"Kb", truth.Kb}};
    for (const auto& p : row.summary.parameters) {
      if (!physical.count(p.name)) continue;
      ASSERT_TRUE(p.std_error.has_value()) << row.point.name << " " << p.name;
      EXPECT_LT(std::abs(p.estimate - physical.at(p.name)), 3 * *p.std_error)
          << row.point.name << " " << p.name << " = " << p.estimate << " ± " << *p.std_error
          << ", truth " << physical.at(p.name);
    }
  }
  // Fig. 3: the delay falls with speed, Δt = c / n with c near the dyno's own relation.
  ASSERT_TRUE(result->delay_vs_speed.has_value());
  const double c_truth = sim::ExhaustDelay(1.0);
  EXPECT_LT(std::abs(result->delay_vs_speed->b - c_truth), 3 * result->delay_vs_speed->se_b);
  // Fig. 4: X grows with the throttle angle.
  ASSERT_TRUE(result->trend.has_value());
  EXPECT_GT(result->trend->b, 0.0);
  // The tables.
  EXPECT_NE(result->Markdown().find("| f1 |"), std::string::npos);
  EXPECT_NE(result->Csv().find("tau_fv_se"), std::string::npos);
}

TEST(Sweep, ReadsTheOperatingPointTagOfADataFile) {
  auto p = ReadOperatingPoint(kRoot + "/assets/data/fuel_f7.csv");
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p->name, "f7");
  EXPECT_EQ(p->values.at("alpha_deg"), 36.5);
  auto untagged = ReadOperatingPoint(std::string(GREYBENCH_TEST_DATA_DIR) + "/cli/fuel.csv");
  ASSERT_TRUE(untagged.ok());
  EXPECT_EQ(untagged->name, "fuel");
  EXPECT_TRUE(untagged->values.empty());
}

}  // namespace
}  // namespace gb::estimate
