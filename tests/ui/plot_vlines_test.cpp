// The plot widget's vertical lines (PlotVLines): events on a time axis take no part in fitting
// the ranges, and hovering over a plot that has some reads no y values of theirs (they have none).
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "tests/ui/headless_imgui.h"
#include "ui/widgets/plot.h"

namespace gb::ui::plot {
namespace {

constexpr float kWidth = 800.0f;
constexpr float kHeight = 400.0f;

class PlotVLinesTest : public testing::HeadlessImGuiTest {
 protected:
  PlotVLinesTest() : HeadlessImGuiTest(kWidth, kHeight) {}

  void SetUp() override {
    HeadlessImGuiTest::SetUp();
    for (int i = 0; i <= 100; ++i) {
      x_.push_back(0.1 * i);  // 0 .. 10
      y_.push_back(std::sin(0.1 * i));
    }
  }

  void Frame() {
    ImGui::NewFrame();
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(kWidth, kHeight));
    ImGui::Begin("test", nullptr, ImGuiWindowFlags_NoDecoration);
    PlotOptions options;
    options.linked_x = &linked_;
    options.legend = Legend::kShow;
    if (BeginPlot(plots_, "plot", ImVec2(-1, -1), options)) {
      PlotLine(plots_, "sine", x_.data(), y_.data(), static_cast<int>(x_.size()));
      PlotVLines(plots_, "events", events_.data(), static_cast<int>(events_.size()), tags_.data());
      EndPlot(plots_);
    }
    ImGui::End();
    ImGui::Render();
  }

  PlotState& State() {
    ImGui::NewFrame();
    ImGui::Begin("test");
    const ImGuiID id = ImGui::GetID("plot");
    ImGui::End();
    ImGui::EndFrame();
    return plots_.plots.at(id);
  }

  PlotContext plots_;
  LinkedRange linked_;
  std::vector<double> x_, y_;
  // Far outside the line's x range on both sides, one inside.
  std::vector<double> events_ = {-50.0, 5.0, 50.0};
  std::vector<const char*> tags_ = {"#1", "#2", "#3"};
};

TEST_F(PlotVLinesTest, TakeNoPartInFittingEitherAxis) {
  Frame();
  Frame();
  EXPECT_DOUBLE_EQ(linked_.range.min, 0.0);
  EXPECT_DOUBLE_EQ(linked_.range.max, 10.0);
  // y: the sine's extent over [0, 10] with the widget's 5 % margin, not widened by the lines.
  double lo = 1.0, hi = -1.0;
  for (double v : y_) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  const PlotState& st = State();
  EXPECT_NEAR(st.y.min, lo - 0.05 * (hi - lo), 1e-12);
  EXPECT_NEAR(st.y.max, hi + 0.05 * (hi - lo), 1e-12);
}

TEST_F(PlotVLinesTest, HoveringAPlotWithVerticalLinesShowsTheOtherItemsOnly) {
  Frame();
  Frame();
  const PlotState& st = State();
  // Over the line at x = 5 (a vertical line there too), then elsewhere in the plot.
  for (float fx : {0.5f, 0.25f}) {
    ImGui::GetIO().MousePos =
        ImVec2(st.last_plot_min.x + fx * (st.last_plot_max.x - st.last_plot_min.x),
               0.5f * (st.last_plot_min.y + st.last_plot_max.y));
    Frame();
    Frame();
    EXPECT_NEAR(linked_.hover_x, 10.0 * fx, 0.1);
  }
}

}  // namespace
}  // namespace gb::ui::plot
