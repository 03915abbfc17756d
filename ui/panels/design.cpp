// The experiment-design view (user guide §6b): two input designs for the model at the values the
// views show, side by side. Each design is an input's shape (PRBS, square wave, step), its levels
// and its record (sample time, duration); the view shows the standard errors each would give
// (exact, from the expected information of the Kalman filter's innovations: no simulation), their
// ratio, the two inputs, and their spectra against the model's gain and bandwidth. *Try* records
// samples from the model with a design and fits them, so that the predicted and the realised
// standard errors stand side by side (the fit's own on one record; the spread of the estimates
// over several).
//
// The evaluation and the tries run in AppState::design's jobs (PollDesign, StartDesignFit); this
// panel edits the designs and reads the results.
//
// Sections
//   1. The toolbar: the driven input, the comparison, the tries
//   2. A design's settings
//   3. The table of standard errors
//   4. The plots: the inputs, the spectra against the model's gain
//   5. DrawDesignPanel
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include <fmt/format.h>
#include <imgui.h>

#include "ui/format.h"
#include "ui/panels/common.h"
#include "ui/panels/panels.h"

namespace gb::ui {
namespace {

constexpr ImU32 kDesignColor[2] = {IM_COL32(31, 119, 180, 255), IM_COL32(255, 127, 14, 255)};
constexpr ImU32 kGainColor = IM_COL32(110, 116, 126, 255);
constexpr ImU32 kBandwidthColor = IM_COL32(44, 160, 44, 255);
constexpr const char* kName[2] = {"A", "B"};
constexpr const char* kMiddleDot = "  \xC2\xB7  ";
constexpr int kMaxRecordsField = 200;      // the view's field; the CLI takes up to 1000
constexpr float kSettingsHeight = 176.0f;  // pixels at scale 1
constexpr float kMinPlotHeight = 150.0f;

std::string Elapsed(const AppState& state) {
  if (state.deterministic) return kElapsedPlaceholder;
  const double s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - state.design.fit_started)
          .count();
  return FormatFixed(s, 1) + " s";
}

// ---------------------------------------------------------------------------------------------
// 1. The toolbar

void DrawToolbar(AppState& state) {
  const float s = state.fonts.scale;
  DesignViewState& v = state.design;
  const model::ModelSpec& m = *state.model;
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Drive");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(120.0f * s);
  if (ImGui::BeginCombo("##drive", m.inputs[static_cast<std::size_t>(v.input)].c_str())) {
    for (int i = 0; i < static_cast<int>(m.inputs.size()); ++i)
      if (ImGui::Selectable(m.inputs[static_cast<std::size_t>(i)].c_str(), i == v.input)) {
        v.input = i;
        v.seeded_generation = -1;  // seed the levels from the data again
      }
    ImGui::EndCombo();
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("The input the designs drive; the others are held at their mean levels");
  for (int i = 0; i < static_cast<int>(m.inputs.size()); ++i) {
    if (i == v.input || i >= static_cast<int>(v.hold.size())) continue;
    const std::string label = m.inputs[static_cast<std::size_t>(i)] + " held at";
    SameLineIfFits(ImGui::CalcTextSize(label.c_str()).x + 100.0f * s, 12.0f * s);
    ImGui::TextUnformatted(label.c_str());
    ImGui::SameLine();
    ImGui::SetNextItemWidth(90.0f * s);
    ImGui::PushID(i);
    ImGui::InputDouble("##hold", &v.hold[static_cast<std::size_t>(i)], 0, 0, "%.6g");
    ImGui::PopID();
  }
  SameLineIfFits(CheckboxWidth("Compare with B"), 16.0f * s);
  ImGui::Checkbox("Compare with B", &v.compare);
  SameLineIfFits(260.0f * s, 16.0f * s);
  ImGui::TextUnformatted("Records");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90.0f * s);
  ImGui::InputInt("##records", &v.records);
  v.records = std::clamp(v.records, 1, kMaxRecordsField);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "How many records a try simulates from the model and fits: one shows the "
        "fit's own standard errors, several the spread of their estimates");
  const bool trying = v.fit_job.active();
  for (int slot = 0; slot < (v.compare ? 2 : 1); ++slot) {
    ImGui::SameLine();
    ImGui::BeginDisabled(trying);
    const std::string label = fmt::format("Try {}", kName[slot]);
    if (ImGui::Button(label.c_str())) {
      std::string why;
      if (!StartDesignFit(state, slot, &why))
        AddMessage(state, Severity::kError, "Cannot try the design: " + why);
    }
    ImGui::EndDisabled();
    if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
      ImGui::SetTooltip("Simulate %d record%s from the model with design %s and fit %s", v.records,
                        v.records == 1 ? "" : "s", kName[slot], v.records == 1 ? "it" : "them");
  }
  if (trying) {
    ImGui::SameLine();
    if (ImGui::Button("Cancel")) v.fit_job.RequestCancel();
    StatusLine(state, IM_COL32(47, 111, 219, 255), "Trying",
               fmt::format("design {}: {} records simulated and fitted{}{}",
                           kName[std::max(v.fit_slot, 0)], v.records, kMiddleDot, Elapsed(state)));
    ImGui::ProgressBar(v.fit_job.progress(), ImVec2(-1, 4.0f * s), "");
  }
}

