// The residuals view: for one output of the selected dataset, the verdict of core/diagnose in
// words (coloured by severity) with the Ljung-Box and normality figures, then a grid of plots:
//
//   residuals against time (± 2 sd), linked with the Predictions view's time axis
//   ACF of z          | PACF of z        | CCF of z with an input (prewhitened and raw)
//   cumulated periodogram with its KS band | histogram of z with N(0, 1) | QQ plot
//
// z = ε / sd are the standardised one-step residuals; bands are 95 % under whiteness.
// The numbers come from AppState::analysis (ui/jobs/analysis.h); this panel only reads them.
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

constexpr float kMinPlotHeight = 150.0f;  // pixels at scale 1; below it the view scrolls
constexpr float kSelectorWidth = 160.0f;
constexpr float kTimeRowShare = 0.34f;  // of the plots' height; the two grid rows share the rest
constexpr double kLagPadding = 0.03;    // the end stems do not sit on the frame
constexpr float kBandAlpha = 0.16f;

// Output and input selectors (only when there is a choice), on the header's toolbar line.
bool DrawSelectors(AppState& state) {
  AnalysisState& a = state.analysis;
  const Analysis& r = *a.result;
  a.output = std::clamp(a.output, 0, std::max(0, static_cast<int>(r.outputs.size()) - 1));
  a.input = std::clamp(a.input, 0, std::max(0, static_cast<int>(r.inputs.size()) - 1));
  bool any = false;
  auto selector = [&](const char* label, const char* id, int* index,
                      const std::vector<std::string>& names) {
    if (names.size() <= 1) return;
    if (any) ImGui::SameLine(0, 1.6f * ImGui::GetFontSize());
    any = true;
    ImGui::AlignTextToFramePadding();
    ImGui::TextDisabled("%s", label);
    ImGui::SameLine();
    ImGui::SetNextItemWidth(kSelectorWidth * state.fonts.scale);
    if (ImGui::BeginCombo(id, names[static_cast<std::size_t>(*index)].c_str())) {
      for (int i = 0; i < static_cast<int>(names.size()); ++i) {
        if (ImGui::Selectable(names[static_cast<std::size_t>(i)].c_str(), i == *index) &&
            i != *index) {
          *index = i;
          a.RequestFit();
        }
      }
      ImGui::EndCombo();
    }
  };
  selector("Output", "##output", &a.output, r.outputs);
  selector("Cross-correlation with", "##input", &a.input, r.inputs);
  if (r.inputs.empty()) return any;
  if (any) ImGui::SameLine(0, 1.6f * ImGui::GetFontSize());
  ImGui::Checkbox("Raw cross-correlation", &a.show_raw_ccf);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("Also the cross-correlation with the input as measured (not prewhitened)");
  return true;
}

// The verdict in a tinted box: green when the residuals look white and normal, amber when
// white but not normal, red when not white.
void DrawVerdict(AppState& state, const diagnose::ResidualDiagnostics& st) {
  const float s = state.fonts.scale;
  const ImU32 color = VerdictColor(st);
  const char* word = VerdictWord(st);
  ImDrawList* dl = ImGui::GetWindowDrawList();
  dl->ChannelsSplit(2);
  dl->ChannelsSetCurrent(1);
  const ImVec2 top = ImGui::GetCursorScreenPos();
  const float pad = 8.0f * s;
  ImGui::Indent(pad + 4.0f * s);
  ImGui::Dummy(ImVec2(0, 0.5f * pad));
  ImGui::PushFont(state.fonts.bold);
  ImGui::PushStyleColor(ImGuiCol_Text, color);
  ImGui::TextUnformatted(word);
  ImGui::PopStyleColor();
  ImGui::PopFont();
  ImGui::SameLine(0, 0.8f * ImGui::GetFontSize());
  ImGui::PushTextWrapPos(ImGui::GetContentRegionMax().x - pad);
  ImGui::TextUnformatted(st.verdict.c_str());
  ImGui::PopTextWrapPos();
  ImGui::Unindent(pad + 4.0f * s);
  const float bottom = ImGui::GetItemRectMax().y + 0.5f * pad;
  ImGui::Dummy(ImVec2(0, 0.5f * pad - ImGui::GetStyle().ItemSpacing.y));
  dl->ChannelsSetCurrent(0);
  const ImVec2 max(top.x + ImGui::GetContentRegionAvail().x, bottom);
  dl->AddRectFilled(top, max, (color & ~IM_COL32_A_MASK) | IM_COL32(0, 0, 0, 24), 4.0f * s);
  dl->AddRectFilled(top, ImVec2(top.x + 4.0f * s, max.y), color, 4.0f * s,
                    ImDrawFlags_RoundCornersLeft);
  dl->ChannelsMerge();
}

