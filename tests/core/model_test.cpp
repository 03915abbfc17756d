#include "core/model/model.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "core/model/linear_model.h"
#include "core/model/nonlinear_model.h"
#include "core/util/json.h"

namespace gb::model {
namespace {

// The fuel-film model of user guide §2 (paper eq. 13-14).
const char* kFuelFilm = R"json({
  "greybench_model": 1,
  "name": "Fuel film, eq. 13-14",
  "states":  ["mfv", "mff"],
  "inputs":  ["mfi"],
  "outputs": ["ilambda"],
  "parameters": {
    "tau_fv": {"value": 0.08, "lower": 0.005, "upper": 1.0, "unit": "s"},
    "tau_ff": {"value": 0.3, "lower": 0.01, "upper": 5.0, "unit": "s"},
    "X":      {"value": 0.2,  "lower": 0.0,   "upper": 1.0},
    "Kb":     {"value": 1.0, "fixed": true},
    "s11": {"value": 1e-3, "lower": 0}, "s12": {"value": 4e-4, "lower": 0},
    "s2": {"value": 1e-4, "lower": 0}
  },
  "drift":       {"mfv": "(-mfv + (1 - X)*mfi)/tau_fv", "mff": "(-mff + X*mfi)/tau_ff"},
  "diffusion":   {"mfv": "sqrt(s11)", "mff": "sqrt(s12)"},
  "observation": {"ilambda": "Kb*(mfv + mff)"},
  "measurement_variance": {"ilambda": "s2"},
  "output_delay":  {"ilambda": {"min": 0, "max": 10}},
  "initial_state": {"mfv": "0", "mff": "0"},
  "initial_covariance": "ctsm",
  "input_hold": "zoh",
  "robust_huber": 3
})json";

Json FuelFilm() { return Json::parse(kFuelFilm); }

Error ParseError(const Json& j) {
  auto m = ParseModel(j, "fuel.json");
  EXPECT_FALSE(m.ok()) << "expected an error";
  return m.ok() ? Error{} : m.error();
}

TEST(ParseModel, ReadsTheContractExampleInFileOrder) {
  auto m = ParseModel(FuelFilm(), "fuel.json");
  ASSERT_TRUE(m.ok()) << m.error().ToString();
  EXPECT_EQ(m->states, (std::vector<std::string>{"mfv", "mff"}));
  ASSERT_EQ(m->parameters.size(), 7u);
  EXPECT_EQ(m->parameters[0].name, "tau_fv");
  EXPECT_EQ(m->parameters[3].name, "Kb");
  EXPECT_TRUE(m->parameters[3].fixed);
  EXPECT_EQ(m->parameters[0].unit, "s");
  EXPECT_TRUE(m->output_delay[0].IsScan());
  EXPECT_EQ(m->output_delay[0].max, 10);
  ASSERT_TRUE(m->robust_huber.has_value());
  EXPECT_EQ(*m->robust_huber, 3.0);
}

TEST(ParseModel, RoundTripsThroughToJson) {
  auto m = ParseModel(FuelFilm(), "fuel.json");
  ASSERT_TRUE(m.ok());
  auto again = ParseModel(ToJson(*m), "again.json");
  ASSERT_TRUE(again.ok()) << again.error().ToString();
  EXPECT_EQ(ToJson(*again), ToJson(*m));
}

TEST(ParseModel, NamesTheColumnOfAnUnknownNameAndSuggestsTheClosest) {
  Json j = FuelFilm();
  j["drift"]["mff"] = "(-mff + X*mfi)/tauff";
  const Error e = ParseError(j);
  EXPECT_EQ(e.path, "drift.mff");
  EXPECT_EQ(e.expr_col, 16);
  EXPECT_NE(e.message.find("'tauff'"), std::string::npos);
  EXPECT_NE(e.message.find("did you mean 'tau_ff'"), std::string::npos);
  EXPECT_EQ(e.ToString().rfind("fuel.json: drift.mff, column 16: ", 0), 0u) << e.ToString();
}

