// greybench-snapshot: renders one view of the workbench offscreen (OSMesa) to a PNG.
// user guide §6:
//   greybench-snapshot --project PROJECT.json --view VIEW --out OUT.png [--width W --height H]
//                      [--estimate [--quick-sweep]] [--dialog DIALOG] [--time T0:T1]
//                      [--profile PARAMETER] [--live-until T [--live-fault
//                      TIME:PARAMETER*FACTOR[/RAMP] ...]
//                       [--live-point NAME] [--live-seed N] [--live-forgetting L]]
// Exit status: 0 written; 2 bad command line or bad input (stderr names the file); 1 the
// rendering or the PNG writing failed, or --estimate's estimation failed (the PNG is still
// written: it shows why).
//
// Several views of one session: repeat the pair, `--view A --out a.png --view B --out b.png`
// (each --out belongs to the --view before it). The project is opened, and with --estimate
// estimated, once; each view is then drawn in a fresh ImGui context, as a run of its own would
// draw it, so one run of N views writes the same N pictures as N runs (the golden tests render
// the estimated views this way: one estimation instead of seven).
//
// --estimate starts the estimation exactly as the Estimate view's Run button does
// (StartEstimation: the same background job), waits for it, then renders. It runs with
// threads = 1 and the other options at their defaults. For the operating-points view, whose
// computation is the sweep, it starts the sweep as that view's Run button does (StartSweep)
// instead. --quick-sweep runs that sweep's fits the quick way (SweepState::quick: the same
// estimates, delays and table in a fraction of the fits), as the sanitizer suite does.
//
// --profile NAME (with --estimate): the estimation computes the profile likelihood intervals (the
// Estimate view's "Profile intervals" box) and the Parameters view plots NAME's profile, as a
// click on its interval does.
//
// --live-until T (the live view): runs the virtual dyno and the condition monitor to T seconds of
// data on this thread, without a job or a clock (RunLiveSynchronously), as a Start would run them
// in real time, then draws the view stopped there. The reference is the session's estimate, so it
// needs --estimate. --live-fault schedules a fault as `greybench-cli dyno fuel --live --fault`
// does (repeat it for several; e.g. 60:tau_ff*1.5, 60:X*2/30, 90:clear); --live-point,
// --live-seed and --live-forgetting set the dyno's operating point (f1), its seed (2) and the
// estimator's forgetting factor λ (0.999), as the view's controls do. --live-csv FILE takes the
// rows of a CSV file instead of the dyno (to the row at T), and --live-reference RESULT.json a
// result file as the reference instead of the session's estimate, as the view's Source and
// Reference choices do: how a nonlinear model's view is drawn (the dyno is the fuel film's).
//
// --plot NAME (before an --out): that --out gets one plot of the view without the window around
// it, NAME being the plot's title (or, for a plot without one, its id; two plots of one title
// are told apart as "TITLE (2)"). An --out ending in .svg is the SVG drawn from the plot's data
// (core/report/figure.h), W x H pixels; any other --out a PNG of the plot alone drawn at W x H.
// An unknown NAME is bad input: the message lists the view's plots.
//
// --slider NAME[=VALUE] (repeatable): NAME's slider shown beside the view (user guide §6a) and,
// with a value, moved there as a drag would move it: the view is drawn mid-drag, the curves of
// before kept as the ghost.
//
// --step J: the Predictions view's Step mode at state index J (from 1; past the record's end:
// its last), as its Step checkbox and keys would show it.
//
// --design-try SLOT[:N]: the Experiment design view's Try of design SLOT (A or B) with N records
// (default 1), as its button would start it, waited for.
//
// --theme light|dark|projector: View › Theme's colours (default light). --hide-sidebar: View ›
// Sidebar off, the view across the whole width.
//
// --dialog opens one of the shell's dialogs over the view, as its menu item does (the file
// browser lists a real folder, so its dates make that picture depend on the machine).
//
// Deterministic: a fixed frame time, no mouse, no clock-dependent content (AppState::
// deterministic: every elapsed time, in the views and in the report text, is drawn as the
// placeholder "– s"), the fonts of SetUpWorkbench(), and a software rasteriser, so the same
// inputs give the same PNG bytes.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <GL/osmesa.h>
#include <fmt/format.h>
#include <imgui.h>

