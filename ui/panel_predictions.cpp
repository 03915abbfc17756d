// The predictions view: a placeholder until the Kalman filter exists.
#include "ui/panel_common.h"
#include "ui/panels.h"

namespace gb::ui {

void DrawPredictionsPanel(AppState& state) {
  DrawUnavailable(state, View::kPredictions,
                  "its plots (the predictions are computed already: greybench-cli predict)",
                  "It will plot every output's measurements with the one-step predictions and "
                  "their uncertainty bands.");
}

}  // namespace gb::ui
