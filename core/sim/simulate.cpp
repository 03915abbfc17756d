#include "core/sim/simulate.h"

#include <cmath>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "core/filter/discretize.h"
#include "core/sim/random.h"

namespace gb::sim {
namespace {

// A factor L with L L' = M for a symmetric positive semi-definite M (rank-deficient allowed).
Eigen::MatrixXd PsdFactor(const Eigen::MatrixXd& M) {
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(M);
  const Eigen::VectorXd root = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return es.eigenvectors() * root.asDiagonal();
}

Eigen::VectorXd Draw(NormalRng& rng, const Eigen::MatrixXd& L) {
  Eigen::VectorXd z(L.cols());
  for (Eigen::Index i = 0; i < z.size(); ++i) z(i) = rng.Normal();
  return L * z;
}

}  // namespace

Status CheckSimulationSize(std::int64_t rows, int states, int outputs) {
  const double values = static_cast<double>(rows) * (states + outputs);
  if (values <= kMaxSimulatedValues) return Ok{};
  return InputError(fmt::format(
      "{} rows of {} states and {} outputs are {:.3g} simulated values; at most {:.3g} are "
      "simulated at once (split the inputs into shorter files)",
      rows, states, outputs, values, kMaxSimulatedValues));
}

Result<Simulation> Simulate(const model::StateSpace& ss, const data::Series& series,
                            const filter::FilterSettings& settings,
                            const SimulateOptions& options) {
  const int n = ss.n_states(), p = ss.n_outputs(), m = ss.n_inputs();
  const int N = static_cast<int>(series.size());
  if (auto st = CheckSimulationSize(N, n, p); !st) return st.error();
  NormalRng rng(options.seed);
  const auto discretized = filter::DiscretizeIntervals(ss, series, settings.hold);
  if (!discretized) return discretized.error();
  const std::vector<filter::Discrete>& disc = *discretized;
  std::vector<Eigen::MatrixXd> q_factor;
  q_factor.reserve(disc.size());
  for (const auto& d : disc) q_factor.push_back(PsdFactor(d.Q));

  Simulation sim;
  sim.X.resize(n, N);
  sim.Y.setConstant(p, N, std::numeric_limits<double>::quiet_NaN());
  Eigen::VectorXd x = settings.x0.size() > 0 ? settings.x0 : ss.x0;
  if (options.random_initial_state) {
    auto P0 = filter::InitialCovariance(ss, series, settings);
    if (!P0) return P0.error();
    x += Draw(rng, PsdFactor(*P0));
  }
  for (int j = 0; j < N; ++j) {
    sim.X.col(j) = x;
    if (j + 1 < N) {
      const int g = series.intervals.group[j];
      const filter::Discrete& d = disc[g];
      Eigen::VectorXd next = d.Phi * x + d.g;
      if (m > 0) {
        next += d.Gamma0 * series.U.col(j);
        if (settings.hold == model::InputHold::kFoh) next += d.Gamma1 * series.U.col(j + 1);
      }
      if (options.process_noise) next += Draw(rng, q_factor[g]);
      x = next;
      for (Eigen::Index i = 0; i < n; ++i) {
        if (std::isfinite(x(i))) continue;
        Error e = NumericalError(fmt::format(
            "the simulated state number {} is {} at t = {}: the model's path is not finite "
            "over this record",
            i + 1, x(i), series.time[j + 1]));
        e.file = series.source;
        if (j + 1 < static_cast<int>(series.row_line.size())) e.line = series.row_line[j + 1];
        return e;
      }
    }
  }
  // Measurement noise is drawn after the state path so that the state path of a seed does not
  // depend on whether outputs are noisy.
  for (int k = 0; k < N; ++k) {
    for (int o = 0; o < p; ++o) {
      const int delay = settings.delay.empty() ? 0 : settings.delay[o];
      const int j = k - delay;
      if (j < 0) continue;
      double y = ss.C.row(o).dot(sim.X.col(j)) + ss.d(o);
      if (m > 0) y += ss.D.row(o).dot(series.U.col(j));
      if (options.measurement_noise) y += std::sqrt(ss.S(o)) * rng.Normal();
      sim.Y(o, k) = y;
    }
  }
  return sim;
}

}  // namespace gb::sim
