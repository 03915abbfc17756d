// The equations view: the model as written in its JSON (user guide §2). Its formulas
// (drift, diffusion, observation, measurement variance, initial state) are edited in place:
// every keystroke is validated by core (the same parser as the model file), a refused formula
// is kept as a draft with the parser's reason and a caret at the column, and a valid formula is
// applied when the field is left (Enter, Tab or a click elsewhere). The view shows the text as
// the user wrote it, whether or not the model compiles: the equations are the user's words, and
// a mistake is easier to spot here than in the raw file. A model that does not compile, or one
// drawn as a block diagram (edited in the Diagram view), is shown read-only.
//
// The structure is edited here too (ui/state/equations_view.h): the model's name, its states,
// inputs, outputs and parameters (add, rename, delete; a parameter's unit, description and
// prior), the input hold and the initial covariance. A rename or a new name is applied when its
// field is left; a refused one keeps what was typed, with the reason beside it. A formula
// refused for an unknown name offers to create the parameter. Undo and redo (the toolbar,
// Ctrl+Z, Ctrl+Y) cover every edit made in this view. The JSON pane shows the model file the
// edits make; it is not edited.
//
// Sections: 1. helpers  2. editing (formula fields, structure fields, refusals)  3. sections
//           (toolbar, variables, equations, parameters, options)  4. DrawEquationsPanel
#include <algorithm>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <imgui.h>
#include <imgui_stdlib.h>

#include "core/model/linear_model.h"
#include "core/util/json.h"
#include "ui/panels/common.h"
#include "ui/panels/panels.h"
#include "ui/state/equations_view.h"

