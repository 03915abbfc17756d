// greybench-cli monitor: the condition monitor (core/online/monitor.h) over a growing CSV file or
// standard input.
#include "core/online/monitor.h"

#include <fmt/format.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <thread>

#include "app/cli/cli.h"
#include "core/online/follow.h"

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

}  // namespace

int RunMonitor(const MonitorArgs& args) {
  const bool from_stdin = args.source == "-";
  if (from_stdin == !args.follow.empty())
    return Fail(InputError("monitor: give either --follow FILE or - (standard input), not both"));
  if (!args.source.empty() && !from_stdin)
    return Fail(InputError(fmt::format(
        "monitor: '{}' is not a source: use --follow {} to follow a file, or - for standard input",
        args.source, args.source)));
  if (args.every < 1) return Fail(InputError("monitor: --every must be at least 1"));
  if (!(args.idle >= 0)) return Fail(InputError("monitor: --idle must be 0 or more seconds"));
  auto spec = LoadModelWithOverrides(args.model, args.sets);
  if (!spec) return Fail(spec.error());
  auto reference = online::LoadReference(args.reference, *spec);
  if (!reference) return Fail(reference.error());
  online::MonitorOptions options;
  options.recursive.forgetting = args.forgetting;
  options.recursive.track = args.track;
  options.parameter_change = args.change;
  options.false_alarms_per_hour = args.false_alarms;
  auto monitor = online::Monitor::Create(*spec, *reference, options);
  if (!monitor) return Fail(monitor.error());

  std::FILE* out = stdout;
  if (!args.out.empty() && args.out != "-") {
    out = std::fopen(args.out.c_str(), "w");
    if (!out)
      return Fail(
          InputError(fmt::format("cannot write the log {}: {}", args.out, std::strerror(errno))));
  }
  std::signal(SIGPIPE, SIG_IGN);  // a reader that goes away ends the run (EPIPE)
  Log log(out);
  const std::string source = from_stdin ? "<stdin>" : args.follow;
  online::CsvRowReader reader(source, spec->inputs, spec->outputs);
  std::optional<online::FileFollower> follower;
  if (!from_stdin) {
    auto f = online::FileFollower::Open(args.follow);
    if (!f) return Fail(f.error());
    follower.emplace(std::move(*f));
  }

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
    for (const online::Sample& s : reader.TakeSamples()) {
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
                     monitor->estimator().Method().c_str(), list.empty() ? "nothing" : list.c_str());
        for (std::size_t a = 0; a < names.size(); ++a) {
          if (monitor->parameter_block()[a] == 0) continue;
          const double change = monitor->parameter_change()[a];
          const double ref = monitor->reference_values()[a];
          std::fprintf(stderr,
                       "greybench-cli: monitor: %s: score test for a change of %.3g (%.3g %%), "
                       "blocks of %d rows, h = %.3f\n",
                       names[a].c_str(), change, 100.0 * change / std::abs(ref),
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

  bool running = true;
  while (running) {
    Result<std::string> bytes = from_stdin ? online::ReadSome(0) : follower->Poll();
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
      if (args.idle > 0 && std::chrono::steady_clock::now() - idle_since >
                               std::chrono::duration<double>(args.idle)) {
        reader.Finish();
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
