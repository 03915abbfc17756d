// The Live view: on-line identification and condition monitoring. The model's parameters are
// tracked by the recursive estimator and its innovations watched by CUSUM tests (core/online/
// monitor.h) while the data come in, from the virtual dyno (with faults injected on request) or a
// CSV file being written; the plots scroll with the data.
//
// Sections
//   1. Source and reference
//   2. Controls: Start, Pause, Reset, speed, forgetting, false alarms; faults
//   3. Status and the alarm banner
//   4. Plots: signals, CUSUM statistics, one plot per tracked parameter, alarms and faults
//   5. DrawLivePanel
//
// The run is AppState::live.job (StartLive); this panel reads what PollLive took from it and sends
// commands, and never waits for the job.
#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <imgui.h>
#include <imgui_stdlib.h>

#include "core/sim/dyno.h"
#include "core/util/json.h"
#include "ui/format.h"
#include "ui/panels/common.h"
#include "ui/panels/panels.h"
#include "ui/theme.h"

namespace gb::ui {
namespace {

constexpr float kLabelWidth = 84.0f;  // pixels at scale 1: "Source", "Reference", "Fault"
constexpr float kPathWidth = 300.0f;
constexpr float kButtonWidth = 80.0f;
constexpr float kNumberWidth = 84.0f;
constexpr float kSmallNumberWidth = 60.0f;
constexpr float kMinPlotHeight = 120.0f;
constexpr int kGridColumns = 4;  // of the plots' grid
constexpr int kBrowseCsv = 1;
constexpr int kBrowseResult = 2;

constexpr ImU32 kEstimateColor = IM_COL32(31, 119, 180, 255);
constexpr ImU32 kReferenceColor = IM_COL32(110, 118, 132, 255);
constexpr ImU32 kTruthColor = IM_COL32(20, 130, 60, 255);
constexpr ImU32 kAlarmColor = IM_COL32(214, 39, 40, 255);
constexpr ImU32 kFaultColor = IM_COL32(230, 120, 0, 255);
constexpr ImU32 kRunningColor = IM_COL32(44, 160, 44, 255);
constexpr ImU32 kPausedColor = IM_COL32(230, 150, 20, 255);
constexpr ImU32 kStoppedColor = IM_COL32(150, 154, 160, 255);
constexpr std::array<ImU32, 3> kCusumColors = {
    IM_COL32(255, 127, 14, 255), IM_COL32(148, 103, 189, 255), IM_COL32(140, 86, 75, 255)};
constexpr std::array<const char*, 3> kCusumNames = {"mean up", "mean down", "variance up"};
constexpr std::array<ImU32, 4> kSignalColors = {
    IM_COL32(31, 119, 180, 255), IM_COL32(60, 64, 72, 255), IM_COL32(44, 160, 44, 255),
    IM_COL32(148, 103, 189, 255)};

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string Seconds(double t) { return std::isfinite(t) ? FormatFixed(t, 2) + " s" : kDash; }

// "tau_ff [s]"
std::string WithUnit(const std::string& name, const std::string& unit) {
  return unit.empty() ? name : name + " [" + unit + "]";
}

void RowLabel(AppState& state, const char* text) {
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("%s", text);
  ImGui::SameLine(kLabelWidth * state.fonts.scale);
}

void Gap() { ImGui::SameLine(0, 1.4f * ImGui::GetFontSize()); }
// The same for a group of controls `width` wide that goes to the next line where it does not fit
// (1024 x 768).
void GapOrWrap(float width) { SameLineIfFits(width, 1.4f * ImGui::GetFontSize()); }

// A path field and a Browse button that opens the view's file browser for `target`.
void PathField(AppState& state, const char* id, std::string* path, const char* hint, int target,
               FileBrowserRequest request) {
  const float s = state.fonts.scale;
  ImGui::PushID(id);
  ImGui::SetNextItemWidth(kPathWidth * s);
  ImGui::InputTextWithHint("##path", hint, path);
  if (ImGui::IsItemHovered() && !path->empty()) ImGui::SetTooltip("%s", path->c_str());
  ImGui::SameLine();
  if (ImGui::Button("Browse\xE2\x80\xA6")) {
    if (!path->empty()) request.start = *path;
    state.live.browsing = target;
    OpenFileBrowser(state.live.browser, std::move(request));
  }
  ImGui::PopID();
}

// ---------------------------------------------------------------------------------------------
// 1. Source and reference

void DrawSource(AppState& state, bool locked) {
  LiveSettings& settings = state.live.settings;
  const float s = state.fonts.scale;
  RowLabel(state, "Source");
  ImGui::BeginDisabled(locked);
  const bool dyno = settings.source == LiveSourceKind::kDyno;
  ImGui::SetNextItemWidth(170.0f * s);
  if (ImGui::BeginCombo("##source", dyno ? "Virtual dyno" : "Follow a CSV file")) {
    if (ImGui::Selectable("Virtual dyno", dyno)) settings.source = LiveSourceKind::kDyno;
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("The fuel film's experiment simulated live (the paper's Table 2 values)");
    if (ImGui::Selectable("Follow a CSV file", !dyno)) settings.source = LiveSourceKind::kCsvFile;
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("Rows are read as another program appends them (tail -f)");
    ImGui::EndCombo();
  }
  if (settings.source == LiveSourceKind::kDyno) {
    Gap();
    ImGui::AlignTextToFramePadding();
    ImGui::TextDisabled("Operating point");
    ImGui::SameLine();
    ImGui::SetNextItemWidth(70.0f * s);
    if (ImGui::BeginCombo("##point", settings.point.c_str())) {
      for (const sim::FuelOperatingPoint& p : sim::PaperFuelPoints()) {
        if (ImGui::Selectable(p.name.c_str(), p.name == settings.point)) settings.point = p.name;
        if (ImGui::IsItemHovered())
          ImGui::SetTooltip("n = %.0f rpm, \xCE\xB1 = %.1f\xC2\xB0", p.speed_rpm, p.throttle_deg);
      }
      ImGui::EndCombo();
    }
    Gap();
    ImGui::AlignTextToFramePadding();
    ImGui::TextDisabled("Seed");
    ImGui::SameLine();
    ImGui::SetNextItemWidth(kNumberWidth * s);
    int seed = static_cast<int>(std::min<std::uint64_t>(settings.seed, 1000000000));
    if (ImGui::InputInt("##seed", &seed))
      settings.seed = static_cast<std::uint64_t>(std::max(0, seed));
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "The dyno's noise; seed 1 made the bundled records, so another gives data "
          "the reference has not seen");
  } else {
    ImGui::SameLine();
    FileBrowserRequest r;
    r.title = "Follow a CSV file";
    r.confirm = "Follow";
    r.filters = {{"CSV files (*.csv)", {".csv"}}, {"All files", {}}};
    PathField(state, "csv", &settings.csv_path, "a CSV file being written", kBrowseCsv,
              std::move(r));
  }
  ImGui::EndDisabled();
}

void DrawReference(AppState& state, bool locked) {
  LiveState& l = state.live;
  const bool fit = state.estimation.result.has_value();
  RowLabel(state, "Reference");
  ImGui::BeginDisabled(locked);
  ImGui::BeginDisabled(!fit);
  if (ImGui::RadioButton("This session's estimate",
                         fit && l.reference == LiveReferenceKind::kSession))
    l.reference = LiveReferenceKind::kSession;
  ImGui::EndDisabled();
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
    ImGui::SetTooltip("%s", fit ? "The last fit of the Estimate view: its estimates, delays and "
                                  "covariance"
                                : "No estimate yet: run one in the Estimate view");
  Gap();
  if (ImGui::RadioButton("Result file", l.reference == LiveReferenceKind::kFile || !fit))
    l.reference = LiveReferenceKind::kFile;
  ImGui::SameLine();
  FileBrowserRequest r;
  r.title = "Open a result file";
  r.filters = {{"Result files (*.json)", {".json"}}, {"All files", {}}};
  PathField(state, "result", &l.reference_file, "greybench-cli estimate --out FILE", kBrowseResult,
            std::move(r));
  ImGui::EndDisabled();

  // What Start would use, said plainly.
  const std::string text = LiveReferenceText(state);
  ImGui::SetCursorPosX(ImGui::GetCursorPosX() + kLabelWidth * state.fonts.scale);
  if (text.empty() && fit) {
    ImGui::TextColored(SeverityColor(Severity::kWarning),
                       "Choose a result file, or start from this session's estimate.");
  } else if (text.empty()) {
    ImGui::TextColored(SeverityColor(Severity::kWarning),
                       "No reference: run an estimate first, or open a result file.");
  } else {
    ImGui::TextDisabled("The monitor starts from %s.", text.c_str());
  }
}

// ---------------------------------------------------------------------------------------------
// 2. Controls

void DrawControls(AppState& state) {
  LiveState& l = state.live;
  const float s = state.fonts.scale;
  const bool active = l.job.active();
  const bool running = LiveRunning(state);

  ImGui::BeginDisabled(active);
  const bool start = PrimaryButton("Start", ImVec2(kButtonWidth * s, 0));
  ImGui::EndDisabled();
  if (start) {
    std::string why;
    if (!StartLive(state, &why)) {
      l.last_failure = why;
      AddMessage(state, Severity::kError, "The live run cannot start: " + why);
    }
  }
  ImGui::SameLine();
  ImGui::BeginDisabled(!running);
  if (ImGui::Button(l.paused ? "Resume###pause" : "Pause###pause", ImVec2(kButtonWidth * s, 0)))
    PauseLive(state, !l.paused);
  ImGui::EndDisabled();
  ImGui::SameLine();
  ImGui::BeginDisabled(!running && l.series.size() == 0 && !l.setup);
  if (ImGui::Button("Reset", ImVec2(kButtonWidth * s, 0))) ResetLive(state);
  ImGui::EndDisabled();
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
    ImGui::SetTooltip("Stop the run and clear the plots; Start begins again from t = 0");

  Gap();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("Speed");
  ImGui::SameLine();
  ImGui::BeginDisabled(l.settings.source != LiveSourceKind::kDyno);
  ImGui::SetNextItemWidth(150.0f * s);
  if (ImGui::BeginCombo("##speed", Info(l.settings.speed).name)) {
    for (const LiveSpeedInfo& info : kLiveSpeeds) {
      if (ImGui::Selectable(info.name, info.speed == l.settings.speed))
        SetLiveSpeed(state, info.speed);
    }
    ImGui::EndCombo();
  }
  ImGui::EndDisabled();
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
    ImGui::SetTooltip("%s", l.settings.source == LiveSourceKind::kDyno
                                ? "Seconds of data per second of the clock"
                                : "A followed file is read as it grows");

  // The monitor's options are fixed for a run (they design its tests when it starts).
  ImGui::BeginDisabled(active);
  const float spacing = ImGui::GetStyle().ItemSpacing.x;
  GapOrWrap(ImGui::CalcTextSize("Forgetting \xCE\xBB memory 100.0 s").x + kNumberWidth * s +
            2 * spacing);
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("Forgetting \xCE\xBB");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(kNumberWidth * s);
  if (ImGui::InputDouble("##forgetting", &l.settings.forgetting, 0.0, 0.0, "%.5f"))
    l.settings.forgetting = std::clamp(l.settings.forgetting, 0.9, 1.0);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "Row j-k weighs \xCE\xBB^k: the estimate remembers about 1/(1-\xCE\xBB) rows "
        "(1: no forgetting)");
  ImGui::SameLine();
  const double rows = MemoryRows(l.settings.forgetting);
  double ts = l.status.sample_time;
  if (!std::isfinite(ts) && l.settings.source == LiveSourceKind::kDyno)
    ts = sim::FuelExperiment{}.recording.sample_time;
  ImGui::AlignTextToFramePadding();
  if (!std::isfinite(rows)) {
    ImGui::TextDisabled("memory: all rows");
  } else if (std::isfinite(ts)) {
    ImGui::TextDisabled("memory %s s", FormatSig(rows * ts, 3).c_str());
  } else {
    ImGui::TextDisabled("memory %s rows", FormatSig(rows, 3).c_str());
  }
  GapOrWrap(ImGui::CalcTextSize("False alarms per hour").x + kNumberWidth * s + 2 * spacing);
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("False alarms");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(kNumberWidth * s);
  if (ImGui::InputDouble("##false_alarms", &l.settings.false_alarms_per_hour, 0.0, 0.0, "%.3g"))
    l.settings.false_alarms_per_hour = std::clamp(l.settings.false_alarms_per_hour, 1e-6, 3600.0);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "The rate of false alarms of all the monitor's tests together, while the "
        "system is the reference's");
  ImGui::SameLine();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("per hour");
  ImGui::EndDisabled();
}

