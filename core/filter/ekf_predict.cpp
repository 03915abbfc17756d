#include "core/filter/ekf_predict.h"

#include <algorithm>
#include <cmath>

#include <Eigen/QR>

#include "core/filter/internal.h"
#include "core/filter/moments.h"

namespace gb::filter {
namespace {

using internal::kNaN;

HorizonPredictions Empty(int n, int p, int N, int horizon) {
  HorizonPredictions out;
  out.horizon = horizon;
  out.y_pred.setConstant(p, N, kNaN);
  out.y_sd.setConstant(p, N, kNaN);
  out.x_pred.setConstant(n, N, kNaN);
  out.P.assign(N, Eigen::MatrixXd());
  return out;
}

// Stores (x, P) as the prediction of state index j and its outputs.
Status Store(MomentPropagator& propagator, const data::Series& series,
             const std::vector<int>& delay, int j, const Eigen::VectorXd& x,
             const Eigen::MatrixXd& P, std::vector<double>& meas, HorizonPredictions* out) {
  const int n = static_cast<int>(x.size());
  const int p = static_cast<int>(out->y_pred.rows());
  const int N = static_cast<int>(series.size());
  out->x_pred.col(j) = x;
  out->P[j] = P;
  if (auto s = propagator.Measure(j, x, meas); !s) return s;
  for (int o = 0; o < p; ++o) {
    const int k = j + delay[o];
    if (k >= N) continue;
    const Eigen::Map<const Eigen::RowVectorXd> H(
        meas.data() + p + static_cast<std::ptrdiff_t>(o) * n, n);
    out->y_pred(o, k) = meas[o];
    out->y_sd(o, k) = std::sqrt((H * P * H.transpose()).value() + meas[p + p * n + o]);
  }
  return Ok{};
}

}  // namespace

Result<OneStepPredictions> EkfPredictOneStep(const model::NonlinearModel& model,
                                             std::span<const double> theta,
                                             const data::Series& series,
                                             const FilterSettings& settings) {
  FilterTrace trace;
  auto l = EkfRunFilter(model, theta, series, settings, &trace);
  if (!l) return l.error();
  return OneStepFromTrace(series, settings, trace, *l);
}

Result<HorizonPredictions> EkfPredictAhead(const model::NonlinearModel& model,
                                           std::span<const double> theta,
                                           const data::Series& series,
                                           const FilterSettings& settings, const FilterTrace& trace,
                                           int horizon) {
  assert(horizon >= 0 && "the prediction horizon is a number of samples >= 0");
  const int n = model.n_states(), p = model.n_outputs();
  const int N = static_cast<int>(series.size());
  assert(trace.x_filt.cols() == N && trace.x_filt.rows() == n && "the trace of this series");
  const std::vector<int> delay = EffectiveDelay(settings, p);
  MomentPropagator propagator(model, theta, series, settings.hold);
  std::vector<double> meas(model.measurement_size());
  HorizonPredictions out = Empty(n, p, N, horizon);
  // j < h: from the prior, without updates.
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  if (auto s = propagator.Initial(settings.initial_covariance, &x, &P); !s) return s.error();
  settings.OverrideInitial(&x, &P);
  for (int j = 0; j < std::min(horizon, N); ++j) {
    if (auto s = Store(propagator, series, delay, j, x, P, meas, &out); !s) return s.error();
    if (j + 1 < N) {
      if (auto s = propagator.Advance(j, &x, &P); !s) return s.error();
    }
  }
  // j >= h: from the filtered state at s = j - h.
  for (int s = 0; s + horizon < N; ++s) {
    x = trace.x_filt.col(s);
    P = trace.P_filt[s];
    for (int j = s; j < s + horizon; ++j) {
      if (auto st = propagator.Advance(j, &x, &P); !st) return st.error();
    }
    if (auto st = Store(propagator, series, delay, s + horizon, x, P, meas, &out); !st)
      return st.error();
  }
  return out;
}

Result<HorizonPredictions> EkfOpenLoop(const model::NonlinearModel& model,
                                       std::span<const double> theta, const data::Series& series,
                                       const FilterSettings& settings) {
  const int n = model.n_states(), p = model.n_outputs();
  const int N = static_cast<int>(series.size());
  const std::vector<int> delay = EffectiveDelay(settings, p);
  MomentPropagator propagator(model, theta, series, settings.hold);
  std::vector<double> meas(model.measurement_size());
  HorizonPredictions out = Empty(n, p, N, -1);
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  if (auto s = propagator.Initial(settings.initial_covariance, &x, &P); !s) return s.error();
  settings.OverrideInitial(&x, &P);
  for (int j = 0; j < N; ++j) {
    if (auto s = Store(propagator, series, delay, j, x, P, meas, &out); !s) return s.error();
    if (j + 1 < N) {
      if (auto s = propagator.Advance(j, &x, &P); !s) return s.error();
    }
  }
  return out;
}

Result<SmoothedStates> EkfSmooth(const model::NonlinearModel& model, std::span<const double> theta,
                                 const data::Series& series, const FilterSettings& settings,
                                 const FilterTrace& trace) {
  const int n = model.n_states(), p = model.n_outputs();
  const int N = static_cast<int>(series.size());
  assert(trace.x_filt.cols() == N && trace.x_filt.rows() == n && "the trace of this series");
  MomentPropagator propagator(model, theta, series, settings.hold, /*transition=*/true);
  SmoothedStates out;
  out.x = trace.x_filt;
  out.P = trace.P_filt;
  Eigen::VectorXd x;
  Eigen::MatrixXd P, Phi;
  for (int j = N - 2; j >= 0; --j) {
    // The prediction of j + 1 again, now with Φ_j (it equals the trace's to the ODE tolerance).
    x = trace.x_filt.col(j);
    P = trace.P_filt[j];
    if (auto s = propagator.Advance(j, &x, &P, &Phi); !s) return s.error();
    // G' = P_{j+1|j}⁺ Φ P_{j|j}, rank-revealing as the linear smoother's (a noise-free state
    // makes P_{j+1|j} singular up to rounding).
    const Eigen::MatrixXd Gt = P.completeOrthogonalDecomposition().solve(Phi * trace.P_filt[j]);
    const Eigen::MatrixXd G = Gt.transpose();
    out.x.col(j) = trace.x_filt.col(j) + G * (out.x.col(j + 1) - x);
    const Eigen::MatrixXd Ps = trace.P_filt[j] + G * (out.P[j + 1] - P) * Gt;
    out.P[j] = 0.5 * (Ps + Ps.transpose());
  }
  const std::vector<int> delay = EffectiveDelay(settings, p);
  out.y.setConstant(p, N, kNaN);
  out.y_sd.setConstant(p, N, kNaN);
  std::vector<double> meas(model.measurement_size());
  for (int j = 0; j < N; ++j) {
    if (auto s = propagator.Measure(j, out.x.col(j), meas); !s) return s.error();
    for (int o = 0; o < p; ++o) {
      const int k = j + delay[o];
      if (k >= N) continue;
      const Eigen::Map<const Eigen::RowVectorXd> H(
          meas.data() + p + static_cast<std::ptrdiff_t>(o) * n, n);
      out.y(o, k) = meas[o];
      out.y_sd(o, k) = std::sqrt(std::max((H * out.P[j] * H.transpose()).value(), 0.0));
    }
  }
  return out;
}

}  // namespace gb::filter
