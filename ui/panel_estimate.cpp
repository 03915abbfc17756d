// The estimate view: a placeholder until the maximum-likelihood estimator exists.
#include "ui/panel_common.h"
#include "ui/panels.h"

namespace gb::ui {

void DrawEstimatePanel(AppState& state) {
  DrawUnavailable(state, View::kEstimate, "the maximum-likelihood estimator",
                  "It will run the estimation in the background, with progress and a way to cancel "
                  "it, and report convergence, the log-likelihood, AIC and BIC.");
}

}  // namespace gb::ui
