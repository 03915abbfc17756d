// Saving a project: what SaveProject writes, LoadProject reads back to the same project (name,
// model, datasets, the keys greybench does not interpret), and the saved model scores the data
// exactly as the model that was saved.
#include "core/project/project.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/model/model.h"
#include "core/project/problem.h"
#include "core/util/file.h"

#ifndef GREYBENCH_TEST_DATA_DIR
#error "GREYBENCH_TEST_DATA_DIR must name tests/data (tests/CMakeLists.txt sets it)"
#endif

namespace gb::project {
namespace {
namespace fs = std::filesystem;

const std::string kUiData = std::string(GREYBENCH_TEST_DATA_DIR) + "/ui";

// A fresh directory under the system's temporary directory, removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() / ("greybench-project-test-" + std::to_string(::getpid()) +
                                         "-" + std::to_string(counter_++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  static inline int counter_ = 0;
  fs::path path_;
};

double LogLik(const model::ModelSpec& spec, const std::vector<std::string>& data) {
  auto problem = LoadProblem(spec, data);
  EXPECT_TRUE(problem.ok()) << problem.error().ToString();
  auto lik = MakeLikelihood(*problem);
  EXPECT_TRUE(lik.ok()) << lik.error().ToString();
  auto l = lik->Evaluate(spec.Values());
  EXPECT_TRUE(l.ok()) << l.error().ToString();
  return l->loglik;
}

TEST(SaveProject, RoundTripsAnEditedInlineModelTheDataAndUnknownKeys) {
  auto loaded = LoadProject(kUiData + "/project.json");
  ASSERT_TRUE(loaded.ok()) << loaded.error().ToString();
  auto spec = model::ParseModel(loaded->model_json, loaded->model_path);
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  // An edit the original file does not hold: the saved file must carry it.
  ASSERT_TRUE(model::SetParameter(&*spec, "tau_fv", 0.11).ok());

  Project p = *loaded;
  p.model_path.clear();  // inline
  p.model_json = model::ToJson(*spec);
  p.name = "edited";
  p.extra["diagram"] = "../diagrams/fuel_film.json";
  p.extra["layout"] = {{"sidebar", 220}, {"views", {"data", "estimate"}}};

  TempDir dir;
  fs::create_directories(dir / "sub");
  const std::string out = dir / "sub/saved.json";
  ASSERT_TRUE(SaveProject(p, out).ok());

  auto back = LoadProject(out);
  ASSERT_TRUE(back.ok()) << back.error().ToString();
  EXPECT_EQ(back->name, "edited");
  EXPECT_TRUE(back->model_path.empty());
  ASSERT_EQ(back->datasets.size(), 1u);
  EXPECT_TRUE(fs::equivalent(back->datasets[0].file, kUiData + "/f1.csv"));
  EXPECT_EQ(back->extra, p.extra);

  // The dataset is written relative to the saved file, as LoadProject resolves it.
  auto raw = ReadJsonFile(out);
  ASSERT_TRUE(raw.ok());
  const std::string written = (*raw)["datasets"][0].get<std::string>();
  EXPECT_FALSE(fs::path(written).is_absolute()) << written;

  auto spec_back = model::ParseModel(back->model_json, out);
  ASSERT_TRUE(spec_back.ok()) << spec_back.error().ToString();
  EXPECT_EQ(model::ToJson(*spec_back), model::ToJson(*spec));
  EXPECT_EQ(spec_back->parameters[spec_back->ParameterIndex("tau_fv")].value, 0.11);

  const double original = LogLik(*spec, data::Files(loaded->datasets));
  const double reread = LogLik(*spec_back, data::Files(back->datasets));
  EXPECT_TRUE(std::isfinite(original));
  EXPECT_EQ(reread, original);
  // And the edit matters: the file's own model scores the data differently.
  auto file_spec = model::LoadModelFile(kUiData + "/fuel_film.json");
  ASSERT_TRUE(file_spec.ok());
  EXPECT_NE(LogLik(*file_spec, data::Files(loaded->datasets)), original);
}

TEST(SaveProject, KeepsAReferencedModelFileAsARelativePath) {
  auto loaded = LoadProject(kUiData + "/project.json");
  ASSERT_TRUE(loaded.ok());
  TempDir dir;
  const std::string out = dir / "p.json";
  const Json j = ProjectToJson(*loaded, out);
  ASSERT_TRUE(j["model"].is_string());
  EXPECT_TRUE(fs::equivalent(fs::path(dir / "") / j["model"].get<std::string>(),
                             kUiData + "/fuel_film.json"));
  const Json absolute = ProjectToJson(*loaded, out, /*relative_paths=*/false);
  EXPECT_TRUE(fs::path(absolute["datasets"][0].get<std::string>()).is_absolute());
  ASSERT_TRUE(SaveProject(*loaded, out).ok());
  auto back = LoadProject(out);
  ASSERT_TRUE(back.ok()) << back.error().ToString();
  EXPECT_EQ(back->model_json, loaded->model_json);
}

TEST(SaveProject, ReportsAnUnwritableDirectoryByFileName) {
  auto loaded = LoadProject(kUiData + "/project.json");
  ASSERT_TRUE(loaded.ok());
  const std::string out = "/nonexistent-greybench-dir/p.json";
  const Status st = SaveProject(*loaded, out);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().ToString().find(out), std::string::npos) << st.error().ToString();
}

}  // namespace
}  // namespace gb::project