namespace gb::ui {
namespace {

using ModelJson = decltype(project::Project::model_json);

// A JSON value as text: strings as they are, anything else in JSON notation.
std::string Text(const ModelJson& v) {
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

const ModelJson* Member(const ModelJson& object, const char* key) {
  if (!object.is_object()) return nullptr;
  const auto it = object.find(key);
  return it == object.end() ? nullptr : &*it;
}

std::string MemberText(const ModelJson& object, const char* key, const char* absent) {
  const ModelJson* v = Member(object, key);
  return v ? Text(*v) : absent;
}

std::vector<std::string> Names(const ModelJson& model, const char* key) {
  std::vector<std::string> names;
  const ModelJson* list = Member(model, key);
  if (!list || !list->is_array()) return names;
  for (const ModelJson& v : *list) names.push_back(Text(v));
  return names;
}

std::string Join(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out.empty() ? "\xE2\x80\x94" : out;
}

void MonoLine(AppState& state, const std::string& text) {
  ImGui::PushFont(state.fonts.mono);
  ImGui::TextUnformatted(text.c_str());
  ImGui::PopFont();
}

// ---------------------------------------------------------------------------------------------
// Editing

// Whether the formulas can be edited here, and if not, why (shown under the title).
bool Editable(const AppState& state, std::string* why) {
  if (!state.model) {
    *why = "The model does not compile, so it is shown as written; correct the file and reload.";
    return false;
  }
  if (state.diagram_view.model_from_diagram) {
    *why = "This model is drawn as a block diagram: edit it in the Diagram view.";
    return false;
  }
  *why =
      "Edit a formula or a name in place: a formula is checked as you type; both are applied "
      "when you leave the field. Ctrl+Z undoes, Ctrl+Y redoes.";
  return true;
}

// Validates what is being typed into the formula at `path` (a draft the model refuses keeps
// its reason until it is corrected).
void Validate(AppState& state, const std::string& path, const std::string& text) {
  FormulaDraft& draft = state.equations_view.drafts[path];
  draft.text = text;
  Result<model::ModelSpec> edited = ApplyFormulaEdit(*state.model, FormulaEdit{path, text});
  if (edited) {
    draft.error.reset();
  } else {
    draft.error = edited.error();
  }
}

// One formula: a field when the view is editable, else the text. `width` in pixels.
void FormulaField(AppState& state, bool editable, const std::string& path,
                  const std::string& current, float width) {
  if (!editable) {
    ImGui::PushFont(state.fonts.mono);
    ImGui::TextUnformatted(current.c_str());
    ImGui::PopFont();
    return;
  }
  EquationsViewState& v = state.equations_view;
  const auto it = v.drafts.find(path);
  const bool has_draft = it != v.drafts.end();
  std::string text = has_draft ? it->second.text : current;
  const bool refused = has_draft && it->second.error;
  ImGui::PushID(path.c_str());
  ImGui::PushFont(state.fonts.mono);
  ImGui::SetNextItemWidth(width);
  if (refused) {
    ImGui::PushStyleColor(ImGuiCol_Border, SeverityColor(Severity::kError));
    ImGui::PushStyleVar(ImGuiStyleVar_FrameBorderSize, 1.5f * state.fonts.scale);
  }
  if (ImGui::InputText("##formula", &text)) {
    if (text == current) {
      v.drafts.erase(path);
    } else {
      Validate(state, path, text);
    }
  }
  if (refused) {
    ImGui::PopStyleVar();
    ImGui::PopStyleColor();
  }
  ImGui::PopFont();
  if (ImGui::IsItemDeactivated()) {
    const auto d = v.drafts.find(path);
    if (d != v.drafts.end() && !d->second.error) v.pending.push_back({path, d->second.text});
  }
  if (has_draft && ImGui::IsItemHovered()) {
    ImGui::SetTooltip("Model file: %s", current.c_str());
  }
  ImGui::PopID();
}

// Under a refused formula: the text with a caret at the column, and the reason.
void DrawDraftError(AppState& state, const std::string& path, float indent) {
  const auto it = state.equations_view.drafts.find(path);
  if (it == state.equations_view.drafts.end() || !it->second.error) return;
  const Error& e = *it->second.error;
  const ImVec4 red = SeverityColor(Severity::kError);
  ImGui::Indent(indent);
  if (e.expr_col > 0 && e.path == path) {
    ImGui::PushFont(state.fonts.mono);
    ImGui::PushStyleColor(ImGuiCol_Text, red);
    ImGui::TextUnformatted(it->second.text.c_str());
    ImGui::TextUnformatted(
        (std::string(static_cast<std::size_t>(e.expr_col - 1), ' ') + "^").c_str());
    ImGui::PopStyleColor();
    ImGui::PopFont();
  }
  std::string where = e.path;
  if (e.expr_col > 0) where += ", column " + std::to_string(e.expr_col);
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextColored(red, "%s: %s", where.c_str(), e.message.c_str());
  ImGui::PopTextWrapPos();
  ImGui::PushID(path.c_str());
  if (const std::optional<std::string> unknown = UnknownName(e)) {
    const std::string label = "Create parameter '" + *unknown + "'";
    if (ImGui::SmallButton(label.c_str())) {
      StructureEdit edit;
      edit.kind = StructureEditKind::kAddParameter;
      edit.parameter.name = *unknown;
      edit.parameter.value = 1.0;
      edit.control = path;
      state.equations_view.structure_pending.push_back(std::move(edit));
    }
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "A free parameter starting at 1, without bounds; set its start value and "
          "bounds in the Parameters view");
    ImGui::SameLine();
  }
  if (ImGui::SmallButton("Revert")) state.equations_view.drafts.erase(path);
  ImGui::PopID();
  ImGui::SameLine();
  ImGui::TextDisabled("back to the model's formula");
  ImGui::Unindent(indent);
}

// The width of a button (or a small button) labelled `label`.
float ButtonWidth(const char* label) {
  return ImGui::CalcTextSize(label, nullptr, true).x + 2.0f * ImGui::GetStyle().FramePadding.x;
}

// After SameLine(): goes to the next line when an item `width` wide does not fit on this one.
void WrapUnlessFits(float width) {
  if (ImGui::GetContentRegionAvail().x < width) ImGui::NewLine();
}

// A text field of the structure (a name, a unit, a description) showing `current`. What is
// typed is kept in equations_view.typing until an edit made of it is accepted; returns it when
// the field is left with a text other than `current`.
std::optional<std::string> StructureField(AppState& state, const std::string& control,
                                          const std::string& current, float width,
                                          const char* hint = "") {
  EquationsViewState& v = state.equations_view;
  const auto it = v.typing.find(control);
  std::string text = it != v.typing.end() ? it->second : current;
  const bool refused = v.refusal && v.refusal->control == control;
  ImGui::PushID(control.c_str());
  ImGui::SetNextItemWidth(width);
  if (refused) {
    ImGui::PushStyleColor(ImGuiCol_Border, SeverityColor(Severity::kError));
    ImGui::PushStyleVar(ImGuiStyleVar_FrameBorderSize, 1.5f * state.fonts.scale);
  }
  if (ImGui::InputTextWithHint("##field", hint, &text)) v.typing[control] = text;
  if (refused) {
    ImGui::PopStyleVar();
    ImGui::PopStyleColor();
  }
  std::optional<std::string> left;
  if (ImGui::IsItemDeactivated()) {
    const auto t = v.typing.find(control);
    if (t != v.typing.end()) {
      if (t->second == current) {
        v.typing.erase(t);
        if (refused) v.refusal.reset();
      } else {
        left = t->second;
      }
    }
  }
  ImGui::PopID();
  return left;
}

void EmitStructureEdit(AppState& state, StructureEdit edit) {
  state.equations_view.structure_pending.push_back(std::move(edit));
}

// The reason an edit from `control` (or, with `prefix`, any control starting so) was refused,
// with a button that drops what was typed.
void DrawStructureRefusal(AppState& state, const std::string& control, bool prefix = false) {
  EquationsViewState& v = state.equations_view;
  if (!v.refusal) return;
  const std::string& c = v.refusal->control;
  if (prefix ? c.rfind(control, 0) != 0 : c != control) return;
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextColored(SeverityColor(Severity::kError), "%s", v.refusal->reason.c_str());
  ImGui::PopTextWrapPos();
  ImGui::PushID(("revert." + c).c_str());
  if (ImGui::SmallButton("Revert")) {
    v.typing.erase(c);
    v.refusal.reset();
  }
  ImGui::PopID();
  ImGui::SameLine();
  ImGui::TextDisabled("drop what was typed");
}

// "label" in the monospaced font, then the next item on the same line.
void MonoLabel(AppState& state, const std::string& text) {
  ImGui::AlignTextToFramePadding();
  ImGui::PushFont(state.fonts.mono);
  ImGui::TextUnformatted(text.c_str());
  ImGui::PopFont();
  ImGui::SameLine();
}

// ---------------------------------------------------------------------------------------------
// Sections

// The toolbar: undo and redo of the view's edits, and their shortcuts.
void DrawEquationsToolbar(AppState& state) {
  EquationsViewState& v = state.equations_view;
  UndoRedoButtons(!v.undo.empty(), !v.redo.empty(), &v.undo_requested, &v.redo_requested);
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("Model name");
  ImGui::SameLine();
  const std::string name = state.project->model_json.value("name", std::string());
  if (auto typed = StructureField(state, "model.name", name, 320.0f * state.fonts.scale,
                                  "(unnamed model)")) {
    StructureEdit e;
    e.kind = StructureEditKind::kModelName;
    e.text = *typed;
    e.control = "model.name";
    EmitStructureEdit(state, std::move(e));
  }
  DrawStructureRefusal(state, "model.name");
  const ImGuiIO& io = ImGui::GetIO();
  if (!io.KeyCtrl || io.WantTextInput) return;
  const bool z = ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Z), false);
  const bool y = ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Y), false);
  if (z && !io.KeyShift) v.undo_requested = true;
  if (y || (z && io.KeyShift)) v.redo_requested = true;
}

