// libFuzzer target: CSV text -> Dataset (core/data/csv.cpp) -> Series bound to a model whose
// inputs and outputs are the file's columns (core/data/bind.cpp) -> the log-likelihood of a
// one-state linear model on that series (grouped intervals, exact discretisation, the filter).
//
// Properties checked beyond "no crash, no sanitizer report": a Dataset keeps its documented
// invariants (finite, strictly increasing time; one value per row in every column), and a bound
// Series has finite inputs and the shape of the model.
//
// The same text is also read in the other forms a project's dataset keys give (import.h): the
// format SniffCsv tells, headerless with a sample time and a decimal comma, and prepared with a
// map, a range, a detrend and a resample; each result keeps the same invariants.
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/data/dataset.h"
#include "core/data/import.h"
#include "core/filter/likelihood.h"
#include "core/model/linear_model.h"
#include "core/model/model.h"
#include "core/util/json.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

using gb::Json;

// dx = (-x + K u)/tau dt + s dω, y_j = x + e_j: one input and `n_outputs` outputs.
std::shared_ptr<const gb::model::LinearModel> OneStateModel(int n_outputs) {
  Json j = {{"greybench_model", 1}, {"name", "fuzz"}, {"states", {"x"}}, {"inputs", {"u"}}};
  j["outputs"] = Json::array();
  j["parameters"] = {{"tau", {{"value", 0.5}}},
                     {"K", {{"value", 2.0}}},
                     {"s", {{"value", 0.3}}},
                     {"v", {{"value", 0.1}}}};
  j["drift"] = {{"x", "(-x + K*u)/tau"}};
  j["diffusion"] = {{"x", "s"}};
  j["observation"] = Json::object();
  j["measurement_variance"] = Json::object();
  for (int o = 0; o < n_outputs; ++o) {
    const std::string name = "y" + std::to_string(o);
    j["outputs"].push_back(name);
    j["observation"][name] = "x";
    j["measurement_variance"][name] = "v";
  }
  auto spec = gb::model::ParseModel(j, "fuzz-model.json");
  FUZZ_CHECK(spec.ok());
  auto model = gb::model::LinearModel::Compile(std::move(spec).value());
  FUZZ_CHECK(model.ok());
  return std::make_shared<const gb::model::LinearModel>(std::move(model).value());
}

// The text read as the dataset keys would read it, prepared; every result a valid Dataset.
void CheckOtherForms(std::string_view text) {
  gb::data::CsvFormat sniffed = gb::data::SniffCsv(text);
  gb::data::CsvFormat headerless = sniffed;
  headerless.header = false;
  headerless.sample_time = 0.1;
  headerless.decimal = ',';
  headerless.separator = ';';
  gb::data::CsvFormat ranged = sniffed;
  ranged.range = std::array<double, 2>{0.05, 1e6};
  for (const gb::data::CsvFormat& format : {sniffed, headerless, ranged}) {
    auto read = gb::data::ParseCsv(text, "fuzz.csv", format);
    if (!read.ok()) {
      FUZZ_CHECK(!read.error().ToString().empty());
      continue;
    }
    CheckDataset(**read);
    const gb::data::Dataset& d = **read;
    if (d.columns.empty() || d.rows() < 2) continue;
    gb::data::DatasetSpec spec;
    spec.plain = false;
    const std::string& first = d.columns.front().name;
    spec.map = {{"mapped", first}, {"ratio", "1/(" + std::string("c1") + ")"}};
    spec.detrend = {{"", gb::data::Detrend::kLinear}};
    spec.resample = 0.25;
    auto prepared = gb::data::Prepare(*read, spec);
    if (!prepared.ok()) {
      FUZZ_CHECK(!prepared.error().ToString().empty());
      continue;
    }
    CheckDataset(**prepared);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  CheckOtherForms(text);
  auto read = gb::data::ParseCsv(text, "fuzz.csv");
  if (!read.ok()) {
    FUZZ_CHECK(!read.error().ToString().empty());
    return 0;
  }
  const gb::data::Dataset& d = **read;
  CheckDataset(d);
  if (d.columns.empty()) return 0;

  // The first column is the input, up to three others are outputs.
  const std::vector<std::string> inputs = {d.columns[0].name};
  std::vector<std::string> outputs;
  for (std::size_t c = 1; c < d.columns.size() && outputs.size() < 3; ++c)
    outputs.push_back(d.columns[c].name);
  if (outputs.empty()) return 0;
  for (const gb::data::Column& c : d.columns) (void)gb::data::NotANumberReason(c.bad_text);

  auto series = gb::data::Bind(d, inputs, outputs);
  if (!series.ok()) {
    FUZZ_CHECK(!series.error().ToString().empty());
    return 0;
  }
  const gb::data::Series& s = **series;
  FUZZ_CHECK(s.size() == d.rows());
  FUZZ_CHECK(s.U.rows() == 1 && s.U.cols() == static_cast<Eigen::Index>(s.size()));
  FUZZ_CHECK(s.Y.rows() == static_cast<Eigen::Index>(outputs.size()));
  FUZZ_CHECK(s.U.allFinite());
  FUZZ_CHECK(s.intervals.group.size() + 1 == s.size());

  auto model = OneStateModel(static_cast<int>(outputs.size()));
  auto likelihood = gb::filter::Likelihood::Create(model, {*series});
  if (!likelihood.ok()) return 0;
  const std::vector<double> theta = model->spec().Values();
  auto loglik = likelihood->Evaluate(theta);
  if (!loglik.ok()) FUZZ_CHECK(!loglik.error().ToString().empty());
  return 0;
}