TEST(ParseModel, ReportsASyntaxErrorWithItsColumn) {
  Json j = FuelFilm();
  j["observation"]["ilambda"] = "Kb*(mfv + mff";
  const Error e = ParseError(j);
  EXPECT_EQ(e.path, "observation.ilambda");
  EXPECT_GT(e.expr_col, 0);
}

TEST(ParseModel, RefusesInvertedBounds) {
  Json j = FuelFilm();
  j["parameters"]["X"]["lower"] = 1.0;
  j["parameters"]["X"]["upper"] = 0.0;
  const Error e = ParseError(j);
  EXPECT_EQ(e.path, "parameters.X");
  EXPECT_NE(e.message.find("inverted"), std::string::npos);
}

TEST(ParseModel, RefusesAStartValueOutsideItsBounds) {
  Json j = FuelFilm();
  j["parameters"]["tau_fv"]["value"] = 2.0;
  const Error e = ParseError(j);
  EXPECT_EQ(e.path, "parameters.tau_fv.value");
  EXPECT_NE(e.message.find("outside the bounds"), std::string::npos);
}

TEST(ParseModel, RefusesDuplicatedNames) {
  Json j = FuelFilm();
  j["states"] = {"mfv", "mfv"};
  EXPECT_EQ(ParseError(j).path, "states[1]");
  Json k = FuelFilm();
  k["inputs"] = {"X"};  // an input named like a parameter
  k["drift"]["mfv"] = "-mfv/tau_fv";
  k["drift"]["mff"] = "-mff/tau_ff";
  const Error e = ParseError(k);
  EXPECT_EQ(e.path, "parameters.X");
  EXPECT_NE(e.message.find("used twice"), std::string::npos);
}

TEST(ParseModel, RefusesAMissingEquationAndAnUnknownKey) {
  Json j = FuelFilm();
  j["drift"].erase("mff");
  const Error e = ParseError(j);
  EXPECT_EQ(e.path, "drift");
  EXPECT_NE(e.message.find("'mff'"), std::string::npos);
  Json k = FuelFilm();
  k["obsevation"] = k["observation"];
  const Error f = ParseError(k);
  EXPECT_NE(f.message.find("did you mean 'observation'"), std::string::npos);
}

TEST(ParseModel, RefusesStatesInVarianceButNotInDiffusion) {
  Json j = FuelFilm();
  j["measurement_variance"]["ilambda"] = "s2*mfv";
  const Error e = ParseError(j);
  EXPECT_EQ(e.path, "measurement_variance.ilambda");
  EXPECT_EQ(e.expr_col, 4);
  EXPECT_NE(e.message.find("inputs, parameters and the time t"), std::string::npos) << e.message;
  // A diffusion may depend on the states (the EKF evaluates it at the filtered mean), and any
  // formula of the dynamics on the time; neither is linear.
  Json k = FuelFilm();
  k["diffusion"]["mfv"] = "sqrt(s11)*mfv";
  auto spec = ParseModel(k, "fuel.json");
  ASSERT_TRUE(spec) << spec.error().ToString();
  auto linear = LinearModel::Compile(*spec);
  ASSERT_FALSE(linear);
  EXPECT_EQ(linear.error().path, "diffusion.mfv");
  EXPECT_EQ(linear.error().expr_col, 11);
  Json t = FuelFilm();
  t["drift"]["mfv"] = "(-mfv + (1 - X)*mfi*(1 + sin(t)))/tau_fv";
  auto timed = ParseModel(t, "fuel.json");
  ASSERT_TRUE(timed) << timed.error().ToString();
  EXPECT_FALSE(LinearModel::Compile(*timed));
  EXPECT_TRUE(NonlinearModel::Compile(*timed));
}

