// The experiment-design view (issue 39, item 3): the lesson "why a PRBS" driven as a lecturer
// drives it: the designs seeded from the recording, the expected standard errors of a PRBS and
// of slow steps side by side, a design tried (records simulated and fitted), a design edited.
#include <chrono>
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "tests/ui/workbench_driver.h"

namespace gb::ui {
namespace {

using testing::kCaseStudy;
using testing::kSource;
using testing::WorkbenchDriver;
using namespace std::chrono_literals;

int FreeIndex(const DesignRun& run, const std::string& name) {
  for (std::size_t i = 0; i < run.free_names.size(); ++i)
    if (run.free_names[i] == name) return static_cast<int>(i);
  return -1;
}

TEST(DesignView, APrbsDeterminesTheFuelFilmBetterThanSlowSteps) {
  WorkbenchDriver d;
  d.Open(kCaseStudy);
  WaitForJobs(d.state);
  d.state.view = View::kDesign;
  DesignViewState& v = d.state.design;
  ASSERT_TRUE(d.FramesUntil([&] { return v.result.has_value(); }, 30s));
  // Seeded from the record: mfi's mean level and spread, 80 Hz for 125 s; A a PRBS whose bit
  // suits the model's time constants (0.1 and 0.5 s at the model's values: 0.5 s, the paper's),
  // B steps of 10 s.
  const design::InputDesign& a = v.slots[0].design;
  const design::InputDesign& b = v.slots[1].design;
  EXPECT_EQ(a.shape, design::InputShape::kPrbs);
  EXPECT_EQ(b.shape, design::InputShape::kSquare);
  EXPECT_NEAR(a.level, 1.19, 0.01);
  EXPECT_NEAR(a.amplitude, 0.118, 0.01);
  EXPECT_DOUBLE_EQ(a.sample_time, 0.0125);
  EXPECT_NEAR(a.duration, 125.0, 1e-9);
  EXPECT_EQ(a.bit_period, 0.5);
  EXPECT_EQ(b.period, 10.0);
  const DesignRun& run = *v.result;
  ASSERT_TRUE(run.model_error.empty()) << run.model_error;
  ASSERT_TRUE(run.evals[0] && run.evals[1]) << run.errors[0] << run.errors[1];
  // The lesson: the PRBS determines both time constants and the split X better than steps.
  for (const char* name : {"tau_fv", "tau_ff", "X"}) {
    const int i = FreeIndex(run, name);
    ASSERT_GE(i, 0) << name;
    const auto& se_a = run.evals[0]->info.std_error[static_cast<std::size_t>(i)];
    const auto& se_b = run.evals[1]->info.std_error[static_cast<std::size_t>(i)];
    ASSERT_TRUE(se_a && se_b) << name;
    EXPECT_LT(*se_a * 1.2, *se_b) << name;
  }
  ASSERT_TRUE(run.bandwidth.has_value());
  EXPECT_EQ(run.time_constants.size(), 2u);
  const std::string text = d.Text();
  EXPECT_NE(text.find("Expected standard errors"), std::string::npos) << text;
  EXPECT_NE(text.find("B / A"), std::string::npos) << text;

  // Try A: records simulated from the model with the PRBS and fitted.
  v.records = 8;
  const std::optional<ImVec2> try_a = testing::FindButton(d, "Try A");
  ASSERT_TRUE(try_a.has_value());
  d.Click(*try_a);
  ASSERT_TRUE(d.FramesUntil([&] { return v.slots[0].tried.has_value(); }, 120s));
  const DesignFitRun& tried = *v.slots[0].tried;
  ASSERT_TRUE(tried.fits) << tried.error;
  EXPECT_EQ(static_cast<int>(tried.fits->estimates.size()) + tried.fits->failed, 8);
  EXPECT_EQ(tried.key, v.result->key);
  EXPECT_NE(d.Text().find("Spread A"), std::string::npos);

  // An edit of A is evaluated again; the try, made for the old design, says so.
  const std::string old_key = v.result->key;
  const double old_se = *v.result->evals[0]->info.std_error[0];
  v.slots[0].design.bit_period = 0.25;
  ASSERT_TRUE(d.FramesUntil([&] { return v.result->key != old_key; }, 30s));
  EXPECT_NE(*v.result->evals[0]->info.std_error[0], old_se);
  EXPECT_NE(d.Text().find("Try A was made for other values or settings"), std::string::npos);
}

TEST(DesignView, SaysANonlinearModelIsNotDesignedFor) {
  WorkbenchDriver d;
  d.Open(kSource + "/assets/projects/cascaded_tanks_sde.json");
  WaitForJobs(d.state);
  d.state.view = View::kDesign;
  ASSERT_TRUE(d.FramesUntil([&] { return d.state.design.result.has_value(); }, 30s));
  EXPECT_NE(d.state.design.result->model_error.find("linear models"), std::string::npos);
  EXPECT_NE(d.Text().find("Linear models only"), std::string::npos);
  std::string why;
  EXPECT_FALSE(StartDesignFit(d.state, 0, &why));
  EXPECT_NE(why.find("not linear"), std::string::npos) << why;
}

}  // namespace
}  // namespace gb::ui
