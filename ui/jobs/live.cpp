// The Live view's work (live.h).
//
// Sections
//   1. Names, memory
//   2. LiveSeries
//   3. LiveFeed
//   4. LiveSession: the source and the monitor
//   5. RunLive (paced by the clock) and RunLiveUntil (no clock)
#include "ui/jobs/live.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <map>
#include <thread>
#include <utility>

#include <fmt/format.h>

#include "core/data/follow.h"
#include "core/model/linear_model.h"
#include "core/online/monitor.h"
#include "core/project/result_file.h"
#include "core/sim/dyno.h"

namespace gb::ui {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Messages about skipped rows of a followed file: the first few, then only the count.
constexpr int kMaxSkipNotes = 10;

template <class T>
void EraseFront(std::vector<T>* v, std::size_t n) {
  v->erase(v->begin(), v->begin() + static_cast<std::ptrdiff_t>(std::min(n, v->size())));
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 1. Names, memory

const LiveSpeedInfo& Info(LiveSpeed speed) {
  for (const LiveSpeedInfo& info : kLiveSpeeds) {
    if (info.speed == speed) return info;
  }
  return kLiveSpeeds[0];
}

const LiveFaultInfo& Info(sim::FuelFault::Kind kind) {
  for (const LiveFaultInfo& info : kLiveFaults) {
    if (info.kind == kind) return info;
  }
  return kLiveFaults[0];
}

double MemoryRows(double forgetting) {
  return forgetting < 1.0 ? 1.0 / (1.0 - forgetting) : std::numeric_limits<double>::infinity();
}

// ---------------------------------------------------------------------------------------------
// 2. LiveSeries

void LiveSeries::Append(const LivePoint& p) {
  const std::size_t n_signals = p.u.size() + p.y.size();
  if (signals.size() != n_signals) signals.resize(n_signals);
  if (parameters.size() != p.theta.size()) parameters.resize(p.theta.size());
  if (cusum.size() != p.cusum.size()) cusum.resize(p.cusum.size());
  t.push_back(p.t);
  for (std::size_t i = 0; i < p.u.size(); ++i) signals[i].push_back(p.u[i]);
  for (std::size_t i = 0; i < p.y.size(); ++i) signals[p.u.size() + i].push_back(p.y[i]);
  for (std::size_t k = 0; k < p.theta.size(); ++k) {
    Parameter& q = parameters[k];
    const double sd = k < p.sd.size() ? p.sd[k] : kNaN;
    q.estimate.push_back(p.theta[k]);
    q.lower.push_back(p.theta[k] - 2.0 * sd);
    q.upper.push_back(p.theta[k] + 2.0 * sd);
    q.truth.push_back(k < p.truth.size() ? p.truth[k] : kNaN);
  }
  for (std::size_t i = 0; i < p.cusum.size(); ++i) cusum[i].push_back(p.cusum[i]);
  for (const LiveAlarm& a : p.alarms) {
    // An episode under way is one of the last few (one per test at most).
    auto same = std::find_if(alarms.rbegin(), alarms.rend(),
                             [&](const LiveAlarm& e) { return e.episode == a.episode; });
    if (same == alarms.rend()) {
      alarms.push_back(a);
      continue;
    }
    same->last_t = a.t;
    same->count += a.count;
    same->message = a.message;
  }
  if (alarms.size() > kLiveAlarms) EraseFront(&alarms, alarms.size() - kLiveAlarms);
  warming_up = p.warming_up;
}

void LiveSeries::Trim(std::size_t n) {
  if (t.size() <= n) return;
  const std::size_t drop = t.size() - n;
  EraseFront(&t, drop);
  for (auto& s : signals) EraseFront(&s, drop);
  for (Parameter& q : parameters) {
    EraseFront(&q.estimate, drop);
    EraseFront(&q.lower, drop);
    EraseFront(&q.upper, drop);
    EraseFront(&q.truth, drop);
  }
  for (auto& c : cusum) EraseFront(&c, drop);
}

void LiveSeries::Clear() { *this = LiveSeries{}; }

// ---------------------------------------------------------------------------------------------
// 3. LiveFeed

void LiveFeed::Push(std::vector<LivePoint>* points, const LiveStatus* status) {
  if (points->empty() && !status) return;
  const std::lock_guard<std::mutex> lock(mutex_);
  if (status) status_ = *status;
  for (LivePoint& p : *points) ring_.push_back(std::move(p));
  pushed_ += static_cast<long long>(points->size());
  while (ring_.size() > capacity_) ring_.pop_front();
  points->clear();
}

void LiveFeed::SetSetup(LiveSetup setup) {
  const std::lock_guard<std::mutex> lock(mutex_);
  setup_ = std::move(setup);
}

void LiveFeed::SetStatus(const LiveStatus& status) {
  const std::lock_guard<std::mutex> lock(mutex_);
  status_ = status;
}

void LiveFeed::Note(bool error, std::string text) {
  const std::lock_guard<std::mutex> lock(mutex_);
  notes_.push_back({error, std::move(text)});
}

std::vector<LiveCommand> LiveFeed::TakeCommands() {
  const std::lock_guard<std::mutex> lock(mutex_);
  return std::exchange(commands_, {});
}

void LiveFeed::Send(const LiveCommand& command) {
  const std::lock_guard<std::mutex> lock(mutex_);
  commands_.push_back(command);
}

void LiveFeed::AppendTo(LiveSeries* series, LiveStatus* status) const {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (status) *status = status_;
    const long long first = pushed_ - static_cast<long long>(ring_.size());
    for (long long i = std::max(series->taken, first); i < pushed_; ++i)
      series->Append(ring_[static_cast<std::size_t>(i - first)]);
    series->taken = pushed_;
  }
  // Trimmed in steps of an eighth of the capacity: each update is moved about eight times at most.
  if (static_cast<std::size_t>(series->size()) > capacity_ + capacity_ / 8) series->Trim(capacity_);
}

std::optional<LiveSetup> LiveFeed::setup() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return setup_;
}

