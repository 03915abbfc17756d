// AppState's live run: what it starts from (the model, the reference, the source), starting,
// steering and stopping the live job, and taking what it produces every frame (declared in
// ui/state/app_state.h beside the estimation's counterparts).
#include <algorithm>
#include <utility>

#include "core/model/linear_model.h"
#include "core/model/nonlinear_model.h"
#include "core/online/augmented.h"
#include "core/online/recursive.h"
#include "ui/format.h"
#include "ui/state/app_state.h"

namespace gb::ui {
namespace {

// The session's fit as a reference for `spec`: only when it was fitted to a model with the same
// parameters (an edited formula may have renamed or added some since), and finished (a fit the
// user stopped has no covariance to watch the parameters against).
bool SessionFitFits(const FitResult& fit, const model::ModelSpec& spec) {
  const estimate::EstimateSummary& s = fit.summary;
  if (s.cancelled) return false;
  if (s.parameters.size() != spec.parameters.size() || s.theta.size() != spec.parameters.size())
    return false;
  for (std::size_t i = 0; i < s.parameters.size(); ++i) {
    if (s.parameters[i].name != spec.parameters[i].name) return false;
  }
  return std::all_of(s.correlation_names.begin(), s.correlation_names.end(),
                     [&](const std::string& n) { return spec.ParameterIndex(n) >= 0; });
}

bool UsesSessionFit(const AppState& state) {
  return state.live.reference == LiveReferenceKind::kSession && state.estimation.result &&
         state.model && SessionFitFits(*state.estimation.result, *state.model);
}

void InstallFeed(AppState& state) {
  LiveState& l = state.live;
  if (!l.setup) l.setup = l.feed->setup();
  l.feed->AppendTo(&l.series, &l.status);
  for (LiveNote& n : l.feed->TakeNotes())
    AddMessage(state, n.error ? Severity::kError : Severity::kInfo, std::move(n.text));
}

void Send(AppState& state, LiveCommand::Kind kind) {
  LiveCommand c;
  c.kind = kind;
  c.speed = state.live.settings.speed;
  c.fault = state.live.fault;
  if (state.live.feed) state.live.feed->Send(c);
}

// Clears what the view shows of the last run (not the settings).
void ClearShown(LiveState& l) {
  l.setup.reset();
  l.status = LiveStatus{};
  l.series.Clear();
  l.acknowledged = 0;
  l.synchronous = false;
  l.last_failure.clear();
  l.follow = true;
  l.paused = false;
  l.time_x.RequestFit();
}

}  // namespace

const std::string& LiveModelProblem(AppState& state) {
  LiveState& l = state.live;
  if (l.checked_revision == state.model_revision) return l.nonlinear;
  l.checked_revision = state.model_revision;
  l.nonlinear.clear();
  l.trackable.clear();
  if (!state.model) return l.nonlinear;  // the view says the model is not valid
  // A linear model gets the recursive estimator; any other the augmented EKF (monitor.h). Only a
  // model that compiles as neither cannot be watched.
  std::vector<int> free;
  for (int i = 0; i < static_cast<int>(state.model->parameters.size()); ++i)
    if (!state.model->parameters[i].fixed) free.push_back(i);
  std::vector<int> trackable;
  if (Result<model::LinearModel> linear = model::LinearModel::Compile(*state.model)) {
    trackable = online::TrackableParameters(*linear, free);
  } else if (Result<model::NonlinearModel> nonlinear =
                 model::NonlinearModel::Compile(*state.model)) {
    trackable = online::TrackableParameters(*nonlinear, free);
  } else {
    l.nonlinear = nonlinear.error().ToString();
  }
  for (int i : trackable) l.trackable.push_back(state.model->parameters[i].name);
  // A choice the model no longer offers is dropped.
  std::erase_if(l.settings.track, [&](const std::string& name) {
    return std::find(l.trackable.begin(), l.trackable.end(), name) == l.trackable.end();
  });
  return l.nonlinear;
}

const std::vector<std::string>& LiveTrackable(AppState& state) {
  LiveModelProblem(state);
  return state.live.trackable;
}

std::string LiveReferenceText(const AppState& state) {
  if (UsesSessionFit(state)) {
    const FitResult& fit = *state.estimation.result;
    std::string text = "this session's estimate (log L " + FormatFixed(fit.summary.loglik, 2) + ")";
    if (fit.model_revision != state.model_revision) text += "; the parameters were edited since";
    return text;
  }
  if (!state.live.reference_file.empty()) return "result file " + state.live.reference_file;
  return "";
}

std::optional<LiveInput> LiveInputNow(const AppState& state, std::string* why) {
  auto refuse = [why](std::string reason) -> std::optional<LiveInput> {
    if (why) *why = std::move(reason);
    return std::nullopt;
  };
  const LiveState& l = state.live;
  if (!state.project) return refuse("no project is open");
  if (!state.model) return refuse("the model is not valid: " + state.model_error);
  if (!l.nonlinear.empty() && l.checked_revision == state.model_revision)
    return refuse("the model cannot be compiled: " + l.nonlinear);
  LiveInput input;
  input.spec = *state.model;
  input.settings = l.settings;
  input.reference_text = LiveReferenceText(state);
  if (UsesSessionFit(state)) {
    input.reference = online::ReferenceFromSummary(state.estimation.result->summary, *state.model,
                                                   "this session's estimate");
  } else if (!l.reference_file.empty()) {
    input.reference_file = l.reference_file;
  } else if (state.estimation.result && l.reference == LiveReferenceKind::kFile) {
    return refuse("choose a result file, or start from this session's estimate");
  } else {
    return refuse("there is no reference: run an estimate first, or open a result file");
  }
  if (l.settings.source == LiveSourceKind::kCsvFile && l.settings.csv_path.empty())
    return refuse("choose the CSV file to follow");
  return input;
}

bool StartLive(AppState& state, std::string* why) {
  LiveState& l = state.live;
  if (l.job.active()) {
    if (why) *why = "a live run is under way";
    return false;
  }
  LiveModelProblem(state);
  std::optional<LiveInput> input = LiveInputNow(state, why);
  if (!input) return false;
  ClearShown(l);
  l.feed = std::make_shared<LiveFeed>();
  l.discard_end = false;
  l.started_generation = state.project_generation;
  l.job.Start([input = std::move(*input), feed = l.feed](JobControl& control) {
    return RunLive(input, *feed, control);
  });
  return true;
}

bool LiveRunning(const AppState& state) {
  return state.live.job.active() && !state.live.discard_end;
}

void PauseLive(AppState& state, bool pause) {
  state.live.paused = pause;
  Send(state, pause ? LiveCommand::Kind::kPause : LiveCommand::Kind::kResume);
}

void SetLiveSpeed(AppState& state, LiveSpeed speed) {
  state.live.settings.speed = speed;
  Send(state, LiveCommand::Kind::kSpeed);
}

void InjectLiveFault(AppState& state) { Send(state, LiveCommand::Kind::kInject); }

void ClearLiveFaults(AppState& state) { Send(state, LiveCommand::Kind::kClearFaults); }

void AcknowledgeLiveAlarm(AppState& state) {
  LiveState& l = state.live;
  if (!l.series.alarms.empty()) l.acknowledged = l.series.alarms.back().episode;
  Send(state, LiveCommand::Kind::kAcknowledge);
}

void ResetLive(AppState& state) {
  LiveState& l = state.live;
  if (l.job.active()) {
    l.job.RequestCancel();
    l.discard_end = true;
  }
  l.feed.reset();
  ClearShown(l);
}

void PollLive(AppState& state) {
  LiveState& l = state.live;
  std::optional<LiveRunEnd> end = l.job.TakeIfReady();
  if (l.feed) InstallFeed(state);
  if (!end) return;
  const bool discard = l.discard_end || l.started_generation != state.project_generation;
  l.discard_end = false;
  l.feed.reset();
  l.status.running = false;
  l.paused = false;
  if (discard || end->error.empty()) return;
  l.last_failure = end->error;
  AddMessage(state, Severity::kError, "The live run stopped: " + end->error);
}

bool RunLiveSynchronously(AppState& state, double until_s, std::vector<sim::TimedFuelFault> faults,
                          std::string* why) {
  LiveState& l = state.live;
  ResetLive(state);
  LiveModelProblem(state);
  std::optional<LiveInput> input = LiveInputNow(state, why);
  if (!input) return false;
  input->faults = std::move(faults);
  l.feed = std::make_shared<LiveFeed>();
  const Status st = RunLiveUntil(*input, until_s, *l.feed);
  InstallFeed(state);
  l.feed.reset();
  l.synchronous = true;
  if (!st) {
    l.last_failure = st.error().ToString();
    if (why) *why = l.last_failure;
    return false;
  }
  return true;
}

}  // namespace gb::ui
