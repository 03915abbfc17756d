// What the Predictions and Residuals views share (both draw AppState::analysis): the lines above
// their plots that say at which parameter values and delays the analysis is, the dataset
// selector, and the state of the job (computing, cancelled, failed).
#pragma once

#include <string>

#include "ui/state/app_state.h"

namespace gb::ui {

// Draws the header and returns the selected dataset's analysis, or nullptr when there is
// nothing to plot (a notice saying why has been drawn then). `view_controls` (may be null)
// draws the view's own controls on the toolbar line, after the dataset selector, and returns
// whether it drew any; it is called only when a result exists.
const DatasetAnalysis* DrawAnalysisHeader(AppState& state, bool (*view_controls)(AppState&));

// "delay 6 samples" and the like.
std::string SamplesText(int n);

// While a slider is dragged: output `output` of dataset `dataset` in the analysis of before the
// drag (its curves drawn faintly), or null (no drag, or its record had another length).
const OutputAnalysis* GhostOutput(const AppState& state, std::size_t dataset, std::size_t output,
                                  std::size_t rows);
// `color` faint, for a ghost's curve.
inline ImU32 GhostColor(ImU32 color) { return (color & ~IM_COL32_A_MASK) | IM_COL32(0, 0, 0, 80); }
inline constexpr const char* kGhostLabel = "before the slider";

// The residual verdict in a word ("White and normal", "White, not normal", "Not white") and
// its colour (green, amber, red), as the Residuals view and the sliders' table show it.
const char* VerdictWord(const diagnose::ResidualDiagnostics& st);
ImU32 VerdictColor(const diagnose::ResidualDiagnostics& st);

// Colours shared by both views.
inline constexpr ImU32 kPredictionColor = IM_COL32(31, 119, 180, 255);
inline constexpr ImU32 kAheadColor = IM_COL32(255, 127, 14, 255);
inline constexpr ImU32 kSimulationColor = IM_COL32(44, 160, 44, 255);
inline constexpr ImU32 kSmoothedColor = IM_COL32(148, 103, 189, 255);
inline constexpr ImU32 kReferenceColor = IM_COL32(214, 39, 40, 255);
inline constexpr ImU32 kBandColor = IM_COL32(120, 130, 150, 255);
inline constexpr ImU32 kGoodColor = IM_COL32(34, 139, 34, 255);

}  // namespace gb::ui
