// The recursive maximum-likelihood estimator (core/online/recursive.h).
#include "core/online/recursive.h"

#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "core/data/write_csv.h"
#include "core/estimate/estimate.h"
#include "core/filter/score.h"
#include "core/project/problem.h"
#include "core/sim/dyno.h"
#include "core/util/json.h"
#include "core/util/sanitizers.h"

namespace gb::online {
namespace {

const std::string kRecursiveAssets = std::string(GREYBENCH_SOURCE_DIR) + "/assets/";

// The two cases the recursion is held on: the fuel film on f1 (output delay 5) and the
// crankshaft, each with its model file's values as the reference, every free parameter in it.
Result<project::Problem> HeldCase(const std::string& name) {
  auto spec = model::LoadModelFile(kRecursiveAssets + name);
  if (!spec) return spec.error();
  const bool fuel = name.find("fuel") != std::string::npos;
  return project::LoadProblem(
      std::move(*spec), {kRecursiveAssets + (fuel ? "data/fuel_f1.csv" : "data/crankshaft.csv")});
}

Reference HeldReference(const model::LinearModel& model, const std::string& name) {
  Reference ref;
  ref.theta = model.spec().Values();
  for (int i = 0; i < model.n_parameters(); ++i)
    if (!model.spec().parameters[i].fixed) ref.free.push_back(i);
  const bool fuel = name.find("fuel") != std::string::npos;
  ref.delay.assign(static_cast<std::size_t>(model.n_outputs()), fuel ? 5 : 0);
  return ref;
}

struct FittedReference {
  project::Problem problem;
  estimate::EstimateSummary summary;
};

// Held at θ (no step ever: the warm-up outlasts the record), the recursion is the batch filter
// and its score: Σ ℓ_j is log L (kalman.h) and Σ ∂ℓ_j/∂θ its gradient (score.h).
TEST(Recursive, HeldAtThetaItsTermsAndScoresSumToTheBatchLikelihoodAndGradient) {
  for (const char* name : {"models/fuel_film.json", "models/crankshaft.json"}) {
    SCOPED_TRACE(name);
    auto problem = HeldCase(name);
    ASSERT_TRUE(problem) << problem.error().ToString();
    const model::LinearModel& model = *problem->model;
    const data::Series& series = *problem->series[0];
    const Reference ref = HeldReference(model, name);
    RecursiveOptions o;
    o.start = RecursiveOptions::Start::kModel;
    o.warmup = 1 << 30;
    auto rml = RecursiveMl::Create(model, ref, o);
    ASSERT_TRUE(rml) << rml.error().ToString();
    const std::vector<int> tracked = rml->tracked();
    double loglik = 0.0;
    Eigen::VectorXd score = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(tracked.size()));
    for (const Sample& r : SamplesOf(series)) {
      auto up = rml->Push(r);
      ASSERT_TRUE(up) << up.error().ToString();
      for (const RecursiveUpdate& u : *up) {
        loglik += u.loglik_term;
        for (std::size_t a = 0; a < tracked.size(); ++a) score(a) += u.score[a];
      }
    }
    filter::FilterSettings settings = filter::FilterSettings::FromModel(model.spec());
    settings.delay = ref.delay;
    const auto ss = *model.Evaluate(ref.theta);
    const auto dss = *model.EvaluateJacobian(ref.theta, tracked);
    Eigen::VectorXd gradient;
    auto batch = filter::LogLikelihoodScore(ss, dss, series, settings, &gradient);
    ASSERT_TRUE(batch) << batch.error().ToString();
    EXPECT_NEAR(loglik, batch->loglik, 1e-9 * std::abs(batch->loglik));
    for (std::size_t a = 0; a < tracked.size(); ++a)
      EXPECT_NEAR(score(a), gradient(a), 1e-7 * (1.0 + std::abs(gradient(a)))) << a;
  }
}

// Row by row, held at the reference with the model's own start, the recursion is the batch
// filter's step (linear_step.h) at dynamic size: each row's term and score are the batch's term
// of that state index (kalman.h) and its row of LogLikelihoodScore's J, to rounding (the batch
// runs fixed-size matrices, whose products may round otherwise).
TEST(Recursive, HeldAtThetaEveryRowsTermAndScoreAreTheBatchFiltersRow) {
  constexpr double kRowTol = 1e-12;  // relative
  for (const char* name : {"models/fuel_film.json", "models/crankshaft.json"}) {
    SCOPED_TRACE(name);
    auto problem = HeldCase(name);
    ASSERT_TRUE(problem) << problem.error().ToString();
    const model::LinearModel& model = *problem->model;
    const data::Series& series = *problem->series[0];
    const Reference ref = HeldReference(model, name);
    RecursiveOptions o;
    o.start = RecursiveOptions::Start::kModel;
    o.hold = true;
    auto rml = RecursiveMl::Create(model, ref, o);
    ASSERT_TRUE(rml) << rml.error().ToString();
    const std::vector<int> tracked = rml->tracked();

    filter::FilterSettings settings = filter::FilterSettings::FromModel(model.spec());
    settings.delay = ref.delay;
    const auto ss = *model.Evaluate(ref.theta);
    const auto dss = *model.EvaluateJacobian(ref.theta, tracked);
    std::vector<double> terms;
    ASSERT_TRUE(filter::LogLikelihood(ss, series, settings, &terms));
    Eigen::VectorXd gradient;
    Eigen::MatrixXd J;
    ASSERT_TRUE(filter::LogLikelihoodScore(ss, dss, series, settings, &gradient, &J));

    int rows = 0;
    for (const Sample& r : SamplesOf(series)) {
      auto up = rml->Push(r);
      ASSERT_TRUE(up) << up.error().ToString();
      for (const RecursiveUpdate& u : *up) {
        const int j = u.index;
        ASSERT_LT(j, static_cast<int>(terms.size()));
        EXPECT_NEAR(u.loglik_term, terms[j], kRowTol * std::abs(terms[j])) << "row " << j;
        for (std::size_t a = 0; a < tracked.size(); ++a)
          EXPECT_NEAR(u.score[a], J(j, a), kRowTol * std::abs(J(j, a))) << "row " << j << " " << a;
        ++rows;
      }
    }
    EXPECT_GT(rows, 100);
  }
}

// A record of the virtual dyno other than the bundled one, as a dataset file would give it.
std::shared_ptr<const data::Dataset> Record(const sim::Record& r) {
  std::vector<data::CsvColumn> columns;
  for (std::size_t c = 0; c < r.names.size(); ++c) columns.push_back({r.names[c], r.columns[c]});
  auto d = data::ParseCsv(data::FormatCsv(columns), "dyno seed 7");
  EXPECT_TRUE(d) << d.error().ToString();
  return *d;
}

// On a stationary record, λ = 1, starting from the batch fit of another record of the same
// experiment (its information counting as that record's rows, the default): the recursive
// estimate summarises both records, so at the end of the new one it is within 2 standard errors
// of the batch ML estimate from both records together, and log L of both at it is within 2 of
// the maximum.
void EndsWithinTwoBatchStandardErrors(const std::string& model_file,
                                      const sim::Record& reference_record,
                                      const sim::Record& record, std::size_t tracked) {
  auto spec = model::LoadModelFile(kRecursiveAssets + model_file);
  ASSERT_TRUE(spec);
  // Under the sanitizers a delay scan is held at the delay the full fits find (the fuel film's
  // 5), and no extra starts are made (their own tests cover both).
  if (kSanitized && spec->output_delay[0].IsScan()) spec->output_delay[0] = {5, 5};
  estimate::EstimateOptions fit_options;
  if (kSanitized) fit_options.starts_on_bound = 0;
  FittedReference ref_fit;
  {
    auto p = project::MakeProblem(*spec, {Record(reference_record)});
    ASSERT_TRUE(p) << p.error().ToString();
    auto l = project::MakeLikelihood(*p);
    ASSERT_TRUE(l) << l.error().ToString();
    auto s = estimate::Estimate(*l, fit_options);
    ASSERT_TRUE(s && s->converged);
    ref_fit = FittedReference{std::move(*p), std::move(*s)};
  }
  auto problem = project::MakeProblem(std::move(*spec), {Record(record)});
  ASSERT_TRUE(problem) << problem.error().ToString();
  auto both =
      project::MakeProblem(problem->spec(), {ref_fit.problem.datasets[0], problem->datasets[0]});
  ASSERT_TRUE(both) << both.error().ToString();
  auto lik = project::MakeLikelihood(*both);
  ASSERT_TRUE(lik) << lik.error().ToString();
  auto batch = estimate::Estimate(*lik, fit_options);
  ASSERT_TRUE(batch && batch->converged);
  const model::LinearModel& model = *problem->model;

  Reference ref = ReferenceFromSummary(ref_fit.summary, model.spec());
  RecursiveOptions o;
  o.forgetting = 1.0;
  auto rml = RecursiveMl::Create(model, ref, o);
  ASSERT_TRUE(rml) << rml.error().ToString();
  std::optional<RecursiveUpdate> last;
  for (const Sample& r : SamplesOf(*problem->series[0])) {
    auto up = rml->Push(r);
    ASSERT_TRUE(up) << up.error().ToString();
    if (!up->empty()) last = up->back();
  }
  ASSERT_TRUE(last);
  // And log L at the end is within a few units of the maximum (the 2-SE box in 8 dimensions).
  std::vector<int> delay;
  for (const auto& d : batch->delays) delay.push_back(d.estimate);
  const auto at_end = lik->Evaluate(rml->theta(), delay);
  ASSERT_TRUE(at_end);
  EXPECT_GT(at_end->loglik, batch->loglik - 2.0);
  ::testing::Test::RecordProperty("loglik_below_batch",
                                  fmt::format("{:.3f}", batch->loglik - at_end->loglik));
  // Every free parameter but those that only set the initial state (the fuel film's mfi0).
  const std::vector<std::string> names = rml->tracked_names();
  EXPECT_EQ(names.size(), tracked);
  for (std::size_t a = 0; a < names.size(); ++a) {
    const estimate::ParameterEstimate& pe =
        batch->parameters[model.spec().ParameterIndex(names[a])];
    ASSERT_TRUE(pe.std_error) << names[a];
    const double z = (last->theta[a] - pe.estimate) / *pe.std_error;
    ::testing::Test::RecordProperty(names[a] + "_z", fmt::format("{:.2f}", z));
    EXPECT_LT(std::abs(z), 2.0) << names[a] << ": batch " << pe.estimate << " ± " << *pe.std_error
                                << ", recursive " << last->theta[a] << " ± " << last->sd[a];
    // Its own standard deviation is the batch one's size (λ = 1: the inverse information).
    EXPECT_GT(last->sd[a], 0.5 * *pe.std_error) << names[a];
    EXPECT_LT(last->sd[a], 2.0 * *pe.std_error) << names[a];
  }
}

// The reference: the record of the bundled data (seed 1; under the sanitizers, where the point
// is the code path, a fifth of it); the new record: seed 7.
TEST(Recursive, OnAStationaryFuelRecordTheEndIsWithinTwoBatchStandardErrors) {
  sim::FuelExperiment e;
  e.point = *sim::FindFuelPoint("f1");
  if (kSanitized) e.duration /= 5;
  auto reference = sim::RunFuelExperiment(e);
  e.seed = 7;
  auto record = sim::RunFuelExperiment(e);
  ASSERT_TRUE(reference && record);
  EndsWithinTwoBatchStandardErrors("models/fuel_film.json", *reference, *record, 7);
}

TEST(Recursive, OnAStationaryCrankshaftRecordTheEndIsWithinTwoBatchStandardErrors) {
  sim::CrankshaftExperiment e;
  if (kSanitized) e.duration /= 5;
  auto reference = sim::RunCrankshaftExperiment(e);
  e.seed = 7;
  auto record = sim::RunCrankshaftExperiment(e);
  ASSERT_TRUE(reference && record);
  EndsWithinTwoBatchStandardErrors("models/crankshaft.json", *reference, *record, 8);
}

}  // namespace
}  // namespace gb::online
