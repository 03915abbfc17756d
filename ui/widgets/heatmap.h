// A labelled heat map of a square matrix (e.g. the correlation of the estimates), drawn with
// ImGui draw lists: one coloured cell per entry with its value printed in it, the labels along
// the left and the top, and a colour bar. Diverging palette: blue for `min`, white for the
// middle, red for `max` (ColorBrewer's RdBu, which reads in grey and for red-green blindness).
//
//   plot::HeatMapOptions opt;                        // -1 .. 1, "%.2f"
//   plot::HeatMap("##corr", names, matrix.data(), opt);   // matrix row-major, n x n
//
// Data: `values` is read during the call only (row-major, names.size() squared entries); NaN
// is drawn as an empty cell with "–". Hovering a cell shows both labels and the value. The
// widget keeps no state.
#pragma once

#include <string>
#include <vector>

#include <imgui.h>

namespace gb::ui::plot {

struct HeatMapOptions {
  double min = -1.0;  // the ends of the colour scale; values outside are clamped
  double max = 1.0;
  const char* format = "%.2f";  // cell text (printf)
  float scale = 1.0f;           // DPI scale: multiplies the sizes below
  float min_cell = 38.0f;       // cell side, pixels at scale 1 (grows to fit labels and values)
  // The height the map may take (0: any); cells shrink to fit it, but not below the width of
  // the values (column labels wider than a cell are then clipped; the tooltip names them).
  float max_height = 0.0f;
  bool color_bar = true;
  ImFont* label_font = nullptr;  // nullptr: the current font
};

// The diverging colour of `t` in [-1, 1] (clamped): -1 dark blue, 0 near-white, 1 dark red.
ImU32 DivergingColor(double t);
// Dark text on light cells, white text on dark ones.
ImU32 TextColorOn(ImU32 background);

void HeatMap(const char* id, const std::vector<std::string>& labels, const double* values,
             const HeatMapOptions& options = {});

}  // namespace gb::ui::plot
