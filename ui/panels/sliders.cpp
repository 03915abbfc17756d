// The sliders panel (user guide §6a): beside the Data, Predictions, Residuals and Parameters
// views, one slider per parameter of the project's "sliders" list. Moving one recomputes the
// analysis at the moved value (a what-if: the model and the fit are left alone), the curves of
// before kept faintly in the plots until the slider is released; under the sliders, the
// response's figures now (log L, one-step RMS, fit %, the residual verdict), each beside what
// it was when the drag began.
//
// Sections
//   1. One slider
//   2. The response's figures
//   3. DrawSlidersPanel
#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>
#include <imgui.h>
#include <imgui_internal.h>

#include "ui/format.h"
#include "ui/panels/analysis_view.h"
#include "ui/panels/common.h"
#include "ui/panels/panels.h"

namespace gb::ui {
namespace {

constexpr int kValueDigits = 4;

// ---------------------------------------------------------------------------------------------
// 1. One slider

// Name and value on one line (the value bold where moved), the slider under them, its range's
// ends under that. Returns false when the slider was removed.
bool DrawSlider(AppState& state, std::size_t index, const project::SliderSpec& spec) {
  const model::Parameter& p = state.model->parameters[index];
  const double base = SliderBaseValue(state, index);
  const SliderScale scale = SliderRange(p, base, spec);
  const auto moved = state.sliders.moved.find(p.name);
  const bool is_moved = moved != state.sliders.moved.end();
  double value = is_moved ? moved->second : base;

  ImGui::PushID(p.name.c_str());
  ImGui::AlignTextToFramePadding();
  ImGui::PushFont(state.fonts.mono);
  ImGui::TextUnformatted(p.name.c_str());
  ImGui::PopFont();
  if (ImGui::IsItemHovered()) {
    ImGui::SetTooltip("%s%sRange %s \xE2\x80\xA6 %s%s", p.description.c_str(),
                      p.description.empty() ? "" : "\n", FormatSig(scale.min, kValueDigits).c_str(),
                      FormatSig(scale.max, kValueDigits).c_str(), scale.log ? " (log scale)" : "");
  }
  ImGui::SameLine();
  const std::string shown = FormatSig(value, kValueDigits) + (p.unit.empty() ? "" : " " + p.unit);
  if (is_moved) {
    ImGui::PushFont(state.fonts.bold);
    ImGui::TextUnformatted(shown.c_str());
    ImGui::PopFont();
  } else {
    ImGui::TextDisabled("%s", shown.c_str());
  }
  bool keep = true;
  const float right = ImGui::GetContentRegionMax().x;
  const float close_w = ImGui::CalcTextSize("\xC3\x97").x + 2.0f * ImGui::GetStyle().FramePadding.x;
  if (is_moved) {
    const float back_w = ImGui::CalcTextSize("back").x + 2.0f * ImGui::GetStyle().FramePadding.x;
    ImGui::SameLine(right - close_w - back_w - ImGui::GetStyle().ItemSpacing.x);
    if (ImGui::SmallButton("back")) state.sliders.moved.erase(p.name);
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("Back to %s", FormatSig(base, kValueDigits + 2).c_str());
  }
  ImGui::SameLine(right - close_w);
  if (ImGui::SmallButton("\xC3\x97")) keep = false;
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("Remove the slider of %s", p.name.c_str());

  ImGui::SetNextItemWidth(-1.0f);
  ImGuiSliderFlags flags = ImGuiSliderFlags_AlwaysClamp | ImGuiSliderFlags_NoRoundToFormat;
  if (scale.log) flags |= ImGuiSliderFlags_Logarithmic;
  // ImGui's log scale treats values below 10^-(the format's decimals) as zero, so the format
  // carries enough decimals for the range's low end; its text is not drawn (the value is above).
  const int decimals =
      scale.log ? std::clamp(static_cast<int>(std::ceil(-std::log10(scale.min))) + 3, 3, 300) : 6;
  const std::string format = fmt::format("%.{}f", decimals);
  // (While Ctrl+click has made it a text field, the text is drawn.)
  const bool typing = ImGui::TempInputIsActive(ImGui::GetID("##slider"));
  ImGui::PushStyleColor(ImGuiCol_Text,
                        typing ? ImGui::GetColorU32(ImGuiCol_Text) : IM_COL32(0, 0, 0, 0));
  const bool changed = ImGui::SliderScalar("##slider", ImGuiDataType_Double, &value, &scale.min,
                                           &scale.max, format.c_str(), flags);
  ImGui::PopStyleColor();
  if (changed) MoveSlider(state, p.name, value);
  if (ImGui::IsItemActivated()) BeginSliderDrag(state);
  if (ImGui::IsItemDeactivated()) EndSliderDrag(state);
  if (ImGui::IsItemHovered() && !ImGui::IsItemActive())
    ImGui::SetTooltip("Drag to move %s; Ctrl+click to type a value", p.name.c_str());
  const std::string lo = FormatSig(scale.min, 3), hi = FormatSig(scale.max, 3);
  ImGui::TextDisabled("%s", lo.c_str());
  ImGui::SameLine(right - ImGui::CalcTextSize(hi.c_str()).x);
  ImGui::TextDisabled("%s", hi.c_str());
  ImGui::PopID();
  return keep;
}

// The parameters without a slider, to add one.
void DrawAddCombo(AppState& state) {
  const model::ModelSpec& m = *state.model;
  ImGui::SetNextItemWidth(-1.0f);
  if (!ImGui::BeginCombo("##add", "Add a slider\xE2\x80\xA6")) return;
  bool any = false;
  for (const model::Parameter& p : m.parameters) {
    if (SliderShown(state, p.name)) continue;
    any = true;
    if (ImGui::Selectable(p.name.c_str())) ShowSlider(state, p.name, true);
    if (ImGui::IsItemHovered() && !p.description.empty())
      ImGui::SetTooltip("%s", p.description.c_str());
  }
  if (!any) ImGui::TextDisabled("Every parameter has a slider");
  ImGui::EndCombo();
}

// ---------------------------------------------------------------------------------------------
// 2. The response's figures

void DrawVerdictText(const diagnose::ResidualDiagnostics& st) {
  ImGui::TextColored(ImGui::ColorConvertU32ToFloat4(VerdictColor(st)), "%s", VerdictWord(st));
}

// One row of the figures: its name, the value now and (while a drag is under way) before it.
void FigureRow(const char* name, double now, const double* before, int digits) {
  ImGui::TableNextRow();
  ImGui::TableNextColumn();
  ImGui::TextDisabled("%s", name);
  ImGui::TableNextColumn();
  ImGui::TextUnformatted(std::isfinite(now) ? FormatSig(now, digits).c_str() : "\xE2\x80\x94");
  if (!before) return;
  ImGui::TableNextColumn();
  if (std::isfinite(*before)) ImGui::TextDisabled("%s", FormatSig(*before, digits).c_str());
}

void DrawFigures(AppState& state) {
  const AnalysisState& a = state.analysis;
  if (!a.result) {
    ImGui::TextDisabled("Computing the response\xE2\x80\xA6");
    return;
  }
  const auto k = static_cast<std::size_t>(a.dataset);
  if (k >= a.result->datasets.size()) return;
  const DatasetAnalysis& d = a.result->datasets[k];
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextDisabled("%s%s", d.name.c_str(),
                      AnalysisRunning(state) ? " (computing\xE2\x80\xA6)" : "");
  ImGui::PopTextWrapPos();
  if (!d.error.empty()) {
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextColored(SeverityColor(Severity::kError), "%s", d.error.c_str());
    ImGui::PopTextWrapPos();
    return;
  }
  const DatasetAnalysis* g = nullptr;  // the ghost's figures of the same record
  if (state.sliders.ghost && k < state.sliders.ghost->datasets.size() &&
      state.sliders.ghost->datasets[k].outputs.size() == d.outputs.size())
    g = &state.sliders.ghost->datasets[k];
  constexpr ImGuiTableFlags kFlags =
      ImGuiTableFlags_SizingStretchProp | ImGuiTableFlags_NoSavedSettings;
  if (!ImGui::BeginTable("##figures", g ? 3 : 2, kFlags)) return;
  ImGui::TableSetupColumn("", ImGuiTableColumnFlags_WidthStretch, 1.1f);
  ImGui::TableSetupColumn("now", ImGuiTableColumnFlags_WidthStretch, 1.0f);
  if (g) {
    ImGui::TableSetupColumn("before", ImGuiTableColumnFlags_WidthStretch, 1.0f);
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TableNextColumn();
    ImGui::TextDisabled("now");
    ImGui::TableNextColumn();
    ImGui::TextDisabled("before");
  }
  if (d.n_obs > 0) FigureRow("log L", d.loglik, g ? &g->loglik : nullptr, 7);
  for (std::size_t o = 0; o < d.outputs.size(); ++o) {
    const OutputAnalysis& out = d.outputs[o];
    const OutputAnalysis* before = g ? &g->outputs[o] : nullptr;
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::PushFont(state.fonts.bold);
    ImGui::TextUnformatted(out.name.c_str());
    ImGui::PopFont();
    FigureRow("RMS", out.rms, before ? &before->rms : nullptr, 4);
    if (std::isfinite(out.fit_percent))
      FigureRow("fit %", out.fit_percent, before ? &before->fit_percent : nullptr, 3);
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextDisabled("residuals");
    ImGui::TableNextColumn();
    if (out.diagnostics) {
      DrawVerdictText(out.diagnostics->stats);
    } else {
      ImGui::TextDisabled("\xE2\x80\x94");
      if (ImGui::IsItemHovered() && !out.diagnose_error.empty())
        ImGui::SetTooltip("%s", out.diagnose_error.c_str());
    }
    if (before) {
      ImGui::TableNextColumn();
      if (before->diagnostics) DrawVerdictText(before->diagnostics->stats);
    }
  }
  ImGui::EndTable();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 3. DrawSlidersPanel

bool SlidersPanelShown(const AppState& state) {
  if (!state.sliders.open || !state.project || !state.model) return false;
  return state.view == View::kData || state.view == View::kPredictions ||
         state.view == View::kResiduals || state.view == View::kParameters;
}

void DrawSlidersPanel(AppState& state) {
  SlidersState& s = state.sliders;
  ImGui::PushFont(state.fonts.bold);
  ImGui::TextUnformatted("Sliders");
  ImGui::PopFont();
  {
    const float close_w =
        ImGui::CalcTextSize("\xC3\x97").x + 2.0f * ImGui::GetStyle().FramePadding.x;
    ImGui::SameLine(ImGui::GetContentRegionMax().x - close_w);
    if (ImGui::SmallButton("\xC3\x97##close")) s.open = false;
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("Hide the sliders (View \xE2\x80\xBA Sliders)");
  }
  ImGui::PushTextWrapPos(0.0f);
  const bool at_fit = state.estimation.result && !state.analysis.use_current_values &&
                      FitMatchesModel(*state.estimation.result, *state.model);
  ImGui::TextDisabled("%s", at_fit ? "From the fit's estimates; the fit is not changed."
                                   : "From the model's values; the model is not changed.");
  ImGui::PopTextWrapPos();
  ImGui::Separator();

  const model::ModelSpec& m = *state.model;
  std::string remove;
  for (const project::SliderSpec& spec : s.shown) {
    const auto it =
        std::find_if(m.parameters.begin(), m.parameters.end(),
                     [&](const model::Parameter& p) { return p.name == spec.parameter; });
    if (it == m.parameters.end()) {
      ImGui::TextDisabled("%s: not a parameter of the model", spec.parameter.c_str());
      continue;
    }
    if (!DrawSlider(state, static_cast<std::size_t>(it - m.parameters.begin()), spec))
      remove = spec.parameter;
    ImGui::Spacing();
  }
  if (!remove.empty()) ShowSlider(state, remove, false);
  if (s.shown.empty()) {
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextDisabled(
        "No sliders yet: add one here, or right-click a parameter in the Parameters view.");
    ImGui::PopTextWrapPos();
  }
  DrawAddCombo(state);

  ImGui::BeginDisabled(s.moved.empty());
  if (ImGui::Button("Reset")) ResetSliders(state);
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
    ImGui::SetTooltip("Every slider back to the value the views had");
  ImGui::SameLine();
  if (ImGui::Button("Use as start values")) UseSliderValuesAsStart(state);
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
    ImGui::SetTooltip(
        "Make the moved values the model's start values (the Parameters view's "
        "Start column), and show the model there");
  ImGui::EndDisabled();

  ImGui::Spacing();
  SectionHeading(state, "Response");
  DrawFigures(state);
}

}  // namespace gb::ui
