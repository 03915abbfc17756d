// The operating points view: one model fitted to every dataset of the project's sweep
// ("operating_points", core/project/operating_points.h), each dataset tagged with the operating
// point it was recorded at. Run / Cancel and the progress of the sweep under way; once a sweep
// has finished, the paper's Table 2 layout (one column per point: tags, delay, estimates with
// standard errors, the means over the points) and two plots: the delay against speed with the
// fitted Δt = c / n (Fig. 3), and any parameter against any tag with a fitted line (Fig. 4: X
// against the throttle angle α). A project that names a fitted nonlinear model
// (operating_points.linearised) gets that model linearised at every point beside the per-point
// fits: rows beneath the estimates of the same name, and markers of their own in both plots.
//
// The sweep runs in AppState::sweep.job (StartSweep); this panel only reads the status record
// and the installed result, and never waits for the job.
//
// Sections
//   1. Run, Cancel and what the sweep is; the status of the run
//   2. Table 2
//   3. Plots: Fig. 3 and the trend (Fig. 4)
//   4. What the view says before there is a sweep
//   5. DrawOperatingPointsPanel
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include <imgui.h>

#include "ui/format.h"
#include "ui/panels/common.h"
#include "ui/panels/panels.h"

namespace gb::ui {
namespace {

constexpr float kMinPlotHeight = 220.0f;  // pixels at scale 1; below it the view scrolls
constexpr float kComboWidth = 130.0f;
constexpr double kPointsXPadding = 0.06;  // the end points do not sit on the frame
constexpr ImU32 kPointColor = IM_COL32(31, 119, 180, 255);
constexpr ImU32 kFitColor = IM_COL32(214, 39, 40, 255);
constexpr ImU32 kLinearisedColor = IM_COL32(255, 127, 14, 255);
constexpr double kDisagreeZ = 3;  // combined SEs beyond which a linearised cell is marked
constexpr const char* kMiddleDot = "  \xC2\xB7  ";
constexpr const char* kPlusMinus = " \xC2\xB1 ";

std::string Elapsed(const AppState& state) {
  if (state.deterministic) return kElapsedPlaceholder;
  const double s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - state.sweep.started).count();
  return FormatFixed(s, 1) + " s";
}

// "fuel_f1.csv, fuel_f2.csv and 4 more"
std::string FileList(const std::vector<std::string>& files, std::size_t shown) {
  std::string out;
  for (std::size_t i = 0; i < files.size() && i < shown; ++i)
    out += (i == 0 ? "" : ", ") + FileName(files[i]);
  if (files.size() > shown) out += " and " + std::to_string(files.size() - shown) + " more";
  return out;
}

std::string FileList(const std::vector<data::DatasetSpec>& datasets, std::size_t shown) {
  std::vector<std::string> files;
  for (const data::DatasetSpec& d : datasets) files.push_back(d.file);
  return FileList(files, shown);
}

// The label of a tag with its unit, for axes and choices.
std::string TagText(const project::OperatingPointsSpec& points, const std::string& tag) {
  const project::TagLabel l = points.Label(tag);
  return l.unit.empty() ? l.label : l.label + " [" + l.unit + "]";
}

// ---------------------------------------------------------------------------------------------
// 1. Run, Cancel and what the sweep is

void DrawToolbar(AppState& state) {
  const float s = state.fonts.scale;
  SweepState& w = state.sweep;
  const bool running = SweepRunning(state);
  const bool own_model = w.spec && !w.spec->model.empty();  // operating_points.model
  const bool can_run = !running && w.spec && (state.model || own_model) && !state.load_job.active();
  ImGui::BeginDisabled(!can_run);
  const bool run = PrimaryButton("Run", ImVec2(80.0f * s, 0));
  ImGui::EndDisabled();
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) {
    ImGui::SetTooltip("%s", !state.model && !own_model
                                ? "The model is not valid (see the Equations view)"
                            : !w.spec ? "The project names no operating points"
                                      : "Fit the model to every operating point");
  }
  if (run) {
    std::string why;
    if (!StartSweep(state, &why)) AddMessage(state, Severity::kError, "Cannot sweep: " + why);
  }
  ImGui::SameLine();
  ImGui::BeginDisabled(!running);
  if (ImGui::Button("Cancel", ImVec2(80.0f * s, 0))) CancelSweep(state);
  ImGui::EndDisabled();
  if (!w.spec) return;
  const project::OperatingPointsSpec& p = *w.spec;
  ImGui::SameLine(0, 1.6f * ImGui::GetFontSize());
  ImGui::AlignTextToFramePadding();
  const std::string what = std::to_string(p.datasets.size()) +
                           (p.datasets.size() == 1 ? " dataset" : " datasets") +
                           (p.datasets_from_project ? " of the project" : "") + kMiddleDot +
                           "delay against " + p.Label(p.speed_tag).label + kMiddleDot +
                           p.trend_parameter + " against " + p.Label(p.trend_tag).label;
  ImGui::TextDisabled("%s", what.c_str());
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", FileList(p.datasets, 100).c_str());
}