// "label value" pairs left to right, a pair moving to the next line when it does not fit.
void DrawFigures(const OutputAnalysis& o, const diagnose::ResidualDiagnostics& st) {
  const diagnose::LjungBox& lb = st.ljung_box;
  const diagnose::Normality& nm = st.normality;
  const float gap = 1.6f * ImGui::GetFontSize();
  const float right = ImGui::GetWindowPos().x + ImGui::GetContentRegionMax().x;
  bool first = true;
  auto figure = [&](const char* label, const std::string& value) {
    const float w = ImGui::CalcTextSize(label).x + 0.5f * ImGui::GetFontSize() +
                    ImGui::CalcTextSize(value.c_str()).x;
    if (!first && ImGui::GetItemRectMax().x + gap + w <= right) ImGui::SameLine(0, gap);
    first = false;
    LabelValue(label, value);
  };
  const std::string df = lb.df == lb.lags ? "" : " (" + std::to_string(lb.df) + " df)";
  figure("Ljung-Box", "Q = " + FormatSig(lb.statistic, 4) + " on " + std::to_string(lb.lags) +
                          " lags" + df + ", p = " + FormatPValue(lb.p_value));
  figure("Jarque-Bera", FormatSig(nm.jarque_bera, 4) + ", p = " + FormatPValue(nm.p_value));
  figure("Skewness", FormatSig(nm.skewness, 3));
  figure("Excess kurtosis", FormatSig(nm.excess_kurtosis, 3));
  figure("sd of z", FormatSig(nm.sd, 3));
  figure("RMS of \xCE\xB5", FormatSig(o.rms, 4));
  figure("n", GroupedCount(st.n));
}

plot::ItemStyle Style(ImU32 color, float alpha = 0.22f) {
  plot::ItemStyle style;
  style.color = color;
  style.fill_alpha = alpha;
  return style;
}

void DrawTimePlot(AppState& state, const DatasetAnalysis& d, const OutputAnalysis& o, ImVec2 size) {
  const std::string title = "Residuals \xCE\xB5 = " + o.name + " \xE2\x88\x92 one-step prediction";
  plot::PlotOptions options;
  options.title = title.c_str();
  options.x_label = d.time_name.c_str();
  options.y_label = "\xCE\xB5";
  options.linked_x = &state.analysis.time_x;
  options.legend = plot::Legend::kShow;
  if (!plot::BeginPlot(state.plots, "##time", size, options)) return;
  const int n = static_cast<int>(d.time.size());
  plot::PlotBand(state.plots, "\xC2\xB1 2 sd", d.time.data(), o.residual_lower.data(),
                 o.residual_upper.data(), n, Style(kPredictionColor, kBandAlpha));
  if (const OutputAnalysis* g =
          GhostOutput(state, static_cast<std::size_t>(state.analysis.dataset),
                      static_cast<std::size_t>(&o - d.outputs.data()), d.time.size()))
    plot::PlotLine(state.plots, kGhostLabel, d.time.data(), g->residual.data(), n,
                   Style(GhostColor(kReferenceColor)));
  plot::PlotLine(state.plots, "residual", d.time.data(), o.residual.data(), n,
                 Style(state.plots.style.ink));
  plot::EndPlot(state.plots);
}