// ---------------------------------------------------------------------------------------------
// 2. A design's settings

bool Field(const char* label, const char* id, double* value) {
  ImGui::TableNextColumn();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("%s", label);
  ImGui::TableNextColumn();
  ImGui::SetNextItemWidth(-FLT_MIN);
  return ImGui::InputDouble(id, value, 0, 0, "%.6g");
}

void DrawSettings(AppState& state, int slot, const DesignRun* run) {
  const float s = state.fonts.scale;
  DesignViewState& v = state.design;
  design::InputDesign& d = v.slots[static_cast<std::size_t>(slot)].design;
  ImGui::PushID(slot);
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 p = ImGui::GetCursorScreenPos();
  const float r = 5.0f * s;
  dl->AddCircleFilled(ImVec2(p.x + r, p.y + ImGui::GetTextLineHeight() * 0.5f), r,
                      kDesignColor[slot]);
  ImGui::Dummy(ImVec2(2 * r + 4.0f * s, 0));
  ImGui::SameLine();
  ImGui::PushFont(state.fonts.bold);
  ImGui::Text("Design %s", kName[slot]);
  ImGui::PopFont();
  ImGui::SameLine();
  const char* shapes[] = {"PRBS", "Square wave", "Step"};
  int shape = static_cast<int>(d.shape);
  ImGui::SetNextItemWidth(130.0f * s);
  if (ImGui::Combo("##shape", &shape, shapes, 3)) d.shape = static_cast<design::InputShape>(shape);
  if (ImGui::BeginTable("##fields", 4, ImGuiTableFlags_SizingFixedFit)) {
    ImGui::TableSetupColumn("##l1", ImGuiTableColumnFlags_WidthFixed);
    ImGui::TableSetupColumn("##f1", ImGuiTableColumnFlags_WidthStretch);
    ImGui::TableSetupColumn("##l2", ImGuiTableColumnFlags_WidthFixed);
    ImGui::TableSetupColumn("##f2", ImGuiTableColumnFlags_WidthStretch);
    switch (d.shape) {
      case design::InputShape::kPrbs: {
        ImGui::TableNextColumn();
        ImGui::AlignTextToFramePadding();
        ImGui::TextDisabled("Order");
        ImGui::TableNextColumn();
        ImGui::SetNextItemWidth(-FLT_MIN);
        ImGui::InputInt("##order", &d.order, 0, 0);
        d.order = std::clamp(d.order, design::kMinPrbsOrder, design::kMaxPrbsOrder);
        Field("Bit period", "##bit", &d.bit_period);
        break;
      }
      case design::InputShape::kSquare:
        Field("Period", "##period", &d.period);
        ImGui::TableNextRow();
        break;
      case design::InputShape::kStep:
        Field("Step at", "##at", &d.step_time);
        ImGui::TableNextRow();
        break;
    }
    Field("Level", "##level", &d.level);
    Field("Amplitude \xC2\xB1", "##amplitude", &d.amplitude);
    Field("Sample time", "##ts", &d.sample_time);
    Field("Duration", "##duration", &d.duration);
    ImGui::EndTable();
  }
  std::string why;
  if (!d.IsValid(&why)) {
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextColored(SeverityColor(Severity::kError), "%s", why.c_str());
    ImGui::PopTextWrapPos();
  } else {
    std::string line =
        GroupedCount(static_cast<long long>(std::ceil(d.duration / d.sample_time - 1e-9))) +
        " samples";
    if (d.shape == design::InputShape::kPrbs) {
      const auto range = design::EstimableTimeConstants(d.order, d.bit_period);
      line += kMiddleDot + std::string("suits time constants ") + FormatSig(range.shortest, 3) +
              " to " + FormatSig(range.longest, 3);
    }
    if (run && !run->errors[static_cast<std::size_t>(slot)].empty())
      line = run->errors[static_cast<std::size_t>(slot)];
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextDisabled("%s", line.c_str());
    ImGui::PopTextWrapPos();
  }
  ImGui::PopID();
}