void DrawRunning(AppState& state) {
  const SweepState& w = state.sweep;
  const std::vector<SweepStatus::PointState> states =
      w.status ? w.status->states() : std::vector<SweepStatus::PointState>{};
  std::vector<std::string> fitting;
  int done = 0;
  for (std::size_t i = 0; i < states.size() && i < w.running_datasets.size(); ++i) {
    if (states[i] == SweepStatus::PointState::kFitting) fitting.push_back(w.running_datasets[i]);
    if (states[i] == SweepStatus::PointState::kDone) ++done;
  }
  std::string rest = fitting.empty() ? std::string("starting") : "fitting " + FileList(fitting, 4);
  rest += kMiddleDot + std::to_string(done) + " of " + std::to_string(states.size()) + " done" +
          kMiddleDot + Elapsed(state);
  StatusLine(state, IM_COL32(47, 111, 219, 255), "Sweeping", rest);
  const float fraction =
      states.empty() ? 0.0f : static_cast<float>(done) / static_cast<float>(states.size());
  ImGui::ProgressBar(fraction, ImVec2(-1, 4.0f * state.fonts.scale), "");
}

void DrawResultStatus(AppState& state, const SweepFigures& f) {
  const auto& rows = f.result.rows;
  const auto converged =
      std::count_if(rows.begin(), rows.end(), [](const auto& r) { return r.summary.converged; });
  const bool all = converged == static_cast<long>(rows.size());
  const std::string rest = std::to_string(rows.size()) + " operating points, " +
                           (all ? "every fit converged" : std::to_string(converged) + " converged");
  StatusLine(state,
             all ? IM_COL32(44, 160, 44, 255)
                 : ImGui::ColorConvertFloat4ToU32(SeverityColor(Severity::kWarning)),
             all ? "Fitted" : "Not all converged", rest);
}

// ---------------------------------------------------------------------------------------------
// 2. Table 2

// The width the table takes with every column fitting its widest cell.
float TableWidth(AppState& state, const SweepFigures& f, bool with_mean) {
  const ImGuiStyle& style = ImGui::GetStyle();
  const float pad = 2.0f * style.CellPadding.x + 1.0f;  // both sides and the border
  float labels = ImGui::CalcTextSize("Point").x;
  ImGui::PushFont(state.fonts.mono);
  for (const SweepTableRow& row : f.table)
    labels = std::max(labels, ImGui::CalcTextSize(row.label.c_str()).x);
  ImGui::PopFont();
  float width = labels + pad;
  for (std::size_t c = 0; c < f.columns.size(); ++c) {
    float w = ImGui::CalcTextSize(f.columns[c].c_str()).x;
    for (const SweepTableRow& row : f.table)
      w = std::max(w, ImGui::CalcTextSize(row.cells[c].c_str()).x);
    width += w + pad;
  }
  if (with_mean) {
    float w = ImGui::CalcTextSize("mean (SD)").x;
    for (const SweepTableRow& row : f.table)
      w = std::max(w, ImGui::CalcTextSize(row.mean.c_str()).x);
    width += w + pad;
  }
  return width;
}