// Which parameters the run tracks (none ticked: all it can) and the change the score tests look
// for; fixed for a run, as the other options of the monitor.
void DrawTracking(AppState& state) {
  LiveState& l = state.live;
  const float s = state.fonts.scale;
  const std::vector<std::string>& trackable = LiveTrackable(state);
  ImGui::BeginDisabled(l.job.active());
  RowLabel(state, "Track");
  const float right = ImGui::GetWindowContentRegionMax().x;
  for (const std::string& name : trackable) {
    const ImGuiStyle& style = ImGui::GetStyle();
    const float w = ImGui::GetFrameHeight() + style.ItemInnerSpacing.x +
                    ImGui::CalcTextSize(name.c_str()).x + style.ItemSpacing.x;
    if (ImGui::GetCursorPosX() + w > right) {  // wrap under the first box
      ImGui::NewLine();
      ImGui::SetCursorPosX(kLabelWidth * s);
    }
    auto it = std::find(l.settings.track.begin(), l.settings.track.end(), name);
    bool on = it != l.settings.track.end();
    if (ImGui::Checkbox(name.c_str(), &on)) {
      if (on) {
        l.settings.track.push_back(name);
      } else {
        l.settings.track.erase(it);
      }
    }
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("Track %s; with none ticked, every parameter that can be", name.c_str());
    ImGui::SameLine();
  }
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("%s", l.settings.track.empty() ? "(all)" : "");
  Gap();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("Change");
  ImGui::SameLine();
  double percent = 100.0 * l.settings.parameter_change;
  ImGui::SetNextItemWidth(kSmallNumberWidth * s);
  if (ImGui::InputDouble("##change", &percent, 0.0, 0.0, "%.3g"))
    l.settings.parameter_change = std::clamp(percent, 0.1, 1000.0) / 100.0;
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "The relative change of a tracked parameter worth an alarm (its score test's design)");
  ImGui::SameLine();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("%%");
  ImGui::EndDisabled();
}

