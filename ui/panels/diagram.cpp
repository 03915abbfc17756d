// The diagram view: the model as a block diagram (Fig. 1 of the paper for the fuel film), edited
// with the node editor widget.
//
//   toolbar    undo, redo, fit, new diagram; whether the diagram compiles; a refused edit
//   palette    one button per block kind core offers; a click places the block in view
//   canvas     ui/widgets/node_editor (select, move, link, delete)
//   inspector  the selected block's name and expression fields (typed, committed on Enter or
//              when the field loses focus), the diagram's parameters, and the problems
//
// Everything the user does becomes a DiagramEdit; ApplyDiagramEdits() applies the frame's edits
// through core after the view is drawn (ui/state/diagram_view.h says what an accepted edit
// changes).
//
// Sections
//   1. Helpers: names, text fields
//   2. Toolbar
//   3. Palette
//   4. Inspector
//   5. DrawDiagramPanel
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <imgui.h>
#include <imgui_stdlib.h>

#include "ui/format.h"
#include "ui/panels/common.h"
#include "ui/panels/panels.h"

namespace gb::ui {
namespace {

using diagram::Block;
using diagram::BlockKind;

constexpr float kPaletteWidth = 150.0f;     // pixels at scale 1
constexpr float kInspectorHeight = 230.0f;  // pixels at scale 1
constexpr float kMinCanvasHeight = 160.0f;  // pixels at scale 1
constexpr float kPlacedWidth = 150.0f;      // canvas units reserved for a block placed
const ImVec4 kErrorText(0.78f, 0.12f, 0.13f, 1.0f);
const ImVec4 kRefusedFieldBg(1.0f, 0.93f, 0.93f, 1.0f);

// ---------------------------------------------------------------------------------------------
// 1. Helpers

bool NameTaken(const diagram::BlockDiagram& d, const std::string& name) {
  for (const Block& b : d.blocks)
    if (b.name == name) return true;
  for (const model::Parameter& p : d.parameters)
    if (p.name == name) return true;
  return false;
}

// "u", "u2", "u3", ...: the first name no block or parameter uses.
std::string UniqueName(const diagram::BlockDiagram& d, const std::string& base) {
  if (!NameTaken(d, base)) return base;
  for (int i = 2;; ++i) {
    const std::string name = base + std::to_string(i);
    if (!NameTaken(d, name)) return name;
  }
}

std::string DefaultName(BlockKind kind) {
  switch (kind) {
    case BlockKind::kInput:
      return "u";
    case BlockKind::kOutput:
      return "y";
    case BlockKind::kLag:
    case BlockKind::kIntegrator:
    case BlockKind::kState:
      return "x";
    default:
      return "";  // a label, not a model name: the block shows its kind
  }
}

std::string JoinPorts(const std::vector<std::string>& ports) {
  std::string out;
  for (const std::string& p : ports) out += (out.empty() ? "" : ", ") + p;
  return out;
}

std::vector<std::string> SplitPorts(const std::string& text) {
  std::vector<std::string> out;
  std::string cur;
  auto flush = [&] {
    const auto a = cur.find_first_not_of(' ');
    const auto b = cur.find_last_not_of(' ');
    if (a != std::string::npos) out.push_back(cur.substr(a, b - a + 1));
    cur.clear();
  };
  for (char c : text) {
    if (c == ',') {
      flush();
    } else {
      cur += c;
    }
  }
  flush();
  return out;
}

std::string DelayText(const model::DelaySpec& d) {
  return d.IsScan() ? std::to_string(d.min) + ".." + std::to_string(d.max) : std::to_string(d.min);
}

// "3" or "0..10" (whole samples).
std::optional<model::DelaySpec> ParseDelay(const std::string& text) {
  auto whole = [](const std::string& s, int* out) {
    if (s.empty() || s.find_first_not_of("0123456789 ") != std::string::npos) return false;
    *out = std::atoi(s.c_str());
    return true;
  };
  model::DelaySpec d;
  const auto dots = text.find("..");
  if (dots == std::string::npos) {
    if (!whole(text, &d.min)) return std::nullopt;
    d.max = d.min;
    return d;
  }
  if (!whole(text.substr(0, dots), &d.min) || !whole(text.substr(dots + 2), &d.max))
    return std::nullopt;
  return d;
}

bool IsRefused(const DiagramViewState& v, int block, const std::string& field) {
  return v.refusal && v.refusal->id == block && v.refusal->field == field;
}

// One row of the inspector: a label and a text field committed on Enter or when it loses focus.
// ImGui keeps the text only while the field is active, so the text being typed lives in
// DiagramViewState. Returns the committed text when it differs from `current`.
std::optional<std::string> TextRow(AppState& state, int block, const std::string& field,
                                   const char* label, const std::string& current,
                                   const char* hint = "") {
  DiagramViewState& v = state.diagram_view;
  const bool refused = IsRefused(v, block, field);
  const bool editing = v.editing_block == block && v.editing_field == field;
  std::string shown = refused ? v.refusal->text : current;
  std::string* text = editing ? &v.editing_text : &shown;
  ImGui::TableNextRow();
  ImGui::TableNextColumn();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("%s", label);
  ImGui::TableNextColumn();
  ImGui::SetNextItemWidth(-FLT_MIN);
  if (refused) {
    ImGui::PushStyleColor(ImGuiCol_Border, SeverityColor(Severity::kError));
    ImGui::PushStyleColor(ImGuiCol_FrameBg, kRefusedFieldBg);
  }
  ImGui::PushFont(state.fonts.mono);
  ImGui::InputTextWithHint(("##" + field).c_str(), hint, text, ImGuiInputTextFlags_AutoSelectAll);
  ImGui::PopFont();
  if (refused) ImGui::PopStyleColor(2);
  if (ImGui::IsItemActivated()) {
    v.editing_block = block;
    v.editing_field = field;
    v.editing_text = *text;
  }
  std::optional<std::string> committed;
  if (ImGui::IsItemDeactivated()) {
    const std::string typed = editing ? v.editing_text : *text;
    if (ImGui::IsItemDeactivatedAfterEdit() && (typed != current || refused)) committed = typed;
    v.editing_block = 0;
    v.editing_field.clear();
    v.editing_text.clear();
  }
  if (refused) {
    ImGui::PushStyleColor(ImGuiCol_Text, kErrorText);
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextUnformatted(v.refusal->reason.c_str());
    ImGui::PopTextWrapPos();
    ImGui::PopStyleColor();
  }
  return committed;
}

void Emit(AppState& state, DiagramEdit edit) {
  state.diagram_view.pending.push_back(std::move(edit));
}

// ---------------------------------------------------------------------------------------------
// 2. Toolbar

std::string CompileStatus(const AppState& state, Severity* severity) {
  const DiagramViewState& v = state.diagram_view;
  *severity = Severity::kInfo;
  if (!v.problems.empty()) {
    *severity = Severity::kError;
    const std::size_t n = v.problems.size();
    return std::to_string(n) + (n == 1 ? " problem" : " problems") +
           " (listed below): the workbench keeps the last model that compiled";
  }
  if (v.from_model)
    return "Drawn from the equations-only model; the first edit makes it the project's diagram";
  if (v.model_from_diagram && state.model) {
    const model::ModelSpec& m = *state.model;
    auto count = [](std::size_t n, const char* what) {
      return std::to_string(n) + " " + what + (n == 1 ? "" : "s");
    };
    return "Compiles to " + count(m.states.size(), "state") + ", " +
           count(m.inputs.size(), "input") + ", " + count(m.outputs.size(), "output") +
           " \xE2\x80\x94 the model the other views use";
  }
  return "Compiles";
}

// Asks for the canvas font of the editor's zoom once the zoom has stayed for kSettleSeconds, so
// that a wheel zoom rebuilds the font atlas once, not at every notch.
void AskForCanvasFont(AppState& state) {
  constexpr double kSettleSeconds = 0.3;
  DiagramViewState& v = state.diagram_view;
  const float wanted = CanvasZoomFor(v.editor.zoom);
  const double now = ImGui::GetTime();
  if (wanted != v.canvas_zoom_seen) {
    v.canvas_zoom_seen = wanted;
    v.canvas_zoom_since = now;
  }
  if (wanted != state.fonts.wanted_canvas_zoom && now - v.canvas_zoom_since >= kSettleSeconds)
    state.fonts.wanted_canvas_zoom = wanted;
}

void DrawToolbar(AppState& state) {
  DiagramViewState& v = state.diagram_view;
  UndoRedoButtons(!v.undo.empty(), !v.redo.empty(), &v.undo_requested, &v.redo_requested);
  if (ImGui::Button("Fit view")) v.editor.RequestFit();
  ImGui::SameLine();
  ImGui::BeginDisabled(!state.model);
  const bool new_diagram = ImGui::Button("New diagram");
  ImGui::EndDisabled();
  if (new_diagram && state.model) {
    DiagramEdit e;
    e.kind = DiagramEditKind::kReplace;
    e.diagram = EmptyDiagramLike(*state.model);
    Emit(state, std::move(e));
    v.editor.selected_blocks.clear();
    v.editor.selected_links.clear();
  }
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
    ImGui::SetTooltip("An empty diagram with the model's parameters and options (undo restores)");
  ImGui::SameLine(0, 16.0f * state.fonts.scale);
  Severity severity = Severity::kInfo;
  const std::string status = CompileStatus(state, &severity);
  ImGui::AlignTextToFramePadding();
  if (severity == Severity::kInfo) {
    ImGui::TextDisabled("%s", status.c_str());
  } else {
    ImGui::TextColored(SeverityColor(severity), "%s", status.c_str());
  }
  // Where saving puts the diagram: its own file (the project keeps the path), or the project.
  if (!v.file.empty() && !v.from_model) {
    ImGui::SameLine(0, 16.0f * state.fonts.scale);
    bool keep = v.keep_file;
    const std::string label = "Save in " + FileName(v.file);
    if (ImGui::Checkbox(label.c_str(), &keep)) {
      v.keep_file = keep;
      ++state.layout_revision;  // an unsaved change: where the diagram goes
    }
    if (ImGui::IsItemHovered()) {
      ImGui::SetTooltip("%s", (keep ? "Saving the project writes the diagram to " + v.file +
                                          " and keeps its path in the project file; untick to "
                                          "write the diagram into the project file instead"
                                    : "Saving the project writes the diagram into the project "
                                      "file; tick to keep it in " +
                                          v.file)
                                  .c_str());
    }
  }
  // Refusals of canvas edits (links, deletes) have no field to sit next to.
  if (v.refusal && v.refusal->field.empty()) {
    ImGui::TextColored(SeverityColor(Severity::kError), "Refused: %s", v.refusal->reason.c_str());
  }
}

void HandleShortcuts(AppState& state) {
  const ImGuiIO& io = ImGui::GetIO();
  if (!io.KeyCtrl || io.WantTextInput) return;
  DiagramViewState& v = state.diagram_view;
  const bool z = ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Z), false);
  const bool y = ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Y), false);
  if (z && !io.KeyShift) v.undo_requested = true;
  if (y || (z && io.KeyShift)) v.redo_requested = true;
}

