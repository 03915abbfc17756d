#include "ui/state/diagram_view.h"

#include <filesystem>
#include <utility>

#include "core/util/json.h"
#include "ui/state/app_state.h"

namespace gb::ui {
namespace {

bool HasDiagramKey(const project::Project& p) {
  return p.extra.is_object() && p.extra.contains("diagram");
}

// Makes the compiled model of the current diagram the workbench's model, when it compiles.
void Recompile(AppState& state) {
  DiagramViewState& v = state.diagram_view;
  const std::string source = state.project ? state.project->path : std::string();
  diagram::CompileResult compiled = diagram::Compile(*v.diagram, source);
  v.problems = std::move(compiled.problems);
  if (!compiled.model) return;
  state.model = std::move(compiled.model);
  state.model_error.clear();
  ResolveMessages(state, MessageTopic::kModel);
  ++state.model_revision;
  v.synced_revision = state.model_revision;
  v.model_from_diagram = true;
  // The equations view and saving read the project's model JSON.
  if (state.project) state.project->model_json = model::ToJson(*state.model);
}

void Install(AppState& state, diagram::BlockDiagram d, const diagram::BlockDiagram& before) {
  DiagramViewState& v = state.diagram_view;
  // The first edit of FromModel's picture makes it the project's diagram, and its model the
  // workbench's (the same equations, compiled from the blocks).
  const bool semantic = !SameSemantics(before, d) || v.from_model;
  v.diagram = std::move(d);
  v.from_model = false;
  if (state.project) state.project->extra["diagram"] = diagram::ToJson(*v.diagram);
  if (semantic) {
    Recompile(state);
  } else {
    ++state.layout_revision;
  }
}

}  // namespace

void InstallDiagram(AppState& state) {
  DiagramViewState& v = state.diagram_view;
  v = DiagramViewState{};
  v.synced_revision = state.model_revision;
  if (!state.project) return;
  if (HasDiagramKey(*state.project)) {
    if (const Json& key = state.project->extra["diagram"]; key.is_string()) {
      v.file = std::filesystem::path(
                   project::ResolvePath(state.project->base_dir, key.get<std::string>()))
                   .lexically_normal()
                   .string();
    }
    Result<diagram::BlockDiagram> d = diagram::LoadProjectDiagram(*state.project);
    if (!d) {
      v.error = d.error().ToString();
      AddMessage(state, Severity::kError, "The project's diagram cannot be read: " + v.error);
      return;
    }
    v.diagram = std::move(d).value();
    diagram::CompileResult compiled = diagram::Compile(*v.diagram, state.project->path);
    v.problems = std::move(compiled.problems);
    if (compiled.model) {
      state.model = std::move(compiled.model);
      state.model_error.clear();
      ResolveMessages(state, MessageTopic::kModel);
      v.model_from_diagram = true;
      state.project->model_json = model::ToJson(*state.model);
    } else {
      AddMessage(state, Severity::kWarning,
                 "The project's diagram does not compile (" + std::to_string(v.problems.size()) +
                     (v.problems.size() == 1 ? " problem" : " problems") +
                     "); the model file is used until it does.",
                 MessageTopic::kModel);
    }
    return;
  }
  if (!state.model) {
    v.error = "the model is not valid: " + state.model_error;
    return;
  }
  Result<diagram::BlockDiagram> d = diagram::FromModel(*state.model);
  if (!d) {
    v.error = d.error().ToString();
    return;
  }
  v.diagram = std::move(d).value();
  v.from_model = true;
}

void SyncDiagramParameters(AppState& state) {
  DiagramViewState& v = state.diagram_view;
  if (!v.diagram || !state.model || v.synced_revision == state.model_revision) return;
  v.synced_revision = state.model_revision;
  bool changed = false;
  for (const model::Parameter& p : state.model->parameters) {
    for (model::Parameter& q : v.diagram->parameters) {
      if (q.name != p.name) continue;
      if (q.value == p.value && q.lower == p.lower && q.upper == p.upper && q.fixed == p.fixed)
        break;
      q.value = p.value;
      q.lower = p.lower;
      q.upper = p.upper;
      q.fixed = p.fixed;
      changed = true;
      break;
    }
  }
  if (changed && !v.from_model && state.project)
    state.project->extra["diagram"] = diagram::ToJson(*v.diagram);
}

void ApplyDiagramEdits(AppState& state) {
  DiagramViewState& v = state.diagram_view;
  std::vector<DiagramEdit> edits = std::move(v.pending);
  v.pending.clear();
  const bool undo = std::exchange(v.undo_requested, false);
  const bool redo = std::exchange(v.redo_requested, false);
  if (!v.diagram) return;
  SyncDiagramParameters(state);

  const diagram::BlockDiagram before = *v.diagram;
  if (undo || redo) {
    std::vector<diagram::BlockDiagram>& from = undo ? v.undo : v.redo;
    std::vector<diagram::BlockDiagram>& to = undo ? v.redo : v.undo;
    if (from.empty()) return;
    to.push_back(before);
    diagram::BlockDiagram restored = std::move(from.back());
    from.pop_back();
    v.refusal.reset();
    Install(state, std::move(restored), before);
    return;
  }
  if (edits.empty()) return;

  diagram::BlockDiagram d = before;
  bool accepted = false;
  for (const DiagramEdit& edit : edits) {
    const int next_id = d.next_id;
    Status s = ApplyDiagramEdit(&d, edit);
    if (!s) {
      DiagramRefusal r;
      r.kind = edit.kind;
      r.id = edit.id;
      r.field = edit.field;
      r.text = edit.kind == DiagramEditKind::kSetParameter ? edit.parameter.name : edit.text;
      r.reason = s.error().ToString();
      v.refusal = std::move(r);
      continue;
    }
    if (v.refusal && v.refusal->kind == edit.kind && v.refusal->id == edit.id &&
        v.refusal->field == edit.field)
      v.refusal.reset();
    accepted = true;
    if (edit.kind == DiagramEditKind::kAddBlock) v.editor.Select(next_id);  // to edit it next
  }
  if (!accepted || diagram::ToJson(d) == diagram::ToJson(before)) return;
  v.undo.push_back(before);
  if (v.undo.size() > kDiagramHistory) v.undo.erase(v.undo.begin());
  v.redo.clear();
  Install(state, std::move(d), before);
}

}  // namespace gb::ui