void DrawFaults(AppState& state) {
  LiveState& l = state.live;
  const float s = state.fonts.scale;
  RowLabel(state, "Fault");
  ImGui::SetNextItemWidth(130.0f * s);
  if (ImGui::BeginCombo("##fault", Info(l.fault.kind).name)) {
    for (const LiveFaultInfo& info : kLiveFaults) {
      if (ImGui::Selectable(info.name, info.kind == l.fault.kind)) l.fault.kind = info.kind;
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", info.summary);
    }
    ImGui::EndCombo();
  }
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", Info(l.fault.kind).summary);
  ImGui::SameLine();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("\xC3\x97");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(kSmallNumberWidth * s);
  ImGui::InputDouble("##factor", &l.fault.factor, 0.0, 0.0, "%.3g");
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("The parameter becomes its value times this");
  ImGui::SameLine();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("ramp");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(kSmallNumberWidth * s);
  if (ImGui::InputDouble("##ramp", &l.fault.ramp_s, 0.0, 0.0, "%.3g"))
    l.fault.ramp_s = std::max(0.0, l.fault.ramp_s);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("0: a step; else the change runs linearly over this many seconds");
  ImGui::SameLine();
  ImGui::AlignTextToFramePadding();
  ImGui::TextDisabled("s");
  ImGui::SameLine();
  ImGui::BeginDisabled(!LiveRunning(state) || !l.setup || !l.setup->dyno);
  if (ImGui::Button("Inject", ImVec2(kButtonWidth * s, 0))) InjectLiveFault(state);
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
    ImGui::SetTooltip("From the dyno's next sample, while it runs");
  ImGui::SameLine();
  if (ImGui::Button("Clear faults")) ClearLiveFaults(state);
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
    ImGui::SetTooltip("Every parameter back to its nominal value (over the ramp)");
  ImGui::EndDisabled();

  // The dyno's true values now.
  if (const std::optional<sim::FuelTruth>& t = l.status.truth) {
    Gap();
    ImGui::AlignTextToFramePadding();
    ImGui::TextDisabled(
        "now \xCF\x84_ff %s s \xC2\xB7 X %s \xC2\xB7 \xCE\x94t %s s \xC2\xB7 K_b %s",
        FormatSig(t->tau_ff, 3).c_str(), FormatSig(t->X, 3).c_str(),
        FormatSig(t->delay_s, 3).c_str(), FormatSig(t->Kb, 3).c_str());
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("The dyno's true values at the last row");
  }
}