// ---------------------------------------------------------------------------------------------
// 3. The table of standard errors

std::string Cell(const std::optional<double>& v) { return v ? FormatSig(*v, 3) : "\xE2\x80\x94"; }

void DrawTable(AppState& state, const DesignRun& run) {
  const DesignViewState& v = state.design;
  const int designs = v.compare ? 2 : 1;
  // Which tries belong to the request on screen (the model's values and the designs unchanged).
  std::array<const DesignFitRun*, 2> tried = {nullptr, nullptr};
  for (int d = 0; d < designs; ++d) {
    const auto& t = v.slots[static_cast<std::size_t>(d)].tried;
    if (t && t->key == run.key && t->fits) tried[static_cast<std::size_t>(d)] = &*t;
  }
  int columns = 2 + designs + (designs == 2 ? 1 : 0);
  for (const auto* t : tried) columns += t ? 1 : 0;
  if (!ImGui::BeginTable("##se", columns,
                         ImGuiTableFlags_RowBg | ImGuiTableFlags_BordersInnerH |
                             ImGuiTableFlags_SizingStretchProp | ImGuiTableFlags_ScrollY))
    return;
  ImGui::TableSetupScrollFreeze(0, 1);
  ImGui::TableSetupColumn("Parameter");
  ImGui::TableSetupColumn("Value");
  for (int d = 0; d < designs; ++d) ImGui::TableSetupColumn(fmt::format("SE {}", kName[d]).c_str());
  if (designs == 2) ImGui::TableSetupColumn("B / A");
  for (int d = 0; d < 2; ++d) {
    const auto* t = tried[static_cast<std::size_t>(d)];
    if (!t) continue;
    const bool spread = t->fits->estimates.size() >= 2;
    ImGui::TableSetupColumn(
        (spread ? fmt::format("Spread {}", kName[d]) : fmt::format("Fit {}", kName[d])).c_str());
  }
  ImGui::TableHeadersRow();
  for (std::size_t i = 0; i < run.free_names.size(); ++i) {
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(run.free_names[i].c_str());
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(FormatSig(run.free_values[i], 4).c_str());
    std::array<std::optional<double>, 2> se;
    for (int d = 0; d < designs; ++d) {
      ImGui::TableNextColumn();
      const auto& e = run.evals[static_cast<std::size_t>(d)];
      if (e && i < e->info.std_error.size()) se[static_cast<std::size_t>(d)] = e->info.std_error[i];
      ImGui::TextUnformatted(Cell(se[static_cast<std::size_t>(d)]).c_str());
    }
    if (designs == 2) {
      ImGui::TableNextColumn();
      if (se[0] && se[1] && *se[0] > 0) {
        const double ratio = *se[1] / *se[0];
        // The better design's ratio in its colour: B/A < 1 favours B.
        ImGui::PushStyleColor(ImGuiCol_Text, kDesignColor[ratio < 1 ? 1 : 0]);
        ImGui::TextUnformatted(FormatSig(ratio, 3).c_str());
        ImGui::PopStyleColor();
      } else {
        ImGui::TextDisabled("\xE2\x80\x94");
      }
    }
    for (const auto* t : tried) {
      if (!t) continue;
      ImGui::TableNextColumn();
      const project::DesignFits& f = *t->fits;
      const bool spread = f.estimates.size() >= 2;
      ImGui::TextUnformatted(
          Cell(spread ? std::optional<double>(f.spread[i]) : f.first_std_error[i]).c_str());
    }
  }
  ImGui::EndTable();
}

