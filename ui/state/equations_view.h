// How the Equations view's edits reach the model, and its undo.
//
// After the view is drawn, ApplyEquationsEdits applies, in this order:
//   - undo or redo, when asked (Ctrl+Z / Ctrl+Y, or the toolbar): the model file as it was
//     before (after) the step becomes the project's model JSON and state.model again;
//   - the formula edits (ApplyFormulaEdits, ui/state/app_state.h);
//   - the structure edits (ApplyStructureEdit, ui/edits/model_edit.h): each accepted one makes
//     its model file the project's model JSON (what the view shows and a save writes) and its
//     model state.model, and counts state.model_revision up; a refused one is kept, with the
//     reason, in equations_view.refusal.
// The accepted edits of one frame are one undo step (at most kEquationsHistory steps are kept).
// The history holds whole model files, so it is dropped when the model changes elsewhere (the
// Parameters view, a fit's estimates taken as start values, a project opened): undoing past
// such a change would silently take it back too.
// Whenever the model has changed, every formula draft is checked again, so a draft refused for
// an unknown name is accepted once that name exists (and a draft of a deleted formula dropped).
#pragma once

#include <cstddef>

namespace gb::ui {

struct AppState;

inline constexpr std::size_t kEquationsHistory = 200;

void ApplyEquationsEdits(AppState& state);

}  // namespace gb::ui
