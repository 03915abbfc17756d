// The linearisation of a fitted nonlinear model at every operating point of a sweep, beside the
// per-point linear fits (the project key operating_points.linearised, operating_points.h): at
// each point the steady state its tags give (core/model/linearise.h) and the named quantities,
// with standard errors by the delta method from the fit's covariance.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/model/linearise.h"
#include "core/model/model.h"
#include "core/model/nonlinear_model.h"
#include "core/project/operating_points.h"
#include "core/project/sweep.h"
#include "core/util/result.h"

namespace gb::project {

struct LinearisedAtPoint {
  OperatingPoint point;
  std::string error;  // why this point has no linearisation ("" when it has)
  model::Linearisation lin;
};

struct LinearisedSweep {
  std::string model_name;
  std::string result;                   // the result file the estimates came from
  std::vector<std::string> quantities;  // names, in the order of every point's values
  std::vector<LinearisedAtPoint> points;
  // The quantity named `name` at point i: its value and SE (NaN when absent or failed).
  std::pair<double, double> At(std::size_t i, const std::string& name) const;
};

// The fit the linearisations use: θ (all parameters) and the covariance of the free ones.
struct NonlinearFit {
  std::vector<double> theta;
  std::vector<int> free;
  Eigen::MatrixXd covariance;
};

// Linearises at each point. A point whose tags lack one `spec.point` names, or where no steady
// state is found, gets its `error` and the others go on; an expression that does not parse, and a
// model whose drift or observation uses the time t, is an Error for the whole sweep.
Result<LinearisedSweep> LineariseAtPoints(const model::NonlinearModel& model,
                                          const NonlinearFit& fit, const LinearisedSpec& spec,
                                          const std::vector<OperatingPoint>& points);

// The same from files: the model (`spec.model`, else `project_model`), the result file's
// estimates and covariance, and the tags of every data file.
Result<LinearisedSweep> LineariseAtPoints(const LinearisedSpec& spec,
                                          const std::string& project_model,
                                          const std::vector<std::string>& datasets);

// The same with the model given (the workbench's, which may hold unsaved edits); `spec.model`
// is not read.
Result<LinearisedSweep> LineariseAtPoints(const LinearisedSpec& spec,
                                          const model::ModelSpec& model_spec,
                                          const std::vector<std::string>& datasets);

}  // namespace gb::project