// ---------------------------------------------------------------------------------------------
// 3. Palette

struct PaletteEntry {
  BlockKind kind;
  const char* label;
  const char* help;
};

constexpr PaletteEntry kPalette[] = {
    {BlockKind::kInput, "Input", "A model input u (a data column)"},
    {BlockKind::kOutput, "Output / sensor",
     "A model output y = h(ports) + e; its variance is the measurement noise"},
    {BlockKind::kLag, "First-order lag", "dx = (K u - x)/tau dt (a state)"},
    {BlockKind::kIntegrator, "Integrator", "dx = k u dt (a state)"},
    {BlockKind::kState, "General state", "dx = f(ports, x) dt (a state)"},
    {BlockKind::kGain, "Gain", "out = k u"},
    {BlockKind::kSum, "Sum", "out = sum of the inputs with the signs (\"+-\")"},
    {BlockKind::kSplit, "Split X / 1\xE2\x88\x92X", "X u and (1 - X) u"},
    {BlockKind::kDelay, "Transport delay", "whole samples, directly in front of an output"},
    {BlockKind::kNoise, "Process noise", "sigma d\xCF\x89 on the state it is linked to"},
    // Nonlinear maps last: a model with them runs through the extended Kalman filter.
    {BlockKind::kProduct, "Product", "out = u1 u2"},
    {BlockKind::kQuotient, "Quotient", "out = num / den"},
    {BlockKind::kFunction, "Static function", "out = g(ports): any expression of its inputs"},
    {BlockKind::kOrifice, "Orifice (sqrt flow)", "out = k sqrt(u): flow out of a tank of level u"},
    {BlockKind::kSaturation, "Saturation",
     "u clipped to [lower, upper]; smooth with width > 0 (for the EKF)"},
};

