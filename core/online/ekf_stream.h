// The continuous-discrete extended Kalman filter of core/filter/ekf.h fed one row at a time, at a
// cost per row that does not depend on how many rows came before: the on-line filter of nonlinear
// models, under the augmented EKF (augmented.h) and the monitor's reference filter (HeldEkf below).
//
// Between rows the moment equations are integrated with the model's solver and tolerances
// (moments.h, with error control; BDF where the model is stiff); each state index is updated with
// the scalar updates of ekf.h (one pass: the on-line filters do not iterate the update) and gives
// its log-likelihood term. With `sensitivities`, the forward sensitivities of x̂ and P with
// respect to those parameters are carried as ekf_score.h carries them, and each index also gives
// its exact score ∂ℓ_j/∂θ and its Fisher information (per scalar observation with innovation ε
// and variance R: dε dε'/R + ½ dR dR'/R², as recursive.h).
//
// Output delays as kalman.h: index j is complete once row j + max d_o is in; the last max d_o + 2
// rows are kept in a ring. Index 0 also waits for the second row (the start may need the first
// interval).
//
// The start (RecursiveOptions::Start):
//   kLive   the equilibrium for the first row's input, f(x, u_0, θ, t_0) = 0 by damped Newton
//           from the model's x0, with the stationary covariance (J P + P J' + diag(σ²) = 0) when
//           J is stable there: a stream starts wherever the system is, not where a record began.
//           Only the first `equilibrium_states` states are solved for; the others (the augmented
//           EKF's parameters) keep their x0 with zero variance. Without a stable equilibrium,
//           as kModel. The sensitivities start at zero (they forget their start within the
//           warm-up of the filters that use them).
//   kModel  the model's own x0 and P0 (ekf.h: "ctsm", "stationary" or explicit), with their
//           sensitivities, as the batch filter starts.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/data/follow.h"
#include "core/model/nonlinear_model.h"
#include "core/ode/ode.h"
#include "core/online/estimator.h"
#include "core/util/result.h"

namespace gb::online {

struct EkfStreamOptions {
  std::vector<int> delay;          // per output, whole samples
  std::vector<int> sensitivities;  // parameter indices whose scores and information are wanted
  RecursiveOptions::Start start = RecursiveOptions::Start::kLive;
  int equilibrium_states = -1;  // kLive: the leading states solved for (-1: all)
};

// What one state index gave.
struct EkfStep {
  int index = 0;
  double t = 0.0;
  int line = 0;
  // Per output (NaN where not observed at this index): ε = y - h(x̂⁻) and √R.
  std::vector<double> innovation, innovation_sd;
  int observed = 0;             // scalar observations used
  double loglik_term = 0.0;     // ℓ_j
  Eigen::VectorXd score;        // ∂ℓ_j/∂θ (the `sensitivities` parameters)
  Eigen::MatrixXd information;  // Fisher information of index j (same order)
};

class EkfStream {
 public:
  // θ: all parameters. Errors: delays that do not fit the model, a sensitivity the model's
  // derivatives cannot be compiled for.
  static Result<EkfStream> Create(std::shared_ptr<const model::NonlinearModel> model,
                                  std::vector<double> theta, EkfStreamOptions options,
                                  std::string source);
  EkfStream(EkfStream&&) noexcept;
  EkfStream& operator=(EkfStream&&) noexcept;
  ~EkfStream();

  // Feeds the next row; the steps of the state indices it completes. Errors name the source's
  // line: a time that does not increase, an entry of the model that is not finite at the
  // filtered mean, moment equations the solver could not integrate.
  Result<std::vector<EkfStep>> Push(const Sample& row);

  // The filtered mean and covariance of the last completed index (before the first: empty). The
  // caller may change them between pushes (the augmented EKF opens its parameters' variances
  // after the warm-up).
  Eigen::VectorXd& x();
  Eigen::MatrixXd& P();
  const Eigen::VectorXd& x() const;
  const Eigen::MatrixXd& P() const;
  // New parameter values from the next interval on.
  void SetParameters(std::span<const double> theta);

  const model::NonlinearModel& model() const;
  const std::vector<double>& theta() const;
  // At the start: the slowest time constant of J over the solved states (max -1/Re λ), +inf
  // when J is not stable there; 0 before the start.
  double slowest_time_constant() const;
  const ode::OdeCounts& counts() const;

 private:
  struct Impl;
  explicit EkfStream(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The extended Kalman filter held at the reference, with the exact scores of the tracked
// parameters: the monitor's reference filter for a nonlinear model (monitor.h). Never steps; its
// updates carry the innovations at the reference, the scores and the information's diagonal.
class HeldEkf final : public OnlineEstimator {
 public:
  static Result<HeldEkf> Create(std::shared_ptr<const model::NonlinearModel> model,
                                const Reference& reference, std::vector<int> tracked,
                                RecursiveOptions::Start start);

  Result<std::vector<RecursiveUpdate>> Push(const Sample& row) override;
  const std::vector<int>& tracked() const override { return tracked_; }
  const std::vector<std::string>& tracked_names() const override { return names_; }
  const model::ModelSpec& spec() const override { return stream_.model().spec(); }
  const std::vector<double>& theta() const override { return stream_.theta(); }
  Eigen::MatrixXd Covariance() const override { return {}; }
  std::string Method() const override { return "extended Kalman filter held at the reference"; }

 private:
  HeldEkf(EkfStream stream, std::vector<int> tracked, std::vector<std::string> names)
      : stream_(std::move(stream)), tracked_(std::move(tracked)), names_(std::move(names)) {}
  EkfStream stream_;
  std::vector<int> tracked_;
  std::vector<std::string> names_;
};

// An EkfStep as the estimators report a row (the score and the information's diagonal copied).
RecursiveUpdate ToUpdate(const EkfStep& step);

}  // namespace gb::online
