#include "core/sim/dyno.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/data/write_csv.h"
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
                                                     std::optional<double> duration) {
  std::vector<sim::TimedFuelFault> faults;
  for (const auto& text : texts) {
    auto f = sim::ParseFuelFault(text, kFaultOption);
    if (!f) return f.error();
    if (duration && f->at_s >= *duration)
      return sim::FuelFaultError(
          kFaultOption, text,
          fmt::format("{} s is not before the end of the run (--duration {})", f->at_s, *duration));
    faults.push_back(std::move(*f));
  }
  return sim::ScheduleFuelFaults(std::move(faults), point, kFaultOption);
}

// --no-filter and --oversample, which every experiment's recording takes (after any other
// setting of the filter's corner).
void ApplyRecordingArgs(const DynoArgs& args, sim::RecordingOptions* r) {
  if (args.no_filter) r->filter_hz = 0;
  if (args.oversample) r->oversample = *args.oversample;
}

// The options given, as the command line that regenerates the record writes them (the experiment
// before them, the seed and --out after).
std::string GivenOptions(const DynoArgs& args) {
  std::string line;
  if (args.point) line += fmt::format(" --point '{}'", *args.point);
  if (args.path) line += fmt::format(" --path '{}'", *args.path);
  if (args.hold) line += fmt::format(" --hold {}", *args.hold);
  if (args.ramp) line += fmt::format(" --ramp {}", *args.ramp);
  if (args.duration) line += fmt::format(" --duration {}", *args.duration);
  if (args.order) line += fmt::format(" --order {}", *args.order);
  if (args.bit_period) line += fmt::format(" --bit-period {}", *args.bit_period);
  if (args.hold_speed) line += " --hold-speed";
  if (args.sample_time) line += fmt::format(" --sample-time {}", *args.sample_time);
  if (args.throttle_amplitude)
    line += fmt::format(" --throttle-amplitude {}", *args.throttle_amplitude);
  if (args.no_filter) line += " --no-filter";
  if (args.oversample) line += fmt::format(" --oversample {}", *args.oversample);
  if (args.lambda_sensor) line += " --lambda-sensor " + *args.lambda_sensor;
  if (args.constant_load) line += " --constant-load";
  return line;
}

std::string Regenerate(const DynoArgs& args) {
  std::string line = fmt::format("regenerate: greybench-cli dyno fuel{} --seed {} --live --speed 0",
                                 GivenOptions(args), args.seed);
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

// The longest --live run with a --duration, in samples (a count a double holds exactly); without
// one the run has no end.
constexpr double kMaxLiveSamples = 9007199254740992.0;  // 2^53
// The slowest pace: a row every 12.5e6 s (145 days); a slower one would overflow the clock's
// nanoseconds.
constexpr double kMinSpeed = 1e-6;

int StreamFuel(const DynoArgs& args, const sim::FuelExperiment& e) {
  const double ts = e.recording.sample_time;
  const double speed = args.speed.value_or(1.0);
  if (!(speed == 0 || (speed >= kMinSpeed && std::isfinite(speed))))
    return Fail(InputError(fmt::format(
        "--speed {}: expected a factor of real time of at least {} (or 0: as fast as possible)",
        speed, kMinSpeed)));
  if (args.duration && !(*args.duration > 0 && *args.duration / ts <= kMaxLiveSamples))
    return Fail(InputError(fmt::format(
        "--duration {}: expected seconds > 0 giving at most {:.3g} samples (leave --duration out "
        "to run without end)",
        *args.duration, kMaxLiveSamples)));
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

  const auto n_samples =
      args.duration ? static_cast<std::int64_t>(std::ceil(*args.duration / ts - 1e-9)) : -1;
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
    // Nothing that is not a number leaves: the run stops before such a row.
    for (const auto& [name, v] : {std::pair{"mfi", s.mfi}, std::pair{"ilambda", s.ilambda}}) {
      if (std::isfinite(v)) continue;
      const int status = finish(true, false);
      if (status != 0) return status;
      return Fail(NumericalError(fmt::format(
          "--live: the simulated row at t = {} s is not finite ({} is {}); the run stops before "
          "it",
          s.t, name, v)));
    }
    row.clear();
    fmt::format_to(std::back_inserter(row), "{},{},{}", s.t, s.mfi, s.ilambda);
    if (args.truth)
      fmt::format_to(std::back_inserter(row), ",{},{},{},{}", truth.tau_ff, truth.X, truth.delay_s,
                     truth.Kb);
    row += '\n';
    if (speed > 0)
      std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                std::chrono::duration<double>(s.t / speed)));
    if (!Put(out, row, &reader_gone)) return finish(false, reader_gone);
  }
  return finish(true, false);
}