#include "core/project/project.h"
#include "core/report/figure.h"
#include "core/sim/dyno.h"
#include "core/sim/fault_schedule.h"
#include "core/util/file.h"
#include "core/util/output_guard.h"
#include "ui/render/fixed_gl_renderer.h"
#include "ui/render/png.h"
#include "ui/shell/shell.h"
#include "ui/state/app_state.h"
#include "ui/theme.h"
#include "ui/workbench.h"

namespace {

constexpr int kExitBadInput = 2;
constexpr int kExitRenderFailed = 1;
// Frames drawn before the one written: windows size themselves in the first frames and linked
// plots agree on their range and left margin one frame after they first meet.
constexpr int kSettleFrames = 4;
constexpr float kFrameTime = 1.0f / 60.0f;
constexpr int kMinSize = 64;
// --plot: the screen the view is laid out on to record its plots' figures.
constexpr float kRecordWidth = 1280.0f;
constexpr float kRecordHeight = 4096.0f;
constexpr int kMaxSize = 8192;
// --live-until: a day of data at most (the live view runs it on this thread before drawing).
constexpr double kMaxLiveSeconds = 86400;

struct Shot {
  gb::ui::View view = gb::ui::View::kData;
  std::string out;
  std::string plot;  // --plot NAME: one plot of the view ("" : the whole window)
};

struct Options {
  std::string project;
  std::vector<Shot> shots;  // in command-line order
  int width = 1280;
  int height = 800;
  bool estimate = false;
  bool quick_sweep = false;  // --quick-sweep: SweepState::quick
  std::string profile;       // --profile NAME: with --estimate, profile intervals and NAME's plot
  std::optional<gb::ui::plot::Range> time;  // --time: the time axes' range (else the whole record)
  std::string dialog;  // a dialog of the shell drawn over the view (ui/shell/shell.h)
  // --overlays: the predictions view's checkboxes to tick (ahead, simulation, smoothed, compare).
  bool ahead = false, simulation = false, smoothed = false, compare = false;
  // The live view: run to this many seconds of data (absent: not started), with these faults.
  std::optional<double> live_until;
  std::vector<gb::sim::TimedFuelFault> live_faults;  // as given; scheduled in Prepare
  std::string live_point;                            // "": the view's default
  std::optional<std::uint64_t> live_seed;
  std::optional<double> live_forgetting;
  std::string live_csv;        // "": the dyno
  std::string live_reference;  // "": the session's estimate
  int dataset = 0;  // the Predictions and Residuals views' dataset, from 1 (0: the first)
  // --slider NAME[=VALUE]: the parameter's slider shown (and moved to VALUE, mid-drag).
  std::vector<std::pair<std::string, std::optional<double>>> sliders;
  int step = 0;  // --step J: the Predictions view's Step mode at state index J (from 1; 0: off)
  int design_try = -1;     // --design-try SLOT[:N]: the slot (0 A, 1 B; -1: none) ...
  int design_records = 1;  // ... and N
  gb::ui::ThemeKind theme = gb::ui::ThemeKind::kLight;  // --theme NAME
  bool hide_sidebar = false;                            // --hide-sidebar (View › Sidebar off)
  std::string pending_plot;                             // a --plot waiting for its --out
};

constexpr const char* kUsage =
    "usage: greybench-snapshot --project PROJECT.json --view VIEW [--plot NAME] --out OUT.png\n"
    "                          [--view VIEW [--plot NAME] --out OUT.png|OUT.svg ...]\n"
    "                          [--width W] [--height H] [--estimate [--quick-sweep]]\n"
    "                          [--dialog DIALOG]\n"
    "                          [--time T0:T1] [--profile PARAMETER]\n"
    "                          [--overlays ahead,simulation,smoothed,compare] [--dataset N]\n"
    "                          [--slider PARAMETER[=VALUE] ...] [--step J] [--design-try A|B[:N]]\n"
    "                          [--theme light|dark|projector] [--hide-sidebar]\n"
    "                          [--live-until T [--live-fault TIME:PARAMETER*FACTOR[/RAMP] ...]\n"
    "                           [--live-point NAME] [--live-seed N] [--live-forgetting L]\n"
    "                           [--live-csv FILE] [--live-reference RESULT.json]]\n"
    "VIEW: data diagram equations estimate predictions residuals parameters operating-points\n"
    "      live\n"
    "DIALOG: open-project save-project-as new-project keyboard-shortcuts unsaved-changes\n"
    "        import-dataset\n";

int Fail(int status, const std::string& message) {
  std::fprintf(stderr, "greybench-snapshot: error: %s\n", message.c_str());
  return status;
}

std::optional<int> ParseSize(const std::string& text) {
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || v < kMinSize || v > kMaxSize) return std::nullopt;
  return static_cast<int>(v);
}

