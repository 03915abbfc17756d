// Everything the workbench shows and remembers, in one struct owned by main(). Panels receive
// it by reference; no panel keeps data of its own between frames.
//
//   AppState state;                    // main()
//   OpenProject(state, path);          // starts the loading job
//   every frame: DrawWorkbench(state); // polls jobs, draws menu, sidebar, current view
#pragma once

#include <imgui.h>

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/data/dataset.h"
#include "core/project/project.h"
#include "ui/data_summary.h"
#include "ui/job.h"
#include "ui/widgets/plot.h"

namespace gb::ui {

// The views of CONTRACT section 6, in the order of the workflow.
enum class View {
  kData,
  kDiagram,
  kEquations,
  kEstimate,
  kPredictions,
  kResiduals,
  kParameters,
  kOperatingPoints,
};
inline constexpr std::array<View, 8> kAllViews = {
    View::kData,        View::kDiagram,   View::kEquations,  View::kEstimate,
    View::kPredictions, View::kResiduals, View::kParameters, View::kOperatingPoints};

std::string_view ViewName(View view);   // the command-line name: "operating-points"
std::string_view ViewTitle(View view);  // the title in the UI: "Operating points"
std::optional<View> ParseView(std::string_view name);

enum class Severity { kInfo, kWarning, kError };
struct Message {
  Severity severity = Severity::kInfo;
  std::string text;
};

// Fonts of the workbench (owned by ImGui's font atlas). Any may be the default font when the
// DejaVu files are missing; never null after LoadFonts().
struct Fonts {
  ImFont* regular = nullptr;
  ImFont* bold = nullptr;
  ImFont* heading = nullptr;  // view titles
  ImFont* mono = nullptr;     // equations, JSON
  float scale = 1.0f;         // DPI scale the sizes were built for
};

// One dataset file of the project, as read by the loading job.
struct LoadedDataset {
  std::string path;
  std::shared_ptr<const data::Dataset> data;  // null when the file could not be read
  std::string error;                          // why `data` is null
  DatasetSummary summary;
};

// The result of the loading job.
struct ProjectLoad {
  std::string path;
  std::optional<project::Project> project;
  std::string error;  // why `project` is empty
  std::vector<LoadedDataset> datasets;
};

struct DataViewState {
  // One per dataset: the plots of a dataset's columns pan and zoom together in x.
  std::vector<plot::LinkedRange> x_ranges;
};

struct AppState {
  // The open project and its data, replaced as a whole when a loading job succeeds.
  std::optional<project::Project> project;
  std::vector<LoadedDataset> datasets;
  std::string open_error;  // the last project that could not be opened, and why
  std::string start_note;  // shown on the empty workbench (e.g. why no project was opened)
  Job<ProjectLoad> load_job;
  std::string loading_path;

  View view = View::kData;
  std::vector<Message> messages;
  bool show_messages = false;
  bool show_about = false;
  bool open_dialog_requested = false;
  std::string open_dialog_path;
  bool quit_requested = false;

  Fonts fonts;
  plot::PlotContext plots;
  DataViewState data_view;
};

void AddMessage(AppState& state, Severity severity, std::string text);

// Starts reading the project and its datasets in the loading job (ignored while one runs).
void OpenProject(AppState& state, std::string path);
// Installs the results of finished jobs. DrawWorkbench calls it at the start of every frame.
void PollJobs(AppState& state);
// Blocks until every job has finished, then polls. For the snapshot renderer only.
void WaitForJobs(AppState& state);

}  // namespace gb::ui
