// The predictions view: for every output of the selected dataset, the measurements (markers),
// the one-step predictions (line) with their ± 2 sd band, and on request the h-step-ahead
// predictions, the simulation (the deterministic response, no data assimilated) and the
// smoothed output (conditioned on every measurement); the plots are stacked with their time axes
// linked, each titled with the output's RMS of residuals, the observations used and the delay.
// *Compare* shows every record instead, estimation and validation alike: for each record and
// output the measurements and the simulation from the record's own initial state, titled with
// the record's role and fit % (as System Identification Toolbox's `compare` shows a model
// against several data sets).
//
// The numbers come from AppState::analysis (ui/jobs/analysis.h), computed in the background; this
// panel only reads the installed result.
#include <algorithm>
#include <cmath>
#include <string>

#include "ui/format.h"
#include "ui/panels/analysis_view.h"
#include "ui/panels/common.h"
#include "ui/panels/panels.h"

namespace gb::ui {
namespace {

constexpr float kMinPlotHeight = 150.0f;  // pixels at scale 1; below it the plots scroll
constexpr float kHorizonWidth = 96.0f;

bool DrawOverlayControls(AppState& state) {
  AnalysisState& a = state.analysis;
  ImGui::Checkbox("Predicted", &a.show_ahead);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "Predictions k samples ahead: from the filtered state k samples earlier, "
        "with the measured inputs in between");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(kHorizonWidth * state.fonts.scale);
  if (ImGui::InputInt("##horizon", &a.horizon)) a.horizon = std::clamp(a.horizon, 1, kMaxHorizon);
  ImGui::SameLine();
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("samples ahead");
  const float gap = 1.6f * ImGui::GetFontSize();
  SameLineIfFits(CheckboxWidth("Simulation"), gap);
  ImGui::Checkbox("Simulation", &a.show_simulation);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "The deterministic response of the model to the measured inputs from its "
        "initial state: no measurement is assimilated");
  SameLineIfFits(CheckboxWidth("Smoothed"), gap);
  ImGui::Checkbox("Smoothed", &a.show_smoothed);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "The output at the smoothed state, which every measurement informs, earlier and "
        "later (Rauch-Tung-Striebel; extended for a nonlinear model), \xC2\xB1 2 sd without "
        "the measurement noise");
  if (state.datasets.size() < 2) return true;  // one record: the plots are the comparison
  SameLineIfFits(CheckboxWidth("Compare records"), gap);
  ImGui::Checkbox("Compare records", &a.show_compare);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "Every record at once, estimation and validation: its measurements and the model's "
        "simulation from the record's own initial state, with the fit %%");
  return true;
}

std::string PlotTitle(const OutputAnalysis& o) {
  // The simulation's RMS is in the table of every record's figures (and the fit % says it
  // relative to the output's spread).
  std::string title = o.name + "    one-step RMS " + FormatSig(o.rms, 4) + "  \xC2\xB7  ";
  if (std::isfinite(o.fit_percent))
    title += "fit " + FormatFixed(o.fit_percent, 1) + " %  \xC2\xB7  ";
  return title + GroupedCount(o.n_observed) + " observed  \xC2\xB7  delay " + SamplesText(o.delay);
}

// Every record's figures side by side: one-step RMS, simulation RMS and fit % per output,
// estimation and validation records alike (collapsed at first for a single record, whose plot
// titles carry its one-step RMS and fit %).
void DrawFitFigures(AppState& state, const Analysis& r) {
  if (!ImGui::CollapsingHeader(
          "Fit figures: one-step RMS, simulation RMS and fit % of every record",
          r.datasets.size() > 1 ? ImGuiTreeNodeFlags_DefaultOpen : 0))
    return;
  constexpr ImGuiTableFlags kFlags = ImGuiTableFlags_SizingFixedFit | ImGuiTableFlags_RowBg |
                                     ImGuiTableFlags_BordersInnerH | ImGuiTableFlags_ScrollY;
  const float row_h = ImGui::GetTextLineHeightWithSpacing();
  std::size_t rows = 0;
  for (const DatasetAnalysis& d : r.datasets) rows += std::max<std::size_t>(1, d.outputs.size());
  const float height = row_h * (static_cast<float>(std::min<std::size_t>(rows, 6)) + 1.4f);
  if (!ImGui::BeginTable("##fit-figures", 6, kFlags, ImVec2(0, height))) return;
  ImGui::TableSetupScrollFreeze(0, 1);
  for (const char* c : {"Record", "Role", "Output", "One-step RMS", "Simulation RMS", "Fit"})
    ImGui::TableSetupColumn(c);
  ImGui::TableHeadersRow();
  for (std::size_t k = 0; k < r.datasets.size(); ++k) {
    const DatasetAnalysis& d = r.datasets[k];
    const auto cells = [&](const char* output, const std::string& rms, const std::string& sim,
                           const std::string& fit) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      const bool selected = static_cast<int>(k) == state.analysis.dataset;
      if (ImGui::Selectable((d.name + "##" + std::to_string(k) + output).c_str(), selected,
                            ImGuiSelectableFlags_SpanAllColumns) &&
          !selected) {
        state.analysis.dataset = static_cast<int>(k);
        state.analysis.RequestFit();
        OpenTimeWindow(state.analysis);
      }
      ImGui::TableNextColumn();
      ImGui::TextDisabled("%s", d.validation ? "validation" : "estimation");
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(output);
      for (const std::string* v : {&rms, &sim, &fit}) {
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(v->c_str());
      }
    };
    if (!d.error.empty() || d.outputs.empty()) {
      cells("", "cannot be used", "", "");
      continue;
    }
    for (const OutputAnalysis& o : d.outputs) {
      cells(o.name.c_str(), FormatSig(o.rms, 4),
            std::isfinite(o.simulation_rms) ? FormatSig(o.simulation_rms, 4) : "\xE2\x80\x94",
            std::isfinite(o.fit_percent) ? FormatFixed(o.fit_percent, 1) + " %" : "\xE2\x80\x94");
    }
  }
  ImGui::EndTable();
}

