#include "core/model/model_structure.h"

#include <cmath>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "core/model/linear_model.h"
#include "core/project/problem.h"
#include "core/util/json.h"

namespace gb::model {
namespace {

// A small model whose names overlap on purpose: k and k1, a state and an output both named T,
// a parameter used inside a function call and a number with an exponent.
Json Tank() {
  return Json::parse(R"json({
    "greybench_model": 1,
    "name": "tank",
    "description": "kept as written",
    "states": ["T"],
    "inputs": ["u"],
    "outputs": ["T", "q"],
    "parameters": {
      "k":  {"value": 2, "lower": 0.1, "upper": 10, "unit": "s"},
      "k1": {"value": 0.5},
      "e5": {"value": 1},
      "s":  {"value": 0.1, "lower": 0}
    },
    "drift": {"T": "( -T + k1*u )/ k"},
    "diffusion": {"T": "sqrt(s)*exp(k - k)"},
    "observation": {"T": "T", "q": "e5 * 1e5 * T"},
    "measurement_variance": {"T": "s", "q": "s"},
    "output_delay": {"q": 2},
    "initial_state": {"T": "k1"}
  })json");
}

std::vector<std::string> Keys(const Json& object) {
  std::vector<std::string> keys;
  for (auto it = object.begin(); it != object.end(); ++it) keys.push_back(it.key());
  return keys;
}

TEST(ModelStructure, RenameRewritesWholeNamesOnlyAndKeepsTheRestOfTheText) {
  Result<Json> j = RenameName(Tank(), NameKind::kParameter, "k", "tau");
  ASSERT_TRUE(j) << j.error().message;
  EXPECT_EQ((*j)["drift"]["T"], "( -T + k1*u )/ tau");
  EXPECT_EQ((*j)["diffusion"]["T"], "sqrt(s)*exp(tau - tau)");
  EXPECT_EQ((*j)["observation"]["q"], "e5 * 1e5 * T");
  EXPECT_EQ((*j)["description"], "kept as written");
}

TEST(ModelStructure, RenameKeepsTheParameterInItsPlaceWithItsFields) {
  Result<Json> j = RenameName(Tank(), NameKind::kParameter, "k", "tau");
  ASSERT_TRUE(j) << j.error().message;
  EXPECT_EQ(Keys((*j)["parameters"]), (std::vector<std::string>{"tau", "k1", "e5", "s"}));
  EXPECT_EQ((*j)["parameters"]["tau"]["unit"], "s");
}

TEST(ModelStructure, RenameOfANameLikeAnExponentLeavesTheNumberAlone) {
  Result<Json> j = RenameName(Tank(), NameKind::kParameter, "e5", "gain");
  ASSERT_TRUE(j) << j.error().message;
  EXPECT_EQ((*j)["observation"]["q"], "gain * 1e5 * T");
  EXPECT_EQ(RenameInFormula("2.5E-3*e5 + .5e5 - 3e+5", "e5", "g"), "2.5E-3*g + .5e5 - 3e+5");
}

TEST(ModelStructure, RenameOfAStateRenamesItsFormulasKeysButNotTheOutputOfTheSameName) {
  Result<Json> j = RenameName(Tank(), NameKind::kState, "T", "x");
  ASSERT_TRUE(j) << j.error().message;
  EXPECT_EQ((*j)["states"], Json({"x"}));
  EXPECT_EQ((*j)["outputs"], Json({"T", "q"}));
  EXPECT_EQ((*j)["drift"], Json::parse(R"({"x": "( -x + k1*u )/ k"})"));
  EXPECT_EQ((*j)["initial_state"], Json::parse(R"({"x": "k1"})"));
  EXPECT_EQ((*j)["observation"], Json::parse(R"({"T": "x", "q": "e5 * 1e5 * x"})"));
}

TEST(ModelStructure, RenameOfAnOutputRenamesItsKeysAndNoFormula) {
  Result<Json> j = RenameName(Tank(), NameKind::kOutput, "q", "flow");
  ASSERT_TRUE(j) << j.error().message;
  EXPECT_EQ((*j)["outputs"], Json({"T", "flow"}));
  EXPECT_EQ(Keys((*j)["observation"]), (std::vector<std::string>{"T", "flow"}));
  EXPECT_EQ((*j)["output_delay"], Json::parse(R"({"flow": 2})"));
  Result<Json> same = RenameName(Tank(), NameKind::kOutput, "T", "Tm");
  ASSERT_TRUE(same) << same.error().message;
  EXPECT_EQ((*same)["drift"]["T"], "( -T + k1*u )/ k");  // the state T is another thing
}

TEST(ModelStructure, RenameOfAnInputFollowsItIntoTheFormulas) {
  Result<Json> j = RenameName(Tank(), NameKind::kInput, "u", "power");
  ASSERT_TRUE(j) << j.error().message;
  EXPECT_EQ((*j)["inputs"], Json({"power"}));
  EXPECT_EQ((*j)["drift"]["T"], "( -T + k1*power )/ k");
}

TEST(ModelStructure, DeleteIsRefusedNamingTheFormulasThatUseTheName) {
  Result<Json> k = DeleteName(Tank(), NameKind::kParameter, "k");
  ASSERT_FALSE(k);
  EXPECT_EQ(k.error().message, "cannot delete parameter 'k': drift.T and diffusion.T use it");
  Result<Json> u = DeleteName(Tank(), NameKind::kInput, "u");
  ASSERT_FALSE(u);
  EXPECT_EQ(u.error().message, "cannot delete input 'u': drift.T uses it");
}

TEST(ModelStructure, DeleteOfAnUnusedParameterRemovesOnlyIt) {
  Json model = Tank();
  model["observation"]["q"] = "1e5 * T";
  Result<Json> j = DeleteName(model, NameKind::kParameter, "e5");
  ASSERT_TRUE(j) << j.error().message;
  EXPECT_EQ(Keys((*j)["parameters"]), (std::vector<std::string>{"k", "k1", "s"}));
}

TEST(ModelStructure, DeleteOfAStateTakesItsOwnFormulasAndIsRefusedWhileOthersUseIt) {
  Result<Json> used =
      DeleteName(AddName(Tank(), NameKind::kState, "z").value(), NameKind::kState, "T");
  ASSERT_FALSE(used);
  EXPECT_EQ(used.error().message,
            "cannot delete state 'T': observation.T and observation.q use it");
  Result<Json> z = AddName(Tank(), NameKind::kState, "z");
  ASSERT_TRUE(z) << z.error().message;
  Result<Json> j = DeleteName(*z, NameKind::kState, "z");
  ASSERT_TRUE(j) << j.error().message;
  EXPECT_EQ(*j, Tank());
}

TEST(ModelStructure, DeleteOfAnOutputTakesItsFormulasAndDelay) {
  Result<Json> j = DeleteName(Tank(), NameKind::kOutput, "q");
  ASSERT_TRUE(j) << j.error().message;
  EXPECT_EQ((*j)["outputs"], Json({"T"}));
  EXPECT_FALSE((*j)["observation"].contains("q"));
  EXPECT_FALSE((*j)["measurement_variance"].contains("q"));
  EXPECT_TRUE((*j)["output_delay"].empty());
}

TEST(ModelStructure, DeleteOfTheLastStateOrOutputIsRefused) {
  Result<Json> j = DeleteName(BlankModel("b"), NameKind::kOutput, "y");
  ASSERT_FALSE(j);
  EXPECT_EQ(j.error().message, "cannot delete output 'y': the model needs at least one output");
}

TEST(ModelStructure, BadNamesAreRefusedWithTheReason) {
  const Json m = Tank();
  auto refused = [&](NameKind kind, const std::string& name) {
    Result<Json> j = AddName(m, kind, name);
    return j ? std::string("accepted") : j.error().message;
  };
  EXPECT_EQ(refused(NameKind::kState, ""), "cannot add state '': a state needs a name");
  EXPECT_EQ(refused(NameKind::kInput, "1u"),
            "cannot add input '1u': '1u' is not a valid name (letters, digits and _, not starting "
            "with a digit)");
  EXPECT_EQ(refused(NameKind::kInput, "a b"),
            "cannot add input 'a b': 'a b' is not a valid name (letters, digits and _, not "
            "starting with a digit)");
  EXPECT_EQ(refused(NameKind::kState, "exp"),
            "cannot add state 'exp': 'exp' is the name of a function and cannot name a state");
  EXPECT_EQ(refused(NameKind::kInput, "k1"),
            "cannot add input 'k1': 'k1' is already the name of a parameter");
  EXPECT_EQ(refused(NameKind::kOutput, "q"),
            "cannot add output 'q': 'q' is already the name of an output");
  EXPECT_EQ(refused(NameKind::kOutput, "u"),
            "cannot add output 'u': 'u' is already the name of an input");
  Parameter p;
  p.name = "s";
  Result<Json> dup = AddParameter(m, p);
  ASSERT_FALSE(dup);
  EXPECT_EQ(dup.error().message,
            "cannot add parameter 's': 's' is already the name of a parameter");
  Result<Json> rename = RenameName(m, NameKind::kParameter, "k", "k1");
  ASSERT_FALSE(rename);
  EXPECT_EQ(rename.error().message,
            "cannot rename parameter 'k' to 'k1': 'k1' is already the name of a parameter");
}

TEST(ModelStructure, AnOutputMayShareAStateName) {
  EXPECT_TRUE(AddName(BlankModel("b"), NameKind::kOutput, "x"));
}

TEST(ModelStructure, TheNameTIsRefusedWhileAFormulaUsesTheTime) {
  Json m = BlankModel("b");
  m["drift"]["x"] = "sin(t)";
  Result<Json> j = AddName(m, NameKind::kInput, "t");
  ASSERT_FALSE(j);
  EXPECT_EQ(j.error().message,
            "cannot add input 't': 't' is the time in drift.x; an input named t would take its "
            "place there");
  EXPECT_TRUE(AddName(BlankModel("b"), NameKind::kInput, "t"));
}

TEST(ModelStructure, AddedNamesBringFormulasThatParse) {
  Result<Json> j = AddName(BlankModel("b"), NameKind::kInput, "u");
  ASSERT_TRUE(j);
  j = AddName(*j, NameKind::kState, "z");
  ASSERT_TRUE(j);
  j = AddName(*j, NameKind::kOutput, "w");
  ASSERT_TRUE(j);
  Parameter k;
  k.name = "k";
  k.value = 3;
  k.lower = 0;
  k.unit = "1/s";
  j = AddParameter(*j, k);
  ASSERT_TRUE(j) << j.error().message;
  Result<ModelSpec> m = ParseModel(*j, "b.json");
  ASSERT_TRUE(m) << m.error().ToString();
  EXPECT_EQ(m->states, (std::vector<std::string>{"x", "z"}));
  EXPECT_EQ(m->inputs, (std::vector<std::string>{"u"}));
  EXPECT_EQ(m->outputs, (std::vector<std::string>{"y", "w"}));
  EXPECT_EQ(m->observation[1].text, "x");  // observed through the first state
  EXPECT_EQ(m->drift[1].text, "0");
  ASSERT_EQ(m->parameters.size(), 3u);
  EXPECT_EQ(m->parameters[2].unit, "1/s");
  EXPECT_EQ(m->parameters[2].lower, 0.0);
}

TEST(ModelStructure, OptionsAndParameterFieldsReachTheParsedModel) {
  Result<Json> j = SetModelName(Tank(), "exhaust");
  ASSERT_TRUE(j);
  j = SetInputHold(*j, InputHold::kFoh);
  ASSERT_TRUE(j);
  j = SetInitialCovariance(*j, InitialCovariance::kExplicit);
  ASSERT_TRUE(j);
  j = SetParameterText(*j, "k1", ParameterText::kDescription, "gain");
  ASSERT_TRUE(j);
  j = SetParameterText(*j, "k", ParameterText::kUnit, "");
  ASSERT_TRUE(j);
  j = SetParameterPrior(*j, "s", Parameter::Prior{0.1, 0.02});
  ASSERT_TRUE(j);
  Result<ModelSpec> m = ParseModel(*j, "");
  ASSERT_TRUE(m) << m.error().ToString();
  EXPECT_EQ(m->name, "exhaust");
  EXPECT_EQ(m->input_hold, InputHold::kFoh);
  EXPECT_EQ(m->initial_covariance, InitialCovariance::kExplicit);
  ASSERT_EQ(m->initial_variance.size(), 1u);
  EXPECT_EQ(m->initial_variance[0].text, "1");
  EXPECT_EQ(m->parameters[1].description, "gain");
  EXPECT_EQ(m->parameters[0].unit, "");
  ASSERT_TRUE(m->parameters[3].prior);
  EXPECT_EQ(m->parameters[3].prior->sd, 0.02);
  EXPECT_FALSE(SetParameterPrior(*j, "s", Parameter::Prior{0.1, 0.0}));
  EXPECT_FALSE(SetParameterText(*j, "nope", ParameterText::kUnit, "s"));
}

TEST(ModelStructure, TheBlankModelParses) {
  Result<ModelSpec> m = ParseModel(BlankModel("new"), "");
  ASSERT_TRUE(m) << m.error().ToString();
  EXPECT_EQ(m->name, "new");
  EXPECT_EQ(m->states.size(), 1u);
  EXPECT_EQ(m->outputs.size(), 1u);
}

TEST(ModelStructure, AGeneratedModelHasAFirstOrderStatePerOutput) {
  ColumnsModelRequest r;
  r.name = "engine";
  r.inputs = {{"n", 800.0, 50.0}, {"load", 0.2, 0.1}};
  r.outputs = {{"Tex", 400.0, 30.0}, {"Tcat", std::nullopt, std::nullopt}};
  r.duration = 600;
  Result<Json> j = ModelFromColumns(r);
  ASSERT_TRUE(j) << j.error().message;
  Result<ModelSpec> m = ParseModel(*j, "");
  ASSERT_TRUE(m) << m.error().ToString();
  EXPECT_EQ(m->states, (std::vector<std::string>{"x_Tex", "x_Tcat"}));
  EXPECT_EQ(m->inputs, (std::vector<std::string>{"n", "load"}));
  EXPECT_EQ(m->outputs, (std::vector<std::string>{"Tex", "Tcat"}));
  EXPECT_EQ(m->parameters.size(), 2u * (4 + 2));
  // dx = (-x + b_n*n + b_load*load)/tau at a point, against the formula written out by hand.
  std::map<std::string, double> at = {{"x_Tex", 3},   {"n", 5},        {"load", 7},
                                      {"tau_Tex", 2}, {"b_Tex_n", 11}, {"b_Tex_load", 13}};
  auto lookup = [&](const std::string& name) { return at.at(name); };
  EXPECT_DOUBLE_EQ(expr::EvaluateTree(m->drift[0].expr, lookup), (-3 + 11 * 5 + 13 * 7) / 2.0);
  EXPECT_EQ(m->observation[1].text, "x_Tcat");
  const Parameter& tau = m->parameters[static_cast<std::size_t>(m->ParameterIndex("tau_Tex"))];
  EXPECT_EQ(tau.value, 60.0);
  EXPECT_EQ(m->parameters[static_cast<std::size_t>(m->ParameterIndex("x0_Tex"))].value, 400.0);
  EXPECT_EQ(m->parameters[static_cast<std::size_t>(m->ParameterIndex("e_Tex"))].value, 3.0);
}

// The generated model is the linear first-order model it says it is (A = -1/tau, B = b/tau,
// C = 1, S = e^2), and its likelihood on data with those columns is finite at the start values.
TEST(ModelStructure, AGeneratedModelIsLinearAndFitsDataOfItsShape) {
  ColumnsModelRequest r;
  r.name = "fuel";
  r.inputs = {{"mfi", 1.5, 0.3}};
  r.outputs = {{"ilambda", 0.01, 0.002}};
  r.duration = 10;
  Result<Json> j = ModelFromColumns(r);
  ASSERT_TRUE(j) << j.error().message;
  Result<ModelSpec> spec = ParseModel(*j, "");
  ASSERT_TRUE(spec) << spec.error().ToString();
  Result<LinearModel> linear = LinearModel::Compile(*spec);
  ASSERT_TRUE(linear) << linear.error().ToString();
  std::vector<double> theta = spec->Values();
  auto set = [&](const char* name, double v) {
    theta[static_cast<std::size_t>(spec->ParameterIndex(name))] = v;
  };
  set("tau_ilambda", 0.5);
  set("b_ilambda_mfi", 0.02);
  set("e_ilambda", 0.003);
  Result<StateSpace> ss = linear->Evaluate(theta);
  ASSERT_TRUE(ss) << ss.error().ToString();
  EXPECT_DOUBLE_EQ(ss->A(0, 0), -1 / 0.5);
  EXPECT_DOUBLE_EQ(ss->B(0, 0), 0.02 / 0.5);
  EXPECT_DOUBLE_EQ(ss->C(0, 0), 1.0);
  EXPECT_DOUBLE_EQ(ss->S(0), 0.003 * 0.003);

  Result<project::Problem> problem = project::LoadProblem(
      *spec, std::vector<std::string>{std::string(GREYBENCH_SOURCE_DIR) + "/tests/data/ui/f1.csv"});
  ASSERT_TRUE(problem) << problem.error().ToString();
  Result<filter::Likelihood> likelihood = project::MakeLikelihood(*problem);
  ASSERT_TRUE(likelihood) << likelihood.error().ToString();
  const std::vector<int> no_delay = {0};
  auto l = likelihood->Evaluate(spec->Values(), no_delay);
  ASSERT_TRUE(l) << l.error().ToString();
  EXPECT_TRUE(std::isfinite(l->loglik));
}

TEST(ModelStructure, AGeneratedModelRefusesAColumnThatCannotBeAName) {
  ColumnsModelRequest r;
  r.inputs = {{"T exhaust [C]", {}, {}}};
  r.outputs = {{"y", {}, {}}};
  Result<Json> j = ModelFromColumns(r);
  ASSERT_FALSE(j);
  EXPECT_EQ(j.error().message,
            "column 'T exhaust [C]' cannot be an input: a model's names are letters, digits and "
            "_, not starting with a digit");
  r.inputs.clear();
  r.outputs.clear();
  EXPECT_FALSE(ModelFromColumns(r));
}

}  // namespace
}  // namespace gb::model