void DrawCorrelogram(AppState& state, const char* id, const char* title, const char* x_label,
                     const CorrelogramPlot& c, const CorrelogramPlot* raw, plot::LinkedRange* x,
                     ImVec2 size) {
  plot::PlotOptions options;
  options.title = title;
  options.x_label = x_label;
  options.x_unit = "samples";
  options.linked_x = x;
  options.x_padding = kLagPadding;
  options.legend = raw ? plot::Legend::kShow : plot::Legend::kHide;
  if (!plot::BeginPlot(state.plots, id, size, options)) return;
  plot::PlotBand(state.plots, "95 % band", c.band_x.data(), c.band_lo.data(), c.band_hi.data(),
                 static_cast<int>(c.band_x.size()), Style(kBandColor, kBandAlpha));
  if (raw) {
    plot::PlotLine(state.plots, "input as measured", raw->lag.data(), raw->value.data(),
                   static_cast<int>(raw->lag.size()), Style(kAheadColor));
  }
  plot::PlotStems(state.plots, raw ? "prewhitened input" : "correlation", c.lag.data(),
                  c.value.data(), static_cast<int>(c.lag.size()), 0.0, Style(kPredictionColor));
  plot::EndPlot(state.plots);
}

void DrawPeriodogram(AppState& state, const DiagnosticsPlot& p, ImVec2 size) {
  const diagnose::CumulatedPeriodogram& cp = p.stats.periodogram;
  plot::PlotOptions options;
  options.title = "Cumulated periodogram";
  options.x_label = "frequency";
  options.x_unit = "cycles/sample";
  options.linked_x = &state.analysis.periodogram_x;
  options.legend = plot::Legend::kShow;
  options.legend_corner = plot::LegendCorner::kBottomRight;
  if (!plot::BeginPlot(state.plots, "##periodogram", size, options)) return;
  const int n = static_cast<int>(cp.frequency.size());
  plot::PlotBand(state.plots, "KS 95 % band", cp.frequency.data(), p.white_lo.data(),
                 p.white_hi.data(), n, Style(kBandColor, kBandAlpha));
  plot::PlotLine(state.plots, "white noise", cp.frequency.data(), cp.white.data(), n,
                 Style(kBandColor));
  plot::PlotLine(state.plots, "residuals", cp.frequency.data(), cp.value.data(), n,
                 Style(kPredictionColor));
  plot::EndPlot(state.plots);
}

void DrawHistogram(AppState& state, const DiagnosticsPlot& p, ImVec2 size) {
  plot::PlotOptions options;
  options.title = "Histogram of z";
  options.x_label = "z";
  options.y_label = "density";
  options.linked_x = &state.analysis.histogram_x;
  options.legend = plot::Legend::kShow;
  options.legend_corner = plot::LegendCorner::kTopLeft;  // the tails are low
  if (!plot::BeginPlot(state.plots, "##histogram", size, options)) return;
  const int n = static_cast<int>(p.hist_x.size());
  plot::PlotBand(state.plots, "##bins", p.hist_x.data(), p.hist_zero.data(), p.hist_density.data(),
                 n, Style(kPredictionColor, 0.3f));
  plot::PlotLine(state.plots, "z", p.hist_x.data(), p.hist_density.data(), n,
                 Style(kPredictionColor));
  plot::PlotLine(state.plots, "N(0, 1)", p.normal_x.data(), p.normal_density.data(),
                 static_cast<int>(p.normal_x.size()), Style(kReferenceColor));
  plot::EndPlot(state.plots);
}

void DrawQQ(AppState& state, const DiagnosticsPlot& p, ImVec2 size) {
  const diagnose::Normality& nm = p.stats.normality;
  plot::PlotOptions options;
  options.title = "Normal QQ plot of z";
  options.x_label = "N(0, 1) quantile";
  options.y_label = "z";
  options.linked_x = &state.analysis.qq_x;
  options.legend = plot::Legend::kShow;
  options.legend_corner = plot::LegendCorner::kTopLeft;  // the points run bottom-left to top-right
  options.x_padding = kLagPadding;
  if (!plot::BeginPlot(state.plots, "##qq", size, options)) return;
  plot::ItemStyle points = Style(kPredictionColor);
  points.marker_radius = 1.75f;
  plot::PlotMarkers(state.plots, "z", nm.qq_theoretical.data(), nm.qq_sample.data(),
                    static_cast<int>(nm.qq_theoretical.size()), points);
  plot::PlotLine(state.plots, "z = quantile", p.qq_line.data(), p.qq_line.data(),
                 static_cast<int>(p.qq_line.size()), Style(kReferenceColor));
  plot::EndPlot(state.plots);
}

