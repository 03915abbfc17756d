#include "ui/export/export.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <utility>

#include <fmt/format.h>
#include <imgui.h>

#include "core/fmu/fmu.h"
#include "core/model/model.h"
#include "core/model/nonlinear_model.h"
#include "core/project/project.h"
#include "core/report/figure.h"
#include "core/util/file.h"
#include "core/util/output_guard.h"
#include "ui/render/png.h"

namespace gb::ui {
namespace {

// The files of the open project: no export may write onto one of them.
std::vector<FileRole> ProjectInputs(const AppState& state) {
  if (!state.project) return {};
  return project::ProjectFiles(*state.project);
}

Status CheckOutput(const AppState& state, const std::string& path) {
  return CheckOutputs(ProjectInputs(state), {{path, "the export"}});
}

// A proposed file name from a plot's title: letters, digits, '-' and '_' kept, the rest '_'.
std::string FileStem(const std::string& name) {
  std::string stem;
  for (char c : name) {
    const bool keep = std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_';
    stem += keep ? c : '_';
  }
  while (stem.find("__") != std::string::npos) stem.erase(stem.find("__"), 1);
  while (!stem.empty() && stem.back() == '_') stem.pop_back();
  while (!stem.empty() && stem.front() == '_') stem.erase(0, 1);
  return stem.empty() ? "plot" : stem;
}

std::string StartDirectory(const AppState& state) {
  return state.project ? state.project->path : std::string();
}

void Report(AppState& state, const Status& st, const std::string& what, const std::string& path) {
  if (st) {
    std::string text = what + " written to " + path;
    text[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(text[0])));
    AddMessage(state, Severity::kInfo, text);
  } else {
    AddMessage(state, Severity::kError, "Could not write " + what + ": " + st.error().ToString());
  }
}

void FinishPlotExport(AppState& state, const std::string& path) {
  std::optional<plot::ExportRequest> request = std::move(state.shell.plot_export);
  state.shell.plot_export.reset();
  if (!request) return;
  if (Status st = CheckOutput(state, path); !st) return Report(state, st, "the plot", path);
  if (request->kind == plot::ExportRequest::Kind::kSvg) {
    const report::SvgSize size{static_cast<int>(std::lround(request->size.x)),
                               static_cast<int>(std::lround(request->size.y))};
    Report(state, WriteFileAtomic(path, report::FigureToSvg(request->figure, size)),
           "the plot's SVG", path);
    return;
  }
  // PNG: drawn offscreen by the application after this frame.
  if (Status st = CheckWritable(path); !st) return Report(state, st, "the plot", path);
  state.shell.png_export =
      PendingPng{std::move(request->figure), request->png_width, request->png_height, path};
}

// The residual sections of the analysis the Residuals view shows.
std::vector<report::ResidualSection> ShownResiduals(const AppState& state, std::string* note) {
  const std::optional<Analysis>& a = state.analysis.result;
  if (!a || a->datasets.empty()) {
    *note = "Not computed: the workbench had no predictions when the report was saved.";
    return {};
  }
  const std::size_t index = std::min<std::size_t>(
      static_cast<std::size_t>(std::max(state.analysis.dataset, 0)), a->datasets.size() - 1);
  const DatasetAnalysis& d = a->datasets[index];
  std::vector<report::ResidualSection> sections;
  for (const OutputAnalysis& o : d.outputs) {
    if (!o.diagnostics) continue;
    report::ResidualSection s;
    s.output = o.name;
    s.dataset = d.name;
    s.diagnostics = o.diagnostics->stats;
    s.predictions =
        report::PredictionFigure(o.name, "", d.time, o.measured, o.predicted, o.lower, o.upper);
    s.predictions.x_label = d.time_name.empty() ? "t" : d.time_name;
    s.acf = report::AcfFigure(o.name, s.diagnostics.acf);
    sections.push_back(std::move(s));
  }
  if (sections.empty()) {
    *note = d.error.empty() ? "Not computed: no output of " + d.name + " could be diagnosed."
                            : "Not computed: " + d.error;
  }
  return sections;
}

void FinishReport(AppState& state, std::string path) {
  std::optional<report::ReportInput> input = std::move(state.shell.report_export);
  state.shell.report_export.reset();
  if (!input) return;
  std::string ext = std::filesystem::path(path).extension().string();
  if (!ext.empty()) ext.erase(0, 1);
  std::optional<report::ReportFormat> format = report::ParseReportFormat(ext);
  if (!format) {
    // No known extension: the browser's filter says which, and names the file.
    format = state.shell.browser.filter == 1 ? report::ReportFormat::kHtml
                                             : report::ReportFormat::kMarkdown;
    path += *format == report::ReportFormat::kHtml ? ".html" : ".md";
  }
  if (Status st = CheckOutput(state, path); !st) return Report(state, st, "the report", path);
  Result<std::string> text = report::WriteReport(*input, *format);
  if (!text) return Report(state, text.error(), "the report", path);
  Report(state, WriteFileAtomic(path, *text), "the report", path);
}

// The parameter values the views show and the delays with them: the fit's when the views show a
// fit of this model (its model part for a fit with initial states per record: record 1's), else
// the model's values and no delays (as AnalysisRequestNow chooses).
struct ShownValues {
  std::vector<double> theta;
  std::vector<int> delays;
  bool from_fit = false;
};

ShownValues ValuesShown(const AppState& state) {
  const model::ModelSpec& m = *state.model;
  const FitResult* fit = state.estimation.result ? &*state.estimation.result : nullptr;
  ShownValues shown;
  shown.from_fit = fit && !state.analysis.use_current_values && FitMatchesModel(*fit, m);
  if (!shown.from_fit) {
    shown.theta = m.Values();
    return shown;
  }
  shown.theta = fit->summary.theta;
  shown.theta.resize(m.parameters.size());
  for (const estimate::DelayEstimate& d : fit->summary.delays) shown.delays.push_back(d.estimate);
  return shown;
}

void StartFmuExport(AppState& state, std::string path) {
  if (!state.model) return;
  if (state.shell.fmu_job.active()) {
    AddMessage(state, Severity::kError,
               "Could not export the FMU to " + path + ": another FMU is being built");
    return;
  }
  if (std::filesystem::path(path).extension().empty()) path += ".fmu";
  if (Status st = CheckOutput(state, path); !st) return Report(state, st, "the FMU", path);
  const std::string identifier = fmu::IdentifierOf(std::filesystem::path(path).stem().string());
  ShownValues shown = ValuesShown(state);
  const bool at_fit = shown.from_fit;
  const bool sensor = state.shell.fmu_virtual_sensor;
  fmu::FmuOptions options;
  options.interface = state.shell.fmu_interface;
  options.identifier = identifier;
  const std::string kind = sensor ? std::string("a virtual sensor, the model's filter")
                                  : std::string(fmu::InterfaceName(options.interface));
  AddMessage(state, Severity::kInfo,
             "Building the FMU " + path + " (" + kind + ", " +
                 (at_fit ? "at the fit's estimates" : "at the model's values") + ")\xE2\x80\xA6");
  state.shell.fmu_job.Start([spec = *state.model, theta = std::move(shown.theta),
                             delays = std::move(shown.delays), options, path, at_fit, sensor,
                             kind](JobControl&) mutable {
    FmuExportEnd end;
    end.path = path;
    auto compiled = model::NonlinearModel::Compile(spec);
    if (compiled && sensor) {
      auto sensor_options = fmu::VirtualSensorOptions(*compiled, theta, delays);
      if (!sensor_options) {
        end.error = sensor_options.error().ToString();
        return end;
      }
      sensor_options->identifier = options.identifier;
      options = std::move(*sensor_options);
    }
    Status st = compiled ? fmu::ExportFmu(*compiled, theta, options, path) : compiled.error();
    if (!st) {
      end.error = st.error().ToString();
      return end;
    }
    end.summary = fmt::format(
        "FMI 2.0, {}, model identifier {}; {} states, {} inputs, {} outputs, {} parameters at {}",
        kind, options.identifier, spec.states.size(), spec.inputs.size(), spec.outputs.size(),
        spec.parameters.size(), at_fit ? "the fit's estimates" : "the model's values");
    if (!sensor) end.warning = fmu::DelayNote(spec, delays);
    return end;
  });
}

}  // namespace