std::vector<LiveNote> LiveFeed::TakeNotes() {
  const std::lock_guard<std::mutex> lock(mutex_);
  return std::exchange(notes_, {});
}

// ---------------------------------------------------------------------------------------------
// 4. LiveSession

namespace {

// The dyno's true value of a model parameter, by the fuel film's names (NaN: not the dyno's).
double TrueValue(const std::string& name, const sim::FuelTruth& truth,
                 const sim::FuelOperatingPoint& point) {
  if (name == "tau_fv") return truth.tau_fv;
  if (name == "tau_ff") return truth.tau_ff;
  if (name == "X") return truth.X;
  if (name == "Kb") return truth.Kb;
  if (name == "s11") return point.s11;  // the noise is never faulted
  if (name == "s12") return point.s12;
  if (name == "s2") return point.s2;
  return kNaN;
}

std::string Join(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out.empty() ? "none" : out;
}

std::string How(double ramp_s) {
  return ramp_s > 0 ? fmt::format("linearly over {:g} s", ramp_s) : std::string("as a step");
}

LiveFaultMark FaultMark(const sim::FuelFault& f, bool clear, double t) {
  LiveFaultMark m;
  m.t = t;
  if (clear) {
    m.tag = "clear";
    m.description = "every parameter back to nominal, " + How(f.ramp_s);
  } else {
    m.tag = fmt::format("{}\xC3\x97{:g}", sim::FaultName(f.kind), f.factor);
    m.description =
        fmt::format("{} \xC3\x97 {:g}, {}", sim::FaultName(f.kind), f.factor, How(f.ramp_s));
  }
  return m;
}

}  // namespace

struct LiveSession::State {
  LiveSetup setup;
  std::optional<online::Monitor> monitor;
  std::vector<std::string> tracked;

  // The dyno.
  std::optional<sim::LiveFuelDyno> dyno;
  sim::FuelOperatingPoint point;
  std::vector<sim::TimedFuelFault> schedule;
  std::size_t next_fault = 0;
  std::vector<LiveFaultMark> faults;  // as taken

  // A followed file.
  std::optional<data::FileFollower> follower;
  std::optional<data::CsvRowReader> reader;
  std::deque<data::Sample> pending;  // parsed, not yet fed

