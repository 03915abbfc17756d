// greybench-cli export-model: the model a project's block diagram compiles to.
#include <cstddef>
#include <cstdio>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/diagram/diagram.h"
#include "core/project/project.h"

namespace gb::cli {

int RunExportModel(const ExportModelArgs& args) {
  auto project = project::LoadProject(args.project);
  if (!project) return Fail(project.error());
  if (int s = GuardOutputs(project::ProjectFiles(*project), {{args.out, "--out"}})) return s;
  auto diagram = diagram::LoadProjectDiagram(*project);
  if (!diagram) return Fail(diagram.error());
  const diagram::CompileResult compiled = diagram::Compile(*diagram, args.out);
  if (!compiled.ok()) {
    // The problems, each naming the block, so that they can be fixed in one pass; a diagram with
    // a problem on every one of 100 000 blocks gets the first few and their count.
    constexpr std::size_t kMaxShown = 20;
    const std::size_t n = compiled.problems.size();
    for (std::size_t i = 0; i < n && i < kMaxShown; ++i) {
      Error e = InputError(compiled.problems[i].ToString());
      e.file = args.project;
      Fail(e);
    }
    if (n > kMaxShown) {
      Error e = InputError(
          fmt::format("the diagram has {} problems; the first {} are above", n, kMaxShown));
      e.file = args.project;
      Fail(e);
    }
    return 2;
  }
  if (auto s = model::SaveModelFile(*compiled.model, args.out); !s) return Fail(s.error());
  return 0;
}

}  // namespace gb::cli
