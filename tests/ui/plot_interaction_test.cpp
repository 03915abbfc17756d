// The plot widget driven by synthetic mouse input in a headless ImGui context (no GL): each
// expectation is the range computed by hand from the plot's pixel rectangle.
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <imgui_internal.h>  // the open popup's window (the plot's menu)

#include "tests/ui/headless_imgui.h"
#include "ui/widgets/plot.h"
#include "ui/widgets/plot_internal.h"

namespace gb::ui::plot {
namespace {

constexpr float kWidth = 800.0f;
constexpr float kHeight = 600.0f;

class PlotInteraction : public testing::HeadlessImGuiTest {
 protected:
  PlotInteraction() : HeadlessImGuiTest(kWidth, kHeight) {}

  void SetUp() override {
    HeadlessImGuiTest::SetUp();
    for (int i = 0; i <= 100; ++i) {
      x_.push_back(0.1 * i);  // 0 .. 10
      y_.push_back(std::sin(0.1 * i));
      y2_.push_back(5.0 + 0.01 * i);      // 5 .. 6, far above y_
      x_late_.push_back(5.0 + 0.15 * i);  // 5 .. 20
    }
  }

  // One frame: two stacked plots sharing `linked_`; the first has two items (and a legend).
  void Frame() {
    ImGui::NewFrame();
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(kWidth, kHeight));
    ImGui::Begin("test", nullptr, ImGuiWindowFlags_NoDecoration);
    PlotOptions options;
    options.linked_x = &linked_;
    if (BeginPlot(plots_, "top", ImVec2(-1, 280), options)) {
      PlotLine(plots_, "sine", x_.data(), y_.data(), static_cast<int>(x_.size()));
      PlotLine(plots_, "high", x_.data(), y2_.data(), static_cast<int>(x_.size()));
      EndPlot(plots_);
    }
    if (BeginPlot(plots_, "bottom", ImVec2(-1, 280), options)) {
      PlotLine(plots_, "late", x_late_.data(), y_.data(), static_cast<int>(x_late_.size()));
      EndPlot(plots_);
    }
    ImGui::End();
    ImGui::Render();
  }

  PlotState& Top() {
    ImGui::NewFrame();  // ids are only computed inside a frame
    ImGui::Begin("test");
    const ImGuiID id = ImGui::GetID("top");
    ImGui::End();
    ImGui::EndFrame();
    return plots_.plots.at(id);
  }

  void MouseTo(ImVec2 p) { ImGui::GetIO().MousePos = p; }
  void Button(int b, bool down) { ImGui::GetIO().MouseDown[b] = down; }

  // Pixel -> data along x in the top plot, as the widget defines it.
  double XAt(float px) {
    PlotState& st = Top();
    const double w = st.last_plot_max.x - st.last_plot_min.x;
    return linked_.range.min + (px - st.last_plot_min.x) / w * linked_.range.Span();
  }

