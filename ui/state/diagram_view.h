// The diagram view's state in AppState, and how its edits reach the project and the model.
//
// After an accepted step of edits (ui/edits/diagram_edit.h):
//   - state.project->extra["diagram"] holds the diagram's JSON (diagram::ToJson, inline), so
//     saving the project writes the edited diagram;
//   - a step that changes the semantics recompiles; when the diagram compiles, its model becomes
//     state.model (and the project's model JSON) and state.model_revision counts up; when it does
//     not, the problems are kept for the editor and state.model stays the last model that compiled;
//   - a step that only moves blocks counts state.layout_revision up instead;
//   - undo and redo restore whole diagrams (a history of values, at most kDiagramHistory steps).
// Parameter values edited in the Parameters view are copied into the diagram's parameter table
// (SyncDiagramParameters), so a recompile keeps them.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/diagram/diagram.h"
#include "ui/edits/diagram_edit.h"
#include "ui/widgets/node_editor.h"

namespace gb::ui {

struct AppState;

// An edit core refused, shown next to the control it came from.
struct DiagramRefusal {
  DiagramEditKind kind = DiagramEditKind::kMove;
  int id = 0;         // the block (or link) concerned, 0 if none
  std::string field;  // the field ("tau"), or "name", "ports", "signs", "delay", "parameter";
                      // "" for canvas edits (links, deletes), shown in the toolbar
  std::string text;   // what the user entered
  std::string reason;
};

struct DiagramViewState {
  // The diagram being edited: the project's own ("diagram" key), or FromModel's picture of an
  // equations-only model (`from_model`), which becomes the project's diagram at the first edit.
  std::optional<diagram::BlockDiagram> diagram;
  bool from_model = false;
  bool model_from_diagram = false;  // state.model is the diagram's compiled model
  // The diagram file the project names ("diagram": "PATH"), absolute; "" for an inline diagram
  // or FromModel's picture. Saving the project writes the diagram to it and keeps the path,
  // unless the user unticked `keep_file` (then the diagram is written into the project file).
  std::string file;
  bool keep_file = true;
  // The canvas font the zoom asks for, and since when (AskForCanvasFont, ui/panels/diagram.cpp).
  float canvas_zoom_seen = 1.0f;
  double canvas_zoom_since = 0.0;
  std::string error;                       // why there is no diagram
  std::vector<diagram::Problem> problems;  // of the last compile
  std::vector<diagram::BlockDiagram> undo, redo;
  std::vector<DiagramEdit> pending;
  bool undo_requested = false, redo_requested = false;
  std::optional<DiagramRefusal> refusal;
  int synced_revision = 0;  // state.model_revision the diagram's parameters were taken from
  node_editor::EditorContext editor;
  // The inspector field being typed into (ImGui keeps the text only while it is active).
  int editing_block = 0;
  std::string editing_field;
  std::string editing_text;
  // The "add parameter" form.
  std::string new_parameter_name, new_parameter_value, new_parameter_lower, new_parameter_upper;
};

// The undo history keeps at most this many steps.
inline constexpr std::size_t kDiagramHistory = 200;

// Sets up state.diagram_view for the project just installed (InstallProject calls it): loads the
// project's diagram (or FromModel of its model) and, when the project has a diagram that
// compiles, makes its model state.model.
void InstallDiagram(AppState& state);
// Applies state.diagram_view.pending, undo and redo (see the top of this file).
void ApplyDiagramEdits(AppState& state);
// Copies parameter edits made elsewhere (the Parameters view) into the diagram's parameter table,
// so the next recompile keeps them. Called after parameter edits are applied.
void SyncDiagramParameters(AppState& state);

}  // namespace gb::ui
