// Fixtures shared by the filter tests (kalman_test, predict_test): a two-output model with
// coupled states, direct feedthrough and constants everywhere, and series built directly.
#pragma once

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "core/data/dataset.h"
#include "core/model/linear_model.h"
#include "core/util/json.h"

namespace gb::filter::fixtures {

inline model::LinearModel CompileModel(const char* json_text) {
  auto spec = model::ParseModel(Json::parse(json_text), "test.json");
  EXPECT_TRUE(spec.ok()) << (spec.ok() ? "" : spec.error().ToString());
  auto lm = model::LinearModel::Compile(std::move(*spec));
  EXPECT_TRUE(lm.ok()) << (lm.ok() ? "" : lm.error().ToString());
  return std::move(*lm);
}

inline data::Series MakeSeries(const std::vector<double>& t, const Eigen::MatrixXd& U,
                               const Eigen::MatrixXd& Y) {
  data::Series s;
  s.source = "test.csv";
  s.time = t;
  s.U = U;
  s.Y = Y;
  s.intervals = data::GroupIntervals(t);
  return s;
}

// Two coupled states, two inputs, two outputs (one reading an input directly), constants
// everywhere.
inline const char* const kTwoOutputModel = R"json({
  "greybench_model": 1,
  "states": ["x1", "x2"], "inputs": ["u1", "u2"], "outputs": ["y1", "y2"],
  "parameters": {"a": 1.3, "b": 0.4, "k": 2.0, "s1": 0.3, "s2": 0.6, "r1": 0.05, "r2": 0.2,
                 "m1": 0.5, "m2": -1.0},
  "drift": {"x1": "-a*x1 + b*x2 + k*u1 + 0.1",
            "x2": "-(x2 - x1)/k - 0.5*b*x1 + u2 - 0.2"},
  "diffusion": {"x1": "s1", "x2": "s2"},
  "observation": {"y1": "x1 + 0.5*x2 + 0.3*u2 + 1", "y2": "2*x2 - x1"},
  "measurement_variance": {"y1": "r1", "y2": "r2"},
  "initial_state": {"x1": "m1", "x2": "m2"}
})json";

// Irregular times, a square-wave and a sine input, standard-normal outputs with a fraction missing.
inline data::Series RandomSeries(int N, int p, double missing_fraction, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> t(N);
  t[0] = 0.3;
  for (int k = 1; k < N; ++k) t[k] = t[k - 1] + (k % 3 == 0 ? 0.25 : 0.1 + 0.4 * unit(rng));
  Eigen::MatrixXd U(2, N), Y(p, N);
  for (int k = 0; k < N; ++k) {
    U(0, k) = (k / 4) % 2 ? 1.0 : -1.0;
    U(1, k) = std::sin(0.7 * k);
    for (int o = 0; o < p; ++o)
      Y(o, k) =
          unit(rng) < missing_fraction ? std::numeric_limits<double>::quiet_NaN() : normal(rng) + 1;
  }
  return MakeSeries(t, U, Y);
}

}  // namespace gb::filter::fixtures
