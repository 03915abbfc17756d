// The application shell.
//
// Sections
//   1. Session files: directories, recent projects
//   2. Saving and the unsaved-changes guard
//   3. Recovery files
//   4. Model and dataset edits from the File menu
//   5. UpdateShell: installed projects, added datasets, autosave, shortcuts
//   6. The File menu
//   7. Dialogs: browser, save changes?, recovery, new project, keyboard shortcuts
#include "ui/shell/shell.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <utility>

#include <imgui.h>
#include <imgui_stdlib.h>

#include "core/data/import.h"
#include "core/model/model.h"
#include "core/model/model_structure.h"
#include "core/project/project.h"
#include "core/util/file.h"
#include "ui/export/export.h"
#include "ui/panels/common.h"
#include "ui/shell/help.h"
#include "ui/shell/import_dialog.h"
#include "ui/theme.h"

namespace gb::ui {
namespace fs = std::filesystem;
namespace {

constexpr const char* kUnsavedPopup = "Unsaved changes";
constexpr const char* kRecoveryPopup = "Restore unsaved work?";
constexpr const char* kNewPopup = "New project";
constexpr const char* kRecoveryKey = "greybench_recovery";

const std::vector<FileFilter> kProjectFilters = {{"Projects (*.json)", {".json"}},
                                                 {"All files", {}}};
const std::vector<FileFilter> kModelFilters = {{"Models (*.json)", {".json"}}, {"All files", {}}};
const std::vector<FileFilter> kDataFilters = {{"Data (*.csv, *.mf4)", {".csv", ".mf4", ".mdf"}},
                                              {"All files", {}}};

// The keys of the workbench (Help > Keyboard shortcuts lists this table).
struct ShortcutInfo {
  const char* keys;
  const char* action;
};
constexpr ShortcutInfo kShortcuts[] = {
    {"Ctrl+O", "Open a project"},
    {"Ctrl+S", "Save the project"},
    {"Ctrl+Shift+S", "Save the project under another name"},
    {"Ctrl+Q", "Quit (asks to save changes)"},
    {"F1", "The user guide"},
    {"F5", "Run the estimation"},
    {"Esc", "Cancel the estimation under way; close this window or Messages"},
    {"Ctrl+1 \xE2\x80\xA6 Ctrl+9", "Show a view (Data \xE2\x80\xA6 Live)"},
    {"Ctrl+= / Ctrl+-", "Zoom in / out"},
    {"Ctrl+0", "Actual size"},
    {"Ctrl+B", "Show or hide the sidebar"},
    {"", ""},
    {"In the file browser", ""},
    {"Up / Down", "Move the selection"},
    {"Enter", "Open the folder or choose the file"},
    {"Backspace", "The folder above"},
    {"Esc", "Close the browser"},
};

std::string Absolute(const std::string& path) {
  std::error_code ec;
  const fs::path p = fs::absolute(fs::path(path), ec);
  return (ec ? fs::path(path) : p).lexically_normal().string();
}

// $VAR when set to an absolute path, else $HOME/<fallback> (the XDG base directory rules).
std::string XdgDir(const char* var, const char* fallback) {
  const char* value = std::getenv(var);
  if (value && *value && fs::path(value).is_absolute()) return value;
  return (fs::path(HomeDirectory()) / fallback).string();
}

std::string Basename(const std::string& path) { return fs::path(path).filename().string(); }

// ---------------------------------------------------------------------------------------------
// 1. Session files

void WriteRecent(AppState& state) {
  ShellState& sh = state.shell;
  if (!sh.session_files) return;
  std::error_code ec;
  fs::create_directories(fs::path(sh.recent_file).parent_path(), ec);
  Json j = {{"greybench_recent", 1}, {"projects", sh.recent}, {"theme", ThemeName(sh.theme)}};
  if (Status st = WriteFileAtomic(sh.recent_file, j.dump(1) + "\n"); !st) {
    AddMessage(state, Severity::kWarning,
               "The recent projects could not be saved: " + st.error().ToString());
  }
}

void ReadRecent(AppState& state) {
  ShellState& sh = state.shell;
  sh.recent.clear();
  std::error_code ec;
  if (!fs::exists(sh.recent_file, ec)) return;  // the first start: nothing to read
  auto ignore = [&](const std::string& why) {
    AddMessage(state, Severity::kWarning,
               "The recent projects list " + sh.recent_file + " was ignored: " + why);
  };
  Result<Json> j = ReadJsonFile(sh.recent_file);
  if (!j) return ignore(j.error().ToString());
  if (!j->is_object() || !j->contains("projects") || !(*j)["projects"].is_array())
    return ignore("expected {\"greybench_recent\": 1, \"projects\": [...]}");
  for (const Json& p : (*j)["projects"]) {
    if (!p.is_string()) return ignore("projects: expected file names (strings)");
    if (sh.recent.size() < static_cast<std::size_t>(kMaxRecent))
      sh.recent.push_back(p.get<std::string>());
  }
  // The theme chosen last (View > Theme); an unknown one keeps the light theme.
  if (j->contains("theme")) {
    const Json& t = (*j)["theme"];
    const auto theme = t.is_string() ? ParseTheme(t.get<std::string>()) : std::nullopt;
    if (theme)
      sh.theme = *theme;
    else
      AddMessage(state, Severity::kWarning,
                 sh.recent_file +
                     ": theme: expected \"light\", \"dark\" or \"projector\"; the light "
                     "theme is used");
  }
}

// ---------------------------------------------------------------------------------------------
// 2. Saving and the unsaved-changes guard

// The project as it is to be written: the current model, inline once it differs from the
// model file the project names.
project::Project ProjectToSave(const AppState& state) {
  project::Project p = *state.project;
  if (!state.model) return p;  // an invalid model is written back as it was read
  p.model_json = model::ToJson(*state.model);
  if (!p.model_path.empty()) {
    Result<model::ModelSpec> file = model::LoadModelFile(p.model_path);
    if (!file || model::ToJson(*file) != p.model_json) p.model_path.clear();
  }
  return p;
}

void MarkSaved(AppState& state) {
  state.shell.saved_model_revision = state.model_revision;
  state.shell.saved_layout_revision = state.layout_revision;
  state.shell.autosave_due = false;
}

void RemoveRecovery(AppState& state, const std::string& project_path) {
  if (!state.shell.session_files || project_path.empty()) return;
  std::error_code ec;
  fs::remove(RecoveryPath(state, project_path), ec);
}

void OpenNow(AppState& state, const std::string& path) {
  if (state.load_job.active()) return;
  state.shell.opening = path;
  OpenProject(state, path);
}

void RunPending(AppState& state) {
  PendingAction action = std::move(state.shell.pending);
  state.shell.pending = PendingAction{};
  switch (action.kind) {
    case PendingAction::Kind::kNone:
      break;
    case PendingAction::Kind::kQuit:
      state.quit_requested = true;
      break;
    case PendingAction::Kind::kOpen:
      OpenNow(state, action.path);
      break;
    case PendingAction::Kind::kNew:
      state.shell.new_form = NewProjectForm{};
      state.shell.new_dialog_requested = true;
      break;
  }
}

// Runs `action` now, or after "save changes?" when there are unsaved changes.
void Guard(AppState& state, PendingAction action) {
  state.shell.pending = std::move(action);
  if (!HasUnsavedChanges(state)) return RunPending(state);
  state.shell.unsaved_error.clear();
  state.shell.unsaved_prompt_requested = true;
}

void BrowseProject(AppState& state) {
  FileBrowserRequest r;
  r.title = "Open project";
  r.filters = kProjectFilters;
  r.purpose = static_cast<int>(BrowsePurpose::kOpenProject);
  if (state.project) r.start = state.project->path;
  OpenFileBrowser(state.shell.browser, std::move(r));
}

void BrowseSaveAs(AppState& state) {
  if (!state.project) return;
  FileBrowserRequest r;
  r.title = "Save project as";
  r.confirm = "Save";
  r.mode = FileBrowserMode::kSave;
  r.filters = kProjectFilters;
  r.start = state.project->path;
  r.file_name = Basename(state.project->path);
  r.purpose = static_cast<int>(BrowsePurpose::kSaveProjectAs);
  OpenFileBrowser(state.shell.browser, std::move(r));
}

void SaveWithMessage(AppState& state) {
  if (!state.project) return;
  if (Status st = SaveCurrentProject(state); !st)
    AddMessage(state, Severity::kError, "Could not save the project: " + st.error().ToString());
}

// ---------------------------------------------------------------------------------------------
// 3. Recovery files

// A stable short name for a path (FNV-1a, 64 bit).
std::string PathHash(const std::string& path) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : path) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

// Offers the recovery file of the project just opened when it is newer than the project.
void CheckRecovery(AppState& state) {
  const std::string recovery = RecoveryPath(state, state.project->path);
  std::error_code ec1, ec2;
  const auto recovery_time = fs::last_write_time(recovery, ec1);
  const auto project_time = fs::last_write_time(state.project->path, ec2);
  if (ec1) return;  // no recovery file
  if (!ec2 && recovery_time <= project_time) {
    fs::remove(recovery, ec1);  // saved since: the recovery is out of date
    return;
  }
  state.shell.recovery_offer = recovery;
  state.shell.recovery_prompt_requested = true;
}

// The project just loaded is a recovery file: make it the project it belongs to again, with
// the restored edits counted as unsaved.
void FinishRestore(AppState& state) {
  ShellState& sh = state.shell;
  project::Project& p = *state.project;
  std::string model_file;
  if (p.extra.is_object() && p.extra.contains(kRecoveryKey)) {
    const Json& r = p.extra[kRecoveryKey];
    if (r.is_object() && r.contains("model_file") && r["model_file"].is_string())
      model_file = r["model_file"].get<std::string>();
    p.extra.erase(kRecoveryKey);
  }
  p.path = sh.restoring_project;
  p.base_dir = fs::path(p.path).parent_path().string();
  std::error_code ec;
  if (!model_file.empty() && fs::exists(model_file, ec)) p.model_path = model_file;
  sh.saved_model_revision = -1;  // unsaved until saved
  AddMessage(state, Severity::kInfo,
             "Restored the unsaved work on " + Basename(p.path) + " from " + sh.restoring + ".");
  sh.restoring.clear();
  sh.restoring_project.clear();
}

// ---------------------------------------------------------------------------------------------
// 4. Model and dataset edits

void InstallDataset(AppState& state, DatasetRead read) {
  // Another project was opened while the file was read: it was not meant for that one.
  if (!state.project || state.shell.dataset_generation != state.project_generation) return;
  if (!read.data) {
    AddMessage(state, Severity::kError, "Could not add the dataset: " + read.error);
    return;
  }
  LoadedDataset d;
  d.path = read.path;
  d.data = std::move(read.data);
  d.summary = std::move(read.summary);
  d.spec = std::move(read.spec);  // its file is read.path
  state.project->datasets.push_back(d.spec);
  state.datasets.push_back(std::move(d));
  state.data_view.x_ranges.push_back(plot::LinkedRange{});
  ++state.layout_revision;
  ++state.datasets_revision;  // the predictions are computed for it too
  AddMessage(state, Severity::kInfo,
             "Added " + Basename(read.path) + " to the project (" +
                 GroupedCount(static_cast<long long>(state.datasets.back().summary.rows)) +
                 " rows).");
}

// ---------------------------------------------------------------------------------------------
// 5. UpdateShell helpers

void OnProjectInstalled(AppState& state) {
  ShellState& sh = state.shell;
  MarkSaved(state);
  sh.autosaved_model_revision = state.model_revision;
  sh.autosaved_layout_revision = state.layout_revision;
  if (!sh.restoring.empty() && Absolute(state.project->path) == Absolute(sh.restoring)) {
    FinishRestore(state);
    return;
  }
  if (!sh.session_files) return;
  AddRecent(state, state.project->path);
  CheckRecovery(state);
}

void Autosave(AppState& state) {
  ShellState& sh = state.shell;
  if (!sh.session_files || !state.project || !HasUnsavedChanges(state)) return;
  if (sh.autosaved_model_revision == state.model_revision &&
      sh.autosaved_layout_revision == state.layout_revision)
    return;
  const auto now = std::chrono::steady_clock::now();
  if (!sh.autosave_due) {
    sh.autosave_due = true;
    sh.autosave_at = now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                               std::chrono::duration<double>(sh.autosave_seconds));
  }
  if (now < sh.autosave_at) return;
  sh.autosave_due = false;
  // A folder that cannot be written stays so: the warning is given once, not every 30 s, and
  // the next write that works says so.
  if (Status st = WriteRecovery(state); !st) {
    if (!sh.autosave_failing)
      AddMessage(state, Severity::kWarning,
                 "Autosave failed: " + st.error().ToString() +
                     ". It will go on trying; save the project to keep your changes.");
    sh.autosave_failing = true;
  } else if (sh.autosave_failing) {
    sh.autosave_failing = false;
    AddMessage(state, Severity::kInfo, "Autosave works again.");
  }
}

