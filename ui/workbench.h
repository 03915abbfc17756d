// The workbench window: main menu bar, a sidebar listing the project and the views, the current
// view filling the rest, and a status bar with the latest message. Shared by the GLFW window
// (greybench) and the offscreen renderer (greybench-snapshot), so both draw the same thing.
#pragma once

#include "ui/state/app_state.h"

namespace gb::ui {

// Draws one frame of the workbench, between ImGui::NewFrame() and ImGui::Render(). Installs the
// results of finished jobs first. Sets state.quit_requested when the user has chosen File > Quit
// (or RequestQuit was called) and answered "save changes?".
void DrawWorkbench(AppState& state);

}  // namespace gb::ui
