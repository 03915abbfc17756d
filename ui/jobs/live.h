// The Live view's work: on-line identification and condition monitoring of a model
// (core/online/monitor.h), one row at a time, from the virtual dyno (core/sim/live_dyno.h) or a
// CSV file another program is writing (core/data/follow.h).
//
//   LiveSession  the source and the monitor, stepped synchronously: what the job runs, and what
//                greybench-snapshot runs without a job or a clock (RunLiveUntil)
//   LiveFeed     between the job and the UI, every member thread-safe: a bounded ring of the
//                monitor's updates (the last kLivePoints), the commands the UI sends (pause,
//                speed, inject, acknowledge), the job's status and its notes
//   RunLive      the job's work: paces the session by the clock (data time = wall time × speed),
//                applies the commands at its current sample, pushes the updates
//   LiveSeries   the UI's copy of the ring as plot arrays, one column per quantity, bounded too
//
//   auto feed = std::make_shared<LiveFeed>();
//   job.Start([=](JobControl& c) { return RunLive(input, *feed, c); });
//   every frame: feed->AppendTo(&series, &status); feed->TakeNotes(); job.TakeIfReady()
//   a button:    feed->Send({LiveCommand::Kind::kPause});
//
// Stopping: JobControl::cancel ends the run within one step (a few milliseconds).
// No ImGui here: the job runs on its own thread and the tests use these types without a UI.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/model/model.h"
#include "core/online/recursive.h"
#include "core/sim/fault_schedule.h"
#include "core/sim/live_dyno.h"
#include "core/util/result.h"
#include "ui/jobs/job.h"