  // Rows fed whose update has not come yet (the monitor lags by the largest output delay).
  struct Row {
    long long index = 0;
    data::Sample sample;
    std::vector<double> truth;
  };
  std::deque<Row> rows;
  long long rows_fed = 0, updates = 0, skipped = 0, alarms = 0, episodes = 0;
  // The episode of each test's latest alarm (LiveAlarm).
  struct Episode {
    long long number = 0;
    long long last_index = 0;
  };
  std::map<std::string, Episode> episodes_of;
  long long episode_rows = kEpisodeRows;
  double t_last = kNaN, t_first = kNaN;
  double sample_time = kNaN;

  Status Feed(data::Sample sample, std::vector<double> truth, std::vector<LivePoint>* out);
};

Status LiveSession::State::Feed(data::Sample sample, std::vector<double> truth,
                                std::vector<LivePoint>* out) {
  if (std::isfinite(t_last) && !(sample.t > t_last)) {
    // A file started again (truncated or replaced): its times run again from its start.
    ++skipped;
    return Ok{};
  }
  if (rows_fed == 0) t_first = sample.t;
  if (rows_fed == 1 && dyno == std::nullopt) sample_time = sample.t - t_first;
  t_last = sample.t;
  rows.push_back({rows_fed++, sample, std::move(truth)});
  Result<std::vector<online::MonitorUpdate>> ups = monitor->Push(rows.back().sample);
  if (!ups) return ups.error();
  for (online::MonitorUpdate& u : *ups) {
    while (!rows.empty() && rows.front().index < u.estimate.index) rows.pop_front();
    if (rows.empty() || rows.front().index != u.estimate.index) continue;  // cannot happen
    const Row& row = rows.front();
    LivePoint p;
    p.t = row.sample.t;
    p.u = row.sample.u;
    p.y = row.sample.y;
    p.warming_up = u.estimate.warming_up;
    p.theta = std::move(u.estimate.theta);
    p.sd = std::move(u.estimate.sd);
    p.truth = row.truth;
    p.cusum = std::move(u.cusum);
    for (const online::MonitorAlarm& a : u.alarms) {
      ++alarms;
      Episode& e = episodes_of[a.what];
      if (e.number == 0 || u.estimate.index - e.last_index > episode_rows) e.number = ++episodes;
      e.last_index = u.estimate.index;
      LiveAlarm alarm;
      alarm.episode = static_cast<int>(e.number);
      alarm.t = alarm.last_t = p.t;
      alarm.parameter = a.kind == online::MonitorAlarm::Kind::kParameter;
      alarm.what = a.what;
      alarm.message = a.message;
      p.alarms.push_back(std::move(alarm));
    }
    ++updates;
    out->push_back(std::move(p));
  }
  return Ok{};
}

LiveSession::LiveSession(std::unique_ptr<State> s) : s_(std::move(s)) {}
LiveSession::LiveSession(LiveSession&&) noexcept = default;
LiveSession& LiveSession::operator=(LiveSession&&) noexcept = default;
LiveSession::~LiveSession() = default;