bool Pressed(int key) { return key >= 0 && ImGui::IsKeyPressed(key, false); }

void HandleShortcuts(AppState& state) {
  const ImGuiIO& io = ImGui::GetIO();
  // A dialog has the keyboard while it is open.
  if (ImGui::IsPopupOpen("", ImGuiPopupFlags_AnyPopupId | ImGuiPopupFlags_AnyPopupLevel)) return;
  const bool ctrl = io.KeyCtrl && !io.KeyAlt;
  if (ctrl && Pressed('O')) BrowseProject(state);
  if (ctrl && !io.KeyShift && Pressed('S')) SaveWithMessage(state);
  if (ctrl && io.KeyShift && Pressed('S')) BrowseSaveAs(state);
  if (ctrl && Pressed('Q')) RequestQuit(state);
  if (ctrl && Pressed('B')) state.shell.show_sidebar = !state.shell.show_sidebar;
  if (ctrl && Pressed(kKeyEqual)) Zoom(state, kZoomStep);
  if (ctrl && Pressed(kKeyMinus)) Zoom(state, 1.0f / kZoomStep);
  if (ctrl && Pressed('0')) Zoom(state, 1.0f / state.shell.zoom);
  if (ctrl) {
    for (std::size_t i = 0; i < kAllViews.size() && i < 9; ++i) {
      if (Pressed('1' + static_cast<int>(i))) state.view = kAllViews[i];
    }
  }
  if (!io.KeyCtrl && Pressed(kKeyF1)) state.shell.show_help = !state.shell.show_help;
  if (!io.KeyCtrl && Pressed(kKeyF5) && !EstimationRunning(state)) {
    std::string why;
    if (!StartEstimation(state, &why))
      AddMessage(state, Severity::kWarning, "The estimation cannot start: " + why);
  }
  // Esc in a text field reverts the field, in the shortcuts or messages window closes it; only
  // elsewhere does it cancel the run.
  const bool tool_window = state.shell.tool_window_focused;
  state.shell.tool_window_focused = false;  // the windows say it again as they are drawn
  if (!io.WantTextInput && !tool_window && Pressed(ImGui::GetKeyIndex(ImGuiKey_Escape)) &&
      EstimationRunning(state))
    CancelEstimation(state);
}