// What the tries say under the table: how many records, how many fits did not converge.
void DrawTriesNote(AppState& state, const DesignRun& run) {
  for (int d = 0; d < (state.design.compare ? 2 : 1); ++d) {
    const auto& t = state.design.slots[static_cast<std::size_t>(d)].tried;
    if (!t) continue;
    std::string text;
    if (!t->error.empty()) {
      text = fmt::format("Try {}: {}", kName[d], t->error);
    } else if (t->key != run.key) {
      text = fmt::format("Try {} was made for other values or settings: try again", kName[d]);
    } else {
      const int n = static_cast<int>(t->fits->estimates.size());
      text = fmt::format("Try {}: {} record{} simulated from the model and fitted", kName[d],
                         n + t->fits->failed, n + t->fits->failed == 1 ? "" : "s");
      if (t->fits->failed > 0) text += fmt::format(", {} did not converge", t->fits->failed);
      text += n >= 2 ? "; the spread is the standard deviation of their estimates"
                     : "; the fit's own standard errors";
      if (!state.deterministic) text += fmt::format(" ({:.1f} s)", t->seconds);
    }
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextDisabled("%s", text.c_str());
    ImGui::PopTextWrapPos();
  }
}

// ---------------------------------------------------------------------------------------------
// 4. The plots

void DrawPlots(AppState& state, const DesignRun& run, float height) {
  const float s = state.fonts.scale;
  const int designs = state.design.compare ? 2 : 1;
  const float gap = 6.0f * s;
  const float spacing = ImGui::GetStyle().ItemSpacing.y;
  const float h = std::max(kMinPlotHeight * s, std::floor((height - gap - 3 * spacing) / 2));
  plot::PlotOptions in;
  in.title = "The inputs";
  in.x_label = "t";
  in.y_label = state.model->inputs[static_cast<std::size_t>(state.design.input)].c_str();
  in.legend_corner = plot::LegendCorner::kBottomRight;
  in.linked_x = &state.design.time_x;
  if (plot::BeginPlot(state.plots, "##design-inputs", ImVec2(-1, h), in)) {
    for (int d = 0; d < designs; ++d) {
      const auto& e = run.evals[static_cast<std::size_t>(d)];
      if (!e) continue;
      plot::ItemStyle style;
      style.color = kDesignColor[d];
      plot::PlotLine(state.plots, kName[d], e->signal.t.data(), e->signal.u.data(),
                     static_cast<int>(e->signal.t.size()), style);
    }
    plot::EndPlot(state.plots);
  }
  ImGui::Dummy(ImVec2(0, gap));
  // The spectra in dB against log10 of the frequency (the plot has linear axes).
  std::array<std::vector<double>, 2> x, y;
  for (int d = 0; d < designs; ++d) {
    const auto& e = run.evals[static_cast<std::size_t>(d)];
    if (!e) continue;
    for (std::size_t b = 0; b < e->spectrum.frequency.size(); ++b) {
      if (!(e->spectrum.power[b] > 0)) continue;
      x[static_cast<std::size_t>(d)].push_back(std::log10(e->spectrum.frequency[b]));
      y[static_cast<std::size_t>(d)].push_back(10 * std::log10(e->spectrum.power[b]));
    }
  }
  // The gain, shifted to sit at the top of the spectra (its shape matters, not its level).
  std::vector<double> gx, gy;
  double top = -INFINITY;
  for (const auto& yy : y)
    for (double v : yy) top = std::max(top, v);
  if (!run.gain_db.empty() && std::isfinite(top)) {
    const double peak = *std::max_element(run.gain_db.begin(), run.gain_db.end());
    for (std::size_t i = 0; i < run.gain_db.size(); ++i) {
      gx.push_back(std::log10(run.gain_frequency[i]));
      gy.push_back(run.gain_db[i] - peak + top);
    }
  }
  const double bw = run.bandwidth ? std::log10(*run.bandwidth) : 0.0;
  plot::PlotOptions sp;
  sp.title = "Spectra against the model's gain";
  sp.x_label = "log\xE2\x82\x81\xE2\x82\x80 frequency";
  sp.x_unit = "cycles per time unit";
  sp.y_label = "power";
  sp.y_unit = "dB";
  sp.legend_corner = plot::LegendCorner::kBottomLeft;
  if (plot::BeginPlot(state.plots, "##design-spectra", ImVec2(-1, h), sp)) {
    for (int d = 0; d < designs; ++d) {
      if (x[static_cast<std::size_t>(d)].empty()) continue;
      plot::ItemStyle style;
      style.color = kDesignColor[d];
      plot::PlotLine(state.plots, kName[d], x[static_cast<std::size_t>(d)].data(),
                     y[static_cast<std::size_t>(d)].data(),
                     static_cast<int>(x[static_cast<std::size_t>(d)].size()), style);
    }
    if (!gx.empty()) {
      plot::ItemStyle style;
      style.color = kGainColor;
      plot::PlotLine(state.plots, "model gain |G|\xC2\xB2", gx.data(), gy.data(),
                     static_cast<int>(gx.size()), style);
    }
    if (run.bandwidth) {
      plot::ItemStyle style;
      style.color = kBandwidthColor;
      static const char* const kTag[] = {"bandwidth"};
      plot::PlotVLines(state.plots, "bandwidth", &bw, 1, kTag, style);
    }
    plot::EndPlot(state.plots);
  }
}

