// A plot as data (a Figure), written as a standalone SVG 1.1 document or as CSV. Plain text
// generation: no ImGui, no GL. The workbench copies a plot's items into a Figure at EndPlot (its
// context menu, greybench-snapshot --plot); the CLI's report builds its figures directly.
//
//   report::Figure f;
//   f.title = "y"; f.x_label = "t"; f.x_unit = "s"; f.x = {0, 10}; f.y = {-1, 1};
//   report::FigureSeries& s = f.series.emplace_back();
//   s.kind = report::SeriesKind::kLine; s.label = "predicted"; s.x = t; s.y = yhat;
//   std::string svg = report::FigureToSvg(f, {640, 360});
//
// SVG: every item is drawn from its values, not from a screenshot. The items are in the group
//   <g id="plot-data" gb:plot-area="LEFT TOP RIGHT BOTTOM" gb:x-range="X0 X1" gb:y-range="Y0 Y1">
// (gb: is the namespace https://greybench.org/figure) in pixels of the document, each coordinate
// written in the shortest decimal form that reads back as the same double, so the values come
// back by the inverse of the plot's mapping:
//   x = X0 + (px - LEFT) / (RIGHT - LEFT) * (X1 - X0)
//   y = Y0 + (BOTTOM - py) / (BOTTOM - TOP) * (Y1 - Y0)
// to about 1e-15 of the axis' span (far below the precision the plot prints). Pixel coordinates,
// not data coordinates under a transform: strokes and dots then keep their width in every
// renderer (non-scaling strokes are not SVG 1.1). A value more than 1e6 pixels outside the plot
// area is written at that distance (the clip path hides it; the CSV holds it).
// Each item is a <g class="series KIND"> with a <title> (its label) holding
//   line        one <polyline> per run of finite values (a NaN breaks the line)
//   band        one <polygon> per run where lower and upper are finite: upper left to right,
//               then lower right to left
//   markers     a <path> of zero-length segments "M x,y h0" drawn with round caps (dots)
//   stems       a <path> "M x,ref V y" per finite value, and the dots at y
//   error bars  a <path> "M x,y-e V y+e" per finite value, and the dots at y
//   vertical lines  a <path> "M x,y0 V y1" per line across the plot, tags as <text> beside them
// Text: the title, tick labels, axis titles "label [unit]", the shared power of ten ("×1e-5"), the
// legend and the tags. What lies outside the plot area is clipped by a <clipPath>.
//
// CSV: one merged x column (the x axis' title as its header) and a column per value an item
// shows: line, markers, stems "LABEL"; band "LABEL lower", "LABEL upper"; error bars "LABEL",
// "LABEL error" (the half-width); vertical lines "LABEL" holding the line's tag (or "|" without
// tags). A row per distinct x of all items, ascending (an item with an x twice gets two rows);
// a cell is empty where an item has no sample at that x or its value is missing (NaN). Numbers
// in the shortest form that reads back as the same double. Only the samples inside the x range.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/report/axis.h"

namespace gb::report {

enum class SeriesKind { kLine, kBand, kMarkers, kStems, kErrorBars, kVLines };

struct Rgba {
  std::uint8_t r = 0, g = 0, b = 0, a = 255;
};

// One item of a figure, with its own copy of the values (x ascending). y (and y2 where the kind
// has one) as long as x; the SVG leaves out a series whose arrays are not.
struct FigureSeries {
  SeriesKind kind = SeriesKind::kLine;
  std::string label;  // "" : no legend entry, column "series N"
  Rgba color;
  std::vector<double> x;
  std::vector<double> y;          // line, markers, stems, error bars: the value; band: lower
  std::vector<double> y2;         // band: upper; error bars: the half-width; else empty
  double ref = 0.0;               // stems: the baseline
  std::vector<std::string> tags;  // vertical lines: a tag per line, or empty
  float line_weight = 1.5f;       // pixels
  float marker_radius = 2.5f;     // pixels
  float fill_alpha = 0.22f;       // bands
};

struct Figure {
  std::string title, x_label, x_unit, y_label, y_unit;
  Range x, y;          // what the plot shows
  bool legend = true;  // a legend of the series that have labels
  std::vector<FigureSeries> series;
};

struct SvgSize {
  int width = 640;   // pixels, >= 64
  int height = 400;  // pixels, >= 64
};

// The samples a figure shows inside its x range: each series keeps the samples with x in
// f.x, and lines and bands also the one sample either side (so the drawn line reaches the
// frame; the SVG clips it). Series with no sample left stay, empty.
Figure ClipToXRange(Figure f);

// The figure as a standalone SVG 1.1 document (see above). Ranges that are empty, inverted or
// not finite (or whose span is not) are drawn as [0, 1].
std::string FigureToSvg(const Figure& f, SvgSize size);

// The figure's samples inside its x range as CSV (see above), ending with a newline.
std::string FigureToCsv(const Figure& f);

// Text for XML content and attribute values: & < > " ' escaped, bytes < 0x20 other than tab
// and newline dropped (XML 1.0 cannot hold them).
std::string XmlEscape(const std::string& text);

// A double in the shortest decimal form that reads back as the same double ("0.1", "1e-05").
std::string ShortestDouble(double v);

}  // namespace gb::report
