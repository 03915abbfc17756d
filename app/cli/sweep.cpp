#include <cstdio>

#include "app/cli/cli.h"
#include "core/estimate/sweep.h"
#include "core/project/project.h"

namespace gb::cli {

int RunSweep(const SweepArgs& args) {
  auto spec = LoadModelWithOverrides(args.model, args.sets);
  if (!spec) return Fail(spec.error());
  estimate::SweepOptions options;
  options.parallel = args.parallel;
  const auto colon = args.trend.find(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == args.trend.size())
    return Fail(InputError("--trend: expected PARAMETER:TAG, e.g. X:alpha_deg"));
  options.trend_parameter = args.trend.substr(0, colon);
  options.trend_tag = args.trend.substr(colon + 1);
  options.delay_parameter = args.delay_parameter;
  // A sweep may take minutes: output files that cannot be written are reported before it.
  for (const std::string* out : {&args.out_md, &args.out_csv})
    if (!out->empty())
      if (auto st = project::CheckWritable(*out); !st) return Fail(st.error());
  auto result = estimate::Sweep(*spec, args.data, options);
  if (!result) return Fail(result.error());
  const std::string md = result->Markdown();
  std::printf("%s", md.c_str());
  if (!args.out_md.empty())
    if (auto st = project::WriteFileAtomic(args.out_md, md); !st) return Fail(st.error());
  if (!args.out_csv.empty())
    if (auto st = project::WriteFileAtomic(args.out_csv, result->Csv()); !st) return Fail(st.error());
  for (const auto& r : result->rows)
    if (!r.summary.converged) return 1;
  return 0;
}

}  // namespace gb::cli
