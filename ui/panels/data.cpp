// The data view: per dataset a summary (samples, sample time, time span), a table of the
// columns (role in the model, missing values, range) and one plot per column against time,
// stacked, their x axes linked. Over each output, on request, a preview of the model's
// simulated response at its current values (the deterministic response to the measured inputs,
// computed by the analysis job: AppState::analysis, ui/jobs/analysis.h).
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "core/util/json.h"
#include "ui/format.h"
#include "ui/panels/analysis_view.h"
#include "ui/panels/common.h"
#include "ui/panels/panels.h"

namespace gb::ui {
namespace {

constexpr float kMinPlotHeight = 150.0f;  // pixels at scale 1; below it the plots scroll
constexpr int kMaxTableRows = 8;          // more columns than this scroll inside the table

// The names listed under `key` ("inputs", "outputs") in the model JSON; tolerant of a model
// that core/model would reject (the data view shows the data even then).
template <class J>
std::vector<std::string> NameList(const J& model, const char* key) {
  std::vector<std::string> names;
  if (!model.is_object() || !model.contains(key) || !model[key].is_array()) return names;
  for (const auto& v : model[key]) {
    if (v.is_string()) names.push_back(v.template get<std::string>());
  }
  return names;
}

bool Contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

std::string SampleTimeText(const DatasetSummary& s) {
  if (s.rows < 2) return "\xE2\x80\x94";
  std::string text = plot::FormatValue(s.median_interval);
  if (s.uniform) return text + " (uniform)";
  return text + " (median; " + plot::FormatValue(s.min_interval) + " \xE2\x80\xA6 " +
         plot::FormatValue(s.max_interval) + ")";
}

void DrawSummaryLine(const LoadedDataset& d) {
  const DatasetSummary& s = d.summary;
  const float gap = 2.0f * ImGui::GetFontSize();
  LabelValue("Samples", GroupedCount(static_cast<long long>(s.rows)));
  ImGui::SameLine(0, gap);
  LabelValue("Sample time", SampleTimeText(s));
  ImGui::SameLine(0, gap);
  LabelValue("Time", plot::FormatValue(s.t_first) + " \xE2\x80\xA6 " + plot::FormatValue(s.t_last));
  ImGui::SameLine(0, gap);
  LabelValue("File", d.path);
}

void DrawColumnTable(AppState& state, const LoadedDataset& d) {
  const data::Dataset& data = *d.data;
  const auto& model = state.project->model_json;
  const std::vector<std::string> inputs = NameList(model, "inputs");
  const std::vector<std::string> outputs = NameList(model, "outputs");

  const int rows = static_cast<int>(data.columns.size());
  const float row_h = ImGui::GetTextLineHeight() + 2.0f * ImGui::GetStyle().CellPadding.y;
  const float height = row_h * static_cast<float>(std::min(rows, kMaxTableRows) + 1) + 2.0f;
  const ImGuiTableFlags flags = ImGuiTableFlags_BordersOuter | ImGuiTableFlags_BordersInnerH |
                                ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingFixedFit |
                                ImGuiTableFlags_ScrollY;
  if (!ImGui::BeginTable("##columns", 7, flags, ImVec2(0, height))) return;
  ImGui::TableSetupScrollFreeze(0, 1);
  ImGui::TableSetupColumn("Column");
  ImGui::TableSetupColumn("Role");
  ImGui::TableSetupColumn("Missing");
  ImGui::TableSetupColumn("Min");
  ImGui::TableSetupColumn("Max");
  ImGui::TableSetupColumn("Mean");
  ImGui::TableSetupColumn("Notes", ImGuiTableColumnFlags_WidthStretch);
  ImGui::TableHeadersRow();
  for (int c = 0; c < rows; ++c) {
    const data::Column& column = data.columns[c];
    const ColumnSummary& cs = d.summary.columns[c];
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(column.name.c_str());
    ImGui::TableNextColumn();
    if (Contains(inputs, column.name)) {
      ImGui::TextUnformatted("input");
    } else if (Contains(outputs, column.name)) {
      ImGui::TextUnformatted("output");
    } else {
      ImGui::TextDisabled("not in the model");
    }
    ImGui::TableNextColumn();
    if (cs.n_missing == 0) {
      ImGui::TextDisabled("0");
    } else {
      const double pct = 100.0 * cs.n_missing / std::max<std::size_t>(1, d.summary.rows);
      char buf[32];
      std::snprintf(buf, sizeof buf, " (%.1f %%)", pct);
      ImGui::TextColored(SeverityColor(Severity::kWarning), "%s%s",
                         GroupedCount(cs.n_missing).c_str(), buf);
    }
    for (double v : {cs.min, cs.max, cs.mean}) {
      ImGui::TableNextColumn();
      if (cs.n_values > 0) {
        ImGui::TextUnformatted(plot::FormatValue(v).c_str());
      } else {
        ImGui::TextDisabled("\xE2\x80\x94");
      }
    }
    ImGui::TableNextColumn();
    if (cs.has_bad_cell) {
      ImGui::TextColored(SeverityColor(Severity::kError), "line %d: \"%s\" is not a number",
                         column.bad_line, column.bad_text.c_str());
    } else if (cs.n_values == 0) {
      ImGui::TextDisabled("no values");
    }
  }
  ImGui::EndTable();

  // Model variables the file does not have: the model cannot use this dataset as it stands.
  for (const auto* names : {&inputs, &outputs}) {
    for (const std::string& name : *names) {
      if (data.Find(name) != -1) continue;
      ImGui::TextColored(SeverityColor(Severity::kWarning),
                         "The model's %s '%s' is not a column of this file.",
                         names == &inputs ? "input" : "output", name.c_str());
    }
  }
}

// The preview of output `name` in dataset `index`, or null (not an output, none computed yet,
// or the model's values cannot be simulated).
const std::vector<double>* Preview(const AppState& state, std::size_t index,
                                   const std::string& name) {
  const std::optional<Analysis>& r = state.analysis.result;
  if (!state.data_view.show_preview || !r || index >= r->datasets.size()) return nullptr;
  const DatasetAnalysis& d = r->datasets[index];
  if (d.time.size() != state.datasets[index].data->rows()) return nullptr;
  for (const OutputAnalysis& o : d.outputs) {
    if (o.name == name && o.preview.size() == d.time.size()) return &o.preview;
  }
  return nullptr;
}

// The same in the analysis of before a slider's drag, or null.
const std::vector<double>* GhostPreview(const AppState& state, std::size_t index,
                                        const std::string& name) {
  const std::optional<Analysis>& g = state.sliders.ghost;
  if (!state.data_view.show_preview || !g || index >= g->datasets.size()) return nullptr;
  const DatasetAnalysis& d = g->datasets[index];
  for (const OutputAnalysis& o : d.outputs) {
    if (o.name == name && o.preview.size() == d.time.size() &&
        d.time.size() == state.datasets[index].data->rows())
      return &o.preview;
  }
  return nullptr;
}

// The preview's switch and what it shows.
void DrawPreviewToggle(AppState& state) {
  ImGui::Checkbox("Simulated response", &state.data_view.show_preview);
  if (ImGui::IsItemHovered()) {
    ImGui::SetTooltip(
        "Over each output: the model's deterministic response to the measured inputs at its "
        "current values (the Parameters view), from its initial state; no measurement is "
        "assimilated");
  }
  if (!state.data_view.show_preview) return;
  ImGui::SameLine();
  ImGui::AlignTextToFramePadding();
  const AnalysisState& a = state.analysis;
  const bool current =
      a.result && a.result->request.preview_theta ==
                      AnalysisRequestNow(state).value_or(AnalysisRequest{}).preview_theta;
  if (!state.model) {
    ImGui::TextDisabled("(the model is not valid)");
  } else if (a.result && !a.result->preview_error.empty()) {
    ImGui::TextColored(SeverityColor(Severity::kWarning), "(not at these values: %s)",
                       a.result->preview_error.c_str());
  } else if (!current && AnalysisRunning(state)) {
    ImGui::TextDisabled("(computing\xE2\x80\xA6)");
  } else if (!current && !a.last_failure.empty()) {
    ImGui::TextColored(SeverityColor(a.last_failure_severity), "(%s)", a.last_failure.c_str());
  } else {
    ImGui::TextDisabled("at the model's current values");
  }
}

void DrawColumnPlots(AppState& state, std::size_t index) {
  const LoadedDataset& d = state.datasets[index];
  const data::Dataset& data = *d.data;
  std::vector<int> shown;
  for (int c = 0; c < static_cast<int>(data.columns.size()); ++c) {
    if (d.summary.columns[c].n_values > 0) shown.push_back(c);
  }
  if (shown.empty()) {
    ImGui::TextDisabled("No column holds numbers to plot.");
    return;
  }

  // Equal plot areas: the bottom plot also carries the time axis' title.
  const float s = state.fonts.scale;
  const float spacing = 4.0f * s;
  const float title_h = 1.2f * ImGui::GetFontSize();
  const float avail = ImGui::GetContentRegionAvail().y;
  const float n = static_cast<float>(shown.size());
  const float height =
      std::max(kMinPlotHeight * s, (avail - spacing * (n - 1.0f) - title_h) / n - 1.0f);
  const bool scrolls = height * n + spacing * (n - 1.0f) + title_h > avail;
  ImGui::BeginChild("##plots", ImVec2(0, 0), false,
                    scrolls ? ImGuiWindowFlags_None : ImGuiWindowFlags_NoScrollbar);
  ImGui::PushStyleVar(ImGuiStyleVar_ItemSpacing, ImVec2(0, spacing));
  const int n_time = static_cast<int>(data.time.size());
  const std::vector<ImU32>& palette = state.plots.style.palette;
  for (std::size_t k = 0; k < shown.size(); ++k) {
    const data::Column& column = data.columns[shown[k]];
    plot::PlotOptions options;
    options.title = column.name.c_str();
    const bool last = k + 1 == shown.size();
    options.x_label = data.time_name.c_str();
    options.x_title = last;
    options.linked_x = &state.data_view.x_ranges[index];
    const std::vector<double>* preview = Preview(state, index, column.name);
    options.legend = preview ? plot::Legend::kShow : plot::Legend::kHide;
    ImGui::PushID(shown[k]);
    if (plot::BeginPlot(state.plots, "##column", ImVec2(-1, last ? height + title_h : height),
                        options)) {
      plot::ItemStyle style;
      style.color = palette[static_cast<std::size_t>(shown[k]) % palette.size()];
      plot::PlotLine(state.plots, column.name.c_str(), data.time.data(), column.values.data(),
                     n_time, style);
      if (const std::vector<double>* before = GhostPreview(state, index, column.name)) {
        plot::ItemStyle ghost;
        ghost.color = GhostColor(state.plots.style.strong_ink);
        plot::PlotLine(state.plots, kGhostLabel, data.time.data(), before->data(), n_time, ghost);
      }
      if (preview) {
        plot::ItemStyle sim;
        sim.color = state.plots.style.strong_ink;
        plot::PlotLine(state.plots, "simulated", data.time.data(), preview->data(), n_time, sim);
      }
      plot::EndPlot(state.plots);
    }
    ImGui::PopID();
  }
  ImGui::PopStyleVar();
  ImGui::EndChild();
}

// The record's estimation range: the time span the plots show becomes the dataset's `range`
// key (its other rows are left out of the fit and the views); "Whole record" takes it back.
void DrawRangeControls(AppState& state, std::size_t index) {
  const LoadedDataset& d = state.datasets[index];
  const data::Dataset& data = *d.data;
  if (data.rows() < 2) return;
  const plot::Range& x = state.data_view.x_ranges[index].range;
  const double lo = std::max(x.min, data.time.front());
  const double hi = std::min(x.max, data.time.back());
  const auto first = std::lower_bound(data.time.begin(), data.time.end(), lo);
  const auto last = std::upper_bound(data.time.begin(), data.time.end(), hi);
  const bool part = (lo > data.time.front() || hi < data.time.back()) && last - first >= 2;
  std::string why;
  if (part) {
    const std::string label = "Use " + data.time_name + " = " + plot::FormatValue(lo) +
                              " \xE2\x80\xA6 " + plot::FormatValue(hi) + " only";
    if (ImGui::Button(label.c_str()) && !SetDatasetRange(state, index, {{lo, hi}}, &why))
      AddMessage(state, Severity::kWarning, "The range was not applied: " + why);
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "Keep only the rows the plots show (%lld of %zu) for the fit, the "
          "predictions and the residuals: the dataset's \"range\" key, saved "
          "with the project; the file is not changed",
          static_cast<long long>(last - first), data.rows());
  }
  if (d.spec.range) {
    if (part) ImGui::SameLine();
    ImGui::AlignTextToFramePadding();
    ImGui::TextDisabled("Range %s = %s \xE2\x80\xA6 %s of the file", data.time_name.c_str(),
                        plot::FormatValue((*d.spec.range)[0]).c_str(),
                        plot::FormatValue((*d.spec.range)[1]).c_str());
    ImGui::SameLine();
    if (ImGui::Button("Whole record") && !SetDatasetRange(state, index, std::nullopt, &why))
      AddMessage(state, Severity::kWarning, "The whole record could not be read: " + why);
  }
}

void DrawDataset(AppState& state, std::size_t index) {
  const LoadedDataset& d = state.datasets[index];
  if (!d.data) {
    DrawNotice(state, "This dataset could not be read", d.error, Severity::kError);
    return;
  }
  DrawSummaryLine(d);
  ImGui::Spacing();
  DrawColumnTable(state, d);
  ImGui::Spacing();
  DrawPreviewToggle(state);
  DrawRangeControls(state, index);
  ImGui::TextDisabled(
      "Wheel: zoom time \xC2\xB7 drag: pan \xC2\xB7 right-drag: zoom to box \xC2\xB7 "
      "double-click: fit \xC2\xB7 over the y axis, wheel and drag act on y \xC2\xB7 "
      "wheel over a title scrolls");
  DrawColumnPlots(state, index);
}

}  // namespace

void DrawDataPanel(AppState& state) {
  if (DrawNoProjectNotice(state)) return;
  if (state.datasets.empty()) {
    DrawNotice(state, "No data", "The project lists no datasets (its \"datasets\" entry).");
    return;
  }
  if (state.data_view.x_ranges.size() != state.datasets.size())
    state.data_view.x_ranges.assign(state.datasets.size(), plot::LinkedRange{});
  if (state.datasets.size() == 1) {
    DrawDataset(state, 0);
    return;
  }
  if (!ImGui::BeginTabBar("##datasets")) return;
  for (std::size_t i = 0; i < state.datasets.size(); ++i) {
    const LoadedDataset& d = state.datasets[i];
    const std::string label =
        DatasetLabel(d.spec) + (d.data ? "" : "  (unreadable)") + "###" + std::to_string(i);
    if (ImGui::BeginTabItem(label.c_str())) {
      DrawDataset(state, i);
      ImGui::EndTabItem();
    }
  }
  ImGui::EndTabBar();
}

}  // namespace gb::ui