// ---------------------------------------------------------------------------------------------
// 7. Dialogs

// Acts on a file the browser returned.
void UseBrowsedFile(AppState& state, BrowsePurpose purpose, const std::string& path) {
  NewProjectForm& form = state.shell.new_form;
  switch (purpose) {
    case BrowsePurpose::kNone:
      break;
    case BrowsePurpose::kOpenProject:
      RequestOpenProject(state, path);
      break;
    case BrowsePurpose::kSaveProjectAs:
      if (Status st = SaveProjectAs(state, path); !st)
        AddMessage(state, Severity::kError, "Could not save the project: " + st.error().ToString());
      break;
    case BrowsePurpose::kOpenModel:
      if (Status st = ReplaceModel(state, path); !st)
        AddMessage(state, Severity::kError, "Could not open the model: " + st.error().ToString());
      break;
    case BrowsePurpose::kAddDataset:
      OpenImportDialog(state, path);
      break;
    case BrowsePurpose::kNewModel:
      form.model = path;
      if (form.name.empty()) {
        if (auto spec = model::LoadModelFile(path); spec && !spec->name.empty())
          form.name = spec->name;
      }
      break;
    case BrowsePurpose::kNewDataset:
      form.datasets.push_back(path);
      break;
    case BrowsePurpose::kNewProjectFile:
      form.project = path;
      break;
    case BrowsePurpose::kExportPlot:
    case BrowsePurpose::kSaveReport:
    case BrowsePurpose::kExportModel:
    case BrowsePurpose::kExportFmu:
    case BrowsePurpose::kViewImage:
      FinishExport(state, purpose, path);
      break;
  }
}

bool IsNewFormPurpose(BrowsePurpose p) {
  return p == BrowsePurpose::kNewModel || p == BrowsePurpose::kNewDataset ||
         p == BrowsePurpose::kNewProjectFile;
}

void DrawBrowser(AppState& state, bool inside_new_dialog) {
  const auto purpose = static_cast<BrowsePurpose>(state.shell.browser.purpose);
  if (IsNewFormPurpose(purpose) != inside_new_dialog) return;
  if (std::optional<std::string> path = DrawFileBrowser(state.shell.browser, state.fonts.scale))
    UseBrowsedFile(state, purpose, *path);
}

void CenterNextWindow() {
  const ImGuiViewport* vp = ImGui::GetMainViewport();
  ImGui::SetNextWindowPos(
      ImVec2(vp->WorkPos.x + vp->WorkSize.x * 0.5f, vp->WorkPos.y + vp->WorkSize.y * 0.4f),
      ImGuiCond_Appearing, ImVec2(0.5f, 0.5f));
}