bool IsSvg(const std::string& path) {
  return path.size() >= 4 && (path.compare(path.size() - 4, 4, ".svg") == 0 ||
                              path.compare(path.size() - 4, 4, ".SVG") == 0);
}

// Returns an error message, or "" when the command line is good.
std::string ParseArgs(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--estimate") {
      o->estimate = true;
      continue;
    }
    if (arg == "--quick-sweep") {
      o->quick_sweep = true;
      continue;
    }
    if (arg == "--hide-sidebar") {
      o->hide_sidebar = true;
      continue;
    }
    if (arg == "--help" || arg == "-h") return "help";
    const bool takes_value =
        arg == "--project" || arg == "--view" || arg == "--out" || arg == "--width" ||
        arg == "--height" || arg == "--dialog" || arg == "--time" || arg == "--profile" ||
        arg == "--overlays" || arg == "--live-until" || arg == "--live-fault" ||
        arg == "--live-point" || arg == "--live-seed" || arg == "--live-forgetting" ||
        arg == "--live-csv" || arg == "--live-reference" || arg == "--dataset" || arg == "--plot" ||
        arg == "--slider" || arg == "--step" || arg == "--design-try" || arg == "--theme";
    if (!takes_value) return "unknown option '" + std::string(arg) + "'";
    if (i + 1 >= argc) return std::string(arg) + " needs a value";
    const std::string value = argv[++i];
    if (arg == "--project") {
      o->project = value;
    } else if (arg == "--profile") {
      o->profile = value;
    } else if (arg == "--plot") {
      if (value.empty()) return "--plot needs the name of a plot of the view";
      if (!o->pending_plot.empty())
        return "--plot " + value + ": the --plot before it (" + o->pending_plot + ") has no --out";
      o->pending_plot = value;
    } else if (arg == "--view") {
      const std::optional<gb::ui::View> view = gb::ui::ParseView(value);
      if (!view) return "unknown view '" + value + "'";
      if (!o->shots.empty() && o->shots.back().out.empty()) {
        return "--view " + value + ": the view before it has no --out";
      }
      o->shots.push_back({*view, "", ""});
    } else if (arg == "--out") {
      if (o->shots.empty()) o->shots.push_back({});  // the default view, data
      if (!o->shots.back().out.empty()) {
        return "--out " + value + ": give each --out its own --view before it";
      }
      o->shots.back().out = value;
      o->shots.back().plot = std::exchange(o->pending_plot, "");
      if (IsSvg(value) && o->shots.back().plot.empty()) {
        return "--out " + value +
               ": an SVG is drawn from one plot's data; give --plot NAME before this --out";
      }
    } else if (arg == "--dialog") {
      o->dialog = value;
    } else if (arg == "--overlays") {
      // The predictions view's overlays, ticked as their checkboxes would be.
      std::size_t begin = 0;
      while (begin <= value.size()) {
        const std::size_t end = std::min(value.find(',', begin), value.size());
        const std::string name = value.substr(begin, end - begin);
        if (name == "ahead") {
          o->ahead = true;
        } else if (name == "simulation") {
          o->simulation = true;
        } else if (name == "smoothed") {
          o->smoothed = true;
        } else if (name == "compare") {
          o->compare = true;
        } else {
          return "--overlays '" + value + "': unknown overlay '" + name +
                 "' (expected a comma-separated list of ahead, simulation, smoothed, compare)";
        }
        begin = end + 1;
      }
    } else if (arg == "--live-until") {
      char* end = nullptr;
      const double t = std::strtod(value.c_str(), &end);
      if (value.empty() || *end != '\0' || !std::isfinite(t) || t < 0 || t > kMaxLiveSeconds) {
        return "--live-until '" + value + "': expected seconds of data from 0 to " +
               fmt::format("{:g}", kMaxLiveSeconds) + " (a day; the run is drawn synchronously)";
      }
      o->live_until = t;
    } else if (arg == "--live-fault") {
      gb::Result<gb::sim::TimedFuelFault> f = gb::sim::ParseFuelFault(value, "--live-fault");
      if (!f) return f.error().message;
      o->live_faults.push_back(std::move(f).value());
    } else if (arg == "--dataset") {
      char* end = nullptr;
      const long n = std::strtol(value.c_str(), &end, 10);
      if (value.empty() || *end != '\0' || n < 1 || n > 100000)
        return "--dataset '" + value + "': expected the dataset's number, from 1";
      o->dataset = static_cast<int>(n);
    } else if (arg == "--slider") {
      const std::size_t eq = value.find('=');
      const std::string name = value.substr(0, eq);
      if (name.empty()) return "--slider '" + value + "': expected PARAMETER or PARAMETER=VALUE";
      std::optional<double> moved;
      if (eq != std::string::npos) {
        const std::string number = value.substr(eq + 1);
        char* end = nullptr;
        const double v = std::strtod(number.c_str(), &end);
        if (number.empty() || *end != '\0' || !std::isfinite(v))
          return "--slider '" + value + "': expected a finite number after '='";
        moved = v;
      }
      o->sliders.emplace_back(name, moved);
    } else if (arg == "--step") {
      char* end = nullptr;
      const long j = std::strtol(value.c_str(), &end, 10);
      if (value.empty() || *end != '\0' || j < 1 || j > 100000000)
        return "--step '" + value + "': expected the state index to show, from 1";
      o->step = static_cast<int>(j);
    } else if (arg == "--theme") {
      const auto theme = gb::ui::ParseTheme(value);
      if (!theme) return "--theme '" + value + "': expected light, dark or projector";
      o->theme = *theme;
    } else if (arg == "--design-try") {
      const std::string slot = value.substr(0, value.find(':'));
      if (slot != "A" && slot != "B")
        return "--design-try '" + value + "': expected A or B, then :N for N records";
      o->design_try = slot == "A" ? 0 : 1;
      if (value.size() > 1) {
        char* end = nullptr;
        const std::string n = value.substr(slot.size() + 1);
        const long records = std::strtol(n.c_str(), &end, 10);
        if (value[1] != ':' || n.empty() || *end != '\0' || records < 1 || records > 1000)
          return "--design-try '" + value + "': expected A or B, then :N for 1 to 1000 records";
        o->design_records = static_cast<int>(records);
      }
    } else if (arg == "--live-csv") {
      o->live_csv = value;
    } else if (arg == "--live-reference") {
      o->live_reference = value;
    } else if (arg == "--live-point") {
      if (!gb::sim::FindFuelPoint(value)) return gb::sim::FindFuelPoint(value).error().message;
      o->live_point = value;
    } else if (arg == "--live-forgetting") {
      char* end = nullptr;
      const double lambda = std::strtod(value.c_str(), &end);
      if (value.empty() || *end != '\0' || !(lambda > 0 && lambda <= 1))
        return "--live-forgetting '" + value + "': expected a forgetting factor in (0, 1]";
      o->live_forgetting = lambda;
    } else if (arg == "--live-seed") {
      char* end = nullptr;
      const unsigned long long seed = std::strtoull(value.c_str(), &end, 10);
      if (value.empty() || *end != '\0' || value[0] == '-')
        return "--live-seed '" + value + "': expected a whole number >= 0";
      o->live_seed = seed;
    } else if (arg == "--time") {
      double t0 = 0, t1 = 0;
      char rest = 0;
      if (std::sscanf(value.c_str(), "%lf:%lf%c", &t0, &t1, &rest) != 2 || !std::isfinite(t0) ||
          !std::isfinite(t1) || !(t0 < t1)) {
        return "--time '" + value + "': expected T0:T1 with T0 < T1 (in the data's time unit)";
      }
      o->time = gb::ui::plot::Range{t0, t1};
    } else {
      const std::optional<int> size = ParseSize(value);
      if (!size) {
        return std::string(arg) + " '" + value + "': expected a whole number of pixels in [" +
               std::to_string(kMinSize) + ", " + std::to_string(kMaxSize) + "]";
      }
      (arg == "--width" ? o->width : o->height) = *size;
    }
  }
  if (!o->live_faults.empty() && !o->live_until)
    return "--live-fault needs --live-until (the time the run is drawn at)";
  if ((!o->live_csv.empty() || !o->live_reference.empty()) && !o->live_until)
    return "--live-csv and --live-reference need --live-until (the time the run is drawn at)";
  if (!o->live_csv.empty() && !o->live_faults.empty())
    return "--live-fault injects into the virtual dyno, not into --live-csv's file";
  if (!o->pending_plot.empty()) return "--plot " + o->pending_plot + ": give its --out after it";
  if (o->project.empty()) return "--project is required";
  if (o->shots.empty() || o->shots.back().out.empty()) return "--out is required";
  return "";
}

