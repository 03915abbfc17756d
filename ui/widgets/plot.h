// greybench's plot widget, drawn with ImGui draw lists (no ImPlot).
//
//   plot::PlotOptions opt;
//   opt.title = "ilambda";
//   opt.x_label = "t";
//   opt.linked_x = &state.data_view.x_range;      // plots sharing it pan and zoom together
//   if (plot::BeginPlot(ctx, "##ilambda", ImVec2(-1, 200), opt)) {
//     plot::PlotBand(ctx, "±2 sd", t, lo, hi, n);
//     plot::PlotLine(ctx, "predicted", t, yhat, n);
//     plot::PlotMarkers(ctx, "measured", t, y, n);
//     plot::EndPlot(ctx);                           // only when BeginPlot returned true
//   }
//
// Data: the Plot* functions keep pointers to the caller's arrays until EndPlot() of the same
// frame, which draws everything; nothing is copied. x must be ascending (time series); y may
// hold NaN (a missing value: lines break there). Each frame draws at most about two vertices
// per pixel column and series: min/max per pixel column when the view holds more samples than
// pixels, so 1e6 points stay interactive.
//
// Mouse: wheel zooms x about the cursor (over the y axis: zooms y; over the title it scrolls
// the window as usual); left drag pans; right drag zooms to a box; double-click fits the data;
// clicking a legend entry hides or shows the item. A right click without a drag opens the
// plot's context menu: "Save image as SVG…" and "Save image as PNG…" leave an ExportRequest in
// the context for the application to finish (it asks for a file name; the PNG is the plot drawn
// alone at the size the menu's fields give, by default its size on screen); "Copy data as CSV"
// puts the plot's data on the clipboard (report::FigureToCsv).
//
// Export: what a plot shows becomes a report::Figure (core/report/figure.h) at EndPlot, while
// the items' arrays are still valid: the shown items (not those hidden in the legend), their
// samples inside the x range, the ranges, the titles and the colours.
// Hovering shows a crosshair on every linked plot and the nearest sample of each item.
// y follows the data in view (auto-fit) until the user zooms or pans y.
//
// State: everything that persists from frame to frame (ranges, drags, hidden items) lives in a
// PlotContext owned by the application (AppState), keyed by the plot's ImGui id.
#pragma once

#include <climits>
#include <cmath>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <imgui.h>

#include "core/report/figure.h"
#include "ui/widgets/plot_axis.h"
#include "ui/widgets/plot_decimate.h"

namespace gb::ui::plot {

// An x range shared by several plots. Owned by the caller; must outlive the plots using it.
struct LinkedRange {
  static constexpr int kNoFit = INT_MAX;
  Range range;
  // A fit was asked for in this frame; the plots drawn in the next frame fit the range to the
  // union of their data. The initial value asks for a fit at the first use.
  int fit_request_frame = -1;
  int fit_frame = -1;  // [internal] frame in which the union is being built
  bool fit_has_data = false;
  // [internal] the x under the mouse in a plot sharing this range, and in which frame.
  double hover_x = 0.0;
  int hover_frame = -1;
  // [internal] the widest left gutter of the plots sharing this range, so their plot areas
  // line up: `gutter` from the previous frame, `gutter_next` being gathered in this one.
  float gutter = 0.0f, gutter_next = 0.0f;
  int gutter_frame = -1;