TEST(ParseModel, RefusesBadDelays) {
  Json j = FuelFilm();
  j["output_delay"]["ilambda"] = {{"min", 5}, {"max", 2}};
  EXPECT_EQ(ParseError(j).path, "output_delay.ilambda");
  Json k = FuelFilm();
  k["output_delay"]["ilambda"] = 1.5;
  EXPECT_EQ(ParseError(k).path, "output_delay.ilambda");
  Json l = FuelFilm();
  l["output_delay"]["lambda"] = 1;
  EXPECT_EQ(ParseError(l).path, "output_delay.lambda");
}

TEST(ParseModel, RefusesWrongJsonTypes) {
  Json j = FuelFilm();
  j["parameters"]["X"]["value"] = "0.2";
  const Error e = ParseError(j);
  EXPECT_EQ(e.path, "parameters.X.value");
  EXPECT_NE(e.message.find("expected a number"), std::string::npos);
  EXPECT_EQ(ParseError(Json::array()).path, "");
}

TEST(LinearModel, ExtractsTheMatricesOfEquations13And14) {
  auto spec = ParseModel(FuelFilm(), "fuel.json");
  ASSERT_TRUE(spec.ok());
  auto lm = LinearModel::Compile(std::move(*spec));
  ASSERT_TRUE(lm.ok()) << lm.error().ToString();
  std::vector<double> theta = lm->spec().Values();
  theta[0] = 0.075;   // tau_fv
  theta[1] = 0.375;   // tau_ff
  theta[2] = 0.175;   // X
  theta[3] = 0.8421;  // Kb
  auto ss = lm->Evaluate(theta);
  ASSERT_TRUE(ss.ok());
  EXPECT_DOUBLE_EQ(ss->A(0, 0), -1 / 0.075);
  EXPECT_DOUBLE_EQ(ss->A(1, 1), -1 / 0.375);
  EXPECT_EQ(ss->A(0, 1), 0.0);
  EXPECT_EQ(ss->A(1, 0), 0.0);
  EXPECT_DOUBLE_EQ(ss->B(0, 0), (1 - 0.175) / 0.075);
  EXPECT_DOUBLE_EQ(ss->B(1, 0), 0.175 / 0.375);
  EXPECT_DOUBLE_EQ(ss->C(0, 0), 0.8421);
  EXPECT_DOUBLE_EQ(ss->C(0, 1), 0.8421);
  EXPECT_EQ(ss->D(0, 0), 0.0);
  EXPECT_EQ(ss->c.norm(), 0.0);
  EXPECT_EQ(ss->d(0), 0.0);
  EXPECT_DOUBLE_EQ(ss->sigma(0), std::sqrt(1e-3));
  EXPECT_DOUBLE_EQ(ss->S(0), 1e-4);
}

TEST(LinearModel, KeepsConstantTermsAndDirectFeedthrough) {
  Json j = Json::parse(R"json({"greybench_model": 1, "states": ["x"], "inputs": ["u"],
    "outputs": ["y"], "parameters": {"a": 2, "b": 3},
    "drift": {"x": "a*(b - x) + 4*u"}, "observation": {"y": "x/a + b*u - 1"},
    "measurement_variance": {"y": "1"}})json");
  auto lm = LinearModel::Compile(*ParseModel(j, "m.json"));
  ASSERT_TRUE(lm.ok()) << lm.error().ToString();
  auto ss = lm->Evaluate(lm->spec().Values());
  ASSERT_TRUE(ss.ok());
  EXPECT_DOUBLE_EQ(ss->A(0, 0), -2);
  EXPECT_DOUBLE_EQ(ss->B(0, 0), 4);
  EXPECT_DOUBLE_EQ(ss->c(0), 6);
  EXPECT_DOUBLE_EQ(ss->C(0, 0), 0.5);
  EXPECT_DOUBLE_EQ(ss->D(0, 0), 3);
  EXPECT_DOUBLE_EQ(ss->d(0), -1);
}

