#include "core/project/design_fits.h"

#include <cmath>
#include <memory>
#include <mutex>

#include <fmt/format.h>

#include "core/estimate/estimate.h"
#include "core/filter/likelihood.h"
#include "core/sim/response.h"
#include "core/util/parallel.h"

namespace gb::project {

Result<DesignFits> FitDesignRecords(const model::LinearModel& model,
                                    const design::InputDesign& design, int input,
                                    std::span<const double> hold, const DesignFitOptions& options) {
  if (options.records < 1 || options.records > kMaxDesignRecords)
    return InputError(
        fmt::format("records: {} is not from 1 to {}", options.records, kMaxDesignRecords));
  auto signal = design::MakeInput(design);
  if (!signal) return signal.error();
  // The fitted model: each output's delay held at the design's (the filter's min).
  model::ModelSpec spec = model.spec();
  for (auto& d : spec.output_delay) d.max = d.min;
  auto compiled = model::LinearModel::Compile(spec);
  if (!compiled) return compiled.error();
  const auto fitted = std::make_shared<const model::LinearModel>(std::move(*compiled));
  const std::vector<double> theta = spec.Values();
  auto ss = fitted->Evaluate(theta);
  if (!ss) return ss.error();
  const filter::FilterSettings settings = filter::FilterSettings::FromModel(spec);
  const data::Series design_series = design::DesignSeries(spec, input, *signal, hold);

  DesignFits out;
  for (int i = 0; i < static_cast<int>(spec.parameters.size()); ++i)
    if (!spec.parameters[static_cast<std::size_t>(i)].fixed) out.free.push_back(i);
  const int R = options.records;
  std::vector<std::optional<estimate::EstimateSummary>> fits(static_cast<std::size_t>(R));
  std::vector<std::optional<Error>> sim_errors(static_cast<std::size_t>(R));
  std::atomic<int> done{0};
  ParallelFor(R, options.threads, [&](int r) {
    if (options.cancel && options.cancel->load()) return;
    auto path =
        sim::SamplePath(*ss, design_series, settings, options.seed + static_cast<std::uint64_t>(r));
    if (!path) {
      sim_errors[static_cast<std::size_t>(r)] = path.error();
      return;
    }
    auto series = std::make_shared<data::Series>(design_series);
    series->source = fmt::format("record {} of the design", r + 1);
    series->Y = path->Y;
    auto likelihood = filter::Likelihood::Create(fitted, {series});
    if (!likelihood) {
      sim_errors[static_cast<std::size_t>(r)] = likelihood.error();
      return;
    }
    estimate::EstimateOptions eo;
    eo.threads = 1;
    eo.cancel = options.cancel;
    auto fit = estimate::Estimate(*likelihood, eo);
    if (fit) fits[static_cast<std::size_t>(r)] = std::move(*fit);
    const int n = ++done;
    if (options.progress) options.progress(n);
  });
  if (options.cancel && options.cancel->load()) return NumericalError("cancelled");
  // A simulation that failed fails the whole (the design cannot be tried); a fit that failed or
  // did not converge is counted.
  for (const auto& e : sim_errors)
    if (e) return *e;
  for (int r = 0; r < R; ++r) {
    const auto& fit = fits[static_cast<std::size_t>(r)];
    if (!fit || !fit->converged || fit->cancelled) {
      ++out.failed;
      continue;
    }
    std::vector<double> est;
    for (int i : out.free) est.push_back(fit->theta[static_cast<std::size_t>(i)]);
    if (r == 0) {
      out.first_converged = true;
      out.first_loglik = fit->loglik;
      for (int i : out.free)
        out.first_std_error.push_back(fit->parameters[static_cast<std::size_t>(i)].std_error);
    }
    out.estimates.push_back(std::move(est));
  }
  if (out.first_std_error.empty()) out.first_std_error.assign(out.free.size(), std::nullopt);
  const auto M = out.estimates.size();
  if (M >= 2) {
    const std::size_t k = out.free.size();
    out.mean.assign(k, 0.0);
    out.spread.assign(k, 0.0);
    for (const auto& e : out.estimates)
      for (std::size_t i = 0; i < k; ++i) out.mean[i] += e[i] / static_cast<double>(M);
    for (const auto& e : out.estimates)
      for (std::size_t i = 0; i < k; ++i)
        out.spread[i] += (e[i] - out.mean[i]) * (e[i] - out.mean[i]) / static_cast<double>(M - 1);
    for (auto& s : out.spread) s = std::sqrt(s);
  }
  return out;
}

}  // namespace gb::project