// States, inputs and outputs: a field per name (rename), Delete, and a field to add one.
void DrawEditableVariables(AppState& state, const ModelJson& model) {
  SectionHeading(state, "Variables");
  const float s = state.fonts.scale;
  const model::NameKind kinds[] = {model::NameKind::kState, model::NameKind::kInput,
                                   model::NameKind::kOutput};
  const char* labels[] = {"States x", "Inputs u", "Outputs y"};
  for (int i = 0; i < 3; ++i) {
    const model::NameKind kind = kinds[i];
    const std::string what = model::NameKindText(kind);
    ImGui::AlignTextToFramePadding();
    ImGui::TextDisabled("%s", labels[i]);
    ImGui::SameLine(110.0f * s);
    ImGui::BeginGroup();
    for (const std::string& name : model::NamesOf(model, kind)) {
      const std::string control = "rename." + what + "." + name;
      ImGui::PushFont(state.fonts.mono);
      const std::optional<std::string> typed = StructureField(state, control, name, 110.0f * s);
      ImGui::PopFont();
      if (typed) {
        StructureEdit e;
        e.kind = StructureEditKind::kRename;
        e.what = kind;
        e.name = name;
        e.text = *typed;
        e.control = control;
        EmitStructureEdit(state, std::move(e));
      }
      ImGui::SameLine(0, 2.0f * s);
      ImGui::PushID(("delete." + what + "." + name).c_str());
      if (ImGui::SmallButton("Delete")) {
        StructureEdit e;
        e.kind = StructureEditKind::kDelete;
        e.what = kind;
        e.name = name;
        e.control = "delete." + what + "." + name;
        EmitStructureEdit(state, std::move(e));
      }
      if (ImGui::IsItemHovered())
        ImGui::SetTooltip("Delete the %s '%s'%s", what.c_str(), name.c_str(),
                          kind == model::NameKind::kInput ? "" : " and its own formulas");
      ImGui::PopID();
      ImGui::SameLine(0, 12.0f * s);
      WrapUnlessFits(110.0f * s + ButtonWidth("Delete"));
    }
    const std::string add = "add." + what;
    WrapUnlessFits(110.0f * s + ButtonWidth(("Add " + what).c_str()));
    ImGui::SetNextItemWidth(110.0f * s);
    std::string& typing = state.equations_view.typing[add];
    ImGui::PushID(add.c_str());
    ImGui::PushFont(state.fonts.mono);
    const bool enter = ImGui::InputTextWithHint("##field", ("new " + what).c_str(), &typing,
                                                ImGuiInputTextFlags_EnterReturnsTrue);
    ImGui::PopFont();
    ImGui::PopID();
    ImGui::SameLine();
    if (ImGui::Button(("Add " + what).c_str()) || enter) {
      StructureEdit e;
      e.kind = StructureEditKind::kAdd;
      e.what = kind;
      e.name = typing;
      e.control = add;
      EmitStructureEdit(state, std::move(e));
    }
    DrawStructureRefusal(state, "rename." + what + ".", true);
    DrawStructureRefusal(state, "delete." + what + ".", true);
    DrawStructureRefusal(state, add);
    ImGui::EndGroup();
  }
}

