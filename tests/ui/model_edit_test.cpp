// Parameter edits as the Parameters view emits them: accepted exactly when the model file
// would accept the same change, refused with the parser's reason otherwise.
#include "ui/edits/model_edit.h"

#include <tuple>

#include <gtest/gtest.h>

#include "core/util/json.h"
#include "ui/state/app_state.h"

namespace gb::ui {
namespace {

model::ModelSpec Model() {
  const Json j = Json::parse(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {"a": {"value": 0.5, "lower": 0.1, "upper": 2, "unit": "1/s"},
                   "b": {"value": 1, "fixed": true},
                   "s": {"value": 0.01, "lower": 0, "upper": 1}},
    "drift": {"x": "-a*x + b*u"}, "diffusion": {"x": "sqrt(s)"},
    "observation": {"y": "x"}, "measurement_variance": {"y": "0.01"}})json");
  auto spec = model::ParseModel(j, "test.json");
  EXPECT_TRUE(spec.ok()) << spec.error().ToString();
  return *spec;
}

ParameterEdit Edit(const std::string& name, ParameterField field, const std::string& text) {
  auto edit = ParseParameterEdit(name, field, text);
  EXPECT_TRUE(edit.ok()) << edit.error().message;
  return *edit;
}

TEST(ModelEdit, AStartValueInsideTheBoundsIsAccepted) {
  auto edited = ApplyParameterEdit(Model(), Edit("a", ParameterField::kValue, "1.5"));
  ASSERT_TRUE(edited.ok()) << edited.error().message;
  EXPECT_EQ(edited->parameters[0].value, 1.5);
  EXPECT_EQ(edited->parameters[0].unit, "1/s");  // the rest of the parameter is kept
}

TEST(ModelEdit, AStartValueOutsideTheBoundsIsRefusedWithTheReason) {
  auto edited = ApplyParameterEdit(Model(), Edit("a", ParameterField::kValue, "3"));
  ASSERT_FALSE(edited.ok());
  EXPECT_NE(edited.error().message.find("outside the bounds [0.1, 2]"), std::string::npos)
      << edited.error().message;
}

TEST(ModelEdit, InvertedBoundsAreRefused) {
  auto edited = ApplyParameterEdit(Model(), Edit("a", ParameterField::kUpper, "0.05"));
  ASSERT_FALSE(edited.ok());
  EXPECT_NE(edited.error().message.find("inverted"), std::string::npos) << edited.error().message;
}

TEST(ModelEdit, AnEmptyBoundRemovesIt) {
  auto edited = ApplyParameterEdit(Model(), Edit("a", ParameterField::kUpper, "  "));
  ASSERT_TRUE(edited.ok());
  EXPECT_FALSE(edited->parameters[0].upper);
  EXPECT_EQ(edited->parameters[0].lower, 0.1);
}

TEST(ModelEdit, TextThatIsNotANumberIsRefusedBeforeTheModelSeesIt) {
  EXPECT_FALSE(ParseParameterEdit("a", ParameterField::kValue, "1.5x").ok());
  EXPECT_FALSE(ParseParameterEdit("a", ParameterField::kValue, "").ok());
  EXPECT_FALSE(ParseParameterEdit("a", ParameterField::kLower, "1e999").ok());
}

TEST(ModelEdit, FreeingAParameterWhoseValueIsOutsideItsBoundsIsRefused) {
  model::ModelSpec m = Model();
  auto bounded = ApplyParameterEdit(m, Edit("b", ParameterField::kUpper, "0.5"));
  ASSERT_TRUE(bounded.ok()) << "a fixed value may lie outside its bounds";
  ParameterEdit free;
  free.parameter = "b";
  free.field = ParameterField::kFixed;
  free.fixed = false;
  EXPECT_FALSE(ApplyParameterEdit(*bounded, free).ok());
}

// A fit's estimates of a = 0.7, b = 1 (fixed) and s = 0.002.
estimate::EstimateSummary Estimates() {
  estimate::EstimateSummary s;
  for (const auto& [name, value, fixed] :
       {std::tuple{"a", 0.7, false}, std::tuple{"b", 1.0, true}, std::tuple{"s", 0.002, false}}) {
    estimate::ParameterEstimate e;
    e.name = name;
    e.estimate = value;
    e.fixed = fixed;
    s.parameters.push_back(e);
  }
  return s;
}

TEST(ModelEdit, UseEstimatesAsStartSetsTheFreeParametersOnly) {
  const estimate::EstimateSummary s = Estimates();
  auto edited = UseEstimatesAsStart(Model(), s);
  ASSERT_TRUE(edited.ok()) << edited.error().message;
  EXPECT_EQ(edited->parameters[0].value, 0.7);
  EXPECT_EQ(edited->parameters[1].value, 1.0);
  EXPECT_EQ(edited->parameters[2].value, 0.002);
}

TEST(ModelEdit, UseEstimatesAsStartTakesAnotherOptimumWhenAsked) {
  estimate::EstimateSummary s = Estimates();
  s.optima = {{100.0, 2, true, {0.7, 1.0, 0.002}}, {90.0, 1, true, {1.3, 1.0, 0.004}}};
  auto second = UseEstimatesAsStart(Model(), s, 1);
  ASSERT_TRUE(second.ok()) << second.error().message;
  EXPECT_EQ(second->parameters[0].value, 1.3);
  EXPECT_EQ(second->parameters[1].value, 1.0);  // fixed: left alone
  EXPECT_EQ(second->parameters[2].value, 0.004);
  // An optimum the fit does not have is refused, naming it.
  auto missing = UseEstimatesAsStart(Model(), s, 2);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("optimum number 3"), std::string::npos);
}

TEST(ApplyParameterEdits, ARefusedEditLeavesTheModelAndKeepsTheReason) {
  AppState state;
  state.model = Model();
  state.parameters_view.pending.push_back(Edit("a", ParameterField::kValue, "9"));
  const int revision = state.model_revision;
  ApplyParameterEdits(state);
  EXPECT_EQ(state.model->parameters[0].value, 0.5);
  EXPECT_EQ(state.model_revision, revision);
  ASSERT_TRUE(state.parameters_view.refusal);
  EXPECT_EQ(state.parameters_view.refusal->text, "9");
  EXPECT_TRUE(state.parameters_view.pending.empty());

  // The same cell edited again, acceptably: the refusal goes, the revision counts the change.
  state.parameters_view.pending.push_back(Edit("a", ParameterField::kValue, "0.6"));
  ApplyParameterEdits(state);
  EXPECT_FALSE(state.parameters_view.refusal);
  EXPECT_EQ(state.model->parameters[0].value, 0.6);
  EXPECT_EQ(state.model_revision, revision + 1);

  // Retyping the same number is no change.
  state.parameters_view.pending.push_back(Edit("a", ParameterField::kValue, "0.6"));
  ApplyParameterEdits(state);
  EXPECT_EQ(state.model_revision, revision + 1);
}

}  // namespace
}  // namespace gb::ui