// ---------------------------------------------------------------------------------------------
// 3. Status and the alarm banner

void DrawStatus(AppState& state) {
  LiveState& l = state.live;
  const LiveStatus& st = l.status;
  const char* word = "Stopped";
  ImU32 color = kStoppedColor;
  if (LiveRunning(state)) {
    word = l.paused ? "Paused" : "Running";
    color = l.paused ? kPausedColor : kRunningColor;
  }
  std::string rest = "t = " + Seconds(st.t) + "  \xC2\xB7  " + GroupedCount(st.rows) + " rows";
  if (st.skipped > 0) rest += " (" + GroupedCount(st.skipped) + " skipped)";
  if (LiveRunning(state) && l.setup && l.setup->dyno) {
    rest += "  \xC2\xB7  " + std::string(Info(st.speed).name);
    if (!state.deterministic && std::isfinite(st.achieved_speed) && !l.paused)
      rest += " (now \xC3\x97" + FormatSig(st.achieved_speed, 3) + ")";
    if (st.behind) rest += ": the monitor cannot keep up";
  }
  if (l.series.warming_up) rest += "  \xC2\xB7  warming up (the estimates hold)";
  if (st.alarms == 0) {
    rest += "  \xC2\xB7  no alarm";
  } else {
    rest += "  \xC2\xB7  " + GroupedCount(st.alarms) + (st.alarms == 1 ? " alarm" : " alarms");
    if (st.episodes < st.alarms)
      rest += " in " + GroupedCount(st.episodes) + (st.episodes == 1 ? " episode" : " episodes");
  }
  if (l.synchronous) rest += "  \xC2\xB7  run to this time by greybench-snapshot";
  StatusLine(state, color, word, rest);
  if (!st.design.empty() && ImGui::IsItemHovered()) ImGui::SetTooltip("%s", st.design.c_str());
  if (!l.last_failure.empty() && !LiveRunning(state)) {
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextColored(SeverityColor(Severity::kError), "%s", l.last_failure.c_str());
    ImGui::PopTextWrapPos();
  }
}

// Red until acknowledged: the latest alarm, its message wrapped left of the Acknowledge button.
void DrawAlarmBanner(AppState& state) {
  LiveState& l = state.live;
  if (l.series.alarms.empty() || l.series.alarms.back().episode <= l.acknowledged) return;
  const LiveAlarm& a = l.series.alarms.back();
  const float s = state.fonts.scale;
  const float pad = 6.0f * s;
  const ImVec2 top = ImGui::GetCursorScreenPos();
  const float width = ImGui::GetContentRegionAvail().x;
  const float button_w =
      ImGui::CalcTextSize("Acknowledge").x + 2.0f * ImGui::GetStyle().FramePadding.x;
  ImDrawList* dl = ImGui::GetWindowDrawList();
  dl->ChannelsSplit(2);
  dl->ChannelsSetCurrent(1);
  ImGui::SetCursorScreenPos(ImVec2(top.x + 2.0f * pad, top.y + pad));
  ImGui::PushStyleColor(ImGuiCol_Text, IM_COL32(255, 255, 255, 255));
  ImGui::AlignTextToFramePadding();
  ImGui::PushFont(state.fonts.bold);
  ImGui::Text("ALARM #%d at %s", a.episode, Seconds(a.t).c_str());
  ImGui::PopFont();
  ImGui::SameLine(0, 0.8f * ImGui::GetFontSize());
  const float wrap = top.x + width - button_w - 3.0f * pad;
  ImGui::PushTextWrapPos(wrap - ImGui::GetWindowPos().x + ImGui::GetScrollX());
  if (a.count > 1) {
    ImGui::Text("%s (%d alarms of this test since, the latest at %s)", a.message.c_str(), a.count,
                Seconds(a.last_t).c_str());
  } else {
    ImGui::TextUnformatted(a.message.c_str());
  }
  ImGui::PopTextWrapPos();
  ImGui::PopStyleColor();
  const float height =
      std::max(ImGui::GetItemRectMax().y + pad - top.y, ImGui::GetFrameHeight() + 2.0f * pad);
  ImGui::SetCursorScreenPos(
      ImVec2(top.x + width - button_w - pad, top.y + 0.5f * (height - ImGui::GetFrameHeight())));
  if (ImGui::Button("Acknowledge")) AcknowledgeLiveAlarm(state);
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("The alarm has been seen: the banner goes");
  dl->ChannelsSetCurrent(0);
  dl->AddRectFilled(top, ImVec2(top.x + width, top.y + height), IM_COL32(198, 40, 40, 255),
                    4.0f * s);
  dl->ChannelsMerge();
  ImGui::SetCursorScreenPos(ImVec2(top.x, top.y + height));
  ImGui::Dummy(ImVec2(width, 0.0f));
}

