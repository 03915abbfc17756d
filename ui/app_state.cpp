#include "ui/app_state.h"

#include <exception>
#include <filesystem>
#include <utility>

namespace gb::ui {
namespace {

struct ViewInfo {
  View view;
  std::string_view name;
  std::string_view title;
};
constexpr std::array<ViewInfo, 8> kViewInfo = {{
    {View::kData, "data", "Data"},
    {View::kDiagram, "diagram", "Diagram"},
    {View::kEquations, "equations", "Equations"},
    {View::kEstimate, "estimate", "Estimate"},
    {View::kPredictions, "predictions", "Predictions"},
    {View::kResiduals, "residuals", "Residuals"},
    {View::kParameters, "parameters", "Parameters"},
    {View::kOperatingPoints, "operating-points", "Operating points"},
}};

const ViewInfo& Info(View view) {
  for (const ViewInfo& info : kViewInfo) {
    if (info.view == view) return info;
  }
  return kViewInfo[0];
}

// Runs on the loading job's thread: reads the project file, then each dataset.
ProjectLoad LoadProjectAndData(const std::string& path, JobControl& control) {
  ProjectLoad out;
  out.path = path;
  try {
    Result<project::Project> project = project::LoadProject(path);
    if (!project.ok()) {
      out.error = project.error().ToString();
      return out;
    }
    const std::vector<std::string>& files = project->datasets;
    for (std::size_t i = 0; i < files.size() && !control.cancel; ++i) {
      control.progress = static_cast<float>(i) / static_cast<float>(files.size());
      LoadedDataset d;
      d.path = files[i];
      Result<std::shared_ptr<const data::Dataset>> read = data::ReadCsvFile(files[i]);
      if (read.ok()) {
        d.data = std::move(read).value();
        d.summary = Summarize(*d.data);
      } else {
        d.error = read.error().ToString();
      }
      out.datasets.push_back(std::move(d));
    }
    out.project = std::move(project).value();
  } catch (const std::exception& e) {  // e.g. out of memory on a huge file
    out.project.reset();
    out.error = path + ": " + e.what();
  }
  control.progress = 1.0f;
  return out;
}

std::string FileName(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

}  // namespace

std::string_view ViewName(View view) { return Info(view).name; }
std::string_view ViewTitle(View view) { return Info(view).title; }

std::optional<View> ParseView(std::string_view name) {
  for (const ViewInfo& info : kViewInfo) {
    if (info.name == name) return info.view;
  }
  return std::nullopt;
}

void AddMessage(AppState& state, Severity severity, std::string text) {
  state.messages.push_back({severity, std::move(text)});
}

void OpenProject(AppState& state, std::string path) {
  if (state.load_job.active()) return;
  state.loading_path = path;
  state.load_job.Start(
      [path = std::move(path)](JobControl& control) { return LoadProjectAndData(path, control); });
}

void PollJobs(AppState& state) {
  std::optional<ProjectLoad> load = state.load_job.TakeIfReady();
  if (!load) return;
  state.loading_path.clear();
  if (!load->project) {
    state.open_error = load->error;
    AddMessage(state, Severity::kError, "Could not open the project: " + load->error);
    return;
  }
  state.project = std::move(load->project);
  state.datasets = std::move(load->datasets);
  state.open_error.clear();
  state.data_view.x_ranges.assign(state.datasets.size(), plot::LinkedRange{});
  int failed = 0;
  for (const LoadedDataset& d : state.datasets) {
    if (d.data) continue;
    ++failed;
    AddMessage(state, Severity::kError, "Could not read data: " + d.error);
  }
  const std::string name = state.project->name.empty() ? FileName(load->path) : state.project->name;
  std::string text = "Opened " + name + " (" + std::to_string(state.datasets.size()) +
                     (state.datasets.size() == 1 ? " dataset" : " datasets");
  if (failed > 0) text += ", " + std::to_string(failed) + " could not be read";
  AddMessage(state, failed > 0 ? Severity::kWarning : Severity::kInfo, text + ")");
}

void WaitForJobs(AppState& state) {
  state.load_job.Wait();
  PollJobs(state);
}

}  // namespace gb::ui