void DrawOutputPlot(AppState& state, const DatasetAnalysis& d, const OutputAnalysis& o, ImVec2 size,
                    bool last) {
  const AnalysisState& a = state.analysis;
  const std::string title = PlotTitle(o);
  const std::string ahead_label = "predicted " + SamplesText(a.result->request.horizon) + " ahead";
  plot::PlotOptions options;
  options.title = title.c_str();
  options.x_label = d.time_name.c_str();
  options.x_title = last;
  options.y_label = o.name.c_str();
  options.linked_x = &state.analysis.time_x;
  options.legend = plot::Legend::kShow;
  if (!plot::BeginPlot(state.plots, "##output", size, options)) return;
  const int n = static_cast<int>(d.time.size());
  const double* t = d.time.data();
  plot::ItemStyle band;
  band.color = kPredictionColor;
  band.fill_alpha = 0.18f;
  plot::PlotBand(state.plots, "\xC2\xB1 2 sd", t, o.lower.data(), o.upper.data(), n, band);
  plot::ItemStyle measured;
  measured.color = kMeasuredColor;
  measured.marker_radius = 1.5f;
  plot::PlotMarkers(state.plots, "measured", t, o.measured.data(), n, measured);
  if (const OutputAnalysis* g =
          GhostOutput(state, static_cast<std::size_t>(a.dataset),
                      static_cast<std::size_t>(&o - d.outputs.data()), d.time.size())) {
    plot::ItemStyle ghost;
    ghost.color = GhostColor(a.show_simulation ? kSimulationColor : kPredictionColor);
    const std::vector<double>& before =
        a.show_simulation && g->simulated.size() == d.time.size() ? g->simulated : g->predicted;
    plot::PlotLine(state.plots, kGhostLabel, t, before.data(), n, ghost);
  }
  plot::ItemStyle predicted;
  predicted.color = kPredictionColor;
  plot::PlotLine(state.plots, "one-step prediction", t, o.predicted.data(), n, predicted);
  if (a.show_ahead && o.ahead.size() == d.time.size()) {
    plot::ItemStyle ahead;
    ahead.color = kAheadColor;
    plot::PlotLine(state.plots, ahead_label.c_str(), t, o.ahead.data(), n, ahead);
  }
  if (a.show_simulation && o.simulated.size() == d.time.size()) {
    plot::ItemStyle sim;
    sim.color = kSimulationColor;
    plot::PlotLine(state.plots, "simulation", t, o.simulated.data(), n, sim);
  }
  if (a.show_smoothed && o.smoothed.size() == d.time.size()) {
    plot::ItemStyle smoothed;
    smoothed.color = kSmoothedColor;
    smoothed.fill_alpha = 0.18f;
    plot::PlotBand(state.plots, "smoothed \xC2\xB1 2 sd", t, o.smoothed_lower.data(),
                   o.smoothed_upper.data(), n, smoothed);
    plot::PlotLine(state.plots, "smoothed", t, o.smoothed.data(), n, smoothed);
  }
  plot::EndPlot(state.plots);
}

// One record's output in the Compare overlay: measurements and simulation on the record's own
// time axis.
void DrawComparePlot(AppState& state, const DatasetAnalysis& d, const OutputAnalysis& o,
                     ImVec2 size) {
  // The name says "(validation)" already (DatasetLabel).
  std::string title = d.name + (d.validation ? "" : " (estimation)") + "    " + o.name + "    ";
  title += std::isfinite(o.fit_percent) ? "fit " + FormatFixed(o.fit_percent, 1) + " %"
                                        : "no simulation";
  if (std::isfinite(o.simulation_rms))
    title += "  \xC2\xB7  simulation RMS " + FormatSig(o.simulation_rms, 4);
  plot::PlotOptions options;
  options.title = title.c_str();
  options.x_label = d.time_name.c_str();
  options.x_title = true;
  options.y_label = o.name.c_str();
  options.legend = plot::Legend::kShow;
  if (!plot::BeginPlot(state.plots, "##compare", size, options)) return;
  const int n = static_cast<int>(d.time.size());
  plot::ItemStyle measured;
  measured.color = kMeasuredColor;
  measured.marker_radius = 1.5f;
  plot::PlotMarkers(state.plots, "measured", d.time.data(), o.measured.data(), n, measured);
  if (o.simulated.size() == d.time.size()) {
    plot::ItemStyle sim;
    sim.color = kSimulationColor;
    plot::PlotLine(state.plots, "simulation", d.time.data(), o.simulated.data(), n, sim);
  }
  plot::EndPlot(state.plots);
}

