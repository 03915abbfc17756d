// Edits of the project's block diagram as the diagram view emits them.
//
// The editor (ui/widgets/node_editor) and the panel (ui/panels/diagram.cpp) never change the
// diagram while drawing: they append `DiagramEdit`s to DiagramViewState::pending, and
// ApplyDiagramEdits() applies them after the view is drawn, each through the core function that
// can refuse it (diagram::AddBlock, Connect, SetBlockParameter, ...). The edits of one frame form
// one step of the undo history (a drag that moves five blocks is undone at once).
//
// What an accepted step does to the project and the model: ui/diagram_view.h.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/diagram/diagram.h"
#include "core/util/result.h"

namespace gb::ui {

enum class DiagramEditKind {
  kAddBlock,      // block, position
  kRemoveBlock,   // id
  kConnect,       // from, to (as the user drew them; core refuses a wrong direction)
  kDisconnect,    // id (a link)
  kMove,          // id, position
  kSetField,      // id, field, text
  kRename,        // id, text
  kSetSigns,      // id, text
  kSetPorts,      // id, names
  kSetDelay,      // id, delay
  kSetParameter,  // parameter (added, or replacing the one of the same name)
  kReplace,       // diagram: the whole diagram (e.g. "new empty diagram")
};

struct DiagramEdit {
  DiagramEditKind kind = DiagramEditKind::kMove;
  int id = 0;
  diagram::Block block;
  std::array<double, 2> position = {0, 0};
  diagram::PortRef from, to;
  // kSetField: the field; other inspector edits name their control ("name", "ports", "signs",
  // "delay", "parameter") so a refusal is shown next to it; "" for canvas edits.
  std::string field;
  std::string text;
  std::vector<std::string> names;
  model::DelaySpec delay;
  model::Parameter parameter;
  std::optional<diagram::BlockDiagram> diagram;
};

// Applies one edit to `d` through core; on refusal `d` is unchanged and the error says why.
Status ApplyDiagramEdit(diagram::BlockDiagram* d, const DiagramEdit& edit);
// Whether two diagrams mean the same (everything but the layout is equal).
bool SameSemantics(const diagram::BlockDiagram& a, const diagram::BlockDiagram& b);

// An empty diagram with the parameters and options of `m` (what "New diagram" starts from).
diagram::BlockDiagram EmptyDiagramLike(const model::ModelSpec& m);

}  // namespace gb::ui