namespace gb::ui {

// Ten minutes at the dyno's 80 Hz: what the ring and the plot arrays keep.
inline constexpr std::size_t kLivePoints = 48000;
// Alarm episodes kept for the list and the time axes (the latest).
inline constexpr std::size_t kLiveAlarms = 1000;

enum class LiveSourceKind { kDyno, kCsvFile };

// How fast the dyno runs: data seconds per second of the clock (0: as fast as the monitor goes).
enum class LiveSpeed { kRealTime, kTimes10, kTimes100, kFastest };
struct LiveSpeedInfo {
  LiveSpeed speed;
  const char* name;  // "×10"
  double factor;     // 0: as fast as possible
};
inline constexpr std::array<LiveSpeedInfo, 4> kLiveSpeeds = {{
    {LiveSpeed::kRealTime,
     "\xC3\x97"
     "1",
     1.0},
    {LiveSpeed::kTimes10,
     "\xC3\x97"
     "10",
     10.0},
    {LiveSpeed::kTimes100,
     "\xC3\x97"
     "100",
     100.0},
    {LiveSpeed::kFastest, "as fast as possible", 0.0},
}};
const LiveSpeedInfo& Info(LiveSpeed speed);

// The faults the view offers, in its order, with the names it shows.
struct LiveFaultInfo {
  sim::FuelFault::Kind kind;
  const char* name;     // "\xCF\x84_ff", "sensor delay"
  const char* summary;  // for a tooltip
};
inline constexpr std::array<LiveFaultInfo, 4> kLiveFaults = {{
    {sim::FuelFault::Kind::kTauFF, "\xCF\x84_ff",
     "the film's time constant (a clogging injector wets the port more)"},
    {sim::FuelFault::Kind::kX, "X", "the fraction of the fuel that goes into the film"},
    {sim::FuelFault::Kind::kSensorDelay, "sensor delay",
     "\xCE\x94t, the \xCE\xBB sensor's delay (the exhaust's transport time)"},
    {sim::FuelFault::Kind::kSensorGain, "sensor gain", "K_b, the \xCE\xBB sensor's gain"},
}};
const LiveFaultInfo& Info(sim::FuelFault::Kind kind);

// What the Live view lets the user choose.
struct LiveSettings {
  LiveSourceKind source = LiveSourceKind::kDyno;
  std::string point = "f1";  // the dyno's operating point (sim::PaperFuelPoints)
  // The dyno's noise and PRBS. Seed 1 made the bundled records (assets/data/fuel_f*.csv): another
  // gives data the reference has not seen.
  std::uint64_t seed = 2;
  std::string csv_path;                  // kCsvFile: the file to follow
  double forgetting = 0.999;             // λ of the recursive estimator: memory 1/(1-λ) rows
  double false_alarms_per_hour = 0.125;  // all the monitor's tests together
  LiveSpeed speed = LiveSpeed::kRealTime;
  std::vector<std::string> track;  // the parameters to track (empty: all that can be)
  double parameter_change = 0.25;  // the relative change the score tests look for
};

// Everything a run needs, copied when it starts.
struct LiveInput {
  model::ModelSpec spec;
  // The reference: the session's fit, or else read by the run from `reference_file`.
  std::optional<online::Reference> reference;
  std::string reference_file;
  std::string reference_text;  // how the view names it ("this session's estimate")
  LiveSettings settings;
  std::vector<sim::TimedFuelFault> faults;  // the dyno: a schedule (time order), as the CLI's
};

// What a run is, known once it has started: names and the reference, constant over the run.
struct LiveSetup {
  std::string source;     // "virtual dyno at f1, seed 2" or the file's path
  std::string reference;  // LiveInput::reference_text
  std::vector<std::string> inputs, outputs;
  std::vector<std::string> parameters;  // tracked, in the monitor's order
  std::vector<std::string> units;       // of the tracked parameters ("" when none)
  std::vector<double> reference_value;  // of the tracked parameters
  std::vector<double> reference_sd;     // NaN: unknown
  bool truth = false;                   // the source knows the true values (the dyno)
  bool dyno = false;
  double sample_time = std::numeric_limits<double>::quiet_NaN();  // the dyno's T_s
};

// An alarm episode: the alarms of one test (`what`) that follow each other less than the
// estimator's memory apart (at most kEpisodeRows rows). A CUSUM test restarts after its alarm, so
// under a lasting change it alarms again every few samples: one episode, not hundreds of marks.
// In a LivePoint: one alarm (count 1), with the episode it belongs to.
inline constexpr long long kEpisodeRows = 1000;
struct LiveAlarm {
  int episode = 0;         // 1, 2, ... in the run
  double t = 0.0;          // of its first alarm
  double last_t = 0.0;     // of its latest alarm
  int count = 1;           // alarms in it
  bool parameter = false;  // a parameter left its reference interval (else an innovation test)
  std::string what;        // "tau_ff", "ilambda: mean up"
  std::string message;     // the monitor's sentence, of its latest alarm
};

// One update of the monitor, with its row.
struct LivePoint {
  double t = 0.0;
  std::vector<double> u, y;  // the row: inputs, outputs (NaN: missing)
  bool warming_up = false;
  std::vector<double> theta, sd;  // tracked parameters
  std::vector<double> truth;      // per tracked parameter, at t (NaN: unknown)
  std::vector<double> cusum;      // per output: mean up, mean down, variance up (S/h)
  std::vector<LiveAlarm> alarms;  // raised at this update
};

// A change the dyno has taken: a fault (injected or scheduled) or a clear.
struct LiveFaultMark {
  double t = 0.0;           // the sample it acts from
  std::string tag;          // short, for the time axes: "tau_ff\xC3\x97" "1.5", "clear"
  std::string description;  // "tau_ff \xC3\x97 1.5, as a step"
};

// What the run is doing now.
struct LiveStatus {
  bool running = false;  // the session exists and has not ended
  bool paused = false;
  LiveSpeed speed = LiveSpeed::kRealTime;
  double t = std::numeric_limits<double>::quiet_NaN();            // of the last row fed
  double sample_time = std::numeric_limits<double>::quiet_NaN();  // known after two rows
  long long rows = 0, updates = 0, skipped = 0;
  long long alarms = 0, episodes = 0;
  double achieved_speed = std::numeric_limits<double>::quiet_NaN();  // data s per clock s
  bool behind = false;            // the monitor cannot keep up with the speed asked for
  std::string design;             // the CUSUM tests' design (after the second row)
  double parameter_change = 0.0;  // the relative change the parameter tests look for (0: none)
  std::optional<sim::FuelTruth> truth;  // the dyno's values at t
  std::vector<LiveFaultMark> faults;    // the dyno's changes so far, in time order
};

struct LiveCommand {
  enum class Kind { kPause, kResume, kSpeed, kInject, kClearFaults, kAcknowledge };
  Kind kind = Kind::kPause;
  LiveSpeed speed = LiveSpeed::kRealTime;  // kSpeed
  sim::FuelFault fault;                    // kInject; kClearFaults: its ramp_s
};

struct LiveNote {
  bool error = false;  // else information
  std::string text;
};

// The UI's copy of the updates as the plot widget takes them (ascending t, NaN for gaps).
struct LiveSeries {
  struct Parameter {
    std::vector<double> estimate, lower, upper;  // estimate ± 2 SD
    std::vector<double> truth;
  };
  long long taken = 0;  // updates of the feed taken so far (including any it dropped before)
  std::vector<double> t;
  std::vector<std::vector<double>> signals;  // inputs, then outputs
  std::vector<Parameter> parameters;         // LiveSetup::parameters' order
  std::vector<std::vector<double>> cusum;    // 3 per output
  std::vector<LiveAlarm> alarms;             // the last kLiveAlarms episodes, by their start
  bool warming_up = false;                   // the last update's

