#include "ui/state/equations_view.h"

#include <utility>

#include "core/util/json.h"
#include "ui/state/app_state.h"

namespace gb::ui {
namespace {

// Makes `edited` the workbench's model and the project's model file.
void InstallEditedModel(AppState& state, EditedModel edited) {
  state.model = std::move(edited.spec);
  state.model_error.clear();
  ResolveMessages(state, MessageTopic::kModel);
  ++state.model_revision;
  if (state.project) state.project->model_json = std::move(edited.json);
  // The Diagram view's picture of an equations-only model is drawn again from the new model
  // (its first edit would otherwise bring back the old structure).
  const DiagramViewState& d = state.diagram_view;
  const bool has_diagram =
      state.project && state.project->extra.is_object() && state.project->extra.contains("diagram");
  if (!has_diagram && (d.from_model || !d.diagram)) InstallDiagram(state);
}

// Restores the model file at the back of `from`, moving the current one onto `to`.
void RestoreModelFile(AppState& state, std::vector<Json>& from, std::vector<Json>& to) {
  if (from.empty() || !state.project || !state.model) return;
  Result<model::ModelSpec> spec = model::ParseModel(from.back(), state.model->source);
  if (!spec) {  // cannot happen: every step in the history was a model that parsed
    AddMessage(state, Severity::kError, "Undo failed: " + spec.error().ToString());
    from.clear();
    return;
  }
  to.push_back(state.project->model_json);
  Json restored = std::move(from.back());
  from.pop_back();
  InstallEditedModel(state, EditedModel{std::move(restored), std::move(spec).value()});
}

// Checks every draft against the model as it now is.
void RecheckDrafts(AppState& state) {
  EquationsViewState& v = state.equations_view;
  if (v.drafts_revision == state.model_revision || !state.model) return;
  v.drafts_revision = state.model_revision;
  for (auto it = v.drafts.begin(); it != v.drafts.end();) {
    Result<model::ModelSpec> edited = ApplyFormulaEdit(*state.model, {it->first, it->second.text});
    if (!edited &&
        edited.error().message.find("is not a formula of the model") != std::string::npos) {
      it = v.drafts.erase(it);  // its state or output is gone
      continue;
    }
    it->second.error = edited ? std::nullopt : std::optional<Error>(edited.error());
    ++it;
  }
}

// What was typed for an accepted edit (a prior's two fields and the new parameter's row are
// one edit).
void ForgetTyping(EquationsViewState& v, const std::string& control) {
  v.typing.erase(control);
  for (const char* group : {"prior.", "new_parameter."}) {
    if (control.rfind(group, 0) != 0) continue;
    const std::string prefix = control.substr(0, control.rfind('.') + 1);
    std::erase_if(v.typing, [&](const auto& entry) { return entry.first.rfind(prefix, 0) == 0; });
  }
}

}  // namespace

void ApplyEquationsEdits(AppState& state) {
  EquationsViewState& v = state.equations_view;
  std::vector<StructureEdit> edits = std::move(v.structure_pending);
  v.structure_pending.clear();
  const bool undo = std::exchange(v.undo_requested, false);
  const bool redo = std::exchange(v.redo_requested, false);
  if (v.history_revision != state.model_revision) {
    v.undo.clear();
    v.redo.clear();
  }
  if (!state.project || !state.model) {
    v.pending.clear();
    v.history_revision = state.model_revision;
    return;
  }
  if (undo || redo) {
    v.pending.clear();
    v.refusal.reset();
    if (undo)
      RestoreModelFile(state, v.undo, v.redo);
    else
      RestoreModelFile(state, v.redo, v.undo);
  } else {
    const Json before = state.project->model_json;
    const int revision = state.model_revision;
    ApplyFormulaEdits(state);
    for (const StructureEdit& edit : edits) {
      Result<EditedModel> edited =
          ApplyStructureEdit(state.project->model_json, state.model->source, edit);
      if (!edited) {
        v.refusal = StructureRefusal{edit.control, edited.error().ToString()};
        continue;
      }
      if (v.refusal && v.refusal->control == edit.control) v.refusal.reset();
      ForgetTyping(v, edit.control);
      if (edited->json == state.project->model_json) continue;  // e.g. the same name retyped
      InstallEditedModel(state, std::move(edited).value());
      // A parameter created from a refused formula's offer: the formula, left while it was
      // refused, is applied now that it names a parameter of the model.
      const auto draft = v.drafts.find(edit.control);
      if (edit.kind == StructureEditKind::kAddParameter && draft != v.drafts.end()) {
        v.pending.push_back({draft->first, draft->second.text});
        ApplyFormulaEdits(state);
      }
    }
    if (state.model_revision != revision) {
      v.undo.push_back(before);
      if (v.undo.size() > kEquationsHistory) v.undo.erase(v.undo.begin());
      v.redo.clear();
    }
  }
  v.history_revision = state.model_revision;
  RecheckDrafts(state);
}

}  // namespace gb::ui
