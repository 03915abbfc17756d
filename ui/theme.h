// Look of the workbench: fonts (DejaVu from the Debian package fonts-dejavu-core), a light
// colour theme, and the plot widget's style. Both greybench and greybench-snapshot call
// SetUpWorkbench() after ImGui::CreateContext() and before the renderer builds the font atlas,
// so the window and the snapshots look the same.
#pragma once

#include "ui/state/app_state.h"

namespace gb::ui {

inline constexpr float kBaseFontSize = 15.0f;  // pixels at DPI scale 1
inline constexpr const char* kFontDir = "/usr/share/fonts/truetype/dejavu/";

// Loads the fonts, applies the theme scaled by `scale` (the window's content scale; 1 for
// snapshots), and sets the plot style. A missing font file falls back to ImGui's built-in
// font with a warning in state.messages.
void SetUpWorkbench(AppState& state, float scale);

}  // namespace gb::ui
