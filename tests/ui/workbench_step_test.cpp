// Stepping through the filter (issue 39, item 2): the analysis' FilterSteps must be the filter's
// own update, x̂_{j|j} = x̂_{j|j-1} + K_j ε_j, with K_j computed from P_{j|j-1} alone: checked
// against the filter's posterior on the Kalman filter of a linear model and on the EKF of the
// Cascaded Tanks SDE model. Then the Predictions view's Step mode driven by its keys.
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

// Checks x_post = x_prior + K ε at every state index with an update; returns how many.
int ExpectGainIsTheUpdate(const Analysis& a, std::size_t dataset) {
  const DatasetAnalysis& d = a.datasets[dataset];
  const FilterSteps& st = d.steps;
  EXPECT_TRUE(st.error.empty()) << st.error;
  const auto n = st.x_prior.rows(), N = st.x_prior.cols();
  const auto p = static_cast<Eigen::Index>(d.outputs.size());
  EXPECT_EQ(static_cast<std::size_t>(N), d.time.size());
  EXPECT_EQ(st.states, a.states);
  int updates = 0;
  for (Eigen::Index j = 0; j < N; ++j) {
    Eigen::VectorXd step = Eigen::VectorXd::Zero(n);
    bool any = false;
    for (Eigen::Index o = 0; o < p; ++o) {
      const double k0 = st.gain(o, j);
      if (!std::isfinite(k0)) continue;
      any = true;
      const auto k = static_cast<std::size_t>(j + d.outputs[static_cast<std::size_t>(o)].delay);
      const double e = d.outputs[static_cast<std::size_t>(o)].residual[k];
      for (Eigen::Index i = 0; i < n; ++i) step(i) += st.gain(i * p + o, j) * e;
    }
    if (!any) continue;
    ++updates;
    const Eigen::VectorXd actual = st.x_post.col(j) - st.x_prior.col(j);
    const double scale = std::max(st.x_prior.col(j).norm(), 1.0);
    EXPECT_LE((actual - step).norm(), 1e-9 * scale) << "state index " << j;
    for (Eigen::Index i = 0; i < n; ++i)
      EXPECT_LE(st.sd_post(i, j), st.sd_prior(i, j) * (1 + 1e-12));
  }
  return updates;
}

TEST(FilterSteps, TheGainIsTheKalmanFiltersUpdate) {
  WorkbenchDriver d;
  d.state.analysis.show_step = true;  // the steps are computed for the Step mode only
  d.Open(kCaseStudy);
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result) << d.state.analysis.last_failure;
  EXPECT_GT(ExpectGainIsTheUpdate(*d.state.analysis.result, 0), 9000);
}

TEST(FilterSteps, TheGainIsTheExtendedKalmanFiltersUpdate) {
  WorkbenchDriver d;
  d.state.analysis.show_step = true;
  d.Open(kSource + "/assets/projects/cascaded_tanks_sde.json");
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result) << d.state.analysis.last_failure;
  EXPECT_GT(ExpectGainIsTheUpdate(*d.state.analysis.result, 0), 1000);
}

TEST(FilterSteps, TheStepBarStepsPlaysAndTheTimeWindowFollows) {
  WorkbenchDriver d;
  d.Open(kCaseStudy);
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result);
  EXPECT_EQ(d.state.analysis.result->datasets[0].steps.x_prior.size(), 0);  // not asked for
  d.state.view = View::kPredictions;
  d.state.analysis.show_step = true;
  ASSERT_TRUE(
      d.FramesUntil([&] { return d.state.analysis.result->datasets[0].steps.x_prior.size() > 0; },
                    std::chrono::seconds(30)));
  AnalysisState& a = d.state.analysis;
  EXPECT_EQ(a.step, 0);
  const std::optional<ImVec2> next = testing::FindButton(d, "Next \xE2\x96\xB6");
  ASSERT_TRUE(next.has_value());
  d.Click(*next);
  d.Click(*next);
  EXPECT_EQ(a.step, 2);
  const std::optional<ImVec2> back = testing::FindButton(d, "\xE2\x97\x80 Back");
  ASSERT_TRUE(back.has_value());
  d.Click(*back);
  EXPECT_EQ(a.step, 1);
  // The window shows the step: 60 samples from the start here.
  const std::vector<double>& t = a.result->datasets[0].time;
  EXPECT_EQ(a.time_x.range.min, t[0]);
  EXPECT_EQ(a.time_x.range.max, t[60]);
  // Playing at 10 samples a second for one second of frames (60 frames of 1/60 s): 10 steps on.
  a.step_rate = 10.0f;
  a.step_playing = true;
  a.step_clock = 0.0;
  for (int f = 0; f < 60; ++f) d.Frame();
  a.step_playing = false;
  EXPECT_GE(a.step, 10);
  EXPECT_LE(a.step, 11);  // the frames' float time may leave the last step for the next frame
  // A step beyond the window moves it; one past the end stops at the last state.
  a.step = 5000;
  d.Frame();
  EXPECT_LE(a.time_x.range.min, t[5000]);
  EXPECT_GE(a.time_x.range.max, t[5000]);
  const std::string text = d.Text();
  EXPECT_NE(text.find("innovation"), std::string::npos) << text;
  EXPECT_NE(text.find("Gain K (ilambda)"), std::string::npos) << text;
  a.step = 1000000;
  d.Frame();
  EXPECT_EQ(a.step, static_cast<int>(t.size()) - 1);
  EXPECT_NE(d.Text().find("after the record's end"), std::string::npos);
}

}  // namespace
}  // namespace gb::ui