void DrawTable(AppState& state, const SweepFigures& f) {
  const bool with_mean = std::any_of(f.table.begin(), f.table.end(),
                                     [](const SweepTableRow& r) { return !r.mean.empty(); });
  const int columns = 1 + static_cast<int>(f.columns.size()) + (with_mean ? 1 : 0);
  ImGuiTableFlags flags = ImGuiTableFlags_BordersOuter | ImGuiTableFlags_BordersInnerH |
                          ImGuiTableFlags_BordersInnerV | ImGuiTableFlags_RowBg |
                          ImGuiTableFlags_SizingFixedFit | ImGuiTableFlags_NoSavedSettings;
  // Many points: the table scrolls sideways (the labels stay), with room for the scrollbar.
  const float width = TableWidth(state, f, with_mean);
  ImVec2 outer(0, 0);
  if (width > ImGui::GetContentRegionAvail().x) {
    flags |= ImGuiTableFlags_ScrollX;
    const float row_h = ImGui::GetTextLineHeight() + 2.0f * ImGui::GetStyle().CellPadding.y;
    outer.y = row_h * static_cast<float>(f.table.size() + 1) + ImGui::GetStyle().ScrollbarSize +
              2.0f * state.fonts.scale;
  }
  if (!ImGui::BeginTable("##table2", columns, flags, outer)) return;
  if (flags & ImGuiTableFlags_ScrollX) ImGui::TableSetupScrollFreeze(1, 0);
  ImGui::TableSetupColumn("Point");
  for (const std::string& c : f.columns) ImGui::TableSetupColumn(c.c_str());
  if (with_mean) ImGui::TableSetupColumn("mean (SD)");
  ImGui::TableHeadersRow();
  for (const SweepTableRow& row : f.table) {
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::PushFont(state.fonts.mono);
    if (row.linearised) {
      ImGui::TextColored(ImGui::ColorConvertU32ToFloat4(kLinearisedColor), "%s", row.label.c_str());
      if (ImGui::IsItemHovered() && f.linearised) {
        ImGui::SetTooltip("%s linearised at each point, with delta-method standard errors\n(%s)",
                          f.linearised->model_name.c_str(), FileName(f.linearised->result).c_str());
      }
    } else {
      ImGui::TextUnformatted(row.label.c_str());
    }
    ImGui::PopFont();
    for (std::size_t c = 0; c < row.cells.size(); ++c) {
      const std::string& cell = row.cells[c];
      ImGui::TableNextColumn();
      const double z = c < row.z.size() ? row.z[c] : NAN;
      if (row.linearised && std::isfinite(z)) {
        if (std::abs(z) > kDisagreeZ) {
          ImGui::TextColored(SeverityColor(Severity::kWarning), "%s", cell.c_str());
        } else {
          ImGui::TextUnformatted(cell.c_str());
        }
        if (ImGui::IsItemHovered()) {
          ImGui::SetTooltip("%s the per-point estimate by %s combined standard errors",
                            z >= 0 ? "Above" : "Below", FormatFixed(std::abs(z), 1).c_str());
        }
      } else if (cell == kDash) {
        ImGui::TextDisabled("%s", cell.c_str());
      } else if (cell == "NO") {
        ImGui::TextColored(SeverityColor(Severity::kWarning), "%s", cell.c_str());
      } else {
        ImGui::TextUnformatted(cell.c_str());
      }
    }
    if (with_mean) {
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(row.mean.c_str());
    }
  }
  ImGui::EndTable();
  ImGui::TextDisabled(
      "Estimates with standard errors in brackets; the mean over the points with "
      "the standard deviation across them.");
  if (f.linearised) {
    ImGui::PushTextWrapPos(0.0f);
    const std::string text =
        "Linearised (orange): " + FileName(f.linearised->result) +
        ", the nonlinear model fitted once, linearised at each point's steady state; amber where "
        "it differs from the per-point estimate by more than " +
        FormatFixed(kDisagreeZ, 0) + " combined standard errors.";
    ImGui::TextDisabled("%s", text.c_str());
    ImGui::PopTextWrapPos();
  }
}

// ---------------------------------------------------------------------------------------------
// 3. Plots

