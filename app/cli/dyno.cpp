#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/data/write_csv.h"
#include "core/sim/dyno.h"

namespace gb::cli {

int RunDyno(const DynoArgs& args) {
  Result<sim::Record> record = InputError("unknown experiment");
  if (args.experiment == "fuel") {
    auto point = sim::FindFuelPoint(args.point);
    if (!point) return Fail(point.error());
    sim::FuelExperiment e;
    e.point = *point;
    if (args.duration > 0) e.duration = args.duration;
    if (args.order > 0) e.prbs_order = args.order;
    if (args.bit_period > 0) e.bit_period = args.bit_period;
    e.seed = args.seed;
    if (args.no_filter) e.recording.filter_hz = 0;
    record = sim::RunFuelExperiment(e);
  } else if (args.experiment == "crankshaft") {
    sim::CrankshaftExperiment e;
    if (args.duration > 0) e.duration = args.duration;
    if (args.order > 0) e.prbs_order = args.order;
    if (args.bit_period > 0) e.bit_period = args.bit_period;
    e.seed = args.seed;
    e.perturb_load = !args.constant_load;
    if (args.no_filter) e.recording.filter_hz = 0;
    record = sim::RunCrankshaftExperiment(e);
  } else {
    sim::SquareWaveTest e;
    if (args.duration > 0) e.duration = args.duration;
    e.seed = args.seed;
    if (args.no_filter) e.recording.filter_hz = 0;
    record = sim::RunSquareWaveTest(e);
  }
  if (!record) return Fail(record.error());
  std::vector<data::CsvColumn> cols;
  for (std::size_t i = 0; i < record->names.size(); ++i)
    cols.push_back({record->names[i], record->columns[i]});
  std::vector<std::string> comments = record->comments;
  comments.push_back(fmt::format("regenerate: greybench-cli dyno {}{} --seed {}{} --out FILE",
                                 args.experiment,
                                 args.experiment == "fuel" ? " --point " + args.point : "",
                                 args.seed, args.constant_load ? " --constant-load" : ""));
  if (auto st = data::WriteCsvFile(args.out, cols, comments); !st) return Fail(st.error());
  return 0;
}

}  // namespace gb::cli
