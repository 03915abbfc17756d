// Item renderers of the plot widget. Each reads the caller's arrays inside the visible index
// window only, and switches to min/max per pixel column when the window holds more samples
// than the plot has pixel columns.
#include <algorithm>
#include <cfloat>
#include <cmath>

#include "ui/widgets/plot_internal.h"

namespace gb::ui::plot::internal {
namespace {

bool Finite(double v) { return std::isfinite(v); }

ImU32 WithAlpha(ImU32 color, float alpha) {
  const auto a = static_cast<unsigned>(((color >> IM_COL32_A_SHIFT) & 0xFF) * alpha + 0.5f);
  return (color & ~IM_COL32_A_MASK) | (std::min(a, 255u) << IM_COL32_A_SHIFT);
}

int PixelColumns(const Transform& t) { return std::max(1, static_cast<int>(t.Width())); }

void Quad(ImDrawList* dl, ImVec2 a, ImVec2 b, ImVec2 c, ImVec2 d, ImU32 color) {
  const ImVec2 uv = ImGui::GetFontTexUvWhitePixel();
  dl->PrimReserve(6, 4);
  dl->PrimQuadUV(a, b, c, d, uv, uv, uv, uv, color);
}

// A finite run of samples is one polyline; a lone sample between missing values is a dot, so
// an isolated observation stays visible.
void FlushRun(ImDrawList* dl, std::vector<ImVec2>* points, ImU32 color, float thickness) {
  if (points->size() >= 2) {
    dl->AddPolyline(points->data(), static_cast<int>(points->size()), color, 0, thickness);
  } else if (points->size() == 1) {
    dl->AddCircleFilled((*points)[0], thickness, color, 8);
  }
  points->clear();
}

void DrawLine(PlotContext& ctx, ImDrawList* dl, const Item& item, const Transform& t) {
  const IndexWindow w = VisibleWindow(item.x, item.n, t.x.min, t.x.max);
  if (w.size() <= 0) return;
  const float thickness = item.line_weight * ctx.style.scale;
  const int columns = PixelColumns(t);
  const double* x = item.x;
  const double* y = item.y;

  if (w.size() <= 2 * columns) {
    // The neighbours outside the view move to the view's edge along their segment, so no vertex
    // lies far away however deep the zoom.
    const double left = t.PixelToX(t.min.x - 2.0f);
    const double right = t.PixelToX(t.max.x + 2.0f);
    std::vector<ImVec2>& points = ctx.points;
    points.clear();
    for (int i = w.begin; i < w.end; ++i) {
      if (!Finite(y[i])) {
        FlushRun(dl, &points, item.color, thickness);
        continue;
      }
      double px = x[i];
      double py = y[i];
      if (px < left && i + 1 < w.end && Finite(y[i + 1]) && x[i + 1] > px) {
        py += (y[i + 1] - py) * (left - px) / (x[i + 1] - px);
        px = left;
      } else if (px > right && i > w.begin && Finite(y[i - 1]) && x[i - 1] < px) {
        py += (y[i - 1] - py) * (px - right) / (px - x[i - 1]);
        px = right;
      }
      points.push_back(t.ToPixel(px, py));
    }
    FlushRun(dl, &points, item.color, thickness);
    return;
  }

  // Min/max per pixel column: a vertical bar for each column's extent, and a segment from each
  // column's last value to the next column's first (unless a value is missing in between).
  DecimateMinMax(x, y, w, t.x.min, t.x.max, columns, &ctx.columns);
  const float half = 0.5f * thickness;
  bool have_prev = false;
  ImVec2 prev;
  for (int c = 0; c < columns; ++c) {
    const ColumnAggregate& col = ctx.columns[c];
    if (!col.any) continue;
    const float cx = t.min.x + static_cast<float>(c) + 0.5f;
    const ImVec2 first(cx, t.YToPixel(col.first));
    if (have_prev && !col.gap_before) dl->AddLine(prev, first, item.color, thickness);
    dl->AddRectFilled(ImVec2(cx - half, t.YToPixel(col.max) - half),
                      ImVec2(cx + half, t.YToPixel(col.min) + half), item.color);
    prev = ImVec2(cx, t.YToPixel(col.last));
    have_prev = true;
  }
}

void DrawBand(PlotContext& ctx, ImDrawList* dl, const Item& item, const Transform& t) {
  const IndexWindow w = VisibleWindow(item.x, item.n, t.x.min, t.x.max);
  if (w.size() < 2) return;
  const ImU32 fill = WithAlpha(item.color, item.fill_alpha);
  const int columns = PixelColumns(t);
  const double* x = item.x;
  const double* lo = item.y;
  const double* hi = item.y2;

  if (w.size() <= 2 * columns) {
    for (int i = w.begin; i + 1 < w.end; ++i) {
      if (!Finite(lo[i]) || !Finite(hi[i]) || !Finite(lo[i + 1]) || !Finite(hi[i + 1])) continue;
      Quad(dl, t.ToPixel(x[i], lo[i]), t.ToPixel(x[i], hi[i]), t.ToPixel(x[i + 1], hi[i + 1]),
           t.ToPixel(x[i + 1], lo[i + 1]), fill);
    }
    return;
  }

  DecimateMinMax(x, lo, w, t.x.min, t.x.max, columns, &ctx.columns);
  DecimateMinMax(x, hi, w, t.x.min, t.x.max, columns, &ctx.columns2);
  int prev = -1;
  for (int c = 0; c < columns; ++c) {
    const ColumnAggregate& l = ctx.columns[c];
    const ColumnAggregate& h = ctx.columns2[c];
    if (!l.any || !h.any) continue;
    if (prev >= 0 && !l.gap_before && !h.gap_before) {
      const float x0 = t.min.x + static_cast<float>(prev) + 0.5f;
      const float x1 = t.min.x + static_cast<float>(c) + 0.5f;
      const ColumnAggregate& pl = ctx.columns[prev];
      const ColumnAggregate& ph = ctx.columns2[prev];
      Quad(dl, ImVec2(x0, t.YToPixel(pl.min)), ImVec2(x0, t.YToPixel(ph.max)),
           ImVec2(x1, t.YToPixel(h.max)), ImVec2(x1, t.YToPixel(l.min)), fill);
    }
    prev = c;
  }
}

// Markers that would land on an already-marked cell of a grid about a marker wide are skipped:
// the picture is the same and a dense scatter costs a bounded number of circles.
void DrawMarkers(PlotContext& ctx, ImDrawList* dl, const Item& item, const Transform& t) {
  const IndexWindow w = VisibleWindow(item.x, item.n, t.x.min, t.x.max);
  if (w.size() <= 0) return;
  const float r = item.marker_radius * ctx.style.scale;
  const float cell = std::max(1.0f, std::floor(0.75f * r));
  const int gw = static_cast<int>(t.Width() / cell) + 1;
  const int gh = static_cast<int>(t.Height() / cell) + 1;
  ctx.occupied.assign(static_cast<std::size_t>(gw) * gh, 0);
  for (int i = w.begin; i < w.end; ++i) {
    if (!Finite(item.y[i])) continue;
    const ImVec2 p = t.ToPixel(item.x[i], item.y[i]);
    if (p.x < t.min.x - r || p.x > t.max.x + r || p.y < t.min.y - r || p.y > t.max.y + r) continue;
    const int cx = std::clamp(static_cast<int>((p.x - t.min.x) / cell), 0, gw - 1);
    const int cy = std::clamp(static_cast<int>((p.y - t.min.y) / cell), 0, gh - 1);
    unsigned char& seen = ctx.occupied[static_cast<std::size_t>(cy) * gw + cx];
    if (seen) continue;
    seen = 1;
    dl->AddCircleFilled(p, r, item.color, 12);
  }
}

void DrawStems(PlotContext& ctx, ImDrawList* dl, const Item& item, const Transform& t) {
  const IndexWindow w = VisibleWindow(item.x, item.n, t.x.min, t.x.max);
  if (w.size() <= 0) return;
  const float thickness = item.line_weight * ctx.style.scale;
  const float r = item.marker_radius * ctx.style.scale;
  const float base = t.YToPixel(item.ref);
  const int columns = PixelColumns(t);
  if (w.size() <= columns) {
    for (int i = w.begin; i < w.end; ++i) {
      if (!Finite(item.y[i])) continue;
      const ImVec2 top = t.ToPixel(item.x[i], item.y[i]);
      dl->AddLine(ImVec2(top.x, base), top, item.color, thickness);
      dl->AddCircleFilled(top, r, item.color, 12);
    }
    return;
  }
  DecimateMinMax(item.x, item.y, w, t.x.min, t.x.max, columns, &ctx.columns);
  const float half = 0.5f * thickness;
  for (int c = 0; c < columns; ++c) {
    const ColumnAggregate& col = ctx.columns[c];
    if (!col.any) continue;
    const float cx = t.min.x + static_cast<float>(c) + 0.5f;
    const float y0 = std::min(base, t.YToPixel(col.max));
    const float y1 = std::max(base, t.YToPixel(col.min));
    dl->AddRectFilled(ImVec2(cx - half, y0), ImVec2(cx + half, y1), item.color);
  }
}

void DrawErrorBars(PlotContext& ctx, ImDrawList* dl, const Item& item, const Transform& t) {
  const IndexWindow w = VisibleWindow(item.x, item.n, t.x.min, t.x.max);
  const float thickness = item.line_weight * ctx.style.scale;
  const float r = item.marker_radius * ctx.style.scale;
  const float cap = 1.6f * r;
  for (int i = w.begin; i < w.end; ++i) {
    const double y = item.y[i];
    if (!Finite(y)) continue;
    const ImVec2 p = t.ToPixel(item.x[i], y);
    const double err = item.y2[i];
    if (Finite(err)) {
      const float top = t.YToPixel(y + std::abs(err));
      const float bottom = t.YToPixel(y - std::abs(err));
      dl->AddLine(ImVec2(p.x, top), ImVec2(p.x, bottom), item.color, thickness);
      dl->AddLine(ImVec2(p.x - cap, top), ImVec2(p.x + cap, top), item.color, thickness);
      dl->AddLine(ImVec2(p.x - cap, bottom), ImVec2(p.x + cap, bottom), item.color, thickness);
    }
    dl->AddCircleFilled(p, r, item.color, 12);
  }
}

// The lines first, then the tags over them; a tag is drawn only where it clears the one before.
void DrawVLines(PlotContext& ctx, ImDrawList* dl, const Item& item, const Transform& t) {
  const IndexWindow w = VisibleWindow(item.x, item.n, t.x.min, t.x.max);
  const float thickness = item.line_weight * ctx.style.scale;
  const float pad = 2.0f * ctx.style.scale;
  for (int i = w.begin; i < w.end; ++i) {
    if (!Finite(item.x[i])) continue;
    const float px = std::round(t.XToPixel(item.x[i])) + 0.5f;
    dl->AddLine(ImVec2(px, t.min.y), ImVec2(px, t.max.y), item.color, thickness);
  }
  if (!item.tags) return;
  float tag_end = -FLT_MAX;
  for (int i = w.begin; i < w.end; ++i) {
    if (!Finite(item.x[i]) || !item.tags[i] || !*item.tags[i]) continue;
    const float px = std::round(t.XToPixel(item.x[i])) + 0.5f;
    const ImVec2 size = ImGui::CalcTextSize(item.tags[i]);
    const ImVec2 at(px + thickness + pad, t.min.y + pad);
    if (at.x < tag_end) continue;
    dl->AddRectFilled(ImVec2(at.x - pad, at.y), ImVec2(at.x + size.x + pad, at.y + size.y),
                      ctx.style.label_bg);
    dl->AddText(at, item.color, item.tags[i]);
    tag_end = at.x + size.x + 2.0f * pad;
  }
}

}  // namespace

void DrawItem(PlotContext& ctx, ImDrawList* dl, const Item& item, const Transform& t) {
  if (item.hidden || item.n <= 0) return;
  switch (item.kind) {
    case ItemKind::kLine:
      DrawLine(ctx, dl, item, t);
      break;
    case ItemKind::kBand:
      DrawBand(ctx, dl, item, t);
      break;
    case ItemKind::kMarkers:
      DrawMarkers(ctx, dl, item, t);
      break;
    case ItemKind::kStems:
      DrawStems(ctx, dl, item, t);
      break;
    case ItemKind::kErrorBars:
      DrawErrorBars(ctx, dl, item, t);
      break;
    case ItemKind::kVLines:
      DrawVLines(ctx, dl, item, t);
      break;
  }
}

bool ItemXExtent(const Item& item, double* lo, double* hi) {
  if (item.n <= 0 || item.kind == ItemKind::kVLines) return false;
  *lo = item.x[0];
  *hi = item.x[item.n - 1];
  return Finite(*lo) && Finite(*hi);
}

bool ItemYExtent(const Item& item, Range view, double* lo, double* hi) {
  const IndexWindow w = VisibleWindow(item.x, item.n, view.min, view.max);
  if (w.size() <= 0) return false;
  bool any = false;
  auto take = [&](double a, double b) {
    *lo = any ? std::min(*lo, a) : a;
    *hi = any ? std::max(*hi, b) : b;
    any = true;
  };
  double a = 0, b = 0;
  switch (item.kind) {
    case ItemKind::kLine:
    case ItemKind::kMarkers:
      if (FiniteMinMax(item.y + w.begin, w.size(), &a, &b)) take(a, b);
      break;
    case ItemKind::kBand:
      if (FiniteMinMax(item.y + w.begin, w.size(), &a, &b)) take(a, b);
      if (FiniteMinMax(item.y2 + w.begin, w.size(), &a, &b)) take(a, b);
      break;
    case ItemKind::kStems:
      if (FiniteMinMax(item.y + w.begin, w.size(), &a, &b)) {
        take(a, b);
        take(item.ref, item.ref);
      }
      break;
    case ItemKind::kErrorBars:
      for (int i = w.begin; i < w.end; ++i) {
        const double y = item.y[i];
        if (!Finite(y)) continue;
        const double e = Finite(item.y2[i]) ? std::abs(item.y2[i]) : 0.0;
        take(y - e, y + e);
      }
      break;
    case ItemKind::kVLines:
      break;  // across whatever y range the other items set
  }
  return any;
}

int NearestIndex(const Item& item, double x) {
  if (item.n <= 0) return -1;
  const double* it = std::lower_bound(item.x, item.x + item.n, x);
  int i = static_cast<int>(it - item.x);
  if (i >= item.n) return item.n - 1;
  if (i > 0 && x - item.x[i - 1] < item.x[i] - x) --i;
  return i;
}

std::optional<double> ReadoutX(const std::vector<Item>& items, double x) {
  const Item* chosen = nullptr;
  for (const Item& item : items) {
    if (item.hidden || item.kind == ItemKind::kVLines || NearestIndex(item, x) < 0) continue;
    if (!chosen || (chosen->kind == ItemKind::kBand && item.kind != ItemKind::kBand))
      chosen = &item;
  }
  if (!chosen) return std::nullopt;
  return chosen->x[NearestIndex(*chosen, x)];
}

std::string ItemValueText(const Item& item, int i) {
  switch (item.kind) {
    case ItemKind::kBand:
      return FormatValue(item.y[i]) + " \xE2\x80\xA6 " + FormatValue(item.y2[i]);
    case ItemKind::kErrorBars:
      return FormatValue(item.y[i]) + " \xC2\xB1 " + FormatValue(item.y2[i]);
    case ItemKind::kVLines:
      return item.tags && item.tags[i] ? item.tags[i] : FormatValue(item.x[i]);
    default:
      return FormatValue(item.y[i]);
  }
}

void DrawSwatch(ImDrawList* dl, const Item& item, ImVec2 min, ImVec2 max, float scale,
                float alpha) {
  const ImU32 color = WithAlpha(item.color, alpha);
  const ImVec2 c((min.x + max.x) * 0.5f, (min.y + max.y) * 0.5f);
  const float r = std::min(item.marker_radius * scale + 0.5f, 0.5f * (max.y - min.y));
  switch (item.kind) {
    case ItemKind::kLine:
      dl->AddLine(ImVec2(min.x, c.y), ImVec2(max.x, c.y), color, 2.0f * scale);
      break;
    case ItemKind::kBand:
      dl->AddRectFilled(min, max, WithAlpha(item.color, alpha * std::max(item.fill_alpha, 0.35f)));
      break;
    case ItemKind::kMarkers:
      dl->AddCircleFilled(c, r, color, 12);
      break;
    case ItemKind::kStems:
    case ItemKind::kErrorBars:
      dl->AddLine(ImVec2(c.x, min.y), ImVec2(c.x, max.y), color, 1.5f * scale);
      dl->AddCircleFilled(c, r, color, 12);
      break;
    case ItemKind::kVLines:
      dl->AddLine(ImVec2(c.x, min.y - 2.0f * scale), ImVec2(c.x, max.y + 2.0f * scale), color,
                  1.5f * scale);
      break;
  }
}

}  // namespace gb::ui::plot::internal
