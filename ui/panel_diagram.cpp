// The diagram view: a placeholder until the block-diagram editor exists.
#include "ui/panel_common.h"
#include "ui/panels.h"

namespace gb::ui {

void DrawDiagramPanel(AppState& state) {
  DrawUnavailable(state, View::kDiagram,
                  "the node editor (diagrams compile already: greybench-cli export-model)",
                  "It will show the model as blocks linked by signals, and edits made there will "
                  "change the model.");
}

}  // namespace gb::ui
