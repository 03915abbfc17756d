// What the application shell remembers between frames (AppState::shell): the file browser,
// recent projects, the saved state of the project (for the unsaved-changes marker), the action
// waiting for an answer to "save changes?", autosave and crash recovery, and the dialogs of the
// File menu. ui/shell/shell.h has the functions that work on it.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/data/dataset.h"
#include "core/data/import.h"
#include "core/data/mdf4.h"
#include "core/fmu/fmu.h"
#include "core/model/model_structure.h"
#include "core/report/report.h"
#include "ui/jobs/job.h"
#include "ui/state/data_summary.h"
#include "ui/widgets/file_browser.h"
#include "ui/widgets/plot.h"

namespace gb::ui {

// What the file browser was opened for (FileBrowserRequest::purpose).
enum class BrowsePurpose {
  kNone,
  kOpenProject,
  kSaveProjectAs,
  kOpenModel,
  kAddDataset,
  kNewModel,  // the New project dialog's fields
  kNewDataset,
  kNewProjectFile,
  kExportPlot,  // ui/export/export.h
  kSaveReport,
  kExportModel,
  kExportFmu,
  kViewImage,  // File › Export › Image of the view
};

// An action that replaces or closes the open project: it waits for "save changes?" when the
// project has unsaved changes.
struct PendingAction {
  enum class Kind { kNone, kQuit, kOpen, kNew };
  Kind kind = Kind::kNone;
  std::string path;  // kOpen: the project to open
};

// A plot to draw alone at width x height pixels and write to `path` as PNG (ui/export/export.h).
struct PendingPng {
  report::Figure figure;
  int width = 0, height = 0;
  std::string path;
};

// The current view drawn whole (the workbench as the window shows it) at width x height pixels,
// written to `path` as PNG: File › Export › Image of the view (ui/export/export.h).
struct PendingViewImage {
  int width = 0, height = 0;
  std::string path;
};

// How an FMU export ended (ui/export/export.h): written, or why not.
struct FmuExportEnd {
  std::string path;
  std::string error;    // empty when written
  std::string summary;  // "Model Exchange and Co-Simulation, identifier fuel_film; ..."
  std::string warning;  // the output delays the FMU does not carry, or empty
};

// A dataset file read off the UI thread for File > Add dataset.
struct DatasetRead {
  std::string path;
  data::DatasetSpec spec;                     // the entry read (file = path)
  std::shared_ptr<const data::Dataset> data;  // null when the file could not be read
  std::string error;
  DatasetSummary summary;
};

// The import dialog's form (ui/shell/import_dialog.h).
struct ImportForm {
  bool requested = false;  // opens the dialog at the next frame
  std::string path;        // the recording
  std::string preview;     // its first 64 KB, cut at a line end
  bool truncated = false;  // the file is longer than the preview
  std::string read_error;  // why there is no preview

  bool header = true;
  int separator = 0;               // 0 ',', 1 ';', 2 TAB
  int decimal = 0;                 // 0 '.', 1 ','
  std::vector<std::string> names;  // the fields' names, as edited (empty: the header's, c1, ...)
  int time = 0;                    // 0: no time column (rows sample_time apart); k: field k
  double sample_time = 0.1;
  std::vector<std::string> map;  // per model input, then output: "" = the column of its name
  std::string name;
  bool validation = false;
  // Preparation (the entry's range, detrend and resample keys).
  bool use_range = false;
  double range_from = 0, range_to = 0;  // seconds
  int detrend = 0;                      // 0 none, 1 means, 2 linear trends (every column)
  double resample = 0;                  // a new sample time in seconds; 0: keep
  // An ASAM MDF file (data::IsMdfFile): its channels, picked, instead of the CSV preview.
  bool mdf = false;
  std::shared_ptr<const data::Mdf4File> mdf_file;
  std::vector<std::string> channels;  // each numeric channel as an entry names it (name or name@G)
  std::vector<bool> use;              // per channel: read it
  int time_base = 0;                  // the group (1-based number) whose master times the rows;
                                      // 0: a uniform grid, sample_time apart
  int interpolation = 0;              // channels at other rates: 0 hold, 1 linear