void DrawVariables(AppState& state, const ModelJson& model) {
  SectionHeading(state, "Variables");
  const char* labels[] = {"States x", "Inputs u", "Outputs y"};
  const char* keys[] = {"states", "inputs", "outputs"};
  if (!ImGui::BeginTable("##variables", 2, ImGuiTableFlags_SizingFixedFit)) return;
  for (int i = 0; i < 3; ++i) {
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextDisabled("%s", labels[i]);
    ImGui::TableNextColumn();
    MonoLine(state, Join(Names(model, keys[i])));
  }
  ImGui::EndTable();
}

void DrawSystemEquations(AppState& state, const ModelJson& model, bool editable) {
  SectionHeading(
      state,
      "System equations   dx = f(x, u, \xCE\xB8, t) dt + \xCF\x83(x, u, \xCE\xB8, t) d\xCF\x89");
  const ModelJson empty = ModelJson::object();
  const ModelJson* drift = Member(model, "drift");
  const ModelJson* diffusion = Member(model, "diffusion");
  const std::vector<std::string> states = Names(model, "states");
  if (states.empty()) ImGui::TextDisabled("The model names no states.");
  const float s = state.fonts.scale;
  for (const std::string& x : states) {
    const std::string f = MemberText(drift ? *drift : empty, x.c_str(), "(no drift given)");
    const std::string g = MemberText(diffusion ? *diffusion : empty, x.c_str(), "0");
    const float avail = ImGui::GetContentRegionAvail().x;
    MonoLabel(state, "d" + x + " = (");
    FormulaField(state, editable, "drift." + x, f, std::max(120.0f * s, 0.55f * avail));
    ImGui::SameLine();
    MonoLabel(state, ") dt +");
    FormulaField(state, editable, "diffusion." + x, g, std::max(80.0f * s, 0.18f * avail));
    ImGui::SameLine();
    MonoLabel(state, "d\xCF\x89_" + x);
    ImGui::NewLine();
    DrawDraftError(state, "drift." + x, 0.0f);
    DrawDraftError(state, "diffusion." + x, 0.0f);
  }
}

void DrawObservationEquations(AppState& state, const ModelJson& model, bool editable) {
  SectionHeading(state, "Observation equations   y_k = h(x_k, u_k, \xCE\xB8, t_k) + e_k");
  const ModelJson empty = ModelJson::object();
  const ModelJson* h = Member(model, "observation");
  const ModelJson* var = Member(model, "measurement_variance");
  const ModelJson* delay = Member(model, "output_delay");
  const std::vector<std::string> outputs = Names(model, "outputs");
  if (outputs.empty()) ImGui::TextDisabled("The model names no outputs.");
  const float s = state.fonts.scale;
  for (const std::string& o : outputs) {
    const float avail = ImGui::GetContentRegionAvail().x;
    MonoLabel(state, o + "_k =");
    FormulaField(state, editable, "observation." + o,
                 MemberText(h ? *h : empty, o.c_str(), "(no observation given)"),
                 std::max(120.0f * s, 0.30f * avail));
    ImGui::SameLine();
    MonoLabel(state, "+ e_k,   e_k ~ N(0,");
    FormulaField(state, editable, "measurement_variance." + o,
                 MemberText(var ? *var : empty, o.c_str(), "(no variance given)"),
                 std::max(80.0f * s, 0.12f * avail));
    ImGui::SameLine();
    std::string tail = ")";
    if (const ModelJson* d = delay ? Member(*delay, o.c_str()) : nullptr) {
      if (d->is_object()) {
        tail += "   delay " + MemberText(*d, "min", "?") + " \xE2\x80\xA6 " +
                MemberText(*d, "max", "?") + " samples (estimated)";
      } else {
        tail += "   delay " + Text(*d) + " samples";
      }
    }
    MonoLabel(state, tail);
    ImGui::NewLine();
    DrawDraftError(state, "observation." + o, 0.0f);
    DrawDraftError(state, "measurement_variance." + o, 0.0f);
  }
}

