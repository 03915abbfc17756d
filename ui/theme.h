// Look of the workbench: fonts (DejaVu from the Debian package fonts-dejavu-core), the colour
// theme (state.shell.theme: light, dark, or high-contrast light for projectors), and the plot
// widget's style. Both greybench and greybench-snapshot call
// SetUpWorkbench() after ImGui::CreateContext() and before the renderer builds the font atlas,
// so the window and the snapshots look the same.
#pragma once

#include <array>
#include <optional>
#include <string_view>

#include "ui/state/app_state.h"

namespace gb::ui {

inline constexpr float kBaseFontSize = 15.0f;  // pixels at DPI scale 1
inline constexpr const char* kFontDir = "/usr/share/fonts/truetype/dejavu/";

// Loads the fonts, applies the theme scaled by `scale` (the window's content scale; 1 for
// snapshots), and sets the plot style. A missing font file falls back to ImGui's built-in
// font with a warning in state.messages.
void SetUpWorkbench(AppState& state, float scale);

// The colours the frame and the panels draw themselves (ImGui's own are set by SetUpWorkbench).
struct ThemeColors {
  ImU32 sidebar_bg;     // the sidebar
  ImU32 side_panel_bg;  // the sliders' panel beside a view
  ImU32 card_bg;        // a notice's card
  ImU32 pane_bg;        // a view's inner pane (the Estimate view's report, the Live view's alarms)
};
const ThemeColors& Colors(ThemeKind theme);

// View > Theme's items and greybench-snapshot --theme's names.
inline constexpr std::array<ThemeKind, 3> kThemes = {ThemeKind::kLight, ThemeKind::kDark,
                                                     ThemeKind::kProjector};
const char* ThemeTitle(ThemeKind theme);  // "Light", "Dark", "High contrast (projector)"
const char* ThemeName(ThemeKind theme);   // "light", "dark", "projector"
std::optional<ThemeKind> ParseTheme(std::string_view name);

}  // namespace gb::ui