  // What the check found (CheckImport), and the form it checked.
  std::string checked;  // the entry's JSON when last checked
  struct Field {
    std::string name;
    std::vector<double> values;  // the first rows
  };
  std::vector<Field> fields;
  std::string fields_error;  // why the fields could not be read
  std::string check;         // in words: the rows read and bound, or what is wrong
  bool check_ok = false;
};

// Where a new project's model comes from: a model file, the blank model, or one generated from
// the first dataset's columns (core/model/model_structure.h); the last two are written beside
// the project as NAME.model.json.
enum class NewModelSource { kFile, kBlank, kFromData };
enum class ColumnUse { kUnused, kInput, kOutput };

struct NewProjectForm {
  std::string name;
  NewModelSource model_source = NewModelSource::kFile;
  std::string model;
  std::vector<std::string> datasets;
  std::string project;  // the file to create
  std::string error;    // why Create was refused
  // kFromData: the columns of the first dataset (read from `columns_of` when it changes) and
  // what each becomes.
  std::string columns_of;
  std::vector<model::ColumnSummary> columns;
  std::vector<ColumnUse> column_use;
  std::optional<double> duration;  // the time span of the rows read
  std::string columns_error;       // why the columns could not be read
};

// A section of the user guide as the Help window shows it: its heading and its Markdown lines.
struct GuideSection {
  std::string title;  // "6b. Experiment design: ..."
  int level = 2;      // 2 for "##", 3 for "###"
  std::vector<std::string> lines;
};

// The workbench's colours: the light theme; a dark one; and a high-contrast light one for
// projectors (black text, darker rules, thicker lines). ui/theme.h applies them.
enum class ThemeKind { kLight, kDark, kProjector };

struct ShellState {
  // The Keyboard shortcuts or Messages window had the focus in the last frame: Esc closes it and
  // does not cancel the estimation.
  bool tool_window_focused = false;
  FileBrowserState browser;
  // A plot's export, and a report, waiting for their file names, and a PNG of a plot waiting to
  // be drawn offscreen after the frame (ui/export/export.h).
  std::optional<plot::ExportRequest> plot_export;
  std::optional<report::ReportInput> report_export;
  std::optional<PendingPng> png_export;
  std::optional<PendingViewImage> view_image;            // chosen, to be drawn after the frame
  int view_image_width = 1024, view_image_height = 768;  // the size the menu asked for
  // File > Export > FMU: the interfaces chosen in the menu, and the build under way (the C
  // compiler runs off the UI thread).
  fmu::Interface fmu_interface = fmu::Interface::kBoth;
  bool fmu_virtual_sensor = false;  // the filter instead (export-fmu --virtual-sensor)
  Job<FmuExportEnd> fmu_job;

  // Recent projects, autosave and recovery read and write files under the user's
  // $XDG_CONFIG_HOME and $XDG_STATE_HOME; only the greybench window turns them on
  // (StartSession), so the snapshot renderer and tests touch nothing by default.
  bool session_files = false;
  std::string recent_file;          // .../greybench/recent.json
  std::string recovery_dir;         // .../greybench/recovery
  std::vector<std::string> recent;  // most recent first, absolute paths

  // The revisions the project file on disk corresponds to (AppState::model_revision and
  // layout_revision at the last save or open). -1: never saved (a restored recovery).
  int saved_model_revision = 0;
  int saved_layout_revision = 0;
  int seen_generation = 0;  // AppState::project_generation handled by the shell
  std::string opening;      // a project the shell asked to open, until it loads or fails

  PendingAction pending;  // waiting for "save changes?"
  bool unsaved_prompt_requested = false;
  std::string unsaved_error;  // the save in the prompt failed: why

  // Autosave: the recovery file is written `autosave_seconds` after an edit it does not hold.
  double autosave_seconds = 30.0;
  int autosaved_model_revision = -1;
  int autosaved_layout_revision = -1;
  bool autosave_due = false;
  std::chrono::steady_clock::time_point autosave_at;
  bool autosave_failing = false;  // said once; retried quietly until a write works again

  // Recovery: a recovery file newer than the project just opened, offered for restoring.
  std::string recovery_offer;
  bool recovery_prompt_requested = false;
  std::string restoring;          // the recovery file being loaded to restore it
  std::string restoring_project;  // ... and the project it belongs to

  bool new_dialog_requested = false;
  NewProjectForm new_form;

  Job<DatasetRead> dataset_job;  // File > Add dataset
  ImportForm import;             // its dialog
  int dataset_generation = 0;    // AppState::project_generation it was started for

  bool show_shortcuts = false;  // Help > Keyboard shortcuts
  // Help > User guide (F1): docs/user-guide.md of the source tree, read when first shown.
  bool show_help = false;
  std::string guide_file;  // empty: the build's own docs/user-guide.md
  std::vector<GuideSection> guide;
  std::string guide_error;           // why the guide could not be read
  int guide_section = -1;            // shown; -1: the first on the workbench (section 6)
  std::string guide_section_wanted;  // "6b.": show the section so numbered once read

  // View > Theme (kept in the recent-projects file beside the list). greybench applies it with
  // the fonts and the style before the next frame; greybench-snapshot --theme.
  ThemeKind theme = ThemeKind::kLight;
  bool show_sidebar = true;  // View › Sidebar (Ctrl+B): hidden, the view has the whole width

  // View > Zoom: a factor on the monitor's content scale. greybench rebuilds the fonts and
  // the style at the new scale before the next frame (the snapshot renderer ignores it).
  float zoom = 1.0f;
};

}  // namespace gb::ui