bool Shows(const Options& o, gb::ui::View view) {
  for (const Shot& shot : o.shots) {
    if (shot.view == view) return true;
  }
  return false;
}

// Opens the project and, with --estimate, runs what the views show (the estimation, and the
// sweep for the operating-points view). An ImGui context with the workbench's set-up is current.
// Returns the exit status so far; *fatal when nothing can be drawn.
int Prepare(const Options& options, gb::ui::AppState& state, bool* fatal) {
  namespace ui = gb::ui;
  *fatal = true;
  state.view = options.shots.front().view;
  state.deterministic = true;
  state.sweep.quick = options.quick_sweep;
  state.analysis.show_ahead = options.ahead;
  state.analysis.show_simulation = options.simulation;
  state.analysis.show_smoothed = options.smoothed;
  state.analysis.show_compare = options.compare;
  state.analysis.show_step = options.step > 0;
  state.analysis.step = options.step - 1;
  state.analysis.step_recentre = options.step > 0;
  state.analysis.enabled = Shows(options, ui::View::kData) ||
                           Shows(options, ui::View::kPredictions) ||
                           Shows(options, ui::View::kResiduals);
  ui::OpenProject(state, options.project);
  ui::WaitForJobs(state);
  if (!state.project) return Fail(kExitBadInput, state.open_error);
  // No image may land on a file the session reads (the project, its model, data and diagram).
  std::vector<gb::FileRole> inputs = gb::project::ProjectFiles(*state.project);
  inputs.push_back({options.live_csv, "the --live-csv file"});
  inputs.push_back({options.live_reference, "the --live-reference file"});
  std::vector<gb::FileRole> outputs;
  for (const Shot& shot : options.shots) outputs.push_back({shot.out, "--out"});
  if (auto st = gb::CheckOutputs(inputs, outputs); !st)
    return Fail(kExitBadInput, st.error().ToString());
  for (const ui::LoadedDataset& d : state.datasets) {
    if (!d.data) return Fail(kExitBadInput, d.error);
  }
  if (options.dataset > static_cast<int>(state.datasets.size())) {
    return Fail(kExitBadInput, "--dataset " + std::to_string(options.dataset) +
                                   ": the project has " + std::to_string(state.datasets.size()) +
                                   " datasets");
  }
  if (options.dataset > 0) {
    state.analysis.dataset = options.dataset - 1;
    state.analysis.RequestFit();
    ui::OpenTimeWindow(state.analysis);
  }
  int status = 0;
  if (options.estimate && Shows(options, ui::View::kOperatingPoints)) {
    // The view shows the sweep: run it as its Run button does (its fits use one thread each).
    std::string why;
    if (!ui::StartSweep(state, &why)) return Fail(kExitBadInput, "--estimate: " + why);
    ui::WaitForJobs(state);
    if (!state.sweep.last_failure.empty()) {
      std::fprintf(stderr, "greybench-snapshot: error: %s\n", state.sweep.last_failure.c_str());
      status = kExitRenderFailed;
    }
  }
  bool others = false;
  for (const Shot& shot : options.shots) others |= shot.view != ui::View::kOperatingPoints;
  if (options.estimate && others) {
    state.estimation.settings.threads = 1;  // the same iterations on every machine
    if (!options.profile.empty()) {
      state.estimation.settings.profile_intervals = true;
      state.parameters_view.profile_plot = options.profile;
    }
    std::string why;
    if (!ui::StartEstimation(state, &why)) return Fail(kExitBadInput, "--estimate: " + why);
    ui::WaitForJobs(state);
    if (!state.estimation.last_failure.empty()) {
      std::fprintf(stderr, "greybench-snapshot: error: %s\n",
                   state.estimation.last_failure.c_str());
      status = kExitRenderFailed;
    }
  }
  if (!options.sliders.empty()) {
    // The sliders shown, then moved as a drag moves them: the views drawn mid-drag, the curves
    // of before as the ghost.
    if (!state.model) return Fail(kExitBadInput, "--slider: the model is not valid");
    bool any_moved = false;
    for (const auto& slider : options.sliders) {
      const std::string& name = slider.first;
      const std::optional<double>& value = slider.second;
      const auto& ps = state.model->parameters;
      const auto it =
          std::find_if(ps.begin(), ps.end(), [&](const auto& p) { return p.name == name; });
      if (it == ps.end())
        return Fail(kExitBadInput, "--slider " + name + ": the model has no such parameter");
      if (value && ((it->lower && *value < *it->lower) || (it->upper && *value > *it->upper)))
        return Fail(kExitBadInput,
                    fmt::format("--slider {}={}: outside {}'s bounds [{}, {}]", name, *value, name,
                                it->lower.value_or(-HUGE_VAL), it->upper.value_or(HUGE_VAL)));
      ui::ShowSlider(state, name, true);
      any_moved |= value.has_value();
    }
    if (any_moved) {
      state.analysis.enabled = true;
      ui::WaitForJobs(state);
      ui::BeginSliderDrag(state);
      for (const auto& [name, value] : options.sliders)
        if (value) ui::MoveSlider(state, name, *value);
      ui::WaitForJobs(state);
    }
  }
  if (options.design_try >= 0 && Shows(options, ui::View::kDesign)) {
    ui::WaitForJobs(state);
    state.design.records = options.design_records;
    std::string why;
    if (!ui::StartDesignFit(state, options.design_try, &why))
      return Fail(kExitBadInput, "--design-try: " + why);
    ui::WaitForJobs(state);
  }
  if (!options.live_point.empty()) state.live.settings.point = options.live_point;
  if (options.live_seed) state.live.settings.seed = *options.live_seed;
  if (options.live_forgetting) state.live.settings.forgetting = *options.live_forgetting;
  if (!options.live_csv.empty()) {
    state.live.settings.source = ui::LiveSourceKind::kCsvFile;
    state.live.settings.csv_path = options.live_csv;
  }
  if (!options.live_reference.empty()) {
    state.live.reference = ui::LiveReferenceKind::kFile;
    state.live.reference_file = options.live_reference;
  }
  if (options.live_until && Shows(options, ui::View::kLive)) {
    // The view's run, to the time asked for, without a clock (the Start button's job paces it).
    gb::Result<gb::sim::FuelOperatingPoint> point =
        gb::sim::FindFuelPoint(state.live.settings.point);
    if (!point) return Fail(kExitBadInput, point.error().message);
    gb::Result<std::vector<gb::sim::TimedFuelFault>> faults =
        gb::sim::ScheduleFuelFaults(options.live_faults, *point, "--live-fault");
    if (!faults) return Fail(kExitBadInput, faults.error().message);
    std::string why;
    if (!ui::RunLiveSynchronously(state, *options.live_until, std::move(faults).value(), &why)) {
      // Nothing ran (no reference, a nonlinear model) is bad input; a run that failed on the
      // way is drawn as far as it got.
      if (!state.live.setup) return Fail(kExitBadInput, "--live-until: " + why);
      std::fprintf(stderr, "greybench-snapshot: error: %s\n", why.c_str());
      status = kExitRenderFailed;
    }
  }
  *fatal = false;
  return status;
}

