// The plot widget's frame: see plot.h for the API and the mouse controls.
//
// Sections
//   1. Recording items (Plot* functions)
//   2. Input: wheel zoom, drag pan, box zoom, double-click fit, legend clicks
//   3. Fitting the ranges to the data
//   4. Layout: gutters, ticks, linked plots aligned on their left edge
//   5. Drawing: grid, axes, labels, legend, hover readout
//   6. Export: the plot as a report::Figure, the context menu
//   7. BeginPlot / EndPlot
#include "ui/widgets/plot.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <string>

#include <imgui_internal.h>  // SetItemUsingMouseWheel: the wheel zooms instead of scrolling

#include "ui/widgets/plot_internal.h"

namespace gb::ui::plot {
namespace {

using internal::Transform;

// Zoom factor per wheel notch, and the narrowest span a zoom may reach relative to the
// magnitude of the values (below it, doubles cannot tell the ticks apart).
constexpr double kWheelZoom = 0.8;
constexpr double kMinRelativeSpan = 1e-10;
constexpr double kMaxSpan = 1e300;
constexpr double kFitPadding = 0.05;   // y auto-fit: fraction of the span added above and below
constexpr float kMinBoxPixels = 4.0f;  // a box zoom narrower than this keeps that axis

bool Inside(ImVec2 p, ImVec2 min, ImVec2 max) {
  return p.x >= min.x && p.x < max.x && p.y >= min.y && p.y < max.y;
}

std::string VisibleLabel(const char* label) {
  const char* end = std::strstr(label, "##");
  return end ? std::string(label, end) : std::string(label);
}

PlotState& CurrentState(PlotContext& ctx) { return ctx.plots[ctx.current_id]; }

LinkedRange& XRange(PlotContext& ctx, PlotState& st) {
  return ctx.options.linked_x ? *ctx.options.linked_x : st.own_x;
}

// Zooms `r` by `factor` about `anchor`, refusing spans that doubles cannot resolve.
void ZoomAbout(Range* r, double anchor, double factor) {
  const double lo = anchor - (anchor - r->min) * factor;
  const double hi = anchor + (r->max - anchor) * factor;
  const double magnitude = std::max(std::abs(lo), std::abs(hi));
  if (!(hi - lo > kMinRelativeSpan * magnitude) || hi - lo > kMaxSpan) return;
  r->min = lo;
  r->max = hi;
}

// ---------------------------------------------------------------------------------------------
// 1. Recording items

Item& AddItem(PlotContext& ctx, ItemKind kind, const char* label, const double* x, int n,
              const ItemStyle& style) {
  IM_ASSERT(ctx.in_plot && "Plot* called outside BeginPlot()/EndPlot()");
  PlotState& st = CurrentState(ctx);
  Item& item = ctx.items.emplace_back();
  item.kind = kind;
  item.label = VisibleLabel(label);
  ImGui::PushID(static_cast<int>(ctx.current_id));
  item.id = ImGui::GetID(label);
  ImGui::PopID();
  item.x = x;
  item.n = std::max(0, n);
  const PlotStyle& ps = ctx.style;
  item.color = style.color ? style.color : ps.palette[(ctx.items.size() - 1) % ps.palette.size()];
  item.line_weight = style.line_weight > 0 ? style.line_weight : ps.line_weight;
  item.marker_radius = style.marker_radius > 0 ? style.marker_radius : ps.marker_radius;
  item.fill_alpha = style.fill_alpha;
  item.hidden = std::find(st.hidden.begin(), st.hidden.end(), item.id) != st.hidden.end();
  return item;
}

// ---------------------------------------------------------------------------------------------
// 2. Input (uses the previous frame's layout, as ImGui's own hit tests do)

enum class Region { kNone, kPlot, kYAxis, kXAxis, kLegend };

Region RegionAt(const PlotContext& ctx, const PlotState& st, ImVec2 p) {
  if (!st.drawn_before || !Inside(p, ctx.frame_min, ctx.frame_max)) return Region::kNone;
  if (Inside(p, st.last_legend_min, st.last_legend_max)) return Region::kLegend;
  if (Inside(p, st.last_plot_min, st.last_plot_max)) return Region::kPlot;
  if (p.x < st.last_plot_min.x && p.y >= st.last_plot_min.y && p.y < st.last_plot_max.y)
    return Region::kYAxis;
  if (p.y >= st.last_plot_max.y && p.x >= st.last_plot_min.x && p.x < st.last_plot_max.x)
    return Region::kXAxis;
  return Region::kNone;
}

void ToggleLegendEntry(PlotState& st, ImVec2 mouse) {
  std::size_t row = 0;
  while (row < st.legend_ids.size() &&
         !Inside(mouse, st.legend_entry_min[row], st.legend_entry_max[row]))
    ++row;
  if (row >= st.legend_ids.size()) return;
  const ImGuiID id = st.legend_ids[row];
  const auto it = std::find(st.hidden.begin(), st.hidden.end(), id);
  if (it == st.hidden.end()) {
    st.hidden.push_back(id);
  } else {
    st.hidden.erase(it);
  }
}

void HandleInput(PlotContext& ctx, PlotState& st, LinkedRange& xr) {
  if (!st.drawn_before) return;
  const ImGuiIO& io = ImGui::GetIO();
  const Transform t{st.last_plot_min, st.last_plot_max, xr.range, st.y};
  const Region region = RegionAt(ctx, st, io.MousePos);
  const int frame = ImGui::GetFrameCount();

  const bool over_axes =
      region == Region::kPlot || region == Region::kYAxis || region == Region::kXAxis;
  if (ctx.hovered && io.MouseWheel != 0.0f && over_axes) {
    const double factor = std::pow(kWheelZoom, io.MouseWheel);
    if (region == Region::kYAxis) {
      ZoomAbout(&st.y, t.PixelToY(io.MousePos.y), factor);
      st.y_auto = false;
    } else {
      ZoomAbout(&xr.range, t.PixelToX(io.MousePos.x), factor);
    }
  }

  if (ctx.hovered && ImGui::IsMouseClicked(ImGuiMouseButton_Left)) {
    st.drag_region = static_cast<int>(region);
    if (region == Region::kLegend) ToggleLegendEntry(st, io.MousePos);
  }
  if (ctx.hovered && ImGui::IsMouseDoubleClicked(ImGuiMouseButton_Left) &&
      region != Region::kLegend) {
    st.y_auto = true;
    if (region != Region::kYAxis) xr.fit_request_frame = frame;
  }

  const Region drag = static_cast<Region>(st.drag_region);
  if (ctx.active && ImGui::IsMouseDragging(ImGuiMouseButton_Left, 1.0f) &&
      (drag == Region::kPlot || drag == Region::kYAxis || drag == Region::kXAxis)) {
    const ImVec2 d = io.MouseDelta;
    if (drag != Region::kYAxis && d.x != 0.0f) {
      const double dx = double{d.x} / double{t.Width()} * xr.range.Span();
      xr.range.min -= dx;
      xr.range.max -= dx;
    }
    if ((drag == Region::kYAxis || (drag == Region::kPlot && !st.y_auto)) && d.y != 0.0f) {
      const double dy = double{d.y} / double{t.Height()} * st.y.Span();
      st.y.min += dy;
      st.y.max += dy;
      st.y_auto = false;
    }
  }

  // Box zoom with the right button: x and y, or only the axis the box is wide enough along.
  // Released where it went down (closer than a box zoom's smallest box), it opens the menu.
  if (ctx.hovered && ImGui::IsMouseClicked(ImGuiMouseButton_Right)) {
    st.right_down = true;
    st.right_start = io.MousePos;
  }
  if (st.right_down && !ImGui::IsMouseDown(ImGuiMouseButton_Right)) {
    st.right_down = false;
    st.open_menu = std::abs(io.MousePos.x - st.right_start.x) < kMinBoxPixels &&
                   std::abs(io.MousePos.y - st.right_start.y) < kMinBoxPixels;
  }
  if (ctx.hovered && region == Region::kPlot && ImGui::IsMouseClicked(ImGuiMouseButton_Right)) {
    st.box_active = true;
    st.box_start = io.MousePos;
  }
  if (st.box_active && !ImGui::IsMouseDown(ImGuiMouseButton_Right)) {
    st.box_active = false;
    const ImVec2 a = st.box_start;
    const ImVec2 b(std::clamp(io.MousePos.x, t.min.x, t.max.x),
                   std::clamp(io.MousePos.y, t.min.y, t.max.y));
    if (std::abs(b.x - a.x) >= kMinBoxPixels) {
      xr.range = {t.PixelToX(std::min(a.x, b.x)), t.PixelToX(std::max(a.x, b.x))};
    }
    if (std::abs(b.y - a.y) >= kMinBoxPixels) {
      st.y = {t.PixelToY(std::max(a.y, b.y)), t.PixelToY(std::min(a.y, b.y))};
      st.y_auto = false;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// 3. Fitting

// x: when a fit is due, the first plot drawn in the frame takes its own extent and the plots
// after it (sharing the range) widen it, so linked plots agree from the next frame on.
void FitX(PlotContext& ctx, LinkedRange& xr) {
  const int frame = ImGui::GetFrameCount();
  if (xr.fit_request_frame != LinkedRange::kNoFit && frame > xr.fit_request_frame) {
    xr.fit_request_frame = LinkedRange::kNoFit;
    xr.fit_frame = frame;
    xr.fit_has_data = false;
  }
  if (xr.fit_frame != frame) return;
  // This plot's extent (padded as its options ask), then the union with the plots before it.
  bool any = false;
  Range own;
  for (const Item& item : ctx.items) {
    double lo = 0, hi = 0;
    if (!internal::ItemXExtent(item, &lo, &hi)) continue;
    own = any ? Range{std::min(own.min, lo), std::max(own.max, hi)} : Range{lo, hi};
    any = true;
  }
  if (any && ctx.options.x_padding > 0.0) {
    const double h = own.Span() * ctx.options.x_padding;
    own = {own.min - h, own.max + h};
  }
  if (any) {
    xr.range = xr.fit_has_data
                   ? Range{std::min(xr.range.min, own.min), std::max(xr.range.max, own.max)}
                   : own;
    xr.fit_has_data = true;
  }
  if (!xr.fit_has_data) xr.range = {0.0, 1.0};
  if (!(xr.range.Span() > 0.0)) {
    const double c = xr.range.min;
    const double h = std::max(std::abs(c) * kFitPadding, 0.5);
    xr.range = {c - h, c + h};
  }
}

// y: the extent of what is in view (visible items only), with a margin.
void FitY(PlotContext& ctx, PlotState& st, Range x_view) {
  if (!st.y_auto) return;
  bool any = false;
  double lo = 0, hi = 0;
  for (const Item& item : ctx.items) {
    double a = 0, b = 0;
    if (item.hidden || !internal::ItemYExtent(item, x_view, &a, &b)) continue;
    lo = any ? std::min(lo, a) : a;
    hi = any ? std::max(hi, b) : b;
    any = true;
  }
  if (!any) {
    st.y = {0.0, 1.0};
    return;
  }
  const double span = hi - lo;
  const double pad = span > 0 ? span * kFitPadding : std::max(std::abs(lo) * kFitPadding, 0.5);
  st.y = {lo - pad, hi + pad};
}

// ---------------------------------------------------------------------------------------------
// 4. Layout

struct Layout {
  ImVec2 plot_min, plot_max;
  Ticks x_ticks, y_ticks;
  float font_h = 0, title_h = 0, pad = 0, tick_len = 0;
};

float MaxLabelWidth(const Ticks& ticks) {
  float w = 0.0f;
  for (double v : ticks.values)
    w = std::max(w, ImGui::CalcTextSize(FormatTick(v, ticks).c_str()).x);
  return w;
}

Layout ComputeLayout(PlotContext& ctx, const PlotState& st, const LinkedRange& xr) {
  const PlotOptions& o = ctx.options;
  Layout l;
  l.font_h = ImGui::GetFontSize();
  l.pad = std::round(0.5f * l.font_h);
  l.tick_len = std::round(4.0f * ctx.style.scale);
  ImFont* title_font = ctx.style.title_font ? ctx.style.title_font : ImGui::GetFont();
  l.title_h = o.title ? title_font->FontSize + l.pad : 0.5f * l.font_h;

  const float top = ctx.frame_min.y + l.title_h;
  float bottom = ctx.frame_max.y - 0.5f * l.pad;
  if (o.x_tick_labels) bottom -= l.tick_len + l.font_h + 0.25f * l.pad;
  if (o.x_title && (o.x_label || o.x_unit)) bottom -= l.font_h + 0.25f * l.pad;
  bottom = std::max(bottom, top + 1.0f);

  l.y_ticks = NiceTicks(st.y, static_cast<int>((bottom - top) / (2.2f * l.font_h)) + 1);
  float gutter = MaxLabelWidth(l.y_ticks) + l.tick_len + 0.5f * l.pad;
  if (o.y_label) gutter += l.font_h + 0.5f * l.pad;
  gutter = std::max(gutter, 3.0f * l.font_h);
  // Plots sharing an x range share the widest gutter of the previous frame, so their plot
  // areas line up one above the other.
  if (o.linked_x) {
    LinkedRange& lx = *o.linked_x;
    const int frame = ImGui::GetFrameCount();
    if (lx.gutter_frame != frame) {
      lx.gutter = lx.gutter_next;
      lx.gutter_next = 0.0f;
      lx.gutter_frame = frame;
    }
    lx.gutter_next = std::max(lx.gutter_next, gutter);
    gutter = std::max(gutter, lx.gutter);
  }

  l.plot_min = ImVec2(std::floor(ctx.frame_min.x + gutter), std::floor(top));
  l.plot_max = ImVec2(std::floor(std::max(ctx.frame_max.x - l.pad, l.plot_min.x + 1.0f)),
                      std::floor(bottom));
  const float width = l.plot_max.x - l.plot_min.x;
  // As many x ticks as fit with their labels a couple of characters apart.
  const Ticks probe = NiceTicks(xr.range, static_cast<int>(width / (5.0f * l.font_h)) + 1);
  const float label_w = MaxLabelWidth(probe) + 3.0f * l.font_h;
  l.x_ticks = NiceTicks(xr.range, static_cast<int>(width / label_w) + 1);
  return l;
}

// ---------------------------------------------------------------------------------------------
// 5. Drawing

// Text turned a quarter anticlockwise (reading upwards), centred on `center`.
void AddVerticalText(ImDrawList* dl, ImVec2 center, ImU32 color, const char* text) {
  ImFont* font = ImGui::GetFont();
  const float size = ImGui::GetFontSize();
  const ImVec2 ts = font->CalcTextSizeA(size, FLT_MAX, 0.0f, text);
  const int begin = dl->VtxBuffer.Size;
  const ImVec4 no_clip(-FLT_MAX, -FLT_MAX, FLT_MAX, FLT_MAX);
  font->RenderText(dl, size, ImVec2(center.x - 0.5f * ts.x, center.y - 0.5f * ts.y), color, no_clip,
                   text, nullptr);
  for (int i = begin; i < dl->VtxBuffer.Size; ++i) {
    ImVec2& p = dl->VtxBuffer[i].pos;
    const float dx = p.x - center.x;
    const float dy = p.y - center.y;
    p = ImVec2(center.x + dy, center.y - dx);
  }
}

std::string AxisTitle(const char* label, const char* unit) {
  std::string s = label ? label : "";
  if (unit && *unit) s += std::string(s.empty() ? "" : " ") + "[" + unit + "]";
  return s;
}

void DrawAxes(PlotContext& ctx, ImDrawList* dl, const Layout& l, const Transform& t) {
  const PlotOptions& o = ctx.options;
  const PlotStyle& s = ctx.style;
  // Grid.
  for (double v : l.x_ticks.values) {
    const float px = std::round(t.XToPixel(v)) + 0.5f;
    dl->AddLine(ImVec2(px, t.min.y), ImVec2(px, t.max.y), s.grid);
  }
  for (double v : l.y_ticks.values) {
    const float py = std::round(t.YToPixel(v)) + 0.5f;
    dl->AddLine(ImVec2(t.min.x, py), ImVec2(t.max.x, py), s.grid);
  }
  // Tick marks and labels, kept inside the frame.
  for (double v : l.y_ticks.values) {
    const float py = std::round(t.YToPixel(v)) + 0.5f;
    dl->AddLine(ImVec2(t.min.x - l.tick_len, py), ImVec2(t.min.x, py), s.border);
    const std::string text = FormatTick(v, l.y_ticks);
    const ImVec2 ts = ImGui::CalcTextSize(text.c_str());
    const float y = std::clamp(py - 0.5f * ts.y, ctx.frame_min.y, ctx.frame_max.y - ts.y);
    dl->AddText(ImVec2(t.min.x - l.tick_len - 0.25f * l.pad - ts.x, y), s.tick_text, text.c_str());
  }
  for (double v : l.x_ticks.values) {
    const float px = std::round(t.XToPixel(v)) + 0.5f;
    dl->AddLine(ImVec2(px, t.max.y), ImVec2(px, t.max.y + l.tick_len), s.border);
    if (!o.x_tick_labels) continue;
    const std::string text = FormatTick(v, l.x_ticks);
    const ImVec2 ts = ImGui::CalcTextSize(text.c_str());
    const float x = std::clamp(px - 0.5f * ts.x, ctx.frame_min.x, ctx.frame_max.x - ts.x);
    dl->AddText(ImVec2(x, t.max.y + l.tick_len + 0.15f * l.pad), s.tick_text, text.c_str());
  }
  dl->AddRect(ImVec2(t.min.x - 0.5f, t.min.y - 0.5f), ImVec2(t.max.x + 0.5f, t.max.y + 0.5f),
              s.border);

  // Axis titles and shared powers of ten.
  if (o.x_title && (o.x_label || o.x_unit)) {
    const std::string title = AxisTitle(o.x_label, o.x_unit);
    const ImVec2 ts = ImGui::CalcTextSize(title.c_str());
    const float y = ctx.frame_max.y - 0.5f * l.pad - ts.y;
    dl->AddText(ImVec2(0.5f * (t.min.x + t.max.x - ts.x), y), s.tick_text, title.c_str());
  }
  if (o.y_label || o.y_unit) {
    const std::string title = AxisTitle(o.y_label, o.y_unit);
    const float cx = ctx.frame_min.x + 0.5f * l.font_h;
    AddVerticalText(dl, ImVec2(cx, 0.5f * (t.min.y + t.max.y)), s.tick_text, title.c_str());
  }
  auto exponent_note = [&](int e, ImVec2 pos, bool right_align) {
    const std::string text =
        "\xC3\x97"
        "1e" +
        std::to_string(e);
    const ImVec2 ts = ImGui::CalcTextSize(text.c_str());
    if (right_align) pos.x -= ts.x;
    dl->AddRectFilled(ImVec2(pos.x - 2, pos.y), ImVec2(pos.x + ts.x + 2, pos.y + ts.y), s.label_bg);
    dl->AddText(pos, s.tick_text, text.c_str());
  };
  if (l.y_ticks.exponent != 0)
    exponent_note(l.y_ticks.exponent, ImVec2(t.min.x + 0.3f * l.pad, t.min.y + 2.0f), false);
  if (l.x_ticks.exponent != 0)
    exponent_note(l.x_ticks.exponent, ImVec2(t.max.x - 0.3f * l.pad, t.max.y - l.font_h - 2.0f),
                  true);

  if (o.title) {
    ImFont* font = s.title_font ? s.title_font : ImGui::GetFont();
    const float y = ctx.frame_min.y + 0.5f * (l.title_h - font->FontSize) - 0.1f * l.pad;
    // A title longer than the plot is wide ends in "…" at the frame's right edge.
    const float room = ctx.frame_max.x - t.min.x;
    std::string title = o.title;
    if (font->CalcTextSizeA(font->FontSize, FLT_MAX, 0.0f, title.c_str()).x > room) {
      const char* kEllipsis = "\xE2\x80\xA6";
      while (!title.empty() &&
             font->CalcTextSizeA(font->FontSize, FLT_MAX, 0.0f, (title + kEllipsis).c_str()).x >
                 room) {
        unsigned char c = 0;
        do {  // a whole UTF-8 character: its continuation bytes, then its first
          c = static_cast<unsigned char>(title.back());
          title.pop_back();
        } while (!title.empty() && (c & 0xC0) == 0x80);
      }
      title += kEllipsis;
    }
    dl->AddText(font, font->FontSize, ImVec2(t.min.x, y), s.title_text, title.c_str());
    // Drawn, not an item: the title goes into ImGui's log as a line of its own (a view copied
    // as text, the interaction tests' Text()).
    ImGui::LogText("%s%s", IM_NEWLINE, o.title);
  }
}

void DrawLegend(PlotContext& ctx, PlotState& st, ImDrawList* dl, const Layout& l,
                const Transform& t) {
  st.legend_ids.clear();
  st.legend_entry_min.clear();
  st.legend_entry_max.clear();
  st.last_legend_min = st.last_legend_max = ImVec2(0, 0);
  std::vector<const Item*> entries;
  float text_w = 0.0f;
  for (const Item& item : ctx.items) {
    if (item.label.empty()) continue;
    entries.push_back(&item);
    text_w = std::max(text_w, ImGui::CalcTextSize(item.label.c_str()).x);
  }
  const Legend mode = ctx.options.legend;
  const int labelled = static_cast<int>(entries.size());
  if (mode == Legend::kHide || labelled == 0 || (mode == Legend::kAuto && labelled < 2)) return;

  const float pad = 0.4f * l.font_h;
  const float row_h = l.font_h + 0.3f * l.font_h;
  const float swatch_w = 1.4f * l.font_h;
  const float plot_w = t.max.x - t.min.x, plot_h = t.max.y - t.min.y;
  // One entry a row; where that box would cover much of a small plot (a third of its height, or
  // a sixth of its area), the entries run side by side in as few rows as the width allows.
  const ImVec2 column(pad * 3.0f + swatch_w + text_w, pad * 2.0f + row_h * labelled);
  const bool side_by_side =
      column.y > plot_h / 3.0f || column.x * column.y > plot_w * plot_h / 6.0f;
  const auto entry_w = [&](const Item* item) {
    return swatch_w + pad + ImGui::CalcTextSize(item->label.c_str()).x + 2.0f * pad;
  };
  // Each entry's offset in the box, and the box's size.
  std::vector<ImVec2> at;
  ImVec2 size(0, 0);
  if (side_by_side) {
    const float limit = std::max(plot_w - 2.0f * pad, 0.0f);
    float x = pad, y = pad;
    for (const Item* item : entries) {
      const float w = entry_w(item);
      if (x > pad && x + w > limit) {
        x = pad;
        y += row_h;
      }
      at.emplace_back(x, y);
      x += w;
      size.x = std::max(size.x, x);
    }
    size.y = y + row_h + pad;
  } else {
    for (int k = 0; k < labelled; ++k) at.emplace_back(pad, pad + row_h * static_cast<float>(k));
    size = column;
  }
  // Still a quarter of the plot: left out (the hover readout names the items with their
  // swatches).
  if (side_by_side && size.x * size.y > 0.25f * plot_w * plot_h) return;
  const LegendCorner corner = ctx.options.legend_corner;
  const bool right = corner == LegendCorner::kTopRight || corner == LegendCorner::kBottomRight;
  const bool top = corner == LegendCorner::kTopRight || corner == LegendCorner::kTopLeft;
  const ImVec2 min(right ? t.max.x - pad - size.x : t.min.x + pad,
                   top ? t.min.y + pad : t.max.y - pad - size.y);
  const ImVec2 max(min.x + size.x, min.y + size.y);
  dl->AddRectFilled(min, max, ctx.style.label_bg, 3.0f * ctx.style.scale);
  dl->AddRect(min, max, ctx.style.border, 3.0f * ctx.style.scale);
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const Item& item = *entries[k];
    const float alpha = item.hidden ? 0.3f : 1.0f;
    const float sh = 0.6f * l.font_h;
    const ImVec2 e(min.x + at[k].x, min.y + at[k].y);
    const ImVec2 sw_min(e.x, e.y + 0.5f * (row_h - sh));
    internal::DrawSwatch(dl, item, sw_min, ImVec2(sw_min.x + swatch_w, sw_min.y + sh),
                         ctx.style.scale, alpha);
    const ImU32 text = item.hidden ? IM_COL32(150, 154, 160, 255) : ctx.style.title_text;
    dl->AddText(ImVec2(e.x + pad + swatch_w, e.y + 0.5f * (row_h - l.font_h)), text,
                item.label.c_str());
    st.legend_ids.push_back(item.id);
    st.legend_entry_min.push_back(e);
    st.legend_entry_max.emplace_back(side_by_side ? e.x + entry_w(&item) : max.x - pad,
                                     e.y + row_h);
  }
  st.last_legend_min = ImVec2(min.x, min.y + pad);
  st.last_legend_max = ImVec2(max.x, max.y - pad);
}

// The crosshair at the hovered x (on every plot sharing the x range), the nearest sample of
// each item, and, in the hovered plot, a tooltip with their values.
void DrawHover(PlotContext& ctx, PlotState& st, LinkedRange& xr, ImDrawList* dl,
               const Transform& t) {
  const ImGuiIO& io = ImGui::GetIO();
  const int frame = ImGui::GetFrameCount();
  const bool dragging = ImGui::IsMouseDragging(ImGuiMouseButton_Left) || st.box_active;
  const bool here = ctx.hovered && !dragging && Inside(io.MousePos, t.min, t.max) &&
                    !Inside(io.MousePos, st.last_legend_min, st.last_legend_max);
  if (here) {
    xr.hover_x = t.PixelToX(io.MousePos.x);
    xr.hover_frame = frame;
  }
  const bool shared = ctx.options.linked_x && xr.hover_frame >= frame - 1;
  if (!here && !shared) return;
  const double hx = xr.hover_x;
  if (!xr.range.Contains(hx)) return;

  const float px = std::round(t.XToPixel(hx)) + 0.5f;
  dl->AddLine(ImVec2(px, t.min.y), ImVec2(px, t.max.y), ctx.style.crosshair);
  for (const Item& item : ctx.items) {
    if (item.hidden || item.kind == ItemKind::kBand || item.kind == ItemKind::kVLines) continue;
    const int i = internal::NearestIndex(item, hx);
    if (i < 0 || !std::isfinite(item.y[i])) continue;
    const ImVec2 p = t.ToPixel(item.x[i], item.y[i]);
    dl->AddCircleFilled(p, 3.5f * ctx.style.scale, ctx.style.plot_bg, 12);
    dl->AddCircle(p, 3.5f * ctx.style.scale, item.color, 12, 1.5f * ctx.style.scale);
  }
  if (!here) return;

  ImGui::BeginTooltip();
  const std::string x_name = ctx.options.x_label ? ctx.options.x_label : "x";
  if (const std::optional<double> x = internal::ReadoutX(ctx.items, hx))
    ImGui::TextDisabled("%s = %s", x_name.c_str(), FormatValue(*x).c_str());
  bool first = true;
  for (const Item& item : ctx.items) {
    if (item.hidden || item.kind == ItemKind::kVLines) continue;
    const int i = internal::NearestIndex(item, hx);
    if (i < 0) continue;
    first = false;
    const ImVec2 pos = ImGui::GetCursorScreenPos();
    const float h = ImGui::GetTextLineHeight();
    internal::DrawSwatch(ImGui::GetWindowDrawList(), item, ImVec2(pos.x, pos.y + 0.25f * h),
                         ImVec2(pos.x + h, pos.y + 0.75f * h), ctx.style.scale, 1.0f);
    ImGui::Dummy(ImVec2(h, h));
    ImGui::SameLine(0.0f, 0.5f * h);
    const std::string name = item.label.empty() ? "value" : item.label;
    ImGui::Text("%s  %s", name.c_str(), internal::ItemValueText(item, i).c_str());
  }
  if (first) ImGui::TextDisabled("no data");
  ImGui::EndTooltip();
}

// ---------------------------------------------------------------------------------------------
// 6. Export

report::Rgba ToRgba(ImU32 c) {
  return {static_cast<std::uint8_t>((c >> IM_COL32_R_SHIFT) & 0xFF),
          static_cast<std::uint8_t>((c >> IM_COL32_G_SHIFT) & 0xFF),
          static_cast<std::uint8_t>((c >> IM_COL32_B_SHIFT) & 0xFF),
          static_cast<std::uint8_t>((c >> IM_COL32_A_SHIFT) & 0xFF)};
}

report::SeriesKind ToSeriesKind(ItemKind k) {
  switch (k) {
    case ItemKind::kLine:
      return report::SeriesKind::kLine;
    case ItemKind::kBand:
      return report::SeriesKind::kBand;
    case ItemKind::kMarkers:
      return report::SeriesKind::kMarkers;
    case ItemKind::kStems:
      return report::SeriesKind::kStems;
    case ItemKind::kErrorBars:
      return report::SeriesKind::kErrorBars;
    case ItemKind::kVLines:
      return report::SeriesKind::kVLines;
  }
  return report::SeriesKind::kLine;
}

// The plot as drawn: the shown items' samples in the x range (copied: the items' arrays are
// the caller's and valid only until EndPlot returns).
report::Figure MakeFigure(const PlotContext& ctx, const PlotState& st, const LinkedRange& xr) {
  const PlotOptions& o = ctx.options;
  report::Figure f;
  f.title = o.title ? o.title : "";
  f.x_label = o.x_label ? o.x_label : "";
  f.x_unit = o.x_unit ? o.x_unit : "";
  f.y_label = o.y_label ? o.y_label : "";
  f.y_unit = o.y_unit ? o.y_unit : "";
  f.x = xr.range;
  f.y = st.y;
  int labelled = 0;
  for (const Item& item : ctx.items) {
    if (item.hidden) continue;
    labelled += item.label.empty() ? 0 : 1;
    report::FigureSeries& s = f.series.emplace_back();
    s.kind = ToSeriesKind(item.kind);
    s.label = item.label;
    s.color = ToRgba(item.color);
    s.line_weight = item.line_weight;
    s.marker_radius = item.marker_radius;
    s.fill_alpha = item.fill_alpha;
    s.ref = item.ref;
    const auto n = static_cast<std::size_t>(item.n);
    s.x.assign(item.x, item.x + n);
    if (item.y) s.y.assign(item.y, item.y + n);
    if (item.y2) s.y2.assign(item.y2, item.y2 + n);
    if (item.tags) {
      for (std::size_t i = 0; i < n; ++i) s.tags.emplace_back(item.tags[i] ? item.tags[i] : "");
    }
  }
  f.legend = o.legend == Legend::kShow || (o.legend == Legend::kAuto && labelled >= 2);
  return report::ClipToXRange(std::move(f));
}

void DrawContextMenu(PlotContext& ctx, PlotState& st, const LinkedRange& xr) {
  ImGui::PushID(static_cast<int>(ctx.current_id));
  const ImVec2 size(ctx.frame_max.x - ctx.frame_min.x, ctx.frame_max.y - ctx.frame_min.y);
  if (st.open_menu) {
    st.open_menu = false;
    st.png_width = static_cast<int>(std::lround(size.x));
    st.png_height = static_cast<int>(std::lround(size.y));
    ImGui::OpenPopup("##plot-menu");
  }
  if (ImGui::BeginPopup("##plot-menu")) {
    const bool svg = ImGui::MenuItem("Save image as SVG\xE2\x80\xA6");
    const bool png = ImGui::MenuItem("Save image as PNG\xE2\x80\xA6");
    const bool csv = ImGui::MenuItem("Copy data as CSV");
    if (svg || png) {
      ExportRequest& r = ctx.export_request.emplace();
      r.kind = svg ? ExportRequest::Kind::kSvg : ExportRequest::Kind::kPng;
      r.name = ctx.current_name;
      r.id = ctx.current_id;
      r.figure = MakeFigure(ctx, st, xr);
      r.size = size;
      r.png_width = std::clamp(st.png_width, kMinPngSize, kMaxPngSize);
      r.png_height = std::clamp(st.png_height, kMinPngSize, kMaxPngSize);
    }
    if (csv) ImGui::SetClipboardText(report::FigureToCsv(MakeFigure(ctx, st, xr)).c_str());
    ImGui::Separator();
    // The PNG's size: the plot's on screen unless changed here.
    ImGui::TextDisabled("PNG size");
    ImGui::SameLine();
    ImGui::SetNextItemWidth(4.5f * ImGui::GetFontSize());
    ImGui::DragInt("##png-width", &st.png_width, 1.0f, kMinPngSize, kMaxPngSize, "%d",
                   ImGuiSliderFlags_AlwaysClamp);
    ImGui::SameLine();
    ImGui::TextUnformatted("\xC3\x97");
    ImGui::SameLine();
    ImGui::SetNextItemWidth(4.5f * ImGui::GetFontSize());
    ImGui::DragInt("##png-height", &st.png_height, 1.0f, kMinPngSize, kMaxPngSize, "%d",
                   ImGuiSliderFlags_AlwaysClamp);
    ImGui::EndPopup();
  }
  ImGui::PopID();
}

}  // namespace

void PlotFigure(PlotContext& ctx, const char* id, ImVec2 size, const report::Figure& figure) {
  PlotState& st = ctx.plots[ImGui::GetID(id)];
  st.own_x.range = figure.x;
  st.own_x.fit_request_frame = LinkedRange::kNoFit;
  st.y = figure.y;
  st.y_auto = false;
  PlotOptions o;
  const auto text = [](const std::string& s) { return s.empty() ? nullptr : s.c_str(); };
  o.title = text(figure.title);
  o.x_label = text(figure.x_label);
  o.x_unit = text(figure.x_unit);
  o.y_label = text(figure.y_label);
  o.y_unit = text(figure.y_unit);
  o.legend = figure.legend ? Legend::kShow : Legend::kHide;
  if (!BeginPlot(ctx, id, size, o)) return;
  std::vector<std::vector<const char*>> tags(figure.series.size());
  for (std::size_t k = 0; k < figure.series.size(); ++k) {
    const report::FigureSeries& s = figure.series[k];
    const std::string label = s.label + "##series" + std::to_string(k);
    ItemStyle style;
    style.color = IM_COL32(s.color.r, s.color.g, s.color.b, s.color.a);
    style.line_weight = s.line_weight;
    style.marker_radius = s.marker_radius;
    style.fill_alpha = s.fill_alpha;
    const int n = static_cast<int>(s.x.size());
    const bool has_y = s.y.size() == s.x.size(), has_y2 = s.y2.size() == s.x.size();
    switch (s.kind) {
      case report::SeriesKind::kLine:
        if (has_y) PlotLine(ctx, label.c_str(), s.x.data(), s.y.data(), n, style);
        break;
      case report::SeriesKind::kBand:
        if (has_y && has_y2)
          PlotBand(ctx, label.c_str(), s.x.data(), s.y.data(), s.y2.data(), n, style);
        break;
      case report::SeriesKind::kMarkers:
        if (has_y) PlotMarkers(ctx, label.c_str(), s.x.data(), s.y.data(), n, style);
        break;
      case report::SeriesKind::kStems:
        if (has_y) PlotStems(ctx, label.c_str(), s.x.data(), s.y.data(), n, s.ref, style);
        break;
      case report::SeriesKind::kErrorBars:
        if (has_y && has_y2)
          PlotErrorBars(ctx, label.c_str(), s.x.data(), s.y.data(), s.y2.data(), n, style);
        break;
      case report::SeriesKind::kVLines:
        for (const std::string& t : s.tags) tags[k].push_back(t.c_str());
        PlotVLines(ctx, label.c_str(), s.x.data(), n,
                   tags[k].size() == s.x.size() ? tags[k].data() : nullptr, style);
        break;
    }
  }
  EndPlot(ctx);
}

void DrawFigureFrame(PlotContext& ctx, const report::Figure& figure) {
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowPos(ImVec2(0, 0));
  ImGui::SetNextWindowSize(display);
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(0, 0));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowBorderSize, 0.0f);
  ImGui::PushStyleColor(ImGuiCol_WindowBg, IM_COL32(255, 255, 255, 255));
  ImGui::Begin("##figure-frame", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove |
                   ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoScrollWithMouse |
                   ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_NoBringToFrontOnFocus);
  PlotFigure(ctx, "##figure", display, figure);
  ImGui::End();
  ImGui::PopStyleColor();
  ImGui::PopStyleVar(2);
}

std::string PlotName(const char* title, const char* id) {
  if (title && *title) {
    // "ilambda    one-step RMS 0.017  ·  fit 85 %": the figures after a double space change
    // with every fit; the name is what is before them.
    std::string name = title;
    name = name.substr(0, name.find("  "));
    while (!name.empty() && name.back() == ' ') name.pop_back();
    if (!name.empty()) return name;
  }
  std::string name = id ? id : "";
  while (!name.empty() && name.front() == '#') name.erase(0, 1);
  return name.empty() ? "plot" : name;
}

// ---------------------------------------------------------------------------------------------
// 7. BeginPlot / EndPlot

bool BeginPlot(PlotContext& ctx, const char* id, ImVec2 size, const PlotOptions& options) {
  IM_ASSERT(!ctx.in_plot && "BeginPlot() inside another plot");
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  if (size.x <= 0.0f) size.x = avail.x + size.x;
  if (size.y <= 0.0f) size.y = avail.y + size.y;
  size = ImVec2(std::max(size.x, 8.0f), std::max(size.y, 8.0f));

  ImGui::InvisibleButton(id, size,
                         ImGuiButtonFlags_MouseButtonLeft | ImGuiButtonFlags_MouseButtonRight);
  if (!ImGui::IsItemVisible()) return false;
  ctx.current_id = ImGui::GetItemID();
  ctx.hovered = ImGui::IsItemHovered();
  ctx.active = ImGui::IsItemActive();
  ctx.frame_min = ImGui::GetItemRectMin();
  ctx.frame_max = ImGui::GetItemRectMax();
  // The wheel zooms over the plot area and the axes; over the title it scrolls the window, so
  // a long stack of plots can still be scrolled.
  const Region region = RegionAt(ctx, ctx.plots[ctx.current_id], ImGui::GetIO().MousePos);
  if (ctx.hovered && region != Region::kNone && region != Region::kLegend) {
    ImGui::SetItemUsingMouseWheel();
  }
  ctx.options = options;
  ctx.current_name = PlotName(options.title, id);
  ctx.items.clear();
  ctx.in_plot = true;
  return true;
}

void PlotLine(PlotContext& ctx, const char* label, const double* x, const double* y, int n,
              const ItemStyle& style) {
  AddItem(ctx, ItemKind::kLine, label, x, n, style).y = y;
}

void PlotBand(PlotContext& ctx, const char* label, const double* x, const double* lo,
              const double* hi, int n, const ItemStyle& style) {
  Item& item = AddItem(ctx, ItemKind::kBand, label, x, n, style);
  item.y = lo;
  item.y2 = hi;
}

void PlotMarkers(PlotContext& ctx, const char* label, const double* x, const double* y, int n,
                 const ItemStyle& style) {
  AddItem(ctx, ItemKind::kMarkers, label, x, n, style).y = y;
}

void PlotStems(PlotContext& ctx, const char* label, const double* x, const double* y, int n,
               double ref, const ItemStyle& style) {
  Item& item = AddItem(ctx, ItemKind::kStems, label, x, n, style);
  item.y = y;
  item.ref = ref;
}

void PlotErrorBars(PlotContext& ctx, const char* label, const double* x, const double* y,
                   const double* err, int n, const ItemStyle& style) {
  Item& item = AddItem(ctx, ItemKind::kErrorBars, label, x, n, style);
  item.y = y;
  item.y2 = err;
}

void PlotVLines(PlotContext& ctx, const char* label, const double* x, int n,
                const char* const* tags, const ItemStyle& style) {
  AddItem(ctx, ItemKind::kVLines, label, x, n, style).tags = tags;
}

void EndPlot(PlotContext& ctx) {
  IM_ASSERT(ctx.in_plot && "EndPlot() without a BeginPlot() that returned true");
  PlotState& st = CurrentState(ctx);
  LinkedRange& xr = XRange(ctx, st);

  HandleInput(ctx, st, xr);
  FitX(ctx, xr);
  FitY(ctx, st, xr.range);

  const Layout l = ComputeLayout(ctx, st, xr);
  const Transform t{l.plot_min, l.plot_max, xr.range, st.y};
  ImDrawList* dl = ImGui::GetWindowDrawList();
  if (ctx.style.frame_bg >> IM_COL32_A_SHIFT)
    dl->AddRectFilled(ctx.frame_min, ctx.frame_max, ctx.style.frame_bg);
  dl->AddRectFilled(t.min, t.max, ctx.style.plot_bg);
  DrawAxes(ctx, dl, l, t);

  dl->PushClipRect(t.min, t.max, true);
  for (const Item& item : ctx.items) internal::DrawItem(ctx, dl, item, t);
  DrawHover(ctx, st, xr, dl, t);
  if (st.box_active) {
    const ImVec2 m = ImGui::GetIO().MousePos;
    const ImVec2 a(std::min(st.box_start.x, m.x), std::min(st.box_start.y, m.y));
    const ImVec2 b(std::max(st.box_start.x, m.x), std::max(st.box_start.y, m.y));
    dl->AddRectFilled(a, b, (ctx.style.box_zoom & ~IM_COL32_A_MASK) | (40u << IM_COL32_A_SHIFT));
    dl->AddRect(a, b, ctx.style.box_zoom);
  }
  DrawLegend(ctx, st, dl, l, t);
  dl->PopClipRect();

  st.last_plot_min = t.min;
  st.last_plot_max = t.max;
  st.drawn_before = true;
  const ImVec2 size(ctx.frame_max.x - ctx.frame_min.x, ctx.frame_max.y - ctx.frame_min.y);
  if (ctx.record_figures)
    ctx.recorded.push_back({ctx.current_name, ctx.current_id, MakeFigure(ctx, st, xr), size});
  DrawContextMenu(ctx, st, xr);
  ctx.items.clear();
  ctx.in_plot = false;
}

}  // namespace gb::ui::plot