Result<LiveSession> LiveSession::Create(const LiveInput& input) {
  auto s = std::make_unique<State>();
  const model::ModelSpec& spec = input.spec;
  online::Reference reference;
  if (input.reference) {
    reference = *input.reference;
  } else if (!input.reference_file.empty()) {
    Result<online::Reference> read = project::LoadReference(input.reference_file, spec);
    if (!read) return read.error();
    reference = std::move(read).value();
  } else {
    return InputError("there is no reference: run an estimate first, or open a result file");
  }

  online::MonitorOptions options;
  options.recursive.forgetting = input.settings.forgetting;
  options.false_alarms_per_hour = input.settings.false_alarms_per_hour;
  options.recursive.track = input.settings.track;
  options.parameter_change = input.settings.parameter_change;
  std::string why;
  if (!options.IsValid(&why)) return InputError(why);
  Result<online::Monitor> monitor = online::Monitor::Create(spec, reference, options);
  if (!monitor) return monitor.error();
  s->monitor.emplace(std::move(monitor).value());
  s->episode_rows = static_cast<long long>(
      std::min(MemoryRows(input.settings.forgetting), static_cast<double>(kEpisodeRows)));
  s->tracked = s->monitor->estimator().tracked_names();

  LiveSetup& setup = s->setup;
  setup.reference = input.reference_text;
  setup.inputs = spec.inputs;
  setup.outputs = spec.outputs;
  setup.parameters = s->tracked;
  for (const std::string& name : s->tracked)
    setup.units.push_back(
        spec.parameters[static_cast<std::size_t>(spec.ParameterIndex(name))].unit);
  setup.reference_value = s->monitor->reference_values();
  setup.reference_sd = s->monitor->reference_sd();

  if (input.settings.source == LiveSourceKind::kDyno) {
    if (spec.inputs != std::vector<std::string>{"mfi"} ||
        spec.outputs != std::vector<std::string>{"ilambda"}) {
      return InputError(fmt::format(
          "the virtual dyno records the input mfi and the output ilambda (the fuel film); the "
          "model's inputs are {} and its outputs {}: follow a CSV file instead",
          Join(spec.inputs), Join(spec.outputs)));
    }
    Result<sim::FuelOperatingPoint> point = sim::FindFuelPoint(input.settings.point);
    if (!point) return point.error();
    s->point = *point;
    sim::FuelExperiment e;
    e.point = *point;
    e.seed = input.settings.seed;
    Result<sim::LiveFuelDyno> dyno = sim::LiveFuelDyno::Create(e);
    if (!dyno) return dyno.error();
    s->dyno.emplace(std::move(dyno).value());
    s->schedule = input.faults;
    s->sample_time = e.recording.sample_time;
    setup.sample_time = e.recording.sample_time;
    setup.dyno = true;
    setup.truth = true;
    setup.source = fmt::format("virtual dyno, fuel film at {} (seed {})", point->name, e.seed);
  } else {
    if (input.settings.csv_path.empty()) return InputError("choose the CSV file to follow");
    Result<data::FileFollower> follower = data::FileFollower::Open(input.settings.csv_path);
    if (!follower) return follower.error();
    s->follower.emplace(std::move(follower).value());
    s->reader.emplace(input.settings.csv_path, spec.inputs, spec.outputs);
    setup.source = input.settings.csv_path;
  }
  return LiveSession(std::move(s));
}

const LiveSetup& LiveSession::setup() const { return s_->setup; }

double LiveSession::next_time() const {
  if (s_->dyno) return s_->dyno->Time();
  return s_->pending.empty() ? kNaN : s_->pending.front().t;
}

Result<int> LiveSession::Step(int max_rows, std::vector<LivePoint>* out,
                              std::vector<LiveNote>* notes) {
  State& s = *s_;
  int fed = 0;
  if (s.dyno) {
    std::vector<double> truth(s.tracked.size());
    for (; fed < max_rows; ++fed) {
      const std::size_t before = s.next_fault;
      if (Status st = sim::ApplyDueFuelFaults(s.schedule, &s.next_fault, &*s.dyno, "fault"); !st)
        return st.error();
      for (std::size_t f = before; f < s.next_fault; ++f)
        s.faults.push_back(FaultMark(s.schedule[f].fault, s.schedule[f].clear, s.dyno->Time()));
      const sim::FuelTruth now = s.dyno->Truth();
      for (std::size_t k = 0; k < s.tracked.size(); ++k)
        truth[k] = TrueValue(s.tracked[k], now, s.point);
      const sim::FuelSample row = s.dyno->Next();
      data::Sample sample;
      sample.t = row.t;
      sample.u = {row.mfi};
      sample.y = {row.ilambda};
      if (Status st = s.Feed(std::move(sample), truth, out); !st) return st.error();
    }
    return fed;
  }

  if (s.pending.empty()) {
    Result<std::string> bytes = s.follower->Poll();
    if (!bytes) return bytes.error();
    if (std::optional<std::string> note = s.follower->TakeNote()) {
      notes->push_back({false, *note});
      s.reader->Restart();
    }
    s.reader->Feed(*bytes);
    for (data::Sample& sample : s.reader->TakeSamples()) s.pending.push_back(std::move(sample));
    for (const Error& e : s.reader->TakeProblems()) {
      if (++s.skipped <= kMaxSkipNotes) notes->push_back({false, e.ToString()});
      if (s.skipped == kMaxSkipNotes)
        notes->push_back({false, "further rows skipped are only counted (the status line)"});
    }
    if (s.reader->fatal()) return *s.reader->fatal();
  }
  const std::vector<double> no_truth(s.tracked.size(), kNaN);
  for (; fed < max_rows && !s.pending.empty(); ++fed) {
    data::Sample sample = std::move(s.pending.front());
    s.pending.pop_front();
    if (Status st = s.Feed(std::move(sample), no_truth, out); !st) return st.error();
  }
  return fed;
}