// The figures of the plots the current view draws, by name (PlotName; a name met again gets
// " (2)", " (3)", ...), from one more frame of the settled view.
std::vector<gb::ui::plot::RecordedFigure> RecordFigures(gb::ui::AppState& state) {
  namespace ui = gb::ui;
  // A plot below the fold is not drawn: the view is laid out on a tall screen, where every plot
  // is, before its figures are recorded. (A figure does not depend on the size it was drawn at:
  // its ranges follow the data and the zoom, the SVG chooses its own ticks.)
  ImGuiIO& io = ImGui::GetIO();
  const ImVec2 display = io.DisplaySize;
  io.DisplaySize = ImVec2(std::max(display.x, kRecordWidth), kRecordHeight);
  for (int frame = 0; frame <= kSettleFrames; ++frame) {
    if (frame == kSettleFrames) {
      state.plots.record_figures = true;
      state.plots.recorded.clear();
    }
    io.MousePos = ImVec2(-FLT_MAX, -FLT_MAX);
    ImGui::NewFrame();
    ui::DrawWorkbench(state);
    ImGui::Render();
  }
  io.DisplaySize = display;
  state.plots.record_figures = false;
  std::vector<ui::plot::RecordedFigure> figures = std::move(state.plots.recorded);
  state.plots.recorded.clear();
  std::vector<std::string> base;
  for (const ui::plot::RecordedFigure& f : figures) base.push_back(f.name);
  for (std::size_t i = 0; i < figures.size(); ++i) {
    const auto seen =
        std::count(base.begin(), base.begin() + static_cast<std::ptrdiff_t>(i), base[i]);
    if (seen > 0) figures[i].name += " (" + std::to_string(seen + 1) + ")";
  }
  return figures;
}

