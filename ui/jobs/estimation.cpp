#include "ui/jobs/estimation.h"

#include <cmath>
#include <cstdio>
#include <exception>
#include <mutex>
#include <optional>
#include <utility>

#include "core/project/problem.h"
#include "core/util/file.h"

namespace gb::ui {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

FitStage ParseStage(const std::string& stage) {
  if (stage == "delay profile") return FitStage::kDelayProfile;
  if (stage == "standard errors") return FitStage::kStandardErrors;
  return FitStage::kFitting;
}

// The "N iterations, M log-likelihood evaluations, 0.21 s" line of Report() without the time.
std::string HideElapsed(std::string report, double elapsed_s) {
  char seconds[64];
  std::snprintf(seconds, sizeof seconds, ", %.2f s\n", elapsed_s);
  const std::size_t at = report.find(seconds);
  if (at == std::string::npos) return report;
  return report.replace(at, std::string(seconds).size(),
                        std::string(", ") + kElapsedPlaceholder + "\n");
}

}  // namespace

const AlgorithmInfo& Info(estimate::Algorithm algorithm) {
  for (const AlgorithmInfo& info : kAlgorithms) {
    if (info.algorithm == algorithm) return info;
  }
  return kAlgorithms[0];
}

std::string_view StageText(FitStage stage) {
  switch (stage) {
    case FitStage::kStarting:
      return "starting";
    case FitStage::kFitting:
      return "fitting";
    case FitStage::kDelayProfile:
      return "delay profile";
    case FitStage::kStandardErrors:
      return "standard errors";
  }
  return "";
}

void Trace::Append(const TracePoint& p) {
  const double loglik = std::isfinite(p.loglik) ? p.loglik : kNaN;
  const bool profile = p.stage == FitStage::kDelayProfile;
  iteration.push_back(p.iteration);
  loglik_fit.push_back(profile ? kNaN : loglik);
  loglik_profile.push_back(profile ? loglik : kNaN);
  if (profile && std::isfinite(loglik)) has_profile = true;
}

void Trace::Clear() {
  iteration.clear();
  loglik_fit.clear();
  loglik_profile.clear();
  has_profile = false;
}

void EstimationProgress::Record(const estimate::Progress& p) {
  TracePoint point{p.iteration, p.evaluations, p.loglik, ParseStage(p.stage)};
  const std::lock_guard<std::mutex> lock(mutex_);
  latest_.any = true;
  latest_.iteration = point.iteration;
  latest_.evaluations = point.evaluations;
  latest_.stage = point.stage;
  if (point.stage != FitStage::kDelayProfile && std::isfinite(point.loglik) &&
      !(point.loglik <= latest_.best_loglik)) {
    latest_.best_loglik = point.loglik;
  }
  trace_.push_back(point);
}

EstimationProgress::Latest EstimationProgress::latest() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return latest_;
}

void EstimationProgress::AppendTrace(Trace* trace) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  for (std::size_t i = static_cast<std::size_t>(trace->size()); i < trace_.size(); ++i)
    trace->Append(trace_[i]);
}