void PlaceBlock(AppState& state, BlockKind kind) {
  DiagramViewState& v = state.diagram_view;
  const diagram::BlockDiagram& d = *v.diagram;
  Block b = diagram::MakeBlock(kind, "");
  const std::string base = DefaultName(kind);
  if (!base.empty()) b.name = UniqueName(d, base);
  const node_editor::TextWidth width = node_editor::FontTextWidth(state.fonts.regular);
  const node_editor::BlockShape shape = node_editor::LayoutBlock(b, {0, 0}, width);
  // Room for the block to grow as its fields are typed (a new block shows short defaults).
  const ImVec2 size(std::max(shape.max.x - shape.min.x, kPlacedWidth), shape.max.y - shape.min.y);
  const ImVec2 centre = v.editor.view_centre;
  const ImVec2 at =
      node_editor::FreeSpot(node_editor::LayoutDiagram(d, width),
                            ImVec2(centre.x - 0.5f * size.x, centre.y - 0.5f * size.y), size);
  DiagramEdit e;
  e.kind = DiagramEditKind::kAddBlock;
  e.block = std::move(b);
  e.position = {std::round(at.x), std::round(at.y)};
  Emit(state, std::move(e));  // selected once it exists (ApplyDiagramEdits)
}

void DrawPalette(AppState& state) {
  const float s = state.fonts.scale;
  ImGui::TextDisabled("PLACE A BLOCK");
  ImGui::PushStyleVar(ImGuiStyleVar_ButtonTextAlign, ImVec2(0.0f, 0.5f));
  for (const PaletteEntry& p : kPalette) {
    if (ImGui::Button(p.label, ImVec2(-FLT_MIN, 0))) PlaceBlock(state, p.kind);
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", p.help);
  }
  ImGui::PopStyleVar();
  ImGui::Dummy(ImVec2(0, 4.0f * s));
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextDisabled("Measurement noise: the variance of an output block.");
  ImGui::PopTextWrapPos();
}