// --plot NAME: the named plot of the settled view, alone, as SVG (from its data) or PNG (drawn
// by the plot widget at the whole image's size).
int RenderPlot(const Options& options, const Shot& shot, gb::ui::AppState& state,
               gb::ui::FixedGlRenderer& renderer, std::vector<unsigned char>* pixels) {
  namespace ui = gb::ui;
  const std::vector<ui::plot::RecordedFigure> figures = RecordFigures(state);
  const ui::plot::RecordedFigure* chosen = nullptr;
  std::string names;
  for (const ui::plot::RecordedFigure& f : figures) {
    if ((f.name == shot.plot || f.figure.title == shot.plot) && !chosen) chosen = &f;
    names += (names.empty() ? "'" : ", '") + f.name + "'";
  }
  const std::string view(ui::ViewName(shot.view));
  if (!chosen) {
    return Fail(kExitBadInput,
                "--plot '" + shot.plot + "': the " + view + " view has no plot of that name; " +
                    (names.empty() ? std::string("it shows no plot here") : "its plots: " + names));
  }
  if (IsSvg(shot.out)) {
    const std::string svg =
        gb::report::FigureToSvg(chosen->figure, {options.width, options.height});
    if (gb::Status st = gb::WriteFileAtomic(shot.out, svg); !st)
      return Fail(kExitRenderFailed, st.error().ToString());
    return 0;
  }
  const gb::report::Figure figure = chosen->figure;
  ImGuiIO& io = ImGui::GetIO();
  for (int frame = 0; frame < 2; ++frame) {
    io.MousePos = ImVec2(-FLT_MAX, -FLT_MAX);
    ImGui::NewFrame();
    ui::plot::DrawFigureFrame(state.plots, figure);
    ImGui::Render();
  }
  glClearColor(1.0f, 1.0f, 1.0f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT);
  renderer.Render(ImGui::GetDrawData());
  glFinish();
  std::string error;
  if (!ui::WritePngFromGl(shot.out, options.width, options.height, pixels->data(), &error))
    return Fail(kExitRenderFailed, error);
  return 0;
}