void DrawUnsavedPrompt(AppState& state) {
  ShellState& sh = state.shell;
  if (sh.unsaved_prompt_requested) {
    sh.unsaved_prompt_requested = false;
    ImGui::OpenPopup(kUnsavedPopup);
  }
  CenterNextWindow();
  if (!ImGui::BeginPopupModal(kUnsavedPopup, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return;
  const std::string name = state.project ? Basename(state.project->path) : "the project";
  ImGui::PushFont(state.fonts.bold);
  ImGui::Text("Save the changes to %s?", name.c_str());
  ImGui::PopFont();
  ImGui::TextUnformatted("Your edits are lost if you don't save them.");
  if (!sh.unsaved_error.empty()) {
    ImGui::PushTextWrapPos(ImGui::GetCursorPosX() + 520.0f * state.fonts.scale);
    ImGui::TextColored(SeverityColor(Severity::kError), "%s", sh.unsaved_error.c_str());
    ImGui::PopTextWrapPos();
  }
  ImGui::Spacing();
  if (ImGui::Button("Save")) {
    if (Status st = SaveCurrentProject(state); st) {
      ImGui::CloseCurrentPopup();
      RunPending(state);
    } else {
      sh.unsaved_error = "Could not save: " + st.error().ToString();
    }
  }
  ImGui::SameLine();
  if (ImGui::Button("Discard changes")) {
    if (state.project) RemoveRecovery(state, state.project->path);
    MarkSaved(state);  // what is on disk is now what counts
    ImGui::CloseCurrentPopup();
    RunPending(state);
  }
  ImGui::SameLine();
  if (ImGui::Button("Cancel") || ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Escape))) {
    sh.pending = PendingAction{};
    ImGui::CloseCurrentPopup();
  }
  ImGui::EndPopup();
}