Status LiveSession::Inject(const sim::FuelFault& fault) {
  if (!s_->dyno) return InputError("faults are injected into the virtual dyno, not into a file");
  const double t = s_->dyno->Time();
  if (Status st = s_->dyno->Inject(fault); !st) return st;
  s_->faults.push_back(FaultMark(fault, false, t));
  return Ok{};
}

Status LiveSession::ClearFaults(double ramp_s) {
  if (!s_->dyno) return InputError("faults are injected into the virtual dyno, not into a file");
  const double t = s_->dyno->Time();
  if (Status st = s_->dyno->ClearFaults(ramp_s); !st) return st;
  sim::FuelFault f;
  f.ramp_s = ramp_s;
  s_->faults.push_back(FaultMark(f, true, t));
  return Ok{};
}

void LiveSession::Acknowledge() { s_->monitor->Acknowledge(); }

void LiveSession::FillStatus(LiveStatus* status) const {
  const State& s = *s_;
  status->t = s.t_last;
  status->rows = s.rows_fed;
  status->updates = s.updates;
  status->skipped = s.skipped;
  status->alarms = s.alarms;
  status->episodes = s.episodes;
  status->sample_time = s.sample_time;
  if (status->design.empty() && s.monitor->design()) status->design = s.monitor->design()->Report();
  const std::vector<int>& blocks = s.monitor->parameter_block();
  status->parameter_change = std::any_of(blocks.begin(), blocks.end(), [](int b) { return b > 0; })
                                 ? s.monitor->options().parameter_change
                                 : 0.0;
  if (s.dyno) status->truth = s.dyno->Truth();
  status->faults = s.faults;
}

// ---------------------------------------------------------------------------------------------
// 5. RunLive and RunLiveUntil

namespace {

using Clock = std::chrono::steady_clock;
// The longest the job works before it looks at the commands and the cancel flag again.
constexpr auto kStepBudget = std::chrono::milliseconds(15);
// Idle wait (paused, or a file with nothing new), and the longest sleep between rows.
constexpr auto kIdleWait = std::chrono::milliseconds(10);
constexpr int kRowsPerStep = 64;
// Behind by this much of the clock, the run gives up catching up (and says it is behind).
constexpr double kMaxLagSeconds = 1.0;
constexpr double kRateWindowSeconds = 0.5;  // the achieved speed is measured over this

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

}  // namespace

