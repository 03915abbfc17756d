// The Equations view edits the model's structure: names added, renamed and deleted through the
// view's fields and buttons (synthetic clicks and keystrokes, tests/ui/workbench_driver.h), a
// parameter created from a formula's refusal, and undo/redo of every edit.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/estimate/estimate.h"
#include "core/model/model_structure.h"
#include "core/project/project.h"
#include "tests/ui/workbench_driver.h"
#include "ui/shell/shell.h"

namespace gb::ui {
namespace {

namespace fs = std::filesystem;
using testing::kSource;
using testing::WorkbenchDriver;

// A project beside a blank model file, fitted to the fuel-film test data (its columns are mfi and
// ilambda; the blank model's output y is renamed to ilambda before anything is fitted).
class EquationsStructure : public ::testing::Test {
 protected:
  static constexpr int kKeyA = 65, kKeyZ = 90, kKeyY = 89, kKeyEnd = 35;

  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("greybench-structure-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    std::ofstream(dir_ / "blank.model.json") << model::BlankModel("blank").dump(1);
    Json project = {{"greybench_project", 1},
                    {"name", "blank"},
                    {"model", "blank.model.json"},
                    {"datasets", {kSource + "/tests/data/ui/f1.csv"}}};
    std::ofstream(dir_ / "project.json") << project.dump(1);
    d_.Open((dir_ / "project.json").string());
    ASSERT_TRUE(d_.state.model) << d_.state.model_error;
    d_.state.view = View::kEquations;
    d_.Frame();
    ImGuiIO& io = ImGui::GetIO();
    io.KeyMap[ImGuiKey_A] = kKeyA;
    io.KeyMap[ImGuiKey_Z] = kKeyZ;
    io.KeyMap[ImGuiKey_Y] = kKeyY;
    io.KeyMap[ImGuiKey_End] = kKeyEnd;
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  static ImGuiWindow* View() {
    return WorkbenchDriver::FindWindow("##workbench/##view_", "##equations_");
  }

  // The id of a structure field or button drawn under PushID(control) in the view (`seed`: the
  // view's window, or the parameters table inside it).
  static ImGuiID Id(const std::string& control, const char* label, ImGuiID seed = 0) {
    return ImHashStr(label, 0, ImHashStr(control.c_str(), 0, seed ? seed : View()->ID));
  }
  static ImGuiID ParametersTable() { return ImHashStr("##parameters", 0, View()->ID); }

  bool Click(ImGuiID id) {
    d_.MouseTo(ImVec2(1, 1));  // GetHoveredID() falls back to the previous frame's item
    const auto at = d_.Find(View(), id);
    if (!at) return false;
    d_.Click(*at);
    return true;
  }
  void Key(int key, bool ctrl = false) {
    ImGuiIO& io = ImGui::GetIO();
    io.KeyCtrl = ctrl;
    io.KeysDown[key] = true;
    d_.Frame();
    io.KeysDown[key] = false;
    io.KeyCtrl = false;
    d_.Frame();
  }
  // Clicks into the field `id`, replaces its text by `text` and presses Enter.
  bool Retype(ImGuiID id, const char* text) {
    if (!Click(id) || ImGui::GetActiveID() != id) return false;
    Key(kKeyA, /*ctrl=*/true);  // select all: the typed text replaces it
    d_.Type(text);
    d_.PressEnter();
    return true;
  }
  // Types a name into the "new ..." field of `what` and presses its Add button.
  bool Add(const std::string& what, const char* name) {
    if (!Click(Id("add." + what, "##field"))) return false;
    d_.Type(name);
    return Click(ImHashStr(("Add " + what).c_str(), 0, View()->ID));
  }
  const Json& ModelJson() { return d_.state.project->model_json; }

  fs::path dir_;
  WorkbenchDriver d_;
};

TEST_F(EquationsStructure, ABlankModelGrowsAnInputAStateAnOutputAndAParameterOfferedByAFormula) {
  const int revision = d_.state.model_revision;
  ASSERT_TRUE(Add("input", "mfi"));
  ASSERT_TRUE(Add("state", "z"));
  ASSERT_TRUE(Add("output", "w"));
  EXPECT_EQ(d_.state.model->inputs, (std::vector<std::string>{"mfi"}));
  EXPECT_EQ(d_.state.model->states, (std::vector<std::string>{"x", "z"}));
  EXPECT_EQ(d_.state.model->outputs, (std::vector<std::string>{"y", "w"}));
  EXPECT_EQ(d_.state.model_revision, revision + 3);

  // A drift naming an unknown parameter: refused, with the offer to create it.
  const ImGuiID drift = Id("drift.z", "##formula");
  ASSERT_TRUE(Click(drift));
  Key(kKeyEnd);
  d_.Type("+k0*mfi");  // "0" -> "0+k0*mfi"
  ASSERT_TRUE(d_.state.equations_view.drafts.at("drift.z").error);
  d_.PressEnter();
  EXPECT_NE(d_.Text().find("Create parameter 'k0'"), std::string::npos);
  ASSERT_TRUE(Click(ImHashStr("Create parameter 'k0'", 0, ImHashStr("drift.z", 0, View()->ID))));
  // The parameter exists, the formula was checked again and applied.
  ASSERT_GE(d_.state.model->ParameterIndex("k0"), 0);
  EXPECT_EQ(d_.state.model->drift[1].text, "0+k0*mfi");
  EXPECT_TRUE(d_.state.equations_view.drafts.empty());
  EXPECT_EQ(ModelJson()["drift"]["z"], "0+k0*mfi");
  // The project's model JSON is the model: it parses to the same thing.
  Result<model::ModelSpec> reparsed = model::ParseModel(ModelJson(), "");
  ASSERT_TRUE(reparsed) << reparsed.error().ToString();
  EXPECT_EQ(model::ToJson(*reparsed), model::ToJson(*d_.state.model));
}

TEST_F(EquationsStructure, RenamingAParameterRewritesTheFormulasThatUseIt) {
  ASSERT_TRUE(Retype(Id("rename.parameter.sigma_y", "##field", ParametersTable()), "e"));
  EXPECT_EQ(d_.state.model->measurement_variance[0].text, "e^2");
  EXPECT_GE(d_.state.model->ParameterIndex("e"), 0);
  EXPECT_EQ(d_.state.model->ParameterIndex("sigma_y"), -1);
  EXPECT_EQ(ModelJson()["measurement_variance"]["y"], "e^2");
  // A state renamed in the variables row: its formulas' keys and every use follow.
  ASSERT_TRUE(Retype(Id("rename.state.x", "##field"), "level"));
  EXPECT_EQ(d_.state.model->states, (std::vector<std::string>{"level"}));
  EXPECT_EQ(ModelJson()["observation"]["y"], "level");
  EXPECT_EQ(ModelJson()["diffusion"]["level"], "sigma_x");
}

TEST_F(EquationsStructure, ADeleteAFormulaNeedsIsRefusedNamingTheFormula) {
  const int revision = d_.state.model_revision;
  ASSERT_TRUE(Click(Id("delete.parameter.sigma_x", "Delete", ParametersTable())));
  EXPECT_EQ(d_.state.model_revision, revision);
  ASSERT_TRUE(d_.state.equations_view.refusal);
  EXPECT_EQ(d_.state.equations_view.refusal->reason,
            "cannot delete parameter 'sigma_x': diffusion.x uses it");
  EXPECT_NE(d_.Text().find("cannot delete parameter 'sigma_x': diffusion.x uses it"),
            std::string::npos);
  // A bad new name is refused with its reason, and nothing changes.
  ASSERT_TRUE(Add("input", "exp"));
  EXPECT_EQ(d_.state.equations_view.refusal->reason,
            "cannot add input 'exp': 'exp' is the name of a function and cannot name an input");
  EXPECT_EQ(d_.state.model_revision, revision);
}

TEST_F(EquationsStructure, UndoAndRedoRestoreEveryEdit) {
  const Json blank = ModelJson();
  ASSERT_TRUE(Add("input", "u"));
  ASSERT_TRUE(Retype(Id("rename.output.y", "##field"), "ilambda"));
  const Json edited = ModelJson();
  EXPECT_EQ(edited["outputs"], Json({"ilambda"}));
  d_.MouseTo(ImVec2(1, 1));  // away from any field: the shortcuts are not for a text field
  Key(kKeyZ, /*ctrl=*/true);
  EXPECT_EQ(ModelJson()["outputs"], Json({"y"}));
  EXPECT_EQ(d_.state.model->outputs, (std::vector<std::string>{"y"}));
  Key(kKeyZ, /*ctrl=*/true);
  EXPECT_EQ(ModelJson(), blank);
  EXPECT_TRUE(d_.state.model->inputs.empty());
  Key(kKeyY, /*ctrl=*/true);
  Key(kKeyY, /*ctrl=*/true);
  EXPECT_EQ(ModelJson(), edited);
  EXPECT_EQ(d_.state.model->outputs, (std::vector<std::string>{"ilambda"}));
  // The toolbar's Undo does the same.
  ASSERT_TRUE(Click(ImHashStr("Undo", 0, View()->ID)));
  EXPECT_EQ(ModelJson()["outputs"], Json({"y"}));
}

TEST_F(EquationsStructure, UndoTakesBackAFormulaEditAsWell) {
  const ImGuiID drift = Id("drift.x", "##formula");
  ASSERT_TRUE(Click(drift));
  Key(kKeyEnd);
  d_.Type("-x");  // "0" -> "0-x"
  d_.PressEnter();
  ASSERT_EQ(d_.state.model->drift[0].text, "0-x");
  d_.MouseTo(ImVec2(1, 1));
  Key(kKeyZ, /*ctrl=*/true);
  EXPECT_EQ(d_.state.model->drift[0].text, "0");
  EXPECT_EQ(ModelJson()["drift"]["x"], "0");
  Key(kKeyY, /*ctrl=*/true);
  EXPECT_EQ(d_.state.model->drift[0].text, "0-x");
}

TEST_F(EquationsStructure, AnEditElsewhereStartsANewHistory) {
  ASSERT_TRUE(Add("input", "u"));
  ASSERT_FALSE(d_.state.equations_view.undo.empty());
  // A start value edited in the Parameters view: undoing the input would take it back too.
  d_.state.parameters_view.pending.push_back(
      ParseParameterEdit("sigma_x", ParameterField::kValue, "0.5").value());
  ApplyParameterEdits(d_.state);
  d_.Frame();
  EXPECT_TRUE(d_.state.equations_view.undo.empty());
  d_.state.equations_view.undo_requested = true;
  d_.Frame();
  EXPECT_EQ(d_.state.model->inputs, (std::vector<std::string>{"u"}));
  EXPECT_EQ(d_.state.model->parameters[0].value, 0.5);
}

// A draft refused for an unknown name turns valid, without retyping, once the model has the name
// (here by a rename), and is applied when its field is left.
TEST_F(EquationsStructure, ARefusedDraftIsCheckedAgainWhenTheNamesChange) {
  ASSERT_TRUE(Click(Id("drift.x", "##formula")));
  Key(kKeyEnd);
  d_.Type("-k*x");
  ASSERT_TRUE(d_.state.equations_view.drafts.at("drift.x").error);
  EXPECT_EQ(
      d_.state.equations_view.drafts.at("drift.x").error->message.rfind("unknown name 'k'", 0), 0u);
  StructureEdit rename;
  rename.kind = StructureEditKind::kRename;
  rename.name = "sigma_y";
  rename.text = "k";
  d_.state.equations_view.structure_pending.push_back(rename);
  d_.Frame();
  ASSERT_GE(d_.state.model->ParameterIndex("k"), 0);
  EXPECT_FALSE(d_.state.equations_view.drafts.at("drift.x").error);
  d_.PressEnter();
  EXPECT_EQ(d_.state.model->drift[0].text, "0-k*x");
}

TEST_F(EquationsStructure, OptionsAndParameterFieldsAreEditedAndUndone) {
  ASSERT_TRUE(Retype(Id("model.name", "##field"), "exhaust"));
  EXPECT_EQ(d_.state.model->name, "exhaust");
  ASSERT_TRUE(Retype(Id("unit.sigma_x", "##field", ParametersTable()), "K"));
  EXPECT_EQ(ModelJson()["parameters"]["sigma_x"]["unit"], "K");
  ASSERT_TRUE(Retype(Id("prior.sigma_x.mean", "##field", ParametersTable()), "0.2"));
  // A mean without an sd is not a prior: refused with the reason, the model unchanged.
  ASSERT_TRUE(d_.state.equations_view.refusal);
  EXPECT_FALSE(d_.state.model->parameters[0].prior);
  ASSERT_TRUE(Retype(Id("prior.sigma_x.sd", "##field", ParametersTable()), "0.05"));
  ASSERT_TRUE(d_.state.model->parameters[0].prior);
  EXPECT_EQ(d_.state.model->parameters[0].prior->mean, 0.2);
  EXPECT_EQ(d_.state.model->parameters[0].prior->sd, 0.05);
  // The input hold, as the combo emits it.
  StructureEdit hold;
  hold.kind = StructureEditKind::kInputHold;
  hold.hold = model::InputHold::kFoh;
  d_.state.equations_view.structure_pending.push_back(hold);
  d_.Frame();
  EXPECT_EQ(d_.state.model->input_hold, model::InputHold::kFoh);
  EXPECT_EQ(ModelJson()["input_hold"], "foh");
  d_.state.equations_view.undo_requested = true;
  d_.Frame();
  EXPECT_EQ(d_.state.model->input_hold, model::InputHold::kZoh);
}

TEST_F(EquationsStructure, AStructureEditIsAnUnsavedChangeThatSaveWrites) {
  EXPECT_FALSE(HasUnsavedChanges(d_.state));
  ASSERT_TRUE(Retype(Id("rename.output.y", "##field"), "ilambda"));
  ASSERT_TRUE(Add("input", "mfi"));
  EXPECT_TRUE(HasUnsavedChanges(d_.state));
  ASSERT_TRUE(SaveCurrentProject(d_.state).ok());
  EXPECT_FALSE(HasUnsavedChanges(d_.state));
  // Read back from disk: the project's model is the edited one.
  Result<project::Project> saved = project::LoadProject((dir_ / "project.json").string());
  ASSERT_TRUE(saved) << saved.error().ToString();
  Result<model::ModelSpec> m = model::ParseModel(saved->model_json, "");
  ASSERT_TRUE(m) << m.error().ToString();
  EXPECT_EQ(m->outputs, (std::vector<std::string>{"ilambda"}));
  EXPECT_EQ(m->inputs, (std::vector<std::string>{"mfi"}));
}

// The workflow in the workbench alone, step by step: a blank model grows into a
// first-order model of the lambda signal (an input added, the output renamed, two parameters
// created from the drift's refusal), is fitted, gets an offset in its observation (a second,
// nested model) and is fitted again; the two fits are compared by the likelihood-ratio test, the
// project is saved and reopened, and both fits and their test are there.
TEST_F(EquationsStructure, ABlankModelIsBuiltFittedExtendedComparedSavedAndReopened) {
  d_.state.estimation.keep_on_disk = true;
  d_.state.estimation.settings.threads = 1;
  ASSERT_TRUE(Retype(Id("rename.output.y", "##field"), "ilambda"));
  ASSERT_TRUE(Add("input", "mfi"));
  // The drift names two parameters the model lacks: each is offered and created in turn.
  ASSERT_TRUE(Retype(Id("drift.x", "##formula"), "(-x + K*mfi)/tau"));
  const ImGuiID drift = ImHashStr("drift.x", 0, View()->ID);
  ASSERT_TRUE(Click(ImHashStr("Create parameter 'K'", 0, drift))) << d_.Text();
  ASSERT_TRUE(Click(ImHashStr("Create parameter 'tau'", 0, drift))) << d_.Text();
  ASSERT_EQ(d_.state.model->drift[0].text, "(-x + K*mfi)/tau");
  EXPECT_TRUE(d_.state.equations_view.drafts.empty());
  // A time constant is positive: its lower bound, as the Parameters view takes it.
  d_.state.parameters_view.pending.push_back(
      ParseParameterEdit("tau", ParameterField::kLower, "0.001").value());
  ApplyParameterEdits(d_.state);

  auto fit = [&]() -> ::testing::AssertionResult {
    std::string why;
    if (!StartEstimation(d_.state, &why)) return ::testing::AssertionFailure() << why;
    if (!d_.FramesUntil([&] { return !EstimationRunning(d_.state); }, std::chrono::minutes(10)))
      return ::testing::AssertionFailure() << "the fit did not end";
    d_.Frame();
    if (!d_.state.estimation.result)
      return ::testing::AssertionFailure() << d_.state.estimation.last_failure;
    return ::testing::AssertionSuccess();
  };
  ASSERT_TRUE(fit());
  const estimate::EstimateSummary first = d_.state.estimation.result->summary;
  ASSERT_TRUE(std::isfinite(first.loglik));

  // The second model: an offset in the observation, created from its refusal.
  ASSERT_TRUE(Retype(Id("observation.ilambda", "##formula"), "x + c"));
  ASSERT_TRUE(
      Click(ImHashStr("Create parameter 'c'", 0, ImHashStr("observation.ilambda", 0, View()->ID))))
      << d_.Text();
  ASSERT_EQ(d_.state.model->observation[0].text, "x + c");
  ASSERT_TRUE(fit());
  const estimate::EstimateSummary second = d_.state.estimation.result->summary;
  ASSERT_EQ(second.n_free, first.n_free + 1);

  auto test = CompareFits(d_.state, 0, 1);
  ASSERT_TRUE(test.ok()) << test.error().ToString();
  EXPECT_DOUBLE_EQ(test->statistic, 2 * (second.loglik - first.loglik));
  EXPECT_EQ(test->df, 1);

  ASSERT_TRUE(SaveCurrentProject(d_.state).ok());
  WorkbenchDriver again;
  again.Open((dir_ / "project.json").string());
  ASSERT_TRUE(again.state.model) << again.state.model_error;
  EXPECT_EQ(again.state.model->observation[0].text, "x + c");
  ASSERT_EQ(again.state.estimation.fits.size(), 2u);
  EXPECT_EQ(again.state.estimation.fits[0].fit.summary.loglik, first.loglik);
  EXPECT_EQ(again.state.estimation.fits[1].fit.summary.loglik, second.loglik);
  EXPECT_EQ(again.state.estimation.shown, 1) << "the fit of the saved model is shown";
  again.state.view = View::kEstimate;
  again.state.estimation.compare_a = 0;
  again.state.estimation.compare_b = 1;
  const std::string log = again.Text();
  EXPECT_NE(log.find("Likelihood-ratio test of fit 1"), std::string::npos) << log;
  // The first model comes back when its fit is shown.
  std::string why;
  ASSERT_TRUE(ShowFit(again.state, 0, &why)) << why;
  EXPECT_EQ(again.state.model->observation[0].text, "x");
}

}  // namespace
}  // namespace gb::ui