void DrawParameters(AppState& state, const ModelJson& model) {
  SectionHeading(state, "Parameters");
  const ModelJson* params = Member(model, "parameters");
  if (!params || !params->is_object() || params->empty()) {
    ImGui::TextDisabled("The model has no parameters.");
    return;
  }
  const ImGuiTableFlags flags = ImGuiTableFlags_BordersOuter | ImGuiTableFlags_BordersInnerH |
                                ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingFixedFit;
  if (!ImGui::BeginTable("##parameters", 7, flags)) return;
  for (const char* h : {"Name", "Value", "Lower", "Upper", "Fixed", "Unit"})
    ImGui::TableSetupColumn(h);
  ImGui::TableSetupColumn("Description", ImGuiTableColumnFlags_WidthStretch);
  ImGui::TableHeadersRow();
  for (auto it = params->begin(); it != params->end(); ++it) {
    const ModelJson& p = it.value();
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    MonoLine(state, it.key());
    if (!p.is_object()) {
      ImGui::TableNextColumn();
      ImGui::TextColored(SeverityColor(Severity::kError), "%s (expected an object)",
                         Text(p).c_str());
      continue;
    }
    for (const char* key : {"value", "lower", "upper"}) {
      ImGui::TableNextColumn();
      if (const ModelJson* v = Member(p, key)) {
        ImGui::TextUnformatted(Text(*v).c_str());
      } else {
        ImGui::TextDisabled("\xE2\x80\x94");
      }
    }
    ImGui::TableNextColumn();
    const ModelJson* fixed = Member(p, "fixed");
    const bool is_fixed = fixed && fixed->is_boolean() && fixed->get<bool>();
    if (is_fixed) {
      ImGui::TextUnformatted("fixed");
    } else {
      ImGui::TextDisabled("free");
    }
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(MemberText(p, "unit", "").c_str());
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(MemberText(p, "description", "").c_str());
  }
  ImGui::EndTable();
}

std::string NumberText(const std::optional<double>& v) {
  return v ? fmt::format("{:g}", *v) : std::string();
}

// The prior's two fields: a change to either is emitted when its field is left.
void PriorFields(AppState& state, const model::Parameter& p, float width) {
  EquationsViewState& v = state.equations_view;
  const std::string control = "prior." + p.name;
  const std::string mean = p.prior ? fmt::format("{:g}", p.prior->mean) : "";
  const std::string sd = p.prior ? fmt::format("{:g}", p.prior->sd) : "";
  const std::optional<std::string> m =
      StructureField(state, control + ".mean", mean, width, "mean");
  ImGui::SameLine(0, 2.0f * state.fonts.scale);
  const std::optional<std::string> d = StructureField(state, control + ".sd", sd, width, "sd");
  if (!m && !d) return;
  auto typed = [&](const std::string& key, const std::string& current) {
    const auto it = v.typing.find(control + key);
    return it != v.typing.end() ? it->second : current;
  };
  Result<std::optional<model::Parameter::Prior>> prior =
      ParsePrior(typed(".mean", mean), typed(".sd", sd));
  const std::string from = control + (m ? ".mean" : ".sd");
  if (!prior) {
    v.refusal = StructureRefusal{from, prior.error().message};
    return;
  }
  StructureEdit e;
  e.kind = StructureEditKind::kParameterPrior;
  e.name = p.name;
  e.prior = *prior;
  e.control = from;
  EmitStructureEdit(state, std::move(e));
}