void DrawRecoveryPrompt(AppState& state) {
  ShellState& sh = state.shell;
  if (sh.recovery_prompt_requested) {
    sh.recovery_prompt_requested = false;
    ImGui::OpenPopup(kRecoveryPopup);
  }
  CenterNextWindow();
  if (!ImGui::BeginPopupModal(kRecoveryPopup, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return;
  ImGui::PushFont(state.fonts.bold);
  ImGui::TextUnformatted("greybench kept unsaved work on this project.");
  ImGui::PopFont();
  ImGui::TextUnformatted("It was written after the project was last saved");
  ImGui::TextUnformatted("(greybench may have been closed without saving, or crashed).");
  ImGui::TextDisabled("%s", sh.recovery_offer.c_str());
  ImGui::Spacing();
  if (ImGui::Button("Restore")) {
    RestoreRecovery(state);
    ImGui::CloseCurrentPopup();
  }
  ImGui::SameLine();
  if (ImGui::Button("Discard")) {
    std::error_code ec;
    fs::remove(sh.recovery_offer, ec);
    AddMessage(state, Severity::kInfo, "Discarded the recovered work " + sh.recovery_offer);
    sh.recovery_offer.clear();
    ImGui::CloseCurrentPopup();
  }
  ImGui::EndPopup();
}

// A path field with a Browse button that opens the file browser for `purpose`.
void PathRow(AppState& state, const char* label, std::string* path, const char* hint,
             BrowsePurpose purpose, FileBrowserRequest request) {
  const float s = state.fonts.scale;
  ImGui::PushID(label);
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted(label);
  ImGui::SameLine(110.0f * s);
  ImGui::SetNextItemWidth(440.0f * s);
  ImGui::InputTextWithHint("##path", hint, path);
  ImGui::SameLine();
  if (ImGui::Button("Browse\xE2\x80\xA6")) {
    request.purpose = static_cast<int>(purpose);
    if (!path->empty()) request.start = *path;
    OpenFileBrowser(state.shell.browser, std::move(request));
  }
  ImGui::PopID();
}

// How much of the first dataset the generated model's start values are taken from: the
// header and the first rows, without waiting for a long recording.
constexpr std::size_t kColumnsHeadBytes = 256 * 1024;

// Reads the first dataset's columns into the form (once per file), each an input but the last,
// which is the output, to start with.
void ReadColumns(NewProjectForm& f) {
  const std::string path = f.datasets.empty() ? std::string() : f.datasets.front();
  if (path == f.columns_of) return;
  f.columns_of = path;
  f.columns.clear();
  f.column_use.clear();
  f.duration.reset();
  f.columns_error.clear();
  if (path.empty()) return;
  if (data::IsMdfFile(path)) {
    f.columns_error = path +
                      ": an MDF recording's channels are chosen when it is added (File "
                      "\xE2\x80\xBA Add dataset\xE2\x80\xA6): start from a blank model, or "
                      "from a CSV file";
    return;
  }
  bool truncated = false;
  Result<std::string> head = data::ReadFileHead(path, kColumnsHeadBytes, &truncated);
  if (!head) {
    f.columns_error = head.error().ToString();
    return;
  }
  std::string text = std::move(head).value();
  if (truncated) text.erase(text.find_last_of('\n') + 1);  // whole lines only
  const data::CsvFormat format = data::FormatOf(data::PlainDataset(path), text);
  Result<std::shared_ptr<const data::Dataset>> d = data::ParseCsv(text, path, format);
  if (!d) {
    f.columns_error = d.error().ToString();
    return;
  }
  const data::Dataset& data = **d;
  for (const data::Column& c : data.columns) {
    model::ColumnSummary summary{c.name, std::nullopt, std::nullopt};
    double sum = 0, sum2 = 0;
    int n = 0;
    for (const double v : c.values) {
      if (!std::isfinite(v)) continue;
      if (!summary.first) summary.first = v;
      sum += v;
      sum2 += v * v;
      ++n;
    }
    if (n > 1) summary.sd = std::sqrt(std::max(0.0, (sum2 - sum * sum / n) / (n - 1)));
    f.columns.push_back(std::move(summary));
    f.column_use.push_back(ColumnUse::kInput);
  }
  if (!f.column_use.empty()) f.column_use.back() = ColumnUse::kOutput;
  if (data.rows() > 1) f.duration = data.time.back() - data.time.front();
}

// The model the form asks for, when it is not a file: the blank one or one generated from the
// first dataset's columns.
Result<Json> NewModelJson(const NewProjectForm& f, const std::string& name) {
  if (f.model_source == NewModelSource::kBlank) return model::BlankModel(name);
  if (f.datasets.empty()) return InputError("Add a data file: the model is made from its columns.");
  if (!f.columns_error.empty()) return InputError(f.columns_error);
  model::ColumnsModelRequest r;
  r.name = name;
  r.duration = f.duration;
  for (std::size_t i = 0; i < f.columns.size(); ++i) {
    if (f.column_use[i] == ColumnUse::kInput) r.inputs.push_back(f.columns[i]);
    if (f.column_use[i] == ColumnUse::kOutput) r.outputs.push_back(f.columns[i]);
  }
  return model::ModelFromColumns(r);
}

// Validates the form, writes the project file (and a new model beside it) and opens it.
void CreateProject(AppState& state) {
  NewProjectForm& f = state.shell.new_form;
  f.error.clear();
  const bool model_file = f.model_source == NewModelSource::kFile;
  if (model_file && f.model.empty()) {
    f.error = "Choose a model file, or start from a blank model or one made from the data.";
    return;
  }
  if (f.project.empty()) {
    f.error = "Choose where to save the project file.";
    return;
  }
  std::string project_path = f.project;
  if (fs::path(project_path).extension().empty()) project_path += ".json";
  project::Project p;
  p.name = f.name.empty() ? fs::path(project_path).stem().string() : f.name;
  // The new model, written beside the project once everything else is checked.
  std::optional<Json> new_model;
  std::string new_model_path;
  if (model_file) {
    Result<model::ModelSpec> spec = model::LoadModelFile(f.model);
    if (!spec) {
      f.error = spec.error().ToString();
      return;
    }
    p.model_path = Absolute(f.model);
  } else {
    Result<Json> j = NewModelJson(f, p.name);
    if (!j) {
      f.error = j.error().ToString();
      return;
    }
    new_model = std::move(j).value();
    const fs::path at = fs::path(Absolute(project_path));
    new_model_path = (at.parent_path() / (at.stem().string() + ".model.json")).string();
    std::error_code ec;
    if (fs::exists(new_model_path, ec)) {
      f.error = new_model_path +
                " exists already: choose another project name, or choose that "
                "file as the model.";
      return;
    }
    p.model_path = new_model_path;
  }
  for (const std::string& d : f.datasets) {
    std::error_code ec;
    if (!fs::is_regular_file(d, ec)) {
      f.error = d + ": there is no such file.";
      return;
    }
    p.datasets.push_back(data::PlainDataset(Absolute(d)));
  }
  if (Status st = CheckOutputs(project::ProjectFiles(p), {{project_path, "the project file"}});
      !st) {
    f.error = st.error().ToString();
    return;
  }
  if (new_model) {
    if (Status st = WriteFileAtomic(new_model_path, new_model->dump(1) + "\n"); !st) {
      f.error = st.error().ToString();
      return;
    }
  }
  if (Status st = project::SaveProject(p, project_path); !st) {
    f.error = st.error().ToString();
    std::error_code ec;
    if (new_model) fs::remove(new_model_path, ec);  // nothing half made is left behind
    return;
  }
  ImGui::CloseCurrentPopup();
  OpenNow(state, project_path);
}

// What each column of the first dataset becomes in the generated model.
void DrawColumnUses(AppState& state, NewProjectForm& f) {
  const float s = state.fonts.scale;
  ReadColumns(f);
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Columns");
  ImGui::SameLine(110.0f * s);
  ImGui::BeginGroup();
  if (f.datasets.empty()) {
    ImGui::TextDisabled("Add a data file: the model is made from its columns.");
  } else if (!f.columns_error.empty()) {
    ImGui::PushTextWrapPos(ImGui::GetCursorPosX() + 520.0f * s);
    ImGui::TextColored(SeverityColor(Severity::kError), "%s", f.columns_error.c_str());
    ImGui::PopTextWrapPos();
  } else {
    const char* uses[] = {"not used", "input", "output"};
    for (std::size_t i = 0; i < f.columns.size(); ++i) {
      ImGui::PushID(static_cast<int>(i));
      ImGui::SetNextItemWidth(110.0f * s);
      int use = static_cast<int>(f.column_use[i]);
      if (ImGui::Combo("##use", &use, uses, 3)) f.column_use[i] = static_cast<ColumnUse>(use);
      ImGui::SameLine();
      ImGui::AlignTextToFramePadding();
      ImGui::TextUnformatted(f.columns[i].name.c_str());
      ImGui::PopID();
    }
  }
  ImGui::EndGroup();
}

void DrawNewProjectDialog(AppState& state) {
  ShellState& sh = state.shell;
  if (sh.new_dialog_requested) {
    sh.new_dialog_requested = false;
    ImGui::OpenPopup(kNewPopup);
  }
  CenterNextWindow();
  if (!ImGui::BeginPopupModal(kNewPopup, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return;
  const float s = state.fonts.scale;
  NewProjectForm& f = sh.new_form;
  ImGui::TextDisabled("A project names a model and the data files it is fitted to.");
  ImGui::Spacing();
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Name");
  ImGui::SameLine(110.0f * s);
  ImGui::SetNextItemWidth(440.0f * s);
  ImGui::InputTextWithHint("##name", "the project file's name when empty", &f.name);

  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Model");
  ImGui::SameLine(110.0f * s);
  int source = static_cast<int>(f.model_source);
  ImGui::RadioButton("a model file", &source, static_cast<int>(NewModelSource::kFile));
  ImGui::SameLine();
  ImGui::RadioButton("a blank model", &source, static_cast<int>(NewModelSource::kBlank));
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "One state x, one output y = x, no inputs: rename and extend it in the "
        "Equations view");
  ImGui::SameLine();
  ImGui::RadioButton("made from the first dataset's columns", &source,
                     static_cast<int>(NewModelSource::kFromData));
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "One input per input column, one output per output column, and a "
        "first-order state per output");
  f.model_source = static_cast<NewModelSource>(source);
  if (f.model_source == NewModelSource::kFile) {
    FileBrowserRequest model_request;
    model_request.title = "Choose the model";
    model_request.confirm = "Choose";
    model_request.filters = kModelFilters;
    PathRow(state, "Model file", &f.model, "model.json", BrowsePurpose::kNewModel, model_request);
  } else {
    ImGui::Indent(110.0f * s);
    ImGui::TextDisabled(
        "Written beside the project as NAME.model.json (NAME: the project "
        "file's name).");
    ImGui::Unindent(110.0f * s);
  }

  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Datasets");
  ImGui::SameLine(110.0f * s);
  ImGui::BeginGroup();
  int remove = -1;
  for (int i = 0; i < static_cast<int>(f.datasets.size()); ++i) {
    ImGui::PushID(i);
    ImGui::AlignTextToFramePadding();
    ImGui::TextUnformatted(f.datasets[i].c_str());
    ImGui::SameLine();
    if (ImGui::SmallButton("Remove")) remove = i;
    ImGui::PopID();
  }
  if (remove >= 0) f.datasets.erase(f.datasets.begin() + remove);
  if (ImGui::Button("Add data file\xE2\x80\xA6")) {
    FileBrowserRequest r;
    r.title = "Add a data file";
    r.confirm = "Add";
    r.filters = kDataFilters;
    r.purpose = static_cast<int>(BrowsePurpose::kNewDataset);
    if (!f.datasets.empty())
      r.start = f.datasets.back();
    else if (!f.model.empty())
      r.start = f.model;
    OpenFileBrowser(sh.browser, std::move(r));
  }
  ImGui::EndGroup();

  if (f.model_source == NewModelSource::kFromData) DrawColumnUses(state, f);

  FileBrowserRequest save_request;
  save_request.title = "Save the new project as";
  save_request.confirm = "Choose";
  save_request.mode = FileBrowserMode::kSave;
  save_request.filters = kProjectFilters;
  save_request.file_name = "project.json";
  if (!f.model.empty()) save_request.start = f.model;
  PathRow(state, "Project file", &f.project, "where to write the project (.json)",
          BrowsePurpose::kNewProjectFile, save_request);

  if (!f.error.empty()) {
    ImGui::PushTextWrapPos(ImGui::GetCursorPosX() + 640.0f * s);
    ImGui::TextColored(SeverityColor(Severity::kError), "%s", f.error.c_str());
    ImGui::PopTextWrapPos();
  }
  ImGui::Separator();
  if (ImGui::Button("Create")) CreateProject(state);
  ImGui::SameLine();
  if (ImGui::Button("Cancel")) ImGui::CloseCurrentPopup();
  DrawBrowser(state, /*inside_new_dialog=*/true);
  ImGui::EndPopup();
}

void DrawShortcutsWindow(AppState& state) {
  if (!state.shell.show_shortcuts) return;
  CenterNextWindow();
  ImGui::PushStyleVar(ImGuiStyleVar_WindowBorderSize, 1.0f);  // as the Messages window
  const bool open = ImGui::Begin("Keyboard shortcuts", &state.shell.show_shortcuts,
                                 ImGuiWindowFlags_NoCollapse | ImGuiWindowFlags_AlwaysAutoResize);
  ImGui::PopStyleVar();
  // Esc closes it, as it closes the dialogs.
  if (open && ImGui::IsWindowFocused(ImGuiFocusedFlags_RootAndChildWindows)) {
    state.shell.tool_window_focused = true;
    if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Escape), false))
      state.shell.show_shortcuts = false;
  }
  if (open) {
    if (ImGui::BeginTable("##shortcuts", 2, ImGuiTableFlags_SizingFixedFit)) {
      for (const ShortcutInfo& k : kShortcuts) {
        ImGui::TableNextRow();
        ImGui::TableNextColumn();
        if (*k.keys && !*k.action) {
          ImGui::PushFont(state.fonts.bold);
          ImGui::TextUnformatted(k.keys);
          ImGui::PopFont();
          continue;
        }
        ImGui::PushFont(state.fonts.mono);
        ImGui::TextUnformatted(k.keys);
        ImGui::PopFont();
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(k.action);
      }
      ImGui::EndTable();
    }
  }
  ImGui::End();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Public functions (sections 1-6)

