// The estimate view: the options and Run / Cancel, the progress of the run under way (stage,
// iterations, evaluations, best log L, elapsed time, the log L trace), and once a fit has
// finished its key figures, the trace, the delay profile of every scanned output and the
// report (the text greybench-cli estimate prints).
//
// The estimation runs in AppState::estimation.job (StartEstimation); this panel only reads
// the progress record and the installed result, and never waits for the job.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <imgui.h>

#include "ui/export/export.h"
#include "ui/format.h"
#include "ui/panels/common.h"
#include "ui/panels/panels.h"
#include "ui/theme.h"

namespace gb::ui {
namespace {

constexpr float kPlotHeight = 230.0f;       // pixels at scale 1
constexpr float kMinReportHeight = 160.0f;  // below it the view scrolls
constexpr float kOptionInputWidth = 96.0f;  // the multistart and threads fields
constexpr float kAlgorithmWidth = 110.0f;
constexpr double kProfileXPadding = 0.03;  // the end points do not sit on the frame
constexpr ImU32 kEstimateColor = IM_COL32(214, 39, 40, 255);
constexpr ImU32 kFitColor = IM_COL32(31, 119, 180, 255);
constexpr ImU32 kProfileColor = IM_COL32(255, 127, 14, 255);

std::string Elapsed(const AppState& state, double seconds) {
  if (state.deterministic) return kElapsedPlaceholder;
  return FormatFixed(seconds, seconds < 10 ? 2 : 1) + " s";
}

double RunningSeconds(const AppState& state) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - state.estimation.started)
      .count();
}

// ---------------------------------------------------------------------------------------------
// Options, Run and Cancel

void DrawToolbar(AppState& state) {
  const float s = state.fonts.scale;
  EstimationState& e = state.estimation;
  const bool running = EstimationRunning(state);
  const bool can_run = !running && state.model && !state.load_job.active();

  ImGui::BeginDisabled(!can_run);
  const bool run = PrimaryButton("Run", ImVec2(80.0f * s, 0));
  ImGui::EndDisabled();
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) {
    ImGui::SetTooltip("%s", state.model ? "Estimate the free parameters (and scanned delays)"
                                        : "The model is not valid (see the Equations view)");
  }
  if (run) {
    std::string why;
    if (!StartEstimation(state, &why))
      AddMessage(state, Severity::kError, "Cannot estimate: " + why);
  }
  ImGui::SameLine();
  ImGui::BeginDisabled(!running);
  if (ImGui::Button("Cancel", ImVec2(80.0f * s, 0))) CancelEstimation(state);
  ImGui::EndDisabled();

  // Options: fixed while a run is under way (it uses those it started with).
  const float gap = 1.6f * ImGui::GetFontSize();
  ImGui::BeginDisabled(running);
  ImGui::SameLine(0, gap);
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("Algorithm");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(kAlgorithmWidth * s);
  if (ImGui::BeginCombo("##algorithm", Info(e.settings.algorithm).name)) {
    for (const AlgorithmInfo& a : kAlgorithms) {
      if (ImGui::Selectable(a.name, a.algorithm == e.settings.algorithm))
        e.settings.algorithm = a.algorithm;
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", a.summary);
    }
    ImGui::EndCombo();
  }
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", Info(e.settings.algorithm).summary);

  // A label and its input: on this line where both fit, else on the next (1024 x 768).
  const auto labelled = [&](const char* label, float extra) {
    SameLineIfFits(ImGui::CalcTextSize(label).x + ImGui::GetStyle().ItemSpacing.x +
                       kOptionInputWidth * s + extra,
                   gap);
    ImGui::AlignTextToFramePadding();
    ImGui::TextDisabled("%s", label);
  };
  labelled("Extra starts", 0);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(kOptionInputWidth * s);
  if (ImGui::InputInt("##multistart", &e.settings.multistart))
    e.settings.multistart = std::clamp(e.settings.multistart, 0, kMaxMultistart);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("Starts spread over the bounds besides the model's start values");

  labelled("Threads", ImGui::GetStyle().ItemSpacing.x + ImGui::CalcTextSize("(all cores)").x);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(kOptionInputWidth * s);
  if (ImGui::InputInt("##threads", &e.settings.threads))
    e.settings.threads = std::clamp(e.settings.threads, 0, kMaxThreads);
  ImGui::SameLine();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("%s", e.settings.threads == 0 ? "(all cores)" : "");
  SameLineIfFits(CheckboxWidth("Profile intervals"), gap);
  ImGui::Checkbox("Profile intervals", &e.settings.profile_intervals);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "Likelihood-ratio (profile) 95 %% intervals for every free parameter, "
        "shown in the Parameters view beside the Wald intervals (costs about a "
        "dozen fits per parameter)");
  // On this line where it fits, else at the start of the next (narrow windows).
  constexpr const char* kSteadyLabel = "Steady-state start";
  SameLineIfFits(CheckboxWidth(kSteadyLabel), gap);
  if (ImGui::Checkbox(kSteadyLabel, &e.settings.steady_start) && state.project) {
    // Kept with the project (its "estimation" key), like a model edit: saved with it.
    state.project->extra[project::kEstimationKey]["steady_start"] = e.settings.steady_start;
    ++state.layout_revision;
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "Before fitting, move the parameters the model's steady states depend on "
        "until those match the records' levels (means over %g-unit windows); for "
        "nonlinear models whose start values are far off. The report says what "
        "moved. Saved with the project.",
        e.settings.steady_window);
  // Several fitted records: each from its own initial state, or all from the model's.
  int fitted = 0;
  for (const LoadedDataset& d : state.datasets) fitted += d.spec.role == data::Role::kEstimation;
  if (fitted >= 2) {
    constexpr const char* kPerRecordLabel = "Initial state per record";
    SameLineIfFits(CheckboxWidth(kPerRecordLabel), gap);
    if (ImGui::Checkbox(kPerRecordLabel, &e.settings.per_record_initial_states) && state.project) {
      state.project->extra[project::kEstimationKey]["initial_states"] =
          e.settings.per_record_initial_states ? "per_record" : "shared";
      ++state.layout_revision;
    }
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "Each of the %d fitted records starts from its own initial state: the "
          "parameters only the model's initial state uses get a copy per record "
          "(NAME_r2, NAME_r3, ...), started from the record's first samples. "
          "Off: every record starts from the model's one initial state. Saved "
          "with the project.",
          fitted);
  }
  ImGui::EndDisabled();
}

