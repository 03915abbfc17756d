// The "operating_points" key of a project file (core/project/operating_points.h).
#include "core/project/operating_points.h"

#include <cstdint>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "core/util/json.h"

namespace gb::project {
namespace {

namespace fs = std::filesystem;

// A project file in a fresh temporary directory, with a model beside it.
class ProjectFile {
 public:
  explicit ProjectFile(const std::string& operating_points) {
    dir_ = fs::temp_directory_path() /
           ("greybench_op_" + std::to_string(reinterpret_cast<std::uintptr_t>(this)));
    fs::create_directories(dir_);
    std::ofstream(dir_ / "model.json") << R"({"greybench_model": 1})";
    std::string text = R"({"greybench_project": 1, "model": "model.json",
                           "datasets": ["a.csv", "b.csv"])";
    if (!operating_points.empty()) text += ",\n\"operating_points\": " + operating_points;
    std::ofstream(path()) << text << "}";
  }
  ~ProjectFile() { fs::remove_all(dir_); }
  std::string path() const { return (dir_ / "case.json").string(); }
  std::string dir() const { return dir_.string(); }

 private:
  fs::path dir_;
};

Result<std::optional<OperatingPointsSpec>> Read(const ProjectFile& file) {
  auto project = LoadProject(file.path());
  EXPECT_TRUE(project.ok()) << project.error().ToString();
  if (!project) return project.error();
  return ReadOperatingPoints(*project);
}

TEST(OperatingPoints, AProjectWithoutTheKeyHasNoSweep) {
  const ProjectFile file("");
  auto spec = Read(file);
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  EXPECT_FALSE(spec->has_value());
}

TEST(OperatingPoints, ReadsEveryMemberAndResolvesPathsAgainstTheProject) {
  const ProjectFile file(R"({"datasets": ["data/p1.csv", "/abs/p2.csv"], "speed_tag": "speed",
      "trend": {"parameter": "tau", "tag": "load"}, "mean_of": ["tau"],
      "tags": {"speed": {"label": "n", "unit": "rpm"}, "load": {"unit": "%"}}})");
  auto spec = Read(file);
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  ASSERT_TRUE(spec->has_value());
  const OperatingPointsSpec& s = **spec;
  ASSERT_EQ(s.datasets.size(), 2u);
  EXPECT_EQ(s.datasets[0].file, (fs::path(file.dir()) / "data/p1.csv").string());
  EXPECT_EQ(s.datasets[1].file, "/abs/p2.csv");
  EXPECT_FALSE(s.datasets_from_project);
  EXPECT_EQ(s.speed_tag, "speed");
  EXPECT_EQ(s.trend_parameter, "tau");
  EXPECT_EQ(s.trend_tag, "load");
  EXPECT_EQ(s.mean_of, std::vector<std::string>{"tau"});
  EXPECT_EQ(s.Label("speed").label, "n");
  EXPECT_EQ(s.Label("speed").unit, "rpm");
  EXPECT_EQ(s.Label("load").label, "load");  // no label given: the tag itself
  EXPECT_EQ(s.Label("load").unit, "%");
  EXPECT_EQ(s.Label("other").label, "other");
}

TEST(OperatingPoints, AnEmptyObjectSweepsTheProjectsDatasetsWithTheDefaults) {
  const ProjectFile file("{}");
  auto spec = Read(file);
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  ASSERT_TRUE(spec->has_value());
  EXPECT_TRUE((*spec)->datasets_from_project);
  EXPECT_EQ((*spec)->datasets.size(), 2u);
  EXPECT_EQ((*spec)->speed_tag, "n_rpm");
  EXPECT_EQ((*spec)->trend_parameter, "X");
  EXPECT_EQ((*spec)->trend_tag, "alpha_deg");
}

