// A small nonlinear model for the EKF tests (ekf_estimate_test.cpp, augmented_test.cpp): a tank
// draining through an orifice, a level-dependent diffusion, a sensor with a square term; and its
// sample paths under a PRBS inflow.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "core/data/dataset.h"
#include "core/design/prbs.h"
#include "core/filter/kalman.h"
#include "core/model/nonlinear_model.h"
#include "core/sim/sde.h"
#include "core/util/json.h"

namespace gb::testing {

inline const char* const kTank = R"json({
  "greybench_model": 1,
  "states": ["h"], "inputs": ["u"], "outputs": ["y"],
  "parameters": {
    "k": {"value": 0.3, "lower": 0.01, "upper": 5},
    "a": {"value": 0.3, "lower": 0.01, "upper": 5},
    "s": {"value": 0.05, "lower": 1e-4, "upper": 1},
    "r": {"value": 0.01, "lower": 1e-6, "upper": 1},
    "h0": {"value": 1.0, "lower": 0.1, "upper": 10}
  },
  "drift": {"h": "k*u - a*sqrt(h)"},
  "diffusion": {"h": "s*sqrt(h)"},
  "observation": {"y": "h + 0.1*h^2"},
  "measurement_variance": {"y": "r"},
  "initial_state": {"h": "h0"}
})json";

inline std::shared_ptr<const model::NonlinearModel> CompileTank(const Json& j) {
  auto spec = model::ParseModel(j, "tank.json");
  EXPECT_TRUE(spec) << spec.error().ToString();
  auto nm = model::NonlinearModel::Compile(*spec);
  EXPECT_TRUE(nm) << nm.error().ToString();
  return std::make_shared<const model::NonlinearModel>(std::move(*nm));
}

// The tank model at the truth: k = 0.8, a = 0.5, s = 0.08, r = 0.004, h0 = 2.5 (steady level
// (k u / a)² ≈ 2.6).
inline Json TankTruth() {
  Json truth = Json::parse(kTank);
  truth["parameters"]["k"]["value"] = 0.8;
  truth["parameters"]["a"]["value"] = 0.5;
  truth["parameters"]["s"]["value"] = 0.08;
  truth["parameters"]["r"]["value"] = 0.004;
  truth["parameters"]["h0"]["value"] = 2.5;
  return truth;
}

// A sample path of `truth` (a model with the tank's input and output) under a PRBS inflow between
// 0.7 and 1.3 (bit period 4 s), sampled every 0.5 s.
inline std::shared_ptr<const data::Series> SimulateTank(std::uint64_t seed, double duration = 300.0,
                                                        const Json& truth = TankTruth()) {
  const auto nm = CompileTank(truth);
  design::PrbsOptions o;
  o.order = 6;
  o.bit_period = 4.0;
  o.sample_time = 0.5;
  o.duration = duration;
  o.low = 0.7;
  o.high = 1.3;
  auto u = *design::MakePrbs(o);
  data::Series s;
  s.source = "tank.csv";
  s.time = u.t;
  s.U = Eigen::Map<const Eigen::MatrixXd>(u.u.data(), 1, static_cast<Eigen::Index>(u.u.size()));
  s.Y.setZero(1, static_cast<Eigen::Index>(u.t.size()));
  s.intervals = data::GroupIntervals(s.time);
  auto path = sim::SamplePath(*nm, nm->spec().Values(), s,
                              filter::FilterSettings::FromModel(nm->spec()), seed);
  EXPECT_TRUE(path) << path.error().ToString();
  s.Y = path->Y;
  return std::make_shared<const data::Series>(std::move(s));
}

}  // namespace gb::testing
