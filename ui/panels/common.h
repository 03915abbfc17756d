// Small pieces the panels share: notices in the middle of a view, section headings, number
// formats. Drawing helpers only; they hold no state.
#pragma once

#include <string>

#include "ui/state/app_state.h"

namespace gb::ui {

// When no project is open, draws the empty-workbench notice (loading, the last error, how to
// open one) and returns true: the panel then draws nothing else.
bool DrawNoProjectNotice(AppState& state);

// A centred card: a bold title and a wrapped explanation.
void DrawNotice(AppState& state, const char* title, const std::string& text,
                Severity severity = Severity::kInfo);

// A status line: a coloured dot and a bold word, then the rest of the line dimmed ("Running
// iteration 12 ...", "Converged ...").
void StatusLine(AppState& state, ImU32 color, const char* word, const std::string& rest);

// The view's main action (Run): a blue button with white text. True when clicked.
bool PrimaryButton(const char* label, ImVec2 size);

// A bold heading with a rule under it.
void SectionHeading(AppState& state, const char* text);

// "label value" pairs on one line: the label dimmed.
void LabelValue(const char* label, const std::string& value);

ImVec4 SeverityColor(Severity severity);
std::string FileName(const std::string& path);
// `text` as drawn in at most `width` pixels: whole, or cut at a character and ended with "…".
std::string FitToWidth(const std::string& text, float width);
std::string GroupedCount(long long n);  // 2400 -> "2,400"

// A toolbar's next item on this line `spacing` after the last when its `width` still fits in the
// window, else at the start of the next line (narrow windows, 1024 x 768).
void SameLineIfFits(float width, float spacing);
// The width of ImGui::Checkbox(label).
float CheckboxWidth(const char* label);

// A view's Undo and Redo buttons (disabled when there is nothing to take back or do again; the
// tooltips name the shortcuts): a click sets *undo or *redo. The next item follows on the line.
void UndoRedoButtons(bool can_undo, bool can_redo, bool* undo, bool* redo);

}  // namespace gb::ui
