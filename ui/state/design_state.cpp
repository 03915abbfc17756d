// The experiment-design view's life in AppState: its designs seeded from the project, its
// evaluation recomputed when the request changes, a design tried in a job.
#include <algorithm>
#include <cmath>

#include "core/model/linear_model.h"
#include "ui/state/app_state.h"

namespace gb::ui {

namespace {

// The smallest of 1, 2, 5 times a power of ten that is at least x (x > 0).
double NiceUp(double x) {
  const double decade = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * decade >= x * (1 - 1e-12)) return m * decade;
  return 10 * decade;
}

// The mean and standard deviation of a column's finite cells (nullopt without two of them).
std::optional<std::pair<double, double>> Moments(const std::vector<double>& v) {
  double sum = 0, sum2 = 0;
  long n = 0;
  for (double x : v)
    if (std::isfinite(x)) {
      sum += x;
      sum2 += x * x;
      ++n;
    }
  if (n < 2) return std::nullopt;
  const double mean = sum / static_cast<double>(n);
  const double var = std::max(0.0, sum2 / static_cast<double>(n) - mean * mean);
  return std::make_pair(mean, std::sqrt(var));
}

const data::Dataset* FirstDataset(const AppState& state) {
  for (const LoadedDataset& d : state.datasets)
    if (d.data && d.data->rows() >= 2) return d.data.get();
  return nullptr;
}

}  // namespace

std::optional<DesignRequest> DesignRequestNow(const AppState& state) {
  if (!state.model) return std::nullopt;
  const DesignViewState& v = state.design;
  auto analysis = AnalysisRequestNow(state);
  DesignRequest r;
  r.spec = *state.model;
  if (analysis) {
    // The values the views show: the fit's estimates (or the model's), sliders applied.
    for (std::size_t i = 0; i < r.spec.parameters.size() && i < analysis->theta.size(); ++i)
      r.spec.parameters[i].value = analysis->theta[i];
    r.delay = analysis->delay;
  }
  for (std::size_t o = r.delay.size(); o < r.spec.output_delay.size(); ++o)
    r.delay.push_back(r.spec.output_delay[o].min);
  r.designs = {v.slots[0].design, v.slots[1].design};
  r.compare = v.compare;
  r.input = std::clamp(v.input, 0, std::max(0, static_cast<int>(r.spec.inputs.size()) - 1));
  r.hold = v.hold;
  r.hold.resize(r.spec.inputs.size(), 0.0);
  return r;
}

void SeedDesigns(AppState& state) {
  DesignViewState& v = state.design;
  v.seeded_generation = state.project_generation;
  v.result.reset();
  v.slots[0].tried.reset();
  v.slots[1].tried.reset();
  if (!state.model || state.model->inputs.empty()) return;
  const model::ModelSpec& m = *state.model;
  v.input = std::clamp(v.input, 0, static_cast<int>(m.inputs.size()) - 1);
  v.hold.assign(m.inputs.size(), 0.0);
  design::InputDesign d;
  d.level = 0.0;
  d.amplitude = 1.0;
  if (const data::Dataset* data = FirstDataset(state)) {
    for (std::size_t i = 0; i < m.inputs.size(); ++i) {
      const int c = data->Find(m.inputs[i]);
      if (c < 0) continue;
      const auto mo = Moments(data->columns[static_cast<std::size_t>(c)].values);
      if (!mo) continue;
      v.hold[i] = mo->first;
      if (static_cast<int>(i) == v.input) {
        d.level = mo->first;
        d.amplitude = mo->second > 0 ? mo->second : std::max(0.1 * std::abs(mo->first), 1e-3);
      }
    }
    const double span = data->time.back() - data->time.front();
    d.sample_time = span / static_cast<double>(data->rows() - 1);
    d.duration = span + d.sample_time;
  }
  // The model's time constants at its values: A a PRBS with T_prbs = 5 τ_min (rounded up to 1, 2,
  // 5 times a power of ten; the rule of thumb asks τ_min >= T_prbs / 10) and an order that makes
  // 2 n T_prbs reach τ_max; B steps of period 20 τ_max, slow next to every mode.
  std::vector<double> tau;
  if (auto lm = model::LinearModel::Compile(m)) {
    if (auto ss = lm->Evaluate(m.Values())) tau = design::TimeConstants(ss->A);
  }
  design::InputDesign a = d, b = d;
  a.shape = design::InputShape::kPrbs;
  b.shape = design::InputShape::kSquare;
  if (!tau.empty()) {
    a.bit_period = std::max(NiceUp(5 * tau.front()), d.sample_time);
    a.order = std::clamp(static_cast<int>(std::ceil(tau.back() / (2 * a.bit_period))), 6, 12);
    b.period = std::max(NiceUp(20 * tau.back()), 2 * d.sample_time);
  } else {
    a.bit_period = std::max(d.sample_time * 10, d.sample_time);
    b.period = std::max(d.duration / 10, 2 * d.sample_time);
  }
  std::string why;
  if (!a.IsValid(&why)) a = design::InputDesign{};
  if (!b.IsValid(&why)) b = a;
  v.slots[0].design = a;
  v.slots[1].design = b;
  const double window =
      std::max(a.shape == design::InputShape::kPrbs ? 40 * a.bit_period : 0.0, 3 * b.period);
  v.time_x.fit_request_frame = plot::LinkedRange::kNoFit;
  v.time_x.range = {0.0, std::min(a.duration, window)};
}

void PollDesign(AppState& state) {
  DesignViewState& v = state.design;
  if (auto run = v.job.TakeIfReady()) {
    v.running_key.clear();
    if (!run->cancelled) v.result = std::move(*run);
  }
  if (auto run = v.fit_job.TakeIfReady()) {
    const int slot = run->slot;
    v.fit_slot = -1;
    v.slots[static_cast<std::size_t>(slot)].tried = std::move(*run);
  }
  if (state.view != View::kDesign || !state.model) return;
  if (v.seeded_generation != state.project_generation) SeedDesigns(state);
  auto request = DesignRequestNow(state);
  if (!request) return;
  const std::string key = request->Key();
  if (v.result && v.result->key == key) return;
  if (v.job.active()) {
    if (v.running_key != key) v.job.RequestCancel();  // a newer request follows it
    return;
  }
  v.running_key = key;
  v.job.Start([r = std::move(*request)](JobControl& c) { return EvaluateDesigns(r, c); });
}

bool StartDesignFit(AppState& state, int slot, std::string* why) {
  auto refuse = [why](std::string reason) {
    if (why) *why = std::move(reason);
    return false;
  };
  DesignViewState& v = state.design;
  if (v.fit_job.active()) return refuse("a design is being tried");
  auto request = DesignRequestNow(state);
  if (!request) return refuse("the model is not valid");
  if (v.result && !v.result->model_error.empty()) return refuse(v.result->model_error);
  std::string bad;
  if (!v.slots[static_cast<std::size_t>(slot)].design.IsValid(&bad)) return refuse(bad);
  const int records = std::clamp(v.records, 1, project::kMaxDesignRecords);
  v.fit_slot = slot;
  v.fit_started = std::chrono::steady_clock::now();
  v.fit_job.Start([r = std::move(*request), slot, records](JobControl& c) {
    return FitDesign(r, slot, records, c);
  });
  return true;
}

}  // namespace gb::ui