  // Refit at the next frame (e.g. after new data arrived).
  void RequestFit() { fit_request_frame = -1; }
};

enum class Legend { kAuto, kShow, kHide };  // kAuto: shown when the plot has two or more items
// Where in the plot area the legend sits (choose the corner the data leave free).
enum class LegendCorner { kTopRight, kTopLeft, kBottomRight, kBottomLeft };

struct PlotOptions {
  const char* title = nullptr;    // above the plot area
  const char* x_label = nullptr;  // axis names; units are printed as "t [s]"
  const char* x_unit = nullptr;
  const char* y_label = nullptr;
  const char* y_unit = nullptr;
  LinkedRange* linked_x = nullptr;  // nullptr: the plot keeps its own x range
  Legend legend = Legend::kAuto;
  LegendCorner legend_corner = LegendCorner::kTopRight;
  bool x_tick_labels = true;
  bool x_title = true;  // "x_label [x_unit]" under the axis; the hover readout names x either way
  // Fraction of the data's x span added on both sides when x is fitted (0: the data reach the
  // edges, as a time series should; e.g. 0.03 for points that should not sit on the frame).
  // With a linked range, each plot pads its own extent before the union is taken.
  double x_padding = 0.0;
};

struct ItemStyle {
  ImU32 color = 0;             // 0: the next colour of the palette
  float line_weight = 0.0f;    // pixels at scale 1; 0: PlotStyle::line_weight
  float marker_radius = 0.0f;  // pixels at scale 1; 0: PlotStyle::marker_radius
  float fill_alpha = 0.22f;    // bands
};

struct PlotStyle {
  float scale = 1.0f;  // DPI scale: multiplies every size below
  float line_weight = 1.5f;
  float marker_radius = 2.5f;
  ImU32 frame_bg = IM_COL32(255, 255, 255, 0);
  ImU32 plot_bg = IM_COL32(255, 255, 255, 255);
  ImU32 border = IM_COL32(196, 200, 206, 255);
  ImU32 grid = IM_COL32(232, 234, 238, 255);
  ImU32 tick_text = IM_COL32(88, 94, 104, 255);
  ImU32 title_text = IM_COL32(30, 34, 40, 255);
  ImU32 crosshair = IM_COL32(120, 126, 136, 150);
  ImU32 box_zoom = IM_COL32(47, 111, 219, 255);
  // Behind text drawn over the data (the legend, an axis' exponent, a vertical line's tag) and
  // the ring of a hover marker: the plot's background, mostly opaque.
  ImU32 label_bg = IM_COL32(255, 255, 255, 220);
  // Neutral marks that are not a palette colour: measured data, a model's simulated response.
  ImU32 ink = IM_COL32(60, 64, 72, 255);
  ImU32 strong_ink = IM_COL32(20, 24, 30, 255);
  ImFont* title_font = nullptr;  // nullptr: the current font
  std::vector<ImU32> palette = {IM_COL32(31, 119, 180, 255),  IM_COL32(255, 127, 14, 255),
                                IM_COL32(44, 160, 44, 255),   IM_COL32(214, 39, 40, 255),
                                IM_COL32(148, 103, 189, 255), IM_COL32(140, 86, 75, 255),
                                IM_COL32(227, 119, 194, 255), IM_COL32(127, 127, 127, 255),
                                IM_COL32(188, 189, 34, 255),  IM_COL32(23, 190, 207, 255)};
};

// Persistent state of one plot (by ImGui id).
struct PlotState {
  LinkedRange own_x;  // used when the options link no range
  Range y;
  bool y_auto = true;
  int drag_region = 0;  // where the left button went down (plot, an axis, the legend)
  bool box_active = false;
  ImVec2 box_start;
  ImVec2 last_plot_min, last_plot_max;  // plot area of the previous frame (input uses it)
  ImVec2 last_legend_min, last_legend_max;
  std::vector<ImGuiID> legend_ids;  // entries of the previous frame's legend, in order
  std::vector<ImVec2> legend_entry_min, legend_entry_max;  // ... and where each was drawn
  std::vector<ImGuiID> hidden;  // items the user switched off in the legend
  bool drawn_before = false;
  bool right_down = false;  // the right button went down over the plot ...
  ImVec2 right_start;       // ... here: released near it, it opens the context menu
  bool open_menu = false;
  int png_width = 0, png_height = 0;  // the menu's PNG size (the plot's, when it opens)
};

// An export the context menu asked for, for the application to finish.
struct ExportRequest {
  enum class Kind { kSvg, kPng };
  Kind kind = Kind::kSvg;
  std::string name;  // the plot's name (PlotName), for a proposed file name
  ImGuiID id = 0;
  report::Figure figure;              // the plot as drawn
  ImVec2 size;                        // the plot's frame in pixels (the SVG's size)
  int png_width = 0, png_height = 0;  // kPng: the size asked for in the menu
};

// The PNG sizes the menu accepts, in pixels.
inline constexpr int kMinPngSize = 64;
inline constexpr int kMaxPngSize = 8192;

// One plot's figure, recorded when PlotContext::record_figures is on.
struct RecordedFigure {
  std::string name;  // PlotName
  ImGuiID id = 0;
  report::Figure figure;
  ImVec2 size;  // the frame in pixels
};

enum class ItemKind { kLine, kBand, kMarkers, kStems, kErrorBars, kVLines };

// One item of the plot being built: pointers into the caller's arrays, valid until EndPlot().
struct Item {
  ItemKind kind = ItemKind::kLine;
  std::string label;  // the visible part (before "##")
  ImGuiID id = 0;
  const double* x = nullptr;
  const double* y = nullptr;   // line, markers, stems, error bars: the value; band: lower
  const double* y2 = nullptr;  // band: upper; error bars: the half-width
  int n = 0;
  double ref = 0.0;                   // stems: the baseline
  const char* const* tags = nullptr;  // vertical lines: a tag per line (may be null)
  ImU32 color = 0;
  float line_weight = 0.0f, marker_radius = 0.0f, fill_alpha = 0.0f;
  bool hidden = false;
};

class PlotContext {
 public:
  PlotStyle style;
  // Set by the context menu; the application takes it (and resets it) to ask for a file.
  std::optional<ExportRequest> export_request;
  // greybench-snapshot --plot: every plot drawn appends its figure to `recorded`.
  bool record_figures = false;
  std::vector<RecordedFigure> recorded;

