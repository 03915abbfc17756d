// Internal to the plot widget: the data <-> pixel transform and the item renderers shared by
// plot.cpp (frame, axes, input, legend) and plot_items.cpp (lines, bands, markers, ...).
#pragma once

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include <imgui.h>

#include "ui/widgets/plot.h"

namespace gb::ui::plot::internal {

// Pixels further than this outside the plot are clamped: float vertices stay exact enough and
// a segment leaving the view keeps its visible slope.
constexpr double kPixelLimit = 1e6;

struct Transform {
  ImVec2 min, max;  // plot area in screen pixels
  Range x, y;

  float Width() const { return max.x - min.x; }
  float Height() const { return max.y - min.y; }
  float XToPixel(double v) const {
    const double p = (v - x.min) / x.Span() * Width();
    return min.x + static_cast<float>(std::clamp(p, -kPixelLimit, kPixelLimit));
  }
  float YToPixel(double v) const {
    const double p = (v - y.min) / y.Span() * Height();
    return max.y - static_cast<float>(std::clamp(p, -kPixelLimit, kPixelLimit));
  }
  ImVec2 ToPixel(double vx, double vy) const { return ImVec2(XToPixel(vx), YToPixel(vy)); }
  double PixelToX(float px) const {
    return x.min + (double{px} - min.x) / double{Width()} * x.Span();
  }
  double PixelToY(float py) const {
    return y.min + (double{max.y} - py) / double{Height()} * y.Span();
  }
};

// Draws one item, clipped by the caller to the plot area.
void DrawItem(PlotContext& ctx, ImDrawList* dl, const Item& item, const Transform& t);

// Extent of the item's x values (x ascending): false when it has no samples.
bool ItemXExtent(const Item& item, double* lo, double* hi);
// Extent of the finite values the item shows for x in `view`: false when there are none.
bool ItemYExtent(const Item& item, Range view, double* lo, double* hi);

// The sample nearest to `x` (-1 for an empty item).
int NearestIndex(const Item& item, double x);

// The x the hover readout names with the mouse at `x`: the nearest sample of the first shown
// line, marker or stem item (a band may have only its two ends, a correlogram's ± bound, whose
// nearest x is not the one pointed at), else of the first shown band; nullopt without samples.
std::optional<double> ReadoutX(const std::vector<Item>& items, double x);

// The item's values at sample i, formatted for the hover readout ("0.125", "0.1 … 0.3").
std::string ItemValueText(const Item& item, int i);

// The legend swatch of an item: a short line, a filled box or a marker in `min`-`max`.
void DrawSwatch(ImDrawList* dl, const Item& item, ImVec2 min, ImVec2 max, float scale, float alpha);

}  // namespace gb::ui::plot::internal