// Draws one view of the prepared workbench offscreen and writes its PNG. The GL context and an
// ImGui context with the workbench's set-up are current.
int RenderView(const Options& options, const Shot& shot, gb::ui::AppState& state,
               std::vector<unsigned char>* pixels) {
  namespace ui = gb::ui;
  ui::FixedGlRenderer renderer;
  renderer.Init();
  state.view = shot.view;
  if (!options.dialog.empty() && !ui::OpenDialogByName(state, options.dialog)) {
    return Fail(kExitBadInput,
                "--dialog '" + options.dialog + "': expected one of " + ui::kDialogNames);
  }

  ImGuiIO& io = ImGui::GetIO();
  io.DisplaySize = ImVec2(static_cast<float>(options.width), static_cast<float>(options.height));
  io.DisplayFramebufferScale = ImVec2(1.0f, 1.0f);
  io.DeltaTime = kFrameTime;
  auto settle = [&] {
    for (int frame = 0; frame < kSettleFrames; ++frame) {
      io.MousePos = ImVec2(-FLT_MAX, -FLT_MAX);
      ImGui::NewFrame();
      ui::DrawWorkbench(state);
      ImGui::Render();
    }
  };
  settle();
  if (options.time) {
    // Once the plots have fitted the whole record, show only the asked-for stretch of time on
    // every time axis (the data view's and the predictions/residuals one), as a zoom would.
    for (ui::plot::LinkedRange& r : state.data_view.x_ranges) r.range = *options.time;
    state.analysis.time_x.range = *options.time;
    state.live.time_x.range = *options.time;
    state.live.follow = false;
    settle();
  }
  if (!shot.plot.empty()) return RenderPlot(options, shot, state, renderer, pixels);
  const ImVec4 bg = ImGui::GetStyle().Colors[ImGuiCol_WindowBg];
  glClearColor(bg.x, bg.y, bg.z, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT);
  renderer.Render(ImGui::GetDrawData());
  glFinish();

  std::string error;
  if (!ui::WritePngFromGl(shot.out, options.width, options.height, pixels->data(), &error)) {
    return Fail(kExitRenderFailed, error);
  }
  return 0;
}

