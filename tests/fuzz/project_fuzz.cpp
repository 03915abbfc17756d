// libFuzzer target: project files (core/project/project.cpp) and what opening one leads to.
//
// Each input is written to project.json in a private temporary directory that also holds a valid
// model (model.json), block diagram (diagram.json) and data file (data.csv), so relative names in
// a fuzzed project reach real files. Then, as the workbench and `greybench-cli export-model` do:
// LoadProject -> ParseModel of its model -> LinearModel; the datasets' keys are written back
// (DatasetSpecToJson must reproduce them), and the datasets inside the directory are read,
// prepared and bound (LoadProblem); the project's diagram (inline or a file) is read, written back
// (ToJson/FromJson must reproduce it) and compiled; an equations model is turned into a diagram
// (FromModel) and compiled back.
// Files outside the temporary directory are never read (a fuzzed path could name /dev/zero).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/diagram/diagram.h"
#include "core/model/linear_model.h"
#include "core/model/model.h"
#include "core/model/nonlinear_model.h"
#include "core/project/problem.h"
#include "core/project/project.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

namespace fs = std::filesystem;
using gb::Json;

struct Fixture {
  fs::path dir;
  std::string project_path;
};

Fixture& TheFixture() {
  static Fixture fixture;  // set once by LLVMFuzzerInitialize
  return fixture;
}

void RemoveFixture() {
  std::error_code ec;
  fs::remove_all(TheFixture().dir, ec);
}

bool Inside(const fs::path& dir, const std::string& path) {
  const std::string d = dir.string() + "/";
  const std::string p = fs::path(path).lexically_normal().string();
  return p.compare(0, d.size(), d) == 0;
}

void CheckDiagram(const gb::diagram::BlockDiagram& d, const std::string& source) {
  const Json written = gb::diagram::ToJson(d);
  auto again = gb::diagram::FromJson(written, source);
  FUZZ_CHECK(again.ok());
  FUZZ_CHECK(gb::diagram::ToJson(*again).dump() == written.dump());
  const gb::diagram::CompileResult compiled = gb::diagram::Compile(d, source);
  if (!compiled.ok()) {
    FUZZ_CHECK(!compiled.problems.empty());
    (void)compiled.Message();
    return;
  }
  // Compile promises a model that one of the filters accepts: LinearModel, or (a diagram with
  // nonlinear blocks, or one made from a nonlinear model) NonlinearModel.
  if (gb::model::LinearModel::Compile(*compiled.model).ok()) return;
  FUZZ_CHECK(gb::model::NonlinearModel::Compile(*compiled.model).ok());
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  char pattern[] = "/tmp/greybench-project-fuzz-XXXXXX";
  FUZZ_CHECK(mkdtemp(pattern) != nullptr);
  Fixture& f = TheFixture();
  f.dir = pattern;
  f.project_path = (f.dir / "project.json").string();
  const fs::path source = GREYBENCH_SOURCE_DIR;
  fs::copy_file(source / "assets/models/fuel_film.json", f.dir / "model.json");
  fs::copy_file(source / "assets/diagrams/fuel_film.json", f.dir / "diagram.json");
  fs::copy_file(source / "tests/data/cli/fuel.csv", f.dir / "data.csv");
  std::atexit(RemoveFixture);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const Fixture& f = TheFixture();
  // LoadProject reads the model file a project names: only one inside the directory.
  const Json j = Json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (j.is_object() && j.contains("model") && j["model"].is_string() &&
      !Inside(f.dir, (f.dir / j["model"].get<std::string>()).string()))
    return 0;
  {
    std::ofstream out(f.project_path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  auto project = gb::project::LoadProject(f.project_path);
  if (!project.ok()) {
    FUZZ_CHECK(!project.error().ToString().empty());
    return 0;
  }
  const gb::project::Project& p = *project;

  if (p.extra.contains("diagram")) {
    const Json& v = p.extra["diagram"];
    const bool local =
        !v.is_string() || Inside(f.dir, (f.dir / v.get<std::string>()).lexically_normal().string());
    if (local) {
      auto diagram = gb::diagram::LoadProjectDiagram(p);
      if (diagram.ok()) CheckDiagram(*diagram, p.path);
    }
  }

  auto spec = gb::model::ParseModel(p.model_json, p.model_path.empty() ? p.path : p.model_path);
  if (!spec.ok()) return 0;
  if (spec->initial_covariance != gb::model::InitialCovariance::kExplicit) {
    auto diagram = gb::diagram::FromModel(*spec);
    if (diagram.ok()) CheckDiagram(*diagram, p.path);
  }
  // A dataset's keys are written back as they were read (ProjectToJson's entries).
  std::vector<gb::data::DatasetSpec> datasets;
  for (const gb::data::DatasetSpec& d : p.datasets) {
    const Json written = gb::data::DatasetSpecToJson(d, d.file);
    auto again = gb::data::ParseDatasetSpec(written, p.path, d.origin_path);
    FUZZ_CHECK(again.ok());
    FUZZ_CHECK(gb::data::DatasetSpecToJson(*again, again->file).dump() == written.dump());
    if (Inside(f.dir, d.file)) datasets.push_back(d);
  }
  auto problem = gb::project::LoadProblem(*spec, datasets);
  if (problem.ok() && !problem->series.empty()) {
    auto likelihood = gb::project::MakeLikelihood(*problem);
    if (likelihood.ok()) (void)likelihood->Evaluate(problem->spec().Values());
  }
  return 0;
}