// ---------------------------------------------------------------------------------------------
// Status: the run under way, the last result, and why the last run left no result

void DrawRunning(AppState& state) {
  const EstimationState& e = state.estimation;
  const EstimationProgress::Latest p =
      e.progress ? e.progress->latest() : EstimationProgress::Latest{};
  std::string rest = std::string(StageText(p.stage));
  if (p.any) {
    rest += "  \xC2\xB7  iteration " + std::to_string(p.iteration) + "  \xC2\xB7  " +
            GroupedCount(p.evaluations) + " evaluations  \xC2\xB7  best log L " +
            FormatFixed(p.best_loglik, 3);
  }
  rest += "  \xC2\xB7  " + Elapsed(state, RunningSeconds(state));
  StatusLine(state, IM_COL32(47, 111, 219, 255), "Running", rest);
}

void DrawResultStatus(AppState& state, const FitResult& r) {
  const estimate::EstimateSummary& s = r.summary;
  const ImU32 color = ImGui::ColorConvertFloat4ToU32(
      SeverityColor(s.converged ? Severity::kInfo : Severity::kWarning));
  StatusLine(state, s.converged ? IM_COL32(44, 160, 44, 255) : color,
             s.cancelled   ? "Stopped"
             : s.converged ? "Converged"
                           : "Not converged",
             s.cancelled ? s.message + ": the best point so far, not an optimum" : s.message);
}

const char* FitStatus(const estimate::EstimateSummary& s) {
  return s.cancelled ? "stopped" : s.converged ? "converged" : "not converged";
}

// "label value" pairs left to right, wrapping to a new line when the next does not fit.
class FigureRow {
 public:
  void Add(const char* label, const std::string& value) {
    const float gap = 1.6f * ImGui::GetFontSize();
    const float w = ImGui::CalcTextSize(label).x + 0.5f * ImGui::GetFontSize() +
                    ImGui::CalcTextSize(value.c_str()).x;
    if (!first_) {
      const float right = ImGui::GetWindowPos().x + ImGui::GetContentRegionMax().x;
      if (ImGui::GetItemRectMax().x + gap + w <= right) ImGui::SameLine(0, gap);
    }
    first_ = false;
    LabelValue(label, value);
  }

