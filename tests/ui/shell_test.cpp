// The application shell driven as a user drives it (synthetic keys and clicks on the headless
// workbench): save as and open again through the file browser, "save changes?" before quitting,
// the recent-projects list (and a corrupt one), restoring an edit from the recovery file after
// a crash, the keyboard shortcuts, adding a dataset and replacing the model.
//
// Every test runs in a fresh temporary directory and points HOME, XDG_CONFIG_HOME and
// XDG_STATE_HOME there, so nothing is written into the user's home.
#include "ui/shell/shell.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/diagram/diagram.h"
#include "core/model/model.h"
#include "core/project/project.h"
#include "core/util/file.h"
#include "core/util/json.h"
#include "tests/ui/workbench_driver.h"
#include "ui/shell/help.h"
#include "ui/widgets/file_browser.h"

#ifndef GREYBENCH_SOURCE_DIR
#error "GREYBENCH_SOURCE_DIR must name the source tree (tests/ui/CMakeLists.txt sets it)"
#endif

namespace gb::ui {
namespace {
namespace fs = std::filesystem;
using std::chrono::milliseconds;
using testing::EndedAsCancelled;
using testing::WorkbenchDriver;

const fs::path kUiData = fs::path(GREYBENCH_SOURCE_DIR) / "tests/data/ui";
constexpr milliseconds kTimeout{30000};

// Key codes the tests map ImGui's named keys to (GLFW's, as in greybench).
constexpr int kKeyEscape = 256;
constexpr int kKeyBackspace = 259;
constexpr int kKeyDown = 264;
constexpr int kKeyUp = 265;
constexpr int kKeyA = 'A';

class ShellTest : public ::testing::Test {
 protected:
  void SetUp() override {
    static int counter = 0;
    dir_ = fs::temp_directory_path() /
           ("greybench-shell-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "work");
    for (const char* f : {"project.json", "fuel_film.json", "f1.csv"})
      fs::copy_file(kUiData / f, dir_ / "work" / f);
    // The project was saved a while ago (the recovery file must be newer to be offered).
    fs::last_write_time(project(), fs::file_time_type::clock::now() - std::chrono::hours(1));
    for (const char* var : kEnvironment) {
      const char* value = std::getenv(var);
      saved_env_.push_back(value ? std::optional<std::string>(value) : std::nullopt);
    }
    ::setenv("HOME", (dir_ / "home").c_str(), 1);
    ::setenv("XDG_CONFIG_HOME", (dir_ / "config").c_str(), 1);
    ::setenv("XDG_STATE_HOME", (dir_ / "state").c_str(), 1);
    fs::create_directories(dir_ / "home");
  }
  void TearDown() override {
    driver_.reset();
    for (std::size_t i = 0; i < kEnvironment.size(); ++i) {
      if (saved_env_[i]) {
        ::setenv(kEnvironment[i], saved_env_[i]->c_str(), 1);
      } else {
        ::unsetenv(kEnvironment[i]);
      }
    }
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  std::string project() const { return (dir_ / "work/project.json").string(); }
  fs::path dir() const { return dir_; }

  // A new workbench (as if greybench started), with the session files on.
  WorkbenchDriver& Start() {
    driver_.reset();
    driver_ = std::make_unique<WorkbenchDriver>();
    ImGuiIO& io = ImGui::GetIO();
    io.KeyMap[ImGuiKey_Escape] = kKeyEscape;
    io.KeyMap[ImGuiKey_Backspace] = kKeyBackspace;
    io.KeyMap[ImGuiKey_DownArrow] = kKeyDown;
    io.KeyMap[ImGuiKey_UpArrow] = kKeyUp;
    io.KeyMap[ImGuiKey_A] = kKeyA;
    StartSession(driver_->state);
    return *driver_;
  }

  // Presses and releases `key` (with Ctrl / Shift held).
  void Key(int key, bool ctrl = false, bool shift = false) {
    ImGuiIO& io = ImGui::GetIO();
    io.KeyCtrl = ctrl;
    io.KeyShift = shift;
    io.KeysDown[key] = true;
    driver_->Frame();
    io.KeysDown[key] = false;
    io.KeyCtrl = false;
    io.KeyShift = false;
    driver_->Frame();
  }

  bool WaitLoaded() {
    return driver_->FramesUntil([&] { return !driver_->state.load_job.active(); }, kTimeout);
  }

  // The start value of `name` in the workbench's model.
  double Value(const std::string& name) const {
    const model::ModelSpec& m = *driver_->state.model;
    return m.parameters[m.ParameterIndex(name)].value;
  }

  // Edits a start value the way the Parameters view does.
  void EditValue(const std::string& name, double value) {
    ParameterEdit e;
    e.parameter = name;
    e.number = value;
    e.text = std::to_string(value);
    driver_->state.parameters_view.pending.push_back(e);
    ApplyParameterEdits(driver_->state);
    driver_->Frame();
  }

  // Clicks the button `label` in the popup (or window) whose name starts with `window`.
  bool ClickIn(const char* window, const char* label) {
    driver_->Frame();  // an auto-sized popup takes the size of new content a frame later
    driver_->Frame();
    ImGuiWindow* w = WorkbenchDriver::FindWindow(window);
    if (!w || !w->Active) return false;
    std::optional<ImVec2> at = driver_->Find(w, ImHashStr(label, 0, w->ID));
    if (!at) return false;
    driver_->Click(*at);
    return true;
  }

  static bool PopupOpen(const char* name) {
    ImGuiWindow* w = WorkbenchDriver::FindWindow(name);
    return w && w->Active;
  }
  // The file browser is open with the title `title`.
  bool BrowserOpen(const std::string& title) const {
    ImGuiWindow* w = WorkbenchDriver::FindWindow("", "###file_browser");
    return w && w->Active && driver_->state.shell.browser.request.title == title;
  }

 private:
  static constexpr std::array<const char*, 3> kEnvironment = {"HOME", "XDG_CONFIG_HOME",
                                                              "XDG_STATE_HOME"};
  std::vector<std::optional<std::string>> saved_env_;  // restored after the test
  fs::path dir_;
  std::unique_ptr<WorkbenchDriver> driver_;
};

TEST_F(ShellTest, SaveAsAndOpenAgainThroughTheFileBrowser) {
  WorkbenchDriver& d = Start();
  d.Open(project());
  ASSERT_TRUE(d.state.project && d.state.model);
  EXPECT_FALSE(HasUnsavedChanges(d.state));
  EXPECT_EQ(WindowTitle(d.state).back(), 'm');  // "greybench — UI test: fuel film", no marker

  EditValue("tau_fv", 0.123);
  EXPECT_TRUE(HasUnsavedChanges(d.state));
  EXPECT_EQ(WindowTitle(d.state).substr(WindowTitle(d.state).size() - 2), " *");

  // Ctrl+Shift+S: the browser opens in the project's folder with its name in the field.
  Key('S', /*ctrl=*/true, /*shift=*/true);
  ASSERT_TRUE(BrowserOpen("Save project as"));
  EXPECT_EQ(d.state.shell.browser.directory, (dir() / "work").string());
  Key(kKeyA, /*ctrl=*/true);  // select the proposed name, then type over it
  d.Type("saved");            // the .json of the filter is added
  d.PressEnter();
  d.Frame();
  const std::string saved = (dir() / "work/saved.json").string();
  ASSERT_TRUE(fs::exists(saved)) << "messages: " << d.state.messages.back().text;
  EXPECT_FALSE(BrowserOpen("Save project as"));
  EXPECT_EQ(d.state.project->path, saved);
  EXPECT_FALSE(HasUnsavedChanges(d.state));

  // The file holds the edited model inline (the model file no longer holds it) and the data
  // relative to the project.
  auto raw = ReadJsonFile(saved);
  ASSERT_TRUE(raw.ok());
  EXPECT_TRUE((*raw)["model"].is_object());
  EXPECT_EQ((*raw)["datasets"][0], "f1.csv");
  EXPECT_EQ((*raw)["model"]["parameters"]["tau_fv"]["value"], 0.123);
  const Json model_before = model::ToJson(*d.state.model);

  // Open it again with the keyboard: Ctrl+O, Down to saved.json, Enter.
  EditValue("tau_fv", 0.2);  // an edit that must not survive: Discard it below
  Key('O', /*ctrl=*/true);
  ASSERT_TRUE(BrowserOpen("Open project"));
  const FileBrowserState& b = d.state.shell.browser;
  for (int i = 0; i < 10 && (b.selected < 0 || b.entries[b.selected].name != "saved.json"); ++i)
    Key(kKeyDown);
  ASSERT_GE(b.selected, 0);
  ASSERT_EQ(b.entries[b.selected].name, "saved.json");
  d.PressEnter();
  ASSERT_TRUE(PopupOpen("Unsaved changes"));  // the 0.2 edit
  ASSERT_TRUE(ClickIn("Unsaved changes", "Discard changes"));
  ASSERT_TRUE(WaitLoaded());
  d.Frame();
  ASSERT_TRUE(d.state.project);
  EXPECT_EQ(d.state.project->path, saved);
  EXPECT_EQ(model::ToJson(*d.state.model), model_before);
  EXPECT_EQ(Value("tau_fv"), 0.123);
  EXPECT_FALSE(HasUnsavedChanges(d.state));
}

TEST_F(ShellTest, QuitAsksToSaveAndCancelKeepsTheWork) {
  WorkbenchDriver& d = Start();
  d.Open(project());
  // No edit: quitting asks nothing.
  RequestQuit(d.state);
  EXPECT_TRUE(d.state.quit_requested);
  d.state.quit_requested = false;

  EditValue("X", 0.3);
  Key('Q', /*ctrl=*/true);
  EXPECT_FALSE(d.state.quit_requested);
  ASSERT_TRUE(PopupOpen("Unsaved changes"));
  ASSERT_TRUE(ClickIn("Unsaved changes", "Cancel"));
  d.Frame();
  EXPECT_FALSE(PopupOpen("Unsaved changes"));
  EXPECT_FALSE(d.state.quit_requested);
  EXPECT_EQ(Value("X"), 0.3);
  EXPECT_TRUE(HasUnsavedChanges(d.state));

  // Save in the prompt: the project file gets the edit, then greybench quits.
  Key('Q', /*ctrl=*/true);
  ASSERT_TRUE(ClickIn("Unsaved changes", "Save"));
  EXPECT_TRUE(d.state.quit_requested);
  auto back = project::LoadProject(project());
  ASSERT_TRUE(back.ok()) << back.error().ToString();
  auto spec = model::ParseModel(back->model_json, project());
  ASSERT_TRUE(spec.ok());
  EXPECT_EQ(spec->parameters[spec->ParameterIndex("X")].value, 0.3);
}

TEST_F(ShellTest, RecentProjectsUpdateAndSurviveACorruptFile) {
  const fs::path recent = dir() / "config/greybench/recent.json";
  fs::create_directories(recent.parent_path());
  std::ofstream(recent) << "{\"greybench_recent\": 1, \"projects\": [tru";
  WorkbenchDriver& d = Start();
  EXPECT_TRUE(d.state.shell.recent.empty());
  ASSERT_FALSE(d.state.messages.empty());
  EXPECT_NE(d.state.messages.back().text.find("ignored"), std::string::npos);
  EXPECT_NE(d.state.messages.back().text.find("recent.json"), std::string::npos);

  d.Open(project());
  d.Frame();
  ASSERT_EQ(d.state.shell.recent.size(), 1u);
  EXPECT_EQ(d.state.shell.recent[0], project());

  // A second project goes to the front; the list is written and read back by a new session.
  const std::string second = (dir() / "work/second.json").string();
  fs::copy_file(project(), second);
  RequestOpenProject(d.state, second);
  ASSERT_TRUE(WaitLoaded());
  d.Frame();
  ASSERT_EQ(d.state.shell.recent.size(), 2u);
  EXPECT_EQ(d.state.shell.recent[0], second);
  WorkbenchDriver& again = Start();
  ASSERT_EQ(again.state.shell.recent.size(), 2u);
  EXPECT_EQ(again.state.shell.recent[0], second);
  EXPECT_EQ(again.state.shell.recent[1], project());

  // At most kMaxRecent, newest first, no duplicates.
  for (int i = 0; i < kMaxRecent + 2; ++i)
    AddRecent(again.state, (dir() / ("p" + std::to_string(i) + ".json")).string());
  AddRecent(again.state, second);
  ASSERT_EQ(again.state.shell.recent.size(), static_cast<std::size_t>(kMaxRecent));
  EXPECT_EQ(again.state.shell.recent[0], second);

  // A recent project that has gone away is dropped when opening it fails.
  fs::remove(second);
  RequestOpenProject(again.state, second);
  ASSERT_TRUE(WaitLoaded());
  again.Frame();
  EXPECT_EQ(std::count(again.state.shell.recent.begin(), again.state.shell.recent.end(), second),
            0);
}

TEST_F(ShellTest, RecoveryFileRestoresAnEditAfterACrash) {
  {
    WorkbenchDriver& d = Start();
    d.Open(project());
    d.state.shell.autosave_seconds = 0.0;
    EditValue("tau_fv", 0.0777);
    d.Frame();
    ASSERT_TRUE(fs::exists(RecoveryPath(d.state, project())));
    // The workbench goes away without saving (a crash): the next Start() replaces it.
  }
  WorkbenchDriver& d = Start();
  d.Open(project());
  d.Frame();
  EXPECT_NE(Value("tau_fv"), 0.0777);  // the project file as saved
  ASSERT_TRUE(PopupOpen("Restore unsaved work?"));
  ASSERT_TRUE(ClickIn("Restore unsaved work?", "Restore"));
  ASSERT_TRUE(WaitLoaded());
  d.Frame();
  ASSERT_TRUE(d.state.project && d.state.model);
  EXPECT_EQ(d.state.project->path, project());
  EXPECT_EQ(Value("tau_fv"), 0.0777);
  EXPECT_TRUE(HasUnsavedChanges(d.state));
  EXPECT_TRUE(d.state.project->extra.is_null() ||
              !d.state.project->extra.contains("greybench_recovery"));

  Key('S', /*ctrl=*/true);
  EXPECT_FALSE(HasUnsavedChanges(d.state));
  EXPECT_FALSE(fs::exists(RecoveryPath(d.state, project())));
  auto back = project::LoadProject(project());
  ASSERT_TRUE(back.ok());
  auto spec = model::ParseModel(back->model_json, project());
  ASSERT_TRUE(spec.ok());
  EXPECT_EQ(spec->parameters[spec->ParameterIndex("tau_fv")].value, 0.0777);
}

TEST_F(ShellTest, AnAutosaveThatCannotWriteWarnsOnceAndSaysWhenItWorksAgain) {
  WorkbenchDriver& d = Start();
  d.Open(project());
  d.state.shell.autosave_seconds = 0.0;  // every frame after an edit
  const std::string writable = d.state.shell.recovery_dir;
  d.state.shell.recovery_dir = "/proc/greybench-no-recovery";  // refused even to root
  auto count = [&](const std::string& text) {
    return std::count_if(d.state.messages.begin(), d.state.messages.end(),
                         [&](const Message& m) { return m.text.find(text) != std::string::npos; });
  };
  for (double tau : {0.0771, 0.0772, 0.0773}) {
    EditValue("tau_fv", tau);
    d.Frame();
    d.Frame();
  }
  EXPECT_EQ(count("Autosave failed"), 1);
  EXPECT_EQ(count("Autosave works again"), 0);
  d.state.shell.recovery_dir = writable;
  d.Frame();
  EXPECT_TRUE(fs::exists(RecoveryPath(d.state, project())));
  EXPECT_EQ(count("Autosave works again"), 1);
  EXPECT_EQ(count("Autosave failed"), 1);
}

TEST_F(ShellTest, ShortcutsSwitchViewsAndRunAndCancelTheEstimation) {
  WorkbenchDriver& d = Start();
  d.Open(project());
  for (std::size_t i = 0; i < kAllViews.size() && i < 9; ++i) {  // Ctrl+0 resets the zoom
    Key('1' + static_cast<int>(i), /*ctrl=*/true);
    EXPECT_EQ(d.state.view, kAllViews[i]) << i;
  }
  d.state.estimation.settings.multistart = 50;  // long enough to cancel
  Key(kKeyF5);
  ASSERT_TRUE(EstimationRunning(d.state));
  Key(kKeyEscape);
  ASSERT_TRUE(d.FramesUntil([&] { return !EstimationRunning(d.state); }, kTimeout));
  EXPECT_TRUE(EndedAsCancelled(d.state));
}

// Esc closes the Keyboard shortcuts and Messages windows, and there it does not cancel the
// estimation under way.
TEST_F(ShellTest, EscClosesTheShortcutsAndMessagesWindowsWithoutCancellingTheRun) {
  WorkbenchDriver& d = Start();
  d.Open(project());
  d.state.shell.show_shortcuts = true;
  d.Frame();
  d.Frame();
  ASSERT_TRUE(PopupOpen("Keyboard shortcuts"));
  d.state.estimation.settings.multistart = 50;  // long enough to outlast the keys
  ASSERT_TRUE(StartEstimation(d.state));
  Key(kKeyEscape);
  EXPECT_FALSE(d.state.shell.show_shortcuts);
  EXPECT_TRUE(EstimationRunning(d.state));
  d.state.show_messages = true;
  d.Frame();
  d.Frame();
  Key(kKeyEscape);
  EXPECT_FALSE(d.state.show_messages);
  EXPECT_TRUE(EstimationRunning(d.state));
  // Elsewhere Esc still cancels the run.
  Key(kKeyEscape);
  ASSERT_TRUE(d.FramesUntil([&] { return !EstimationRunning(d.state); }, kTimeout));
}

// An error the workbench later gets past (the predictions computed after all) leaves the status
// bar; the Messages window keeps it, marked, with the time of each message.
TEST_F(ShellTest, AnErrorThatIsResolvedLeavesTheStatusBarAndMessagesHaveTimes) {
  WorkbenchDriver& d = Start();
  d.Open(project());
  WaitForJobs(d.state);
  AddMessage(d.state, Severity::kError, "The predictions could not be computed: a test",
             MessageTopic::kPredictions);
  EXPECT_EQ(StatusText(d.state), "The predictions could not be computed: a test");
  ASSERT_EQ(d.state.messages.back().time.size(), 8u);  // HH:MM:SS
  EXPECT_EQ(d.state.messages.back().time[2], ':');
  RecomputeAnalysis(d.state);
  d.Frame();
  WaitForJobs(d.state);
  ASSERT_TRUE(d.state.analysis.result);
  EXPECT_TRUE(d.state.messages.back().resolved);
  EXPECT_EQ(StatusText(d.state), "Ready");
  d.state.show_messages = true;
  d.Frame();
  d.Frame();
  ImGuiWindow* w = WorkbenchDriver::FindWindow("Messages");
  ASSERT_TRUE(w && w->Active);
}

TEST_F(ShellTest, AddDatasetAndReplaceModelAreSavedWithTheProject) {
  WorkbenchDriver& d = Start();
  d.Open(project());
  fs::copy_file(dir() / "work/f1.csv", dir() / "work/f1_copy.csv");
  AddDataset(d.state, (dir() / "work/f1_copy.csv").string());
  ASSERT_TRUE(d.FramesUntil([&] { return d.state.datasets.size() == 2; }, kTimeout));
  EXPECT_TRUE(d.state.datasets[1].data);
  EXPECT_TRUE(HasUnsavedChanges(d.state));

  // The model replaced by a file with another start value: the project names that file.
  auto spec = model::LoadModelFile((dir() / "work/fuel_film.json").string());
  ASSERT_TRUE(spec.ok());
  ASSERT_TRUE(model::SetParameter(&*spec, "tau_fv", 0.0555).ok());
  const std::string other = (dir() / "work/other_model.json").string();
  ASSERT_TRUE(model::SaveModelFile(*spec, other).ok());
  ASSERT_TRUE(ReplaceModel(d.state, other).ok());
  EXPECT_EQ(Value("tau_fv"), 0.0555);
  EXPECT_FALSE(ReplaceModel(d.state, (dir() / "work/f1.csv").string()).ok());  // not a model

  ASSERT_TRUE(SaveCurrentProject(d.state).ok());
  auto raw = ReadJsonFile(project());
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ((*raw)["model"], "other_model.json");
  EXPECT_EQ((*raw)["datasets"], Json::array({"f1.csv", "f1_copy.csv"}));
}

TEST_F(ShellTest, AProjectKeepsItsDiagramFileWhenSavedUnlessTheUserChoosesInline) {
  // A project naming its diagram by a file: an edit, then Save writes the diagram to that file and
  // the project keeps the path (it used to write the diagram inline and drop the path); Save As
  // into another folder keeps it relative to the new place; unticked, the diagram goes inline.
  fs::create_directories(dir() / "work/diagrams");
  fs::copy_file(fs::path(GREYBENCH_SOURCE_DIR) / "assets/diagrams/fuel_film.json",
                dir() / "work/diagrams/film.json");
  auto raw = ReadJsonFile(project());
  ASSERT_TRUE(raw.ok());
  (*raw)["diagram"] = "diagrams/film.json";
  ASSERT_TRUE(WriteFileAtomic(project(), raw->dump(1)).ok());

  WorkbenchDriver& d = Start();
  d.Open(project());
  ASSERT_TRUE(d.state.diagram_view.diagram) << d.state.diagram_view.error;
  EXPECT_EQ(d.state.diagram_view.file, (dir() / "work/diagrams/film.json").string());
  d.state.view = View::kDiagram;
  d.Frame();
  const int block = d.state.diagram_view.diagram->blocks.front().id;
  DiagramEdit move;
  move.kind = DiagramEditKind::kMove;
  move.id = block;
  move.position = {1234.0, 567.0};
  d.state.diagram_view.pending.push_back(move);
  d.Frame();
  ASSERT_TRUE(HasUnsavedChanges(d.state));
  ASSERT_TRUE(SaveCurrentProject(d.state).ok());
  raw = ReadJsonFile(project());
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ((*raw)["diagram"], "diagrams/film.json");
  auto file = diagram::LoadDiagramFile((dir() / "work/diagrams/film.json").string());
  ASSERT_TRUE(file.ok()) << file.error().ToString();
  EXPECT_EQ(file->layout.positions.at(block), (std::array<double, 2>{1234.0, 567.0}));

  // Save As elsewhere: the same file, named from the new folder.
  fs::create_directories(dir() / "other");
  ASSERT_TRUE(SaveProjectAs(d.state, (dir() / "other/copy.json").string()).ok());
  raw = ReadJsonFile((dir() / "other/copy.json").string());
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ((*raw)["diagram"], "../work/diagrams/film.json");

  // Unticked: inline, and the file is left as it was.
  d.state.diagram_view.keep_file = false;
  move.position = {1.0, 2.0};
  d.state.diagram_view.pending.push_back(move);
  d.Frame();
  ASSERT_TRUE(SaveCurrentProject(d.state).ok());
  raw = ReadJsonFile((dir() / "other/copy.json").string());
  ASSERT_TRUE(raw.ok());
  ASSERT_TRUE((*raw)["diagram"].is_object());
  EXPECT_EQ((*raw)["diagram"]["layout"][std::to_string(block)], Json::array({1.0, 2.0}));
  file = diagram::LoadDiagramFile((dir() / "work/diagrams/film.json").string());
  ASSERT_TRUE(file.ok());
  EXPECT_EQ(file->layout.positions.at(block), (std::array<double, 2>{1234.0, 567.0}));
}

// Save As onto a file the project is made of (its model, a dataset) would destroy it: refused
// with both named, and the file keeps every byte.
TEST_F(ShellTest, SaveAsOntoTheProjectsOwnModelOrDataIsRefusedAndLosesNothing) {
  WorkbenchDriver& d = Start();
  d.Open(project());
  ASSERT_TRUE(d.state.project);
  auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  for (const char* name : {"fuel_film.json", "f1.csv"}) {
    const fs::path target = dir() / "work" / name;
    const std::string before = bytes(target);
    ASSERT_FALSE(before.empty());
    const Status st = SaveProjectAs(d.state, target.string());
    ASSERT_FALSE(st.ok()) << name;
    EXPECT_NE(st.error().message.find("would destroy"), std::string::npos) << st.error().message;
    EXPECT_EQ(bytes(target), before) << name;
    EXPECT_EQ(d.state.project->path, project());
  }
  // Over itself it saves as always.
  EXPECT_TRUE(SaveProjectAs(d.state, project()).ok());
}

TEST_F(ShellTest, NewProjectWritesTheProjectFileAndOpensIt) {
  WorkbenchDriver& d = Start();
  d.Open(project());
  ASSERT_TRUE(OpenDialogByName(d.state, "new-project"));
  d.Frame();
  ASSERT_TRUE(PopupOpen("New project"));
  // Create refuses an empty form and says what is missing.
  ASSERT_TRUE(ClickIn("New project", "Create"));
  EXPECT_NE(d.state.shell.new_form.error.find("model"), std::string::npos);
  EXPECT_TRUE(PopupOpen("New project"));

  fs::create_directories(dir() / "new");
  NewProjectForm& f = d.state.shell.new_form;
  f.model = (dir() / "work/fuel_film.json").string();
  f.datasets = {(dir() / "work/f1.csv").string(), (dir() / "work/missing.csv").string()};
  f.project = (dir() / "new/fresh").string();  // .json is added
  ASSERT_TRUE(ClickIn("New project", "Create"));
  EXPECT_NE(f.error.find("missing.csv"), std::string::npos) << f.error;

  f.datasets.pop_back();
  ASSERT_TRUE(ClickIn("New project", "Create"));
  ASSERT_TRUE(WaitLoaded());
  d.Frame();
  EXPECT_FALSE(PopupOpen("New project"));
  const std::string fresh = (dir() / "new/fresh.json").string();
  ASSERT_TRUE(d.state.project);
  EXPECT_EQ(d.state.project->path, fresh);
  ASSERT_EQ(d.state.datasets.size(), 1u);
  EXPECT_TRUE(d.state.datasets[0].data);
  EXPECT_TRUE(d.state.model);
  auto raw = ReadJsonFile(fresh);
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ((*raw)["model"], "../work/fuel_film.json");
  EXPECT_EQ((*raw)["datasets"], Json::array({"../work/f1.csv"}));
}

// New project without a model file: a model made from the first dataset's columns, or the blank
// model, written beside the project as NAME.model.json and never over a file that exists.
TEST_F(ShellTest, NewProjectMakesItsModelFromTheDataOrBlankAndNeverOverwritesOne) {
  WorkbenchDriver& d = Start();
  d.Open(project());
  fs::create_directories(dir() / "new");
  ASSERT_TRUE(OpenDialogByName(d.state, "new-project"));
  d.Frame();
  NewProjectForm& f = d.state.shell.new_form;
  f.model_source = NewModelSource::kFromData;
  f.datasets = {(dir() / "work/f1.csv").string()};
  f.project = (dir() / "new/engine").string();
  d.Frame();  // the dialog reads the columns: each an input, the last the output
  ASSERT_EQ(f.columns.size(), 2u);
  EXPECT_EQ(f.columns[0].name, "mfi");
  EXPECT_EQ(f.column_use, (std::vector<ColumnUse>{ColumnUse::kInput, ColumnUse::kOutput}));
  ASSERT_TRUE(ClickIn("New project", "Create"));
  ASSERT_TRUE(WaitLoaded());
  d.Frame();
  ASSERT_TRUE(d.state.project);
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  EXPECT_EQ(d.state.model->inputs, (std::vector<std::string>{"mfi"}));
  EXPECT_EQ(d.state.model->outputs, (std::vector<std::string>{"ilambda"}));
  EXPECT_EQ(d.state.model->states, (std::vector<std::string>{"x_ilambda"}));
  EXPECT_EQ(d.state.model->name, "engine");
  ASSERT_EQ(d.state.datasets.size(), 1u);
  EXPECT_TRUE(d.state.datasets[0].data);
  const fs::path model_file = dir() / "new/engine.model.json";
  ASSERT_TRUE(fs::exists(model_file));
  auto raw = ReadJsonFile((dir() / "new/engine.json").string());
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ((*raw)["model"], "engine.model.json");

  // The same name again: refused, naming the file, which keeps every byte.
  auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string before = bytes(model_file);
  ASSERT_TRUE(OpenDialogByName(d.state, "new-project"));
  d.Frame();
  f.model_source = NewModelSource::kBlank;
  f.project = (dir() / "new/engine.json").string();
  ASSERT_TRUE(ClickIn("New project", "Create"));
  EXPECT_NE(f.error.find("engine.model.json exists already"), std::string::npos) << f.error;
  EXPECT_EQ(bytes(model_file), before);

  // Another name: the blank model, named after the project.
  f.project = (dir() / "new/blank").string();
  ASSERT_TRUE(ClickIn("New project", "Create"));
  ASSERT_TRUE(WaitLoaded());
  d.Frame();
  ASSERT_TRUE(d.state.model) << d.state.model_error;
  EXPECT_EQ(d.state.model->name, "blank");
  EXPECT_EQ(d.state.model->states, (std::vector<std::string>{"x"}));
  EXPECT_TRUE(fs::exists(dir() / "new/blank.model.json"));
}

TEST(FileBrowser, ListsFoldersFirstFiltersAndReportsUnreadableFolders) {
  const fs::path dir =
      fs::temp_directory_path() / ("greybench-browser-test-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "zeta");
  fs::create_directories(dir / "Alpha");
  for (const char* f : {"b.json", "a.csv", "C.JSON", ".hidden.json"}) std::ofstream(dir / f) << f;
  FileBrowserState b;
  FileBrowserRequest r;
  r.filters = {{"Projects", {".json"}}, {"All", {}}};
  r.start = dir.string();
  OpenFileBrowser(b, r);
  ASSERT_TRUE(b.error.empty()) << b.error;
  std::vector<std::string> names;
  for (const FileEntry& e : b.entries) names.push_back(e.name);
  EXPECT_EQ(names, (std::vector<std::string>{"Alpha", "zeta", "b.json", "C.JSON"}));

  b.descending = true;
  b.filter = 1;
  ASSERT_TRUE(ChangeDirectory(b, dir.string()));
  names.clear();
  for (const FileEntry& e : b.entries) names.push_back(e.name);
  EXPECT_EQ(names, (std::vector<std::string>{"zeta", "Alpha", "C.JSON", "b.json", "a.csv"}));

  EXPECT_FALSE(ChangeDirectory(b, (dir / "missing").string()));
  EXPECT_NE(b.error.find((dir / "missing").string()), std::string::npos) << b.error;
  EXPECT_EQ(b.directory, dir.string());  // stays where it was
  fs::remove_all(dir);
}

}  // namespace
}  // namespace gb::ui

namespace gb::ui {
namespace {

// View › Theme is remembered for the next start (beside the recent projects); a theme the file
// does not know keeps the light one and says so.
TEST_F(ShellTest, TheThemeIsKeptForTheNextStart) {
  WorkbenchDriver& d = Start();
  EXPECT_EQ(d.state.shell.theme, ThemeKind::kLight);
  SetTheme(d.state, ThemeKind::kProjector);
  d.Frame();
  WorkbenchDriver& again = Start();
  EXPECT_EQ(again.state.shell.theme, ThemeKind::kProjector);
  // Another program (or a hand) wrote a theme greybench does not have.
  Json j = *ReadJsonFile(again.state.shell.recent_file);
  j["theme"] = "neon";
  ASSERT_TRUE(WriteFileAtomic(again.state.shell.recent_file, j.dump()).ok());
  WorkbenchDriver& third = Start();
  EXPECT_EQ(third.state.shell.theme, ThemeKind::kLight);
  bool said = false;
  for (const Message& m : third.state.messages)
    said = said ||
           m.text.find("theme: expected \"light\", \"dark\" or \"projector\"") != std::string::npos;
  EXPECT_TRUE(said);
}

// F1 opens the user guide at the workbench's section; Esc closes it; Ctrl+B hides the sidebar.
TEST_F(ShellTest, F1ShowsTheUserGuideAndCtrlBHidesTheSidebar) {
  WorkbenchDriver& d = Start();
  d.Open(project());
  Key(kKeyF1);
  ASSERT_TRUE(d.state.shell.show_help);
  d.Frame();
  ASSERT_TRUE(d.state.shell.guide_error.empty()) << d.state.shell.guide_error;
  ASSERT_FALSE(d.state.shell.guide.empty());
  const GuideSection& shown =
      d.state.shell.guide[static_cast<std::size_t>(d.state.shell.guide_section)];
  EXPECT_EQ(shown.title.rfind("6. The workbench", 0), 0u) << shown.title;
  const ImGuiWindow* guide = WorkbenchDriver::FindWindow("User guide");
  ASSERT_NE(guide, nullptr);
  EXPECT_TRUE(guide->WasActive);
  Key(kKeyEscape);
  EXPECT_FALSE(d.state.shell.show_help);
  d.Frame();
  EXPECT_FALSE(guide->WasActive);
  // The sidebar, and the view beside it; Ctrl+B gives the view the whole width.
  EXPECT_TRUE(d.state.shell.show_sidebar);
  const float beside = WorkbenchDriver::ViewWindow()->Size.x;
  Key('B', /*ctrl=*/true);
  EXPECT_FALSE(d.state.shell.show_sidebar);
  d.Frame();
  EXPECT_GT(WorkbenchDriver::ViewWindow()->Size.x, beside + 150);
}

TEST(ParseGuide, SplitsAtTheHeadingsOutsideCodeFences) {
  const auto g = ParseGuide(
      "# Title\nintro\n## 1. One\ntext\n```\n## not a heading\n```\n### 1a. Sub\n- item\n## 2. "
      "Two");
  ASSERT_EQ(g.size(), 3u);
  EXPECT_EQ(g[0].title, "1. One");
  EXPECT_EQ(g[0].level, 2);
  EXPECT_EQ(g[0].lines.size(), 4u);  // text, the fence, the line in it, the fence
  EXPECT_EQ(g[1].title, "1a. Sub");
  EXPECT_EQ(g[1].level, 3);
  EXPECT_EQ(g[2].title, "2. Two");
  EXPECT_TRUE(g[2].lines.empty());
}

}  // namespace
}  // namespace gb::ui
