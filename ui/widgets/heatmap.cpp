#include "ui/widgets/heatmap.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "ui/widgets/plot_axis.h"

namespace gb::ui::plot {
namespace {

struct Rgb {
  float r, g, b;
};
// ColorBrewer RdBu (7 classes), from -1 to 1.
constexpr Rgb kStops[] = {{33, 102, 172},  {103, 169, 207}, {209, 229, 240}, {247, 247, 247},
                          {253, 219, 199}, {239, 138, 98},  {178, 24, 43}};
constexpr int kNumStops = static_cast<int>(sizeof kStops / sizeof kStops[0]);

constexpr const char* kMissing = "\xE2\x80\x93";  // "–"
constexpr float kCellGap = 1.0f;                  // pixels between cells, at scale 1
constexpr float kLabelPad = 8.0f;
constexpr float kBarWidth = 12.0f;
constexpr float kBarGap = 18.0f;
constexpr int kBarSteps = 64;

float Luminance(ImU32 c) {
  const float r = static_cast<float>((c >> IM_COL32_R_SHIFT) & 0xFF);
  const float g = static_cast<float>((c >> IM_COL32_G_SHIFT) & 0xFF);
  const float b = static_cast<float>((c >> IM_COL32_B_SHIFT) & 0xFF);
  return (0.299f * r + 0.587f * g + 0.114f * b) / 255.0f;
}

double ToUnit(double v, const HeatMapOptions& o) {
  const double mid = 0.5 * (o.min + o.max);
  const double half = 0.5 * (o.max - o.min);
  return half > 0 ? (v - mid) / half : 0.0;
}

// printf of `v`, without the sign of a value that rounds to zero ("0.00", not "-0.00").
void FormatCell(char* buf, std::size_t size, const char* format, double v) {
  std::snprintf(buf, size, format, v);
  if (buf[0] != '-') return;
  for (const char* c = buf + 1; *c; ++c) {
    if (*c >= '1' && *c <= '9') return;
  }
  std::memmove(buf, buf + 1, std::strlen(buf));
}

}  // namespace

ImU32 DivergingColor(double t) {
  if (!std::isfinite(t)) t = 0.0;
  const double x = (std::clamp(t, -1.0, 1.0) + 1.0) * 0.5 * (kNumStops - 1);
  const int i = std::min(kNumStops - 2, static_cast<int>(std::floor(x)));
  const float f = static_cast<float>(x - i);
  const Rgb& a = kStops[i];
  const Rgb& b = kStops[i + 1];
  auto mix = [f](float u, float v) { return static_cast<int>(std::lround(u + (v - u) * f)); };
  return IM_COL32(mix(a.r, b.r), mix(a.g, b.g), mix(a.b, b.b), 255);
}

ImU32 TextColorOn(ImU32 background) {
  return Luminance(background) < 0.55f ? IM_COL32(255, 255, 255, 255) : IM_COL32(30, 34, 40, 255);
}

void HeatMap(const char* id, const std::vector<std::string>& labels, const double* values,
             const HeatMapOptions& o) {
  const int n = static_cast<int>(labels.size());
  if (n == 0) return;
  const float s = o.scale;
  ImFont* label_font = o.label_font ? o.label_font : ImGui::GetFont();

  // Sizes: cells fit the widest value and the widest column label.
  char buf[64];
  float value_w = 0.0f;
  for (int i = 0; i < n * n; ++i) {
    if (!std::isfinite(values[i])) continue;
    FormatCell(buf, sizeof buf, o.format, values[i]);
    value_w = std::max(value_w, ImGui::CalcTextSize(buf).x);
  }
  float label_w = 0.0f;
  for (const std::string& l : labels)
    label_w = std::max(label_w,
                       label_font->CalcTextSizeA(label_font->FontSize, FLT_MAX, 0.0f, l.c_str()).x);
  const float pad = kLabelPad * s;
  const float line_h = ImGui::GetTextLineHeight();
  const float gutter_x = std::round(label_w + pad);
  const float gutter_y = std::round(line_h + 0.5f * pad);
  float cell = std::max({o.min_cell * s, value_w + pad, label_w + pad});
  if (o.max_height > 0.0f) {
    const float bar_label = o.color_bar ? 0.5f * line_h : 0.0f;
    cell = std::max(value_w + pad,
                    std::min(cell, (o.max_height - gutter_y - bar_label) / static_cast<float>(n)));
  }
  cell = std::round(cell);
  char tick_text[3][16];
  std::snprintf(tick_text[0], sizeof tick_text[0], "%s", FormatValue(o.max).c_str());
  std::snprintf(tick_text[1], sizeof tick_text[1], "%s",
                FormatValue(0.5 * (o.min + o.max)).c_str());
  std::snprintf(tick_text[2], sizeof tick_text[2], "%s", FormatValue(o.min).c_str());
  float tick_w = 0.0f;
  for (const char* t : tick_text) tick_w = std::max(tick_w, ImGui::CalcTextSize(t).x);
  const float bar_w = o.color_bar ? (kBarGap + kBarWidth) * s + 4.0f * s + tick_w : 0.0f;
  const float side = cell * static_cast<float>(n);
  // The colour bar's bottom label reaches half a line below the cells.
  const ImVec2 size(gutter_x + side + bar_w,
                    gutter_y + side + (o.color_bar ? 0.5f * line_h : 0.0f));

  const ImVec2 origin = ImGui::GetCursorScreenPos();
  ImGui::InvisibleButton(id, size);
  const bool hovered = ImGui::IsItemHovered();
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 grid(origin.x + gutter_x, origin.y + gutter_y);
  const ImU32 text_col = ImGui::GetColorU32(ImGuiCol_Text);
  const ImU32 dim_col = ImGui::GetColorU32(ImGuiCol_TextDisabled);
  const float gap = kCellGap * s;

  // Labels.
  for (int i = 0; i < n; ++i) {
    const char* l = labels[static_cast<std::size_t>(i)].c_str();
    const ImVec2 ls = label_font->CalcTextSizeA(label_font->FontSize, FLT_MAX, 0.0f, l);
    const float ci = static_cast<float>(i) * cell;
    const ImVec4 clip(grid.x + ci, origin.y, grid.x + ci + cell, grid.y);
    dl->AddText(label_font, label_font->FontSize,
                ImVec2(std::round(grid.x + ci + std::max(0.0f, 0.5f * (cell - ls.x))), origin.y),
                text_col, l, nullptr, 0.0f, &clip);
    dl->AddText(label_font, label_font->FontSize,
                ImVec2(std::round(grid.x - 0.5f * pad - ls.x),
                       std::round(grid.y + ci + 0.5f * (cell - ls.y))),
                text_col, l);
  }

  // Cells.
  int hover_r = -1, hover_c = -1;
  const ImVec2 mouse = ImGui::GetIO().MousePos;
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      const double v = values[r * n + c];
      const ImVec2 a(grid.x + static_cast<float>(c) * cell + gap,
                     grid.y + static_cast<float>(r) * cell + gap);
      const ImVec2 b(grid.x + static_cast<float>(c + 1) * cell - gap,
                     grid.y + static_cast<float>(r + 1) * cell - gap);
      const bool finite = std::isfinite(v);
      const ImU32 bg = finite ? DivergingColor(ToUnit(v, o)) : IM_COL32(238, 239, 242, 255);
      dl->AddRectFilled(a, b, bg);
      const char* text = kMissing;
      if (finite) {
        FormatCell(buf, sizeof buf, o.format, v);
        text = buf;
      }
      const ImVec2 ts = ImGui::CalcTextSize(text);
      dl->AddText(
          ImVec2(std::round(0.5f * (a.x + b.x - ts.x)), std::round(0.5f * (a.y + b.y - ts.y))),
          finite ? TextColorOn(bg) : dim_col, text);
      if (hovered && mouse.x >= a.x - gap && mouse.x < b.x + gap && mouse.y >= a.y - gap &&
          mouse.y < b.y + gap) {
        hover_r = r;
        hover_c = c;
      }
    }
  }
  if (hover_r >= 0) {
    const ImVec2 a(grid.x + static_cast<float>(hover_c) * cell,
                   grid.y + static_cast<float>(hover_r) * cell);
    dl->AddRect(a, ImVec2(a.x + cell, a.y + cell), IM_COL32(30, 34, 40, 255), 0.0f, 0, 2.0f * s);
    const double v = values[hover_r * n + hover_c];
    if (std::isfinite(v)) {
      FormatCell(buf, sizeof buf, o.format, v);
    } else {
      std::snprintf(buf, sizeof buf, "%s", kMissing);
    }
    ImGui::SetTooltip("%s / %s: %s", labels[static_cast<std::size_t>(hover_r)].c_str(),
                      labels[static_cast<std::size_t>(hover_c)].c_str(), buf);
  }

  // Colour bar: max at the top.
  if (!o.color_bar) return;
  const float bx = grid.x + side + kBarGap * s;
  const float step = side / kBarSteps;
  for (int i = 0; i < kBarSteps; ++i) {
    const double t = 1.0 - 2.0 * (i + 0.5) / kBarSteps;
    dl->AddRectFilled(ImVec2(bx, grid.y + static_cast<float>(i) * step),
                      ImVec2(bx + kBarWidth * s, grid.y + static_cast<float>(i + 1) * step + 0.5f),
                      DivergingColor(t));
  }
  dl->AddRect(ImVec2(bx, grid.y), ImVec2(bx + kBarWidth * s, grid.y + side),
              ImGui::GetColorU32(ImGuiCol_Border));
  for (int k = 0; k < 3; ++k) {
    const float y = grid.y + 0.5f * side * static_cast<float>(k);
    dl->AddLine(ImVec2(bx + kBarWidth * s, y), ImVec2(bx + kBarWidth * s + 3.0f * s, y), dim_col);
    const float ty =
        std::clamp(y - 0.5f * line_h, grid.y - 0.5f * line_h, grid.y + side - 0.5f * line_h);
    dl->AddText(ImVec2(bx + kBarWidth * s + 5.0f * s, std::round(ty)), dim_col, tick_text[k]);
  }
}

}  // namespace gb::ui::plot