namespace gb::project {
namespace {

// The "estimation" key: read as the Estimate view's options, kept on save, and refused with its
// JSON path when it is not what it should be.
TEST(LoadProject, ReadsTheEstimationKeyAndNamesWhatIsWrongInIt) {
  TempDir dir;
  auto write = [&](const std::string& estimation) {
    const std::string path = dir / "p.json";
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fprintf(f,
                 "{\"greybench_project\": 1, \"model\": \"%s/fuel_film.json\", \"estimation\": "
                 "%s}\n",
                 kUiData.c_str(), estimation.c_str());
    std::fclose(f);
    return path;
  };
  auto ok = LoadProject(write(R"({"steady_start": true, "steady_window": 2.5})"));
  ASSERT_TRUE(ok.ok()) << ok.error().ToString();
  const EstimationDefaults d = ReadEstimationDefaults(*ok);
  EXPECT_EQ(d.steady_start, true);
  EXPECT_EQ(d.steady_window, 2.5);
  ASSERT_TRUE(SaveProject(*ok, dir / "saved.json").ok());
  auto saved = LoadProject(dir / "saved.json");
  ASSERT_TRUE(saved.ok()) << saved.error().ToString();
  EXPECT_EQ(ReadEstimationDefaults(*saved).steady_start, true);

  auto none = LoadProject(kUiData + "/project.json");
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(ReadEstimationDefaults(*none).steady_start.has_value());

  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"steady_start": "yes"})", "estimation.steady_start: expected true or false"},
      {R"({"steady_window": 0})", "estimation.steady_window: expected a number of time units"},
      {R"({"steady": true})", "estimation.steady: unknown member"},
      {R"(true)", "estimation: expected an object"},
  };
  for (const auto& [text, message] : bad) {
    auto r = LoadProject(write(text));
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_NE(r.error().ToString().find("p.json"), std::string::npos) << r.error().ToString();
    EXPECT_NE(r.error().ToString().find(message), std::string::npos) << r.error().ToString();
  }
}

TEST(LoadProject, ReadsTheSlidersAndNamesWhatIsWrongInThem) {
  TempDir dir;
  auto write = [&](const std::string& sliders) {
    const std::string path = dir / "p.json";
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fprintf(f,
                 "{\"greybench_project\": 1, \"model\": \"%s/fuel_film.json\", \"sliders\": "
                 "%s}\n",
                 kUiData.c_str(), sliders.c_str());
    std::fclose(f);
    return path;
  };
  auto ok = LoadProject(write(R"(["tau_ff", {"parameter": "X", "min": 0, "max": 0.5},
                                  {"parameter": "s11", "log": true}])"));
  ASSERT_TRUE(ok.ok()) << ok.error().ToString();
  const std::vector<SliderSpec> expected = {
      {"tau_ff", {}, {}, {}}, {"X", 0.0, 0.5, {}}, {"s11", {}, {}, true}};
  EXPECT_EQ(ReadSliders(*ok), expected);
  // Written back as read: a name alone where nothing else is set.
  ASSERT_TRUE(SaveProject(*ok, dir / "saved.json").ok());
  auto saved = LoadProject(dir / "saved.json");
  ASSERT_TRUE(saved.ok()) << saved.error().ToString();
  EXPECT_EQ(ReadSliders(*saved), expected);
  EXPECT_EQ(SlidersToJson(expected).dump(),
            R"(["tau_ff",{"parameter":"X","min":0.0,"max":0.5},{"parameter":"s11","log":true}])");
  auto none = LoadProject(kUiData + "/project.json");
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(ReadSliders(*none).empty());

  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"("tau_ff")", "sliders: expected a list of parameter names"},
      {R"([3])", "sliders[0]: expected a parameter's name or an object"},
      {R"([""])", "sliders[0]: expected a parameter's name"},
      {R"(["X", {"parameter": "X"}])", "sliders[1]: the parameter X has a slider already"},
      {R"([{"min": 0, "max": 1}])", "sliders[0]: the slider names no parameter"},
      {R"([{"parameter": "X", "min": 0}])", "sliders[0].max: give both"},
      {R"([{"parameter": "X", "min": 1, "max": 1}])", "sliders[0]: min 1 is not below max 1"},
      {R"([{"parameter": "X", "min": "a", "max": 1}])", "sliders[0].min: expected a finite number"},
      {R"([{"parameter": "X", "min": 0, "max": 1, "log": true}])",
       "sliders[0].min: a log scale needs min > 0"},
      {R"([{"parameter": "X", "log": 1}])", "sliders[0].log: expected true or false"},
      {R"([{"parameter": "X", "step": 1}])", "sliders[0].step: unknown member"},
  };
  for (const auto& [text, message] : bad) {
    auto r = LoadProject(write(text));
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_NE(r.error().ToString().find("p.json"), std::string::npos) << r.error().ToString();
    EXPECT_NE(r.error().ToString().find(message), std::string::npos) << r.error().ToString();
  }
}

}  // namespace
}  // namespace gb::project
