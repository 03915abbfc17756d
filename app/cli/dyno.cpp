#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <string_view>
#include <thread>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/data/write_csv.h"
#include "core/sim/dyno.h"
#include "core/sim/engine.h"
#include "core/sim/fault_schedule.h"
#include "core/sim/live_dyno.h"

namespace gb::cli {

namespace {

// ---- --live: the fuel experiment streamed, with faults ------------------------------------------

constexpr std::string_view kFaultOption = "--fault";

// The --fault arguments in time order (the command line's order at equal times), checked by
// replaying them on the operating point's values: a fault the dyno would refuse is refused here,
// before the run.
Result<std::vector<sim::TimedFuelFault>> ParseFaults(const std::vector<std::string>& texts,
                                                     const sim::FuelOperatingPoint& point,
                                                     double duration) {
  std::vector<sim::TimedFuelFault> faults;
  for (const auto& text : texts) {
    auto f = sim::ParseFuelFault(text, kFaultOption);
    if (!f) return f.error();
    if (duration > 0 && f->at_s >= duration)
      return sim::FuelFaultError(
          kFaultOption, text,
          fmt::format("{} s is not before the end of the run (--duration {})", f->at_s, duration));
    faults.push_back(std::move(*f));
  }
  return sim::ScheduleFuelFaults(std::move(faults), point, kFaultOption);
}

// --no-filter and --oversample, which every experiment's recording takes (after any other
// setting of the filter's corner).
void ApplyRecordingArgs(const DynoArgs& args, sim::RecordingOptions* r) {
  if (args.no_filter) r->filter_hz = 0;
  if (args.oversample > 0) r->oversample = args.oversample;
}

std::string Regenerate(const DynoArgs& args) {
  std::string line = fmt::format("regenerate: greybench-cli dyno fuel --point {} --seed {}",
                                 args.point, args.seed);
  if (args.order > 0) line += fmt::format(" --order {}", args.order);
  if (args.bit_period > 0) line += fmt::format(" --bit-period {}", args.bit_period);
  if (args.no_filter) line += " --no-filter";
  if (args.oversample > 0) line += fmt::format(" --oversample {}", args.oversample);
  line += " --live --speed 0";
  if (args.duration > 0) line += fmt::format(" --duration {}", args.duration);
  for (const auto& f : args.faults) line += " --fault '" + f + "'";
  if (args.truth) line += " --truth";
  return line + " --out FILE";
}

// Writes `text` and flushes. false when the stream failed; *reader_gone when that was because
// the reader of a pipe went away.
bool Put(std::FILE* out, const std::string& text, bool* reader_gone) {
  if (std::fputs(text.c_str(), out) >= 0 && std::fflush(out) == 0) return true;
  *reader_gone = errno == EPIPE;
  return false;
}

int StreamFuel(const DynoArgs& args, const sim::FuelExperiment& e) {
  if (!(args.speed >= 0 && std::isfinite(args.speed)))
    return Fail(InputError(fmt::format(
        "--speed {}: expected a factor of real time >= 0 (0: as fast as possible)", args.speed)));
  if (!(args.duration >= 0 && std::isfinite(args.duration)))
    return Fail(InputError(fmt::format(
        "--duration {}: expected seconds >= 0 (0 or none: without end)", args.duration)));
  auto faults = ParseFaults(args.faults, e.point, args.duration);
  if (!faults) return Fail(faults.error());
  auto dyno = sim::LiveFuelDyno::Create(e);
  if (!dyno) return Fail(dyno.error());

  const bool to_stdout = args.out.empty() || args.out == "-";
  std::FILE* out = to_stdout ? stdout : std::fopen(args.out.c_str(), "w");
  if (!out)
    return Fail(
        InputError(fmt::format("{}: cannot write the file: {}", args.out, std::strerror(errno))));
  std::signal(SIGPIPE, SIG_IGN);  // a reader that goes away is EPIPE, and the end of the run
  auto finish = [&](bool ok, bool reader_gone) {
    const int error = errno;
    if (!to_stdout && std::fclose(out) != 0) ok = false;
    if (ok || reader_gone) return 0;
    return Fail(InputError(fmt::format("{}: cannot write: {}", to_stdout ? "stdout" : args.out,
                                       std::strerror(error))));
  };

  std::string head;
  std::vector<std::string> comments = sim::FuelExperimentComments(e);
  for (const auto& f : *faults) comments.push_back(sim::DescribeFuelFault(f));
  comments.push_back(Regenerate(args));
  for (const auto& c : comments) head += "# " + c + "\n";
  head += args.truth ? "t,mfi,ilambda,true_tau_ff,true_X,true_delay,true_Kb\n" : "t,mfi,ilambda\n";
  bool reader_gone = false;
  if (!Put(out, head, &reader_gone)) return finish(false, reader_gone);

  const double ts = e.recording.sample_time;
  const auto n_samples =
      args.duration > 0 ? static_cast<std::int64_t>(std::ceil(args.duration / ts - 1e-9)) : -1;
  const auto start = std::chrono::steady_clock::now();
  std::size_t next_fault = 0;
  std::string row;
  for (std::int64_t k = 0; n_samples < 0 || k < n_samples; ++k) {
    // A fault at T acts from the first sample at or after T.
    if (const Status st = sim::ApplyDueFuelFaults(*faults, &next_fault, &*dyno, kFaultOption);
        !st) {
      finish(true, false);
      return Fail(st.error());
    }
    const sim::FuelTruth truth = dyno->Truth();
    const sim::FuelSample s = dyno->Next();
    row.clear();
    fmt::format_to(std::back_inserter(row), "{},{},{}", s.t, s.mfi, s.ilambda);
    if (args.truth)
      fmt::format_to(std::back_inserter(row), ",{},{},{},{}", truth.tau_ff, truth.X, truth.delay_s,
                     truth.Kb);
    row += '\n';
    if (args.speed > 0)
      std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                std::chrono::duration<double>(s.t / args.speed)));
    if (!Put(out, row, &reader_gone)) return finish(false, reader_gone);
  }
  return finish(true, false);
}

}  // namespace

