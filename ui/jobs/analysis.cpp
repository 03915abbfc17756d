#include "ui/jobs/analysis.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <numbers>
#include <utility>

#include "core/filter/ekf_predict.h"
#include "core/filter/initial_state.h"
#include "core/filter/likelihood.h"
#include "core/filter/predict.h"
#include "core/model/linear_model.h"
#include "core/model/nonlinear_model.h"
#include "core/sim/response.h"
#include "core/sim/sde.h"

namespace gb::ui {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kBandSd = 2.0;            // the prediction bands are ± 2 sd
constexpr int kDensityPoints = 201;        // samples of the N(0, 1) density curve
constexpr double kDensityHalfWidth = 4.0;  // the curve spans at least [-4, 4]

std::vector<double> Row(const Eigen::MatrixXd& m, Eigen::Index r) {
  return std::vector<double>(m.row(r).begin(), m.row(r).end());
}

CorrelogramPlot MakeCorrelogramPlot(const diagnose::Correlogram& c) {
  CorrelogramPlot p;
  p.lag.assign(c.lag.begin(), c.lag.end());
  p.value = c.value;
  p.band = c.band;
  if (!p.lag.empty()) {
    p.band_x = {p.lag.front(), p.lag.back()};
    p.band_lo = {-c.band, -c.band};
    p.band_hi = {c.band, c.band};
  }
  return p;
}

DiagnosticsPlot MakeDiagnosticsPlot(diagnose::ResidualDiagnostics d) {
  DiagnosticsPlot p;
  p.acf = MakeCorrelogramPlot(d.acf);
  p.pacf = MakeCorrelogramPlot(d.pacf);
  for (const diagnose::CrossCorrelogram& c : d.ccf) {
    p.ccf.push_back(MakeCorrelogramPlot(c.ccf));
    p.ccf_prewhitened.push_back(MakeCorrelogramPlot(c.ccf_prewhitened));
  }

  const diagnose::CumulatedPeriodogram& cp = d.periodogram;
  for (double w : cp.white) {
    p.white_lo.push_back(w - cp.band);
    p.white_hi.push_back(w + cp.band);
  }

  // Counts to a density, so the N(0, 1) curve compares whatever the bin width.
  const diagnose::Normality& nm = d.normality;
  const std::size_t bins = nm.histogram_counts.size();
  if (bins > 0 && nm.n > 0) {
    for (std::size_t i = 0; i <= bins; ++i) {
      const double e = nm.histogram_edges[i];
      const double width = i < bins ? nm.histogram_edges[i + 1] - e : 0.0;
      const double left = i > 0 ? p.hist_density.back() : 0.0;
      const double right = i < bins && width > 0.0 ? nm.histogram_counts[i] / (nm.n * width) : 0.0;
      p.hist_x.insert(p.hist_x.end(), {e, e});
      p.hist_density.insert(p.hist_density.end(), {left, right});
    }
    p.hist_zero.assign(p.hist_x.size(), 0.0);
    const double lo = std::min(nm.histogram_edges.front(), -kDensityHalfWidth);
    const double hi = std::max(nm.histogram_edges.back(), kDensityHalfWidth);
    for (int i = 0; i < kDensityPoints; ++i) {
      const double x = lo + (hi - lo) * i / (kDensityPoints - 1);
      p.normal_x.push_back(x);
      p.normal_density.push_back(std::exp(-0.5 * x * x) / std::sqrt(2.0 * std::numbers::pi));
    }
  }
  if (!nm.qq_theoretical.empty()) {
    const double lo = std::min(nm.qq_theoretical.front(), nm.qq_sample.front());
    const double hi = std::max(nm.qq_theoretical.back(), nm.qq_sample.back());
    p.qq_line = {lo, hi};
  }
  p.stats = std::move(d);
  return p;
}

// The delay per output: the request's, else the model's fixed delay or the best of a scanned
// range at θ over every series.
Result<std::vector<int>> ChooseDelays(const AnalysisRequest& request, const model::ModelSpec& m,
                                      const filter::Likelihood& likelihood, std::string* source) {
  const std::size_t p = m.outputs.size();
  if (!request.delay.empty()) {
    if (request.delay.size() != p)
      return InputError("the fit has " + std::to_string(request.delay.size()) +
                        " output delays but the model has " + std::to_string(p) + " outputs");
    *source = "fit";
    return request.delay;
  }
  std::vector<int> delay(p);
  for (std::size_t o = 0; o < p; ++o) delay[o] = m.output_delay[o].min;
  *source = "model";
  if (!m.HasDelayScan()) return delay;
  Result<filter::DelayProfile> profile = likelihood.Profile(request.theta);
  if (!profile) return profile.error();
  if (profile->best < 0) return NumericalError(profile->candidates.front().message);
  *source = "profile likelihood at these values";
  return profile->candidates[static_cast<std::size_t>(profile->best)].delay;
}

// The model at one θ: a linear model's state space, or a nonlinear model with θ (the EKF).
struct ModelAt {
  std::optional<model::StateSpace> ss;
  const model::NonlinearModel* nonlinear = nullptr;
  std::vector<double> theta;

