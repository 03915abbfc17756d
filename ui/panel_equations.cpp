// The equations view: the model as written in its JSON (CONTRACT section 2), read-only. It shows
// the text as the user wrote it, whether or not the model compiles: the equations are the
// user's words, and a mistake is easier to spot here than in the raw file.
#include <string>
#include <vector>

#include "ui/panel_common.h"
#include "ui/panels.h"

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

void DrawSystemEquations(AppState& state, const ModelJson& model) {
  SectionHeading(state,
                 "System equations   dx = f(x, u, \xCE\xB8) dt + \xCF\x83(\xCE\xB8) d\xCF\x89");
  const ModelJson empty = ModelJson::object();
  const ModelJson* drift = Member(model, "drift");
  const ModelJson* diffusion = Member(model, "diffusion");
  const std::vector<std::string> states = Names(model, "states");
  if (states.empty()) ImGui::TextDisabled("The model names no states.");
  for (const std::string& s : states) {
    const std::string f = MemberText(drift ? *drift : empty, s.c_str(), "(no drift given)");
    const std::string g = MemberText(diffusion ? *diffusion : empty, s.c_str(), "0");
    MonoLine(state, "d" + s + " = (" + f + ") dt + " + g + " d\xCF\x89_" + s);
  }
}

void DrawObservationEquations(AppState& state, const ModelJson& model) {
  SectionHeading(state, "Observation equations   y_k = h(x_k, u_k, \xCE\xB8) + e_k");
  const ModelJson empty = ModelJson::object();
  const ModelJson* h = Member(model, "observation");
  const ModelJson* var = Member(model, "measurement_variance");
  const ModelJson* delay = Member(model, "output_delay");
  const std::vector<std::string> outputs = Names(model, "outputs");
  if (outputs.empty()) ImGui::TextDisabled("The model names no outputs.");
  for (const std::string& o : outputs) {
    std::string line = o +
                       "_k = " + MemberText(h ? *h : empty, o.c_str(), "(no observation given)") +
                       " + e_k,   e_k ~ N(0, " +
                       MemberText(var ? *var : empty, o.c_str(), "(no variance given)") + ")";
    if (const ModelJson* d = delay ? Member(*delay, o.c_str()) : nullptr) {
      if (d->is_object()) {
        line += "   delay " + MemberText(*d, "min", "?") + " \xE2\x80\xA6 " +
                MemberText(*d, "max", "?") + " samples (estimated)";
      } else {
        line += "   delay " + Text(*d) + " samples";
      }
    }
    MonoLine(state, line);
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

void DrawOptions(AppState& state, const ModelJson& model) {
  SectionHeading(state, "Initial conditions and options");
  const std::vector<std::string> states = Names(model, "states");
  const ModelJson* x0 = Member(model, "initial_state");
  std::string initial;
  for (const std::string& s : states) {
    const ModelJson* v = x0 ? Member(*x0, s.c_str()) : nullptr;
    initial += (initial.empty() ? "" : ",   ") + s + "(t0) = " + (v ? Text(*v) : "0");
  }
  if (!ImGui::BeginTable("##options", 2, ImGuiTableFlags_SizingFixedFit)) return;
  auto row = [&](const char* label, const std::string& value) {
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextDisabled("%s", label);
    ImGui::TableNextColumn();
    MonoLine(state, value);
  };
  row("Initial state", initial.empty() ? "\xE2\x80\x94" : initial);
  row("Initial covariance", MemberText(model, "initial_covariance", "ctsm (default)"));
  row("Input hold", MemberText(model, "input_hold", "zoh (default)"));
  row("Robust (Huber c)", MemberText(model, "robust_huber", "off (Gaussian)"));
  ImGui::EndTable();
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
    ImGui::TextDisabled("As written in the model file; the model is checked when it is compiled.");
  }
  if (!model.is_object()) {
    DrawNotice(state, "The model is not a JSON object", Text(model), Severity::kError);
    ImGui::EndChild();
    return;
  }
  DrawVariables(state, model);
  DrawSystemEquations(state, model);
  DrawObservationEquations(state, model);
  DrawParameters(state, model);
  DrawOptions(state, model);
  ImGui::Spacing();
  if (ImGui::CollapsingHeader("Model file (JSON)")) {
    ImGui::PushFont(state.fonts.mono);
    ImGui::TextUnformatted(model.dump(2).c_str());
    ImGui::PopFont();
  }
  ImGui::EndChild();
}

}  // namespace gb::ui
