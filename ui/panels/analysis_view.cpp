#include "ui/panels/analysis_view.h"

#include <algorithm>
#include <string>

#include "ui/format.h"
#include "ui/panels/common.h"

namespace gb::ui {
namespace {

constexpr float kDatasetComboWidth = 220.0f;  // pixels at scale 1

// At which values the analysis on screen is, in words.
std::string SourceText(const AppState& state, const Analysis& r) {
  std::string text;
  const FitResult* fit = state.estimation.result ? &*state.estimation.result : nullptr;
  if (r.request.source == AnalysisSource::kFit) {
    text = "At the estimates of the last fit";
    if (fit && fit->model_revision != state.model_revision)
      text += " (the parameters were edited after it: run the estimation again to update it)";
  } else if (fit) {
    text = "At the model's current values (as in the Parameters view), not at the fit's estimates";
  } else {
    text = "At the model's current values: no fit yet (run one in the Estimate view)";
  }
  if (!r.request.moved.empty()) {
    text += ", with ";
    for (std::size_t i = 0; i < r.request.moved.size(); ++i)
      text += (i == 0 ? "" : i + 1 == r.request.moved.size() ? " and " : ", ") + r.request.moved[i];
    text += " moved by the sliders";
  }
  text += ". Delay";
  for (std::size_t o = 0; o < r.outputs.size() && o < r.delay.size(); ++o)
    text += (o ? ", " : " ") + r.outputs[o] + " " + SamplesText(r.delay[o]);
  text += " (from the " + r.delay_source + ").";
  return text;
}

void DrawDatasetSelector(AppState& state, const Analysis* r) {
  AnalysisState& a = state.analysis;
  const int n = static_cast<int>(state.datasets.size());
  a.dataset = std::clamp(a.dataset, 0, std::max(0, n - 1));
  if (n <= 1) return;
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("Dataset");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(kDatasetComboWidth * state.fonts.scale);
  const std::string current =
      DatasetLabel(state.datasets[static_cast<std::size_t>(a.dataset)].spec);
  if (ImGui::BeginCombo("##dataset", current.c_str())) {
    for (int i = 0; i < n; ++i) {
      const auto k = static_cast<std::size_t>(i);
      std::string label = DatasetLabel(state.datasets[k].spec);
      if (r && k < r->datasets.size() && !r->datasets[k].error.empty())
        label += "  (cannot be used)";
      label += "###" + std::to_string(i);
      if (ImGui::Selectable(label.c_str(), i == a.dataset) && i != a.dataset) {
        a.dataset = i;
        a.RequestFit();
        OpenTimeWindow(a);
      }
    }
    ImGui::EndCombo();
  }
  ImGui::SameLine(0, 1.6f * ImGui::GetFontSize());
}

// The toggle between the fit's estimates and the model's values, and the job's state.
// "Showing t = 0 … 2.99 of 0 … 125: double-click ...", while the time axis shows part of the
// record (OpenTimeWindow opens it so).
void DrawWindowHint(const AppState& state, const Analysis& r) {
  const AnalysisState& a = state.analysis;
  const auto k = static_cast<std::size_t>(a.dataset);
  if (k >= r.datasets.size() || r.datasets[k].time.size() < 2) return;
  const DatasetAnalysis& d = r.datasets[k];
  const plot::Range& x = a.time_x.range;
  const double lo = d.time.front(), hi = d.time.back();
  if (x.min <= lo && x.max >= hi) return;
  const std::string text = "Showing " + d.time_name + " = " + FormatSig(std::max(x.min, lo), 4) +
                           " \xE2\x80\xA6 " + FormatSig(std::min(x.max, hi), 4) + " of " +
                           FormatSig(lo, 4) + " \xE2\x80\xA6 " + FormatSig(hi, 4) +
                           ": double-click a time plot for the whole record (wheel: zoom, "
                           "drag: pan).";
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextDisabled("%s", text.c_str());
  ImGui::PopTextWrapPos();
}

void DrawControls(AppState& state) {
  AnalysisState& a = state.analysis;
  const bool has_fit = state.estimation.result.has_value();
  ImGui::BeginDisabled(!has_fit);
  ImGui::Checkbox("At the model's values", &a.use_current_values);
  ImGui::EndDisabled();
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) {
    ImGui::SetTooltip("%s", has_fit ? "Show the model at the values of the Parameters view "
                                      "instead of the last fit's estimates"
                                    : "No fit yet: the model's current values are used");
  }
  ImGui::SameLine(0, 1.6f * ImGui::GetFontSize());
  if (AnalysisRunning(state)) {
    ImGui::AlignTextToFramePadding();
    ImGui::TextDisabled("Computing\xE2\x80\xA6");
    ImGui::SameLine();
    if (ImGui::SmallButton("Cancel")) CancelAnalysis(state);
  } else if (!a.last_failure.empty()) {
    if (ImGui::SmallButton("Compute again")) RecomputeAnalysis(state);
  } else {
    ImGui::NewLine();
  }
}

}  // namespace