EstimationRun RunEstimation(const EstimationInput& input, EstimationProgress& progress,
                            JobControl& control) {
  EstimationRun run;
  run.spec = input.spec;
  run.dataset_specs = input.dataset_specs;
  try {
    Result<project::Problem> problem = project::MakeProblem(input.spec, input.datasets,
                                                            input.settings.per_record_initial_states
                                                                ? project::InitialStates::kPerRecord
                                                                : project::InitialStates::kShared);
    if (!problem) {
      run.error = problem.error().ToString();
      return run;
    }
    Result<filter::Likelihood> likelihood = project::MakeLikelihood(*problem);
    if (!likelihood) {
      run.error = likelihood.error().ToString();
      return run;
    }
    estimate::EstimateOptions options;
    options.algorithm = input.settings.algorithm;
    options.multistart = input.settings.multistart;
    options.threads = input.settings.threads;
    options.profile_intervals = input.settings.profile_intervals;
    options.steady_start = input.settings.steady_start;
    options.steady_window = input.settings.steady_window;
    options.cancel = &control.cancel;
    // The best point reported so far: what a run the user stops leaves.
    std::mutex best_mutex;
    std::optional<estimate::Progress> best;
    options.progress = [&](const estimate::Progress& p) {
      progress.Record(p);
      const std::lock_guard<std::mutex> lock(best_mutex);
      if (std::isfinite(p.loglik) && !p.theta.empty() && (!best || p.loglik > best->loglik))
        best = p;
    };
    Result<estimate::EstimateSummary> summary = estimate::Estimate(*likelihood, options);
    if (!summary) {
      run.error = summary.error().ToString();
      return run;
    }
    run.summary = std::move(summary).value();
    if (run.summary->cancelled && best) {
      Result<estimate::EstimateSummary> stopped =
          estimate::StoppedSummary(*likelihood, *run.summary, *best);
      if (stopped) run.summary = std::move(stopped).value();
    }
    run.series_parameters = problem->series_parameters;
    for (const data::DatasetSpec& d : input.dataset_specs)
      run.fingerprints.push_back(FileFingerprint(d.file));
  } catch (const std::exception& e) {  // e.g. out of memory; never into the UI loop
    run.summary.reset();
    run.error = std::string("the estimation stopped: ") + e.what();
  }
  control.progress = 1.0f;
  return run;
}

bool FitMatchesModel(const FitResult& fit, const model::ModelSpec& m) {
  const estimate::EstimateSummary& s = fit.summary;
  const bool copies = !fit.series_parameters.empty();
  if (s.theta.size() != s.parameters.size() ||
      (copies ? s.parameters.size() < m.parameters.size()
              : s.parameters.size() != m.parameters.size()))
    return false;
  for (const std::vector<int>& row : fit.series_parameters)
    if (row.size() != s.parameters.size()) return false;
  for (std::size_t i = 0; i < m.parameters.size(); ++i)
    if (s.parameters[i].name != m.parameters[i].name) return false;
  if (s.delays.size() != m.outputs.size()) return false;
  for (std::size_t o = 0; o < m.outputs.size(); ++o)
    if (s.delays[o].output != m.outputs[o]) return false;
  return true;
}

FitResult MakeFitResult(estimate::EstimateSummary summary, Trace trace, EstimationSettings settings,
                        int model_revision, bool deterministic) {
  FitResult r;
  r.report = summary.Report();
  if (deterministic) r.report = HideElapsed(std::move(r.report), summary.elapsed_s);
  r.settings = settings;
  r.model_revision = model_revision;
  r.trace = std::move(trace);
  for (const estimate::DelayEstimate& d : summary.delays) {
    if (!d.scanned || d.profile.empty()) continue;
    DelayProfilePlot p;
    p.output = d.output;
    for (const estimate::DelayProfilePoint& pt : d.profile) {
      p.delay.push_back(pt.delay);
      p.loglik.push_back(pt.loglik ? *pt.loglik : kNaN);
      if (pt.loglik && !pt.converged) p.any_lower_bound = true;
      if (pt.delay == d.estimate && pt.loglik) {
        p.estimate_delay.push_back(pt.delay);
        p.estimate_loglik.push_back(*pt.loglik);
      }
    }
    r.profiles.push_back(std::move(p));
  }
  const Eigen::MatrixXd& c = summary.correlation;
  r.correlation.reserve(static_cast<std::size_t>(c.size()));
  for (Eigen::Index a = 0; a < c.rows(); ++a) {
    for (Eigen::Index b = 0; b < c.cols(); ++b) r.correlation.push_back(c(a, b));
  }
  r.summary = std::move(summary);
  return r;
}

}  // namespace gb::ui
