// The operating points view: a placeholder until the operating-point analysis exists.
#include "ui/panel_common.h"
#include "ui/panels.h"

namespace gb::ui {

void DrawOperatingPointsPanel(AppState& state) {
  DrawUnavailable(state, View::kOperatingPoints,
                  "its plots (the sweep runs already: greybench-cli sweep)",
                  "It will compute the model's steady states and linearisations at chosen inputs.");
}

}  // namespace gb::ui
