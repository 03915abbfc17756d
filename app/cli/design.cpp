#include <cmath>
#include <set>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/design/experiment.h"
#include "core/project/design_fits.h"
#include "core/project/result_file.h"
#include "core/util/file.h"
#include "core/util/json.h"

namespace gb::cli {

namespace {

// The model's input the designs drive, and the levels of the others (--hold NAME=VALUE).
struct Drive {
  int input = 0;
  std::vector<double> hold;
};

Result<Drive> ResolveDrive(const model::ModelSpec& m, const DesignArgs& args) {
  Drive d;
  const int n_in = static_cast<int>(m.inputs.size());
  if (n_in == 0) return InputError("the model has no input: there is nothing to design");
  auto index = [&](const std::string& name) {
    for (int i = 0; i < n_in; ++i)
      if (m.inputs[static_cast<std::size_t>(i)] == name) return i;
    return -1;
  };
  auto list = [&] {
    std::string s;
    for (const auto& n : m.inputs) s += (s.empty() ? "" : ", ") + n;
    return s;
  };
  if (args.drive.empty()) {
    if (n_in > 1)
      return InputError(fmt::format(
          "--drive: the model has {} inputs ({}); name the one the design drives", n_in, list()));
  } else {
    d.input = index(args.drive);
    if (d.input < 0)
      return InputError(fmt::format("--drive '{}': the model has no such input (its inputs: {})",
                                    args.drive, list()));
  }
  d.hold.assign(static_cast<std::size_t>(n_in), std::nan(""));
  for (const auto& h : args.holds) {
    const auto eq = h.find('=');
    const std::string name = h.substr(0, eq);
    const int i = index(name);
    if (eq == std::string::npos || i < 0)
      return InputError(
          fmt::format("--hold '{}': expected INPUT=VALUE with an input of the model "
                      "({})",
                      h, list()));
    if (i == d.input)
      return InputError(fmt::format("--hold '{}': {} is the input the design drives", h, name));
    double v = 0;
    try {
      std::size_t used = 0;
      v = std::stod(h.substr(eq + 1), &used);
      if (used != h.size() - eq - 1 || !std::isfinite(v)) throw std::invalid_argument("");
    } catch (const std::exception&) {
      return InputError(fmt::format("--hold '{}': the value must be a finite number", h));
    }
    if (!std::isnan(d.hold[static_cast<std::size_t>(i)]))
      return InputError(fmt::format("--hold: {} is given twice", name));
    d.hold[static_cast<std::size_t>(i)] = v;
  }
  for (int i = 0; i < n_in; ++i)
    if (i != d.input && std::isnan(d.hold[static_cast<std::size_t>(i)]))
      return InputError(fmt::format("--hold: give the level of the input {} (the design drives {})",
                                    m.inputs[static_cast<std::size_t>(i)],
                                    m.inputs[static_cast<std::size_t>(d.input)]));
  d.hold[static_cast<std::size_t>(d.input)] = 0.0;
  return d;
}

std::string Number(const std::optional<double>& v) {
  return v && std::isfinite(*v) ? fmt::format("{:.4g}", *v) : "-";
}

// The share of the input's power below frequency f (the spectrum's bands are log-spaced, each
// band's mean density times its width).
double ShareBelow(const design::Spectrum& s, double f) {
  double below = 0, total = 0;
  for (std::size_t b = 0; b < s.frequency.size(); ++b) {
    const double width = s.frequency[b];  // proportional to the band's width (log spacing)
    total += s.power[b] * width;
    if (s.frequency[b] < f) below += s.power[b] * width;
  }
  return total > 0 ? below / total : 0.0;
}

}  // namespace

int RunDesign(const DesignArgs& args) {
  std::vector<FileRole> inputs = {{args.model, "the model file"}};
  if (!args.result.empty()) inputs.push_back({args.result, "the --result file"});
  std::vector<FileRole> outputs;
  if (!args.out.empty()) outputs.push_back({args.out, "--out"});
  if (int s = GuardOutputs(inputs, outputs)) return s;
  if (args.designs.empty() || args.designs.size() > 2)
    return Fail(InputError("--design: give one design, or two to compare"));
  auto spec = LoadModelWithOverrides(args.model, args.sets);
  if (!spec) return Fail(spec.error());
  if (!args.result.empty()) {
    std::set<std::string> set_names;
    for (const auto& s : args.sets) set_names.insert(s.substr(0, s.find('=')));
    auto delays = project::ApplyResultFile(args.result, set_names, &*spec);
    if (!delays) return Fail(delays.error());
    // The result's delays: the design's records are observed (and its tries fitted) with them.
    for (std::size_t o = 0; o < delays->size() && o < spec->output_delay.size(); ++o)
      if ((*delays)[o] >= 0) spec->output_delay[o] = {(*delays)[o], (*delays)[o]};
  }
  auto lm = model::LinearModel::Compile(*spec);
  if (!lm) {
    Error e = lm.error();
    e.message =
        "the expected information is computed for linear models (the Kalman filter's "
        "exact scores); " +
        e.message;
    return Fail(e);
  }
  auto drive = ResolveDrive(lm->spec(), args);
  if (!drive) return Fail(drive.error());
  std::vector<design::InputDesign> designs;
  for (const auto& text : args.designs) {
    auto d = design::ParseInputDesign(text);
    if (!d) {
      Error e = d.error();
      e.message = "--design: " + e.message;
      return Fail(e);
    }
    designs.push_back(*d);
  }
  const model::ModelSpec& m = lm->spec();
  const filter::FilterSettings settings = filter::FilterSettings::FromModel(m);
  std::vector<design::DesignEvaluation> evals;
  for (const auto& d : designs) {
    auto e = design::EvaluateDesign(*lm, d, drive->input, drive->hold, settings);
    if (!e) return Fail(e.error());
    evals.push_back(std::move(*e));
  }
  auto ss = lm->Evaluate(m.Values());
  if (!ss) return Fail(ss.error());
  const std::vector<double> tau = design::TimeConstants(ss->A);
  const std::string input_name = m.inputs[static_cast<std::size_t>(drive->input)];
  const std::string output_name = m.outputs.empty() ? "" : m.outputs[0];
  // NaN where there is none.
  const double bandwidth = m.outputs.empty()
                               ? std::nan("")
                               : design::Bandwidth(*ss, drive->input, 0).value_or(std::nan(""));
  const bool has_bandwidth = std::isfinite(bandwidth);

  std::vector<project::DesignFits> fits;
  if (args.fit > 0) {
    for (const auto& d : designs) {
      project::DesignFitOptions fo;
      fo.records = args.fit;
      fo.seed = args.seed;
      auto f = project::FitDesignRecords(*lm, d, drive->input, drive->hold, fo);
      if (!f) return Fail(f.error());
      fits.push_back(std::move(*f));
    }
  }

  // The report.
  const char* names[] = {"A", "B"};
  std::string tau_text;
  for (double t : tau) tau_text += fmt::format("{}{:.4g}", tau_text.empty() ? "" : ", ", t);
  fmt::print("Experiment design for {} ({}), at {}\n", m.name.empty() ? args.model : m.name,
             args.model,
             args.result.empty() ? "the model's values" : "the estimates of " + args.result);
  fmt::print(
      "Expected standard errors from the Fisher information of the Kalman filter's innovations "
      "(exact for this linear model, no simulation)\n");
  fmt::print("Input driven: {}{}; time constants: {}; bandwidth {} -> {}: {}\n", input_name,
             drive->hold.size() > 1 ? " (the others held)" : "",
             tau_text.empty() ? "none (no stable mode)" : tau_text, input_name, output_name,
             has_bandwidth ? fmt::format("{:.4g} cycles per time unit", bandwidth) : "none");
  for (std::size_t d = 0; d < evals.size(); ++d) {
    fmt::print("{}: {}", names[d], evals[d].design.Describe());
    if (has_bandwidth)
      fmt::print("; {:.0f} % of its power below the bandwidth",
                 100 * ShareBelow(evals[d].spectrum, bandwidth));
    if (evals[d].design.shape == design::InputShape::kPrbs) {
      const auto range =
          design::EstimableTimeConstants(evals[d].design.order, evals[d].design.bit_period);
      fmt::print("; rule of thumb: time constants {:.3g} to {:.3g}", range.shortest, range.longest);
    }
    fmt::print("\n");
  }
  for (std::size_t d = 0; d < evals.size(); ++d)
    if (evals[d].info.undetermined)
      fmt::print(
          "{}: the design does not determine {} (the information is singular)\n", names[d],
          m.parameters[static_cast<std::size_t>(
                           evals[d].free[static_cast<std::size_t>(*evals[d].info.undetermined)])]
              .name);
  fmt::print("\n{:<14} {:>12}", "parameter", "value");
  for (std::size_t d = 0; d < evals.size(); ++d)
    fmt::print(" {:>11}", fmt::format("SE {}", names[d]));
  if (evals.size() == 2) fmt::print(" {:>7}", "B / A");
  for (std::size_t d = 0; d < fits.size(); ++d) {
    fmt::print(" {:>11}", fmt::format("fit SE {}", names[d]));
    if (args.fit >= 2) fmt::print(" {:>11}", fmt::format("spread {}", names[d]));
  }
  fmt::print("\n");
  const auto& free = evals[0].free;
  for (std::size_t i = 0; i < free.size(); ++i) {
    const auto& p = m.parameters[static_cast<std::size_t>(free[i])];
    fmt::print("{:<14} {:>12.6g}", p.name, p.value);
    for (const auto& e : evals) fmt::print(" {:>11}", Number(e.info.std_error[i]));
    if (evals.size() == 2) {
      const auto& a = evals[0].info.std_error[i];
      const auto& b = evals[1].info.std_error[i];
      fmt::print(" {:>7}", a && b && *a > 0 ? fmt::format("{:.3g}", *b / *a) : "-");
    }
    for (const auto& f : fits) {
      fmt::print(" {:>11}", Number(f.first_std_error[i]));
      if (args.fit >= 2) fmt::print(" {:>11}", f.spread.empty() ? "-" : Number(f.spread[i]));
    }
    fmt::print("\n");
  }
  for (std::size_t d = 0; d < fits.size(); ++d) {
    fmt::print(
        "\n{}: {} record{} simulated from the model with this input (seeds {}..{}) and "
        "fitted from the truth; {} did not converge",
        names[d], args.fit, args.fit == 1 ? "" : "s", args.seed,
        args.seed + static_cast<std::uint64_t>(args.fit) - 1, fits[d].failed);
    if (args.fit >= 2)
      fmt::print("; 'spread' is the standard deviation of the estimates over the records");
    fmt::print("\n");
  }

  if (!args.out.empty()) {
    Json j;
    j["greybench_design"] = 1;
    j["model_file"] = args.model;
    j["input"] = input_name;
    j["time_constants"] = tau;
    j["bandwidth"] = has_bandwidth ? Json(bandwidth) : Json(nullptr);
    Json list = Json::array();
    for (std::size_t d = 0; d < evals.size(); ++d) {
      Json e;
      e["design"] = design::FormatInputDesign(evals[d].design);
      e["n_obs"] = evals[d].info.n_obs;
      Json params = Json::object();
      for (std::size_t i = 0; i < free.size(); ++i) {
        const auto& p = m.parameters[static_cast<std::size_t>(free[i])];
        Json pe;
        pe["value"] = p.value;
        pe["expected_std_error"] =
            evals[d].info.std_error[i] ? Json(*evals[d].info.std_error[i]) : Json(nullptr);
        if (d < fits.size()) {
          pe["fit_std_error"] =
              fits[d].first_std_error[i] ? Json(*fits[d].first_std_error[i]) : Json(nullptr);
          if (!fits[d].spread.empty()) pe["spread"] = fits[d].spread[i];
        }
        params[p.name] = pe;
      }
      e["parameters"] = params;
      if (d < fits.size()) {
        e["records"] = args.fit;
        e["failed"] = fits[d].failed;
      }
      list.push_back(e);
    }
    j["designs"] = list;
    if (auto st = WriteFileAtomic(args.out, j.dump(1) + "\n"); !st) return Fail(st.error());
  }
  return 0;
}

}  // namespace gb::cli
