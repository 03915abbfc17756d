// The views of the workbench (CONTRACT section 6), one free function per view, each in its own
// file ui/panel_<view>.cpp. A panel draws into the current ImGui window (the area right of the
// sidebar, below the view's title), reads AppState and records edits in it; it keeps no data of
// its own between frames and never blocks.
#pragma once

#include "ui/state/app_state.h"

namespace gb::ui {

void DrawDataPanel(AppState& state);             // panel_data.cpp
void DrawDiagramPanel(AppState& state);          // panel_diagram.cpp
void DrawEquationsPanel(AppState& state);        // panel_equations.cpp
void DrawEstimatePanel(AppState& state);         // panel_estimate.cpp
void DrawPredictionsPanel(AppState& state);      // panel_predictions.cpp
void DrawResidualsPanel(AppState& state);        // panel_residuals.cpp
void DrawParametersPanel(AppState& state);       // panel_parameters.cpp
void DrawOperatingPointsPanel(AppState& state);  // panel_operating_points.cpp

// Draws the panel of `view`.
void DrawPanel(AppState& state, View view);

}  // namespace gb::ui