  Result<sim::Simulation> Simulate(const data::Series& series,
                                   const filter::FilterSettings& settings) const {
    if (ss) return sim::DeterministicResponse(*ss, series, settings);
    return sim::DeterministicResponse(*nonlinear, theta, series, settings);
  }
};

// A linear model evaluated at θ, or a nonlinear one with θ kept.
Result<ModelAt> At(const std::shared_ptr<const model::LinearModel>& lm,
                   const model::NonlinearModel* nonlinear, const std::vector<double>& theta) {
  ModelAt at;
  at.theta = theta;
  if (lm) {
    Result<model::StateSpace> ss = lm->Evaluate(theta);
    if (!ss) return ss.error();
    at.ss = std::move(ss).value();
  } else {
    at.nonlinear = nonlinear;
  }
  return at;
}

// The model at the preview's values: none (no preview), the analysis' own (the values are θ),
// or its own.
struct Preview {
  bool same_as_theta = false;
  std::optional<ModelAt> model;
};

// The simulation's RMS error and fit % over the rows the likelihood uses (a finite standardised
// residual), leaving out the first `skip` rows; NaN with fewer than 2 rows or a constant y.
void SimulationFigures(const OutputAnalysis& o, int skip, OutputAnalysis* out) {
  double sum_y = 0;
  int n = 0;
  for (std::size_t k = static_cast<std::size_t>(std::max(skip, 0)); k < o.measured.size(); ++k) {
    if (!std::isfinite(o.standardized[k]) || !std::isfinite(o.simulated[k])) continue;
    sum_y += o.measured[k];
    ++n;
  }
  out->n_simulated = n;
  out->simulation_rms = out->fit_percent = kNaN;
  if (n < 2) return;
  const double mean = sum_y / n;
  double error = 0, spread = 0;
  for (std::size_t k = static_cast<std::size_t>(std::max(skip, 0)); k < o.measured.size(); ++k) {
    if (!std::isfinite(o.standardized[k]) || !std::isfinite(o.simulated[k])) continue;
    error += (o.measured[k] - o.simulated[k]) * (o.measured[k] - o.simulated[k]);
    spread += (o.measured[k] - mean) * (o.measured[k] - mean);
  }
  out->simulation_rms = std::sqrt(error / n);
  if (spread > 0) out->fit_percent = 100 * (1 - std::sqrt(error / spread));
}

// The filter's steps from its trace (FilterSteps): the prior and posterior states, their sd, the
// gains of the outputs each state index's update used (those whose standardised residual at row
// j + d_o is finite), and the output at the posterior.
FilterSteps MakeSteps(const ModelAt& at, const data::Series& series,
                      const filter::FilterTrace& trace, const std::vector<int>& delay,
                      const Eigen::MatrixXd& standardized, const std::vector<std::string>& states) {
  FilterSteps st;
  st.states = states;
  const int n = static_cast<int>(trace.x_pred.rows());
  const int N = static_cast<int>(trace.x_pred.cols());
  const int p = static_cast<int>(standardized.rows());
  st.x_prior = trace.x_pred;
  st.x_post = trace.x_filt;
  st.sd_prior.resize(n, N);
  st.sd_post.resize(n, N);
  st.gain = Eigen::MatrixXd::Constant(static_cast<Eigen::Index>(n) * p, N, kNaN);
  st.y_post = Eigen::MatrixXd::Constant(p, N, kNaN);
  std::vector<double> slots, out;
  if (at.nonlinear) {
    slots.assign(static_cast<std::size_t>(at.nonlinear->n_slots()), 0.0);
    std::copy(at.theta.begin(), at.theta.end(), slots.begin() + at.nonlinear->parameter_slot());
    out.resize(static_cast<std::size_t>(p + p * n + p));
  }
  const int m = static_cast<int>(series.U.rows());
  // H (p x n), h and S at state x and row j.
  auto measure = [&](const Eigen::VectorXd& x, int j, Eigen::MatrixXd* H, Eigen::VectorXd* h,
                     Eigen::VectorXd* S) {
    if (at.ss) {
      *H = at.ss->C;
      *h = at.ss->C * x + at.ss->d;
      if (m > 0) *h += at.ss->D * series.U.col(j);
      *S = at.ss->S;
      return true;
    }
    for (int i = 0; i < n; ++i) slots[static_cast<std::size_t>(i)] = x(i);
    for (int i = 0; i < m; ++i) slots[static_cast<std::size_t>(n + i)] = series.U(i, j);
    slots[static_cast<std::size_t>(at.nonlinear->time_slot())] =
        series.time[static_cast<std::size_t>(j)];
    at.nonlinear->Measurement(slots, out);
    *h = Eigen::Map<const Eigen::VectorXd>(out.data(), p);
    *H = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
        out.data() + p, p, n);
    *S = Eigen::Map<const Eigen::VectorXd>(out.data() + p + p * n, p);
    return h->allFinite() && H->allFinite() && S->allFinite();
  };
  Eigen::MatrixXd H;
  Eigen::VectorXd h, S;
  for (int j = 0; j < N; ++j) {
    const auto& Pp = trace.P_pred[static_cast<std::size_t>(j)];
    const auto& Pf = trace.P_filt[static_cast<std::size_t>(j)];
    for (int i = 0; i < n; ++i) {
      st.sd_prior(i, j) = std::sqrt(std::max(Pp(i, i), 0.0));
      st.sd_post(i, j) = std::sqrt(std::max(Pf(i, i), 0.0));
    }
    std::vector<int> seen;  // the outputs the update at j used
    for (int o = 0; o < p; ++o) {
      const int k = j + delay[static_cast<std::size_t>(o)];
      if (k < N && std::isfinite(standardized(o, k))) seen.push_back(o);
    }
    if (seen.empty()) continue;
    if (!measure(trace.x_pred.col(j), j, &H, &h, &S)) {
      st.error = "the measurement equation is not finite at the prediction of row " +
                 std::to_string(j + 1);
      continue;
    }
    const int q = static_cast<int>(seen.size());
    Eigen::MatrixXd Ho(q, n);
    Eigen::MatrixXd So = Eigen::MatrixXd::Zero(q, q);
    for (int a = 0; a < q; ++a) {
      Ho.row(a) = H.row(seen[static_cast<std::size_t>(a)]);
      So(a, a) = S(seen[static_cast<std::size_t>(a)]);
    }
    So += Ho * Pp * Ho.transpose();
    const Eigen::MatrixXd K = So.ldlt().solve(Ho * Pp).transpose();  // n x q
    for (int a = 0; a < q; ++a)
      for (int i = 0; i < n; ++i)
        st.gain(static_cast<Eigen::Index>(i) * p + seen[static_cast<std::size_t>(a)], j) = K(i, a);
    if (measure(trace.x_filt.col(j), j, &H, &h, &S)) {
      for (const int o : seen) st.y_post(o, j + delay[static_cast<std::size_t>(o)]) = h(o);
    }
  }
  return st;
}