// ---------------------------------------------------------------------------------------------
// 4. Inspector

// An edit typed into the inspector's row `field` of block `id`.
DiagramEdit InspectorEdit(DiagramEditKind kind, int id, std::string field, std::string text) {
  DiagramEdit e;
  e.kind = kind;
  e.id = id;
  e.field = std::move(field);
  e.text = std::move(text);
  return e;
}

void DrawBlockInspector(AppState& state, const Block& b) {
  const int id = b.id;
  ImGui::PushFont(state.fonts.bold);
  ImGui::Text("Block %d", id);
  ImGui::PopFont();
  ImGui::SameLine();
  ImGui::TextDisabled("%s", node_editor::KindSummary(b.kind));
  if (!ImGui::BeginTable("##fields", 2, ImGuiTableFlags_SizingStretchProp)) return;
  ImGui::TableSetupColumn("label", ImGuiTableColumnFlags_WidthFixed);
  ImGui::TableSetupColumn("value", ImGuiTableColumnFlags_WidthStretch);
  const bool model_name =
      b.kind == BlockKind::kInput || b.kind == BlockKind::kOutput || diagram::HoldsState(b.kind);
  if (auto t = TextRow(state, id, "name", model_name ? "name" : "label", b.name)) {
    DiagramEdit e = InspectorEdit(DiagramEditKind::kRename, id, "name", *t);
    Emit(state, std::move(e));
  }
  if (b.kind == BlockKind::kState || b.kind == BlockKind::kOutput ||
      b.kind == BlockKind::kFunction) {
    if (auto t = TextRow(state, id, "ports", "in-ports", JoinPorts(b.ports), "a, b")) {
      DiagramEdit e = InspectorEdit(DiagramEditKind::kSetPorts, id, "ports", *t);
      e.names = SplitPorts(*t);
      Emit(state, std::move(e));
    }
  }
  if (b.kind == BlockKind::kSum) {
    if (auto t = TextRow(state, id, "signs", "signs", b.signs, "+-")) {
      DiagramEdit e = InspectorEdit(DiagramEditKind::kSetSigns, id, "signs", *t);
      Emit(state, std::move(e));
    }
  }
  for (const std::string& field : diagram::FieldsOf(b.kind)) {
    const auto it = b.fields.find(field);
    const std::string current = it == b.fields.end() ? "" : it->second;
    if (auto t = TextRow(state, id, field, field.c_str(), current, "expression")) {
      DiagramEdit e = InspectorEdit(DiagramEditKind::kSetField, id, field, *t);
      Emit(state, std::move(e));
    }
  }
  if (b.kind == BlockKind::kDelay || b.kind == BlockKind::kOutput) {
    if (auto t = TextRow(state, id, "delay", "delay", DelayText(b.delay), "3 or 0..10")) {
      DiagramEdit e = InspectorEdit(DiagramEditKind::kSetDelay, id, "delay", *t);
      if (std::optional<model::DelaySpec> d = ParseDelay(*t)) {
        e.delay = *d;
        Emit(state, std::move(e));
      } else {
        state.diagram_view.refusal =
            DiagramRefusal{e.kind, id, "delay", *t,
                           "a delay is a whole number of samples (\"3\") or a range (\"0..10\")"};
      }
    }
  }
  ImGui::EndTable();
  ImGui::TextDisabled("%s", b.kind == BlockKind::kState || b.kind == BlockKind::kOutput ||
                                    b.kind == BlockKind::kFunction
                                ? "Fields are expressions of the parameters; f, h or g reads the "
                                  "in-ports by name."
                                : "Fields are expressions of the parameters.");
  if (ImGui::Button("Delete block")) {
    DiagramEdit e;
    e.kind = DiagramEditKind::kRemoveBlock;
    e.id = id;
    Emit(state, std::move(e));
  }
}