// The linearised nonlinear fit's markers ± 1 SE at `x` (drawn beside the per-point ones: the
// arrays live in the figures until EndPlot draws them). Nothing when there are none.
void PlotLinearised(AppState& state, const std::vector<double>& x, const std::vector<double>& y,
                    const std::vector<double>& se) {
  if (x.empty()) return;
  plot::ItemStyle lin;
  lin.color = kLinearisedColor;
  lin.marker_radius = 3.5f;
  const int n = static_cast<int>(x.size());
  plot::PlotErrorBars(state.plots, "linearised nonlinear fit \xC2\xB1 1 SE", x.data(), y.data(),
                      se.data(), n, lin);
  plot::PlotMarkers(state.plots, "##linearised", x.data(), y.data(), n, lin);
}

void DrawDelayPlot(AppState& state, const SweepFigures& f, ImVec2 size) {
  const project::OperatingPointsSpec& p = f.points;
  const project::TagLabel speed = p.Label(p.speed_tag);
  const std::optional<project::LinearFit>& fit = f.result.delay_vs_speed;
  std::string title = "Delay against " + speed.label;
  if (fit) {
    title += ": \xCE\x94t = c / " + speed.label + ", c = " + FormatSig(fit->b, 4) + kPlusMinus +
             FormatSig(fit->se_b, 2) + (speed.unit.empty() ? "" : " " + speed.unit + "\xC2\xB7s");
  }
  plot::PlotOptions options;
  options.title = title.c_str();
  options.x_label = speed.label.c_str();
  options.x_unit = speed.unit.empty() ? nullptr : speed.unit.c_str();
  options.y_label = "\xCE\x94t";
  options.y_unit = "s";
  options.x_padding = kPointsXPadding;
  options.linked_x = &state.sweep.delay_x;
  options.legend = plot::Legend::kShow;
  if (!plot::BeginPlot(state.plots, "##delay", size, options)) return;
  const int n = static_cast<int>(f.speed.size());
  plot::ItemStyle fit_style;
  fit_style.color = kFitColor;
  if (fit) {
    plot::PlotLine(state.plots, "fitted c / n", f.curve_speed.data(), f.curve_delay.data(),
                   static_cast<int>(f.curve_speed.size()), fit_style);
  }
  plot::ItemStyle points;
  points.color = kPointColor;
  points.marker_radius = 3.5f;
  plot::PlotErrorBars(
      state.plots,
      f.delay_bar_is_se ? "per-point estimate \xC2\xB1 1 SE" : "estimate \xC2\xB1 half a sample",
      f.speed.data(), f.delay.data(), f.delay_bar.data(), n, points);
  plot::PlotMarkers(state.plots, "##estimates", f.speed.data(), f.delay.data(), n, points);
  PlotLinearised(state, f.lin_speed_drawn, f.lin_delay, f.lin_delay_se);
  plot::EndPlot(state.plots);
}

// The parameter and tag choices of the trend plot, on one line.
void DrawTrendChoice(AppState& state, const SweepFigures& f) {
  const float s = state.fonts.scale;
  std::string parameter = state.sweep.trend.parameter;
  std::string tag = state.sweep.trend.tag;
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("Plot");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(kComboWidth * s);
  if (ImGui::BeginCombo("##parameter", parameter.c_str())) {
    for (const std::string& name : f.parameters)
      if (ImGui::Selectable(name.c_str(), name == parameter)) parameter = name;
    ImGui::EndCombo();
  }
  ImGui::SameLine();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("against");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(kComboWidth * s);
  const std::string tag_text = TagText(f.points, tag);
  if (ImGui::BeginCombo("##tag", tag_text.c_str())) {
    for (const std::string& t : f.tags)
      if (ImGui::Selectable(TagText(f.points, t).c_str(), t == tag)) tag = t;
    ImGui::EndCombo();
  }
  SelectTrend(state, parameter, tag);  // the edit, applied now (nothing else reads it)
}

std::string UnitOf(const SweepFigures& f, const std::string& parameter) {
  if (f.result.rows.empty()) return "";
  for (const estimate::ParameterEstimate& p : f.result.rows[0].summary.parameters)
    if (p.name == parameter) return p.unit;
  return "";
}