  void Append(const LivePoint& p);
  // Keeps the last `n` updates (and the alarms from then on); called with slack, so each update
  // is moved O(1) times.
  void Trim(std::size_t n);
  void Clear();
  int size() const { return static_cast<int>(t.size()); }
};

class LiveFeed {
 public:
  explicit LiveFeed(std::size_t capacity = kLivePoints) : capacity_(capacity) {}

  // The job.
  // Moves the points in (the oldest past capacity go) and, with `status`, sets the status in the
  // same step, so that the UI never takes the one without the other.
  void Push(std::vector<LivePoint>* points, const LiveStatus* status = nullptr);
  void SetSetup(LiveSetup setup);
  void SetStatus(const LiveStatus& status);
  void Note(bool error, std::string text);
  std::vector<LiveCommand> TakeCommands();

  // The UI.
  void Send(const LiveCommand& command);
  // Appends the updates `series` has not taken yet (those still in the ring) and trims it to
  // the ring's capacity; with `status`, copies the status that came with them.
  void AppendTo(LiveSeries* series, LiveStatus* status = nullptr) const;
  std::optional<LiveSetup> setup() const;
  std::vector<LiveNote> TakeNotes();

 private:
  mutable std::mutex mutex_;
  std::size_t capacity_;
  std::deque<LivePoint> ring_;
  long long pushed_ = 0;  // updates pushed since the start (ring_ holds the last ones)
  std::optional<LiveSetup> setup_;
  LiveStatus status_;
  std::vector<LiveCommand> commands_;
  std::vector<LiveNote> notes_;
};

// The source and the monitor of one run. Not thread-safe: it belongs to the thread that runs it.
class LiveSession {
 public:
  // Compiles the model (linear or not: monitor.h says which filters run), reads the
  // reference, creates the monitor and opens the source. Errors are sentences for the user.
  static Result<LiveSession> Create(const LiveInput& input);
  LiveSession(LiveSession&&) noexcept;
  LiveSession& operator=(LiveSession&&) noexcept;
  ~LiveSession();

  const LiveSetup& setup() const;
  // Feeds the monitor up to `max_rows` rows: the dyno's next ones (the scheduled faults due
  // before each applied first), or a followed file's rows that have arrived. Appends the updates
  // they complete to `out` and what the user should know (rows skipped, a file replaced) to
  // `notes`. Returns the rows fed (0: a file has nothing new); an error ends the run.
  Result<int> Step(int max_rows, std::vector<LivePoint>* out, std::vector<LiveNote>* notes);
  // The dyno: the time of the next row. A file: that of the next row read but not yet fed (NaN
  // when none is; Step(0) reads without feeding).
  double next_time() const;

  // The dyno, at its next sample (refused with a reason, changing nothing, e.g. X past 1; or for
  // a file: there is nothing to inject into).
  Status Inject(const sim::FuelFault& fault);
  Status ClearFaults(double ramp_s);
  void Acknowledge();
  // Counters, the design, the truth now (LiveStatus without the pacing fields).
  void FillStatus(LiveStatus* status) const;

 private:
  struct State;
  explicit LiveSession(std::unique_ptr<State> s);
  std::unique_ptr<State> s_;
};

// How a run ended.
struct LiveRunEnd {
  std::string error;  // why it stopped ("" when it was stopped by the user)
};

// The job's work: creates the session, publishes its setup, then steps it at the pace of the
// clock × speed until control.cancel, applying the commands as they come. Never throws.
LiveRunEnd RunLive(const LiveInput& input, LiveFeed& feed, JobControl& control);

// The same without a clock or a thread (greybench-snapshot): steps the dyno, or reads the file,
// until the next row is later than `until_s` (or the file ends), pushing everything into `feed`.
Status RunLiveUntil(const LiveInput& input, double until_s, LiveFeed& feed);

// Memory of the estimator, 1/(1-λ) rows (infinite for λ = 1).
double MemoryRows(double forgetting);

}  // namespace gb::ui
