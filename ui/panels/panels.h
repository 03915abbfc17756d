// The views of the workbench (user guide §6), one free function per view, each in its own
// file ui/panels/<view>.cpp. A panel draws into the current ImGui window (the area right of the
// sidebar, below the view's title), reads AppState and records edits in it; it keeps no data of
// its own between frames and never blocks.
#pragma once

#include "ui/state/app_state.h"

namespace gb::ui {

void DrawDataPanel(AppState& state);             // data.cpp
void DrawDiagramPanel(AppState& state);          // diagram.cpp
void DrawEquationsPanel(AppState& state);        // equations.cpp
void DrawEstimatePanel(AppState& state);         // estimate.cpp
void DrawPredictionsPanel(AppState& state);      // predictions.cpp
void DrawResidualsPanel(AppState& state);        // residuals.cpp
void DrawParametersPanel(AppState& state);       // parameters.cpp
void DrawOperatingPointsPanel(AppState& state);  // operating_points.cpp
void DrawLivePanel(AppState& state);             // live.cpp
void DrawDesignPanel(AppState& state);           // design.cpp

// The sliders beside the Data, Predictions, Residuals and Parameters views (sliders.cpp): whether
// the current view has them, and the panel.
bool SlidersPanelShown(const AppState& state);
void DrawSlidersPanel(AppState& state);

// Draws the panel of `view`.
void DrawPanel(AppState& state, View view);

}  // namespace gb::ui