// Every record's outputs, one plot each, in project order (the records that cannot be used say
// why in one line).
void DrawCompare(AppState& state, const Analysis& r) {
  const float s = state.fonts.scale;
  const float spacing = 4.0f * s;
  std::size_t plots = 0;
  for (const DatasetAnalysis& d : r.datasets)
    if (d.error.empty()) plots += d.outputs.size();
  const float avail = ImGui::GetContentRegionAvail().y;
  const float n = static_cast<float>(std::max<std::size_t>(1, plots));
  const float height = std::max(kMinPlotHeight * s, (avail - spacing * (n - 1.0f)) / n - 1.0f);
  const bool scrolls = height * n + spacing * (n - 1.0f) > avail;
  ImGui::BeginChild("##compare", ImVec2(0, 0), false,
                    scrolls ? ImGuiWindowFlags_None : ImGuiWindowFlags_NoScrollbar);
  ImGui::PushStyleVar(ImGuiStyleVar_ItemSpacing, ImVec2(0, spacing));
  for (std::size_t k = 0; k < r.datasets.size(); ++k) {
    const DatasetAnalysis& d = r.datasets[k];
    ImGui::PushID(static_cast<int>(k));
    if (!d.error.empty()) {
      ImGui::TextColored(SeverityColor(Severity::kError), "%s cannot be used: %s", d.name.c_str(),
                         d.error.c_str());
    } else {
      for (std::size_t o = 0; o < d.outputs.size(); ++o) {
        ImGui::PushID(static_cast<int>(o));
        DrawComparePlot(state, d, d.outputs[o], ImVec2(-1, height));
        ImGui::PopID();
      }
    }
    ImGui::PopID();
  }
  ImGui::PopStyleVar();
  ImGui::EndChild();
}

}  // namespace

void DrawPredictionsPanel(AppState& state) {
  const DatasetAnalysis* d = DrawAnalysisHeader(state, DrawOverlayControls);
  if (!d) return;
  DrawFitFigures(state, *state.analysis.result);
  if (state.analysis.show_compare && state.datasets.size() >= 2) {
    DrawCompare(state, *state.analysis.result);
    return;
  }
  for (const OutputAnalysis& o : d->outputs) {
    if (state.analysis.show_ahead && !o.ahead_error.empty()) {
      ImGui::TextColored(SeverityColor(Severity::kWarning), "No %s-ahead predictions for %s: %s",
                         SamplesText(state.analysis.result->request.horizon).c_str(),
                         o.name.c_str(), o.ahead_error.c_str());
    }
    if (state.analysis.show_smoothed && !o.smoothed_error.empty()) {
      ImGui::TextColored(SeverityColor(Severity::kWarning), "No smoothed output for %s: %s",
                         o.name.c_str(), o.smoothed_error.c_str());
    }
  }

  // Equal plot areas: the bottom plot also carries the time axis' title.
  const float s = state.fonts.scale;
  const float spacing = 4.0f * s;
  const float title_h = 1.2f * ImGui::GetFontSize();
  const float avail = ImGui::GetContentRegionAvail().y;
  const float n = static_cast<float>(std::max<std::size_t>(1, d->outputs.size()));
  const float height =
      std::max(kMinPlotHeight * s, (avail - spacing * (n - 1.0f) - title_h) / n - 1.0f);
  const bool scrolls = height * n + spacing * (n - 1.0f) + title_h > avail;
  ImGui::BeginChild("##predictions", ImVec2(0, 0), false,
                    scrolls ? ImGuiWindowFlags_None : ImGuiWindowFlags_NoScrollbar);
  ImGui::PushStyleVar(ImGuiStyleVar_ItemSpacing, ImVec2(0, spacing));
  ImGui::PushID(state.analysis.dataset);  // each dataset's plots keep their own y ranges
  for (std::size_t k = 0; k < d->outputs.size(); ++k) {
    const bool last = k + 1 == d->outputs.size();
    ImGui::PushID(static_cast<int>(k));
    DrawOutputPlot(state, *d, d->outputs[k], ImVec2(-1, last ? height + title_h : height), last);
    ImGui::PopID();
  }
  ImGui::PopID();
  ImGui::PopStyleVar();
  ImGui::EndChild();
}

}  // namespace gb::ui
