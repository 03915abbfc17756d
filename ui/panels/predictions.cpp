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
#include <vector>

#include "ui/format.h"
#include "ui/panels/analysis_view.h"
#include "ui/panels/common.h"
#include "ui/panels/panels.h"

namespace gb::ui {
namespace {

constexpr float kMinPlotHeight = 150.0f;  // pixels at scale 1; below it the plots scroll
constexpr float kHorizonWidth = 96.0f;
constexpr float kInsetHeight = 130.0f;  // Step mode's plot of P, pixels at scale 1
constexpr int kStepWindow = 60;         // samples shown around the step when it leaves the window
constexpr double kBandSd = 2.0;         // the prediction band is ± 2 sd
constexpr ImU32 kStepColor = IM_COL32(214, 39, 40, 255);

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
  SameLineIfFits(CheckboxWidth("Step through the filter"), gap);
  if (ImGui::Checkbox("Step through the filter", &a.show_step) && a.show_step) {
    a.step_playing = false;
    a.step_recentre = true;
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "The filter one sample at a time: the prediction before the measurement, the "
        "measurement, the gain and the state after it (keys: Left and Right)");
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

// ---------------------------------------------------------------------------------------------
// Step mode: the filter at state index j = a.step; output o's row k = j + d_o.

// Row k of output o at the step shown, or -1 (beyond the record).
int StepRow(const AnalysisState& a, const DatasetAnalysis& d, const OutputAnalysis& o) {
  const int k = a.step + o.delay;
  return k >= 0 && k < static_cast<int>(d.time.size()) ? k : -1;
}

// The step's points in one output's plot. The plot keeps pointers to its items' data until
// EndPlot, so they live in the caller's frame, not in DrawStepMarkers'.
struct StepPoints {
  double t = 0, prior = 0, half = 0, post = 0;
};

// At row k: the line of the instant, the prediction before the measurement with ± 2 sd, the
// measurement and the output at the state after the update.
void DrawStepMarkers(AppState& state, const DatasetAnalysis& d, const OutputAnalysis& o,
                     StepPoints* at) {
  const int k = StepRow(state.analysis, d, o);
  if (k < 0) return;
  const auto i = static_cast<std::size_t>(k);
  at->t = d.time[i];
  plot::ItemStyle line;
  line.color = kStepColor;
  plot::PlotVLines(state.plots, "now", &at->t, 1, nullptr, line);
  at->prior = o.predicted[i];
  at->half = 0.5 * (o.upper[i] - o.lower[i]);
  plot::ItemStyle prior_style;
  prior_style.color = kPredictionColor;
  prior_style.marker_radius = 5.0f;
  plot::PlotErrorBars(state.plots, "before: prediction \xC2\xB1 2 sd", &at->t, &at->prior,
                      &at->half, 1, prior_style);
  plot::ItemStyle measured;
  measured.color = state.plots.style.ink;
  measured.marker_radius = 5.0f;
  plot::PlotMarkers(state.plots, "the measurement", &at->t, &o.measured[i], 1, measured);
  const auto r = static_cast<Eigen::Index>(&o - d.outputs.data());
  if (r < d.steps.y_post.rows() && std::isfinite(d.steps.y_post(r, k))) {
    at->post = d.steps.y_post(r, k);
    plot::ItemStyle after;
    after.color = kStepColor;
    after.marker_radius = 5.0f;
    plot::PlotMarkers(state.plots, "after: at the updated state", &at->t, &at->post, 1, after);
  }
}

// The step bar: back, next, play, the rate and where the step is; the keys Left and Right.
void DrawStepBar(AppState& state, const DatasetAnalysis& d) {
  AnalysisState& a = state.analysis;
  const int N = static_cast<int>(d.time.size());
  if (N == 0) return;
  const int before = a.step;
  if (ImGui::Button("\xE2\x97\x80 Back")) --a.step;
  ImGui::SameLine();
  if (ImGui::Button("Next \xE2\x96\xB6")) ++a.step;
  ImGui::SameLine();
  if (ImGui::Button(a.step_playing ? "Pause" : "Play")) {
    a.step_playing = !a.step_playing;
    a.step_clock = 0.0;
  }
  ImGui::SameLine();
  ImGui::SetNextItemWidth(120.0f * state.fonts.scale);
  ImGui::SliderFloat("##rate", &a.step_rate, 1.0f, 100.0f, "%.0f samples/s",
                     ImGuiSliderFlags_Logarithmic | ImGuiSliderFlags_AlwaysClamp);
  if (!ImGui::GetIO().WantTextInput) {
    if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_LeftArrow))) --a.step;
    if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_RightArrow))) ++a.step;
  }
  if (a.step_playing) {
    a.step_clock += static_cast<double>(ImGui::GetIO().DeltaTime);
    const double every = 1.0 / std::max(a.step_rate, 1.0f);
    while (a.step_clock >= every) {
      a.step_clock -= every;
      ++a.step;
    }
    if (a.step >= N - 1) a.step_playing = false;
  }
  a.step = std::clamp(a.step, 0, N - 1);
  ImGui::SameLine();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("state %s of %s (%s = %s)", GroupedCount(a.step + 1).c_str(),
                      GroupedCount(N).c_str(), d.time_name.c_str(),
                      FormatSig(d.time[static_cast<std::size_t>(a.step)], 6).c_str());
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "The state at this sample is updated with each output's measurement that "
        "many rows later (its delay); the plots mark that row");
  // The time window follows the step: a stretch of 60 samples when it leaves the window.
  const double t = d.time[static_cast<std::size_t>(a.step)];
  plot::Range& x = a.time_x.range;
  if (a.step != before || a.step_recentre || !(t >= x.min && t <= x.max)) {
    if (a.step_recentre || !(t >= x.min && t <= x.max) ||
        x.max - x.min > kStepWindow * d.sample_interval * 2) {
      const int lo = std::max(0, a.step - kStepWindow / 2);
      const int hi = std::min(N - 1, lo + kStepWindow);
      a.time_x.fit_request_frame = plot::LinkedRange::kNoFit;
      x = {d.time[static_cast<std::size_t>(lo)], d.time[static_cast<std::size_t>(hi)]};
    }
  }
  a.step_recentre = false;
}