// The parameters: name (rename), start and bounds (edited in the Parameters view), unit,
// description and prior, Delete; and a row to add one.
void DrawEditableParameters(AppState& state) {
  SectionHeading(state, "Parameters");
  EquationsViewState& v = state.equations_view;
  const float s = state.fonts.scale;
  const model::ModelSpec& spec = *state.model;
  const ImGuiTableFlags flags = ImGuiTableFlags_BordersOuter | ImGuiTableFlags_BordersInnerH |
                                ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingFixedFit;
  if (!spec.parameters.empty() && ImGui::BeginTable("##parameters", 9, flags)) {
    for (const char* h : {"Name", "Value", "Lower", "Upper", "Fixed", "Unit"})
      ImGui::TableSetupColumn(h);
    ImGui::TableSetupColumn("Description", ImGuiTableColumnFlags_WidthStretch);
    ImGui::TableSetupColumn("Prior N(mean, sd\xC2\xB2)");
    ImGui::TableSetupColumn("");
    ImGui::TableHeadersRow();
    for (const model::Parameter& p : spec.parameters) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::PushFont(state.fonts.mono);
      if (auto typed = StructureField(state, "rename.parameter." + p.name, p.name, 110.0f * s)) {
        StructureEdit e;
        e.kind = StructureEditKind::kRename;
        e.what = model::NameKind::kParameter;
        e.name = p.name;
        e.text = *typed;
        e.control = "rename.parameter." + p.name;
        EmitStructureEdit(state, std::move(e));
      }
      ImGui::PopFont();
      for (const std::string& number :
           {fmt::format("{:g}", p.value), NumberText(p.lower), NumberText(p.upper)}) {
        ImGui::TableNextColumn();
        ImGui::AlignTextToFramePadding();
        if (number.empty()) {
          ImGui::TextDisabled("\xE2\x80\x94");
        } else {
          ImGui::TextUnformatted(number.c_str());
        }
        if (ImGui::IsItemHovered()) ImGui::SetTooltip("Edited in the Parameters view");
      }
      ImGui::TableNextColumn();
      ImGui::AlignTextToFramePadding();
      if (p.fixed) {
        ImGui::TextUnformatted("fixed");
      } else {
        ImGui::TextDisabled("free");
      }
      ImGui::TableNextColumn();
      if (auto typed = StructureField(state, "unit." + p.name, p.unit, 70.0f * s)) {
        StructureEdit e;
        e.kind = StructureEditKind::kParameterUnit;
        e.name = p.name;
        e.text = *typed;
        e.control = "unit." + p.name;
        EmitStructureEdit(state, std::move(e));
      }
      ImGui::TableNextColumn();
      if (auto typed = StructureField(state, "description." + p.name, p.description,
                                      std::max(160.0f * s, ImGui::GetContentRegionAvail().x))) {
        StructureEdit e;
        e.kind = StructureEditKind::kParameterDescription;
        e.name = p.name;
        e.text = *typed;
        e.control = "description." + p.name;
        EmitStructureEdit(state, std::move(e));
      }
      ImGui::TableNextColumn();
      PriorFields(state, p, 60.0f * s);
      ImGui::TableNextColumn();
      ImGui::PushID(("delete.parameter." + p.name).c_str());
      if (ImGui::SmallButton("Delete")) {
        StructureEdit e;
        e.kind = StructureEditKind::kDelete;
        e.what = model::NameKind::kParameter;
        e.name = p.name;
        e.control = "delete.parameter." + p.name;
        EmitStructureEdit(state, std::move(e));
      }
      ImGui::PopID();
    }
    ImGui::EndTable();
  } else if (spec.parameters.empty()) {
    ImGui::TextDisabled("The model has no parameters.");
  }
  for (const char* prefix :
       {"rename.parameter.", "delete.parameter.", "unit.", "description.", "prior."})
    DrawStructureRefusal(state, prefix, true);

  // A new parameter: name, start value, bounds, unit, description.
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("New parameter");
  const char* fields[] = {"name", "value", "lower", "upper", "unit", "description"};
  const float widths[] = {110.0f, 70.0f, 70.0f, 70.0f, 70.0f, 200.0f};
  for (int i = 0; i < 6; ++i) {
    ImGui::SameLine();
    const std::string control = std::string("new_parameter.") + fields[i];
    // The description takes what the row leaves beside the button (the row fits at 1024 px).
    float width = widths[i] * s;
    if (i == 5) {
      const float left = ImGui::GetContentRegionAvail().x - ButtonWidth("Add parameter") -
                         ImGui::GetStyle().ItemSpacing.x;
      width = std::max(100.0f * s, std::min(width, left));
    }
    WrapUnlessFits(width);
    ImGui::SetNextItemWidth(width);
    ImGui::PushID(control.c_str());
    ImGui::InputTextWithHint("##field", fields[i], &v.typing[control]);
    ImGui::PopID();
  }
  ImGui::SameLine();
  if (ImGui::Button("Add parameter")) {
    auto typed = [&](const char* f) { return v.typing[std::string("new_parameter.") + f]; };
    StructureEdit e;
    e.kind = StructureEditKind::kAddParameter;
    e.control = "new_parameter.name";
    e.parameter.name = typed("name");
    e.parameter.unit = typed("unit");
    e.parameter.description = typed("description");
    const std::string value = typed("value");
    Result<ParameterEdit> start =
        ParseParameterEdit(e.parameter.name, ParameterField::kValue, value.empty() ? "1" : value);
    Result<ParameterEdit> lower =
        ParseParameterEdit(e.parameter.name, ParameterField::kLower, typed("lower"));
    Result<ParameterEdit> upper =
        ParseParameterEdit(e.parameter.name, ParameterField::kUpper, typed("upper"));
    if (!start || !lower || !upper) {
      const Error& why = !start ? start.error() : !lower ? lower.error() : upper.error();
      v.refusal = StructureRefusal{
          e.control, "cannot add parameter '" + e.parameter.name + "': " + why.message};
    } else {
      e.parameter.value = *start->number;
      e.parameter.lower = lower->number;
      e.parameter.upper = upper->number;
      EmitStructureEdit(state, std::move(e));
    }
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("Start value 1 when none is typed; an empty bound is no bound");
  DrawStructureRefusal(state, "new_parameter.name");
}

