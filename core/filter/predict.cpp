#include "core/filter/predict.h"

#include <cassert>
#include <cmath>

#include <Eigen/Dense>

#include "core/filter/discretize.h"
#include "core/filter/internal.h"

namespace gb::filter {
namespace {

using internal::kNaN;

void CheckTrace([[maybe_unused]] const model::StateSpace& ss,
                [[maybe_unused]] const data::Series& series,
                [[maybe_unused]] const FilterTrace& trace) {
  assert(trace.x_filt.cols() == static_cast<Eigen::Index>(series.size()) &&
         trace.x_filt.rows() == ss.n_states() && trace.P_filt.size() == series.size() &&
         trace.y_pred.rows() == ss.n_outputs() && "the trace belongs to this model and series");
}

}  // namespace

std::vector<int> EffectiveDelay(const FilterSettings& settings, int n_outputs) {
  if (settings.delay.empty()) return std::vector<int>(n_outputs, 0);
  assert(static_cast<int>(settings.delay.size()) == n_outputs);
  return settings.delay;
}

std::vector<int> EffectiveFirstObservation(const FilterSettings& settings, int n_outputs) {
  const std::vector<int> delay = EffectiveDelay(settings, n_outputs);
  std::vector<int> first = settings.first_obs.empty() ? delay : settings.first_obs;
  assert(static_cast<int>(first.size()) == n_outputs);
  for (int o = 0; o < n_outputs; ++o) first[o] = std::max(first[o], delay[o]);
  return first;
}

Eigen::MatrixXd OutputMean(const model::StateSpace& ss, const data::Series& series,
                           const std::vector<int>& delay, const Eigen::MatrixXd& X) {
  const int p = ss.n_outputs();
  const int N = static_cast<int>(series.size());
  assert(X.cols() == N && X.rows() == ss.n_states());
  Eigen::MatrixXd Y = Eigen::MatrixXd::Constant(p, N, kNaN);
  for (int o = 0; o < p; ++o) {
    for (int k = delay[o]; k < N; ++k) {
      const int j = k - delay[o];
      double y = ss.C.row(o).dot(X.col(j)) + ss.d(o);
      if (ss.n_inputs() > 0) y += ss.D.row(o).dot(series.U.col(j));
      Y(o, k) = y;
    }
  }
  return Y;
}

// ---- one step ------------------------------------------------------------------------------

OneStepPredictions OneStepFromTrace(const model::StateSpace& ss, const data::Series& series,
                                    const FilterSettings& settings, const FilterTrace& trace,
                                    const Loglik& loglik) {
  CheckTrace(ss, series, trace);
  return OneStepFromTrace(series, settings, trace, loglik);
}

OneStepPredictions OneStepFromTrace(const data::Series& series, const FilterSettings& settings,
                                    const FilterTrace& trace, const Loglik& loglik) {
  const int p = static_cast<int>(trace.y_pred.rows());
  const int N = static_cast<int>(series.size());
  const std::vector<int> first = EffectiveFirstObservation(settings, p);
  OneStepPredictions out;
  out.y_pred = trace.y_pred;
  out.y_sd = trace.y_var.cwiseSqrt();  // NaN stays NaN
  out.residual = series.Y - out.y_pred;
  out.standardized = Eigen::MatrixXd::Constant(p, N, kNaN);
  for (int o = 0; o < p; ++o)
    for (int k = first[o]; k < N; ++k) out.standardized(o, k) = out.residual(o, k) / out.y_sd(o, k);
  out.loglik = loglik;
  return out;
}

Result<OneStepPredictions> PredictOneStep(const model::StateSpace& ss, const data::Series& series,
                                          const FilterSettings& settings) {
  FilterTrace trace;
  auto l = RunFilter(ss, series, settings, &trace);
  if (!l) return l.error();
  return OneStepFromTrace(ss, series, settings, trace, *l);
}

// ---- h steps ahead ---------------------------------------------------------------------------

Result<HorizonPredictions> PredictAheadFromTrace(const model::StateSpace& ss,
                                                 const data::Series& series,
                                                 const FilterSettings& settings,
                                                 const FilterTrace& trace, int horizon) {
  assert(horizon >= 0 && "the prediction horizon is a number of samples >= 0");
  CheckTrace(ss, series, trace);
  const int n = ss.n_states(), p = ss.n_outputs(), m = ss.n_inputs();
  const int N = static_cast<int>(series.size());
  const bool foh = settings.hold == model::InputHold::kFoh;
  auto P0 = InitialCovariance(ss, series, settings);
  if (!P0) return P0.error();
  const auto discretized = DiscretizeIntervals(ss, series, settings.hold);
  if (!discretized) return discretized.error();
  const std::vector<Discrete>& disc = *discretized;

  HorizonPredictions out;
  out.horizon = horizon;
  out.x_pred.resize(n, N);
  out.P.assign(N, Eigen::MatrixXd());
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  for (int j = 0; j < N; ++j) {
    int i = j - horizon;
    if (i >= 0) {
      x = trace.x_filt.col(i);
      P = trace.P_filt[i];
    } else {
      i = 0;
      x = ss.x0;
      P = *P0;
    }
    for (; i < j; ++i) {
      const Discrete& d = disc[series.intervals.group[i]];
      Eigen::VectorXd next = d.Phi * x + d.g;
      if (m > 0) {
        next += d.Gamma0 * series.U.col(i);
        if (foh) next += d.Gamma1 * series.U.col(i + 1);
      }
      x = next;
      P = (d.Phi * P * d.Phi.transpose() + d.Q).eval();
      P = (0.5 * (P + P.transpose())).eval();
    }
    out.x_pred.col(j) = x;
    out.P[j] = P;
  }
  const std::vector<int> delay = EffectiveDelay(settings, p);
  out.y_pred = OutputMean(ss, series, delay, out.x_pred);
  out.y_sd = Eigen::MatrixXd::Constant(p, N, kNaN);
  for (int o = 0; o < p; ++o) {
    for (int k = delay[o]; k < N; ++k) {
      const int j = k - delay[o];
      out.y_sd(o, k) =
          std::sqrt((ss.C.row(o) * out.P[j] * ss.C.row(o).transpose()).value() + ss.S(o));
    }
  }
  return out;
}

Result<HorizonPredictions> PredictAhead(const model::StateSpace& ss, const data::Series& series,
                                        const FilterSettings& settings, int horizon) {
  FilterTrace trace;
  auto l = RunFilter(ss, series, settings, &trace);
  if (!l) return l.error();
  return PredictAheadFromTrace(ss, series, settings, trace, horizon);
}

// ---- smoother --------------------------------------------------------------------------------

SmoothedStates SmoothFromTrace(const model::StateSpace& ss, const data::Series& series,
                               const FilterSettings& settings, const FilterTrace& trace) {
  CheckTrace(ss, series, trace);
  const int p = ss.n_outputs();
  const int N = static_cast<int>(series.size());
  // The trace is of a filter run, which discretised the same intervals without error.
  const std::vector<Discrete> disc = DiscretizeIntervals(ss, series, settings.hold).value();

  SmoothedStates out;
  out.x = trace.x_filt;
  out.P = trace.P_filt;
  for (int j = N - 2; j >= 0; --j) {
    const Eigen::MatrixXd& Phi = disc[series.intervals.group[j]].Phi;
    // G' = P_{j+1|j}⁺ Φ P_{j|j}. A state without noise makes P_{j+1|j} singular up to rounding;
    // the rank-revealing solve drops the directions below rounding level instead of amplifying
    // them, where LDLT would divide by a pivot of 1e-17.
    const Eigen::MatrixXd Gt =
        trace.P_pred[j + 1].completeOrthogonalDecomposition().solve(Phi * trace.P_filt[j]);
    const Eigen::MatrixXd G = Gt.transpose();
    out.x.col(j) = trace.x_filt.col(j) + G * (out.x.col(j + 1) - trace.x_pred.col(j + 1));
    Eigen::MatrixXd P = trace.P_filt[j] + G * (out.P[j + 1] - trace.P_pred[j + 1]) * Gt;
    out.P[j] = 0.5 * (P + P.transpose());
  }
  const std::vector<int> delay = EffectiveDelay(settings, p);
  out.y = OutputMean(ss, series, delay, out.x);
  out.y_sd = Eigen::MatrixXd::Constant(p, N, kNaN);
  for (int o = 0; o < p; ++o) {
    for (int k = delay[o]; k < N; ++k) {
      const double v = (ss.C.row(o) * out.P[k - delay[o]] * ss.C.row(o).transpose()).value();
      out.y_sd(o, k) = std::sqrt(std::max(v, 0.0));
    }
  }
  return out;
}

Result<SmoothedStates> Smooth(const model::StateSpace& ss, const data::Series& series,
                              const FilterSettings& settings) {
  FilterTrace trace;
  auto l = RunFilter(ss, series, settings, &trace);
  if (!l) return l.error();
  return SmoothFromTrace(ss, series, settings, trace);
}

}  // namespace gb::filter