void StartSession(AppState& state) {
  ShellState& sh = state.shell;
  sh.session_files = true;
  state.estimation.keep_on_disk = true;  // each fit written beside the project (kept_fits.h)
  sh.recent_file =
      (fs::path(XdgDir("XDG_CONFIG_HOME", ".config")) / "greybench" / "recent.json").string();
  sh.recovery_dir =
      (fs::path(XdgDir("XDG_STATE_HOME", ".local/state")) / "greybench" / "recovery").string();
  ReadRecent(state);
}

bool HasUnsavedChanges(const AppState& state) {
  return state.project && (state.model_revision != state.shell.saved_model_revision ||
                           state.layout_revision != state.shell.saved_layout_revision);
}

std::string WindowTitle(const AppState& state) {
  if (!state.project) return "greybench";
  const project::Project& p = *state.project;
  return "greybench \xE2\x80\x94 " + (p.name.empty() ? Basename(p.path) : p.name) +
         (HasUnsavedChanges(state) ? " *" : "");
}

// A diagram the project names by its file stays in that file: the diagram as it is now is written
// there (when it changed) and the project keeps the path, relative to `target`'s folder.
Status KeepDiagramFile(const AppState& state, const std::string& target, project::Project* p) {
  const DiagramViewState& v = state.diagram_view;
  if (v.file.empty() || !v.keep_file || !v.diagram || !p->extra.is_object() ||
      !p->extra.contains("diagram"))
    return Ok{};
  const std::string text = diagram::ToJson(*v.diagram).dump(1) + "\n";
  Result<Json> on_disk = ReadJsonFile(v.file);
  if (!on_disk || on_disk->dump(1) + "\n" != text) {
    if (Status st = WriteFileAtomic(v.file, text); !st) return st;
  }
  std::error_code ec;
  const fs::path relative = fs::relative(v.file, fs::path(target).parent_path(), ec);
  p->extra["diagram"] = ec || relative.empty() ? v.file : relative.generic_string();
  return Ok{};
}