void BrowseExportFmu(AppState& state, fmu::Interface interface, bool virtual_sensor) {
  if (!state.model) return;
  state.shell.fmu_interface = interface;
  state.shell.fmu_virtual_sensor = virtual_sensor;
  FileBrowserRequest r;
  r.title = virtual_sensor
                ? std::string("Export the model's filter as a virtual sensor FMU")
                : std::string("Export the model as an FMU (") + fmu::InterfaceName(interface) + ")";
  r.confirm = "Export";
  r.mode = FileBrowserMode::kSave;
  r.filters = {{"FMUs (*.fmu)", {".fmu"}}};
  r.start = StartDirectory(state);
  r.file_name = fmu::IdentifierOf(state.model->name.empty() ? "model" : state.model->name) +
                (virtual_sensor ? "_sensor.fmu" : ".fmu");
  r.purpose = static_cast<int>(BrowsePurpose::kExportFmu);
  OpenFileBrowser(state.shell.browser, std::move(r));
}

bool PollFmuExport(AppState& state) {
  std::optional<FmuExportEnd> end = state.shell.fmu_job.TakeIfReady();
  if (!end) return false;
  if (!end->error.empty()) {
    AddMessage(state, Severity::kError, "Could not export the FMU: " + end->error);
    return true;
  }
  AddMessage(state, Severity::kInfo, "The FMU written to " + end->path + ": " + end->summary);
  if (!end->warning.empty()) {
    std::string text = end->warning;
    text[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(text[0])));
    AddMessage(state, Severity::kWarning, text);
  }
  return true;
}