int RunDyno(const DynoArgs& args) {
  if (args.live && args.experiment != "fuel")
    return Fail(
        InputError(fmt::format("--live streams the fuel experiment, not {}", args.experiment)));
  if (!args.live && args.out.empty())
    return Fail(InputError("dyno: --out is required (or --live to stream the CSV to stdout)"));
  if (args.lambda_sensor != "exact" && args.experiment != "engine")
    return Fail(InputError("--lambda-sensor: only the engine experiment has this choice, not " +
                           args.experiment));
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
    ApplyRecordingArgs(args, &e.recording);
    if (args.live) return StreamFuel(args, e);
    record = sim::RunFuelExperiment(e);
  } else if (args.experiment == "crankshaft") {
    sim::CrankshaftExperiment e;
    if (args.duration > 0) e.duration = args.duration;
    if (args.order > 0) e.prbs_order = args.order;
    if (args.bit_period > 0) e.bit_period = args.bit_period;
    e.seed = args.seed;
    e.perturb_load = !args.constant_load;
    ApplyRecordingArgs(args, &e.recording);
    record = sim::RunCrankshaftExperiment(e);
  } else if (args.experiment == "engine") {
    sim::EngineExperiment e;
    if (args.path.empty()) {
      auto point = sim::ParseEnginePoint(args.point);
      if (!point) return Fail(point.error());
      e.path = {*point};
    } else {
      // Names separated by commas, or n=..,alpha=.. points separated by semicolons.
      const char sep = args.path.find(';') != std::string::npos || args.path.find('=') != std::string::npos ? ';' : ',';
      std::size_t start = 0;
      while (start <= args.path.size()) {
        const std::size_t end = std::min(args.path.find(sep, start), args.path.size());
        auto point = sim::ParseEnginePoint(args.path.substr(start, end - start));
        if (!point) return Fail(InputError("--path: " + point.error().message));
        e.path.push_back(*point);
        start = end + 1;
      }
      e.hold_s = args.hold;
      e.ramp_s = args.ramp;
      e.duration = static_cast<double>(e.path.size()) * e.hold_s +
                   static_cast<double>(e.path.size() - 1) * e.ramp_s;
    }
    if (args.duration > 0) e.duration = args.duration;
    if (args.throttle_amplitude >= 0) e.throttle_amplitude = args.throttle_amplitude;
    e.hold_speed = args.hold_speed;
    if (args.sample_time > 0) {
      e.recording.sample_time = args.sample_time;
      e.recording.filter_hz = 0.25 / args.sample_time;
    }
    if (args.order > 0) e.fuel_order = args.order;
    if (args.bit_period > 0) e.fuel_bit = args.bit_period;
    e.seed = args.seed;
    ApplyRecordingArgs(args, &e.recording);
    if (args.lambda_sensor == "pade") e.sensor_delay = sim::EngineExperiment::SensorDelay::kPade;
    record = sim::RunEngineExperiment(e);
  } else {
    sim::SquareWaveTest e;
    if (args.duration > 0) e.duration = args.duration;
    e.seed = args.seed;
    ApplyRecordingArgs(args, &e.recording);
    record = sim::RunSquareWaveTest(e);
  }
  if (!record) return Fail(record.error());
  std::vector<data::CsvColumn> cols;
  for (std::size_t i = 0; i < record->names.size(); ++i)
    cols.push_back({record->names[i], record->columns[i]});
  std::vector<std::string> comments = record->comments;
  std::string where;
  if (args.experiment == "fuel")
    where = " --point " + args.point;
  else if (args.experiment == "engine" && args.path.empty())
    where = " --point '" + args.point + "'";
  else if (args.experiment == "engine")
    where = fmt::format(" --path '{}' --hold {} --ramp {}", args.path, args.hold, args.ramp);
  if (args.duration > 0) where += fmt::format(" --duration {}", args.duration);
  if (args.order > 0) where += fmt::format(" --order {}", args.order);
  if (args.bit_period > 0) where += fmt::format(" --bit-period {}", args.bit_period);
  if (args.hold_speed) where += " --hold-speed";
  if (args.sample_time > 0) where += fmt::format(" --sample-time {}", args.sample_time);
  if (args.throttle_amplitude >= 0)
    where += fmt::format(" --throttle-amplitude {}", args.throttle_amplitude);
  if (args.no_filter) where += " --no-filter";
  if (args.oversample > 0) where += fmt::format(" --oversample {}", args.oversample);
  if (args.lambda_sensor != "exact") where += " --lambda-sensor " + args.lambda_sensor;
  comments.push_back(fmt::format("regenerate: greybench-cli dyno {}{} --seed {}{} --out FILE",
                                 args.experiment, where, args.seed,
                                 args.constant_load ? " --constant-load" : ""));
  if (auto st = data::WriteCsvFile(args.out, cols, comments); !st) return Fail(st.error());
  return 0;
}

}  // namespace gb::cli
