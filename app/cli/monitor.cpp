// greybench-cli monitor: the condition monitor (core/online/monitor.h) over a growing CSV file or
// standard input.
#include "core/online/monitor.h"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <optional>
#include <thread>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/data/follow.h"
#include "core/project/result_file.h"
#include "core/util/json.h"

namespace gb::cli {
namespace {

constexpr auto kPollInterval = std::chrono::milliseconds(10);

class Log {
 public:
  explicit Log(std::FILE* f) : f_(f) {}
  bool Write(const std::string& line) {
    if (std::fputs(line.c_str(), f_) < 0 || std::fputc('\n', f_) == EOF || std::fflush(f_) != 0)
      return false;
    return true;
  }

 private:
  std::FILE* f_;
};

// The numeric options, each with its range: an out-of-range value is an error naming the option,
// never a default or "never" in disguise.
Status CheckOptions(const MonitorArgs& args) {
  const auto bad = [](const char* option, double value, const char* range) {
    return InputError(fmt::format("monitor: {} must be {}, not {:g}", option, range, value));
  };
  if (!(args.forgetting > 0.0 && args.forgetting <= 1.0))
    return bad("--forgetting", args.forgetting, "in (0, 1]");
  if (!(args.false_alarms > 0.0) || !std::isfinite(args.false_alarms))
    return bad("--false-alarms", args.false_alarms, "a positive, finite number per hour");
  if (!(args.change > 0.0) || !std::isfinite(args.change))
    return bad("--change", args.change, "a positive, finite relative change (0.25: 25 %)");
  if (args.every < 1)
    return InputError(fmt::format("monitor: --every must be at least 1, not {}", args.every));
  if (args.idle) {
    if (args.follow.empty())
      return InputError(
          "monitor: --idle is for --follow (standard input ends when its writer closes it)");
    if (!(*args.idle > 0.0) || !std::isfinite(*args.idle))
      return bad("--idle", *args.idle,
                 "a positive, finite number of seconds (leave it out to "
                 "follow the file until interrupted)");
  }
  return Ok{};
}

// The log (--out), opened only once every input has been opened and checked, so that a bad input
// leaves an earlier log as it was: stdout for none or "-", else the file (an error naming it when
// it cannot be written).
Result<std::FILE*> OpenLog(const std::string& path) {
  if (path.empty() || path == "-") return stdout;
  std::FILE* out = std::fopen(path.c_str(), "w");
  if (!out)
    return InputError(fmt::format("cannot write the log {}: {}", path, std::strerror(errno)));
  return out;
}

}  // namespace

int RunMonitor(const MonitorArgs& args) {
  const bool from_stdin = args.source == "-";
  if (from_stdin == !args.follow.empty())
    return Fail(InputError("monitor: give either --follow FILE or - (standard input), not both"));
  if (!args.source.empty() && !from_stdin)
    return Fail(InputError(fmt::format(
        "monitor: '{}' is not a source: use --follow {} to follow a file, or - for standard input",
        args.source, args.source)));
  if (Status s = CheckOptions(args); !s) return Fail(s.error());
  if (int s = GuardOutputs({{args.model, "the model file"},
                            {args.reference, "the --reference file"},
                            {args.follow, "the --follow file"}},
                           {{args.out, "--out"}}))
    return s;
  // The inputs: the model, the reference, the followed file.
  auto spec = LoadModelWithOverrides(args.model, args.sets);
  if (!spec) return Fail(spec.error());
  auto reference = project::LoadReference(args.reference, *spec);
  if (!reference) return Fail(reference.error());
  online::MonitorOptions options;
  options.recursive.forgetting = args.forgetting;
  options.recursive.track = args.track;
  options.parameter_change = args.change;
  options.false_alarms_per_hour = args.false_alarms;
  auto monitor = online::Monitor::Create(*spec, *reference, options);
  if (!monitor) return Fail(monitor.error());
  const std::string source = from_stdin ? "<stdin>" : args.follow;
  data::CsvRowReader reader(source, spec->inputs, spec->outputs);
  std::optional<data::FileFollower> follower;
  if (!from_stdin) {
    auto f = data::FileFollower::Open(args.follow);
    if (!f) return Fail(f.error());
    follower.emplace(std::move(*f));
    // What the file holds already: a header that cannot be bound is found before the log is
    // opened (its rows wait in the reader).
    Result<std::string> bytes = follower->Poll();
    if (!bytes) return Fail(bytes.error());
    if (std::optional<std::string> note = follower->TakeNote()) {
      std::fprintf(stderr, "greybench-cli: warning: %s\n", note->c_str());
      reader.Restart();
    }
    reader.Feed(*bytes);
    if (reader.fatal()) return Fail(*reader.fatal());
  }

  // The output.
  auto opened = OpenLog(args.out);
  if (!opened) return Fail(opened.error());
  std::FILE* out = *opened;
  std::signal(SIGPIPE, SIG_IGN);  // a reader that goes away ends the run (EPIPE)
  Log log(out);

  long rows = 0, updates = 0, skipped = 0;
  bool reported_design = false;
  int status = 0;
  auto idle_since = std::chrono::steady_clock::now();
  // Feeds what the reader has parsed; false when the run must end (status set).
  auto drain = [&]() -> bool {
    for (const Error& e : reader.TakeProblems()) {
      ++skipped;
      std::fprintf(stderr, "greybench-cli: warning: %s\n", e.ToString().c_str());
    }
    for (const data::Sample& s : reader.TakeSamples()) {
      ++rows;
      auto ups = monitor->Push(s);
      if (!ups) {
        status = Fail(ups.error());
        return false;
      }
      if (!reported_design && monitor->design()) {
        reported_design = true;
        std::fprintf(stderr, "greybench-cli: monitor: %s\n", monitor->design()->Report().c_str());
        const std::vector<std::string> names = monitor->estimator().tracked_names();
        std::string list;
        for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
        std::fprintf(stderr, "greybench-cli: monitor: %s; tracking %s\n",
                     monitor->estimator().Method().c_str(),
                     list.empty() ? "nothing" : list.c_str());
        for (std::size_t a = 0; a < names.size(); ++a) {
          if (monitor->parameter_block()[a] == 0) {
            const char* why = !(monitor->reference_sd()[a] > 0.0)
                                  ? "the reference gives it no standard error"
                              : monitor->reference_values()[a] == 0.0
                                  ? "its reference value is 0: a relative change of it is 0"
                                  : "the reference gives no n_obs";
            std::fprintf(stderr, "greybench-cli: warning: monitor: %s: no score test (%s)\n",
                         names[a].c_str(), why);
            continue;
          }
          const double change = monitor->parameter_change()[a];
          const double relative = 100.0 * change / std::abs(monitor->reference_values()[a]);
          const double asked = 100.0 * args.change;
          const std::string lowered =
              relative < asked * (1.0 - 1e-9)
                  ? fmt::format(
                        " (--change asks {:.3g} %: a larger change shows within too few "
                        "rows for a calibrated test, and is found sooner)",
                        asked)
                  : "";
          std::fprintf(stderr,
                       "greybench-cli: monitor: %s: score test for a change of %.3g (%.3g %%)%s, "
                       "blocks of %d rows, h = %.3f\n",
                       names[a].c_str(), change, relative, lowered.c_str(),
                       monitor->parameter_block()[a], monitor->parameter_h()[a]);
        }
      }
      for (const online::MonitorUpdate& u : *ups) {
        ++updates;
        for (const online::MonitorAlarm& a : u.alarms)
          std::fprintf(stderr, "greybench-cli: ALARM: %s\n", a.message.c_str());
        if (u.alarms.empty() && u.estimate.index % args.every != 0) continue;
        if (!log.Write(monitor->ToJson(u).dump())) return false;  // the reader went away
      }
    }
    if (reader.fatal()) {
      status = Fail(*reader.fatal());
      return false;
    }
    return true;
  };

  bool running = drain();
  while (running) {
    Result<std::string> bytes = from_stdin ? data::ReadSome(0) : follower->Poll();
    if (!bytes) {
      status = Fail(bytes.error());
      break;
    }
    if (follower) {
      if (std::optional<std::string> note = follower->TakeNote()) {
        std::fprintf(stderr, "greybench-cli: warning: %s\n", note->c_str());
        reader.Restart();
      }
    }
    if (bytes->empty()) {
      if (from_stdin) {
        reader.Finish();
        running = drain();
        break;
      }
      if (args.idle && std::chrono::steady_clock::now() - idle_since >
                           std::chrono::duration<double>(*args.idle)) {
        // The writer may have stopped mid-line: a line without its end is not a row.
        reader.Finish(data::CsvRowReader::LastLine::kDrop);
        running = drain();
        break;
      }
      std::this_thread::sleep_for(kPollInterval);
      continue;
    }
    idle_since = std::chrono::steady_clock::now();
    reader.Feed(*bytes);
    running = drain();
  }
  std::fprintf(stderr,
               "greybench-cli: monitor: %ld rows, %ld updates, %ld rows skipped, %lld alarms\n",
               rows, updates, skipped, monitor->alarm_count());
  if (out != stdout) std::fclose(out);
  return status;
}

}  // namespace gb::cli