void DrawTrendPlot(AppState& state, const SweepFigures& f, ImVec2 size) {
  const TrendPlot& t = state.sweep.trend;
  const project::TagLabel tag = f.points.Label(t.tag);
  const std::string unit = UnitOf(f, t.parameter);
  std::string title = t.parameter + " against " + tag.label;
  if (t.fit) {
    title += ": slope " + FormatSig(t.fit->b, 3) + kPlusMinus + FormatSig(t.fit->se_b, 2) +
             (tag.unit.empty() ? "" : " per " + tag.unit) + ", R\xC2\xB2 " +
             FormatFixed(t.fit->r2, 2);
  }
  plot::PlotOptions options;
  options.title = title.c_str();
  options.x_label = tag.label.c_str();
  options.x_unit = tag.unit.empty() ? nullptr : tag.unit.c_str();
  options.y_label = t.parameter.c_str();
  options.y_unit = unit.empty() ? nullptr : unit.c_str();
  options.x_padding = kPointsXPadding;
  options.linked_x = &state.sweep.trend_x;
  options.legend = plot::Legend::kShow;
  options.legend_corner =
      t.fit && t.fit->b < 0 ? plot::LegendCorner::kTopRight : plot::LegendCorner::kTopLeft;
  if (!plot::BeginPlot(state.plots, "##trend", size, options)) return;
  const int n = static_cast<int>(t.x.size());
  if (t.fit) {
    plot::ItemStyle line;
    line.color = kFitColor;
    plot::PlotLine(state.plots, "least-squares line", t.line_x.data(), t.line_y.data(),
                   static_cast<int>(t.line_x.size()), line);
  }
  plot::ItemStyle points;
  points.color = kPointColor;
  points.marker_radius = 3.5f;
  plot::PlotErrorBars(
      state.plots, t.lin_x.empty() ? "estimate \xC2\xB1 1 SE" : "per-point estimate \xC2\xB1 1 SE",
      t.x.data(), t.y.data(), t.se.data(), n, points);
  plot::PlotMarkers(state.plots, "##estimates", t.x.data(), t.y.data(), n, points);
  PlotLinearised(state, t.lin_x_drawn, t.lin_y, t.lin_se);
  plot::EndPlot(state.plots);
}

void DrawPlots(AppState& state, const SweepFigures& f) {
  const float s = state.fonts.scale;
  // The trend's choices sit above its plot; the delay plot starts level with them.
  const float choice_h = ImGui::GetFrameHeightWithSpacing();
  const float height =
      std::max(kMinPlotHeight * s, ImGui::GetContentRegionAvail().y - choice_h - 2.0f * s);
  const bool has_delay = !f.speed.empty();
  if (ImGui::BeginTable("##plots", 2, ImGuiTableFlags_SizingStretchSame)) {
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::Dummy(ImVec2(0, choice_h - ImGui::GetStyle().ItemSpacing.y));
    if (has_delay) {
      DrawDelayPlot(state, f, ImVec2(-1, height));
    } else {
      ImGui::PushTextWrapPos(0.0f);
      ImGui::TextDisabled(
          "No delay plot: the points need a \"%s\" tag, and the model a scanned output delay "
          "(output_delay with min and max) or a delay parameter (operating_points."
          "delay_parameter).",
          f.points.speed_tag.c_str());
      ImGui::PopTextWrapPos();
    }
    ImGui::TableNextColumn();
    DrawTrendChoice(state, f);
    DrawTrendPlot(state, f, ImVec2(-1, height));
    if (state.sweep.trend.without_se > 0) {
      ImGui::TextDisabled("%d point(s) without a standard error (at a bound or not determined)",
                          state.sweep.trend.without_se);
    }
    ImGui::EndTable();
  }
}

// ---------------------------------------------------------------------------------------------
// 4. What the view says before there is a sweep

constexpr const char* kKeyExample =
    "\"operating_points\": {\n"
    "  \"datasets\": [\"data/point1.csv\", \"data/point2.csv\", \"data/point3.csv\"],\n"
    "  \"trend\": {\"parameter\": \"X\", \"tag\": \"alpha_deg\"}\n"
    "}";