// The model's time constants and bandwidth, on one line.
void DrawModelLine(AppState& state, const DesignRun& run) {
  std::string tau;
  for (double t : run.time_constants) tau += (tau.empty() ? "" : ", ") + FormatSig(t, 3);
  const auto request = AnalysisRequestNow(state);
  const std::string values = request && request->source == AnalysisSource::kFit
                                 ? "At the fit's estimates"
                                 : "At the model's values";
  std::string text = values + kMiddleDot + "time constants " +
                     (tau.empty() ? std::string("none") : tau) + kMiddleDot + "bandwidth " +
                     (run.bandwidth ? FormatSig(*run.bandwidth, 3) + " cycles per time unit"
                                    : std::string("none"));
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextDisabled("%s", text.c_str());
  ImGui::PopTextWrapPos();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 5. DrawDesignPanel

void DrawDesignPanel(AppState& state) {
  if (DrawNoProjectNotice(state)) return;
  if (!state.model) {
    DrawNotice(state, "No valid model",
               "The model is not valid: " + state.model_error + ". Fix it in the Equations view.",
               Severity::kError);
    return;
  }
  if (state.model->inputs.empty()) {
    DrawNotice(state, "Nothing to design",
               "The model has no input: an experiment design chooses the signal an input is "
               "driven with.");
    return;
  }
  DesignViewState& v = state.design;
  // The model may have lost an input since the designs were seeded (an edit in the Equations
  // view): the driven input and the levels follow it.
  v.input = std::clamp(v.input, 0, static_cast<int>(state.model->inputs.size()) - 1);
  v.hold.resize(state.model->inputs.size(), 0.0);
  const DesignRun* run = v.result ? &*v.result : nullptr;
  if (run && !run->model_error.empty()) {
    DrawNotice(state, "Linear models only", run->model_error, Severity::kWarning);
    return;
  }
  const float s = state.fonts.scale;
  DrawToolbar(state);
  ImGui::Spacing();
  const float avail = ImGui::GetContentRegionAvail().x;
  const int designs = v.compare ? 2 : 1;
  const float col_w = (avail - 8.0f * s * static_cast<float>(designs - 1)) / 2;
  for (int d = 0; d < designs; ++d) {
    if (d > 0) ImGui::SameLine(0, 8.0f * s);
    ImGui::BeginChild(kName[d], ImVec2(col_w, kSettingsHeight * s), true);
    DrawSettings(state, d, run);
    ImGui::EndChild();
  }
  if (!run) {
    ImGui::TextDisabled("Computing the expected standard errors\xE2\x80\xA6");
    return;
  }
  DrawModelLine(state, *run);
  const float rest_h = ImGui::GetContentRegionAvail().y;
  const float table_w = std::round(avail * 0.56f);
  ImGui::BeginChild("##left", ImVec2(table_w, rest_h), false);
  SectionHeading(state, "Expected standard errors");
  const float note_h = (v.slots[0].tried || v.slots[1].tried) ? 3.2f * ImGui::GetFontSize() : 0;
  ImGui::BeginChild("##table", ImVec2(0, ImGui::GetContentRegionAvail().y - note_h), false);
  DrawTable(state, *run);
  ImGui::EndChild();
  DrawTriesNote(state, *run);
  ImGui::EndChild();
  ImGui::SameLine(0, 10.0f * s);
  ImGui::BeginChild("##right", ImVec2(0, rest_h), false,
                    ImGuiWindowFlags_NoScrollbar | ImGuiWindowFlags_NoScrollWithMouse);
  DrawPlots(state, *run, ImGui::GetContentRegionAvail().y);
  ImGui::EndChild();
}

}  // namespace gb::ui
