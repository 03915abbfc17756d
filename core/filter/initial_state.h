// A record's own initial state, from its first samples: for a record the model was not fitted to
// (a validation record), which starts where the model's x0, fitted on another record, says
// nothing about.
//
//   1. The prior: the model's x0 with a wide covariance, P_w = P0 + diag((10 s_i)²),
//      s_i = max(|x0_i|, sqrt(P0_ii), 1): wide against any state of the model's scale, so that
//      the first samples decide where the record starts.
//   2. The filter over the first n rows from (x0, P_w), then the smoother back to the first row
//      (Rauch-Tung-Striebel, or its extended form for the EKF): x̂_{0|n} and P_{0|n}, the state at
//      the first row given those n rows.
//
// The result goes into FilterSettings::x0 and P0 for the whole record: the filter's predictions
// and the simulation then start there. The first n rows have been used twice (to place the start
// and again by the filter); figures that judge a model on a validation record leave them out
// (ValidationFigures).
#pragma once

#include <span>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/filter/kalman.h"
#include "core/model/linear_model.h"
#include "core/model/nonlinear_model.h"
#include "core/util/result.h"

namespace gb::filter {

struct InitialStateEstimate {
  Eigen::VectorXd x0;
  Eigen::MatrixXd P0;
  int samples = 0;  // the rows used
};

// The rows the initial state is taken from: 100, or a fifth of a shorter record (at least 2).
int InitialStateSamples(int rows);

// A linear model at θ (its state space), and a nonlinear one. `settings` as the filter takes
// them (their x0 and P0 are ignored); n >= 2 rows (fewer than the series has are used).
Result<InitialStateEstimate> EstimateInitialState(const model::StateSpace& ss,
                                                  const data::Series& series,
                                                  const FilterSettings& settings, int n);
Result<InitialStateEstimate> EkfEstimateInitialState(const model::NonlinearModel& model,
                                                     std::span<const double> theta,
                                                     const data::Series& series,
                                                     const FilterSettings& settings, int n);

// The first n rows of a series (n <= its size).
data::Series Head(const data::Series& series, int n);

}  // namespace gb::filter
