#include "core/sim/sde.h"

#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "core/filter/ekf_predict.h"
#include "core/filter/moments.h"
#include "core/filter/predict.h"
#include "core/sim/random.h"

namespace gb::sim {
namespace {

using Program = model::NonlinearModel::Program;

}  // namespace

Result<Simulation> DeterministicResponse(const model::NonlinearModel& model,
                                         std::span<const double> theta, const data::Series& series,
                                         const filter::FilterSettings& settings) {
  auto open = filter::EkfOpenLoop(model, theta, series, settings);
  if (!open) return open.error();
  Simulation sim;
  sim.X = open->x_pred;
  sim.Y = open->y_pred;  // h(x̂): the noise-free output
  return sim;
}

Result<Simulation> SamplePath(const model::NonlinearModel& model, std::span<const double> theta,
                              const data::Series& series, const filter::FilterSettings& settings,
                              std::uint64_t seed, int substeps) {
  assert(substeps >= 1);
  const int n = model.n_states(), m = model.n_inputs(), p = model.n_outputs();
  const int N = static_cast<int>(series.size());
  if (auto st = CheckSimulationSize(N, n, p); !st) return st.error();
  const std::vector<int> delay = filter::EffectiveDelay(settings, p);
  const bool foh = settings.hold == model::InputHold::kFoh;
  NormalRng rng(seed);
  Eigen::VectorXd x;
  Eigen::MatrixXd P0;
  {
    filter::MomentPropagator propagator(model, theta, series, settings.hold);
    if (auto s = propagator.Initial(settings.initial_covariance, &x, &P0); !s) return s.error();
    settings.OverrideInitial(&x, &P0);
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(P0);
  const Eigen::MatrixXd factor =
      es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  Eigen::VectorXd z(n);
  for (int i = 0; i < n; ++i) z(i) = rng.Normal();
  x += factor * z;

  std::vector<double> slots(model.n_slots(), 0.0);
  std::copy(theta.begin(), theta.end(), slots.begin() + model.parameter_slot());
  std::vector<double> dyn(model.dynamics_size()), noise(2 * static_cast<std::size_t>(n)),
      meas(model.measurement_size());
  Simulation sim;
  sim.X.resize(n, N);
  sim.Y.setConstant(p, N, std::numeric_limits<double>::quiet_NaN());
  for (int j = 0; j < N; ++j) {
    sim.X.col(j) = x;
    if (j + 1 == N) break;
    const double t0 = series.time[j];
    const double dt = series.time[j + 1] - t0;
    // A stiff model needs more sub-steps for the explicit scheme to stay stable: at least
    // ρ Δ, ρ = max_i Σ_j |∂f_i/∂x_j| (Gershgorin) at the interval's start.
    std::copy(x.data(), x.data() + n, slots.begin());
    for (int i = 0; i < m; ++i) slots[n + i] = series.U(i, j);
    slots[model.time_slot()] = t0;
    model.Dynamics(slots, dyn);
    double rho = 0.0;
    for (int i = 0; i < n; ++i) {
      double row = 0.0;
      for (int k = 0; k < n; ++k) row += std::abs(dyn[n + i * n + k]);
      rho = std::max(rho, row);
    }
    const int steps = std::isfinite(rho)
                          ? std::max(substeps, static_cast<int>(std::min(std::ceil(rho * dt), 1e6)))
                          : substeps;
    const double h = dt / steps;
    const double sqrt_h = std::sqrt(h);
    for (int s = 0; s < steps; ++s) {
      const double t = t0 + s * h;
      std::copy(x.data(), x.data() + n, slots.begin());
      for (int i = 0; i < m; ++i) {
        double u = series.U(i, j);
        if (foh) u += (t - t0) / dt * (series.U(i, j + 1) - series.U(i, j));
        slots[n + i] = u;
      }
      slots[model.time_slot()] = t;
      model.Dynamics(slots, dyn);
      model.Noise(slots, noise);
      for (int i = 0; i < n; ++i) {
        const double dw = sqrt_h * rng.Normal();
        const double sigma = noise[i], dsigma = noise[n + i];
        x(i) += dyn[i] * h + sigma * dw + 0.5 * sigma * dsigma * (dw * dw - h);
      }
      for (int i = 0; i < n; ++i) {
        if (std::isfinite(x(i))) continue;
        // Name the entry that broke the path.
        for (std::size_t k = 0; k < dyn.size(); ++k)
          if (!std::isfinite(dyn[k]))
            return data::AtRow(model.NotFinite(Program::kDynamics, k, dyn[k], slots), series, j);
        for (std::size_t k = 0; k < noise.size(); ++k)
          if (!std::isfinite(noise[k]))
            return data::AtRow(model.NotFinite(Program::kNoise, k, noise[k], slots), series, j);
        return data::AtRow(
            NumericalError(fmt::format("the sample path of {} is not finite after row {}",
                                       model.spec().states[i], j + 1)),
            series, j);
      }
    }
  }
  // Measurement noise after the state path, as the linear simulator does.
  for (int k = 0; k < N; ++k) {
    for (int o = 0; o < p; ++o) {
      const int j = k - delay[o];
      if (j < 0) continue;
      std::copy(sim.X.col(j).data(), sim.X.col(j).data() + n, slots.begin());
      for (int i = 0; i < m; ++i) slots[n + i] = series.U(i, j);
      slots[model.time_slot()] = series.time[j];
      model.Measurement(slots, meas);
      const double S = meas[p + p * n + o];
      if (!std::isfinite(meas[o]) || !std::isfinite(S)) {
        const std::size_t entry = std::isfinite(meas[o]) ? p + p * n + o : o;
        return data::AtRow(model.NotFinite(Program::kMeasurement, entry, meas[entry], slots),
                           series, j);
      }
      sim.Y(o, k) = meas[o] + std::sqrt(std::max(0.0, S)) * rng.Normal();
    }
  }
  return sim;
}

}  // namespace gb::sim