// Under the plots: per state, the prediction before the update with its sd, the gain of each
// output observed, the state after with its sd; the innovations; and P over the record.
void DrawStepTable(AppState& state, const DatasetAnalysis& d) {
  const AnalysisState& a = state.analysis;
  const FilterSteps& st = d.steps;
  const auto j = static_cast<Eigen::Index>(a.step);
  if (st.x_prior.cols() == 0) {
    ImGui::TextDisabled("Computing the filter's steps\xE2\x80\xA6");
    return;
  }
  if (j >= st.x_prior.cols()) return;
  const auto p = static_cast<Eigen::Index>(d.outputs.size());
  // The innovations of this step.
  std::string innovations;
  for (const OutputAnalysis& o : d.outputs) {
    const int k = StepRow(a, d, o);
    if (!innovations.empty()) innovations += "    ";
    if (k < 0) {
      innovations += o.name + ": its measurement of this state (" + SamplesText(o.delay) +
                     " later) is after the record's end";
      continue;
    }
    const auto i = static_cast<std::size_t>(k);
    if (!std::isfinite(o.standardized[i])) {
      innovations += o.name + ": no measurement used at this step";
      continue;
    }
    const double sd = 0.5 * (o.upper[i] - o.lower[i]) / kBandSd;
    innovations +=
        o.name + " at " + d.time_name + " = " + FormatSig(d.time[i], 6) +
        ": innovation \xCE\xB5 = measured \xE2\x88\x92 predicted = " + FormatSig(o.residual[i], 4) +
        ", sd " + FormatSig(sd, 4) + ", \xCE\xB5/sd = " + FormatSig(o.standardized[i], 3);
  }
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextUnformatted(innovations.c_str());
  ImGui::PopTextWrapPos();
  if (!st.error.empty())
    ImGui::TextColored(SeverityColor(Severity::kWarning), "%s", st.error.c_str());
  const int columns = 3 + static_cast<int>(p);
  constexpr ImGuiTableFlags kFlags = ImGuiTableFlags_SizingFixedFit | ImGuiTableFlags_RowBg |
                                     ImGuiTableFlags_BordersInnerH |
                                     ImGuiTableFlags_NoSavedSettings;
  if (!ImGui::BeginTable("##step", columns, kFlags)) return;
  ImGui::TableSetupColumn("State");
  ImGui::TableSetupColumn("Before the update \xC2\xB1 sd");
  std::vector<std::string> gain_titles;
  for (const OutputAnalysis& o : d.outputs) gain_titles.push_back("Gain K (" + o.name + ")");
  for (const std::string& g : gain_titles) ImGui::TableSetupColumn(g.c_str());
  ImGui::TableSetupColumn("After the update \xC2\xB1 sd");
  ImGui::TableHeadersRow();
  for (Eigen::Index i = 0; i < st.x_prior.rows(); ++i) {
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(i < static_cast<Eigen::Index>(st.states.size())
                               ? st.states[static_cast<std::size_t>(i)].c_str()
                               : "");
    ImGui::TableNextColumn();
    ImGui::Text("%s \xC2\xB1 %s", FormatSig(st.x_prior(i, j), 5).c_str(),
                FormatSig(st.sd_prior(i, j), 3).c_str());
    for (Eigen::Index o = 0; o < p; ++o) {
      ImGui::TableNextColumn();
      const double g = st.gain(i * p + o, j);
      if (std::isfinite(g)) {
        ImGui::TextUnformatted(FormatSig(g, 4).c_str());
      } else {
        ImGui::TextDisabled("\xE2\x80\x94");
      }
    }
    ImGui::TableNextColumn();
    ImGui::Text("%s \xC2\xB1 %s", FormatSig(st.x_post(i, j), 5).c_str(),
                FormatSig(st.sd_post(i, j), 3).c_str());
  }
  ImGui::EndTable();
}

