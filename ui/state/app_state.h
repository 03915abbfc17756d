// Everything the workbench shows and remembers, in one struct owned by main(). Panels receive
// it by reference; no panel keeps data of its own between frames.
//
//   AppState state;                    // main()
//   OpenProject(state, path);          // starts the loading job
//   every frame: DrawWorkbench(state); // polls jobs, draws menu, sidebar, current view
//   StartEstimation(state);            // the Estimate view's Run button (and the snapshot)
#pragma once

#include <array>
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <imgui.h>

#include "core/data/dataset.h"
#include "core/model/model.h"
#include "core/project/project.h"
#include "ui/edits/model_edit.h"
#include "ui/jobs/analysis.h"
#include "ui/jobs/design.h"
#include "ui/jobs/estimation.h"
#include "ui/jobs/job.h"
#include "ui/jobs/live.h"
#include "ui/jobs/sweep.h"
#include "ui/state/data_summary.h"
#include "ui/state/diagram_view.h"
#include "ui/state/shell_state.h"
#include "ui/widgets/file_browser.h"
#include "ui/widgets/plot.h"

namespace gb::ui {

// The views of user guide §6 in the order of the workflow, then the Live view (on-line
// monitoring, beyond the contract's list).
enum class View {
  kData,
  kDiagram,
  kEquations,
  kEstimate,
  kPredictions,
  kResiduals,
  kParameters,
  kOperatingPoints,
  kLive,
  kDesign,
};
// In the sidebar's and the View menu's order; the first nine have Ctrl+1..9.
inline constexpr std::array<View, 10> kAllViews = {
    View::kData,        View::kDiagram,   View::kEquations,  View::kEstimate,
    View::kPredictions, View::kResiduals, View::kParameters, View::kOperatingPoints,
    View::kLive,        View::kDesign};

std::string_view ViewName(View view);   // the command-line name: "operating-points"
std::string_view ViewTitle(View view);  // the title in the UI: "Operating points"
std::optional<View> ParseView(std::string_view name);

enum class Severity { kInfo, kWarning, kError };
// What a warning or an error is about, so that a later success settles it: the model became
// valid, the predictions or the estimate were computed after all.
enum class MessageTopic { kNone, kModel, kPredictions, kEstimation };

struct Message {
  Severity severity = Severity::kInfo;
  std::string text;
  std::string time;  // local "HH:MM:SS" when it was added ("" in a snapshot: deterministic)
  MessageTopic topic = MessageTopic::kNone;
  bool resolved = false;  // a later success of its topic settled it
};

// Fonts of the workbench (owned by ImGui's font atlas). Any may be the default font when the
// DejaVu files are missing; never null after LoadFonts().
struct Fonts {
  ImFont* regular = nullptr;
  ImFont* bold = nullptr;
  ImFont* heading = nullptr;  // view titles
  ImFont* mono = nullptr;     // equations, JSON
  float scale = 1.0f;         // DPI scale the sizes were built for
  // The node editor's text at its zoom: the regular font scaled up blurs, so the atlas gets a
  // font baked at `canvas_zoom` times the regular size (null at 1). The Diagram view asks for
  // `wanted_canvas_zoom` once a zoom has settled (CanvasZoomFor); the window rebuilds the atlas
  // when it differs from `canvas_zoom`, as it does for View › Zoom.
  ImFont* canvas = nullptr;
  float canvas_zoom = 1.0f;
  float wanted_canvas_zoom = 1.0f;
};

// The canvas font's zoom for an editor zoom: rounded up to a half, from 1 to kMaxCanvasZoom
// (text drawn at a smaller size than its font is sharp; larger, it blurs).
inline constexpr float kMaxCanvasZoom = 3.0f;
float CanvasZoomFor(float editor_zoom);

// One dataset file of the project, as read by the loading job.
struct LoadedDataset {
  std::string path;        // spec.file
  data::DatasetSpec spec;  // the project's entry: how the file is read, and its role
  std::shared_ptr<const data::Dataset> data;  // null when the file could not be read
  std::string error;                          // why `data` is null
  DatasetSummary summary;
};

// A fit of the project's: finished, or stopped by the user (summary.cancelled), kept in the Fits
// list and on disk beside the project (core/project/kept_fits.h).
struct KeptFit {
  FitResult fit;  // its model_revision is the model's when it matches the model, else -1
  Json result;    // its result file's content (what `greybench-cli compare` reads)
  Json model;     // the model it was fitted with (model::ToJson)
  // As they were fitted (for a fit read back: read from its own project when Save as rewrites it).
  std::vector<data::DatasetSpec> datasets;
  std::string file;      // its result file; "" until written (a project never saved)
  int number = 0;        // NNN of fit-NNN.json; the session's count until written
  std::string finished;  // local time it finished ("" in a snapshot)
};

// The result of the loading job.
struct ProjectLoad {
  std::string path;
  std::optional<project::Project> project;
  std::string error;  // why `project` is empty
  std::vector<LoadedDataset> datasets;
  // The project's model, parsed and validated (core/model); absent when it is not valid.
  std::optional<model::ModelSpec> model;
  std::string model_error;  // why `model` is absent
  // The project's kept fits (core/project/kept_fits.h), and the files among them that could not
  // be read, each with why.
  std::vector<KeptFit> fits;
  std::vector<std::string> fit_problems;
};

struct DataViewState {
  // One per dataset: the plots of a dataset's columns pan and zoom together in x.
  std::vector<plot::LinkedRange> x_ranges;
  // Over each output, the model's simulated response at its current values (from the analysis).
  bool show_preview = true;
};

// The estimation: options, the job under way, and the last finished fit.
struct EstimationState {
  EstimationSettings settings;  // edited in the Estimate view
  Job<EstimationRun> job;
  std::shared_ptr<EstimationProgress> progress;  // of the run under way
  Trace live_trace;  // the run under way, copied from `progress` every frame
  // The x ranges of the trace and the delay-profile plots: refitted whenever new points
  // arrive or a new result is installed (the plots follow a live run).
  plot::LinkedRange trace_x;
  std::vector<plot::LinkedRange> profile_x;  // one per FitResult::profiles
  std::chrono::steady_clock::time_point started;
  int started_revision = 0;    // AppState::model_revision when the run started
  int started_generation = 0;  // AppState::project_generation when the run started
  // The fit the views show: the last that finished (converged, not, or stopped by the user), or
  // the one the Fits list showed since; a failed run leaves it alone.
  std::optional<FitResult> result;
  // Every fit of the project, oldest first (the Fits list), and which of them `result` is (-1:
  // none of them).
  std::vector<KeptFit> fits;
  int shown = -1;
  // Write each fit beside the project file as it finishes (the window does; the snapshot renderer
  // and most tests leave the disk alone, as ShellState::session_files does).
  bool keep_on_disk = false;
  int next_number = 1;  // the session's number for a fit not written
  // The two fits of the Fits list's likelihood-ratio test (-1: not chosen), and the row its
  // buttons act on (-1: the one shown).
  int compare_a = -1, compare_b = -1;
  int selected = -1;
  // How the last run ended when it left no result: "cancelled after 1.2 s", or the error.
  std::string last_failure;
  Severity last_failure_severity = Severity::kInfo;
};

// The predictions and residual diagnostics (ui/jobs/analysis.h), computed in the background at the
// last fit's estimates (or the model's current values) and recomputed whenever the request
// changes (PollJobs); and what the Predictions and Residuals views let the user choose.
struct AnalysisState {
  Job<AnalysisRun> job;
  // Whether PollJobs computes it. The workbench always does (in the background); a snapshot
  // only when it draws a view that shows it (data, predictions, residuals), so that it does not
  // wait for filtering and smoothing every record to draw the equations or the diagram.
  bool enabled = true;
  std::optional<AnalysisRequest> running;    // the request of the job under way
  std::optional<AnalysisRequest> attempted;  // the last request started, whatever its outcome
  bool cancel_requested = false;             // by the user (not superseded by a newer request)
  // The last analysis that finished; a failed or cancelled run leaves it alone.
  std::optional<Analysis> result;
  std::string last_failure;  // how the last run ended when it left no result
  Severity last_failure_severity = Severity::kInfo;

