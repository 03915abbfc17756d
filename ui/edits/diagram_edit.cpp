#include "ui/edits/diagram_edit.h"

#include <utility>

#include "core/util/json.h"

namespace gb::ui {

Status ApplyDiagramEdit(diagram::BlockDiagram* d, const DiagramEdit& edit) {
  // Core's edits apply entirely or refuse and leave the diagram as it was.
  Status s = Ok{};
  switch (edit.kind) {
    case DiagramEditKind::kAddBlock: {
      Result<int> id = diagram::AddBlock(d, edit.block, edit.position);
      if (!id) s = id.error();
      break;
    }
    case DiagramEditKind::kRemoveBlock:
      s = diagram::RemoveBlock(d, edit.id);
      break;
    case DiagramEditKind::kConnect: {
      Result<int> id = diagram::Connect(d, edit.from, edit.to);
      if (!id) s = id.error();
      break;
    }
    case DiagramEditKind::kDisconnect:
      s = diagram::Disconnect(d, edit.id);
      break;
    case DiagramEditKind::kMove:
      s = diagram::Move(d, edit.id, edit.position);
      break;
    case DiagramEditKind::kSetField:
      s = diagram::SetBlockParameter(d, edit.id, edit.field, edit.text);
      break;
    case DiagramEditKind::kRename:
      s = diagram::RenameBlock(d, edit.id, edit.text);
      break;
    case DiagramEditKind::kSetSigns:
      s = diagram::SetSumSigns(d, edit.id, edit.text);
      break;
    case DiagramEditKind::kSetPorts:
      s = diagram::SetPortNames(d, edit.id, edit.names);
      break;
    case DiagramEditKind::kSetDelay:
      s = diagram::SetDelay(d, edit.id, edit.delay);
      break;
    case DiagramEditKind::kSetParameter:
      s = diagram::SetParameterEntry(d, edit.parameter);
      break;
    case DiagramEditKind::kReplace:
      if (edit.diagram) *d = *edit.diagram;
      break;
  }
  return s;
}

bool SameSemantics(const diagram::BlockDiagram& a, const diagram::BlockDiagram& b) {
  Json ja = diagram::ToJson(a), jb = diagram::ToJson(b);
  ja.erase("layout");
  jb.erase("layout");
  return ja == jb && a.next_id == b.next_id;
}

diagram::BlockDiagram EmptyDiagramLike(const model::ModelSpec& m) {
  diagram::BlockDiagram d;
  d.name = m.name;
  d.parameters = m.parameters;
  d.input_hold = m.input_hold;
  d.initial_covariance = m.initial_covariance == model::InitialCovariance::kExplicit
                             ? model::InitialCovariance::kCtsm
                             : m.initial_covariance;
  d.robust_huber = m.robust_huber;
  return d;
}

}  // namespace gb::ui
