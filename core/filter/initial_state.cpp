#include "core/filter/initial_state.h"

#include <algorithm>
#include <cmath>

#include "core/filter/ekf.h"
#include "core/filter/ekf_predict.h"
#include "core/filter/moments.h"
#include "core/filter/predict.h"

namespace gb::filter {
namespace {

// The wide prior of step 1.
Eigen::MatrixXd Widened(const Eigen::VectorXd& x0, const Eigen::MatrixXd& P0) {
  Eigen::MatrixXd P = P0;
  for (Eigen::Index i = 0; i < x0.size(); ++i) {
    const double s = std::max({std::abs(x0(i)), std::sqrt(std::max(P0(i, i), 0.0)), 1.0});
    P(i, i) += 100 * s * s;
  }
  return P;
}

InitialStateEstimate FirstRowOf(const SmoothedStates& smoothed, int n) {
  InitialStateEstimate e;
  e.x0 = smoothed.x.col(0);
  e.P0 = 0.5 * (smoothed.P.front() + smoothed.P.front().transpose());
  e.samples = n;
  return e;
}

}  // namespace

int InitialStateSamples(int rows) { return std::max(2, std::min(100, rows / 5)); }

data::Series Head(const data::Series& series, int n) {
  data::Series head;
  head.source = series.source;
  head.time.assign(series.time.begin(), series.time.begin() + n);
  head.U = series.U.leftCols(n);
  head.Y = series.Y.leftCols(n);
  head.intervals = data::GroupIntervals(head.time);
  head.outputs = series.outputs;
  if (static_cast<int>(series.row_line.size()) >= n)
    head.row_line.assign(series.row_line.begin(), series.row_line.begin() + n);
  return head;
}

Result<InitialStateEstimate> EstimateInitialState(const model::StateSpace& ss,
                                                  const data::Series& series,
                                                  const FilterSettings& settings, int n) {
  n = std::clamp(n, 2, static_cast<int>(series.size()));
  const data::Series head = Head(series, n);
  FilterSettings wide = settings;
  wide.x0.resize(0);
  wide.P0.resize(0, 0);
  Result<Eigen::MatrixXd> P0 = InitialCovariance(ss, head, wide);
  if (!P0) return P0.error();
  wide.P0 = Widened(ss.x0, *P0);
  FilterTrace trace;
  if (Result<Loglik> l = RunFilter(ss, head, wide, &trace); !l) return l.error();
  return FirstRowOf(SmoothFromTrace(ss, head, wide, trace), n);
}

Result<InitialStateEstimate> EkfEstimateInitialState(const model::NonlinearModel& model,
                                                     std::span<const double> theta,
                                                     const data::Series& series,
                                                     const FilterSettings& settings, int n) {
  n = std::clamp(n, 2, static_cast<int>(series.size()));
  const data::Series head = Head(series, n);
  FilterSettings wide = settings;
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  {
    MomentPropagator propagator(model, theta, head, settings.hold);
    if (Status s = propagator.Initial(settings.initial_covariance, &x, &P); !s) return s.error();
  }
  wide.x0 = x;
  wide.P0 = Widened(x, P);
  FilterTrace trace;
  if (Result<Loglik> l = EkfRunFilter(model, theta, head, wide, &trace); !l) return l.error();
  Result<SmoothedStates> smoothed = EkfSmooth(model, theta, head, wide, trace);
  if (!smoothed) return smoothed.error();
  return FirstRowOf(*smoothed, n);
}

}  // namespace gb::filter
