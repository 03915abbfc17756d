#include "core/sim/simulate.h"

#include <cstdint>
#include <optional>
#include <set>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/data/write_csv.h"
#include "core/design/prbs.h"
#include "core/expr/native.h"
#include "core/model/linear_model.h"
#include "core/project/result_file.h"
#include "core/sim/response.h"
#include "core/sim/sde.h"

namespace gb::cli {

int RunSimulate(const SimulateArgs& args) {
  if (args.deterministic && args.seed_given)
    return Fail(InputError("--seed: a deterministic response (--deterministic) draws no noise"));
  std::vector<FileRole> inputs_read = {{args.model, "the model file"},
                                       {args.inputs, "the --inputs file"}};
  if (!args.result.empty()) inputs_read.push_back({args.result, "the --result file"});
  if (int s = GuardOutputs(inputs_read, {{args.out, "--out"}})) return s;
  auto spec = LoadModelWithOverrides(args.model, args.sets);
  if (!spec) return Fail(spec.error());
  // A result's estimates (parameters given with --set keep their value) and its delays.
  std::vector<int> result_delay(spec->outputs.size(), -1);
  if (!args.result.empty()) {
    std::set<std::string> set_names;
    for (const auto& s : args.sets) set_names.insert(s.substr(0, s.find('=')));
    auto d = project::ApplyResultFile(args.result, set_names, &*spec);
    if (!d) return Fail(d.error());
    result_delay = *d;
  }
  const std::vector<double> theta = spec->Values();
  // A linear model is simulated exactly; any other by the Milstein scheme (core/sim/sde.h).
  auto lm = model::LinearModel::Compile(*spec);
  std::optional<model::NonlinearModel> nm;
  if (!lm) {
    auto compiled = model::NonlinearModel::Compile(std::move(*spec));
    if (!compiled) return Fail(compiled.error());
    nm = std::move(*compiled);
    // On native code where it can be built (as predict's and a fit's filter: the same values to
    // rounding, the library a fit of the model left in the cache), else on the interpreter.
    if (expr::NativeCode::Enabled()) {
      const model::NonlinearModel& m = *nm;
      if (auto code = expr::NativeCode::Compile(
              m.NativePrograms(), [&m](const std::string& name) { return m.SlotOf(name); }))
        nm->UseNative(*code, 0);
    }
  }
  const model::ModelSpec& m = lm ? lm->spec() : nm->spec();
  auto inputs = data::ReadCsvFile(args.inputs);
  if (!inputs) return Fail(inputs.error());
  auto series = data::Bind(**inputs, m.inputs, {});
  if (!series) return Fail(series.error());
  if (auto st = sim::CheckSimulationSize(static_cast<std::int64_t>((*series)->size()),
                                         static_cast<int>(m.states.size()),
                                         static_cast<int>(m.outputs.size()));
      !st) {
    Error e = st.error();
    e.file = args.inputs;
    return Fail(e);
  }

  // The series has no outputs; give the simulator an empty output block of the right height.
  data::Series with_outputs = **series;
  with_outputs.Y.setConstant(m.outputs.size(), with_outputs.size(),
                             std::numeric_limits<double>::quiet_NaN());
  filter::FilterSettings settings = filter::FilterSettings::FromModel(m);
  settings.delay.resize(m.outputs.size());
  for (std::size_t o = 0; o < m.outputs.size(); ++o)
    if (result_delay[o] >= 0) settings.delay[o] = result_delay[o];
  Result<sim::Simulation> result = InputError("");
  if (lm) {
    auto ss = lm->Evaluate(theta);
    if (!ss) return Fail(ss.error());
    result = args.deterministic ? sim::DeterministicResponse(*ss, with_outputs, settings)
                                : sim::SamplePath(*ss, with_outputs, settings, args.seed);
  } else if (args.deterministic) {
    result = sim::DeterministicResponse(*nm, theta, with_outputs, settings);
  } else {
    result = sim::SamplePath(*nm, theta, with_outputs, settings, args.seed);
  }
  if (!result) return Fail(result.error());

  std::vector<data::CsvColumn> cols;
  cols.push_back({"t", with_outputs.time});
  std::vector<std::vector<double>> storage;
  storage.reserve(m.inputs.size() + m.outputs.size());
  for (std::size_t i = 0; i < m.inputs.size(); ++i) {
    const auto& u = with_outputs.U.row(i);
    storage.emplace_back(u.begin(), u.end());
    cols.push_back({m.inputs[i], storage.back()});
  }
  for (std::size_t o = 0; o < m.outputs.size(); ++o) {
    const auto& y = result->Y.row(o);
    storage.emplace_back(y.begin(), y.end());
    cols.push_back({m.outputs[o], storage.back()});
  }
  std::vector<std::string> comments;
  const std::string values_from =
      args.result.empty() ? "" : fmt::format(" at the estimates of {}", args.result);
  if (!args.deterministic)
    comments.push_back(fmt::format("simulated by greybench-cli from {}{} (seed {})", args.model,
                                   values_from, args.seed));
  else
    comments.push_back(fmt::format(
        "the deterministic response of {}{}: no process or measurement noise, from the initial "
        "state ({})",
        args.model, values_from,
        lm ? "exact discretisation"
           : fmt::format("the moment equations' mean, rtol {} atol {}", m.ekf.rtol, m.ekf.atol)));
  std::string values;
  for (std::size_t i = 0; i < m.parameters.size(); ++i)
    values += fmt::format("{}{}={}", i ? " " : "", m.parameters[i].name, theta[i]);
  comments.push_back("parameters: " + values);
  std::string delays;
  for (std::size_t o = 0; o < m.outputs.size(); ++o)
    if (settings.delay[o] > 0)
      delays += fmt::format("{}{}={}", delays.empty() ? "" : " ", m.outputs[o], settings.delay[o]);
  if (!delays.empty()) comments.push_back("output delays (samples): " + delays);
  if (auto st = data::WriteCsvFile(args.out, cols, comments); !st) return Fail(st.error());
  return 0;
}

int RunPrbs(const PrbsArgs& args) {
  // The column's name: a CSV header's cell beside t.
  if (args.name.empty() || args.name == "t" ||
      args.name.find_first_of(",\"\r\n") != std::string::npos ||
      args.name.find_first_not_of(" \t") == std::string::npos)
    return Fail(InputError(fmt::format(
        "--name '{}': expected a column name (not empty, not t, without commas, quotes or line "
        "breaks)",
        args.name)));
  if (args.low == args.high)
    return Fail(InputError(
        fmt::format("--low {} and --high {}: the same level; the signal would be constant",
                    args.low, args.high)));
  design::PrbsOptions o;
  o.order = args.order;
  o.bit_period = args.period;
  o.sample_time = args.ts;
  o.duration = args.duration;
  o.low = args.low;
  o.high = args.high;
  o.seed = args.seed;
  o.name = args.name;
  auto signal = design::MakePrbs(o);
  if (!signal) return Fail(signal.error());
  const std::vector<data::CsvColumn> cols = {{"t", signal->t}, {args.name, signal->u}};
  const std::vector<std::string> comments = {
      fmt::format("PRBS order {}, bit period {}, period {} ({} bits), levels {} / {}, seed {}",
                  o.order, o.bit_period, design::PrbsPeriod(o.order, o.bit_period),
                  (1u << o.order) - 1u, o.low, o.high, o.seed)};
  if (auto st = data::WriteCsvFile(args.out, cols, comments); !st) return Fail(st.error());
  return 0;
}

}  // namespace gb::cli