 private:
  bool first_ = true;
};

void DrawKeyFigures(AppState& state, const FitResult& r) {
  const estimate::EstimateSummary& s = r.summary;
  FigureRow row;
  row.Add("log L", FormatFixed(s.loglik, 3));
  row.Add("AIC", FormatFixed(s.aic, 2));
  row.Add("BIC", FormatFixed(s.bic, 2));
  for (const estimate::DelayEstimate& d : s.delays) {
    if (d.scanned)
      row.Add(("Delay of " + d.output).c_str(), std::to_string(d.estimate) + " samples");
  }
  row.Add("Observations", GroupedCount(s.n_obs));
  row.Add("Free", std::to_string(s.n_free));
  row.Add("Iterations", std::to_string(s.iterations));
  row.Add("Evaluations", GroupedCount(s.evaluations));
  row.Add("Time", Elapsed(state, s.elapsed_s));
  row.Add("Algorithm", Info(r.settings.algorithm).name);
  // Which filter ran: a nonlinear model's estimate comes from the extended Kalman filter.
  row.Add("Filter",
          s.extended ? (s.ekf.iterations > 1 ? "iterated EKF" : "EKF") : "Kalman (exact)");
  // How the nonlinear model's formulas ran: compiled to machine code, or interpreted.
  if (s.extended) row.Add("Model code", s.native ? "native" : "interpreter");
}

// ---------------------------------------------------------------------------------------------
// Plots

void DrawTracePlot(AppState& state, const Trace& trace, ImVec2 size) {
  plot::PlotOptions options;
  options.title = "Log-likelihood by iteration";
  options.x_label = "iteration";
  options.y_label = "log L";
  options.linked_x = &state.estimation.trace_x;  // refitted as points arrive
  options.legend = plot::Legend::kHide;          // no corner is reliably free: see TraceLegend()
  if (!plot::BeginPlot(state.plots, "##trace", size, options)) return;
  plot::ItemStyle fit;
  fit.color = kFitColor;
  plot::PlotLine(state.plots, "fit", trace.iteration.data(), trace.loglik_fit.data(), trace.size(),
                 fit);
  if (trace.has_profile) {
    plot::ItemStyle profile;
    profile.color = kProfileColor;
    profile.marker_radius = 1.75f;
    plot::PlotMarkers(state.plots, "fits at other delays", trace.iteration.data(),
                      trace.loglik_profile.data(), trace.size(), profile);
  }
  plot::EndPlot(state.plots);
}

void DrawProfilePlot(AppState& state, const DelayProfilePlot& p, plot::LinkedRange* x,
                     ImVec2 size) {
  std::string title = "Profile log L of the " + p.output + " delay";
  if (!p.estimate_delay.empty())
    title += ": estimate " + FormatSig(p.estimate_delay[0], 6) + " samples";
  plot::PlotOptions options;
  options.title = title.c_str();
  options.x_label = "delay";
  options.x_unit = "samples";
  options.y_label = "log L";
  options.legend = plot::Legend::kHide;  // the title names the estimate (the red point)
  options.x_padding = kProfileXPadding;
  options.linked_x = x;  // refitted when a new result arrives
  ImGui::PushID(p.output.c_str());
  if (plot::BeginPlot(state.plots, "##profile", size, options)) {
    const int n = static_cast<int>(p.delay.size());
    plot::ItemStyle line;
    line.color = kProfileColor;
    plot::PlotLine(state.plots, "log L(delay)", p.delay.data(), p.loglik.data(), n, line);
    plot::PlotMarkers(state.plots, "##points", p.delay.data(), p.loglik.data(), n, line);
    plot::ItemStyle est;
    est.color = kEstimateColor;
    est.marker_radius = 5.0f;
    plot::PlotMarkers(state.plots, "estimate", p.estimate_delay.data(), p.estimate_loglik.data(),
                      static_cast<int>(p.estimate_delay.size()), est);
    plot::EndPlot(state.plots);
  }
  ImGui::PopID();
}