TEST(LinearModel, RefusesANonlinearDriftNamingTheStateAndEquation) {
  Json j = FuelFilm();
  j["drift"]["mff"] = "(-mff*mff + X*mfi)/tau_ff";
  auto lm = LinearModel::Compile(*ParseModel(j, "fuel.json"));
  ASSERT_FALSE(lm.ok());
  EXPECT_EQ(lm.error().path, "drift.mff");
  EXPECT_NE(lm.error().message.find("not linear in 'mff'"), std::string::npos)
      << lm.error().message;
  Json k = FuelFilm();
  k["observation"]["ilambda"] = "Kb*mfv*mfi";
  auto lk = LinearModel::Compile(*ParseModel(k, "fuel.json"));
  ASSERT_FALSE(lk.ok());
  EXPECT_EQ(lk.error().path, "observation.ilambda");
  EXPECT_NE(lk.error().message.find("multiplies 'mfv' by 'mfi'"), std::string::npos)
      << lk.error().message;
}

TEST(LinearModel, ReportsANegativeVarianceAtEvaluation) {
  Json j = FuelFilm();
  j["measurement_variance"]["ilambda"] = "s2 - 1";
  auto lm = LinearModel::Compile(*ParseModel(j, "fuel.json"));
  ASSERT_TRUE(lm.ok());
  auto ss = lm->Evaluate(lm->spec().Values());
  ASSERT_FALSE(ss.ok());
  EXPECT_EQ(ss.error().kind, ErrorKind::kNumerical);
  EXPECT_NE(ss.error().message.find("measurement_variance.ilambda"), std::string::npos);
  EXPECT_NE(ss.error().message.find("negative"), std::string::npos);
}

TEST(LinearModel, ReportsANonFiniteEntry) {
  Json j = FuelFilm();
  j["parameters"]["tau_fv"] = {{"value", 0.0}};
  auto lm = LinearModel::Compile(*ParseModel(j, "fuel.json"));
  ASSERT_TRUE(lm.ok());
  auto ss = lm->Evaluate(lm->spec().Values());
  ASSERT_FALSE(ss.ok());
  EXPECT_NE(ss.error().message.find("A[mfv,mfv]"), std::string::npos) << ss.error().message;
}

TEST(SetParameter, RefusesUnknownNamesAndValuesOutsideBounds) {
  auto m = ParseModel(FuelFilm(), "fuel.json");
  ASSERT_TRUE(m.ok());
  EXPECT_TRUE(SetParameter(&*m, "X", 0.5).ok());
  EXPECT_EQ(m->parameters[2].value, 0.5);
  auto bad = SetParameter(&*m, "x", 0.5);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("did you mean 'X'"), std::string::npos);
  EXPECT_FALSE(SetParameter(&*m, "X", 1.5).ok());
  EXPECT_TRUE(SetParameter(&*m, "Kb", 7.0).ok()) << "a fixed parameter has no bounds to respect";
}

// Found by tests/fuzz/project_fuzz (a project file holding 1e400): nlohmann reports a number
// too large for a double as out_of_range, not parse_error, and the exception escaped ReadJsonFile,
// so greybench-cli terminated on such a model or project file.
TEST(LoadModelFile, ReportsANumberTooLargeForADoubleInsteadOfThrowing) {
  const std::string path =
      (std::filesystem::temp_directory_path() / "greybench_model_test_1e400.json").string();
  {
    std::ofstream out(path);
    out << R"({"greybench_model": 1, "states": ["x"], "parameters": {"a": {"value": 1e400}}})";
  }
  Result<ModelSpec> m = LoadModelFile(path);
  std::remove(path.c_str());
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().file, path);
  EXPECT_NE(m.error().message.find("out of range"), std::string::npos) << m.error().message;
  EXPECT_NE(m.error().message.find("1e400"), std::string::npos) << m.error().message;
}

}  // namespace
}  // namespace gb::model