Status SaveProjectAs(AppState& state, const std::string& path) {
  if (!state.project) return InputError("no project is open");
  const std::string target = Absolute(path);
  project::Project p = ProjectToSave(state);
  // The project may be saved over itself, never over a file it is made of.
  std::vector<FileRole> inputs = project::ProjectFiles(*state.project);
  const std::string& current = state.project->path;
  std::erase_if(inputs, [&](const FileRole& f) { return f.path == current; });
  inputs.push_back({state.diagram_view.file, "the diagram file"});
  if (Status st = CheckOutputs(inputs, {{target, "the project file to save"}}); !st) return st;
  if (Status st = KeepDiagramFile(state, target, &p); !st) return st;
  if (Status st = project::SaveProject(p, target); !st) return st;
  const std::string old_path = state.project->path;
  p.path = target;
  p.base_dir = fs::path(target).parent_path().string();
  state.project = std::move(p);
  RemoveRecovery(state, old_path);
  RemoveRecovery(state, target);
  MarkSaved(state);
  WriteUnwrittenFits(state);
  state.shell.autosaved_model_revision = state.model_revision;
  state.shell.autosaved_layout_revision = state.layout_revision;
  if (state.shell.session_files) AddRecent(state, target);
  AddMessage(state, Severity::kInfo,
             "Saved " + target + (state.project->model_path.empty() ? " (model inline)" : ""));
  return Ok{};
}

Status SaveCurrentProject(AppState& state) {
  if (!state.project) return InputError("no project is open");
  return SaveProjectAs(state, state.project->path);
}

void RequestQuit(AppState& state) { Guard(state, {PendingAction::Kind::kQuit, ""}); }

void RequestOpenProject(AppState& state, const std::string& path) {
  Guard(state, {PendingAction::Kind::kOpen, path});
}

Status ReplaceModel(AppState& state, const std::string& path) {
  if (!state.project) return InputError("no project is open");
  Result<model::ModelSpec> spec = model::LoadModelFile(path);
  if (!spec) return spec.error();
  state.project->model_path = Absolute(path);
  state.project->model_json = model::ToJson(*spec);
  state.model = std::move(spec).value();
  state.model_error.clear();
  ResolveMessages(state, MessageTopic::kModel);
  ++state.model_revision;
  // The fit and the parameter edits belonged to the previous model.
  if (state.estimation.job.active()) state.estimation.job.RequestCancel();
  state.estimation.result.reset();
  state.estimation.shown = -1;
  state.estimation.last_failure.clear();
  state.parameters_view = ParametersViewState{};
  AddMessage(state, Severity::kInfo, "The project's model is now " + Basename(path) + ".");
  return Ok{};
}

void AddDataset(AppState& state, const std::string& path) {
  AddDataset(state, data::PlainDataset(path));
}

void AddDataset(AppState& state, data::DatasetSpec spec) {
  if (!state.project || state.shell.dataset_job.active()) return;
  state.shell.dataset_generation = state.project_generation;
  spec.file = Absolute(spec.file);
  state.shell.dataset_job.Start([spec = std::move(spec)](JobControl&) {
    DatasetRead out;
    out.path = spec.file;
    out.spec = spec;
    const std::string& path = spec.file;
    try {
      Result<std::shared_ptr<const data::Dataset>> read = data::ReadDataset(spec);
      if (read) {
        out.data = std::move(read).value();
        out.summary = Summarize(*out.data);
      } else {
        out.error = read.error().ToString();
      }
    } catch (const std::exception& e) {  // e.g. out of memory on a huge file
      out.data.reset();
      out.error = path + ": " + e.what();
    }
    return out;
  });
}

std::string RecoveryPath(const AppState& state, const std::string& project_path) {
  const std::string absolute = Absolute(project_path);
  const std::string stem = fs::path(absolute).stem().string();
  return (fs::path(state.shell.recovery_dir) / (stem + "-" + PathHash(absolute) + ".json"))
      .string();
}

Status WriteRecovery(AppState& state) {
  ShellState& sh = state.shell;
  if (!state.project) return InputError("no project is open");
  if (sh.recovery_dir.empty()) return InputError("recovery files are off (no session)");
  std::error_code ec;
  fs::create_directories(sh.recovery_dir, ec);
  if (ec) return InputError("cannot create " + sh.recovery_dir + ": " + ec.message());
  project::Project p = ProjectToSave(state);
  Json info = {{"project", Absolute(state.project->path)},
               {"model_file", state.project->model_path}};
  p.model_path.clear();  // the model inline, edits and all
  if (!p.extra.is_object()) p.extra = Json::object();
  p.extra[kRecoveryKey] = std::move(info);
  const std::string path = RecoveryPath(state, state.project->path);
  if (Status st = project::SaveProject(p, path, /*relative_paths=*/false); !st) return st;
  sh.autosaved_model_revision = state.model_revision;
  sh.autosaved_layout_revision = state.layout_revision;
  return Ok{};
}

void RestoreRecovery(AppState& state) {
  ShellState& sh = state.shell;
  if (sh.recovery_offer.empty() || !state.project) return;
  sh.restoring = sh.recovery_offer;
  sh.restoring_project = state.project->path;
  sh.recovery_offer.clear();
  OpenNow(state, sh.restoring);
}

void AddRecent(AppState& state, const std::string& path) {
  std::vector<std::string>& r = state.shell.recent;
  const std::string absolute = Absolute(path);
  r.erase(std::remove(r.begin(), r.end(), absolute), r.end());
  r.insert(r.begin(), absolute);
  if (r.size() > static_cast<std::size_t>(kMaxRecent)) r.resize(kMaxRecent);
  WriteRecent(state);
}

void RemoveRecent(AppState& state, const std::string& path) {
  std::vector<std::string>& r = state.shell.recent;
  const auto end = std::remove(r.begin(), r.end(), Absolute(path));
  if (end == r.end()) return;
  r.erase(end, r.end());
  WriteRecent(state);
}

void UpdateShell(AppState& state) {
  ShellState& sh = state.shell;
  UpdateExports(state);
  if (state.project_generation != sh.seen_generation) {
    sh.seen_generation = state.project_generation;
    if (state.project) OnProjectInstalled(state);
    sh.opening.clear();
  }
  if (!sh.opening.empty() && !state.load_job.active()) {
    // The open the shell asked for finished without installing a project: it failed.
    if (sh.session_files) RemoveRecent(state, sh.opening);
    if (sh.opening == sh.restoring) {
      sh.restoring.clear();
      sh.restoring_project.clear();
    }
    sh.opening.clear();
  }
  if (std::optional<DatasetRead> read = sh.dataset_job.TakeIfReady())
    InstallDataset(state, std::move(*read));
  if (state.open_dialog_requested) {
    state.open_dialog_requested = false;
    BrowseProject(state);
  }
  Autosave(state);
  HandleShortcuts(state);
}