std::optional<double> ParseNumber(const std::string& text, bool* ok) {
  *ok = true;
  if (text.find_first_not_of(' ') == std::string::npos) return std::nullopt;
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0') *ok = false;
  return x;
}

void DrawParameters(AppState& state) {
  DiagramViewState& v = state.diagram_view;
  const diagram::BlockDiagram& d = *v.diagram;
  ImGui::PushFont(state.fonts.bold);
  ImGui::TextUnformatted("Parameters");
  ImGui::PopFont();
  const ImGuiTableFlags flags =
      ImGuiTableFlags_SizingStretchProp | ImGuiTableFlags_RowBg | ImGuiTableFlags_BordersInnerH;
  if (!d.parameters.empty() && ImGui::BeginTable("##parameters", 4, flags)) {
    ImGui::TableSetupColumn("name");
    ImGui::TableSetupColumn("start");
    ImGui::TableSetupColumn("lower");
    ImGui::TableSetupColumn("upper");
    ImGui::TableHeadersRow();
    auto bound = [](const std::optional<double>& x) {
      return x ? FormatSig(*x, 4) : std::string("\xE2\x80\x94");
    };
    for (const model::Parameter& p : d.parameters) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(p.name.c_str());
      if (!p.description.empty() && ImGui::IsItemHovered())
        ImGui::SetTooltip("%s", p.description.c_str());
      ImGui::TableNextColumn();
      ImGui::Text("%s%s", FormatSig(p.value, 4).c_str(), p.fixed ? " (fixed)" : "");
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(bound(p.lower).c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(bound(p.upper).c_str());
    }
    ImGui::EndTable();
  }
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextDisabled("Start values and bounds are edited in the Parameters view.");
  ImGui::PopTextWrapPos();
  ImGui::Spacing();
  ImGui::TextUnformatted("Add a parameter");
  const float w = (ImGui::GetContentRegionAvail().x - 3 * ImGui::GetStyle().ItemSpacing.x) / 4;
  ImGui::SetNextItemWidth(w);
  ImGui::InputTextWithHint("##new_name", "name", &v.new_parameter_name);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(w);
  ImGui::InputTextWithHint("##new_value", "start", &v.new_parameter_value);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(w);
  ImGui::InputTextWithHint("##new_lower", "lower", &v.new_parameter_lower);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(w);
  ImGui::InputTextWithHint("##new_upper", "upper", &v.new_parameter_upper);
  if (ImGui::Button("Add parameter")) {
    bool ok_value = true, ok_lower = true, ok_upper = true;
    model::Parameter p;
    p.name = v.new_parameter_name;
    const std::optional<double> value = ParseNumber(v.new_parameter_value, &ok_value);
    p.lower = ParseNumber(v.new_parameter_lower, &ok_lower);
    p.upper = ParseNumber(v.new_parameter_upper, &ok_upper);
    if (!value || !ok_value || !ok_lower || !ok_upper) {
      v.refusal = DiagramRefusal{DiagramEditKind::kSetParameter, 0, "parameter", "",
                                 "the start value must be a number; the bounds numbers or empty"};
    } else {
      p.value = *value;
      DiagramEdit e;
      e.kind = DiagramEditKind::kSetParameter;
      e.parameter = p;
      e.field = "parameter";
      Emit(state, std::move(e));
      v.new_parameter_name.clear();
      v.new_parameter_value.clear();
      v.new_parameter_lower.clear();
      v.new_parameter_upper.clear();
    }
  }
  if (IsRefused(v, 0, "parameter"))
    ImGui::TextColored(SeverityColor(Severity::kError), "%s", v.refusal->reason.c_str());
}