// The trace's legend, under the plots: a swatch and a name per series.
void TraceLegend(AppState& state, const Trace& trace) {
  const float s = state.fonts.scale;
  auto entry = [&](ImU32 color, bool line, const char* text) {
    const ImVec2 p = ImGui::GetCursorScreenPos();
    const float h = ImGui::GetTextLineHeight();
    ImDrawList* dl = ImGui::GetWindowDrawList();
    if (line) {
      dl->AddLine(ImVec2(p.x, p.y + 0.5f * h), ImVec2(p.x + 16.0f * s, p.y + 0.5f * h), color,
                  2.0f * s);
    } else {
      dl->AddCircleFilled(ImVec2(p.x + 8.0f * s, p.y + 0.5f * h), 3.0f * s, color, 12);
    }
    ImGui::Dummy(ImVec2(16.0f * s, h));
    ImGui::SameLine(0, 0.4f * ImGui::GetFontSize());
    ImGui::TextDisabled("%s", text);
  };
  entry(kFitColor, true, "fit at the estimated delay");
  if (!trace.has_profile) return;
  ImGui::SameLine(0, 1.2f * ImGui::GetFontSize());
  entry(kProfileColor, false, "fits at the other delays");
}

// The trace and the delay profiles side by side.
void DrawPlots(AppState& state, const Trace& trace, const FitResult* result) {
  const float s = state.fonts.scale;
  const float spacing = ImGui::GetStyle().ItemSpacing.x;
  const int n_profiles = result ? static_cast<int>(result->profiles.size()) : 0;
  // A fit read back from its result file has no trace (the file does not keep one).
  const bool has_trace = trace.size() > 0 || !result;
  if (!has_trace && n_profiles == 0) return;
  const float n = static_cast<float>((has_trace ? 1 : 0) + n_profiles);
  const float width = std::floor((ImGui::GetContentRegionAvail().x - spacing * (n - 1.0f)) / n);
  const ImVec2 size(std::max(120.0f * s, width), kPlotHeight * s);
  if (has_trace) DrawTracePlot(state, trace, size);
  for (int i = 0; i < n_profiles; ++i) {
    if (i > 0 || has_trace) ImGui::SameLine();
    const auto k = static_cast<std::size_t>(i);
    if (state.estimation.profile_x.size() != result->profiles.size())
      state.estimation.profile_x.assign(result->profiles.size(), plot::LinkedRange{});
    DrawProfilePlot(state, result->profiles[k], &state.estimation.profile_x[k], size);
  }
  if (has_trace) TraceLegend(state, trace);
  for (int i = 0; i < n_profiles; ++i) {
    if (!result->profiles[static_cast<std::size_t>(i)].any_lower_bound) continue;
    if (has_trace) ImGui::SameLine(0, 1.6f * ImGui::GetFontSize());
    ImGui::TextDisabled(
        "Fits at the other delays stop after a few iterations: their log L is a lower bound.");
    break;
  }
}

// The distinct optima the fit's starts reached (more than one: a second basin), each with the
// parameters that differ most from the estimate and a button that makes it the start values.
void DrawOptima(AppState& state, const FitResult& r) {
  const estimate::EstimateSummary& s = r.summary;
  if (s.optima.size() < 2) return;
  SectionHeading(state, "Distinct optima");
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextDisabled(
      "The starts reached %zu optima. The estimate is the first; another can be "
      "made the start values and run again.",
      s.optima.size());
  if (s.relaxed_better)
    ImGui::TextDisabled(
        "A variance of the diffusion had ended on a bound: the fit again with the diffusion "
        "relaxed first reached the estimate.");
  ImGui::PopTextWrapPos();
  const ImGuiTableFlags flags =
      ImGuiTableFlags_BordersInnerH | ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingFixedFit;
  if (!ImGui::BeginTable("##optima", 4, flags)) return;
  ImGui::TableSetupColumn("log L");
  ImGui::TableSetupColumn("Starts");
  ImGui::TableSetupColumn("Differs most from the estimate in", ImGuiTableColumnFlags_WidthStretch);
  ImGui::TableSetupColumn("");
  ImGui::TableHeadersRow();
  for (std::size_t o = 0; o < s.optima.size(); ++o) {
    const estimate::Optimum& opt = s.optima[o];
    ImGui::PushID(static_cast<int>(o));
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(FormatFixed(opt.loglik, 3).c_str());
    ImGui::TableNextColumn();
    ImGui::Text("%d%s", opt.starts, opt.converged ? "" : " (stopped early)");
    ImGui::TableNextColumn();
    if (o == 0) {
      ImGui::TextDisabled("the estimate");
    } else {
      std::string most;
      for (const std::size_t i : s.DifferMost(o, 3))
        most += fmt::format("{}{} {:.4g}", most.empty() ? "" : ", ", s.parameters[i].name,
                            opt.theta[i]);
      ImGui::TextUnformatted(most.c_str());
    }
    ImGui::TableNextColumn();
    if (o > 0 && ImGui::SmallButton("Use as start values")) {
      state.parameters_view.use_estimates_requested = true;
      state.parameters_view.use_optimum = o;
    }
    ImGui::PopID();
  }
  ImGui::EndTable();
}