bool OpenDialogByName(AppState& state, std::string_view name) {
  if (name == "open-project") {
    BrowseProject(state);
  } else if (name == "save-project-as") {
    BrowseSaveAs(state);
  } else if (name == "new-project") {
    state.shell.new_form = NewProjectForm{};
    state.shell.new_dialog_requested = true;
  } else if (name == "keyboard-shortcuts") {
    state.shell.show_shortcuts = true;
  } else if (name.rfind("user-guide", 0) == 0) {
    // "user-guide" at the workbench's section, "user-guide:6b" at the section numbered 6b.
    state.shell.show_help = true;
    if (name.size() > 11 && name[10] == ':') {
      state.shell.guide_section_wanted = std::string(name.substr(11)) + ".";
    }
  } else if (name == "import-dataset") {
    // On the project's last dataset's file, as File > Add dataset… would open it.
    if (state.datasets.empty()) return false;
    OpenImportDialog(state, state.datasets.back().path);
  } else if (name == "unsaved-changes") {
    state.shell.pending = PendingAction{};
    state.shell.unsaved_error.clear();
    state.shell.unsaved_prompt_requested = true;
  } else {
    return false;
  }
  return true;
}

std::string ViewShortcut(View view) {
  for (std::size_t i = 0; i < kAllViews.size() && i < 9; ++i) {  // Ctrl+0 resets the zoom
    if (kAllViews[i] == view) return "Ctrl+" + std::to_string(i + 1);
  }
  return "";
}

void SetTheme(AppState& state, ThemeKind theme) {
  if (state.shell.theme == theme) return;
  state.shell.theme = theme;
  WriteRecent(state);
}

void Zoom(AppState& state, float factor) {
  float z = std::clamp(state.shell.zoom * factor, kMinZoom, kMaxZoom);
  if (std::abs(z - 1.0f) < 0.01f) z = 1.0f;  // steps back to exactly 100 %
  state.shell.zoom = z;
}

void DrawZoomMenuItems(AppState& state) {
  if (ImGui::MenuItem("Zoom in", "Ctrl+=", false, state.shell.zoom < kMaxZoom))
    Zoom(state, kZoomStep);
  if (ImGui::MenuItem("Zoom out", "Ctrl+-", false, state.shell.zoom > kMinZoom))
    Zoom(state, 1.0f / kZoomStep);
  const std::string actual = "Actual size (" +
                             std::to_string(static_cast<int>(std::lround(state.shell.zoom * 100))) +
                             " %)";
  if (ImGui::MenuItem(actual.c_str(), "Ctrl+0", false, state.shell.zoom != 1.0f))
    Zoom(state, 1.0f / state.shell.zoom);
}

// ---------------------------------------------------------------------------------------------
// 6. The File menu

void DrawFileMenu(AppState& state) {
  ShellState& sh = state.shell;
  const bool loading = state.load_job.active();
  const bool open = state.project.has_value();
  if (ImGui::MenuItem("New project\xE2\x80\xA6", nullptr, false, !loading))
    Guard(state, {PendingAction::Kind::kNew, ""});
  if (ImGui::MenuItem("Open project\xE2\x80\xA6", "Ctrl+O", false, !loading)) BrowseProject(state);
  if (ImGui::BeginMenu("Open recent", !loading)) {
    if (sh.recent.empty()) ImGui::TextDisabled(sh.session_files ? "No recent projects" : "Off");
    for (const std::string& path : sh.recent) {
      if (ImGui::MenuItem(Basename(path).c_str())) {
        RequestOpenProject(state, path);
        break;  // the list may change
      }
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", path.c_str());
    }
    if (!sh.recent.empty()) {
      ImGui::Separator();
      if (ImGui::MenuItem("Clear the list")) {
        sh.recent.clear();
        WriteRecent(state);
      }
    }
    ImGui::EndMenu();
  }
  ImGui::Separator();
  if (ImGui::MenuItem("Save project", "Ctrl+S", false, open && !loading)) SaveWithMessage(state);
  if (ImGui::MenuItem("Save project as\xE2\x80\xA6", "Ctrl+Shift+S", false, open && !loading))
    BrowseSaveAs(state);
  ImGui::Separator();
  if (ImGui::MenuItem("Open model\xE2\x80\xA6", nullptr, false, open && !loading)) {
    FileBrowserRequest r;
    r.title = "Open model (replaces the project's model)";
    r.filters = kModelFilters;
    r.start = state.project->model_path.empty() ? state.project->path : state.project->model_path;
    r.purpose = static_cast<int>(BrowsePurpose::kOpenModel);
    OpenFileBrowser(sh.browser, std::move(r));
  }
  if (ImGui::MenuItem("Add dataset\xE2\x80\xA6", nullptr, false,
                      open && !loading && !sh.dataset_job.active())) {
    FileBrowserRequest r;
    r.title = "Add a dataset to the project";
    r.confirm = "Add";
    r.filters = kDataFilters;
    r.start = state.datasets.empty() ? state.project->path : state.datasets.back().path;
    r.purpose = static_cast<int>(BrowsePurpose::kAddDataset);
    OpenFileBrowser(sh.browser, std::move(r));
  }
  if (ImGui::MenuItem("Reload project", nullptr, false, open && !loading))
    RequestOpenProject(state, state.project->path);
  ImGui::Separator();
  DrawExportMenu(state);
  ImGui::Separator();
  if (ImGui::MenuItem("Quit", "Ctrl+Q")) RequestQuit(state);
}

void DrawShellDialogs(AppState& state) {
  DrawBrowser(state, /*inside_new_dialog=*/false);
  DrawUnsavedPrompt(state);
  DrawRecoveryPrompt(state);
  DrawNewProjectDialog(state);
  DrawImportDialog(state);
  DrawShortcutsWindow(state);
  DrawHelpWindow(state);
}

}  // namespace gb::ui