  PlotContext plots_;
  LinkedRange linked_;
  std::vector<double> x_, y_, y2_, x_late_;
};

TEST_F(PlotInteraction, LinkedPlotsFitTheUnionOfTheirData) {
  Frame();
  Frame();
  EXPECT_DOUBLE_EQ(linked_.range.min, 0.0);
  EXPECT_DOUBLE_EQ(linked_.range.max, 20.0);
}

TEST_F(PlotInteraction, WheelZoomsXAboutTheCursor) {
  Frame();
  Frame();
  PlotState& st = Top();
  // Whole pixels: ImGui floors the mouse position.
  const ImVec2 p(std::floor(st.last_plot_min.x + 0.3f * (st.last_plot_max.x - st.last_plot_min.x)),
                 std::floor(0.5f * (st.last_plot_min.y + st.last_plot_max.y)));
  const double anchor = XAt(p.x);
  const Range before = linked_.range;
  MouseTo(p);
  Frame();  // hover
  ImGui::GetIO().MouseWheel = 1.0f;
  Frame();
  EXPECT_NEAR(linked_.range.min, anchor - (anchor - before.min) * 0.8, 1e-9);
  EXPECT_NEAR(linked_.range.max, anchor + (before.max - anchor) * 0.8, 1e-9);
}

TEST_F(PlotInteraction, WheelAboveThePlotAreaLeavesTheRangeToScrolling) {
  Frame();
  Frame();
  PlotState& st = Top();
  const Range before = linked_.range;
  MouseTo(ImVec2(std::floor(0.5f * (st.last_plot_min.x + st.last_plot_max.x)),
                 st.last_plot_min.y - 3.0f));  // the strip above the plot area
  Frame();
  ImGui::GetIO().MouseWheel = 1.0f;
  Frame();
  EXPECT_EQ(linked_.range.min, before.min);
  EXPECT_EQ(linked_.range.max, before.max);
}

TEST_F(PlotInteraction, DragPansXByThePixelsMoved) {
  Frame();
  Frame();
  PlotState& st = Top();
  const float w = st.last_plot_max.x - st.last_plot_min.x;
  const ImVec2 p(std::floor(0.5f * (st.last_plot_min.x + st.last_plot_max.x)),
                 std::floor(0.5f * (st.last_plot_min.y + st.last_plot_max.y)));
  const Range before = linked_.range;
  MouseTo(p);
  Frame();
  Button(0, true);
  Frame();
  MouseTo(ImVec2(p.x - 100.0f, p.y));
  Frame();
  Button(0, false);
  Frame();
  const double shift = 100.0 / w * before.Span();
  EXPECT_NEAR(linked_.range.min, before.min + shift, 1e-9);
  EXPECT_NEAR(linked_.range.max, before.max + shift, 1e-9);
  EXPECT_TRUE(Top().y_auto);  // y follows the data while it was never zoomed
}

TEST_F(PlotInteraction, RightDragZoomsToTheBoxAndDoubleClickFitsAgain) {
  Frame();
  Frame();
  PlotState& st = Top();
  const ImVec2 a(st.last_plot_min.x + 100.0f, st.last_plot_min.y + 40.0f);
  const ImVec2 b(st.last_plot_min.x + 300.0f, st.last_plot_min.y + 120.0f);
  const double xa = XAt(a.x), xb = XAt(b.x);
  MouseTo(a);
  Frame();
  Button(1, true);
  Frame();
  MouseTo(b);
  Frame();
  Button(1, false);
  Frame();
  EXPECT_NEAR(linked_.range.min, xa, 1e-9);
  EXPECT_NEAR(linked_.range.max, xb, 1e-9);
  EXPECT_FALSE(Top().y_auto);

  // Double-click: press, release, press within the double-click time, in place.
  for (bool down : {true, false, true, false}) {
    Button(0, down);
    Frame();
  }
  Frame();
  EXPECT_DOUBLE_EQ(linked_.range.min, 0.0);
  EXPECT_DOUBLE_EQ(linked_.range.max, 20.0);
  EXPECT_TRUE(Top().y_auto);
}

TEST_F(PlotInteraction, ClickingALegendEntryHidesTheItemAndTheFitIgnoresIt) {
  Frame();
  Frame();
  EXPECT_GT(Top().y.max, 6.0);  // "high" reaches 6
  PlotState& st = Top();
  ASSERT_EQ(st.legend_ids.size(), 2u);
  const float row_h = (st.last_legend_max.y - st.last_legend_min.y) / 2.0f;
  MouseTo(ImVec2(0.5f * (st.last_legend_min.x + st.last_legend_max.x),
                 st.last_legend_min.y + 1.5f * row_h));
  Frame();
  Button(0, true);
  Frame();
  Button(0, false);
  Frame();
  EXPECT_EQ(Top().hidden.size(), 1u);
  EXPECT_LT(Top().y.max, 1.2);               // only the sine is fitted now
  EXPECT_DOUBLE_EQ(linked_.range.min, 0.0);  // the click did not pan
}

// The hover readout names the x of the sample pointed at, also where the first item is a band
// known only at its two ends (a correlogram's ± bound): over lag 10, "lag = 10", not "lag = 1".
// The mouse is over lag 10 of a drawn plot (its crosshair is there); the readout's x is
// ReadoutX's.
TEST_F(PlotInteraction, TheHoverReadoutNamesTheLagPointedAtBesideATwoPointBand) {
  std::vector<double> lag, acf;
  for (int k = 1; k <= 20; ++k) {
    lag.push_back(k);
    acf.push_back(0.5 / k);
  }
  const double band_x[2] = {1, 20}, lo[2] = {-0.1, -0.1}, hi[2] = {0.1, 0.1};
  PlotContext plots;
  std::vector<Item> items;
  const auto frame = [&] {
    ImGui::NewFrame();
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(kWidth, kHeight));
    ImGui::Begin("acf", nullptr, ImGuiWindowFlags_NoDecoration);
    PlotOptions options;
    options.x_label = "lag";
    if (BeginPlot(plots, "##acf", ImVec2(-1, 400), options)) {
      PlotBand(plots, "95 % bound", band_x, lo, hi, 2);
      PlotStems(plots, "ACF", lag.data(), acf.data(), static_cast<int>(lag.size()));
      items = plots.items;
      EndPlot(plots);
    }
    ImGui::End();
    ImGui::Render();
  };
  frame();
  frame();
  ImGui::NewFrame();
  ImGui::Begin("acf");
  const ImGuiID id = ImGui::GetID("##acf");
  ImGui::End();
  ImGui::EndFrame();
  const PlotState& st = plots.plots.at(id);
  const Range& x = st.own_x.range;
  const double w = st.last_plot_max.x - st.last_plot_min.x;
  const float px = st.last_plot_min.x + static_cast<float>((10.0 - x.min) / x.Span() * w);
  MouseTo(ImVec2(px, 0.5f * (st.last_plot_min.y + st.last_plot_max.y)));
  frame();
  frame();
  const LinkedRange& hover = plots.plots.at(id).own_x;
  EXPECT_EQ(hover.hover_frame, ImGui::GetFrameCount());  // the last frame: the mouse is over it
  ASSERT_EQ(items.size(), 2u);
  const std::optional<double> readout = internal::ReadoutX(items, hover.hover_x);
  ASSERT_TRUE(readout);
  EXPECT_EQ(*readout, 10.0);
  // The band alone still names its nearest end.
  EXPECT_EQ(*internal::ReadoutX({items[0]}, hover.hover_x), 1.0);
}

}  // namespace
}  // namespace gb::ui::plot