// One dataset at θ. Returns false when cancelled.
bool AnalyseSeries(const ModelAt& at, const Preview& preview, const data::Series& series,
                   const filter::FilterSettings& settings, const Analysis& a, DatasetAnalysis* out,
                   JobControl& control) {
  Result<filter::OneStepPredictions> pred = InputError("");
  Result<filter::HorizonPredictions> ahead = InputError("");
  Result<filter::SmoothedStates> smoothed = InputError("");
  filter::FilterTrace trace;
  const Result<filter::Loglik> l =
      at.ss ? filter::RunFilter(*at.ss, series, settings, &trace)
            : filter::EkfRunFilter(*at.nonlinear, at.theta, series, settings, &trace);
  if (control.cancel) return false;
  if (l) {
    pred = filter::OneStepFromTrace(series, settings, trace, *l);
    const bool with_ahead = a.request.horizon >= 1;
    if (at.ss) {
      if (with_ahead)
        ahead = filter::PredictAheadFromTrace(*at.ss, series, settings, trace, a.request.horizon);
      smoothed = filter::SmoothFromTrace(*at.ss, series, settings, trace);
    } else {
      if (with_ahead)
        ahead = filter::EkfPredictAhead(*at.nonlinear, at.theta, series, settings, trace,
                                        a.request.horizon);
      if (control.cancel) return false;
      smoothed = filter::EkfSmooth(*at.nonlinear, at.theta, series, settings, trace);
    }
  } else {
    pred = l.error();
  }
  if (control.cancel) return false;
  if (!pred) {
    out->error = pred.error().ToString();
    return true;
  }
  out->loglik = pred->loglik.loglik;
  out->n_obs = pred->loglik.n_obs;
  if (a.request.steps)
    out->steps = MakeSteps(at, series, trace, a.delay, pred->standardized, a.states);
  Result<sim::Simulation> simulated = at.Simulate(series, settings);
  std::optional<Result<sim::Simulation>> previewed;
  if (preview.model) previewed = preview.model->Simulate(series, settings);
  if (control.cancel) return false;

  std::vector<std::vector<double>> input_values;
  for (Eigen::Index i = 0; i < series.U.rows(); ++i) input_values.push_back(Row(series.U, i));
  std::vector<diagnose::InputSeries> inputs;
  for (std::size_t i = 0; i < input_values.size(); ++i)
    inputs.push_back({a.inputs[i], input_values[i]});

  const Eigen::Index n = static_cast<Eigen::Index>(series.size());
  for (std::size_t o = 0; o < a.outputs.size(); ++o) {
    const auto r = static_cast<Eigen::Index>(o);
    OutputAnalysis oa;
    oa.name = a.outputs[o];
    oa.delay = a.delay[o];
    oa.measured = Row(series.Y, r);
    oa.predicted = Row(pred->y_pred, r);
    oa.residual = Row(pred->residual, r);
    oa.standardized = Row(pred->standardized, r);
    oa.lower.resize(oa.predicted.size());
    oa.upper.resize(oa.predicted.size());
    oa.residual_lower.resize(oa.predicted.size());
    oa.residual_upper.resize(oa.predicted.size());
    double sum_sq = 0.0;
    for (Eigen::Index k = 0; k < n; ++k) {
      const auto i = static_cast<std::size_t>(k);
      const double half = kBandSd * pred->y_sd(r, k);
      oa.lower[i] = oa.predicted[i] - half;
      oa.upper[i] = oa.predicted[i] + half;
      oa.residual_lower[i] = -half;
      oa.residual_upper[i] = half;
      if (std::isfinite(oa.standardized[i])) {
        ++oa.n_observed;
        sum_sq += oa.residual[i] * oa.residual[i];
      }
    }
    oa.rms = oa.n_observed > 0 ? std::sqrt(sum_sq / oa.n_observed) : kNaN;
    if (ahead) {
      oa.ahead = Row(ahead->y_pred, r);
    } else {
      oa.ahead_error = ahead.error().ToString();
    }
    if (smoothed) {
      oa.smoothed = Row(smoothed->y, r);
      oa.smoothed_lower.resize(oa.smoothed.size());
      oa.smoothed_upper.resize(oa.smoothed.size());
      for (Eigen::Index k = 0; k < n; ++k) {
        const auto i = static_cast<std::size_t>(k);
        const double half = kBandSd * smoothed->y_sd(r, k);
        oa.smoothed_lower[i] = oa.smoothed[i] - half;
        oa.smoothed_upper[i] = oa.smoothed[i] + half;
      }
    } else {
      oa.smoothed_error = smoothed.error().ToString();
    }
    if (simulated) {
      oa.simulated = Row(simulated->Y, r);
      SimulationFigures(oa, out->initial_samples, &oa);
    }
    if (preview.same_as_theta) {
      oa.preview = oa.simulated;
    } else if (previewed && previewed->ok()) {
      oa.preview = Row((*previewed)->Y, r);
    }

    Result<diagnose::ResidualDiagnostics> d = diagnose::Diagnose(oa.standardized, inputs);
    if (d) {
      oa.diagnostics = MakeDiagnosticsPlot(std::move(d).value());
    } else {
      oa.diagnose_error = d.error().message;
    }
    out->outputs.push_back(std::move(oa));
    if (control.cancel) return false;
  }
  return true;
}

