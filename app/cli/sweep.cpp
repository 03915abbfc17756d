#include "core/project/sweep.h"

#include <cstdio>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "app/cli/cli.h"
#include "core/util/file.h"

namespace gb::cli {

int RunSweep(const SweepArgs& args) {
  auto in = ResolveInputs(args.model, args.data);
  if (!in) return Fail(in.error());
  if (int s = GuardOutputs(in->Files(), {{args.out_csv, "--out-csv"}, {args.out_md, "--out-md"}}))
    return s;
  auto datasets = FittedDatasets(*in);
  if (!datasets) return Fail(datasets.error());
  auto spec = LoadModelWithOverrides(*in, args.sets);
  if (!spec) return Fail(spec.error());
  project::SweepOptions options;
  options.parallel = args.parallel.value_or(0);
  // The default trend (X against alpha_deg, the paper's Fig. 4) is fitted where the model and
  // the data have them; one the user names must exist.
  const std::string trend = args.trend.value_or("X:alpha_deg");
  const auto colon = trend.find(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == trend.size())
    return Fail(
        InputError(fmt::format("--trend '{}': expected PARAMETER:TAG, e.g. X:alpha_deg", trend)));
  options.trend_parameter = trend.substr(0, colon);
  options.trend_tag = trend.substr(colon + 1);
  options.delay_parameter = args.delay_parameter;
  auto free_parameter = [&](const std::string& option, const std::string& name) -> std::string {
    const int i = spec->ParameterIndex(name);
    if (i >= 0 && !spec->parameters[i].fixed) return "";
    std::vector<std::string> free;
    for (const auto& p : spec->parameters)
      if (!p.fixed) free.push_back(p.name);
    return fmt::format("{}: '{}' is {} of the model {} (its free parameters: {})", option, name,
                       i < 0 ? "not a parameter" : "a fixed parameter", in->ModelSource(),
                       fmt::join(free, ", "));
  };
  if (args.trend) {
    if (auto why = free_parameter("--trend", options.trend_parameter); !why.empty())
      return Fail(InputError(why));
    for (const data::DatasetSpec& dataset : *datasets) {
      const std::string& d = dataset.file;
      auto point = project::ReadOperatingPoint(d);
      if (!point) return Fail(point.error());
      if (!point->values.count(options.trend_tag)) {
        std::vector<std::string> tags;
        for (const auto& [k, v] : point->values) tags.push_back(k);
        Error e = InputError(fmt::format(
            "--trend {}: the data file's operating point has no tag '{}' (its tags: {})", trend,
            options.trend_tag, tags.empty() ? "none" : fmt::format("{}", fmt::join(tags, ", "))));
        e.file = d;
        return Fail(e);
      }
    }
  }
  if (!args.delay_parameter.empty())
    if (auto why = free_parameter("--delay-parameter", args.delay_parameter); !why.empty())
      return Fail(InputError(why));
  // A sweep may take minutes: output files that cannot be written are reported before it.
  for (const std::string* out : {&args.out_md, &args.out_csv})
    if (!out->empty())
      if (auto st = CheckWritable(*out); !st) return Fail(st.error());
  auto result = project::Sweep(*spec, *datasets, options);
  if (!result) return Fail(result.error());
  const std::string md = result->Markdown();
  std::printf("%s", md.c_str());
  if (!args.out_md.empty())
    if (auto st = WriteFileAtomic(args.out_md, md); !st) return Fail(st.error());
  if (!args.out_csv.empty())
    if (auto st = WriteFileAtomic(args.out_csv, result->Csv()); !st) return Fail(st.error());
  for (const auto& r : result->rows)
    if (!r.summary.converged) return 1;
  return 0;
}

}  // namespace gb::cli
