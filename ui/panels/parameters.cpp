// The parameters view: one row per model parameter with its start value, bounds and whether
// it is fixed, all editable; after a fit also the estimate, standard error, t, p, the 95 %
// interval (estimate ± 1.96 SE) and a note for estimates at a bound; when the fit computed them,
// the profile likelihood intervals beside, and (on a click on one) that parameter's profile
// log-likelihood plotted under the table. Below: the warnings of the fit (identifiability,
// correlation) and the correlation of the estimates as a heat map.
//
// Edits: the table emits ParameterEdits into state.parameters_view.pending while it is drawn;
// ApplyParameterEdits() applies them after the table through core's validation, which may
// refuse one with a reason (shown in red under the table, the cell marked).
//
// Sections
//   1. Cells: editable numbers, right-aligned read-outs
//   2. The table
//   3. Warnings and the correlation heat map
//   4. DrawParametersPanel
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <string>

#include <imgui.h>
#include <imgui_stdlib.h>

#include "ui/format.h"
#include "ui/panels/common.h"
#include "ui/panels/panels.h"
#include "ui/widgets/heatmap.h"
#include "ui/widgets/plot.h"

namespace gb::ui {
namespace {

constexpr float kInputWidth = 80.0f;        // the start value and bound cells, pixels at scale 1
constexpr float kNarrowInputWidth = 64.0f;  // ... beside the profile intervals
constexpr float kNarrowTable = 940.0f;      // narrower than this, the narrow inputs
constexpr double kZ95 = 1.96;               // two-sided 95 % normal quantile
constexpr int kEstimateDigits = 5;
constexpr int kErrorDigits = 3;
constexpr ImU32 kRefusedCellBg = IM_COL32(250, 222, 222, 255);
constexpr ImU32 kSliderGlyphColor = IM_COL32(31, 119, 180, 255);

// ---------------------------------------------------------------------------------------------
// 1. Cells

// The text a number cell shows: 6 significant digits (a bound that is absent: empty).
std::string CellText(const std::optional<double>& v) {
  if (!v) return "";
  if (!std::isfinite(*v)) return kDash;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", *v);
  return buf;
}

void TextRight(const std::string& text, bool dim = false) {
  const float w = ImGui::CalcTextSize(text.c_str()).x;
  const float avail = ImGui::GetContentRegionAvail().x;
  if (avail > w) ImGui::SetCursorPosX(ImGui::GetCursorPosX() + avail - w);
  if (dim) {
    ImGui::TextDisabled("%s", text.c_str());
  } else {
    ImGui::TextUnformatted(text.c_str());
  }
}

bool IsRefused(const AppState& state, const std::string& parameter, ParameterField field) {
  const std::optional<ParameterRefusal>& r = state.parameters_view.refusal;
  return r && r->parameter == parameter && r->field == field;
}

// A start value or bound. ImGui keeps the text only while the cell is active, so the text
// being typed lives in parameters_view; it is committed when the cell loses focus (or on Enter).
void NumberCell(AppState& state, const model::Parameter& p, ParameterField field,
                const std::optional<double>& value) {
  ParametersViewState& v = state.parameters_view;
  const bool refused = IsRefused(state, p.name, field);
  if (refused) ImGui::TableSetBgColor(ImGuiTableBgTarget_CellBg, kRefusedCellBg);
  const bool editing = v.editing_parameter == p.name && v.editing_field == field;
  std::string shown = refused ? v.refusal->text : CellText(value);
  std::string* text = editing ? &v.editing_text : &shown;
  const char* id = field == ParameterField::kValue   ? "##value"
                   : field == ParameterField::kLower ? "##lower"
                                                     : "##upper";
  const char* hint = field == ParameterField::kValue   ? ""
                     : field == ParameterField::kLower ? "\xE2\x88\x92\xE2\x88\x9E"  // −∞
                                                       : "\xE2\x88\x9E";             // ∞
  ImGui::SetNextItemWidth(-FLT_MIN);
  if (refused) {
    ImGui::PushStyleColor(ImGuiCol_FrameBg, kRefusedCellBg);
    ImGui::PushStyleColor(ImGuiCol_Border, SeverityColor(Severity::kError));
  }
  ImGui::InputTextWithHint(id, hint, text,
                           ImGuiInputTextFlags_CharsScientific | ImGuiInputTextFlags_AutoSelectAll);
  if (refused) ImGui::PopStyleColor(2);
  if (ImGui::IsItemActivated()) {
    v.editing_parameter = p.name;
    v.editing_field = field;
    v.editing_text = *text;
  }
  if (ImGui::IsItemHovered() && refused) ImGui::SetTooltip("%s", v.refusal->reason.c_str());
  if (!ImGui::IsItemDeactivated()) return;
  const std::string typed = editing ? v.editing_text : *text;
  const bool edited = ImGui::IsItemDeactivatedAfterEdit();
  v.editing_parameter.clear();
  v.editing_text.clear();
  if (!edited) return;
  Result<ParameterEdit> edit = ParseParameterEdit(p.name, field, typed);
  if (!edit) {
    v.refusal = ParameterRefusal{p.name, field, typed, edit.error().message};
    return;
  }
  v.pending.push_back(std::move(edit).value());
}

void FixedCell(AppState& state, const model::Parameter& p) {
  bool fixed = p.fixed;
  if (IsRefused(state, p.name, ParameterField::kFixed))
    ImGui::TableSetBgColor(ImGuiTableBgTarget_CellBg, kRefusedCellBg);
  const float w = ImGui::GetFrameHeight();
  const float avail = ImGui::GetContentRegionAvail().x;
  if (avail > w) ImGui::SetCursorPosX(ImGui::GetCursorPosX() + 0.5f * (avail - w));
  if (ImGui::Checkbox("##fixed", &fixed)) {
    ParameterEdit edit;
    edit.parameter = p.name;
    edit.field = ParameterField::kFixed;
    edit.fixed = fixed;
    edit.text = fixed ? "fixed" : "free";
    state.parameters_view.pending.push_back(std::move(edit));
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("%s", fixed ? "Held at its value (not estimated)" : "Estimated");
}

// ---------------------------------------------------------------------------------------------
// 2. The table

const estimate::ParameterEstimate* FindEstimate(const FitResult* r, const std::string& name) {
  if (!r) return nullptr;
  for (const estimate::ParameterEstimate& e : r->summary.parameters) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

// "at lower bound", "at upper bound", or "".
std::string BoundNote(const estimate::ParameterEstimate& e) {
  if (!e.at_bound) return "";
  const double to_lower = e.lower ? std::abs(e.estimate - *e.lower) : HUGE_VAL;
  const double to_upper = e.upper ? std::abs(e.estimate - *e.upper) : HUGE_VAL;
  return to_lower <= to_upper ? "at lower bound" : "at upper bound";
}

// Estimate, SE, t (unless `with_t` is false: beside the profile intervals, for room), p and the
// interval. Where there is no standard error the SE cell says why: "fixed", "at lower bound"
// (the at-bound marker, also on the estimate), "not determined".
// "lo … hi" of the Wald 95 % interval, or a dash without a standard error.
std::string WaldText(const estimate::ParameterEstimate& e) {
  if (!e.std_error || !std::isfinite(*e.std_error)) return kDash;
  const double half = kZ95 * *e.std_error;
  return FormatSig(e.estimate - half, kErrorDigits) + " \xE2\x80\xA6 " +
         FormatSig(e.estimate + half, kErrorDigits);
}

// The profile interval "lo … hi" ("bound" for an end the data do not reach before the
// parameter's bound, "none" where the search gave up), or a dash without one.
std::string ProfileText(const estimate::ParameterEstimate& e) {
  if (!e.profile) return kDash;
  const estimate::ProfileInterval& pi = *e.profile;
  auto end = [](const std::optional<double>& v, bool at_bound) {
    return v ? FormatSig(*v, kErrorDigits) : std::string(at_bound ? "bound" : "none");
  };
  return end(pi.lower, pi.lower_at_bound) + " \xE2\x80\xA6 " + end(pi.upper, pi.upper_at_bound);
}

void EstimateCells(const estimate::ParameterEstimate* e, bool with_t = true) {
  if (!e) {  // a parameter the fit did not know (cannot happen unless the model changed)
    for (int i = 0; i < (with_t ? 5 : 4); ++i) {
      ImGui::TableNextColumn();
      TextRight(kDash, true);
    }
    return;
  }
  const ImVec4 warning = SeverityColor(Severity::kWarning);
  ImGui::TableNextColumn();
  const std::string estimate = FormatSig(e->estimate, kEstimateDigits);
  if (e->at_bound && !e->fixed) {
    const float w = ImGui::CalcTextSize(estimate.c_str()).x;
    const float avail = ImGui::GetContentRegionAvail().x;
    if (avail > w) ImGui::SetCursorPosX(ImGui::GetCursorPosX() + avail - w);
    ImGui::TextColored(warning, "%s", estimate.c_str());
  } else {
    TextRight(estimate, e->fixed);
  }
  ImGui::TableNextColumn();
  if (e->std_error) {
    TextRight(FormatSig(e->std_error, kErrorDigits));
  } else if (e->fixed) {
    TextRight("fixed", true);
  } else {
    const std::string why = e->at_bound ? BoundNote(*e) : "not determined";
    const float w = ImGui::CalcTextSize(why.c_str()).x;
    const float avail = ImGui::GetContentRegionAvail().x;
    if (avail > w) ImGui::SetCursorPosX(ImGui::GetCursorPosX() + avail - w);
    ImGui::TextColored(warning, "%s", why.c_str());
    if (ImGui::IsItemHovered()) {
      ImGui::SetTooltip("%s", e->at_bound
                                  ? "The estimate is on its bound: no standard error is reported."
                                  : "The data do not determine it (see the warnings).");
    }
  }
  if (with_t) {
    ImGui::TableNextColumn();
    TextRight(FormatSig(e->t_value, kErrorDigits), !e->t_value);
  }
  ImGui::TableNextColumn();
  TextRight(FormatPValue(e->p_value), !e->p_value);
  ImGui::TableNextColumn();
  const std::string wald = WaldText(*e);
  TextRight(wald, wald == kDash);
}

// The profile interval "lo … hi" ("bound" for an end the data do not reach before the
// parameter's bound, "none" where the search gave up); a click plots the profile.
void ProfileCell(AppState& state, const estimate::ParameterEstimate* e) {
  ImGui::TableNextColumn();
  if (!e || !e->profile) {
    TextRight(kDash, true);
    return;
  }
  const std::string text = ProfileText(*e);
  const bool shown = state.parameters_view.profile_plot == e->name;
  const float w = ImGui::CalcTextSize(text.c_str()).x;
  const float avail = ImGui::GetContentRegionAvail().x;
  if (avail > w) ImGui::SetCursorPosX(ImGui::GetCursorPosX() + avail - w);
  ImGui::PushID("profile");
  if (ImGui::Selectable(text.c_str(), shown, ImGuiSelectableFlags_None, ImVec2(w, 0)))
    state.parameters_view.profile_plot = shown ? "" : e->name;
  ImGui::PopID();
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("Click to %s the profile log-likelihood of %s", shown ? "hide" : "plot",
                      e->name.c_str());
}

// The parameter's name: its description on hover, a right click's menu to show it as a slider
// (beside the Data, Predictions, Residuals and this view), and a small slider drawn after the
// name of one that is.
void NameMenu(AppState& state, const model::Parameter& p) {
  const bool slider = SliderShown(state, p.name);
  if (ImGui::IsItemHovered()) {
    ImGui::SetTooltip("%s%sRight-click: %s", p.description.c_str(),
                      p.description.empty() ? "" : "\n",
                      slider ? "remove its slider" : "show it as a slider");
  }
  if (slider) {
    const float s = state.fonts.scale;
    const ImVec2 a = ImGui::GetItemRectMax();
    const float y = a.y - 0.5f * ImGui::GetTextLineHeight();
    const float x = a.x + 6.0f * s;
    ImDrawList* dl = ImGui::GetWindowDrawList();
    dl->AddLine(ImVec2(x, y), ImVec2(x + 14.0f * s, y), kSliderGlyphColor, 1.5f * s);
    dl->AddCircleFilled(ImVec2(x + 9.0f * s, y), 3.0f * s, kSliderGlyphColor, 12);
  }
  if (ImGui::BeginPopupContextItem("name-menu")) {
    ImGui::TextDisabled("%s", p.name.c_str());
    ImGui::Separator();
    if (ImGui::MenuItem("Show as a slider", nullptr, slider)) ShowSlider(state, p.name, !slider);
    ImGui::EndPopup();
  }
}

bool HasProfiles(const FitResult* r) {
  if (!r) return false;
  for (const estimate::ParameterEstimate& e : r->summary.parameters)
    if (e.profile) return true;
  return false;
}

void HeaderRight(const char* label) {
  ImGui::TableNextColumn();
  const float w = ImGui::CalcTextSize(label, nullptr, true).x;
  const float avail = ImGui::GetContentRegionAvail().x;
  if (avail > w) ImGui::SetCursorPosX(ImGui::GetCursorPosX() + avail - w);
  ImGui::TableHeader(label);
}

void DrawTable(AppState& state, const FitResult* result) {
  const float s = state.fonts.scale;
  const model::ModelSpec& m = *state.model;
  const bool with_fit = result != nullptr;
  const bool with_profiles = HasProfiles(result);
  // Beside the profile intervals the t column gives way (p says the same).
  const int columns = with_fit ? 11 : 7;
  const ImGuiTableFlags flags = ImGuiTableFlags_BordersOuter | ImGuiTableFlags_BordersInnerH |
                                ImGuiTableFlags_BordersInnerV | ImGuiTableFlags_RowBg |
                                ImGuiTableFlags_SizingFixedFit | ImGuiTableFlags_NoSavedSettings;
  // Compact rows.
  ImGui::PushStyleVar(ImGuiStyleVar_FramePadding,
                      ImVec2(ImGui::GetStyle().FramePadding.x, 2.0f * s));
  const float row_h = ImGui::GetFrameHeight() + 2.0f * ImGui::GetStyle().CellPadding.y;
  // With the profile intervals the two interval columns take the width their longest text needs
  // and the table scrolls sideways where the window is narrower (stretched, they were squeezed
  // to a character or two beside the inputs).
  float wald_w = 0, profile_w = 0;
  ImVec2 outer(0, 0);
  if (with_profiles) {
    wald_w = ImGui::CalcTextSize("95 % Wald").x;
    profile_w = ImGui::CalcTextSize("95 % profile").x;
    for (const estimate::ParameterEstimate& e : result->summary.parameters) {
      wald_w = std::max(wald_w, ImGui::CalcTextSize(WaldText(e).c_str()).x);
      profile_w = std::max(profile_w, ImGui::CalcTextSize(ProfileText(e).c_str()).x);
    }
  }
  // A narrow window (1024 x 768) gets the narrow inputs, and a fitted table scrolls sideways
  // there too rather than cutting its last columns.
  const bool narrow = ImGui::GetContentRegionAvail().x < kNarrowTable * s;
  const bool scroll = with_profiles || (with_fit && narrow);
  if (scroll) {
    const std::size_t rows = std::max(m.parameters.size(), result->summary.parameters.size());
    outer.y = row_h * static_cast<float>(rows) + ImGui::GetTextLineHeight() +
              2.0f * ImGui::GetStyle().CellPadding.y + ImGui::GetStyle().ScrollbarSize;
  }
  if (!ImGui::BeginTable("##parameters", columns, scroll ? flags | ImGuiTableFlags_ScrollX : flags,
                         outer)) {
    ImGui::PopStyleVar();
    return;
  }
  ImGui::TableSetupColumn("Parameter");
  ImGui::TableSetupColumn("Unit");
  // Narrower inputs when the profile intervals need the room.
  const float input_w = (with_profiles || narrow ? kNarrowInputWidth : kInputWidth) * s;
  ImGui::TableSetupColumn("Start", ImGuiTableColumnFlags_WidthFixed, input_w);
  ImGui::TableSetupColumn("Lower", ImGuiTableColumnFlags_WidthFixed, input_w);
  ImGui::TableSetupColumn("Upper", ImGuiTableColumnFlags_WidthFixed, input_w);
  ImGui::TableSetupColumn("Fixed");
  if (with_fit) {
    ImGui::TableSetupColumn("Estimate");
    ImGui::TableSetupColumn("Std. error");
    if (!with_profiles) ImGui::TableSetupColumn("t");
    ImGui::TableSetupColumn("p");
    if (with_profiles) {
      ImGui::TableSetupColumn("95 % Wald", ImGuiTableColumnFlags_WidthFixed, wald_w);
      ImGui::TableSetupColumn("95 % profile", ImGuiTableColumnFlags_WidthFixed, profile_w);
    } else {
      ImGui::TableSetupColumn("95 % interval", ImGuiTableColumnFlags_WidthStretch);
    }
  } else {
    ImGui::TableSetupColumn("Description", ImGuiTableColumnFlags_WidthStretch);
  }
  // Headers: numbers right-aligned under right-aligned titles.
  ImGui::TableNextRow(ImGuiTableRowFlags_Headers);
  for (int c = 0; c < columns; ++c) {
    const char* name = ImGui::TableGetColumnName(c);
    const bool right = with_fit && c >= 6;  // the numbers of the fit
    if (right) {
      HeaderRight(name);
    } else {
      ImGui::TableNextColumn();
      ImGui::TableHeader(name);
    }
  }

  for (std::size_t i = 0; i < m.parameters.size(); ++i) {
    const model::Parameter& p = m.parameters[i];
    ImGui::PushID(static_cast<int>(i));
    ImGui::TableNextRow(ImGuiTableRowFlags_None, row_h);
    ImGui::TableNextColumn();
    ImGui::AlignTextToFramePadding();
    ImGui::PushFont(state.fonts.mono);
    ImGui::TextUnformatted(p.name.c_str());
    ImGui::PopFont();
    NameMenu(state, p);
    ImGui::TableNextColumn();
    ImGui::AlignTextToFramePadding();
    if (p.unit.empty()) {
      ImGui::TextDisabled("%s", kDash);
    } else {
      ImGui::TextUnformatted(p.unit.c_str());
    }
    ImGui::TableNextColumn();
    NumberCell(state, p, ParameterField::kValue, p.value);
    ImGui::TableNextColumn();
    NumberCell(state, p, ParameterField::kLower, p.lower);
    ImGui::TableNextColumn();
    NumberCell(state, p, ParameterField::kUpper, p.upper);
    ImGui::TableNextColumn();
    FixedCell(state, p);
    if (with_fit) {
      EstimateCells(FindEstimate(result, p.name), !with_profiles);
      if (with_profiles) ProfileCell(state, FindEstimate(result, p.name));
    } else {
      ImGui::TableNextColumn();
      ImGui::AlignTextToFramePadding();
      ImGui::TextDisabled("%s", p.description.c_str());
    }
    ImGui::PopID();
  }
  // A fit with initial states per record: the records' copies, estimated but not the model's
  // (their starts come from the records' first samples, their bounds from the originals).
  if (with_fit && !result->series_parameters.empty()) {
    for (std::size_t k = m.parameters.size(); k < result->summary.parameters.size(); ++k) {
      const estimate::ParameterEstimate& e = result->summary.parameters[k];
      ImGui::PushID(static_cast<int>(k));
      ImGui::TableNextRow(ImGuiTableRowFlags_None, row_h);
      ImGui::TableNextColumn();
      ImGui::AlignTextToFramePadding();
      ImGui::PushFont(state.fonts.mono);
      ImGui::TextUnformatted(e.name.c_str());
      ImGui::PopFont();
      if (ImGui::IsItemHovered())
        ImGui::SetTooltip(
            "A record's own initial state (Estimate view: Initial state per "
            "record): a copy of a parameter of the model's initial state, started "
            "from the record's first samples");
      ImGui::TableNextColumn();
      ImGui::AlignTextToFramePadding();
      if (e.unit.empty()) {
        ImGui::TextDisabled("%s", kDash);
      } else {
        ImGui::TextUnformatted(e.unit.c_str());
      }
      ImGui::TableNextColumn();
      ImGui::AlignTextToFramePadding();
      TextRight("(record)", /*dim=*/true);
      ImGui::TableNextColumn();
      TextRight(CellText(e.lower), /*dim=*/true);
      ImGui::TableNextColumn();
      TextRight(CellText(e.upper), /*dim=*/true);
      ImGui::TableNextColumn();  // never fixed
      EstimateCells(&e, !with_profiles);
      if (with_profiles) ProfileCell(state, &e);
      ImGui::PopID();
    }
  }
  ImGui::EndTable();
  ImGui::PopStyleVar();
}

void DrawRefusal(AppState& state) {
  std::optional<ParameterRefusal>& r = state.parameters_view.refusal;
  if (!r) return;
  const std::string text = r->parameter + ", " + std::string(FieldText(r->field)) +
                           (r->text.empty() ? "" : " '" + r->text + "'") +
                           ": refused \xE2\x80\x94 " + r->reason;
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextColored(SeverityColor(Severity::kError), "%s", text.c_str());
  ImGui::PopTextWrapPos();
  ImGui::SameLine();
  if (ImGui::SmallButton("Dismiss")) r.reset();
}

// The profile log-likelihood of the parameter picked in the table, relative to its maximum, with
// the threshold -χ²₁(0.95)/2 and the interval's ends.
void DrawProfile(AppState& state, const FitResult& r, float height) {
  const estimate::ParameterEstimate* e = FindEstimate(&r, state.parameters_view.profile_plot);
  if (!e || !e->profile || e->profile->curve.empty()) return;
  const estimate::ProfileInterval& pi = *e->profile;
  const double top = r.summary.log_posterior.value_or(r.summary.loglik);
  std::vector<double> x, y;
  for (const estimate::ProfilePoint& pt : pi.curve) {
    x.push_back(pt.value);
    y.push_back(pt.loglik - top);
  }
  const double threshold = -0.5 * 3.841458820694124;  // χ²₁(0.95)/2
  const double x0 = x.front(), x1 = x.back();
  const double tx[2] = {x0, x1}, ty[2] = {threshold, threshold};
  const std::string title = "Profile log-likelihood of " + e->name + " (relative to the maximum)";
  plot::PlotOptions options;
  options.title = title.c_str();
  options.x_label = e->name.c_str();
  options.x_unit = e->unit.empty() ? nullptr : e->unit.c_str();
  options.y_label = "log L - max";
  ImGui::PushID("profile_plot");
  if (plot::BeginPlot(state.plots, "##profile", ImVec2(-1, height), options)) {
    plot::ItemStyle line;
    line.color = IM_COL32(255, 127, 14, 255);
    plot::PlotLine(state.plots, "profile", x.data(), y.data(), static_cast<int>(x.size()), line);
    plot::PlotMarkers(state.plots, "fits", x.data(), y.data(), static_cast<int>(x.size()), line);
    plot::ItemStyle limit;
    limit.color = IM_COL32(120, 120, 120, 255);
    plot::PlotLine(state.plots, "95 % threshold", tx, ty, 2, limit);
    plot::ItemStyle est;
    est.color = IM_COL32(214, 39, 40, 255);
    est.marker_radius = 5.0f;
    const double ex = e->estimate, ey = 0.0;
    plot::PlotMarkers(state.plots, "estimate", &ex, &ey, 1, est);
    plot::EndPlot(state.plots);
  }
  ImGui::PopID();
}

// ---------------------------------------------------------------------------------------------
// 3. Warnings and correlations

void DrawWarnings(AppState& state, const FitResult& r) {
  SectionHeading(state, "Warnings");
  if (r.summary.warnings.empty()) {
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextDisabled(
        "None: every free parameter has a standard error, none is at a bound, and no two "
        "estimates are correlated beyond |r| = 0.99.");
    ImGui::PopTextWrapPos();
    return;
  }
  const float s = state.fonts.scale;
  for (const std::string& w : r.summary.warnings) {
    const ImVec2 p = ImGui::GetCursorScreenPos();
    const float radius = 3.5f * s;
    ImGui::GetWindowDrawList()->AddCircleFilled(
        ImVec2(p.x + radius, p.y + 0.5f * ImGui::GetTextLineHeight()), radius,
        ImGui::ColorConvertFloat4ToU32(SeverityColor(Severity::kWarning)), 12);
    ImGui::SetCursorScreenPos(ImVec2(p.x + 4.0f * radius, p.y));
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextUnformatted(w.c_str());
    ImGui::PopTextWrapPos();
  }
}

void DrawCorrelation(AppState& state, const FitResult& r, float max_height) {
  SectionHeading(state, "Correlation of the estimates");
  const std::vector<std::string>& names = r.summary.correlation_names;
  if (names.size() < 2) {
    ImGui::TextDisabled("Fewer than two parameters have a standard error.");
    return;
  }
  plot::HeatMapOptions options;
  options.scale = state.fonts.scale;
  options.max_height = max_height;
  plot::HeatMap("##correlation", names, r.correlation.data(), options);
}

// ---------------------------------------------------------------------------------------------
// 4. DrawParametersPanel

void DrawFitLine(AppState& state, const FitResult* result) {
  const float gap = 1.6f * ImGui::GetFontSize();
  const bool running = EstimationRunning(state);
  ImGui::AlignTextToFramePadding();
  if (!result) {
    ImGui::TextDisabled("%s", running ? "An estimation is under way (Estimate view)."
                                      : "No estimates yet: run the estimation in the Estimate "
                                        "view. Edits here change the start values and bounds.");
  } else {
    const estimate::EstimateSummary& s = result->summary;
    if (s.converged) {
      ImGui::TextUnformatted("Converged");
    } else {
      ImGui::TextColored(SeverityColor(Severity::kWarning), "Not converged");
    }
    ImGui::SameLine(0, gap);
    LabelValue("log L", FormatFixed(s.loglik, 3));
    ImGui::SameLine(0, gap);
    LabelValue("Observations", GroupedCount(s.n_obs));
    ImGui::SameLine(0, gap);
    LabelValue("Free", std::to_string(s.n_free));
    ImGui::SameLine(0, gap);
    ImGui::TextDisabled("interval: estimate \xC2\xB1 1.96 SE");
  }
  const char* label = "Use estimates as start values";
  const float w = ImGui::CalcTextSize(label).x + 2.0f * ImGui::GetStyle().FramePadding.x;
  // At the right of the line where it fits after the figures, else under them (1024 x 768).
  const float right = ImGui::GetContentRegionMax().x - w;
  const float after = ImGui::GetItemRectMax().x - ImGui::GetWindowPos().x + gap;
  if (right >= after) ImGui::SameLine(right);
  ImGui::BeginDisabled(!result);
  if (ImGui::Button(label)) state.parameters_view.use_estimates_requested = true;
  ImGui::EndDisabled();
  if (result && result->model_revision != state.model_revision) {
    ImGui::TextColored(SeverityColor(Severity::kWarning),
                       "The parameters were edited after this fit: the estimates are those of "
                       "the model as it was.");
  }
}

}  // namespace

void DrawParametersPanel(AppState& state) {
  if (DrawNoProjectNotice(state)) return;
  if (!state.model) {
    DrawNotice(state, "The model is not valid", state.model_error, Severity::kError);
    return;
  }
  const FitResult* result = state.estimation.result ? &*state.estimation.result : nullptr;
  ImGui::BeginChild("##parameters_view");
  DrawFitLine(state, result);
  ImGui::Spacing();
  DrawTable(state, result);
  DrawRefusal(state);
  if (result) {
    const float s = state.fonts.scale;
    ImGui::Spacing();
    if (!state.parameters_view.profile_plot.empty()) {
      DrawProfile(state, *result, 240.0f * s);
      ImGui::Spacing();
    }
    // The heat map fits the rest of the view (down to a legible size; below it, it scrolls).
    const ImGuiStyle& style = ImGui::GetStyle();
    const float heading_h = ImGui::GetTextLineHeight() + 8.0f * s + 3.0f * style.ItemSpacing.y;
    const float max_height =
        std::max(200.0f * s, ImGui::GetContentRegionAvail().y - heading_h -
                                 2.0f * style.CellPadding.y - style.ItemSpacing.y);
    if (ImGui::BeginTable("##below", 2, ImGuiTableFlags_SizingStretchProp)) {
      ImGui::TableSetupColumn("correlation", ImGuiTableColumnFlags_WidthFixed);
      ImGui::TableSetupColumn("warnings", ImGuiTableColumnFlags_WidthStretch);
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      DrawCorrelation(state, *result, max_height);
      ImGui::TableNextColumn();
      ImGui::Indent(12.0f * s);
      DrawWarnings(state, *result);
      ImGui::Unindent(12.0f * s);
      ImGui::EndTable();
    }
  }
  ImGui::EndChild();
  ApplyParameterEdits(state);
}

}  // namespace gb::ui