// ---- the recorded experiments ------------------------------------------------------------------

// The options each experiment takes; one given to an experiment that does not take it is refused,
// as are --point beside --path and --hold or --ramp without --path.
Status CheckOptionsTaken(const DynoArgs& a) {
  if (a.live && a.experiment != "fuel")
    return InputError(fmt::format("--live streams the fuel experiment, not {}", a.experiment));
  struct Use {
    const char* option;
    bool given;
    std::vector<std::string_view> experiments;
  };
  const Use uses[] = {
      {"--point", a.point.has_value(), {"fuel", "engine"}},
      {"--path", a.path.has_value(), {"engine"}},
      {"--hold", a.hold.has_value(), {"engine"}},
      {"--ramp", a.ramp.has_value(), {"engine"}},
      {"--sample-time", a.sample_time.has_value(), {"engine"}},
      {"--hold-speed", a.hold_speed, {"engine"}},
      {"--throttle-amplitude", a.throttle_amplitude.has_value(), {"engine"}},
      {"--order", a.order.has_value(), {"fuel", "crankshaft", "engine"}},
      {"--bit-period", a.bit_period.has_value(), {"fuel", "crankshaft", "engine"}},
      {"--lambda-sensor", a.lambda_sensor.has_value(), {"engine"}},
      {"--constant-load", a.constant_load, {"crankshaft"}},
  };
  for (const Use& u : uses) {
    if (!u.given ||
        std::find(u.experiments.begin(), u.experiments.end(), a.experiment) != u.experiments.end())
      continue;
    std::string list;  // "fuel, crankshaft and engine"
    for (std::size_t i = 0; i < u.experiments.size(); ++i) {
      if (i > 0) list += i + 1 == u.experiments.size() ? " and " : ", ";
      list += u.experiments[i];
    }
    return InputError(fmt::format("{}: only the {} experiment{} {} it, not {}", u.option, list,
                                  u.experiments.size() > 1 ? "s" : "",
                                  u.experiments.size() > 1 ? "take" : "takes", a.experiment));
  }
  if (a.point && a.path)
    return InputError(
        "--point and --path: give one (--point for the experiment at one operating point, --path "
        "for a sweep through several)");
  if ((a.hold || a.ramp) && !a.path)
    return InputError(
        fmt::format("{}: only a sweep (--path) takes it", a.hold ? "--hold" : "--ramp"));
  return Ok{};
}