void DrawProblems(AppState& state) {
  DiagramViewState& v = state.diagram_view;
  if (v.problems.empty()) return;
  SectionHeading(state, "Problems");
  ImGui::PushStyleColor(ImGuiCol_Text, kErrorText);
  for (std::size_t i = 0; i < v.problems.size(); ++i) {
    const diagram::Problem& p = v.problems[i];
    ImGui::PushID(static_cast<int>(i));
    ImGui::PushTextWrapPos(0.0f);
    const std::string text = p.ToString();
    if (ImGui::Selectable(text.c_str(), p.block != 0 && v.editor.IsSelected(p.block)) &&
        p.block != 0)
      v.editor.Select(p.block);
    ImGui::PopTextWrapPos();
    ImGui::PopID();
  }
  ImGui::PopStyleColor();
}

void DrawInspector(AppState& state) {
  DiagramViewState& v = state.diagram_view;
  const diagram::BlockDiagram& d = *v.diagram;
  const node_editor::EditorContext& ctx = v.editor;
  if (ctx.selected_blocks.size() == 1 && d.FindBlock(ctx.selected_blocks[0])) {
    DrawBlockInspector(state, *d.FindBlock(ctx.selected_blocks[0]));
  } else if (ctx.selected_blocks.size() > 1) {
    ImGui::Text("%zu blocks selected", ctx.selected_blocks.size());
    ImGui::TextDisabled("Drag one of them to move them together; Del deletes them.");
  } else if (ctx.selected_links.size() == 1 && d.FindLink(ctx.selected_links[0])) {
    const diagram::Link& l = *d.FindLink(ctx.selected_links[0]);
    ImGui::Text("Link %d: block %d out-port %d \xE2\x86\x92 block %d in-port %d", l.id,
                l.from.block, l.from.index, l.to.block, l.to.index);
    if (ImGui::Button("Delete link")) {
      DiagramEdit e;
      e.kind = DiagramEditKind::kDisconnect;
      e.id = l.id;
      Emit(state, std::move(e));
    }
  } else {
    ImGui::PushFont(state.fonts.bold);
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextUnformatted(d.name.empty() ? "Diagram" : d.name.c_str());
    ImGui::PopTextWrapPos();
    ImGui::PopFont();
    ImGui::TextDisabled("%zu blocks, %zu links.", d.blocks.size(), d.links.size());
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextDisabled(
        "Click a block to edit its name and fields. Drag from an out-port (right edge) to an "
        "in-port (left edge) to link them. Wheel: zoom; middle drag or space + drag: pan; drag "
        "on empty canvas: select a box (shift or ctrl adds); Del or right click: delete.");
    ImGui::PopTextWrapPos();
  }
  DrawProblems(state);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 5. DrawDiagramPanel

void DrawDiagramPanel(AppState& state) {
  if (DrawNoProjectNotice(state)) return;
  DiagramViewState& v = state.diagram_view;
  if (!v.diagram) {
    DrawNotice(state, "No diagram to show",
               v.error.empty() ? std::string("The project has no valid model to draw.") : v.error,
               Severity::kError);
    return;
  }
  const float s = state.fonts.scale;
  DrawToolbar(state);
  HandleShortcuts(state);
  ImGui::Spacing();

  // The canvas takes the width (diagrams read left to right); the inspector sits below it.
  const ImGuiStyle& style = ImGui::GetStyle();
  const float inspector_h = kInspectorHeight * s;
  const float canvas_h = std::max(
      kMinCanvasHeight * s, ImGui::GetContentRegionAvail().y - inspector_h - style.ItemSpacing.y);
  ImGui::BeginChild("##palette", ImVec2(kPaletteWidth * s, canvas_h), false);
  DrawPalette(state);
  ImGui::EndChild();
  ImGui::SameLine();

  node_editor::Options options;
  options.problems = &v.problems;
  options.scale = s;
  options.font = state.fonts.regular;
  options.draw_font = state.fonts.canvas;
  node_editor::NodeEditor(v.editor, "##canvas", ImVec2(0, canvas_h), *v.diagram, options,
                          &v.pending);
  AskForCanvasFont(state);

  ImGui::BeginChild("##inspector", ImVec2(0, 0), false);
  if (ImGui::BeginTable("##inspector_columns", 2, ImGuiTableFlags_BordersInnerV)) {
    ImGui::TableSetupColumn("selection", ImGuiTableColumnFlags_WidthStretch, 0.55f);
    ImGui::TableSetupColumn("parameters", ImGuiTableColumnFlags_WidthStretch, 0.45f);
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    DrawInspector(state);
    ImGui::TableNextColumn();
    DrawParameters(state);
    ImGui::EndTable();
  }
  ImGui::EndChild();

  ApplyDiagramEdits(state);
}

}  // namespace gb::ui