void BrowseSaveReport(AppState& state, const FitResult& fit, bool with_residuals) {
  report::ReportInput input;
  input.result = fit.summary.ToJson();
  if (with_residuals) {
    input.residuals = ShownResiduals(state, &input.residuals_note);
  } else {
    input.residuals_note = "Not included: the views show another fit's values.";
  }
  state.shell.report_export = std::move(input);
  FileBrowserRequest r;
  r.title = "Save the report";
  r.confirm = "Save";
  r.mode = FileBrowserMode::kSave;
  r.filters = {{"Markdown (*.md)", {".md"}}, {"HTML (*.html)", {".html", ".htm"}}};
  r.start = StartDirectory(state);
  r.file_name =
      FileStem(fit.summary.model_name.empty() ? "report" : fit.summary.model_name) + "-report.md";
  r.purpose = static_cast<int>(BrowsePurpose::kSaveReport);
  OpenFileBrowser(state.shell.browser, std::move(r));
}

void UpdateExports(AppState& state) {
  PollFmuExport(state);
  std::optional<plot::ExportRequest>& asked = state.plots.export_request;
  if (!asked) return;
  plot::ExportRequest request = std::move(*asked);
  asked.reset();
  const bool svg = request.kind == plot::ExportRequest::Kind::kSvg;
  FileBrowserRequest r;
  r.title = svg ? "Save the plot as SVG" : "Save the plot as PNG";
  r.confirm = "Save";
  r.mode = FileBrowserMode::kSave;
  r.filters = {svg ? FileFilter{"SVG images (*.svg)", {".svg"}}
                   : FileFilter{"PNG images (*.png)", {".png"}}};
  r.start = StartDirectory(state);
  r.file_name = FileStem(request.name) + (svg ? ".svg" : ".png");
  r.purpose = static_cast<int>(BrowsePurpose::kExportPlot);
  state.shell.plot_export = std::move(request);
  OpenFileBrowser(state.shell.browser, std::move(r));
}

void BrowseExportModel(AppState& state) {
  if (!state.model) return;
  FileBrowserRequest r;
  r.title = "Export the model";
  r.confirm = "Save";
  r.mode = FileBrowserMode::kSave;
  r.filters = {{"Models (*.json)", {".json"}}};
  r.start = StartDirectory(state);
  r.file_name = FileStem(state.model->name.empty() ? "model" : state.model->name) + ".json";
  r.purpose = static_cast<int>(BrowsePurpose::kExportModel);
  OpenFileBrowser(state.shell.browser, std::move(r));
}

void BrowseViewImage(AppState& state, int width, int height) {
  state.shell.view_image_width = width;
  state.shell.view_image_height = height;
  FileBrowserRequest r;
  r.title =
      "Save an image of the view (" + std::to_string(width) + " x " + std::to_string(height) + ")";
  r.confirm = "Save";
  r.mode = FileBrowserMode::kSave;
  r.filters = {{"PNG images (*.png)", {".png"}}};
  r.start = StartDirectory(state);
  r.file_name = std::string(ViewName(state.view)) + "-" + std::to_string(width) + "x" +
                std::to_string(height) + ".png";
  r.purpose = static_cast<int>(BrowsePurpose::kViewImage);
  OpenFileBrowser(state.shell.browser, std::move(r));
}