// The record's size and the simulated world's step against the limits of core/sim/dyno.h (and
// engine.h), in the options' words, before anything runs. `duration_from` says where the duration
// came from ("--duration 100", "the default duration").
Status CheckRecording(const DynoArgs& a, const sim::RecordingOptions& r, double duration,
                      const std::string& duration_from) {
  const double ts = r.sample_time;
  const int k = r.oversample;
  if (ts / k < sim::kMinFineStep)
    return InputError(fmt::format(
        "--oversample {} at a sample time of {} s: the simulated world's step would be {:.3g} s, "
        "below {} s (at this sample time --oversample at most {:.0f})",
        k, ts, ts / k, sim::kMinFineStep, std::floor(ts / sim::kMinFineStep + 1e-9)));
  if (a.experiment == "engine" && ts / k > sim::kMaxEngineStep)
    return InputError(fmt::format(
        "{}{}: the simulated engine's step would be {:.3g} s, longer than {} s (its Euler-Maruyama "
        "scheme is wrong beyond it: the manifold's time constant is 14 ms at 10 000 rpm); give "
        "--oversample {:.0f} or more{}",
        a.sample_time ? fmt::format("--sample-time {}", ts)
                      : fmt::format("a sample time of {} s", ts),
        a.oversample ? fmt::format(" with --oversample {}", k)
                     : fmt::format(" with oversample {}", k),
        ts / k, sim::kMaxEngineStep, std::ceil(ts / sim::kMaxEngineStep - 1e-9),
        a.sample_time ? " or a shorter --sample-time" : ""));
  const double samples = std::ceil(duration / ts - 1e-9);
  if (samples < 1)
    return InputError(fmt::format("{} gives no sample (a sample every {} s)", duration_from, ts));
  if (samples > sim::kMaxSamples)
    return InputError(fmt::format(
        "{} at a sample time of {} s is {:.3g} samples; at most {:.3g} are recorded (a duration "
        "of at most {:.6g} s)",
        duration_from, ts, samples, sim::kMaxSamples, sim::kMaxSamples * ts));
  if (samples * k > sim::kMaxFineSteps)
    return InputError(fmt::format(
        "{} at a sample time of {} s and --oversample {} is {:.3g} steps of the simulated world; "
        "at most {:.3g} are taken (at this --oversample a duration of at most {:.6g} s; at this "
        "duration --oversample at most {:.0f})",
        duration_from, ts, k, samples * k, sim::kMaxFineSteps, sim::kMaxFineSteps / k * ts,
        std::max(1.0, std::floor(sim::kMaxFineSteps / samples))));
  return Ok{};
}

// A PRBS's bit period against the sample time (bits shorter than a sample would be lost).
Status CheckBitPeriod(double bit_period, double ts) {
  if (bit_period >= ts * (1 - 1e-9)) return Ok{};
  return InputError(fmt::format(
      "--bit-period {}: shorter than the sample time {} s (bits would be lost between samples)",
      bit_period, ts));
}

std::string DurationFrom(const DynoArgs& a, double duration) {
  return a.duration ? fmt::format("--duration {}", duration)
                    : fmt::format("the default duration {} s", duration);
}

// The sweep's points from --path: names separated by commas, or n=..,alpha=.. points separated by
// semicolons; two or more.
Result<std::vector<sim::EnginePoint>> ParsePath(const std::string& path) {
  const char sep =
      path.find(';') != std::string::npos || path.find('=') != std::string::npos ? ';' : ',';
  std::vector<sim::EnginePoint> points;
  std::size_t start = 0;
  while (start <= path.size()) {
    const std::size_t end = std::min(path.find(sep, start), path.size());
    auto point = sim::ParseEnginePoint(path.substr(start, end - start));
    if (!point) return InputError("--path: " + point.error().message);
    points.push_back(*point);
    start = end + 1;
  }
  if (points.size() < 2)
    return InputError(
        fmt::format("--path '{}': a sweep needs two points or more (for one, use --point)", path));
  return points;
}

Result<sim::Record> RunEngine(const DynoArgs& args) {
  sim::EngineExperiment e;
  std::string duration_from;
  if (!args.path) {
    auto point = sim::ParseEnginePoint(args.point.value_or("f1"));
    if (!point) return InputError("--point: " + point.error().message);
    e.path = {*point};
  } else {
    auto points = ParsePath(*args.path);
    if (!points) return points.error();
    e.path = std::move(*points);
    e.hold_s = args.hold.value_or(e.hold_s);
    e.ramp_s = args.ramp.value_or(e.ramp_s);
    const auto n = static_cast<double>(e.path.size());
    e.duration = n * e.hold_s + (n - 1) * e.ramp_s;
    duration_from = fmt::format("the sweep's {} points at {} s each and {} s between ({} s)",
                                e.path.size(), e.hold_s, e.ramp_s, e.duration);
  }
  if (args.duration || duration_from.empty()) {
    e.duration = args.duration.value_or(e.duration);
    duration_from = DurationFrom(args, e.duration);
  }
  e.throttle_amplitude = args.throttle_amplitude.value_or(e.throttle_amplitude);
  e.hold_speed = args.hold_speed;
  if (args.sample_time) {
    e.recording.sample_time = *args.sample_time;
    e.recording.filter_hz = 0.25 / *args.sample_time;
  }
  e.fuel_order = args.order.value_or(e.fuel_order);
  e.fuel_bit = args.bit_period.value_or(e.fuel_bit);
  e.seed = args.seed;
  ApplyRecordingArgs(args, &e.recording);
  if (args.lambda_sensor == "pade") e.sensor_delay = sim::EngineExperiment::SensorDelay::kPade;
  if (auto st = CheckRecording(args, e.recording, e.duration, duration_from); !st)
    return st.error();
  if (args.bit_period)
    if (auto st = CheckBitPeriod(e.fuel_bit, e.recording.sample_time); !st) return st.error();
  if (!args.bit_period && e.fuel_bit < e.recording.sample_time)
    return InputError(fmt::format(
        "--sample-time {}: longer than the fuel PRBS's bit period {} s (give a --bit-period of "
        "at least the sample time)",
        e.recording.sample_time, e.fuel_bit));
  return sim::RunEngineExperiment(e);
}

}  // namespace

