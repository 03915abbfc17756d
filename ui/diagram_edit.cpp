#include "ui/diagram_edit.h"

#include <utility>

namespace gb::ui {

bool ChangesSemantics(const DiagramEdit& edit) { return edit.kind != DiagramEditKind::kMove; }

Status ApplyDiagramEdit(diagram::BlockDiagram* d, const DiagramEdit& edit) {
  // Core functions refuse without changing the diagram, except that the caller cannot rely on
  // that for a sequence; each edit works on a copy and the copy is kept only when accepted.
  diagram::BlockDiagram copy = *d;
  Status s = Ok{};
  switch (edit.kind) {
    case DiagramEditKind::kAddBlock: {
      Result<int> id = diagram::AddBlock(&copy, edit.block, edit.position);
      if (!id) s = id.error();
      break;
    }
    case DiagramEditKind::kRemoveBlock:
      s = diagram::RemoveBlock(&copy, edit.id);
      break;
    case DiagramEditKind::kConnect: {
      Result<int> id = diagram::Connect(&copy, edit.from, edit.to);
      if (!id) s = id.error();
      break;
    }
    case DiagramEditKind::kDisconnect:
      s = diagram::Disconnect(&copy, edit.id);
      break;
    case DiagramEditKind::kMove:
      s = diagram::Move(&copy, edit.id, edit.position);
      break;
    case DiagramEditKind::kSetField:
      s = diagram::SetBlockParameter(&copy, edit.id, edit.field, edit.text);
      break;
    case DiagramEditKind::kRename:
      s = diagram::RenameBlock(&copy, edit.id, edit.text);
      break;
    case DiagramEditKind::kSetSigns:
      s = diagram::SetSumSigns(&copy, edit.id, edit.text);
      break;
    case DiagramEditKind::kSetPorts:
      s = diagram::SetPortNames(&copy, edit.id, edit.names);
      break;
    case DiagramEditKind::kSetDelay:
      s = diagram::SetDelay(&copy, edit.id, edit.delay);
      break;
    case DiagramEditKind::kSetParameter:
      s = diagram::SetParameterEntry(&copy, edit.parameter);
      break;
    case DiagramEditKind::kReplace:
      if (edit.diagram) copy = *edit.diagram;
      break;
  }
  if (!s) return s;
  *d = std::move(copy);
  return Ok{};
}

std::string Describe(const DiagramEdit& edit) {
  auto port = [](const diagram::PortRef& p) {
    return "block " + std::to_string(p.block) +
           (p.side == diagram::PortSide::kIn ? " in " : " out ") + std::to_string(p.index);
  };
  const std::string block = "block " + std::to_string(edit.id);
  switch (edit.kind) {
    case DiagramEditKind::kAddBlock:
      return std::string("add a ") + diagram::KindName(edit.block.kind) + " block";
    case DiagramEditKind::kRemoveBlock:
      return "delete " + block;
    case DiagramEditKind::kConnect:
      return "link " + port(edit.from) + " -> " + port(edit.to);
    case DiagramEditKind::kDisconnect:
      return "delete link " + std::to_string(edit.id);
    case DiagramEditKind::kMove:
      return "move " + block;
    case DiagramEditKind::kSetField:
      return block + "." + edit.field + " = " + edit.text;
    case DiagramEditKind::kRename:
      return "rename " + block + " to " + edit.text;
    case DiagramEditKind::kSetSigns:
      return block + " signs = " + edit.text;
    case DiagramEditKind::kSetPorts:
      return block + " ports";
    case DiagramEditKind::kSetDelay:
      return block + " delay";
    case DiagramEditKind::kSetParameter:
      return "parameter " + edit.parameter.name;
    case DiagramEditKind::kReplace:
      return "replace the diagram";
  }
  return "";
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