// ---------------------------------------------------------------------------------------------
// 4. Plots

// The events of the run on the time axes: alarms (red, tagged "#n" on the outputs' plots) and
// the dyno's faults (orange, tagged on the inputs' plots).
struct Marks {
  std::vector<double> alarm_t, fault_t;
  std::vector<std::string> alarm_text, fault_text;
  std::vector<const char*> alarm_tags, fault_tags;
};

Marks MakeMarks(const LiveState& l) {
  Marks m;
  for (const LiveAlarm& a : l.series.alarms) {
    m.alarm_t.push_back(a.t);
    m.alarm_text.push_back("#" + std::to_string(a.episode));
  }
  for (const LiveFaultMark& f : l.status.faults) {
    m.fault_t.push_back(f.t);
    m.fault_text.push_back(f.tag);
  }
  for (const std::string& s : m.alarm_text) m.alarm_tags.push_back(s.c_str());
  for (const std::string& s : m.fault_text) m.fault_tags.push_back(s.c_str());
  return m;
}

enum class Tags { kNone, kAlarms, kFaults };

void PlotMarks(AppState& state, const Marks& marks, Tags tags) {
  plot::ItemStyle fault;
  fault.color = kFaultColor;
  fault.line_weight = 1.0f;
  plot::PlotVLines(state.plots, "##faults", marks.fault_t.data(),
                   static_cast<int>(marks.fault_t.size()),
                   tags == Tags::kFaults ? marks.fault_tags.data() : nullptr, fault);
  plot::ItemStyle alarm;
  alarm.color = kAlarmColor;
  alarm.line_weight = 1.0f;
  plot::PlotVLines(state.plots, "##alarms", marks.alarm_t.data(),
                   static_cast<int>(marks.alarm_t.size()),
                   tags == Tags::kAlarms ? marks.alarm_tags.data() : nullptr, alarm);
}

plot::PlotOptions TimeOptions(AppState& state, const char* title) {
  plot::PlotOptions o;
  o.title = title;
  o.x_label = "t";
  o.x_unit = "s";
  o.x_title = false;  // the tick labels are enough: every plot is against time
  o.linked_x = &state.live.time_x;
  o.legend = plot::Legend::kHide;
  return o;
}

// The first of `candidates` that fits in `room` pixels.
std::string FittingTitle(AppState& state, const std::vector<std::string>& candidates, float room) {
  ImFont* font = state.plots.style.title_font ? state.plots.style.title_font : ImGui::GetFont();
  for (const std::string& c : candidates) {
    if (font->CalcTextSizeA(font->FontSize, FLT_MAX, 0.0f, c.c_str()).x <= room) return c;
  }
  return candidates.back();
}

void DrawSignalPlot(AppState& state, const LiveSetup& setup, std::size_t i, const Marks& marks,
                    ImVec2 size) {
  const LiveSeries& series = state.live.series;
  const bool input = i < setup.inputs.size();
  const std::string& name = input ? setup.inputs[i] : setup.outputs[i - setup.inputs.size()];
  const std::string title = name + (input ? " (input)" : " (output)");
  const plot::PlotOptions options = TimeOptions(state, title.c_str());
  ImGui::PushID(static_cast<int>(i));
  if (plot::BeginPlot(state.plots, "##signal", size, options)) {
    plot::ItemStyle style;
    style.color = kSignalColors[i % kSignalColors.size()];
    style.line_weight = 1.25f;
    if (i < series.signals.size())
      plot::PlotLine(state.plots, name.c_str(), series.t.data(), series.signals[i].data(),
                     series.size(), style);
    PlotMarks(state, marks, input ? Tags::kFaults : Tags::kAlarms);
    plot::EndPlot(state.plots);
  }
  ImGui::PopID();
}

void DrawCusumPlot(AppState& state, const LiveSetup& setup, std::size_t o, const Marks& marks,
                   ImVec2 size) {
  const LiveSeries& series = state.live.series;
  const std::string title =
      "CUSUM tests on the innovations of " + setup.outputs[o] + ": S/h, alarm at 1";
  plot::PlotOptions options = TimeOptions(state, title.c_str());
  options.legend = plot::Legend::kShow;
  options.legend_corner = plot::LegendCorner::kTopLeft;
  const std::array<double, 2> x = {series.t.empty() ? 0.0 : series.t.front(),
                                   series.t.empty() ? 1.0 : series.t.back()};
  const std::array<double, 2> one = {1.0, 1.0};
  ImGui::PushID(static_cast<int>(o));
  if (plot::BeginPlot(state.plots, "##cusum", size, options)) {
    plot::ItemStyle threshold;
    threshold.color = kAlarmColor;
    threshold.line_weight = 1.0f;
    plot::PlotLine(state.plots, "##threshold", x.data(), one.data(), series.t.empty() ? 0 : 2,
                   threshold);
    for (std::size_t k = 0; k < 3; ++k) {
      const std::size_t c = 3 * o + k;
      if (c >= series.cusum.size()) break;
      plot::ItemStyle style;
      style.color = kCusumColors[k];
      style.line_weight = 1.25f;
      plot::PlotLine(state.plots, kCusumNames[k], series.t.data(), series.cusum[c].data(),
                     series.size(), style);
    }
    PlotMarks(state, marks, Tags::kAlarms);
    plot::EndPlot(state.plots);
  }
  ImGui::PopID();
}

