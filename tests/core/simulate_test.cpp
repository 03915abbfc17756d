// Sample paths of a linear model (core/sim/simulate.h): what they refuse rather than write.
#include "core/sim/simulate.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "core/data/dataset.h"
#include "core/filter/kalman.h"
#include "core/model/linear_model.h"
#include "core/model/model.h"
#include "core/util/json.h"

namespace gb::sim {
namespace {

TEST(Simulate, PathThatOverflowsIsANumericalErrorAtTheFirstRowPastIt) {
  // dx = x dt from x0 = 1 without noise: x(t) = e^t passes the largest double after
  // t = ln(DBL_MAX) = 709.78, so the row at t = 710 is named (file and line), not written as inf.
  auto spec = model::ParseModel(Json::parse(R"json({
    "greybench_model": 1,
    "states": ["x"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {"a": {"value": 1, "fixed": true}},
    "drift": {"x": "a*x + 0*u"},
    "observation": {"y": "x"},
    "measurement_variance": {"y": "0"},
    "initial_state": {"x": "1"}
  })json"),
                                "grow.json");
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  auto lm = model::LinearModel::Compile(*spec);
  ASSERT_TRUE(lm.ok()) << lm.error().ToString();
  auto ss = lm->Evaluate(spec->Values());
  ASSERT_TRUE(ss.ok());
  std::string csv = "t,u\n";
  for (int k = 0; k <= 800; ++k) csv += std::to_string(k) + ",0\n";
  auto data = data::ParseCsv(csv, "u.csv");
  ASSERT_TRUE(data.ok());
  const std::vector<std::string> inputs = {"u"};
  auto series = data::Bind(**data, inputs, {});
  ASSERT_TRUE(series.ok()) << series.error().ToString();
  SimulateOptions o;
  o.process_noise = o.measurement_noise = o.random_initial_state = false;
  auto sim = Simulate(*ss, **series, filter::FilterSettings::FromModel(*spec), o);
  ASSERT_FALSE(sim.ok());
  EXPECT_EQ(sim.error().kind, ErrorKind::kNumerical);
  EXPECT_EQ(sim.error().file, "u.csv");
  EXPECT_EQ(sim.error().line, 712);  // the header, then t = 0 on line 2
  EXPECT_NE(sim.error().message.find("the simulated state number 1 is inf at t = 710"),
            std::string::npos)
      << sim.error().message;
  // Up to t = 709 the same path is finite and e^t.
  std::string shorter = "t,u\n";
  for (int k = 0; k <= 709; ++k) shorter += std::to_string(k) + ",0\n";
  auto data2 = data::ParseCsv(shorter, "u.csv");
  ASSERT_TRUE(data2.ok());
  auto series2 = data::Bind(**data2, inputs, {});
  ASSERT_TRUE(series2.ok());
  auto fine = Simulate(*ss, **series2, filter::FilterSettings::FromModel(*spec), o);
  ASSERT_TRUE(fine.ok()) << fine.error().ToString();
  EXPECT_NEAR(std::log(fine->Y(0, 709)), 709, 1e-9);
}

TEST(Simulate, RefusesMoreValuesThanItsLimitBeforeAllocatingThem) {
  EXPECT_TRUE(CheckSimulationSize(50'000'000, 1, 1).ok());
  const Status st = CheckSimulationSize(50'000'001, 1, 1);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().kind, ErrorKind::kInput);
  EXPECT_NE(st.error().message.find("50000001 rows of 1 states and 1 outputs are 1e+08 simulated "
                                    "values; at most 1e+08"),
            std::string::npos)
      << st.error().message;
}

}  // namespace
}  // namespace gb::sim
