// The experiment-design view's work (core/design/experiment.h): two input designs evaluated for
// the model at the values the views show (their expected standard errors, spectra, the model's
// time constants and gain), and a design tried (records simulated with it and fitted,
// core/project/design_fits.h). Both run as jobs; the key says which request a result answers, so
// a result that arrives after the request changed is dropped.
// No ImGui here: the tests use these types without a UI.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/design/experiment.h"
#include "core/model/model.h"
#include "core/project/design_fits.h"
#include "ui/jobs/job.h"

namespace gb::ui {

// Everything the evaluation needs, copied when it starts.
struct DesignRequest {
  model::ModelSpec spec;   // at the values the views show (the fit's, or the model's)
  std::vector<int> delay;  // per output (the fit's estimates, else each output's min)
  std::array<design::InputDesign, 2> designs;
  bool compare = true;       // evaluate the second design too
  int input = 0;             // the input the designs drive
  std::vector<double> hold;  // every input's level (the driven one's unused)
  std::string Key() const;   // changes whenever anything above does
};

struct DesignRun {
  std::string key;
  std::array<std::optional<design::DesignEvaluation>, 2> evals;
  std::array<std::string, 2> errors;  // why an evaluation is absent
  std::vector<std::string> free_names;
  std::vector<double> free_values;
  std::vector<double> time_constants;
  std::optional<double> bandwidth;  // from the driven input to the first output
  // The model's gain |G|² in dB at log-spaced frequencies over the spectra's range.
  std::vector<double> gain_frequency, gain_db;
  std::string model_error;  // the model is not linear, or not valid at these values
  bool cancelled = false;   // superseded by a newer request: not installed
};
DesignRun EvaluateDesigns(const DesignRequest& request, JobControl& control);

// One design tried: `records` simulated and fitted.
struct DesignFitRun {
  std::string key;  // the DesignRequest::Key it was started for
  int slot = 0;     // 0 or 1
  std::optional<project::DesignFits> fits;
  std::string error;
  double seconds = 0;
};
DesignFitRun FitDesign(const DesignRequest& request, int slot, int records, JobControl& control);

}  // namespace gb::ui