namespace gb::ui::plot {
namespace {

// A right click without a drag opens the plot's menu: its items copy the plot's data as CSV and
// ask the application for an SVG, with the values the plot was given.
class PlotMenu : public PlotInteraction {
 protected:
  // Right press and release at `p`, then a frame for the popup to appear.
  void RightClick(ImVec2 p) {
    MouseTo(p);
    Frame();
    Button(1, true);
    Frame();
    Button(1, false);
    Frame();
    Frame();
  }
  ImGuiWindow* Menu() {
    ImGuiContext& g = *GImGui;
    return g.OpenPopupStack.Size == 1 ? g.OpenPopupStack[0].Window : nullptr;
  }
  // Clicks the menu's k-th item (rows of one line each, from the top of the popup).
  void ClickItem(int k) {
    ImGuiWindow* menu = Menu();
    ASSERT_NE(menu, nullptr);
    const ImGuiStyle& style = ImGui::GetStyle();
    const float row = ImGui::GetFontSize() + style.ItemSpacing.y;
    MouseTo(ImVec2(menu->Pos.x + 2.0f * style.WindowPadding.x,
                   menu->Pos.y + style.WindowPadding.y + (static_cast<float>(k) + 0.5f) * row -
                       0.5f * style.ItemSpacing.y));
    Frame();
    Button(0, true);
    Frame();
    Button(0, false);
    Frame();
  }
};

TEST_F(PlotMenu, CopyDataAsCsvPutsThePlottedValuesOnTheClipboard) {
  Frame();
  Frame();
  const PlotState& st = Top();
  RightClick(ImVec2(0.5f * (st.last_plot_min.x + st.last_plot_max.x), st.last_plot_max.y - 20.0f));
  ASSERT_NE(Menu(), nullptr);
  ClickItem(2);
  EXPECT_EQ(Menu(), nullptr);
  const std::string csv = ImGui::GetClipboardText();
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "x,sine,high");
  int rows = 0;
  while (std::getline(in, line)) {
    double x = 0, sine = 0, high = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf", &x, &sine, &high), 3) << line;
    EXPECT_EQ(x, x_[rows]);
    EXPECT_EQ(sine, y_[rows]);
    EXPECT_EQ(high, y2_[rows]);
    ++rows;
  }
  EXPECT_EQ(rows, 101);
  EXPECT_DOUBLE_EQ(linked_.range.min, 0.0);  // the click did not zoom
  EXPECT_DOUBLE_EQ(linked_.range.max, 20.0);
}

TEST_F(PlotMenu, SaveAsSvgLeavesARequestWithThePlotAsDrawnAndARightDragOpensNoMenu) {
  Frame();
  Frame();
  const PlotState& st = Top();
  const ImVec2 a(st.last_plot_min.x + 100.0f, st.last_plot_min.y + 40.0f);
  MouseTo(a);
  Frame();
  Button(1, true);
  Frame();
  MouseTo(ImVec2(a.x + 200.0f, a.y + 80.0f));
  Frame();
  Button(1, false);
  Frame();
  Frame();
  EXPECT_EQ(Menu(), nullptr);  // a box zoom
  const Range zoomed = linked_.range;

  RightClick(ImVec2(a.x + 50.0f, a.y + 50.0f));
  ClickItem(0);
  ASSERT_TRUE(plots_.export_request.has_value());
  const ExportRequest& r = *plots_.export_request;
  EXPECT_EQ(r.kind, ExportRequest::Kind::kSvg);
  EXPECT_EQ(r.name, "top");
  EXPECT_EQ(r.figure.x.min, zoomed.min);
  EXPECT_EQ(r.figure.x.max, zoomed.max);
  ASSERT_EQ(r.figure.series.size(), 2u);
  const report::FigureSeries& sine = r.figure.series[0];
  EXPECT_EQ(sine.label, "sine");
  ASSERT_FALSE(sine.x.empty());
  // The samples in view and one either side, with their values.
  EXPECT_LT(sine.x.front(), zoomed.min);
  EXPECT_GT(sine.x.back(), zoomed.max);
  for (std::size_t k = 0; k < sine.x.size(); ++k) {
    const auto i = static_cast<std::size_t>(std::lround(sine.x[k] / 0.1));
    EXPECT_EQ(sine.x[k], x_[i]);
    EXPECT_EQ(sine.y[k], y_[i]);
  }
}

TEST_F(PlotMenu, SaveAsPngAsksForThePlotsSizeOnScreenByDefault) {
  Frame();
  Frame();
  const PlotState& st = Top();
  RightClick(ImVec2(st.last_plot_min.x + 50.0f, st.last_plot_min.y + 50.0f));
  ClickItem(1);
  ASSERT_TRUE(plots_.export_request.has_value());
  const ExportRequest& r = *plots_.export_request;
  EXPECT_EQ(r.kind, ExportRequest::Kind::kPng);
  EXPECT_EQ(r.png_width, static_cast<int>(std::lround(r.size.x)));
  EXPECT_EQ(r.png_height, 280);  // the plot's height as BeginPlot was given it
  EXPECT_GT(r.png_width, 700);
}

}  // namespace
}  // namespace gb::ui::plot
