// greybench-cli export-fmu: a fit's model as an FMI 2.0 FMU (core/fmu/fmu.h).
#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/fmu/fmu.h"
#include "core/project/result_file.h"
#include "core/report/report.h"
#include "core/util/file.h"

namespace gb::cli {

int RunExportFmu(const ExportFmuArgs& args) {
  if (args.virtual_sensor && args.interface_given && args.interface != "cs")
    return Fail(InputError(fmt::format(
        "--interface {}: a virtual sensor is a Co-Simulation FMU (leave --interface out)",
        args.interface)));
  auto result = ReadJsonFile(args.result);
  if (!result) return Fail(result.error());
  if (Status st = report::CheckResultJson(*result, args.result); !st) return Fail(st.error());
  std::string model = args.model;
  if (model.empty()) model = NamedFile(*result, "project_file", args.result);
  if (model.empty()) model = NamedFile(*result, "model_file", args.result);
  if (model.empty()) {
    Error e = InputError("the result file names no model or project file: give it with --model");
    e.file = args.result;
    return Fail(e);
  }
  std::vector<FileRole> files = {{args.result, "the result file"}};
  Result<model::ModelSpec> spec = InputError("");
  if (IsProjectFile(model)) {
    auto in = ResolveInputs(model, {});
    if (!in) return Fail(in.error());
    const std::vector<FileRole> read = in->Files();
    files.insert(files.end(), read.begin(), read.end());
    spec = LoadModelWithOverrides(*in, {});
  } else {
    files.push_back({model, "the model file"});
    spec = LoadModelWithOverrides(model, {});
  }
  if (!spec) return Fail(spec.error());
  if (int s = GuardOutputs(files, {{args.out, "--out"}})) return s;
  auto delays = project::ApplyResultFile(args.result, {}, &*spec);
  if (!delays) return Fail(delays.error());
  auto compiled = model::NonlinearModel::Compile(*spec);
  if (!compiled) return Fail(compiled.error());
  fmu::FmuOptions options;
  if (args.virtual_sensor) {
    auto sensor = fmu::VirtualSensorOptions(*compiled, spec->Values(), *delays);
    if (!sensor) return Fail(sensor.error());
    options = std::move(*sensor);
  } else {
    options.interface = args.interface == "me"   ? fmu::Interface::kModelExchange
                        : args.interface == "cs" ? fmu::Interface::kCoSimulation
                                                 : fmu::Interface::kBoth;
  }
  options.identifier = fmu::IdentifierOf(std::filesystem::path(args.out).stem().string());
  if (auto s = fmu::ExportFmu(*compiled, spec->Values(), options, args.out); !s) {
    Error e = s.error();
    if (e.file.empty()) e.file = args.out;
    return Fail(e);
  }
  if (const std::string note = fmu::DelayNote(*spec, *delays);
      !note.empty() && !args.virtual_sensor)
    std::fprintf(stderr, "greybench-cli: warning: %s\n", note.c_str());
  std::printf(
      "%s\n",
      fmt::format("wrote {}: FMI 2.0, {}, model identifier {}; {} states, {} inputs, {} "
                  "outputs, {} parameters at the estimates of {}",
                  args.out,
                  args.virtual_sensor ? std::string("a virtual sensor (the extended Kalman filter, "
                                                    "Co-Simulation)")
                                      : std::string(fmu::InterfaceName(options.interface)),
                  options.identifier, spec->states.size(), spec->inputs.size(),
                  spec->outputs.size(), spec->parameters.size(), args.result)
          .c_str());
  return 0;
}

}  // namespace gb::cli
