#include "ui/jobs/design.h"

#include <chrono>
#include <cmath>

#include <fmt/format.h>

#include "core/filter/kalman.h"
#include "core/model/linear_model.h"

namespace gb::ui {

namespace {

constexpr int kGainPoints = 120;

filter::FilterSettings SettingsOf(const DesignRequest& r) {
  filter::FilterSettings s = filter::FilterSettings::FromModel(r.spec);
  for (std::size_t o = 0; o < s.delay.size() && o < r.delay.size(); ++o) s.delay[o] = r.delay[o];
  return s;
}

}  // namespace

std::string DesignRequest::Key() const {
  std::string k = fmt::format("{}|{}|{}|", input, compare, spec.name);
  for (const auto& p : spec.parameters) k += fmt::format("{}={}{};", p.name, p.value, p.fixed);
  for (int d : delay) k += fmt::format("d{};", d);
  for (double h : hold) k += fmt::format("h{};", h);
  for (const auto& d : designs) k += design::FormatInputDesign(d) + "|";
  return k;
}

DesignRun EvaluateDesigns(const DesignRequest& r, JobControl& control) {
  DesignRun run;
  run.key = r.Key();
  auto lm = model::LinearModel::Compile(r.spec);
  if (!lm) {
    run.model_error =
        "The expected standard errors are computed for linear models (the Kalman filter's exact "
        "scores); this model is not linear: " +
        lm.error().message;
    return run;
  }
  const model::ModelSpec& m = lm->spec();
  for (const auto& p : m.parameters)
    if (!p.fixed) {
      run.free_names.push_back(p.name);
      run.free_values.push_back(p.value);
    }
  auto ss = lm->Evaluate(m.Values());
  if (!ss) {
    run.model_error = ss.error().message;
    return run;
  }
  run.time_constants = design::TimeConstants(ss->A);
  if (!m.outputs.empty()) run.bandwidth = design::Bandwidth(*ss, r.input, 0);
  filter::FilterSettings settings = SettingsOf(r);
  settings.cancel = &control.cancel;
  double f_lo = INFINITY, f_hi = 0;
  for (int d = 0; d < (r.compare ? 2 : 1); ++d) {
    if (control.cancel) {
      run.cancelled = true;
      return run;
    }
    auto e = design::EvaluateDesign(*lm, r.designs[static_cast<std::size_t>(d)], r.input, r.hold,
                                    settings);
    if (!e) {
      run.cancelled = control.cancel.load();
      run.errors[static_cast<std::size_t>(d)] = e.error().message;
      continue;
    }
    if (!e->spectrum.frequency.empty()) {
      f_lo = std::min(f_lo, e->spectrum.frequency.front());
      f_hi = std::max(f_hi, e->spectrum.frequency.back());
    }
    run.evals[static_cast<std::size_t>(d)] = std::move(*e);
    control.progress = 0.5f * static_cast<float>(d + 1);
  }
  if (f_hi > f_lo && !m.outputs.empty()) {
    for (int i = 0; i < kGainPoints; ++i)
      run.gain_frequency.push_back(f_lo * std::pow(f_hi / f_lo, i / (kGainPoints - 1.0)));
    for (double g2 : design::GainSquared(*ss, r.input, 0, run.gain_frequency))
      run.gain_db.push_back(10 * std::log10(std::max(g2, 1e-300)));
  }
  return run;
}

DesignFitRun FitDesign(const DesignRequest& r, int slot, int records, JobControl& control) {
  DesignFitRun run;
  run.key = r.Key();
  run.slot = slot;
  const auto start = std::chrono::steady_clock::now();
  // The design's delays as the fitted model's (held, as FitDesignRecords holds each at its min).
  model::ModelSpec spec = r.spec;
  for (std::size_t o = 0; o < spec.output_delay.size() && o < r.delay.size(); ++o)
    spec.output_delay[o] = {r.delay[o], r.delay[o]};
  auto fitted = model::LinearModel::Compile(spec);
  if (!fitted) {
    run.error = fitted.error().message;
    return run;
  }
  project::DesignFitOptions options;
  options.records = records;
  options.cancel = &control.cancel;
  options.progress = [&control, records](int done) {
    control.progress = static_cast<float>(done) / static_cast<float>(records);
  };
  auto fits = project::FitDesignRecords(*fitted, r.designs[static_cast<std::size_t>(slot)], r.input,
                                        r.hold, options);
  if (fits)
    run.fits = std::move(*fits);
  else
    run.error = fits.error().message;
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return run;
}

}  // namespace gb::ui
