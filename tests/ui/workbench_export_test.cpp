// Exports from the workbench (ui/export/export.h), driven as a user would: the Estimate view's
// "Save report…" button, a plot's export request, File > Export > Export model…; the file
// browser's answer is given as the browser gives it (FinishExport with the chosen path). Each
// file is read back, and none may land on a file of the project.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/model/model.h"
#include "core/util/json.h"
#include "core/util/sanitizers.h"
#include "tests/ui/workbench_driver.h"
#include "ui/export/export.h"
#include "ui/shell/shell.h"

namespace gb::ui {
namespace {

namespace fs = std::filesystem;
using testing::FindButton;
using testing::kSource;
using testing::WorkbenchDriver;

std::string Read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string G6(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// A copy of the test project in a directory of its own: the exports are tried onto its files.
class WorkbenchExport : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("gb_export_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    for (const char* f : {"project.json", "fuel_film.json", "f1.csv"})
      fs::copy_file(kSource + "/tests/data/ui/" + f, dir_ / f);
    d_.Open((dir_ / "project.json").string());
    ASSERT_TRUE(d_.state.model) << d_.state.model_error;
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The project's fit, on one thread, as the Estimate view's Run makes it.
  void Fit() {
    d_.state.estimation.settings.threads = 1;
    std::string why;
    ASSERT_TRUE(StartEstimation(d_.state, &why)) << why;
    WaitForJobs(d_.state);
    d_.Frame();
    ASSERT_TRUE(d_.state.estimation.result) << d_.state.estimation.last_failure;
  }

  bool LastMessageIsError(const std::string& part) const {
    if (d_.state.messages.empty()) return false;
    const Message& m = d_.state.messages.back();
    return m.severity == Severity::kError && m.text.find(part) != std::string::npos;
  }

  fs::path dir_;
  WorkbenchDriver d_;
};

TEST_F(WorkbenchExport, SaveReportWritesTheFitsEstimatesAsMarkdownAndHtml) {
  ASSERT_NO_FATAL_FAILURE(Fit());
  const estimate::EstimateSummary& fit = d_.state.estimation.result->summary;
  // The residuals the Residuals view shows, computed at the estimates.
  d_.state.view = View::kResiduals;
  ASSERT_TRUE(d_.FramesUntil(
      [&] { return d_.state.analysis.result.has_value() && !d_.state.analysis.job.active(); },
      std::chrono::milliseconds(kSanitized ? 300000 : 30000)));
  d_.state.view = View::kEstimate;
  d_.Frame();
  const std::optional<ImVec2> save = FindButton(d_, "Save report\xE2\x80\xA6");
  ASSERT_TRUE(save) << "no Save report… button in the estimate view";
  d_.Click(*save);
  EXPECT_EQ(d_.state.shell.browser.request.purpose, static_cast<int>(BrowsePurpose::kSaveReport));
  ASSERT_TRUE(d_.state.shell.report_export.has_value());
  const report::ReportInput input = *d_.state.shell.report_export;  // for the second format

  FinishExport(d_.state, BrowsePurpose::kSaveReport, (dir_ / "fit.md").string());
  d_.state.shell.report_export = input;
  FinishExport(d_.state, BrowsePurpose::kSaveReport, (dir_ / "fit.html").string());
  for (const char* name : {"fit.md", "fit.html"}) {
    const std::string text = Read(dir_ / name);
    ASSERT_FALSE(text.empty()) << name;
    for (const estimate::ParameterEstimate& p : fit.parameters) {
      EXPECT_NE(text.find(G6(p.estimate)), std::string::npos) << name << ": " << p.name;
      if (p.std_error && !p.fixed) {
        EXPECT_NE(text.find(G6(*p.std_error)), std::string::npos) << name << ": " << p.name;
      }
    }
    EXPECT_NE(text.find("Ljung-Box"), std::string::npos) << name;
  }
  EXPECT_NE(Read(dir_ / "fit.html").find("<svg "), std::string::npos);

  // A name without .md or .html (here the project's data file) gets the extension of the
  // browser's filter: the data file is kept.
  const std::string data_before = Read(dir_ / "f1.csv");
  d_.state.shell.report_export = input;
  FinishExport(d_.state, BrowsePurpose::kSaveReport, (dir_ / "f1.csv").string());
  EXPECT_EQ(Read(dir_ / "f1.csv"), data_before);
  EXPECT_NE(Read(dir_ / "f1.csv.md").find("# Estimation report"), std::string::npos);
}

TEST_F(WorkbenchExport, APlotsSvgAndPngGoThroughTheBrowserAndNeverOntoTheProject) {
  d_.state.view = View::kData;
  d_.Frame();
  d_.Frame();
  // The request a click on "Save image as SVG…" leaves (the menu itself: PlotMenu tests).
  d_.state.plots.record_figures = true;
  d_.Frame();
  d_.state.plots.record_figures = false;
  ASSERT_FALSE(d_.state.plots.recorded.empty());
  const plot::RecordedFigure figure = d_.state.plots.recorded.front();
  d_.state.plots.recorded.clear();
  plot::ExportRequest request{plot::ExportRequest::Kind::kSvg, figure.name, figure.id,
                              figure.figure, figure.size};
  d_.state.plots.export_request = request;
  d_.Frame();
  EXPECT_FALSE(d_.state.plots.export_request.has_value());
  EXPECT_EQ(d_.state.shell.browser.request.purpose, static_cast<int>(BrowsePurpose::kExportPlot));
  EXPECT_EQ(d_.state.shell.browser.request.file_name, figure.name + ".svg");
  FinishExport(d_.state, BrowsePurpose::kExportPlot, (dir_ / "plot.svg").string());
  const std::string svg = Read(dir_ / "plot.svg");
  EXPECT_NE(svg.find("<polyline points=\""), std::string::npos);

  // Onto the model file: refused.
  const std::string model_before = Read(dir_ / "fuel_film.json");
  d_.state.plots.export_request = request;
  d_.Frame();
  FinishExport(d_.state, BrowsePurpose::kExportPlot, (dir_ / "fuel_film.json").string());
  EXPECT_EQ(Read(dir_ / "fuel_film.json"), model_before);
  EXPECT_TRUE(LastMessageIsError("fuel_film.json"));

  // PNG at the size the menu asked for: due once the file is chosen, drawn alone in a frame of
  // that size (greybench_main renders that frame offscreen; here its draw data is looked at).
  request.kind = plot::ExportRequest::Kind::kPng;
  request.png_width = 640;
  request.png_height = 300;
  d_.state.plots.export_request = request;
  d_.Frame();
  EXPECT_EQ(d_.state.shell.browser.request.file_name, figure.name + ".png");
  EXPECT_FALSE(TakePendingPng(d_.state).has_value());
  FinishExport(d_.state, BrowsePurpose::kExportPlot, (dir_ / "plot.png").string());
  const std::optional<PendingPng> png = TakePendingPng(d_.state);
  ASSERT_TRUE(png.has_value());
  EXPECT_FALSE(TakePendingPng(d_.state).has_value());  // taken once
  EXPECT_EQ(png->width, 640);
  EXPECT_EQ(png->height, 300);
  EXPECT_EQ(png->path, (dir_ / "plot.png").string());
  ImGuiIO& io = ImGui::GetIO();
  const ImVec2 display = io.DisplaySize;
  io.DisplaySize = ImVec2(640, 300);
  ImGui::NewFrame();
  plot::DrawFigureFrame(d_.state.plots, png->figure);
  ImGui::Render();
  io.DisplaySize = display;
  const ImDrawData* draw = ImGui::GetDrawData();
  ASSERT_NE(draw, nullptr);
  EXPECT_EQ(draw->DisplaySize.x, 640.0f);
  EXPECT_GT(draw->TotalVtxCount, 100);  // the plot's lines, ticks and text
  const std::vector<unsigned char> grey(640u * 300u * 4u, 200);
  FinishPendingPng(d_.state, *png, &grey);
  EXPECT_EQ(Read(dir_ / "plot.png").substr(1, 3), "PNG");
  FinishPendingPng(d_.state, *png, nullptr);  // no framebuffer: said, not written
  EXPECT_TRUE(LastMessageIsError("no offscreen framebuffer"));
}

// File › Export › Image of the view: the browser proposes the view's name and size; a chosen
// file is due once, at the size the menu asked for; the project's files are refused.
TEST_F(WorkbenchExport, AnImageOfTheViewIsDueAtTheSizeAskedForAndNeverOntoTheProject) {
  d_.state.view = View::kResiduals;
  BrowseViewImage(d_.state, 1024, 768);
  EXPECT_EQ(d_.state.shell.browser.request.purpose, static_cast<int>(BrowsePurpose::kViewImage));
  EXPECT_EQ(d_.state.shell.browser.request.file_name, "residuals-1024x768.png");
  const std::string model_before = Read(dir_ / "fuel_film.json");
  FinishExport(d_.state, BrowsePurpose::kViewImage, (dir_ / "fuel_film.json").string());
  EXPECT_FALSE(TakePendingViewImage(d_.state).has_value());
  EXPECT_TRUE(LastMessageIsError("fuel_film.json"));
  FinishExport(d_.state, BrowsePurpose::kViewImage, (dir_ / "slide.png").string());
  const std::optional<PendingViewImage> image = TakePendingViewImage(d_.state);
  ASSERT_TRUE(image.has_value());
  EXPECT_FALSE(TakePendingViewImage(d_.state).has_value());  // taken once
  EXPECT_EQ(image->width, 1024);
  EXPECT_EQ(image->height, 768);
  const std::vector<unsigned char> grey(1024u * 768u * 4u, 200);
  FinishPendingViewImage(d_.state, *image, &grey);
  EXPECT_EQ(Read(dir_ / "slide.png").substr(1, 3), "PNG");
  EXPECT_EQ(Read(dir_ / "fuel_film.json"), model_before);
  FinishPendingViewImage(d_.state, *image, nullptr);
  EXPECT_TRUE(LastMessageIsError("no offscreen framebuffer"));
}

TEST_F(WorkbenchExport, ExportModelWritesTheModelTheViewsShow) {
  BrowseExportModel(d_.state);
  EXPECT_EQ(d_.state.shell.browser.request.purpose, static_cast<int>(BrowsePurpose::kExportModel));
  FinishExport(d_.state, BrowsePurpose::kExportModel, (dir_ / "exported.json").string());
  Result<model::ModelSpec> spec = model::LoadModelFile((dir_ / "exported.json").string());
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  EXPECT_EQ(spec->name, d_.state.model->name);
  ASSERT_EQ(spec->parameters.size(), d_.state.model->parameters.size());
  for (std::size_t i = 0; i < spec->parameters.size(); ++i)
    EXPECT_EQ(spec->parameters[i].name, d_.state.model->parameters[i].name);
  // Onto the project file: refused.
  const std::string project_before = Read(dir_ / "project.json");
  FinishExport(d_.state, BrowsePurpose::kExportModel, (dir_ / "project.json").string());
  EXPECT_EQ(Read(dir_ / "project.json"), project_before);
  EXPECT_TRUE(LastMessageIsError("project.json"));
}

TEST_F(WorkbenchExport, ExportFmuBuildsTheModelAtTheFitsEstimatesOffTheUiThread) {
  ASSERT_NO_FATAL_FAILURE(Fit());
  const estimate::EstimateSummary& fit = d_.state.estimation.result->summary;

  BrowseExportFmu(d_.state, fmu::Interface::kCoSimulation);
  EXPECT_EQ(d_.state.shell.browser.request.purpose, static_cast<int>(BrowsePurpose::kExportFmu));
  EXPECT_EQ(d_.state.shell.browser.request.file_name.substr(
                d_.state.shell.browser.request.file_name.size() - 4),
            ".fmu");
  // A name without an extension gets ".fmu"; its stem is the model identifier.
  FinishExport(d_.state, BrowsePurpose::kExportFmu, (dir_ / "film").string());
  d_.state.shell.fmu_job.Wait();
  ASSERT_TRUE(PollFmuExport(d_.state));
  const fs::path fmu = dir_ / "film.fmu";
  ASSERT_TRUE(fs::exists(fmu)) << d_.state.messages.back().text;
  bool written = false;
  for (const Message& m : d_.state.messages)
    written = written || (m.severity == Severity::kInfo &&
                          m.text.find("The FMU written to " + fmu.string() +
                                      ": FMI 2.0, Co-Simulation, model identifier film") == 0 &&
                          m.text.find("at the fit's estimates") != std::string::npos);
  EXPECT_TRUE(written) << d_.state.messages.back().text;
  // The estimates are the parameters' start values (Python reads the zip).
  const fs::path xml = dir_ / "film.xml";
  const std::string unzip =
      "python3 -c \"import zipfile,sys; open(sys.argv[2],'wb').write("
      "zipfile.ZipFile(sys.argv[1]).read('modelDescription.xml'))\" '" +
      fmu.string() + "' '" + xml.string() + "'";
  ASSERT_EQ(std::system(unzip.c_str()), 0);
  const std::string description = Read(xml);
  EXPECT_NE(description.find("<CoSimulation modelIdentifier=\"film\""), std::string::npos);
  EXPECT_EQ(description.find("<ModelExchange"), std::string::npos);
  const model::ModelSpec& m = *d_.state.model;
  for (std::size_t i = 0; i < m.parameters.size(); ++i) {
    const std::string variable = "name=\"" + m.parameters[i].name + "\"";
    const auto at = description.find(variable);
    ASSERT_NE(at, std::string::npos) << variable;
    const auto start = description.find("start=\"", at) + 7;
    const double value = std::stod(description.substr(start, description.find('"', start) - start));
    EXPECT_EQ(value, fit.theta[i]) << m.parameters[i].name;
  }
  // A delay the fit estimated is not in the FMU, and the Messages window says so.
  bool delayed = false;
  for (const estimate::DelayEstimate& dl : fit.delays) delayed = delayed || dl.estimate > 0;
  if (delayed) {
    EXPECT_EQ(d_.state.messages.back().severity, Severity::kWarning);
    EXPECT_NE(d_.state.messages.back().text.find("the FMU's outputs are not delayed"),
              std::string::npos);
  }
  // The virtual sensor: the filter's variables, with the fit's delay (no warning: it is in the
  // filter).
  BrowseExportFmu(d_.state, fmu::Interface::kCoSimulation, true);
  EXPECT_NE(d_.state.shell.browser.request.file_name.find("_sensor.fmu"), std::string::npos);
  FinishExport(d_.state, BrowsePurpose::kExportFmu, (dir_ / "sensor.fmu").string());
  d_.state.shell.fmu_job.Wait();
  ASSERT_TRUE(PollFmuExport(d_.state));
  ASSERT_TRUE(fs::exists(dir_ / "sensor.fmu")) << d_.state.messages.back().text;
  EXPECT_EQ(d_.state.messages.back().severity, Severity::kInfo) << d_.state.messages.back().text;
  EXPECT_NE(d_.state.messages.back().text.find("a virtual sensor"), std::string::npos);
  const std::string sensor_unzip =
      "python3 -c \"import zipfile,sys; open(sys.argv[2],'wb').write("
      "zipfile.ZipFile(sys.argv[1]).read('modelDescription.xml'))\" '" +
      (dir_ / "sensor.fmu").string() + "' '" + (dir_ / "sensor.xml").string() + "'";
  ASSERT_EQ(std::system(sensor_unzip.c_str()), 0);
  const std::string sensor_description = Read(dir_ / "sensor.xml");
  EXPECT_NE(sensor_description.find("name=\"mff_filtered\""), std::string::npos);
  EXPECT_NE(sensor_description.find("name=\"ilambda_valid\""), std::string::npos);

  // Onto a file of the project: refused before anything is built.
  const std::string model_before = Read(dir_ / "fuel_film.json");
  FinishExport(d_.state, BrowsePurpose::kExportFmu, (dir_ / "fuel_film.json").string());
  EXPECT_FALSE(d_.state.shell.fmu_job.active());
  EXPECT_EQ(Read(dir_ / "fuel_film.json"), model_before);
  EXPECT_TRUE(LastMessageIsError("fuel_film.json"));
}

}  // namespace
}  // namespace gb::ui