// A title starts over the plot area and may run on over the gap to the next plot's (the y
// axis' labels sit lower); the last plot of a row has only its own width.
void DrawParameterPlot(AppState& state, const LiveSetup& setup, std::size_t k, const Marks& marks,
                       ImVec2 size, bool last_in_row) {
  const LiveSeries& series = state.live.series;
  const std::string& name = setup.parameters[k];
  const std::string unit = k < setup.units.size() ? setup.units[k] : "";
  std::string value;
  if (k < series.parameters.size() && !series.t.empty()) {
    const LiveSeries::Parameter& p = series.parameters[k];
    const double sd = 0.5 * (p.upper.back() - p.lower.back());
    value = FormatSig(p.estimate.back(), 3);
    if (std::isfinite(sd)) value += " \xC2\xB1 " + FormatSig(sd, 2);
  }
  const std::string title =
      value.empty() ? WithUnit(name, unit)
                    : FittingTitle(state,
                                   {WithUnit(name, unit) + "  " + value, name + "  " + value,
                                    WithUnit(name, unit), name},
                                   size.x - (last_in_row ? 4.5f : 1.5f) * ImGui::GetFontSize());
  const plot::PlotOptions options = TimeOptions(state, title.c_str());
  const double ref = k < setup.reference_value.size() ? setup.reference_value[k] : kNaN;
  const double se = k < setup.reference_sd.size() ? setup.reference_sd[k] : kNaN;
  const std::array<double, 2> x = {series.t.empty() ? 0.0 : series.t.front(),
                                   series.t.empty() ? 1.0 : series.t.back()};
  const std::array<double, 2> ref_line = {ref, ref};
  const std::array<double, 2> ref_lo = {ref - 2.0 * se, ref - 2.0 * se};
  const std::array<double, 2> ref_hi = {ref + 2.0 * se, ref + 2.0 * se};
  const int n_ref = series.t.empty() ? 0 : 2;
  ImGui::PushID(static_cast<int>(k));
  if (plot::BeginPlot(state.plots, "##parameter", size, options)) {
    plot::ItemStyle reference;
    reference.color = kReferenceColor;
    reference.fill_alpha = 0.22f;
    reference.line_weight = 1.0f;
    if (std::isfinite(se))
      plot::PlotBand(state.plots, "reference \xC2\xB1 2 SE", x.data(), ref_lo.data(), ref_hi.data(),
                     n_ref, reference);
    plot::PlotLine(state.plots, "reference", x.data(), ref_line.data(), n_ref, reference);
    if (k < series.parameters.size()) {
      const LiveSeries::Parameter& p = series.parameters[k];
      plot::ItemStyle estimate;
      estimate.color = kEstimateColor;
      estimate.fill_alpha = 0.2f;
      plot::PlotBand(state.plots, "\xC2\xB1 2 SD", series.t.data(), p.lower.data(), p.upper.data(),
                     series.size(), estimate);
      plot::PlotLine(state.plots, "estimate", series.t.data(), p.estimate.data(), series.size(),
                     estimate);
      if (setup.truth) {
        plot::ItemStyle truth;
        truth.color = kTruthColor;
        truth.line_weight = 1.0f;
        plot::PlotLine(state.plots, "true", series.t.data(), p.truth.data(), series.size(), truth);
      }
    }
    PlotMarks(state, marks, Tags::kNone);
    plot::EndPlot(state.plots);
  }
  ImGui::PopID();
}