TEST(OperatingPoints, ReadsTheLinearisationOfANonlinearFit) {
  const ProjectFile file(R"({"model": "fuel.json", "delay_parameter": "delay",
      "linearised": {"result": "fit.json", "point": {"N": "n_rpm", "ilambda": 1},
                     "quantities": {"tau_ff": "-1/A_mff_mff", "Kb": "-C_ilambda_mfv"}}})");
  auto spec = Read(file);
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  ASSERT_TRUE(spec->has_value());
  const OperatingPointsSpec& s = **spec;
  EXPECT_EQ(s.model, (fs::path(file.dir()) / "fuel.json").string());
  EXPECT_EQ(s.delay_parameter, "delay");
  ASSERT_TRUE(s.linearised.has_value());
  EXPECT_EQ(s.linearised->result, (fs::path(file.dir()) / "fit.json").string());
  EXPECT_TRUE(s.linearised->model.empty());
  ASSERT_EQ(s.linearised->point.size(), 2u);
  EXPECT_EQ(s.linearised->point[0].first, "N");
  EXPECT_EQ(s.linearised->point[0].second.tag, "n_rpm");
  EXPECT_EQ(s.linearised->point[1].second.tag, "");
  EXPECT_EQ(s.linearised->point[1].second.number, 1.0);
  ASSERT_EQ(s.linearised->quantities.size(), 2u);
  EXPECT_EQ(s.linearised->quantities[0].first, "tau_ff");  // the file's order
  EXPECT_EQ(s.linearised->quantities[1].second, "-C_ilambda_mfv");
}

TEST(OperatingPoints, ErrorsNameTheProjectFileAndTheJsonPath) {
  struct Case {
    const char* json;
    const char* path;
    const char* says;
  };
  const Case cases[] = {
      {R"([1, 2])", "operating_points", "expected an object"},
      {R"({"datasets": "a.csv"})", "operating_points.datasets", "expected a list"},
      {R"({"datasets": ["a.csv", 3]})", "operating_points.datasets[1]", "data file name"},
      {R"({"datasets": []})", "operating_points.datasets", "at least one"},
      {R"({"trend": {"parameter": "X"}})", "operating_points.trend", "\"tag\""},
      {R"({"trend": {"parameter": "X", "tag": 4}})", "operating_points.trend.tag", "tag name"},
      {R"({"trend": {"parameter": "", "tag": "a"}})", "operating_points.trend.parameter", "empty"},
      {R"({"mean_of": ["tau", null]})", "operating_points.mean_of[1]", "parameter name"},
      {R"({"speed_tag": 1})", "operating_points.speed_tag", "tag name"},
      {R"({"tags": {"n": "rpm"}})", "operating_points.tags.n", "label"},
      {R"({"tags": {"n": {"units": "rpm"}}})", "operating_points.tags.n.units", "unknown"},
      {R"({"dataset": ["a.csv"]})", "operating_points.dataset", "unknown member"},
      {R"({"model": 1})", "operating_points.model", "model file name"},
      {R"({"delay_parameter": ""})", "operating_points.delay_parameter", "empty"},
      {R"({"linearised": 1})", "operating_points.linearised", "expected {"},
      {R"({"linearised": {"point": {"N": "n"}}})", "operating_points.linearised", "\"result\""},
      {R"({"linearised": {"result": "r.json"}})", "operating_points.linearised", "\"point\""},
      {R"({"linearised": {"result": "r.json", "point": {"N": true}}})",
       "operating_points.linearised.point.N", "tag name"},
      {R"({"linearised": {"result": "r.json", "point": {"N": "n"}, "quantities": {"X": 2}}})",
       "operating_points.linearised.quantities.X", "expression"},
      {R"({"linearised": {"result": "r.json", "point": {"N": "n"}, "at": 1}})",
       "operating_points.linearised.at", "unknown member"},
  };
  for (const Case& c : cases) {
    const ProjectFile file(c.json);
    auto spec = Read(file);
    ASSERT_FALSE(spec.ok()) << c.json;
    EXPECT_EQ(spec.error().file, file.path()) << c.json;
    EXPECT_EQ(spec.error().path, c.path) << c.json;
    EXPECT_NE(spec.error().message.find(c.says), std::string::npos)
        << c.json << ": " << spec.error().ToString();
    // The whole message as a user reads it: FILE: PATH: message.
    EXPECT_EQ(spec.error().ToString().rfind(file.path() + ": " + c.path + ": ", 0), 0u)
        << spec.error().ToString();
  }
}

}  // namespace
}  // namespace gb::project