// P over the record: each state's sd after the update, the step marked.
void DrawCovarianceInset(AppState& state, const DatasetAnalysis& d, ImVec2 size) {
  const FilterSteps& st = d.steps;
  if (st.sd_post.cols() != static_cast<Eigen::Index>(d.time.size()) || d.time.empty()) return;
  plot::PlotOptions options;
  options.title = "sd of the states after each update (from P)";
  options.x_label = d.time_name.c_str();
  options.x_title = true;
  options.legend = plot::Legend::kShow;
  // The plot keeps pointers to the rows and labels until EndPlot.
  std::vector<Eigen::VectorXd> rows;
  std::vector<std::string> labels;
  for (Eigen::Index i = 0; i < st.sd_post.rows(); ++i) {
    rows.emplace_back(st.sd_post.row(i).transpose());
    labels.push_back(i < static_cast<Eigen::Index>(st.states.size())
                         ? st.states[static_cast<std::size_t>(i)]
                         : std::to_string(i));
  }
  if (!plot::BeginPlot(state.plots, "##covariance", size, options)) return;
  const int n = static_cast<int>(d.time.size());
  for (std::size_t i = 0; i < rows.size(); ++i)
    plot::PlotLine(state.plots, labels[i].c_str(), d.time.data(), rows[i].data(), n);
  const double t = d.time[static_cast<std::size_t>(std::clamp(state.analysis.step, 0, n - 1))];
  plot::ItemStyle line;
  line.color = kStepColor;
  plot::PlotVLines(state.plots, "now", &t, 1, nullptr, line);
  plot::EndPlot(state.plots);
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
  measured.color = state.plots.style.ink;
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
  StepPoints step;  // lives until EndPlot
  if (a.show_step) DrawStepMarkers(state, d, o, &step);
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
  measured.color = state.plots.style.ink;
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

  if (state.analysis.show_step) DrawStepBar(state, *d);
  // Equal plot areas: the bottom plot also carries the time axis' title.
  const float s = state.fonts.scale;
  const float spacing = 4.0f * s;
  const float title_h = 1.2f * ImGui::GetFontSize();
  // Step mode: the table and the inset of P under the plots take their share.
  const float step_h = state.analysis.show_step
                           ? ImGui::GetTextLineHeightWithSpacing() *
                                     (static_cast<float>(d->steps.x_prior.rows()) + 3.0f) +
                                 kInsetHeight * s
                           : 0.0f;
  const float avail = ImGui::GetContentRegionAvail().y - step_h;
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
  if (state.analysis.show_step) {
    DrawStepTable(state, *d);
    DrawCovarianceInset(state, *d, ImVec2(-1, kInsetHeight * s));
  }
  ImGui::PopID();
  ImGui::PopStyleVar();
  ImGui::EndChild();
}

}  // namespace gb::ui
