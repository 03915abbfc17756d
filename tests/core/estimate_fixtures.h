// Shared by the estimation tests (estimate_test.cpp, profile_test.cpp): a model compiled from JSON
// and a data series simulated from it with PRBS inputs.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "core/data/dataset.h"
#include "core/design/prbs.h"
#include "core/filter/kalman.h"
#include "core/model/linear_model.h"
#include "core/sim/simulate.h"
#include "core/util/json.h"

namespace gb::testing {

inline std::shared_ptr<const model::LinearModel> Compile(const Json& j) {
  auto spec = model::ParseModel(j, "test.json");
  EXPECT_TRUE(spec.ok()) << spec.error().ToString();
  auto lm = model::LinearModel::Compile(std::move(*spec));
  EXPECT_TRUE(lm.ok()) << lm.error().ToString();
  return std::make_shared<const model::LinearModel>(std::move(*lm));
}

// PRBS inputs (one column per entry of `prbs`), simulated outputs from `truth` at its values.
inline std::shared_ptr<const data::Series> Simulate(const model::LinearModel& truth,
                                                    const std::vector<design::PrbsOptions>& prbs,
                                                    std::uint64_t seed) {
  data::Series s;
  s.source = "simulated";
  for (std::size_t i = 0; i < prbs.size(); ++i) {
    auto u = *design::MakePrbs(prbs[i]);
    if (i == 0) {
      s.time = u.t;
      s.U.resize(static_cast<Eigen::Index>(prbs.size()), static_cast<Eigen::Index>(u.t.size()));
    }
    for (std::size_t k = 0; k < u.u.size(); ++k) s.U(i, k) = u.u[k];
  }
  s.Y.setZero(truth.n_outputs(), static_cast<Eigen::Index>(s.time.size()));
  s.intervals = data::GroupIntervals(s.time);
  const auto ss = *truth.Evaluate(truth.spec().Values());
  sim::SimulateOptions o;
  o.seed = seed;
  s.Y = sim::Simulate(ss, s, filter::FilterSettings::FromModel(truth.spec()), o)->Y;
  return std::make_shared<const data::Series>(std::move(s));
}

}  // namespace gb::testing