// Whether the model goes through the extended Kalman filter (checked once per revision).
bool IsNonlinear(AppState& state) {
  EquationsViewState& v = state.equations_view;
  if (v.checked_revision != state.model_revision) {
    v.checked_revision = state.model_revision;
    v.nonlinear = !model::LinearModel::Compile(*state.model);
  }
  return v.nonlinear;
}

// The EKF's options (the model file's "ekf" object, user guide 1a): the ODE solver, its
// tolerances and the iterated update. Edits go through ApplyFormulaEdit as formulas do.
void DrawEkfOptions(AppState& state, bool editable) {
  const float s = state.fonts.scale;
  const model::EkfOptions& o = state.model->ekf;
  SectionHeading(state, "Extended Kalman filter");
  // Label, then the control at a common indent (no table: the fields keep the IDs the formula
  // fields have, by their JSON path under the view).
  const float indent = 140.0f * s;
  auto label = [&](const char* text, const char* tip) {
    ImGui::AlignTextToFramePadding();
    ImGui::TextDisabled("%s", text);
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", tip);
    ImGui::SameLine(indent);
  };
  label("ODE solver",
        "How the moment equations are integrated between samples: auto (explicit, BDF where an "
        "interval is stiff), explicit (Dormand-Prince 5(4)) or bdf (SUNDIALS CVODE)");
  ImGui::BeginDisabled(!editable);
  ImGui::SetNextItemWidth(160.0f * s);
  if (ImGui::BeginCombo("##ode", model::OdeMethodName(o.method))) {
    for (const model::OdeMethod m :
         {model::OdeMethod::kAuto, model::OdeMethod::kExplicit, model::OdeMethod::kBdf}) {
      if (ImGui::Selectable(model::OdeMethodName(m), m == o.method) && m != o.method)
        state.equations_view.pending.push_back({"ekf.ode", model::OdeMethodName(m)});
    }
    ImGui::EndCombo();
  }
  ImGui::EndDisabled();
  label("Relative tolerance",
        "rtol of the moment equations (default 1e-8), each error against the moment's own size: "
        "sqrt(mean² + variance) for a state, the variance, sqrt(P_ii P_jj) for a covariance");
  FormulaField(state, editable, "ekf.rtol", fmt::format("{:g}", o.rtol), 160.0f * s);
  DrawDraftError(state, "ekf.rtol", 0.0f);
  label("Absolute tolerance",
        "atol of the moment equations, in the states' units and their squares (default 1e-10)");
  FormulaField(state, editable, "ekf.atol", fmt::format("{:g}", o.atol), 160.0f * s);
  DrawDraftError(state, "ekf.atol", 0.0f);
  label("Update passes",
        "1: the EKF; k > 1: the iterated EKF, the measurement update re-linearised k times");
  FormulaField(state, editable, "ekf.iterations", std::to_string(o.iterations), 160.0f * s);
  DrawDraftError(state, "ekf.iterations", 0.0f);
}

// The initial covariance and the input hold as choices (an explicit covariance with a variance
// formula per state), the Huber threshold as text.
void DrawEditableOptions(AppState& state, const ModelJson& model) {
  const float s = state.fonts.scale;
  const float indent = 140.0f * s;
  const model::ModelSpec& spec = *state.model;
  auto label = [&](const char* text, const char* tip) {
    ImGui::AlignTextToFramePadding();
    ImGui::TextDisabled("%s", text);
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", tip);
    ImGui::SameLine(indent);
  };
  label("Initial covariance",
        "P0: ctsm (a scaled identity, as CTSM), stationary (the stationary covariance of the "
        "linearised model), or explicit (a variance formula of parameters per state)");
  const char* modes[] = {"ctsm", "stationary", "explicit"};
  const model::InitialCovariance values[] = {model::InitialCovariance::kCtsm,
                                             model::InitialCovariance::kStationary,
                                             model::InitialCovariance::kExplicit};
  ImGui::SetNextItemWidth(160.0f * s);
  if (ImGui::BeginCombo("##initial_covariance", modes[static_cast<int>(spec.initial_covariance)])) {
    for (int i = 0; i < 3; ++i) {
      if (ImGui::Selectable(modes[i], values[i] == spec.initial_covariance) &&
          values[i] != spec.initial_covariance) {
        StructureEdit e;
        e.kind = StructureEditKind::kInitialCovariance;
        e.covariance = values[i];
        e.control = "initial_covariance";
        EmitStructureEdit(state, std::move(e));
      }
    }
    ImGui::EndCombo();
  }
  DrawStructureRefusal(state, "initial_covariance");
  if (spec.initial_covariance == model::InitialCovariance::kExplicit) {
    const ModelJson* p0 = Member(model, "initial_covariance");
    for (const std::string& x : spec.states) {
      const ModelJson* v = p0 ? Member(*p0, x.c_str()) : nullptr;
      ImGui::Indent(indent);
      MonoLabel(state, "var " + x + "(t0) =");
      FormulaField(state, true, "initial_covariance." + x, v ? Text(*v) : "1", 160.0f * s);
      DrawDraftError(state, "initial_covariance." + x, 0.0f);
      ImGui::Unindent(indent);
    }
  }
  label("Input hold",
        "How inputs are held between samples: zoh (constant over the interval) or foh (linear "
        "from one sample to the next)");
  const char* holds[] = {"zoh", "foh"};
  ImGui::SetNextItemWidth(160.0f * s);
  if (ImGui::BeginCombo("##input_hold", holds[static_cast<int>(spec.input_hold)])) {
    for (int i = 0; i < 2; ++i) {
      const auto hold = static_cast<model::InputHold>(i);
      if (ImGui::Selectable(holds[i], hold == spec.input_hold) && hold != spec.input_hold) {
        StructureEdit e;
        e.kind = StructureEditKind::kInputHold;
        e.hold = hold;
        e.control = "input_hold";
        EmitStructureEdit(state, std::move(e));
      }
    }
    ImGui::EndCombo();
  }
  DrawStructureRefusal(state, "input_hold");
  label("Robust (Huber c)", "Set in the model file");
  MonoLine(state, MemberText(model, "robust_huber", "off (Gaussian)"));
}