void DrawNoSweep(AppState& state) {
  const std::size_t n = state.project->datasets.size();
  std::string text =
      "A sweep fits the model separately to datasets recorded at different operating points "
      "and relates the estimates to the points. Name its datasets in the project file:\n\n" +
      std::string(kKeyExample) +
      "\n\nEach data file carries its operating point in a comment line such as\n"
      "# greybench: {\"operating_point\": {\"name\": \"f1\", \"n_rpm\": 2931, \"alpha_deg\": 29.5}}"
      "\n(docs/user-guide.md describes every member).";
  DrawNotice(state, "The project names no operating points", text);
  if (n < 2) return;
  ImGui::Spacing();
  const std::string label = "Sweep the project's " + std::to_string(n) + " datasets";
  const float w = ImGui::CalcTextSize(label.c_str()).x + 2.0f * ImGui::GetStyle().FramePadding.x;
  ImGui::SetCursorPosX(ImGui::GetCursorPosX() +
                       std::max(0.0f, 0.5f * (ImGui::GetContentRegionAvail().x - w)));
  if (ImGui::Button(label.c_str())) SweepProjectDatasets(state);
}

void DrawNothingYet(AppState& state) {
  const project::OperatingPointsSpec& p = *state.sweep.spec;
  const std::string fitted =
      p.model.empty() ? "the model, with the start values and bounds of the Parameters view,"
                      : FileName(p.model) +
                            " (operating_points.model), with its start values "
                            "and bounds,";
  std::string text = "Run fits " + fitted + " to each of the " + std::to_string(p.datasets.size()) +
                     " datasets (" + FileList(p.datasets, 3) +
                     "), then relates the estimates to the operating points: the delay against " +
                     p.Label(p.speed_tag).label + " (\xCE\x94t = c / n) and " + p.trend_parameter +
                     " against " + p.Label(p.trend_tag).label + ".";
  if (p.linearised) {
    text += " Beside each point it shows " + FileName(p.linearised->result) +
            ", the nonlinear model fitted once, linearised at that point.";
  }
  DrawNotice(state, "No sweep yet", text);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 5. DrawOperatingPointsPanel

void DrawOperatingPointsPanel(AppState& state) {
  if (DrawNoProjectNotice(state)) return;
  SweepState& w = state.sweep;
  if (!w.spec_error.empty()) {
    DrawNotice(state, "The operating points are not valid",
               w.spec_error +
                   "\n\nCorrect the key \"operating_points\" in the project file, "
                   "then File \xE2\x80\xBA Reload project.",
               Severity::kError);
    return;
  }
  if (!w.spec) {
    DrawNoSweep(state);
    return;
  }
  DrawToolbar(state);
  ImGui::Spacing();
  if (!state.model) {
    DrawNotice(state, "The model is not valid", state.model_error, Severity::kError);
    return;
  }
  const bool running = SweepRunning(state);
  const SweepFigures* result = w.result ? &*w.result : nullptr;
  if (running) {
    DrawRunning(state);
  } else if (result) {
    DrawResultStatus(state, *result);
  }
  if (!running && !w.last_failure.empty()) {
    std::string text = w.last_failure;
    if (text.back() != '.') text += '.';
    if (result) text += " The table below is from the previous sweep.";
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextColored(
        SeverityColor(w.last_failure_is_error ? Severity::kError : Severity::kWarning), "%s",
        text.c_str());
    ImGui::PopTextWrapPos();
  }
  if (result && !running && result->model_revision != state.model_revision) {
    ImGui::TextColored(SeverityColor(Severity::kWarning),
                       "The parameters were edited after this sweep: run again to update it.");
  }
  if (!result) {
    if (!running && w.last_failure.empty()) DrawNothingYet(state);
    return;
  }
  if (!result->linearised_error.empty()) {
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextColored(
        SeverityColor(Severity::kError), "%s",
        ("The nonlinear fit could not be linearised at the points: " + result->linearised_error)
            .c_str());
    ImGui::PopTextWrapPos();
  }
  ImGui::Spacing();
  DrawTable(state, *result);
  ImGui::Spacing();
  DrawPlots(state, *result);
}

}  // namespace gb::ui