  bool use_current_values = false;  // evaluate at the model's values even when a fit exists
  int horizon = 10;                 // h of the h-step-ahead overlay
  bool show_ahead = false;
  bool show_simulation = false;
  bool show_smoothed = false;
  // The Predictions view's Compare: every record's measured and simulated outputs side by side
  // (estimation and validation records), each titled with its fit %, instead of one record.
  bool show_compare = false;
  bool show_raw_ccf = false;  // also the CCF with the input as measured
  // The Predictions view's Step mode: the filter at one state index at a time (FilterSteps).
  bool show_step = false;
  int step = 0;               // the state index shown
  bool step_playing = false;  // advancing at step_rate samples a second
  float step_rate = 5.0f;
  double step_clock = 0.0;     // seconds played since the last step
  bool step_recentre = false;  // Step was just ticked: the time window goes to the step
  int dataset = 0;             // shown in both views
  int output = 0;              // the Residuals view's output
  int input = 0;               // the Residuals view's cross-correlation input
  // Time axes of the predictions and the residuals against time (linked with each other),
  // and the x ranges of the diagnostics plots; refitted when a new result or selection arrives.
  plot::LinkedRange time_x;
  plot::LinkedRange acf_x, pacf_x, ccf_x, periodogram_x, histogram_x, qq_x;
  void RequestFit() {
    for (plot::LinkedRange* r :
         {&time_x, &acf_x, &pacf_x, &ccf_x, &periodogram_x, &histogram_x, &qq_x})
      r->RequestFit();
  }
};

// The Live view (ui/jobs/live.h): the model watched on-line from a reference, the run under way
// in its job, and what it has produced so far.
enum class LiveReferenceKind {
  kSession,  // the last fit of this session (EstimationState::result)
  kFile,     // a result file
};
struct LiveState {
  LiveSettings settings;  // edited in the Live view (speed also while a run is under way)
  LiveReferenceKind reference = LiveReferenceKind::kSession;
  std::string reference_file;
  sim::FuelFault fault{sim::FuelFault::Kind::kTauFF, 1.5, 0.0};  // Inject's; Clear uses its ramp