void DrawGrid(AppState& state, const DatasetAnalysis& d, const OutputAnalysis& o) {
  AnalysisState& a = state.analysis;
  const float s = state.fonts.scale;
  const ImGuiStyle& style = ImGui::GetStyle();
  const float gap = style.ItemSpacing.x;
  const float avail = ImGui::GetContentRegionAvail().y - 2.0f * style.ItemSpacing.y;
  const float time_h = std::max(kMinPlotHeight * s, std::floor(kTimeRowShare * avail));
  const float row_h = std::max(kMinPlotHeight * s, std::floor(0.5f * (avail - time_h)));
  const bool scrolls = time_h + 2.0f * row_h > avail;
  ImGui::BeginChild("##residual_plots", ImVec2(0, 0), false,
                    scrolls ? ImGuiWindowFlags_None : ImGuiWindowFlags_NoScrollbar);
  const float width = ImGui::GetContentRegionAvail().x;
  const float cell_w = std::floor((width - 2.0f * gap) / 3.0f);
  DrawTimePlot(state, d, o, ImVec2(-1, time_h));
  if (!o.diagnostics) {
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextColored(SeverityColor(Severity::kWarning), "Not diagnosed: %s",
                       o.diagnose_error.c_str());
    ImGui::PopTextWrapPos();
    ImGui::EndChild();
    return;
  }
  const DiagnosticsPlot& p = *o.diagnostics;
  const ImVec2 cell(cell_w, row_h);
  DrawCorrelogram(state, "##acf", "Autocorrelation of z", "lag", p.acf, nullptr, &a.acf_x, cell);
  ImGui::SameLine();
  DrawCorrelogram(state, "##pacf", "Partial autocorrelation of z", "lag", p.pacf, nullptr,
                  &a.pacf_x, cell);
  ImGui::SameLine();
  const auto i = static_cast<std::size_t>(a.input);
  if (i < p.ccf.size() && !p.stats.ccf[i].constant) {
    // The prewhitened input locates a peak (the verdict uses it); the input as measured, on
    // request, shows how its own correlation smears it.
    const std::string title = "CCF of z with prewhitened " + p.stats.ccf[i].input;
    DrawCorrelogram(state, "##ccf", title.c_str(), "lag (input leads)", p.ccf_prewhitened[i],
                    a.show_raw_ccf ? &p.ccf[i] : nullptr, &a.ccf_x, ImVec2(-1, row_h));
  } else {
    ImGui::BeginChild("##no_ccf", ImVec2(-1, row_h));
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextDisabled("%s", p.ccf.empty() ? "The model has no input: no cross-correlation."
                                            : "This input does not vary over the rows: no "
                                              "cross-correlation exists.");
    ImGui::PopTextWrapPos();
    ImGui::EndChild();
  }
  DrawPeriodogram(state, p, cell);
  ImGui::SameLine();
  DrawHistogram(state, p, cell);
  ImGui::SameLine();
  DrawQQ(state, p, ImVec2(-1, row_h));
  ImGui::EndChild();
}

}  // namespace

void DrawResidualsPanel(AppState& state) {
  const DatasetAnalysis* d = DrawAnalysisHeader(state, DrawSelectors);
  if (!d || d->outputs.empty()) return;
  state.analysis.output =
      std::clamp(state.analysis.output, 0, static_cast<int>(d->outputs.size()) - 1);
  const OutputAnalysis& o = d->outputs[static_cast<std::size_t>(state.analysis.output)];
  if (o.diagnostics) {
    DrawVerdict(state, o.diagnostics->stats);
    DrawFigures(o, o.diagnostics->stats);
  }
  ImGui::PushID(state.analysis.dataset);
  ImGui::PushID(state.analysis.output);
  DrawGrid(state, *d, o);
  ImGui::PopID();
  ImGui::PopID();
}

}  // namespace gb::ui