// The alarms and the dyno's faults, the latest first.
void DrawEvents(AppState& state, ImVec2 size) {
  const LiveState& l = state.live;
  const float s = state.fonts.scale;
  ImGui::PushStyleColor(ImGuiCol_ChildBg, Colors(state.shell.theme).pane_bg);
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(8.0f * s, 6.0f * s));
  ImGui::PushStyleVar(ImGuiStyleVar_ItemSpacing, ImVec2(6.0f * s, 3.0f * s));
  ImGui::BeginChild("##events", size, true, ImGuiWindowFlags_AlwaysUseWindowPadding);
  ImGui::PushFont(state.fonts.bold);
  ImGui::TextUnformatted("Alarms and faults");
  ImGui::PopFont();
  const auto& alarms = l.series.alarms;
  const auto& faults = l.status.faults;
  if (alarms.empty() && faults.empty()) {
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextDisabled("None so far.");
    ImGui::PopTextWrapPos();
  }
  // Merged by time, the latest first (at equal times the fault before the alarm it caused).
  auto a = alarms.rbegin();
  auto f = faults.rbegin();
  const ImVec4 dim = ImGui::GetStyle().Colors[ImGuiCol_TextDisabled];
  while (a != alarms.rend() || f != faults.rend()) {
    if (a != alarms.rend() && (f == faults.rend() || a->t >= f->t)) {
      const ImVec4 color = a->episode > l.acknowledged ? SeverityColor(Severity::kError) : dim;
      ImGui::TextColored(color, "#%d  %s", a->episode, Seconds(a->t).c_str());
      ImGui::SameLine();
      ImGui::PushTextWrapPos(0.0f);
      if (a->count > 1) {
        ImGui::Text("%s (%d alarms, to %s)", a->what.c_str(), a->count, Seconds(a->last_t).c_str());
      } else {
        ImGui::TextUnformatted(a->what.c_str());
      }
      ImGui::PopTextWrapPos();
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", a->message.c_str());
      ++a;
    } else {
      ImGui::TextColored(ImGui::ColorConvertU32ToFloat4(kFaultColor), "fault %s",
                         Seconds(f->t).c_str());
      ImGui::SameLine();
      ImGui::PushTextWrapPos(0.0f);
      ImGui::TextUnformatted(f->description.c_str());
      ImGui::PopTextWrapPos();
      ++f;
    }
  }
  if (l.status.parameter_change > 0) {
    ImGui::Spacing();
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextDisabled(
        "A parameter alarms when its score test finds it moved by %s %% from its reference; every "
        "test alarms at S/h = 1.",
        FormatSig(100.0 * l.status.parameter_change, 3).c_str());
    ImGui::PopTextWrapPos();
    if (!l.status.design.empty() && ImGui::IsItemHovered())
      ImGui::SetTooltip("%s", l.status.design.c_str());
  }
  ImGui::EndChild();
  ImGui::PopStyleVar(2);
  ImGui::PopStyleColor();
}

// The parameter plots' legend, above the grid: a swatch and a name per item.
void DrawLegend(AppState& state, const LiveSetup& setup) {
  const float s = state.fonts.scale;
  auto entry = [&](ImU32 color, int kind, const char* text) {
    const ImVec2 p = ImGui::GetCursorScreenPos();
    const float h = ImGui::GetTextLineHeight();
    ImDrawList* dl = ImGui::GetWindowDrawList();
    if (kind == 0) {
      dl->AddLine(ImVec2(p.x, p.y + 0.5f * h), ImVec2(p.x + 16.0f * s, p.y + 0.5f * h), color,
                  2.0f * s);
    } else if (kind == 1) {
      dl->AddRectFilled(ImVec2(p.x, p.y + 0.2f * h), ImVec2(p.x + 16.0f * s, p.y + 0.8f * h),
                        (color & ~IM_COL32_A_MASK) | (80u << IM_COL32_A_SHIFT));
    } else {
      dl->AddLine(ImVec2(p.x + 8.0f * s, p.y), ImVec2(p.x + 8.0f * s, p.y + h), color, 1.5f * s);
    }
    ImGui::Dummy(ImVec2(16.0f * s, h));
    ImGui::SameLine(0, 0.4f * ImGui::GetFontSize());
    ImGui::TextDisabled("%s", text);
    ImGui::SameLine(0, 1.2f * ImGui::GetFontSize());
  };
  entry(kEstimateColor, 0, "estimate");
  entry(kEstimateColor, 1, "\xC2\xB1 2 SD");
  entry(kReferenceColor, 0, "reference");
  entry(kReferenceColor, 1, "\xC2\xB1 2 SE");
  if (setup.truth) entry(kTruthColor, 0, "true value");
  entry(kAlarmColor, 2, "alarm");
  if (setup.dyno) entry(kFaultColor, 2, "fault");
  LiveState& l = state.live;
  if (!l.follow) {
    if (ImGui::SmallButton("Follow the data")) l.follow = true;
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("Scroll with the data again, showing the last %.0f s", l.window_s);
  } else {
    ImGui::TextDisabled("\xC2\xB7  the last %.0f s", l.window_s);
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "The plots scroll with the data. Zoom (wheel) or pan (drag) to look "
          "back; double-click shows everything kept (the last 10 minutes).");
  }
}

// Where each plot goes: cells of a grid kGridColumns wide, row by row.
struct Cell {
  enum class Kind { kSignal, kCusum, kParameter, kEvents } kind;
  std::size_t index = 0;
  int span = 1;          // cells wide
  bool new_row = false;  // starts a row
};

// The signals one cell each, then the CUSUM plots sharing what is left of that row (a row of
// their own when that is less than a cell each); the parameters from a new row, one cell each,
// then the list of events.
std::vector<Cell> PlanCells(const LiveSetup& setup, int* rows) {
  std::vector<Cell> cells;
  int column = 0;
  *rows = 0;
  auto add = [&](Cell c) {
    if (column == 0 || column + c.span > kGridColumns || c.new_row) {
      c.new_row = true;
      column = 0;
      ++*rows;
    }
    column += c.span;
    cells.push_back(c);
  };
  const std::size_t n_signals = setup.inputs.size() + setup.outputs.size();
  for (std::size_t i = 0; i < n_signals; ++i) add({Cell::Kind::kSignal, i, 1, false});
  const int n_out = static_cast<int>(setup.outputs.size());
  int left = column == kGridColumns ? kGridColumns : kGridColumns - column;
  if (n_out > left) left = kGridColumns;
  for (int o = 0; o < n_out; ++o) {
    const int span = std::max(1, left / n_out + (o < left % n_out ? 1 : 0));
    add({Cell::Kind::kCusum, static_cast<std::size_t>(o), span, false});
  }
  for (std::size_t k = 0; k < setup.parameters.size(); ++k)
    add({Cell::Kind::kParameter, k, 1, k == 0});
  add({Cell::Kind::kEvents, 0, 1, false});
  return cells;
}

