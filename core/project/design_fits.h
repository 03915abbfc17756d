// A design tried: records simulated from the model with the designed input (the model's values
// as the truth, exact discretisation, core/sim/response.h) and fitted, so that the standard
// errors the design predicts (core/design/experiment.h) can be set beside those the records
// give: the fit's own standard errors on the first record, and the spread of the estimates over
// all of them (a Monte Carlo check of the expected information).
//
// Each record r has seed `seed + r`; each fit starts at the truth, with the model's options
// (estimate::EstimateOptions defaults, one thread a fit, the records' fits side by side) and each
// output's delay held at the design's (no scan). Linear models only, as the design itself.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "core/design/experiment.h"
#include "core/model/linear_model.h"
#include "core/util/result.h"

namespace gb::project {

struct DesignFitOptions {
  int records = 1;         // 1..kMaxDesignRecords
  std::uint64_t seed = 1;  // record r's noise has seed + r
  int threads = 0;         // records fitted side by side (0: all cores)
  const std::atomic<bool>* cancel = nullptr;
  // Called (from a worker thread) after each record's fit with the number done so far.
  std::function<void(int done)> progress;
};

inline constexpr int kMaxDesignRecords = 1000;

struct DesignFits {
  std::vector<int> free;                       // as DesignEvaluation::free
  std::vector<std::vector<double>> estimates;  // per converged record: the free parameters
  int failed = 0;                              // records whose fit failed or did not converge
  // The first record's fit: its standard errors (absent where it has none).
  std::vector<std::optional<double>> first_std_error;
  double first_loglik = 0.0;
  bool first_converged = false;
  // Over the converged records (two or more): the mean and the sample standard deviation.
  std::vector<double> mean, spread;
};

// Errors: records outside 1..kMaxDesignRecords (kInput), the design's (MakeInput), a simulation's,
// and "cancelled" (kNumerical).
Result<DesignFits> FitDesignRecords(const model::LinearModel& model,
                                    const design::InputDesign& design, int input,
                                    std::span<const double> hold, const DesignFitOptions& options);

}  // namespace gb::project
