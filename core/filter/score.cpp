// Sections: 1. derivatives of the discretisation and of P0  2. entry point (the sensitivity loop,
//           templated on the state dimension: linear_loops.h)
#include "core/filter/score.h"

#include <vector>

#include <Eigen/Dense>

#include "core/filter/discretize.h"
#include "core/filter/internal.h"
#include "core/filter/linear_loops.h"

namespace gb::filter {
namespace {

// ---- 1. derivatives of the discretisation and of P0 ------------------------------------------

Eigen::VectorXd Sigma2Derivative(const model::StateSpace& ss, const model::StateSpace& d) {
  return 2.0 * ss.sigma.cwiseProduct(d.sigma);
}

// dd[g][i]: the derivative of the discretisation of distinct interval g along θ_i.
std::vector<std::vector<Discrete>> DiscretizeDerivatives(const model::StateSpace& ss,
                                                         std::span<const model::StateSpace> dss,
                                                         const data::Series& series,
                                                         model::InputHold hold) {
  const Eigen::VectorXd sigma2 = ss.sigma.array().square();
  std::vector<std::vector<Discrete>> out;
  out.reserve(series.intervals.distinct.size());
  for (double dt : series.intervals.distinct) {
    std::vector<Discrete> per_theta;
    per_theta.reserve(dss.size());
    for (const auto& d : dss)
      per_theta.push_back(DiscretizeDerivative(ss.A, ss.B, ss.c, sigma2, d.A, d.B, d.c,
                                               Sigma2Derivative(ss, d), dt, hold));
    out.push_back(std::move(per_theta));
  }
  return out;
}

}  // namespace

std::vector<Eigen::MatrixXd> InitialCovarianceDerivatives(model::InitialCovariance kind,
                                                          const model::StateSpace& ss,
                                                          std::span<const model::StateSpace> dss,
                                                          const Eigen::MatrixXd& P0,
                                                          std::span<const Discrete> dfirst) {
  const Eigen::Index n = ss.A.rows();
  std::vector<Eigen::MatrixXd> dP0;
  switch (kind) {
    case model::InitialCovariance::kCtsm:
      for (const Discrete& d : dfirst) dP0.push_back(d.Q);
      break;
    case model::InitialCovariance::kStationary: {
      // P0 exists, so A is stable and the operator is invertible.
      const Eigen::PartialPivLU<Eigen::MatrixXd> lu(LyapunovOperator(ss.A));
      for (const auto& d : dss) {
        Eigen::MatrixXd rhs = d.A * P0 + P0 * d.A.transpose();
        rhs.diagonal() += Sigma2Derivative(ss, d);
        const Eigen::VectorXd x = lu.solve(-Eigen::Map<const Eigen::VectorXd>(rhs.data(), n * n));
        Eigen::MatrixXd dP = Eigen::Map<const Eigen::MatrixXd>(x.data(), n, n);
        dP0.push_back(0.5 * (dP + dP.transpose()));
      }
      break;
    }
    case model::InitialCovariance::kExplicit:
      for (const auto& d : dss) dP0.emplace_back(d.P0_diag.asDiagonal());
      break;
  }
  return dP0;
}

// ---- 2. entry point --------------------------------------------------------------------------

Result<Loglik> LogLikelihoodScore(const model::StateSpace& ss,
                                  std::span<const model::StateSpace> dss,
                                  const data::Series& series, const FilterSettings& settings,
                                  Eigen::VectorXd* gradient, Eigen::MatrixXd* J_terms_theta) {
  assert(gradient != nullptr);
  assert(series.U.rows() == ss.n_inputs() && series.Y.rows() == ss.n_outputs() &&
         "series bound to the model");
  auto window = ObservationWindowOf(series, ss.n_outputs(), settings);
  if (!window) return window.error();
  const auto disc = DiscretizeIntervals(ss, series, settings.hold);
  if (!disc) return disc.error();
  auto P0 = settings.initial_covariance == model::InitialCovariance::kCtsm
                ? Result<Eigen::MatrixXd>((*disc)[series.intervals.group[0]].Q)
                : InitialCovariance(ss, series, settings);
  if (!P0) return P0.error();
  const auto ddisc = DiscretizeDerivatives(ss, dss, series, settings.hold);
  const auto dP0 = InitialCovarianceDerivatives(settings.initial_covariance, ss, dss, *P0,
                                                ddisc[series.intervals.group[0]]);
  const internal::ScoreContext ctx{ss, dss, series, settings, *disc, ddisc, *P0, dP0, *window};
  return internal::WithStateDimension(ss.n_states(), [&](auto nx) {
    return internal::ScoreLoop<decltype(nx)::value>(ctx, gradient, J_terms_theta);
  });
}

}  // namespace gb::filter