  // Internal to the widget (plot.cpp) from here on.
  std::unordered_map<ImGuiID, PlotState> plots;
  bool in_plot = false;
  ImGuiID current_id = 0;
  std::string current_name;
  PlotOptions options;
  ImVec2 frame_min, frame_max;
  bool hovered = false, active = false;
  std::vector<Item> items;
  // Per-frame scratch buffers, reused so drawing allocates nothing in steady state.
  std::vector<ColumnAggregate> columns, columns2;
  std::vector<ImVec2> points;
  std::vector<unsigned char> occupied;
};

// Reserves the plot's rectangle (size: <= 0 means the available width/height minus |size|)
// and handles nothing yet. Returns false when the plot is clipped; then do not call EndPlot().
bool BeginPlot(PlotContext& ctx, const char* id, ImVec2 size, const PlotOptions& options = {});

void PlotLine(PlotContext& ctx, const char* label, const double* x, const double* y, int n,
              const ItemStyle& style = {});
// A filled band between lo and hi (e.g. a prediction ± 2 standard deviations).
void PlotBand(PlotContext& ctx, const char* label, const double* x, const double* lo,
              const double* hi, int n, const ItemStyle& style = {});
void PlotMarkers(PlotContext& ctx, const char* label, const double* x, const double* y, int n,
                 const ItemStyle& style = {});
// Vertical lines from `ref` to y with a marker at y (e.g. an autocorrelation function).
void PlotStems(PlotContext& ctx, const char* label, const double* x, const double* y, int n,
               double ref = 0.0, const ItemStyle& style = {});
// y ± err with caps (e.g. estimates with their standard errors).
void PlotErrorBars(PlotContext& ctx, const char* label, const double* x, const double* y,
                   const double* err, int n, const ItemStyle& style = {});

// Vertical lines across the plot area at each x (events on a time axis, e.g. alarms), each with
// its tag beside its top when `tags` is given (tags[i] for x[i]; a tag that would overlap the one
// before it is left out). They take no part in fitting the ranges nor in the hover readout.
void PlotVLines(PlotContext& ctx, const char* label, const double* x, int n,
                const char* const* tags = nullptr, const ItemStyle& style = {});

// Handles the mouse, fits the ranges, and draws the plot and its items.
void EndPlot(PlotContext& ctx);

// Draws a figure (e.g. one recorded with record_figures) as a plot of its own, at its ranges,
// with its items, colours and titles (greybench-snapshot --plot NAME --out F.png). The mouse
// works as on any plot.
void PlotFigure(PlotContext& ctx, const char* id, ImVec2 size, const report::Figure& figure);

// The figure alone in a frame of its own, filling the display on a white ground: between
// ImGui::NewFrame() and ImGui::Render() of a frame drawn for a PNG of one plot (greybench-snapshot
// --plot, the menu's Save image as PNG).
void DrawFigureFrame(PlotContext& ctx, const report::Figure& figure);

// A plot's name for exports and greybench-snapshot --plot: its title up to its first double
// space (views put the fit's figures after one: "ilambda    one-step RMS 0.017  ·  fit 85 %"),
// or else its ImGui id without the leading "##".
std::string PlotName(const char* title, const char* id);

}  // namespace gb::ui::plot