const OutputAnalysis* GhostOutput(const AppState& state, std::size_t dataset, std::size_t output,
                                  std::size_t rows) {
  const std::optional<Analysis>& g = state.sliders.ghost;
  if (!g || dataset >= g->datasets.size()) return nullptr;
  const DatasetAnalysis& d = g->datasets[dataset];
  if (output >= d.outputs.size() || d.time.size() != rows) return nullptr;
  return &d.outputs[output];
}

const char* VerdictWord(const diagnose::ResidualDiagnostics& st) {
  return st.white && st.normal ? "White and normal" : st.white ? "White, not normal" : "Not white";
}

ImU32 VerdictColor(const diagnose::ResidualDiagnostics& st) {
  return st.white && st.normal ? kGoodColor
                               : ImGui::ColorConvertFloat4ToU32(SeverityColor(
                                     st.white ? Severity::kWarning : Severity::kError));
}

std::string SamplesText(int n) { return std::to_string(n) + (n == 1 ? " sample" : " samples"); }

const DatasetAnalysis* DrawAnalysisHeader(AppState& state, bool (*view_controls)(AppState&)) {
  if (DrawNoProjectNotice(state)) return nullptr;
  if (!state.model) {
    DrawNotice(state, "The model is not valid", state.model_error, Severity::kError);
    return nullptr;
  }
  if (state.datasets.empty()) {
    DrawNotice(state, "No data", "The project lists no datasets (its \"datasets\" entry).");
    return nullptr;
  }
  AnalysisState& a = state.analysis;
  const Analysis* r = a.result ? &*a.result : nullptr;
  const bool running = AnalysisRunning(state);

  DrawDatasetSelector(state, r);
  if (r && view_controls && view_controls(state))
    SameLineIfFits(CheckboxWidth("At the model's values"), 1.6f * ImGui::GetFontSize());
  DrawControls(state);
  if (r) {
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextDisabled("%s", SourceText(state, *r).c_str());
    ImGui::PopTextWrapPos();
    // Compare shows whole records, not the linked time window.
    if (!(state.view == View::kPredictions && a.show_compare && state.datasets.size() >= 2))
      DrawWindowHint(state, *r);
  }
  if (!running && !a.last_failure.empty()) {
    std::string text = a.last_failure;
    if (text.back() != '.') text += '.';
    if (r) text += " The plots show the previous results.";
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextColored(SeverityColor(a.last_failure_severity), "%s", text.c_str());
    ImGui::PopTextWrapPos();
  }
  if (!r) {
    std::string why;
    if (!running && !a.last_failure.empty()) {
      DrawNotice(state, "No predictions", a.last_failure, a.last_failure_severity);
    } else if (!running && !AnalysisRequestNow(state, &why)) {
      DrawNotice(state, "No predictions", why);
    } else {
      DrawNotice(state, "Computing the predictions",
                 "The one-step predictions, the simulation and the residual diagnostics of every "
                 "dataset are being computed.");
    }
    return nullptr;
  }
  const auto k = static_cast<std::size_t>(a.dataset);
  if (k >= r->datasets.size()) {  // added since: its run follows
    DrawNotice(state, "Computing the predictions",
               "This dataset was added after the predictions shown for the others were "
               "computed; they are being computed for it.");
    return nullptr;
  }
  const DatasetAnalysis& d = r->datasets[k];
  if (!d.error.empty()) {
    DrawNotice(state, "This dataset cannot be used", d.error, Severity::kError);
    return nullptr;
  }
  if (d.validation) {
    ImGui::PushTextWrapPos(0.0f);
    if (d.initial_error.empty()) {
      ImGui::TextDisabled(
          "Validation record: not fitted. It starts at its own initial state, from its first %s "
          "(smoothed back to its start), which the simulation's figures leave out.",
          SamplesText(d.initial_samples).c_str());
    } else {
      ImGui::TextColored(SeverityColor(Severity::kWarning),
                         "Validation record: its own initial state could not be found (%s); it "
                         "starts at the model's.",
                         d.initial_error.c_str());
    }
    ImGui::PopTextWrapPos();
  }
  return &d;
}

}  // namespace gb::ui