LiveRunEnd RunLive(const LiveInput& input, LiveFeed& feed, JobControl& control) {
  try {
    Result<LiveSession> created = LiveSession::Create(input);
    if (!created) return {created.error().ToString()};
    LiveSession& session = *created;
    feed.SetSetup(session.setup());
    const bool dyno = session.setup().dyno;

    LiveStatus status;
    status.running = true;
    status.speed = input.settings.speed;
    bool paused = false;
    Clock::time_point anchor_wall = Clock::now();
    double anchor_t = session.next_time();
    Clock::time_point rate_wall = anchor_wall;
    double rate_t = anchor_t;
    auto reanchor = [&] {
      anchor_wall = rate_wall = Clock::now();
      anchor_t = rate_t = session.next_time();
    };
    std::vector<LivePoint> points;
    std::vector<LiveNote> notes;

    while (!control.cancel) {
      for (const LiveCommand& c : feed.TakeCommands()) {
        switch (c.kind) {
          case LiveCommand::Kind::kPause:
            paused = true;
            break;
          case LiveCommand::Kind::kResume:
            paused = false;
            reanchor();
            break;
          case LiveCommand::Kind::kSpeed:
            status.speed = c.speed;
            reanchor();
            break;
          case LiveCommand::Kind::kInject:
          case LiveCommand::Kind::kClearFaults: {
            const bool clear = c.kind == LiveCommand::Kind::kClearFaults;
            const Status st = clear ? session.ClearFaults(c.fault.ramp_s) : session.Inject(c.fault);
            if (!st) {
              feed.Note(true, std::string(clear ? "The faults were not cleared: "
                                                : "The fault was not injected: ") +
                                  st.error().message);
            } else {
              const LiveFaultMark m = FaultMark(c.fault, clear, session.next_time());
              feed.Note(false, fmt::format("The dyno from {:.2f} s: {}", m.t, m.description));
            }
            break;
          }
          case LiveCommand::Kind::kAcknowledge:
            session.Acknowledge();
            break;
        }
      }

      const Clock::time_point start = Clock::now();
      const double factor = Info(status.speed).factor;
      bool idle = paused;
      if (!paused && dyno) {
        const double ts = session.setup().sample_time;
        // At a finite speed, the rows whose time has come; as fast as possible, rows for the
        // whole budget.
        while (Clock::now() - start < kStepBudget && !control.cancel) {
          int due = kRowsPerStep;
          if (factor > 0) {
            const double now_t = anchor_t + factor * Seconds(Clock::now() - anchor_wall);
            const double ahead = now_t - session.next_time();
            if (ahead < 0) break;
            due = std::min(kRowsPerStep, 1 + static_cast<int>(ahead / ts));
          }
          Result<int> fed = session.Step(due, &points, &notes);
          if (!fed) return {fed.error().ToString()};
        }
        if (factor > 0) {
          const double lag =
              (anchor_t + factor * Seconds(Clock::now() - anchor_wall) - session.next_time()) /
              factor;
          status.behind = lag > kMaxLagSeconds;
          if (status.behind) reanchor();  // run on from here rather than race to catch up
        } else {
          status.behind = false;
        }
      } else if (!paused) {
        Result<int> fed = session.Step(16 * kRowsPerStep, &points, &notes);
        if (!fed) return {fed.error().ToString()};
        idle = *fed == 0;
      }

      const Clock::time_point now = Clock::now();
      if (dyno && Seconds(now - rate_wall) >= kRateWindowSeconds) {
        status.achieved_speed = (session.next_time() - rate_t) / Seconds(now - rate_wall);
        rate_wall = now;
        rate_t = session.next_time();
      }
      if (paused) status.achieved_speed = kNaN;
      status.paused = paused;
      session.FillStatus(&status);
      feed.Push(&points, &status);  // together: a frame never sees one without the other
      for (LiveNote& n : notes) feed.Note(n.error, std::move(n.text));
      notes.clear();

      if (idle) {
        std::this_thread::sleep_for(kIdleWait);
      } else if (dyno && factor > 0) {
        // Until the next row is due, at most the idle wait (commands stay prompt).
        const double wait = (session.next_time() - anchor_t) / factor - Seconds(now - anchor_wall);
        if (wait > 0)
          std::this_thread::sleep_for(std::min<Clock::duration>(
              kIdleWait,
              std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(wait))));
      }
    }
    status.running = false;
    feed.SetStatus(status);
  } catch (const std::exception& e) {  // e.g. out of memory; never into the UI loop
    return {std::string("the live run stopped: ") + e.what()};
  }
  return {};
}

Status RunLiveUntil(const LiveInput& input, double until_s, LiveFeed& feed) {
  Result<LiveSession> session = LiveSession::Create(input);
  if (!session) return session.error();
  feed.SetSetup(session->setup());
  std::vector<LivePoint> points;
  std::vector<LiveNote> notes;
  const bool dyno = input.settings.source == LiveSourceKind::kDyno;
  const double ts = dyno ? session->setup().sample_time : 0.0;
  for (;;) {
    if (!dyno) {
      // Reads on until a row is parsed or the file ends (a file's rows carry their own time).
      Result<int> read = session->Step(0, &points, &notes);
      if (!read) return read.error();
    }
    const double next = session->next_time();
    if (!(next <= until_s + 1e-6 * ts)) break;  // past the time asked for, or the file's end
    Result<int> fed = session->Step(1, &points, &notes);
    if (!fed) return fed.error();
    if (points.size() >= static_cast<std::size_t>(kRowsPerStep)) feed.Push(&points);
  }
  feed.Push(&points);
  for (LiveNote& n : notes) feed.Note(n.error, std::move(n.text));
  LiveStatus status;
  session->FillStatus(&status);
  feed.SetStatus(status);
  return Ok{};
}

}  // namespace gb::ui
