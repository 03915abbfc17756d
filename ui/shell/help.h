// Help › User guide (F1): the user guide's sections in a window of the workbench (help.cpp).
// The guide is docs/user-guide.md of the source tree the build came from (kUserGuideFile), or
// ShellState::guide_file; read the first time the window is shown. A guide that cannot be read is
// said so in the window.
#pragma once

#include <string_view>
#include <vector>

#include "ui/state/app_state.h"

namespace gb::ui {

// The guide's "##" and "###" sections in order, each with its lines (a heading inside a code
// fence is not one).
std::vector<GuideSection> ParseGuide(std::string_view markdown);

// Draws the window while ShellState::show_help is set (Esc or its close button clear it).
void DrawHelpWindow(AppState& state);

extern const char* const kUserGuideFile;

}  // namespace gb::ui