void DrawOptions(AppState& state, const ModelJson& model, bool editable) {
  SectionHeading(state, "Initial conditions and options");
  const std::vector<std::string> states = Names(model, "states");
  const ModelJson* x0 = Member(model, "initial_state");
  const float s = state.fonts.scale;
  for (const std::string& x : states) {
    const ModelJson* v = x0 ? Member(*x0, x.c_str()) : nullptr;
    MonoLabel(state, x + "(t0) =");
    FormulaField(state, editable, "initial_state." + x, v ? Text(*v) : "0", 160.0f * s);
    DrawDraftError(state, "initial_state." + x, 0.0f);
  }
  if (editable) {
    DrawEditableOptions(state, model);
  } else if (ImGui::BeginTable("##options", 2, ImGuiTableFlags_SizingFixedFit)) {
    auto row = [&](const char* label, const std::string& value) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextDisabled("%s", label);
      ImGui::TableNextColumn();
      MonoLine(state, value);
    };
    row("Initial covariance", MemberText(model, "initial_covariance", "ctsm (default)"));
    row("Input hold", MemberText(model, "input_hold", "zoh (default)"));
    row("Robust (Huber c)", MemberText(model, "robust_huber", "off (Gaussian)"));
    ImGui::EndTable();
  }
  if (state.model && IsNonlinear(state)) DrawEkfOptions(state, editable);
}

}  // namespace

void DrawEquationsPanel(AppState& state) {
  if (DrawNoProjectNotice(state)) return;
  const project::Project& project = *state.project;
  const ModelJson& model = project.model_json;

  ImGui::BeginChild("##equations", ImVec2(0, 0));
  ImGui::PushFont(state.fonts.bold);
  ImGui::TextUnformatted(MemberText(model, "name", "(unnamed model)").c_str());
  ImGui::PopFont();
  if (state.diagram_view.model_from_diagram) {
    ImGui::TextDisabled("The model is compiled from the block diagram of %s (Diagram view).",
                        FileName(project.path).c_str());
  } else {
    ImGui::TextDisabled("%s", project.model_path.empty() ? ("inline in " + project.path).c_str()
                                                         : project.model_path.c_str());
  }
  std::string why;
  const bool editable = Editable(state, &why);
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextDisabled("%s", why.c_str());
  ImGui::PopTextWrapPos();
  if (!model.is_object()) {
    DrawNotice(state, "The model is not a JSON object", Text(model), Severity::kError);
    ImGui::EndChild();
    return;
  }
  if (editable) {
    DrawEquationsToolbar(state);
    DrawEditableVariables(state, model);
  } else {
    DrawVariables(state, model);
  }
  DrawSystemEquations(state, model, editable);
  DrawObservationEquations(state, model, editable);
  if (editable) {
    DrawEditableParameters(state);
  } else {
    DrawParameters(state, model);
  }
  DrawOptions(state, model, editable);
  ImGui::Spacing();
  if (ImGui::CollapsingHeader("Model file (JSON, read-only: the file the edits above make)")) {
    ImGui::PushFont(state.fonts.mono);
    ImGui::TextUnformatted(model.dump(2).c_str());
    ImGui::PopFont();
  }
  ImGui::EndChild();
  ApplyEquationsEdits(state);
}

}  // namespace gb::ui