  Job<LiveRunEnd> job;
  std::shared_ptr<LiveFeed> feed;  // of the run under way (null once it has ended)
  bool discard_end = false;        // the run under way was reset: its end says nothing
  int started_generation = 0;      // AppState::project_generation when it started
  bool paused = false;             // as the user last asked
  // The run shown (kept when it ends, until Reset or the next Start).
  std::optional<LiveSetup> setup;
  LiveStatus status;
  LiveSeries series;
  int acknowledged = 0;      // alarm episodes up to this number have been acknowledged
  bool synchronous = false;  // computed by RunLiveSynchronously (greybench-snapshot)
  std::string last_failure;  // why the last run could not start, or stopped

  // The plots' time axis follows the data (its last `window_s`) until the user zooms or pans.
  plot::LinkedRange time_x;
  bool follow = true;
  double window_s = 60.0;
  // Whether the model is linear, checked once per model revision.
  int checked_revision = -1;
  std::string nonlinear;  // why the model cannot be watched ("" when it can)
  // The parameters the run can track (the free ones in the dynamics or the observations, as the
  // model says; the reference may know fewer), checked with it.
  std::vector<std::string> trackable;
  FileBrowserState browser;  // for the CSV file and the result file
  int browsing = 0;          // what the browser is choosing: 1 the CSV file, 2 the result file
};

// A parameter edit the model refused, shown in the Parameters view next to the table.
struct ParameterRefusal {
  std::string parameter;
  ParameterField field = ParameterField::kValue;
  std::string text;    // what the user entered
  std::string reason;  // from core
};

struct ParametersViewState {
  std::vector<ParameterEdit> pending;  // emitted while drawing, applied after the table
  // The cell being typed into and its text (ImGui keeps the text only while the cell is
  // active; it is committed when the cell loses focus).
  std::string editing_parameter;
  ParameterField editing_field = ParameterField::kValue;
  std::string editing_text;
  bool use_estimates_requested = false;
  // Which of the last fit's distinct optima (EstimateSummary::optima) the request takes: 0 the
  // estimate, 1 the second best, ... (the Estimate view's table of optima sets it).
  std::size_t use_optimum = 0;
  std::optional<ParameterRefusal> refusal;
  std::string profile_plot;  // the parameter whose profile log-likelihood is plotted ("": none)
};

// A formula typed in the Equations view that the model has not accepted (yet): kept, with the
// reason, until the user corrects or reverts it, so nothing typed is lost.
struct FormulaDraft {
  std::string text;
  std::optional<Error> error;  // why the model refuses `text`; absent while it is valid
};

// A structure edit the model refused, shown beside the control it came from.
struct StructureRefusal {
  std::string control;  // StructureEdit::control
  std::string reason;
};

struct EquationsViewState {
  std::map<std::string, FormulaDraft> drafts;    // by JSON path ("drift.mff")
  std::vector<FormulaEdit> pending;              // emitted while drawing, applied after the view
  std::vector<StructureEdit> structure_pending;  // the same, for the structure
  std::optional<StructureRefusal> refusal;
  // Undo and redo restore whole model files (ui/state/equations_view.h).
  std::vector<Json> undo, redo;
  bool undo_requested = false, redo_requested = false;
  int history_revision = 0;  // model_revision the history belongs to
  int drafts_revision = 0;   // model_revision the drafts were last checked at
  // What is being typed into the structure's fields (ImGui keeps a text only while it is
  // active): by control ("add.state", "rename.parameter.k", "parameters.k.unit").
  std::map<std::string, std::string> typing;
  int checked_revision = -1;  // model_revision the linearity below was checked at
  bool nonlinear = false;     // the model goes through the extended Kalman filter
};

// The sliders beside the Data, Predictions and Residuals views (user guide §6a): the parameters
// shown as sliders (the project's "sliders" list) and the values they were moved to. A moved
// value is a what-if: the views show the model there, while the model's values and the fit stay
// as they are until "Use as start values" makes the moved values the model's.
struct SlidersState {
  std::vector<project::SliderSpec> shown;
  std::map<std::string, double> moved;  // parameter -> value; absent: the views' value
  bool open = false;  // the panel is shown (View > Sliders; opened with a project that has sliders)
  // A slider is being dragged: a computation under way finishes before the newest starts (one
  // cancelled on every frame of a drag would show nothing until the release).
  bool dragging = false;
  // The analysis on screen when the drag began, drawn faintly until the release.
  std::optional<Analysis> ghost;
};

// A slider's range: the project's, else the parameter's bounds, else around its value (a
// decade each way for a positive value, ± max(|value|, 1) otherwise, within a bound); a log
// scale where every value is positive and the range spans two decades or more. The range always
// holds `value`.
struct SliderScale {
  double min = 0.0, max = 1.0;
  bool log = false;
};
SliderScale SliderRange(const model::Parameter& p, double value, const project::SliderSpec& spec);

// The experiment-design view (user guide §6b): two input designs for the model at the values
// the views show, their expected standard errors side by side, and each design tried (records
// simulated with it and fitted). Seeded from the project's data when the view is first shown.
struct DesignSlot {
  design::InputDesign design;
  // The last try of this design (FitDesign) and the request key it answered.
  std::optional<DesignFitRun> tried;
};
struct DesignViewState {
  std::array<DesignSlot, 2> slots;
  bool compare = true;              // the second design is shown and evaluated
  int input = 0;                    // the input the designs drive
  std::vector<double> hold;         // every input's level while another is driven
  int records = 50;                 // records a try simulates and fits
  int seeded_generation = -1;       // project_generation the designs were seeded for
  std::optional<DesignRun> result;  // the last evaluation that finished
  Job<DesignRun> job;
  std::string running_key;  // the request of the evaluation under way
  Job<DesignFitRun> fit_job;
  int fit_slot = -1;  // the design being tried
  std::chrono::steady_clock::time_point fit_started;
  // The inputs' plot: a window on the records' start (a few of B's periods or 40 of A's bits),
  // panned and zoomed as any time plot; set when the designs are seeded.
  plot::LinkedRange time_x;
};

struct AppState {
  // The open project and its data, replaced as a whole when a loading job succeeds.
  std::optional<project::Project> project;
  std::vector<LoadedDataset> datasets;
  std::string open_error;  // the last project that could not be opened, and why
  std::string start_note;  // shown on the empty workbench (e.g. why no project was opened)
  Job<ProjectLoad> load_job;
  std::string loading_path;
  int project_generation = 0;  // counts the projects installed (a late result can tell)
  // Counts the changes of the open project's datasets (added, removed, role changed): the
  // predictions are computed again, and the project has unsaved changes.
  int datasets_revision = 0;

