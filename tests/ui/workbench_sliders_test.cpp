// The sliders beside the views (issue 39, user guide §6a): their ranges, a drag through synthetic
// input (the ghost kept while it lasts, results arriving during it, none lost), Reset, and "Use
// as start values", whose analysis at the model's values must equal the what-if's to the last
// bit (the same θ reached two ways: a slider's override and an edit of the model).
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/project/project.h"
#include "tests/ui/workbench_driver.h"

namespace gb::ui {
namespace {

using testing::kTestProject;
using testing::WorkbenchDriver;
using namespace std::chrono_literals;

model::Parameter Param(std::optional<double> lower, std::optional<double> upper, double value) {
  model::Parameter p;
  p.name = "p";
  p.value = value;
  p.lower = lower;
  p.upper = upper;
  return p;
}

TEST(SliderRange, FollowsTheBoundsTheValueAndTheProject) {
  const project::SliderSpec none{"p", {}, {}, {}};
  // Both bounds: the bounds; a log scale where they span two decades or more.
  SliderScale s = SliderRange(Param(0.15, 5.0, 0.6), 0.6, none);
  EXPECT_EQ(s.min, 0.15);
  EXPECT_EQ(s.max, 5.0);
  EXPECT_FALSE(s.log);
  s = SliderRange(Param(1e-9, 1.0, 1e-4), 1e-4, none);
  EXPECT_EQ(s.min, 1e-9);
  EXPECT_TRUE(s.log);
  // A lower bound at 0 is not a log scale's.
  s = SliderRange(Param(0.0, 1.0, 1e-4), 1e-4, none);
  EXPECT_FALSE(s.log);
  // No bounds: a decade each way of a positive value (two decades: log), ± max(|v|, 1) else.
  s = SliderRange(Param({}, {}, 2.0), 2.0, none);
  EXPECT_DOUBLE_EQ(s.min, 0.2);
  EXPECT_DOUBLE_EQ(s.max, 20.0);
  EXPECT_TRUE(s.log);
  s = SliderRange(Param({}, {}, -3.0), -3.0, none);
  EXPECT_EQ(s.min, -6.0);
  EXPECT_EQ(s.max, 0.0);
  s = SliderRange(Param({}, {}, 0.25), 0.0, none);  // the views' value is the fit's 0
  EXPECT_EQ(s.min, -1.0);
  EXPECT_EQ(s.max, 1.0);
  // One bound cuts the range around the value.
  s = SliderRange(Param(0.0, {}, 0.0), 0.0, none);
  EXPECT_EQ(s.min, 0.0);
  EXPECT_EQ(s.max, 1.0);
  s = SliderRange(Param({}, 3.0, 2.0), 2.0, none);
  EXPECT_EQ(s.max, 3.0);
  // The project's range and scale win; the range still holds the value.
  s = SliderRange(Param(0.0, 1.0, 0.2), 0.2, {"p", 0.1, 0.5, true});
  EXPECT_EQ(s.min, 0.1);
  EXPECT_EQ(s.max, 0.5);
  EXPECT_TRUE(s.log);
  s = SliderRange(Param(0.0, 1.0, 0.8), 0.8, {"p", 0.1, 0.5, {}});
  EXPECT_EQ(s.max, 0.8);
  // A non-finite value (a fit that failed there) still gives a usable range.
  s = SliderRange(Param({}, {}, 1.0), std::nan(""), none);
  EXPECT_TRUE(std::isfinite(s.min) && std::isfinite(s.max) && s.min < s.max);
}

// The test project's tau_ff slider: shown, with the analysis at the model's values computed.
class SlidersTest : public ::testing::Test {
 protected:
  void SetUp() override {
    d.Open(kTestProject);
    d.state.view = View::kPredictions;
    ASSERT_TRUE(d.FramesUntil([&] { return Settled(); }, 30s));
    ShowSlider(d.state, "tau_ff", true);
    d.Frame();
  }
  bool Settled() { return d.state.analysis.result.has_value() && !AnalysisRunning(d.state); }
  // The slider's screen position (moving the mouse until ImGui reports it hovered).
  std::optional<ImVec2> FindSlider() {
    ImGuiWindow* panel = WorkbenchDriver::FindWindow("##workbench/##view_", "/##sliders_");
    if (!panel) return std::nullopt;
    const ImGuiID id = ImHashStr("##slider", 0, ImHashStr("tau_ff", 0, panel->ID));
    return d.Find(panel, id);
  }
  std::size_t Index() const { return 1; }  // tau_ff in tests/data/ui/fuel_film.json
  double AnalysedTau() const { return d.state.analysis.result->request.theta[Index()]; }
  WorkbenchDriver d;
};

TEST_F(SlidersTest, ADragComputesAtTheMovedValueKeepsTheGhostAndResetGoesBack) {
  ASSERT_EQ(d.state.model->parameters[Index()].name, "tau_ff");
  const double base = d.state.model->parameters[Index()].value;
  const double base_loglik = d.state.analysis.result->datasets[0].loglik;
  ASSERT_EQ(AnalysedTau(), base);
  // The project records the slider (an unsaved change).
  ASSERT_TRUE(d.state.project->extra.contains("sliders"));
  EXPECT_EQ(d.state.project->extra["sliders"].dump(), R"(["tau_ff"])");

  const std::optional<ImVec2> at = FindSlider();
  ASSERT_TRUE(at.has_value());
  d.Press();
  EXPECT_TRUE(d.state.sliders.dragging);
  ASSERT_TRUE(d.state.sliders.ghost.has_value());
  // Dragged right a pixel a frame: results keep arriving during the drag (a run under way is
  // not cancelled by the next move), each at a value the slider had.
  ImVec2 p = *at;
  int arrived = 0;
  double last = AnalysedTau();
  const auto end = std::chrono::steady_clock::now() + 20s;
  while (arrived < 3 && std::chrono::steady_clock::now() < end) {
    p.x += 1.0f;
    d.MouseTo(p);
    if (AnalysedTau() != last) {
      last = AnalysedTau();
      ++arrived;
    }
  }
  EXPECT_GE(arrived, 3) << "no results arrived while the slider was dragged";
  ASSERT_TRUE(d.state.sliders.moved.count("tau_ff"));
  const double moved = d.state.sliders.moved.at("tau_ff");
  EXPECT_NE(moved, base);  // a press sets the value under the mouse, the drag moves it on
  EXPECT_EQ(d.state.sliders.ghost->datasets[0].loglik, base_loglik);
  d.Release();
  EXPECT_FALSE(d.state.sliders.dragging);
  EXPECT_FALSE(d.state.sliders.ghost.has_value());
  ASSERT_TRUE(d.FramesUntil([&] { return Settled() && AnalysedTau() == moved; }, 30s));
  const double what_if = d.state.analysis.result->datasets[0].loglik;
  EXPECT_NE(what_if, base_loglik);
  EXPECT_EQ(d.state.analysis.result->request.moved, std::vector<std::string>{"tau_ff"});
  // The model is not changed by a slider.
  EXPECT_EQ(d.state.model->parameters[Index()].value, base);

  // Reset: the analysis at the model's values again, to the last bit.
  ResetSliders(d.state);
  ASSERT_TRUE(d.FramesUntil([&] { return Settled() && AnalysedTau() == base; }, 30s));
  EXPECT_EQ(d.state.analysis.result->datasets[0].loglik, base_loglik);
  EXPECT_TRUE(d.state.analysis.result->request.moved.empty());

  // Moved again, then made the model's start value: the same θ reached through the model.
  MoveSlider(d.state, "tau_ff", moved);
  ASSERT_TRUE(d.FramesUntil([&] { return Settled() && AnalysedTau() == moved; }, 30s));
  EXPECT_EQ(d.state.analysis.result->datasets[0].loglik, what_if);
  const int revision = d.state.model_revision;
  UseSliderValuesAsStart(d.state);
  EXPECT_EQ(d.state.model->parameters[Index()].value, moved);
  EXPECT_EQ(d.state.model_revision, revision + 1);
  EXPECT_TRUE(d.state.sliders.moved.empty());
  ASSERT_TRUE(d.FramesUntil(
      [&] { return Settled() && d.state.analysis.result->request.model_revision == revision + 1; },
      30s));
  EXPECT_TRUE(d.state.analysis.result->request.moved.empty());
  EXPECT_EQ(d.state.analysis.result->datasets[0].loglik, what_if);
}

TEST_F(SlidersTest, HidingASliderDropsItsValueAndAProjectsUnknownSliderIsLeftOut) {
  MoveSlider(d.state, "tau_ff", 1.0);
  MoveSlider(d.state, "X", 0.5);  // no slider: ignored
  EXPECT_EQ(d.state.sliders.moved.size(), 1U);
  MoveSlider(d.state, "tau_ff", std::nan(""));  // never a non-finite value
  EXPECT_EQ(d.state.sliders.moved.at("tau_ff"), 1.0);
  ShowSlider(d.state, "tau_ff", false);
  EXPECT_TRUE(d.state.sliders.moved.empty());
  EXPECT_FALSE(d.state.project->extra.contains("sliders"));

  // A project whose list names a parameter the model lacks: shown without it, with a warning.
  d.state.project->extra["sliders"] = Json::array({"tau_ff", "nope"});
  InstallSliders(d.state);
  ASSERT_EQ(d.state.sliders.shown.size(), 1U);
  EXPECT_EQ(d.state.sliders.shown[0].parameter, "tau_ff");
  EXPECT_TRUE(d.state.sliders.open);
  ASSERT_FALSE(d.state.messages.empty());
  EXPECT_NE(d.state.messages.back().text.find("nope"), std::string::npos);
  d.Frame();  // draws with the panel open
}

}  // namespace
}  // namespace gb::ui
