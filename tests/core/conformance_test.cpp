// Published results of other tools, reproduced.
#include <gtest/gtest.h>

#include "core/model/model.h"
#include "core/project/problem.h"
#include "core/util/json.h"

namespace gb {
namespace {

const std::string kData = GREYBENCH_TEST_DATA_DIR;

// CTSM-R's fit of building 3 (Leprince et al. 2022): log-likelihood 5930.09335342 at its
// estimates, with Huber c = 3, P0 = Q(Δ0), zero-order hold. See tests/data/building3/README.md.
TEST(Conformance, Building3LogLikelihoodEqualsCtsmR) {
  auto spec = model::LoadModelFile(kData + "/building3/model.json");
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  const std::vector<double> theta = spec->Values();
  auto problem = project::LoadProblem(std::move(*spec), {kData + "/building3/data.csv"});
  ASSERT_TRUE(problem.ok()) << problem.error().ToString();
  auto lik = project::MakeLikelihood(*problem);
  ASSERT_TRUE(lik.ok());
  auto l = lik->Evaluate(theta);
  ASSERT_TRUE(l.ok()) << l.error().ToString();
  EXPECT_EQ(l->n_obs, 6905);
  EXPECT_NEAR(l->loglik, 5930.09335342, 1e-6 * 5930.09335342);
}

}  // namespace
}  // namespace gb