  // The model the views work on: parsed from the project, then edited in the Parameters view.
  std::optional<model::ModelSpec> model;
  std::string model_error;  // why `model` is absent
  int model_revision = 0;   // counts the accepted edits
  // Counts accepted edits that change what saving the project writes but not the model (e.g.
  // a block moved in the diagram). Unsaved changes: either counter moved since the last save.
  int layout_revision = 0;

  EstimationState estimation;
  SweepState sweep;  // the operating-point sweep
  AnalysisState analysis;
  LiveState live;
  SlidersState sliders;
  DesignViewState design;

  View view = View::kData;
  std::vector<Message> messages;
  bool show_messages = false;
  bool show_about = false;
  bool open_dialog_requested = false;  // opens the file browser for File > Open project
  bool quit_requested = false;         // set once the user has answered "save changes?"

  Fonts fonts;
  plot::PlotContext plots;
  DataViewState data_view;
  ParametersViewState parameters_view;
  EquationsViewState equations_view;
  DiagramViewState diagram_view;
  ShellState shell;  // files, recent projects, unsaved changes, recovery (ui/shell/shell.h)

  // greybench-snapshot: draw nothing that depends on the clock (elapsed times are shown as
  // kElapsedPlaceholder), so the same inputs give the same picture.
  bool deterministic = false;
};

void AddMessage(AppState& state, Severity severity, std::string text,
                MessageTopic topic = MessageTopic::kNone);
// Marks the warnings and errors of `topic` resolved: the status bar no longer shows them (the
// Messages window keeps them, marked so).
void ResolveMessages(AppState& state, MessageTopic topic);
// The message the status bar shows: the last, unless it was resolved or a job under way (opening,
// estimating, sweeping) has the bar; null then.
const Message* StatusMessage(const AppState& state);
// What the status bar says: the job under way, else StatusMessage's text, else "Ready".
std::string StatusText(const AppState& state);

// The sidebar's dataset edits. Each changes the project's entry and the loaded dataset together,
// counts as an unsaved change, and makes the predictions be computed again; a fit already made
// is kept (its estimates stay what the views show). Refused (false, with *why) while an
// estimation or a sweep runs, and for an index out of range.
bool SetDatasetRole(AppState& state, std::size_t index, data::Role role,
                    std::string* why = nullptr);
bool RemoveDataset(AppState& state, std::size_t index, std::string* why = nullptr);
// The dataset's `range` key (its rows with t0 <= t <= t1, in seconds; nullopt: the whole
// record): the file is read again with it (a read that fails changes nothing and says why).
bool SetDatasetRange(AppState& state, std::size_t index, std::optional<std::array<double, 2>> range,
                     std::string* why = nullptr);

// Starts reading the project and its datasets in the loading job (ignored while one runs).
void OpenProject(AppState& state, std::string path);
// Installs the results of finished jobs. DrawWorkbench calls it at the start of every frame.
void PollJobs(AppState& state);
// Blocks until every job has finished (but the live run, which has no end), then polls. For the
// snapshot renderer and tests only.
void WaitForJobs(AppState& state);

// " after 1.2 s", ", 1.2 s" for the messages of the jobs: `prefix` and the duration, or nothing
// in a snapshot (deterministic), whose messages must not depend on the machine.
std::string ElapsedClause(const AppState& state, const char* prefix, double seconds);
bool AnyJobActive(const AppState& state);

// Starts estimating the model on the project's data with state.estimation.settings. Returns
// false and says why in `why` when it cannot start (no valid model, unreadable data, a run or
// a project load under way).
bool StartEstimation(AppState& state, std::string* why = nullptr);
// Asks the run under way to stop; PollJobs then keeps the best point it had reached as a fit
// marked stopped (or the previous result, when it had reached none).
void CancelEstimation(AppState& state);

// The Fits list (ui/state/fits.cpp). A project's kept fits are read when it is opened; each
// fit that finishes joins them (and is written beside the project with keep_on_disk).
// Shows fit `index` in every view. A fit of another model (other parameters or outputs) brings
// its model back as the project's model (an edit; refused for a model drawn as a block diagram).
bool ShowFit(AppState& state, std::size_t index, std::string* why = nullptr);
// Removes the fit from the list and its two files from the disk.
bool DeleteFit(AppState& state, std::size_t index, std::string* why = nullptr);
// The likelihood-ratio test of two kept fits (in either order), or why there is none (not
// nested, other data, a stopped fit). `notes`: caveats of a test made (matched by name only).
Result<estimate::LikelihoodRatioTest> CompareFits(const AppState& state, std::size_t a,
                                                  std::size_t b, std::string* notes = nullptr);
// The shell command that fits kept fit `index` again with greybench-cli (its project file, the
// options it ran with, a new result file beside it: `greybench-cli estimate
// '/…/engine.fits/fit-001.project.json' --algorithm auto --out
// '/…/engine.fits/fit-001.again.json'`), or "" with why (a fit not written: the project was never
// saved).
std::string FitCommand(const AppState& state, std::size_t index, std::string* why = nullptr);
// Writes the fits not written yet (of a project saved for the first time, or saved as another
// file: its fits folder is another). The shell calls it after a save.
void WriteUnwrittenFits(AppState& state);
// For app_state.cpp: a finished or stopped run joins the fits (written with keep_on_disk) and is
// shown; the loading job reads the project's kept fits; InstallProject makes them the list.
void KeepFit(AppState& state, FitResult fit, const EstimationRun& run);
void ReadFits(const std::string& project_path, bool deterministic, ProjectLoad* out);
void InstallFits(AppState& state, std::vector<KeptFit> fits,
                 const std::vector<std::string>& problems);
bool EstimationRunning(const AppState& state);

// The sliders (ui/state/sliders.cpp). Showing or hiding one edits the project's "sliders" list
// (an unsaved change); moving one is a what-if the analysis is computed at.
void ShowSlider(AppState& state, const std::string& parameter, bool show);
bool SliderShown(const AppState& state, const std::string& parameter);
// The value the views use for parameter `index` without the sliders: the shown fit's estimate,
// or the model's value.
double SliderBaseValue(const AppState& state, std::size_t index);
// The value slider `index` of the model's parameters shows: moved, else SliderBaseValue.
double SliderValue(const AppState& state, std::size_t index);
void MoveSlider(AppState& state, const std::string& parameter, double value);
void BeginSliderDrag(AppState& state);  // keeps the analysis on screen as the ghost
void EndSliderDrag(AppState& state);
void ResetSliders(AppState& state);  // every moved value back to the views' own
// The moved values become the model's (start) values, in one edit, and the views show the model.
void UseSliderValuesAsStart(AppState& state);
// θ (model order) with the moved values put in.
void ApplySliders(const AppState& state, std::vector<double>* theta);
// The project's list read on opening it (parameters the model lacks are left out, with a warning).
void InstallSliders(AppState& state);

// The experiment-design view. SeedDesigns fills the designs from the project's first dataset
// (the driven input's mean and spread, its sample interval and span) and the model's time
// constants (design A a PRBS whose bit suits them, B slow steps); PollDesign, every frame while
// the view is shown, starts the evaluation when the request changed and installs what finished.
// DesignRequestNow: the request for the values the views show (nullopt without a valid model).
std::optional<DesignRequest> DesignRequestNow(const AppState& state);
void SeedDesigns(AppState& state);
void PollDesign(AppState& state);
// Tries design `slot`: simulates DesignViewState::records records and fits them, in fit_job.
// Refused (false, *why) while a try runs or without a valid linear model.
bool StartDesignFit(AppState& state, int slot, std::string* why);

// The operating-point sweep (ui/state/sweep_state.cpp), run like the estimation.
// Reads the project's "operating_points" key into state.sweep and drops the last sweep (a new
// project was installed).
void ResetSweep(AppState& state);
// Sweeps the project's own datasets with the default relations (the project names no sweep).
void SweepProjectDatasets(AppState& state);
// Starts fitting the model to every dataset of state.sweep.spec. Returns false and says why
// when it cannot start (no sweep named, the key is wrong, no valid model, a run under way).
bool StartSweep(AppState& state, std::string* why = nullptr);
// Asks the sweep under way to stop; PollJobs then reports it and keeps the previous table.
void CancelSweep(AppState& state);
bool SweepRunning(const AppState& state);
// Installs a finished sweep (PollJobs calls it every frame).
void PollSweep(AppState& state);
// The trend plot's parameter and tag (the Operating points view's choice).
void SelectTrend(AppState& state, const std::string& parameter, const std::string& tag);
// The analysis (ui/state/analysis_state.cpp). PollJobs installs a finished run and starts a new one
// when the request it would make differs from the last one started; CancelAnalysis stops the
// run under way (the previous result is kept and the same request is not retried until
// RecomputeAnalysis). AnalysisRequestNow is that request, or nothing when there is nothing to
// analyse (no project, no valid model), with why.
std::optional<AnalysisRequest> AnalysisRequestNow(const AppState& state,
                                                  std::string* why = nullptr);
void PollAnalysis(AppState& state);
// The predictions' and residuals' time axis opens on the first kInitialTimeWindow samples of the
// dataset shown, where single samples can be told apart (as in the paper's Fig. 6; a whole PRBS
// record reads as a solid band); a double-click on a time plot fits the whole record. Records
// that short are shown whole.
inline constexpr int kInitialTimeWindow = 240;
void OpenTimeWindow(AnalysisState& a);
void CancelAnalysis(AppState& state);
void RecomputeAnalysis(AppState& state);
bool AnalysisRunning(const AppState& state);

// The Live view (ui/state/live_state.cpp). The run is a stream without end: WaitForJobs does not
// wait for it (AnyJobActive counts it unless it is paused, so the window keeps drawing while it
// runs).
// Why the model cannot be watched on-line ("" when it can: a valid, linear model); cached.
const std::string& LiveModelProblem(AppState& state);
// The parameters the Live view offers to track (LiveState::trackable, kept current).
const std::vector<std::string>& LiveTrackable(AppState& state);
// The run that Start would begin now, or nothing with why (no reference, no CSV file, ...).
std::optional<LiveInput> LiveInputNow(const AppState& state, std::string* why = nullptr);
// How the reference Start would use is named, or "" when there is none.
std::string LiveReferenceText(const AppState& state);
bool StartLive(AppState& state, std::string* why = nullptr);
bool LiveRunning(const AppState& state);
void PauseLive(AppState& state, bool pause);
void SetLiveSpeed(AppState& state, LiveSpeed speed);
void InjectLiveFault(AppState& state);  // state.live.fault, at the dyno's next sample
void ClearLiveFaults(AppState& state);  // over state.live.fault.ramp_s
void AcknowledgeLiveAlarm(AppState& state);
// Stops the run under way (without waiting for it) and clears what the view shows.
void ResetLive(AppState& state);
// Takes the job's updates, status and notes (PollJobs calls it every frame).
void PollLive(AppState& state);
// greybench-snapshot: runs the dyno and the monitor to `until_s` on this thread, with the fault
// schedule `faults` (time order), and installs the result as a run's. False, with why, when it
// cannot (as StartLive, or the run failed).
bool RunLiveSynchronously(AppState& state, double until_s, std::vector<sim::TimedFuelFault> faults,
                          std::string* why = nullptr);

// Applies state.parameters_view.pending (and a requested "use estimates as start values") to
// state.model through core's validation; a refused edit is kept in parameters_view.refusal.
void ApplyParameterEdits(AppState& state);

// Applies state.equations_view.pending to state.model through core's validation (and to the
// project's copy of the model JSON); a refused edit stays a draft with its reason.
void ApplyFormulaEdits(AppState& state);

}  // namespace gb::ui