int RunDyno(const DynoArgs& args) {
  if (!args.live && args.out.empty())
    return Fail(InputError("dyno: --out is required (or --live to stream the CSV to stdout)"));
  if (auto st = CheckOptionsTaken(args); !st) return Fail(st.error());
  auto check_size = [&](const sim::RecordingOptions& r, double duration) {
    return CheckRecording(args, r, duration, DurationFrom(args, duration));
  };
  Result<sim::Record> record = InputError("unknown experiment");
  if (args.experiment == "fuel") {
    auto point = sim::FindFuelPoint(args.point.value_or("f1"));
    if (!point) return Fail(InputError("--point: " + point.error().message));
    sim::FuelExperiment e;
    e.point = *point;
    e.duration = args.duration.value_or(e.duration);
    e.prbs_order = args.order.value_or(e.prbs_order);
    e.bit_period = args.bit_period.value_or(e.bit_period);
    e.seed = args.seed;
    ApplyRecordingArgs(args, &e.recording);
    if (auto st = CheckBitPeriod(e.bit_period, e.recording.sample_time); !st)
      return Fail(st.error());
    if (args.live) return StreamFuel(args, e);
    if (auto st = check_size(e.recording, e.duration); !st) return Fail(st.error());
    record = sim::RunFuelExperiment(e);
  } else if (args.experiment == "crankshaft") {
    sim::CrankshaftExperiment e;
    e.duration = args.duration.value_or(e.duration);
    e.prbs_order = args.order.value_or(e.prbs_order);
    e.bit_period = args.bit_period.value_or(e.bit_period);
    e.seed = args.seed;
    e.perturb_load = !args.constant_load;
    ApplyRecordingArgs(args, &e.recording);
    if (auto st = CheckBitPeriod(e.bit_period, e.recording.sample_time); !st)
      return Fail(st.error());
    if (auto st = check_size(e.recording, e.duration); !st) return Fail(st.error());
    record = sim::RunCrankshaftExperiment(e);
  } else if (args.experiment == "engine") {
    record = RunEngine(args);
  } else {
    sim::SquareWaveTest e;
    e.duration = args.duration.value_or(e.duration);
    e.seed = args.seed;
    ApplyRecordingArgs(args, &e.recording);
    if (auto st = check_size(e.recording, e.duration); !st) return Fail(st.error());
    record = sim::RunSquareWaveTest(e);
  }
  if (!record) return Fail(record.error());
  std::vector<data::CsvColumn> cols;
  for (std::size_t i = 0; i < record->names.size(); ++i)
    cols.push_back({record->names[i], record->columns[i]});
  std::vector<std::string> comments = record->comments;
  comments.push_back(fmt::format("regenerate: greybench-cli dyno {}{} --seed {} --out FILE",
                                 args.experiment, GivenOptions(args), args.seed));
  if (auto st = data::WriteCsvFile(args.out, cols, comments); !st) return Fail(st.error());
  return 0;
}

}  // namespace gb::cli
