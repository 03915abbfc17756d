// The residuals view: a placeholder until the residual diagnostics exists.
#include "ui/panel_common.h"
#include "ui/panels.h"

namespace gb::ui {

void DrawResidualsPanel(AppState& state) {
  DrawUnavailable(state, View::kResiduals,
                  "its plots (the diagnostics are computed already: greybench-cli diagnose)",
                  "It will show the standardised residuals over time and their autocorrelation, to "
                  "judge whether the model explains the data.");
}

}  // namespace gb::ui