AnalysisRun Analyse(const AnalysisInput& input, JobControl& control) {
  AnalysisRun run;
  if (control.cancel) {  // superseded before it began
    run.cancelled = true;
    return run;
  }
  const AnalysisRequest& request = input.request;
  if (request.theta.size() != input.spec.parameters.size()) {
    run.error = "the parameter values do not match the model (" +
                std::to_string(request.theta.size()) + " values for " +
                std::to_string(input.spec.parameters.size()) + " parameters)";
    return run;
  }
  // A linear model runs the exact Kalman filter; any other the extended one.
  std::shared_ptr<const model::LinearModel> lm;
  std::shared_ptr<const model::NonlinearModel> nm;
  if (Result<model::LinearModel> compiled = model::LinearModel::Compile(input.spec)) {
    lm = std::make_shared<const model::LinearModel>(std::move(compiled).value());
  } else {
    Result<model::NonlinearModel> nonlinear = model::NonlinearModel::Compile(input.spec);
    if (!nonlinear) {
      run.error = nonlinear.error().ToString();
      return run;
    }
    nm = std::make_shared<const model::NonlinearModel>(std::move(nonlinear).value());
  }
  const model::ModelSpec& m = lm ? lm->spec() : nm->spec();

  Analysis a;
  a.request = request;
  for (const model::Parameter& p : m.parameters) a.parameter_names.push_back(p.name);
  a.inputs = m.inputs;
  a.outputs = m.outputs;
  a.states = m.states;

  // Bind every readable dataset; one that does not fit the model keeps its error.
  std::vector<std::shared_ptr<const data::Series>> bound;
  std::vector<int> bound_index;  // the dataset of each bound series
  for (std::size_t i = 0; i < input.datasets.size(); ++i) {
    DatasetAnalysis d;
    d.name = i < input.names.size() ? input.names[i] : "";
    d.validation = i < input.validation.size() && input.validation[i];
    if (!input.datasets[i]) {
      d.error = i < input.read_errors.size() ? input.read_errors[i] : "it could not be read";
    } else {
      d.time_name = input.datasets[i]->time_name;
      Result<std::shared_ptr<const data::Series>> s =
          data::Bind(*input.datasets[i], m.inputs, m.outputs);
      if (s) {
        bound.push_back(*s);
        bound_index.push_back(static_cast<int>(i));
      } else {
        d.error = s.error().ToString();
      }
    }
    a.datasets.push_back(std::move(d));
  }
  if (bound.empty()) {
    run.error = a.datasets.empty() ? "the project lists no datasets"
                                   : "no dataset can be used: " + a.datasets.front().error;
    return run;
  }

  Result<filter::Likelihood> likelihood =
      lm ? filter::Likelihood::Create(lm, bound) : filter::Likelihood::Create(nm, bound);
  if (!likelihood) {
    run.error = likelihood.error().ToString();
    return run;
  }
  likelihood->set_cancel(&control.cancel);
  Result<ModelAt> at = At(lm, nm.get(), request.theta);
  if (!at) {
    run.error = at.error().ToString();
    return run;
  }
  Preview preview;
  if (request.preview_theta == request.theta) {
    preview.same_as_theta = true;
  } else if (request.preview_theta.size() == request.theta.size()) {
    Result<ModelAt> p = At(lm, nm.get(), request.preview_theta);
    if (p) {
      preview.model = std::move(p).value();
    } else {
      a.preview_error = p.error().ToString();
    }
  }
  // A scanned delay is chosen on the records that are fitted, not on the validation records
  // (all of them when every record is a validation record).
  std::vector<std::shared_ptr<const data::Series>> fitted;
  for (std::size_t b = 0; b < bound.size(); ++b)
    if (!a.datasets[static_cast<std::size_t>(bound_index[b])].validation)
      fitted.push_back(bound[b]);
  std::optional<Result<filter::Likelihood>> fitted_likelihood;
  if (!fitted.empty() && fitted.size() < bound.size() && request.delay.empty() &&
      m.HasDelayScan()) {
    fitted_likelihood =
        lm ? filter::Likelihood::Create(lm, fitted) : filter::Likelihood::Create(nm, fitted);
    if (!*fitted_likelihood) {
      run.error = fitted_likelihood->error().ToString();
      return run;
    }
    (**fitted_likelihood).set_cancel(&control.cancel);
  }
  Result<std::vector<int>> delay = ChooseDelays(
      request, m, fitted_likelihood ? **fitted_likelihood : *likelihood, &a.delay_source);
  if (control.cancel) {
    run.cancelled = true;
    return run;
  }
  if (!delay) {
    run.error = delay.error().ToString();
    return run;
  }
  a.delay = std::move(delay).value();

  // The likelihood's settings: each output's first observation is its largest delay, so the
  // residuals are those the fit scored. A fit's delay above today's range moves it up.
  filter::FilterSettings settings = likelihood->settings();
  settings.delay = a.delay;
  settings.first_obs =
      filter::EffectiveFirstObservation(settings, static_cast<int>(m.outputs.size()));
  for (std::size_t o = 0; o < a.delay.size(); ++o)
    settings.first_obs[o] = std::max(settings.first_obs[o], a.delay[o]);
  settings.cancel = &control.cancel;

  // Each fitted record's place among the estimation datasets (its own θ in a fit per record).
  std::vector<int> record(input.datasets.size(), -1);
  for (std::size_t i = 0, k = 0; i < input.datasets.size(); ++i)
    if (!a.datasets[i].validation) record[i] = static_cast<int>(k++);
  for (std::size_t b = 0; b < bound.size(); ++b) {
    control.progress = static_cast<float>(b) / static_cast<float>(bound.size());
    const data::Series& series = *bound[b];
    DatasetAnalysis& d = a.datasets[static_cast<std::size_t>(bound_index[b])];
    const int k = record[static_cast<std::size_t>(bound_index[b])];
    std::optional<ModelAt> own_at;  // a fitted record's own initial state
    if (k >= 0 && k < static_cast<int>(request.record_theta.size()) &&
        request.record_theta[static_cast<std::size_t>(k)] != request.theta) {
      Result<ModelAt> at_k = At(lm, nm.get(), request.record_theta[static_cast<std::size_t>(k)]);
      if (!at_k) {
        d.error = at_k.error().ToString();
        continue;
      }
      own_at = std::move(at_k).value();
    }
    d.time = series.time;
    d.sample_interval =
        series.intervals.distinct.size() == 1 ? series.intervals.distinct.front() : 0.0;
    bool too_short = false;
    for (int first : settings.first_obs)
      too_short = too_short || first >= static_cast<int>(series.size());
    if (too_short) {
      d.error = series.source + ": the output delay leaves no observation in its " +
                std::to_string(series.size()) + " rows";
      continue;
    }
    // A validation record starts where its own first samples place it.
    filter::FilterSettings own = settings;
    if (d.validation) {
      const int n_first = filter::InitialStateSamples(static_cast<int>(series.size()));
      Result<filter::InitialStateEstimate> start =
          at->ss ? filter::EstimateInitialState(*at->ss, series, settings, n_first)
                 : filter::EkfEstimateInitialState(*at->nonlinear, at->theta, series, settings,
                                                   n_first);
      if (control.cancel) {
        run.cancelled = true;
        return run;
      }
      if (start) {
        own.x0 = start->x0;
        own.P0 = start->P0;
        d.initial_samples = start->samples;
      } else {
        d.initial_error = start.error().ToString();
      }
    }
    if (!AnalyseSeries(own_at ? *own_at : *at, preview, series, own, a, &d, control)) {
      run.cancelled = true;
      return run;
    }
  }
  control.progress = 1.0f;
  run.analysis = std::move(a);
  return run;
}

}  // namespace

AnalysisRun RunAnalysis(const AnalysisInput& input, JobControl& control) {
  try {
    return Analyse(input, control);
  } catch (const std::exception& e) {  // e.g. out of memory; never into the UI loop
    AnalysisRun run;
    run.error = std::string("the computation stopped: ") + e.what();
    return run;
  }
}

}  // namespace gb::ui