// Prepares the workbench in the first view's ImGui context and draws every view, each after
// the first in a context of its own.
int Render(const Options& options, std::vector<unsigned char>* pixels) {
  namespace ui = gb::ui;
  ui::AppState state;
  state.shell.theme = options.theme;
  state.shell.show_sidebar = !options.hide_sidebar;
  ImGui::CreateContext();
  ui::SetUpWorkbench(state, 1.0f);
  bool fatal = false;
  int status = Prepare(options, state, &fatal);
  for (std::size_t i = 0; i < options.shots.size() && !fatal; ++i) {
    if (i > 0) {
      ImGui::DestroyContext();
      ImGui::CreateContext();
      ui::SetUpWorkbench(state, 1.0f);
    }
    const int shot_status = RenderView(options, options.shots[i], state, pixels);
    if (shot_status == kExitBadInput) fatal = true;
    if (shot_status != 0 && status != kExitBadInput) status = shot_status;
  }
  ImGui::DestroyContext();
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  const std::string arg_error = ParseArgs(argc, argv, &options);
  if (arg_error == "help") {
    std::fputs(kUsage, stdout);
    return 0;
  }
  if (!arg_error.empty()) {
    std::fputs(kUsage, stderr);
    return Fail(kExitBadInput, arg_error);
  }

  OSMesaContext gl = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
  if (!gl) return Fail(kExitRenderFailed, "cannot create an OSMesa context");
  std::vector<unsigned char> pixels(static_cast<std::size_t>(options.width) * options.height * 4);
  if (!OSMesaMakeCurrent(gl, pixels.data(), GL_UNSIGNED_BYTE, options.width, options.height)) {
    OSMesaDestroyContext(gl);
    return Fail(kExitRenderFailed, "cannot make the OSMesa context current");
  }

  const int status = Render(options, &pixels);
  OSMesaDestroyContext(gl);
  return status;
}
