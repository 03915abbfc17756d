// The parameters view: a placeholder until the estimator exists.
#include "ui/panel_common.h"
#include "ui/panels.h"

namespace gb::ui {

void DrawParametersPanel(AppState& state) {
  DrawUnavailable(state, View::kParameters, "the estimator",
                  "It will list each estimate with its standard error, t- and p-value, flag "
                  "estimates at a bound, and show their correlations.");
}

}  // namespace gb::ui