// Every fit of the project (kept beside it): its figures, which the views show, two of them
// compared by the likelihood-ratio test, and any shown, made the start values or deleted.
void DrawFits(AppState& state) {
  EstimationState& e = state.estimation;
  if (e.fits.empty()) return;
  SectionHeading(state, "Fits");
  const bool on_disk = e.keep_on_disk && state.project && !state.project->path.empty();
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextDisabled("%s%s",
                      on_disk ? "Every fit is kept beside the project, as a result file "
                                "greybench-cli reads. "
                              : "",
                      e.fits.size() < 2 ? "A second fit (another model, or a parameter fixed) "
                                          "can be compared with this one."
                                        : "Tick two fits to compare them by the likelihood-ratio "
                                          "test.");
  ImGui::PopTextWrapPos();
  // The model's name takes what the figures and buttons leave (clipped; its tooltip has it all).
  const ImGuiTableFlags flags = ImGuiTableFlags_BordersInnerH | ImGuiTableFlags_RowBg |
                                ImGuiTableFlags_SizingFixedFit | ImGuiTableFlags_ScrollY;
  const float rows = static_cast<float>(std::min<std::size_t>(e.fits.size(), 8) + 1);
  const float height = rows * ImGui::GetFrameHeightWithSpacing() + ImGui::GetStyle().CellPadding.y;
  std::optional<std::size_t> show, start, remove;
  if (e.selected < 0 || e.selected >= static_cast<int>(e.fits.size())) e.selected = e.shown;
  if (ImGui::BeginTable("##fits", 10, flags, ImVec2(0, height))) {
    ImGui::TableSetupScrollFreeze(0, 1);
    ImGui::TableSetupColumn("");
    ImGui::TableSetupColumn("Fit");
    ImGui::TableSetupColumn("Model", ImGuiTableColumnFlags_WidthStretch);
    ImGui::TableSetupColumn("Finished");
    ImGui::TableSetupColumn("log L");
    ImGui::TableSetupColumn("Free");
    ImGui::TableSetupColumn("AIC");
    ImGui::TableSetupColumn("BIC");
    ImGui::TableSetupColumn("Status");
    ImGui::TableSetupColumn("Compare");
    ImGui::TableHeadersRow();
    for (std::size_t i = 0; i < e.fits.size(); ++i) {
      const KeptFit& k = e.fits[i];
      const estimate::EstimateSummary& s = k.fit.summary;
      const int at = static_cast<int>(i);
      ImGui::PushID(at);
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      if (e.shown == at) ImGui::TextUnformatted("\xE2\x97\x8F");  // shown in the views
      ImGui::TableNextColumn();
      // The row is selected by a click anywhere on it; the buttons below act on it.
      if (ImGui::Selectable(
              std::to_string(k.number).c_str(), e.selected == at,
              ImGuiSelectableFlags_SpanAllColumns | ImGuiSelectableFlags_AllowItemOverlap))
        e.selected = at;
      if (!k.file.empty() && ImGui::IsItemHovered()) ImGui::SetTooltip("%s", k.file.c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(s.model_name.c_str());
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", s.model_name.c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(k.finished.empty() ? "\xE2\x80\x94" : k.finished.c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(FormatFixed(s.loglik, 3).c_str());
      ImGui::TableNextColumn();
      ImGui::Text("%d", s.n_free);
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(FormatFixed(s.aic, 2).c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(FormatFixed(s.bic, 2).c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(FitStatus(s));
      ImGui::TableNextColumn();
      bool ticked = e.compare_a == at || e.compare_b == at;
      if (ImGui::Checkbox("##compare", &ticked)) {
        if (!ticked) {
          if (e.compare_a == at) e.compare_a = e.compare_b;
          e.compare_b = -1;
        } else if (e.compare_a < 0) {
          e.compare_a = at;
        } else {
          if (e.compare_b >= 0) e.compare_a = e.compare_b;  // the older choice goes
          e.compare_b = at;
        }
      }
      ImGui::PopID();
    }
    ImGui::EndTable();
  }
  if (e.selected >= 0) {
    const auto i = static_cast<std::size_t>(e.selected);
    const KeptFit& k = e.fits[i];
    ImGui::BeginDisabled(e.shown == e.selected);
    if (ImGui::Button("Show in the views")) show = i;
    ImGui::EndDisabled();
    ImGui::SameLine();
    if (ImGui::Button("Use as start values")) start = i;
    ImGui::SameLine();
    if (ImGui::Button("Delete\xE2\x80\xA6")) ImGui::OpenPopup("Delete fit?");
    if (ImGui::BeginPopup("Delete fit?")) {
      ImGui::Text("Delete fit %d%s?", k.number,
                  k.file.empty() ? "" : " and its two files beside the project");
      if (ImGui::Button("Delete")) {
        remove = i;
        ImGui::CloseCurrentPopup();
      }
      ImGui::SameLine();
      if (ImGui::Button("Keep it")) ImGui::CloseCurrentPopup();
      ImGui::EndPopup();
    }
    ImGui::SameLine();
    std::string why_not;
    const std::string command = FitCommand(state, i, &why_not);
    ImGui::BeginDisabled(command.empty());
    if (ImGui::Button("Copy as command")) {
      ImGui::SetClipboardText(command.c_str());
      AddMessage(state, Severity::kInfo, "Copied the command that fits it again: " + command);
    }
    ImGui::EndDisabled();
    if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
      ImGui::SetTooltip("%s", command.empty() ? why_not.c_str()
                                              : "The greybench-cli command that fits it again, "
                                                "from the files kept beside the project");
    ImGui::SameLine();
    ImGui::TextDisabled("fit %d", k.number);
  }
  std::string why;
  if (show && !ShowFit(state, *show, &why))
    AddMessage(state, Severity::kError, "Cannot show the fit: " + why);
  if (start) {
    if (ShowFit(state, *start, &why)) {
      state.parameters_view.use_estimates_requested = true;
      state.parameters_view.use_optimum = 0;
    } else {
      AddMessage(state, Severity::kError, "Cannot use the fit's estimates: " + why);
    }
  }
  if (remove && !DeleteFit(state, *remove, &why))
    AddMessage(state, Severity::kError, "Cannot delete the fit: " + why);
  if (e.compare_a < 0 || e.compare_b < 0) return;
  std::string notes;
  const auto a = static_cast<std::size_t>(e.compare_a), b = static_cast<std::size_t>(e.compare_b);
  Result<estimate::LikelihoodRatioTest> test = CompareFits(state, a, b, &notes);
  ImGui::PushTextWrapPos(0.0f);
  if (!test) {
    ImGui::TextColored(SeverityColor(Severity::kWarning), "Fits %d and %d: %s", e.fits[a].number,
                       e.fits[b].number, test.error().message.c_str());
  } else {
    const KeptFit& r =
        e.fits[a].fit.summary.n_free < e.fits[b].fit.summary.n_free ? e.fits[a] : e.fits[b];
    const KeptFit& f = &r == &e.fits[a] ? e.fits[b] : e.fits[a];
    ImGui::Text(
        "Likelihood-ratio test of fit %d (%d free) against fit %d (%d free): "
        "2 (log L\xE2\x82\x82 \xE2\x88\x92 log L\xE2\x82\x81) = %s, %d degrees of "
        "freedom, p = %s.",
        r.number, r.fit.summary.n_free, f.number, f.fit.summary.n_free,
        FormatFixed(test->statistic, 3).c_str(), test->df, FormatSig(test->p_value, 3).c_str());
    const bool better = test->p_value < 0.05;
    ImGui::TextColored(better ? ImVec4(0.17f, 0.63f, 0.17f, 1.0f) : SeverityColor(Severity::kInfo),
                       "%s",
                       better ? "The fit with more parameters is significantly better (5 % level): "
                                "keep the extra parameters."
                              : "The fit with more parameters is not significantly better (5 % "
                                "level): the smaller model suffices.");
    if (!notes.empty()) ImGui::TextDisabled("%s", notes.c_str());
  }
  ImGui::PopTextWrapPos();
}

void DrawReport(AppState& state, const FitResult& r, bool previous) {
  const float s = state.fonts.scale;
  SectionHeading(state, previous ? "Report of the previous run" : "Report");
  if (ImGui::SmallButton("Copy to clipboard")) ImGui::SetClipboardText(r.report.c_str());
  ImGui::SameLine();
  if (ImGui::SmallButton("Save report\xE2\x80\xA6")) BrowseSaveReport(state, r, !previous);
  ImGui::SameLine();
  ImGui::TextDisabled("the text greybench-cli estimate prints");
  const float height = std::max(kMinReportHeight * s, ImGui::GetContentRegionAvail().y);
  ImGui::PushStyleColor(ImGuiCol_ChildBg, Colors(state.shell.theme).pane_bg);
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(10.0f * s, 8.0f * s));
  ImGui::BeginChild("##report", ImVec2(0, height), true,
                    ImGuiWindowFlags_HorizontalScrollbar | ImGuiWindowFlags_AlwaysUseWindowPadding);
  ImGui::PushFont(state.fonts.mono);
  ImGui::TextUnformatted(r.report.c_str(), r.report.c_str() + r.report.size());
  ImGui::PopFont();
  ImGui::EndChild();
  ImGui::PopStyleVar();
  ImGui::PopStyleColor();
}

void DrawNothingYet(AppState& state) {
  const model::ModelSpec& m = *state.model;
  int free = 0;
  for (const model::Parameter& p : m.parameters) free += p.fixed ? 0 : 1;
  std::string text = "Run fits the " + std::to_string(free) + " free parameters";
  if (m.HasDelayScan()) text += " and the scanned output delays";
  text += " of \"" + (m.name.empty() ? std::string("the model") : m.name) + "\" to " +
          std::to_string(state.datasets.size()) +
          (state.datasets.size() == 1 ? " dataset" : " datasets") +
          " by maximum likelihood. The start values and bounds are those of the Parameters "
          "view.";
  DrawNotice(state, "No estimate yet", text);
}

}  // namespace

void DrawEstimatePanel(AppState& state) {
  if (DrawNoProjectNotice(state)) return;
  DrawToolbar(state);
  ImGui::Spacing();
  if (!state.model) {
    DrawNotice(state, "The model is not valid", state.model_error, Severity::kError);
    return;
  }

  EstimationState& e = state.estimation;
  const bool running = EstimationRunning(state);
  const FitResult* result = e.result ? &*e.result : nullptr;
  if (running) {
    DrawRunning(state);
  } else if (result) {
    DrawResultStatus(state, *result);
  }
  if (!running && !e.last_failure.empty()) {
    std::string text = e.last_failure;
    if (!text.empty() && text.back() != '.') text += '.';
    if (result) text += " The results below are from the previous run.";
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextColored(SeverityColor(e.last_failure_severity), "%s", text.c_str());
    ImGui::PopTextWrapPos();
  }
  if (result && !running && result->model_revision != state.model_revision) {
    ImGui::TextColored(SeverityColor(Severity::kWarning),
                       "The parameters were edited after this fit: run again to update it.");
  }
  if (!running && !result) {
    if (e.last_failure.empty()) DrawNothingYet(state);
    DrawFits(state);
    return;
  }
  if (result && !running) DrawKeyFigures(state, *result);
  ImGui::Spacing();
  DrawPlots(state, running ? e.live_trace : result->trace, running ? nullptr : result);
  if (result && !running) {
    DrawOptima(state, *result);
    DrawFits(state);
    // The Parameters view applies such a request when it is drawn; here it may not be.
    if (state.parameters_view.use_estimates_requested) ApplyParameterEdits(state);
  }
  if (result) DrawReport(state, *result, running);
}

}  // namespace gb::ui
