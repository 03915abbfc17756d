// Formula edits as the Equations view emits them: validated by the model file's parser (a
// refused formula names its JSON path and the column), applied to the model the estimation
// uses, and typed through the real view with synthetic keystrokes.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/project/problem.h"
#include "core/util/json.h"
#include "tests/ui/workbench_driver.h"
#include "ui/edits/model_edit.h"

namespace gb::ui {
namespace {

using testing::kSource;
using testing::kTestProject;

model::ModelSpec FuelFilm() {
  auto spec = model::LoadModelFile(kSource + "/tests/data/ui/fuel_film.json");
  EXPECT_TRUE(spec.ok()) << spec.error().ToString();
  return *spec;
}

// log L of `spec` on the test data at its parameter values, with the delay fixed at 5 samples.
double Loglik(const model::ModelSpec& spec) {
  auto problem = project::LoadProblem(spec, {kSource + "/tests/data/ui/f1.csv"});
  EXPECT_TRUE(problem.ok()) << problem.error().ToString();
  auto likelihood = project::MakeLikelihood(*problem);
  EXPECT_TRUE(likelihood.ok()) << likelihood.error().ToString();
  const std::vector<double> theta = spec.Values();
  const std::vector<int> delay = {5};
  auto l = likelihood->Evaluate(theta, delay);
  EXPECT_TRUE(l.ok()) << l.error().ToString();
  return l->loglik;
}

TEST(FormulaEdit, AnObservationScaledByTwoEqualsTheGainDoubled) {
  // y = 2 Kb (mfv + mff) with Kb = k is the original model with Kb = 2k: an independent check
  // that the edited formula, not the old one, reaches the likelihood.
  auto edited = ApplyFormulaEdit(FuelFilm(), {"observation.ilambda", "2*Kb*(mfv + mff)"});
  ASSERT_TRUE(edited.ok()) << edited.error().ToString();
  EXPECT_EQ(edited->observation[0].text, "2*Kb*(mfv + mff)");
  model::ModelSpec doubled = FuelFilm();
  const int kb = doubled.ParameterIndex("Kb");
  doubled.parameters[static_cast<std::size_t>(kb)].value *= 2.0;
  EXPECT_NEAR(Loglik(*edited), Loglik(doubled), 1e-9 * std::abs(Loglik(doubled)));
  EXPECT_GT(std::abs(Loglik(*edited) - Loglik(FuelFilm())), 1.0);  // the edit matters
}

TEST(FormulaEdit, ASyntaxErrorNamesThePathAndTheColumn) {
  const std::string text = "(-mff + X*mfi)/tau_ff + foo^";
  auto edited = ApplyFormulaEdit(FuelFilm(), {"drift.mff", text});
  ASSERT_FALSE(edited.ok());
  EXPECT_EQ(edited.error().path, "drift.mff");
  // The expression ends after the '^': the parser stops one past the last character.
  EXPECT_EQ(edited.error().expr_col, static_cast<int>(text.size()) + 1);
}

TEST(FormulaEdit, AnUnknownNameIsRefusedAtItsColumn) {
  auto edited = ApplyFormulaEdit(FuelFilm(), {"drift.mff", "(-mff + X*mfi)/tau_gg"});
  ASSERT_FALSE(edited.ok());
  EXPECT_EQ(edited.error().path, "drift.mff");
  EXPECT_EQ(edited.error().expr_col, 16);  // "(-mff + X*mfi)/" is 15 characters
  EXPECT_NE(edited.error().message.find("tau_gg"), std::string::npos) << edited.error().message;
}

TEST(FormulaEdit, ANonlinearDriftIsTakenAndAStateInAVarianceRefused) {
  // A nonlinear drift makes the model one for the extended Kalman filter.
  auto edited = ApplyFormulaEdit(FuelFilm(), {"drift.mfv", "-mfv*mfv/tau_fv"});
  ASSERT_TRUE(edited.ok()) << edited.error().ToString();
  EXPECT_EQ(edited->drift[0].text, "-mfv*mfv/tau_fv");
  // A measurement variance may not depend on a state: the parser's reason, at the column.
  auto refused = ApplyFormulaEdit(FuelFilm(), {"measurement_variance.ilambda", "s2*mfv"});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().expr_col, 4);
  EXPECT_NE(refused.error().ToString().find("'mfv' cannot appear here"), std::string::npos);
}

TEST(FormulaEdit, APathThatIsNoFormulaIsRefused) {
  EXPECT_FALSE(ApplyFormulaEdit(FuelFilm(), {"drift.nonexistent", "0"}).ok());
  EXPECT_FALSE(ApplyFormulaEdit(FuelFilm(), {"parameters.X", "0"}).ok());
  EXPECT_FALSE(ApplyFormulaEdit(FuelFilm(), {"observation", "0"}).ok());
}

TEST(FormulaEdit, TheEkfOptionsAreTakenAndCheckedAsTheModelFileWould) {
  auto bdf = ApplyFormulaEdit(FuelFilm(), {"ekf.ode", "bdf"});
  ASSERT_TRUE(bdf.ok()) << bdf.error().ToString();
  EXPECT_EQ(bdf->ekf.method, model::OdeMethod::kBdf);
  auto rtol = ApplyFormulaEdit(FuelFilm(), {"ekf.rtol", " 1e-6 "});
  ASSERT_TRUE(rtol.ok()) << rtol.error().ToString();
  EXPECT_EQ(rtol->ekf.rtol, 1e-6);
  auto passes = ApplyFormulaEdit(FuelFilm(), {"ekf.iterations", "3"});
  ASSERT_TRUE(passes.ok()) << passes.error().ToString();
  EXPECT_EQ(passes->ekf.iterations, 3);
  auto text = ApplyFormulaEdit(FuelFilm(), {"ekf.rtol", "1e-6x"});
  ASSERT_FALSE(text.ok());
  EXPECT_EQ(text.error().path, "ekf.rtol");
  EXPECT_NE(text.error().message.find("not a number"), std::string::npos);
  auto half = ApplyFormulaEdit(FuelFilm(), {"ekf.iterations", "2.5"});
  ASSERT_FALSE(half.ok());
  EXPECT_NE(half.error().message.find("not a whole number"), std::string::npos);
  auto method = ApplyFormulaEdit(FuelFilm(), {"ekf.ode", "rk4"});
  ASSERT_FALSE(method.ok());
  EXPECT_EQ(method.error().path, "ekf.ode");  // the parser's own reason
  EXPECT_FALSE(ApplyFormulaEdit(FuelFilm(), {"ekf.nonexistent", "1"}).ok());
}

// The id of the formula field at `path` in the Equations view's child window.
ImGuiID FormulaFieldId(ImGuiWindow* window, const std::string& path) {
  return ImHashStr("##formula", 0, ImHashStr(path.c_str(), 0, window->ID));
}

// Clicks into the formula field at `path` and moves the cursor to the end of its text.
bool ClickIntoFormula(testing::WorkbenchDriver& d, const std::string& path) {
  ImGuiWindow* w = testing::WorkbenchDriver::FindWindow("##workbench/##view_", "##equations_");
  if (!w) return false;
  const ImGuiID id = FormulaFieldId(w, path);
  // Away first: ImGui::GetHoveredID() falls back to the previous frame's item, so a scan that
  // starts right after a click into this field would "find" it at the scan's first point.
  d.MouseTo(ImVec2(1, 1));
  const auto at = d.Find(w, id);
  if (!at) return false;
  d.Click(*at);
  if (ImGui::GetActiveID() != id) return false;
  constexpr int kEndKey = 35;  // our index into io.KeysDown for ImGuiKey_End
  ImGuiIO& io = ImGui::GetIO();
  io.KeyMap[ImGuiKey_End] = kEndKey;
  io.KeysDown[kEndKey] = true;
  d.Frame();
  io.KeysDown[kEndKey] = false;
  d.Frame();
  return ImGui::GetActiveID() == id;
}

TEST(EquationsView, ATypedFormulaIsValidatedLiveAndAppliedWhenTheFieldIsLeft) {
  testing::WorkbenchDriver d;
  d.Open(kTestProject);
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  d.state.view = View::kEquations;
  d.Frame();
  const int revision = d.state.model_revision;

  ASSERT_TRUE(ClickIntoFormula(d, "observation.ilambda"));
  d.Type(" + foo^");
  // Refused while typing, with the column, and nothing applied.
  const auto& drafts = d.state.equations_view.drafts;
  ASSERT_EQ(drafts.count("observation.ilambda"), 1u);
  ASSERT_TRUE(drafts.at("observation.ilambda").error);
  EXPECT_EQ(drafts.at("observation.ilambda").text, "Kb*(mfv + mff) + foo^");
  EXPECT_EQ(drafts.at("observation.ilambda").error->expr_col, 22);
  d.PressEnter();
  EXPECT_EQ(d.state.model_revision, revision);
  EXPECT_EQ(d.state.model->observation[0].text, "Kb*(mfv + mff)");
  // The draft is kept (nothing typed is lost) and the view says what is wrong, and where.
  const std::string text = d.Text();
  EXPECT_NE(text.find("Kb*(mfv + mff) + foo^"), std::string::npos) << text;
  EXPECT_NE(text.find("observation.ilambda, column 22"), std::string::npos) << text;
}

TEST(EquationsView, AValidFormulaReplacesTheModelsFormula) {
  testing::WorkbenchDriver d;
  d.Open(kTestProject);
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  d.state.view = View::kEquations;
  d.Frame();
  const int revision = d.state.model_revision;

  ASSERT_TRUE(ClickIntoFormula(d, "observation.ilambda"));
  d.Type(" * 2");
  EXPECT_FALSE(d.state.equations_view.drafts.at("observation.ilambda").error);
  d.PressEnter();
  EXPECT_EQ(d.state.model_revision, revision + 1);
  EXPECT_EQ(d.state.model->observation[0].text, "Kb*(mfv + mff) * 2");
  EXPECT_TRUE(d.state.equations_view.drafts.empty());
  // The project's copy of the model (what the view shows and a save writes) follows.
  EXPECT_EQ(d.state.project->model_json["observation"]["ilambda"], "Kb*(mfv + mff) * 2");
}

// A nonlinear model's Equations view has the EKF's options: a typed number is checked and, when
// the field is left, applied to the model and the project's copy (as a number).
TEST(EquationsView, ANonlinearModelsEkfOptionsAreEditedInTheView) {
  testing::WorkbenchDriver d;
  d.Open(kSource + "/assets/projects/cascaded_tanks.json");
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  d.state.view = View::kEquations;
  d.Frame();
  EXPECT_NE(d.Text().find("Extended Kalman filter"), std::string::npos);
  // The section is at the view's end: scrolled into sight as the user would.
  ImGuiWindow* view = testing::WorkbenchDriver::FindWindow("##workbench/##view_", "##equations_");
  ASSERT_NE(view, nullptr);
  d.MouseTo(view->Rect().GetCenter());
  for (int i = 0; i < 20 && view->Scroll.y < view->ScrollMax.y; ++i) {
    ImGui::GetIO().MouseWheel = -5.0f;  // the wheel, down
    d.Frame();
  }
  ASSERT_EQ(view->Scroll.y, view->ScrollMax.y);
  ASSERT_TRUE(ClickIntoFormula(d, "ekf.iterations"));
  d.Type("x");
  ASSERT_TRUE(d.state.equations_view.drafts.at("ekf.iterations").error);
  d.PressEnter();
  EXPECT_EQ(d.state.model->ekf.iterations, 1);
  d.state.equations_view.drafts.clear();  // the refused draft dropped (the driver has no Backspace)
  ASSERT_TRUE(ClickIntoFormula(d, "ekf.iterations"));
  d.Type("2");  // "1" -> "12"
  d.PressEnter();
  EXPECT_EQ(d.state.model->ekf.iterations, 12);
  EXPECT_EQ(d.state.project->model_json["ekf"]["iterations"], 12);
}

}  // namespace
}  // namespace gb::ui
