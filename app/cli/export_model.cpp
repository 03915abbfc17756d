// greybench-cli export-model: the model a project's block diagram compiles to.
#include <cstdio>

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
    // Every problem, each naming the block, so they can all be fixed in one pass.
    for (const auto& p : compiled.problems) {
      Error e = InputError(p.ToString());
      e.file = args.project;
      Fail(e);
    }
    return 2;
  }
  if (auto s = model::SaveModelFile(*compiled.model, args.out); !s) return Fail(s.error());
  return 0;
}

}  // namespace gb::cli