void DrawPlots(AppState& state) {
  LiveState& l = state.live;
  const LiveSetup& setup = *l.setup;
  const LiveSeries& series = l.series;
  plot::LinkedRange& x = l.time_x;
  // Follow: the last window_s of the data (from the first row until the window fills).
  plot::Range follow{};
  if (l.follow && series.size() > 0) {
    const double lo = std::max(series.t.front(), series.t.back() - l.window_s);
    follow = {lo, lo + l.window_s};
    x.range = follow;
    x.fit_request_frame = plot::LinkedRange::kNoFit;
  }
  DrawLegend(state, setup);

  const Marks marks = MakeMarks(l);
  int rows = 0;
  const std::vector<Cell> cells = PlanCells(setup, &rows);
  const float s = state.fonts.scale;
  const float spacing = ImGui::GetStyle().ItemSpacing.x;
  const float gap_y = 4.0f * s;
  const float avail_y = ImGui::GetContentRegionAvail().y;
  const float height =
      std::max(kMinPlotHeight * s, std::floor((avail_y - gap_y * (rows - 1)) / rows) - 1.0f);
  const bool scrolls = height * rows + gap_y * (rows - 1) > avail_y;
  ImGui::BeginChild("##plots", ImVec2(0, 0), false,
                    scrolls ? ImGuiWindowFlags_None : ImGuiWindowFlags_NoScrollbar);
  const float width =
      std::floor((ImGui::GetContentRegionAvail().x - spacing * (kGridColumns - 1)) / kGridColumns);
  ImGui::PushStyleVar(ImGuiStyleVar_ItemSpacing, ImVec2(spacing, gap_y));
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Cell& c = cells[i];
    const bool last_in_row = i + 1 == cells.size() || cells[i + 1].new_row;
    if (!c.new_row) ImGui::SameLine();
    const ImVec2 size(width * static_cast<float>(c.span) + spacing * static_cast<float>(c.span - 1),
                      height);
    switch (c.kind) {
      case Cell::Kind::kSignal:
        DrawSignalPlot(state, setup, c.index, marks, size);
        break;
      case Cell::Kind::kCusum:
        DrawCusumPlot(state, setup, c.index, marks, size);
        break;
      case Cell::Kind::kParameter:
        DrawParameterPlot(state, setup, c.index, marks, size, last_in_row);
        break;
      case Cell::Kind::kEvents:
        DrawEvents(state, size);
        break;
    }
  }
  ImGui::PopStyleVar();
  ImGui::EndChild();

  // The user zoomed, panned or double-clicked: the axis stays where they put it.
  if (l.follow && series.size() > 0 &&
      (x.range.min != follow.min || x.range.max != follow.max ||
       x.fit_request_frame != plot::LinkedRange::kNoFit))
    l.follow = false;
}

void DrawNothingYet(AppState& state) {
  const LiveState& l = state.live;
  std::string text;
  if (l.settings.source == LiveSourceKind::kDyno) {
    text = "Start runs the virtual dyno at " + l.settings.point +
           " and feeds its rows to the monitor as they come: the recursive estimator tracks the "
           "model's parameters from the reference, and CUSUM tests watch the reference filter's "
           "innovations. Inject a fault while it runs and watch the estimates move and the "
           "alarms go.";
  } else {
    text =
        "Start follows the CSV file and feeds its rows to the monitor as another program "
        "writes them: the recursive estimator tracks the model's parameters from the "
        "reference, and CUSUM tests watch the reference filter's innovations.";
  }
  DrawNotice(state, "Not started", text);
}

void DrawBrowser(AppState& state) {
  LiveState& l = state.live;
  std::optional<std::string> path = DrawFileBrowser(l.browser, state.fonts.scale);
  if (!path) return;
  if (l.browsing == kBrowseCsv) {
    l.settings.csv_path = *path;
  } else if (l.browsing == kBrowseResult) {
    l.reference_file = *path;
    l.reference = LiveReferenceKind::kFile;
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 5. DrawLivePanel

void DrawLivePanel(AppState& state) {
  if (DrawNoProjectNotice(state)) return;
  if (!state.model) {
    DrawNotice(state, "The model is not valid", state.model_error, Severity::kError);
    return;
  }
  if (const std::string& why = LiveModelProblem(state); !why.empty()) {
    const std::string name =
        state.model->name.empty() ? "The model" : "\"" + state.model->name + "\"";
    DrawNotice(state, "The model cannot be watched on-line",
               name + " does not compile for the filters:\n\n" + why, Severity::kWarning);
    return;
  }
  LiveState& l = state.live;
  const bool locked = l.job.active();
  DrawSource(state, locked);
  DrawReference(state, locked);
  DrawControls(state);
  DrawTracking(state);
  if (l.settings.source == LiveSourceKind::kDyno) DrawFaults(state);
  DrawStatus(state);
  DrawAlarmBanner(state);
  if (l.setup) {
    DrawPlots(state);
  } else if (!LiveRunning(state)) {
    DrawNothingYet(state);
  }
  DrawBrowser(state);
}

}  // namespace gb::ui