void DrawExportMenu(AppState& state) {
  if (!ImGui::BeginMenu("Export", state.project.has_value())) return;
  if (ImGui::BeginMenu("Image of the view")) {
    static constexpr struct {
      const char* label;
      int width, height;
    } kSizes[] = {{"1024 x 768 (projector)\xE2\x80\xA6", 1024, 768},
                  {"1280 x 800\xE2\x80\xA6", 1280, 800},
                  {"1920 x 1080 (full HD)\xE2\x80\xA6", 1920, 1080}};
    for (const auto& size : kSizes)
      if (ImGui::MenuItem(size.label)) BrowseViewImage(state, size.width, size.height);
    ImGui::EndMenu();
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("The current view drawn whole at that size, as a PNG (for slides)");
  if (ImGui::MenuItem("Export model\xE2\x80\xA6", nullptr, false, state.model.has_value()))
    BrowseExportModel(state);
  const bool building = state.shell.fmu_job.active();
  if (ImGui::BeginMenu(building ? "FMU (building\xE2\x80\xA6)" : "FMU", state.model && !building)) {
    static constexpr std::pair<const char*, fmu::Interface> kChoices[] = {
        {"Model Exchange and Co-Simulation\xE2\x80\xA6", fmu::Interface::kBoth},
        {"Model Exchange\xE2\x80\xA6", fmu::Interface::kModelExchange},
        {"Co-Simulation\xE2\x80\xA6", fmu::Interface::kCoSimulation}};
    for (const auto& [label, interface] : kChoices)
      if (ImGui::MenuItem(label)) BrowseExportFmu(state, interface);
    ImGui::Separator();
    if (ImGui::MenuItem("Virtual sensor (the filter)\xE2\x80\xA6"))
      BrowseExportFmu(state, fmu::Interface::kCoSimulation, true);
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "The model's extended Kalman filter as a Co-Simulation FMU: inputs u and the "
          "measurements,\noutputs the filtered states with their sd, the one-step predictions "
          "and the innovations");
    ImGui::EndMenu();
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "The model's deterministic part as an FMI 2.0 FMU for Simulink, OpenModelica or an ECU "
        "test bench,\nat the values the views show (after a fit, its estimates); built by the "
        "system's C compiler");
  ImGui::EndMenu();
}

void FinishExport(AppState& state, BrowsePurpose purpose, const std::string& path) {
  switch (purpose) {
    case BrowsePurpose::kExportPlot:
      FinishPlotExport(state, path);
      break;
    case BrowsePurpose::kSaveReport:
      FinishReport(state, path);
      break;
    case BrowsePurpose::kExportFmu:
      StartFmuExport(state, path);
      break;
    case BrowsePurpose::kViewImage: {
      if (Status st = CheckOutput(state, path); !st) return Report(state, st, "the image", path);
      state.shell.view_image =
          PendingViewImage{state.shell.view_image_width, state.shell.view_image_height, path};
      break;
    }
    case BrowsePurpose::kExportModel: {
      if (!state.model) break;
      Status st = CheckOutput(state, path);
      if (st) st = model::SaveModelFile(*state.model, path);
      Report(state, st, "the model", path);
      break;
    }
    default:
      break;
  }
}

std::optional<PendingViewImage> TakePendingViewImage(AppState& state) {
  std::optional<PendingViewImage> image = std::move(state.shell.view_image);
  state.shell.view_image.reset();
  return image;
}

void FinishPendingViewImage(AppState& state, const PendingViewImage& image,
                            const std::vector<unsigned char>* rgba) {
  const std::string size = std::to_string(image.width) + " x " + std::to_string(image.height);
  if (!rgba) {
    AddMessage(state, Severity::kError,
               "Could not write the image of the view: no offscreen framebuffer of " + size +
                   " pixels (" + image.path + ")");
    return;
  }
  std::string error;
  if (WritePngFromGl(image.path, image.width, image.height, rgba->data(), &error)) {
    AddMessage(state, Severity::kInfo,
               "The image of the view (" + size + ") written to " + image.path);
  } else {
    AddMessage(state, Severity::kError, "Could not write the image of the view: " + error);
  }
}

std::optional<PendingPng> TakePendingPng(AppState& state) {
  std::optional<PendingPng> png = std::move(state.shell.png_export);
  state.shell.png_export.reset();
  return png;
}

void FinishPendingPng(AppState& state, const PendingPng& png,
                      const std::vector<unsigned char>* rgba) {
  if (!rgba) {
    AddMessage(state, Severity::kError,
               "Could not write the plot's PNG: no offscreen framebuffer of " +
                   std::to_string(png.width) + " x " + std::to_string(png.height) + " pixels (" +
                   png.path + ")");
    return;
  }
  std::string error;
  if (WritePngFromGl(png.path, png.width, png.height, rgba->data(), &error)) {
    AddMessage(state, Severity::kInfo, "The plot's PNG written to " + png.path);
  } else {
    AddMessage(state, Severity::kError, "Could not write the plot's PNG: " + error);
  }
}

}  // namespace gb::ui
