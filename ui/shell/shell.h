// The application shell around the views: the File menu and its dialogs (an in-app file
// browser), saving, recent projects, the unsaved-changes guard, autosave and crash recovery,
// and keyboard shortcuts. State in AppState::shell (ui/state/shell_state.h).
//
//   StartSession(state);        // greybench only: recent files, autosave, recovery
//   every frame, inside DrawWorkbench:
//     UpdateShell(state);       // after PollJobs: shortcuts, autosave, installs added data
//     DrawFileMenu(state);      // inside the menu bar
//     DrawShellDialogs(state);  // browser, "save changes?", recovery offer, new project, help
//
// Files:
//   recent projects   $XDG_CONFIG_HOME/greybench/recent.json (default ~/.config/greybench/)
//                     {"greybench_recent": 1, "projects": ["/abs/a.json", ...]}, newest first,
//                     at most kMaxRecent; a corrupt file is ignored with a warning.
//   recovery files    $XDG_STATE_HOME/greybench/recovery/<project stem>-<hash>.json (default
//                     ~/.local/state/greybench/recovery/): the project with its model inline
//                     and absolute data paths, plus "greybench_recovery": {"project": path,
//                     "model_file": path or ""}. Written autosave_seconds after an unsaved
//                     edit; deleted when the project is saved or the changes are discarded.
//
// Saving writes the model the views show (with its edits). A project that names a model
// file keeps naming it while that file holds exactly this model; once the model has been
// edited, it is written inline into the project file (the shared model file is never
// rewritten behind the user's back; File > Save project as can put it anywhere).
#pragma once

#include <string>
#include <string_view>

#include "core/util/result.h"
#include "ui/state/app_state.h"

namespace gb::ui {

inline constexpr int kMaxRecent = 10;

// Key codes as the GLFW backend fills ImGuiIO::KeysDown (GLFW_KEY_*: letters and digits are
// their ASCII codes); greybench_main.cpp checks them against glfw3.h.
inline constexpr int kKeyF5 = 294;
inline constexpr int kKeyF1 = 290;
inline constexpr int kKeyEqual = 61;
inline constexpr int kKeyMinus = 45;
inline constexpr float kMinZoom = 0.75f;
inline constexpr float kMaxZoom = 2.0f;
inline constexpr float kZoomStep = 1.125f;  // a factor per Ctrl+= / Ctrl+-

// Turns on recent files, autosave and recovery (reads $XDG_CONFIG_HOME, $XDG_STATE_HOME,
// $HOME now), and keeping each fit on disk beside the project; reads the recent projects.
void StartSession(AppState& state);

// The project on disk differs from what the views show (an edit since the last save).
bool HasUnsavedChanges(const AppState& state);
// "greybench — Fuel film f1 *": the window title, with * when there are unsaved changes.
std::string WindowTitle(const AppState& state);

// Saves the open project (with the current model) to `path`, which becomes the project's
// path; updates the recent list and removes the recovery file. Errors name the file.
Status SaveProjectAs(AppState& state, const std::string& path);
// Saves to the project's own path.
Status SaveCurrentProject(AppState& state);

// Quit / open another project / new project, through "save changes?" when there are unsaved
// changes. Quitting sets state.quit_requested once answered.
void RequestQuit(AppState& state);
void RequestOpenProject(AppState& state, const std::string& path);

// Replaces the project's model by the model file at `path` (validated first).
Status ReplaceModel(AppState& state, const std::string& path);
// Starts reading a CSV file that UpdateShell appends to the project's datasets.
void AddDataset(AppState& state, const std::string& path);
// The same for a dataset entry with keys (the import dialog's).
void AddDataset(AppState& state, data::DatasetSpec spec);

// The recovery file of `project_path` (see above), and writing it now.
std::string RecoveryPath(const AppState& state, const std::string& project_path);
Status WriteRecovery(AppState& state);
// Loads the offered recovery file: the project comes back with its unsaved edits.
void RestoreRecovery(AppState& state);

// Recent projects: `path` to the front (and written), or dropped from the list.
void AddRecent(AppState& state, const std::string& path);
void RemoveRecent(AppState& state, const std::string& path);

// Opens a dialog by name, as its menu item does: "open-project", "save-project-as",
// "new-project", "keyboard-shortcuts", "unsaved-changes", "import-dataset" (on the project's
// last dataset's file), "user-guide" (Help › User guide; "user-guide:6b" at section 6b)
// (greybench-snapshot --dialog). False for an unknown name (kDialogNames
// lists them), and for import-dataset in a project without datasets.
bool OpenDialogByName(AppState& state, std::string_view name);
inline constexpr const char* kDialogNames =
    "open-project save-project-as new-project keyboard-shortcuts unsaved-changes import-dataset "
    "user-guide[:SECTION]";

void UpdateShell(AppState& state);
void DrawFileMenu(AppState& state);
void DrawShellDialogs(AppState& state);
// The shortcut text shown in the View menu for a view ("Ctrl+1").
std::string ViewShortcut(View view);
// The zoom items of the View menu (Zoom in / out / Actual size).
void DrawZoomMenuItems(AppState& state);
// Multiplies state.shell.zoom by `factor`, within [kMinZoom, kMaxZoom] (1: back to 100 %).
void Zoom(AppState& state, float factor);
// View > Theme: the colours greybench applies before the next frame, remembered for the next
// start (in the recent-projects file).
void SetTheme(AppState& state, ThemeKind theme);

}  // namespace gb::ui
