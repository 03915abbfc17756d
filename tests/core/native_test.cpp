// Native code (core/expr/native.h) against the interpreter (expr::Tape) and EvaluateTree: the
// same values bit for bit, on hand-made special values, on every program of every bundled model,
// and through the extended Kalman filter's log-likelihood and exact scores.
#include "core/expr/native.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/data/dataset.h"
#include "core/estimate/estimate.h"
#include "core/filter/likelihood.h"
#include "core/model/model.h"
#include "core/model/nonlinear_model.h"
#include "core/model/nonlinear_sensitivity.h"
#include "core/util/json.h"
#include "tests/core/nonlinear_tank.h"

namespace gb::expr {
namespace {

namespace fs = std::filesystem;
const std::string kRoot = GREYBENCH_SOURCE_DIR;

// Equal bit for bit, or both NaN (a NaN's payload is not part of a value).
bool SameValue(double a, double b) {
  if (std::isnan(a) && std::isnan(b)) return true;
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

// Sets an environment variable for one scope, and puts it back.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (old_) {
      setenv(name_, old_->c_str(), 1);
    } else {
      unsetenv(name_);
    }
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
  std::optional<std::string> old_;
};

TEST(NativeCode, SpecialValuesFollowTheInterpretersArithmetic) {
  const std::vector<std::string> texts = {"x + y * z - x / y",
                                          "-x",
                                          "abs(x)",
                                          "abs(x - w)",
                                          "min(x, w)",
                                          "max(w, x)",
                                          "min(w, x)",
                                          "max(x, w)",
                                          "x^y + pow(y, 0.5)",
                                          "exp(800 * x)",
                                          "log(x - x)",
                                          "sqrt(-x)",
                                          "abs(-y) + tanh(z)",
                                          "0.1 + 1e-300",
                                          "-0.1 * x - 2.5e10",
                                          "sin(x) * cos(y) / tan(z)",
                                          "x^2 + x^3 + x^-1",
                                          "(x - x) * -1",
                                          "1e308 * 10 * x",
                                          "x / (x - x)"};
  std::vector<ExprPtr> exprs;
  for (const std::string& t : texts) exprs.push_back(Parse(t).value());
  // sign() is internal: it comes from the derivative of abs (sign(-0) = -0, sign(NaN) = NaN).
  exprs[2] = Differentiate(exprs[2], "x");
  exprs[3] = Differentiate(exprs[3], "w");
  auto slot_of = [](const std::string& name) {
    return name == "x" ? 0 : name == "y" ? 1 : name == "z" ? 2 : name == "w" ? 3 : -1;
  };
  auto code = NativeCode::Compile(std::vector<NativeCode::Program>{{exprs, {}}}, slot_of);
  ASSERT_TRUE(code.ok()) << code.error().ToString();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const std::vector<double>& slots : std::vector<std::vector<double>>{
           {1.5, 0.25, -3.0, nan}, {-0.0, 2.0, 0.5, 1.0}, {0.7, -1.3, 1e-5, -0.7}}) {
    std::vector<double> native(exprs.size());
    (*code)->function(0)(slots.data(), native.data());
    for (std::size_t i = 0; i < exprs.size(); ++i) {
      const double tree = EvaluateTree(exprs[i], [&](const std::string& n) {
        return slots[static_cast<std::size_t>(slot_of(n))];
      });
      EXPECT_TRUE(SameValue(native[i], tree))
          << texts[i] << " at x = " << slots[0] << ": native " << native[i] << ", tree " << tree;
    }
  }
}

TEST(NativeCode, ProgramsOfEveryBundledModelEqualTheInterpretersBitForBit) {
  int models = 0;
  for (const auto& entry : fs::directory_iterator(kRoot + "/assets/models")) {
    if (entry.path().extension() != ".json") continue;
    auto spec = model::LoadModelFile(entry.path().string());
    ASSERT_TRUE(spec.ok()) << spec.error().ToString();
    auto nm = model::NonlinearModel::Compile(*spec);
    ASSERT_TRUE(nm.ok()) << nm.error().ToString();
    auto sens = model::NonlinearSensitivity::Compile(*nm);
    ASSERT_TRUE(sens.ok()) << sens.error().ToString();
    std::vector<NativeCode::Program> programs = nm->NativePrograms();
    for (NativeCode::Program& p : sens->NativePrograms()) programs.push_back(std::move(p));
    const model::NonlinearModel& m = *nm;
    auto code = NativeCode::Compile(programs, [&m](const std::string& n) { return m.SlotOf(n); });
    ASSERT_TRUE(code.ok()) << entry.path() << ": " << code.error().ToString();
    model::NonlinearModel native_model = *nm;
    native_model.UseNative(*code, 0);
    model::NonlinearSensitivity native_sens = *sens;
    native_sens.UseNative(*code, nm->NativePrograms().size());
    ASSERT_TRUE(native_model.native());

    // Slots at the parameters' start values and states, inputs and time drawn around 1.
    std::mt19937_64 rng(20261128);
    std::uniform_real_distribution<double> around(0.2, 3.0);
    const std::vector<double> theta = spec->Values();
    for (int draw = 0; draw < 5; ++draw) {
      std::vector<double> slots(static_cast<std::size_t>(m.n_slots()));
      for (double& s : slots) s = around(rng);
      for (int i = 0; i < m.n_parameters(); ++i)
        slots[static_cast<std::size_t>(m.parameter_slot() + i)] = theta[i];
      auto compare = [&](auto run_interpreted, auto run_native, std::size_t size,
                         const char* what) {
        std::vector<double> a(size, 0.0), b(size, 0.0);
        run_interpreted(a);
        run_native(b);
        for (std::size_t k = 0; k < size; ++k)
          EXPECT_TRUE(SameValue(a[k], b[k])) << entry.path().filename() << " " << what << "[" << k
                                             << "]: interpreter " << a[k] << ", native " << b[k];
      };
      compare([&](std::vector<double>& o) { nm->Dynamics(slots, o); },
              [&](std::vector<double>& o) { native_model.Dynamics(slots, o); }, nm->dynamics_size(),
              "dynamics");
      compare([&](std::vector<double>& o) { nm->Measurement(slots, o); },
              [&](std::vector<double>& o) { native_model.Measurement(slots, o); },
              nm->measurement_size(), "measurement");
      compare([&](std::vector<double>& o) { nm->Initial(slots, o); },
              [&](std::vector<double>& o) { native_model.Initial(slots, o); }, nm->initial_size(),
              "initial");
      compare([&](std::vector<double>& o) { nm->Noise(slots, o); },
              [&](std::vector<double>& o) { native_model.Noise(slots, o); },
              2 * static_cast<std::size_t>(m.n_states()), "noise");
      // (Pairs, not structured bindings: clang 14 does not capture those in lambdas.)
      using ProgramPair = std::pair<const model::NonlinearSensitivity::Program*,
                                    const model::NonlinearSensitivity::Program*>;
      for (const ProgramPair& pair : {ProgramPair{&sens->dynamics(), &native_sens.dynamics()},
                                      ProgramPair{&sens->measurement(), &native_sens.measurement()},
                                      ProgramPair{&sens->initial(), &native_sens.initial()}}) {
        const model::NonlinearSensitivity::Program* program = pair.first;
        const model::NonlinearSensitivity::Program* native_program = pair.second;
        std::vector<double> scratch(program->nonzeros());
        compare([&](std::vector<double>& o) { program->Eval(slots, o, scratch); },
                [&](std::vector<double>& o) { native_program->Eval(slots, o, scratch); },
                program->size(), "derivatives");
      }
    }
    ++models;
  }
  EXPECT_GE(models, 7);
}

// The tanks SDE model's filter over 300 rows of its record: log L and the exact scores on both
// paths, equal bit for bit (the filter does the same operations on the same values).
TEST(NativeCode, EkfLogLikelihoodAndScoresEqualTheInterpretersBitForBit) {
  auto spec = model::LoadModelFile(kRoot + "/assets/models/cascaded_tanks_sde.json");
  ASSERT_TRUE(spec.ok()) << spec.error().ToString();
  auto data = data::ReadCsvFile(kRoot + "/assets/data/tanks_estimation.csv");
  ASSERT_TRUE(data.ok()) << data.error().ToString();
  auto series = data::Bind(**data, spec->inputs, spec->outputs);
  ASSERT_TRUE(series.ok()) << series.error().ToString();
  auto nm = std::make_shared<const model::NonlinearModel>(*model::NonlinearModel::Compile(*spec));
  auto interpreted = filter::Likelihood::Create(nm, {*series});
  ASSERT_TRUE(interpreted.ok()) << interpreted.error().ToString();
  ASSERT_FALSE(interpreted->native());
  auto native = interpreted->WithNativeCode();
  ASSERT_TRUE(native.ok()) << native.error().ToString();
  ASSERT_TRUE(native->native());

  std::vector<double> theta = spec->Values();
  std::vector<int> free;
  for (int i = 0; i < static_cast<int>(spec->parameters.size()); ++i)
    if (!spec->parameters[static_cast<std::size_t>(i)].fixed) free.push_back(i);
  for (double scale : {1.0, 1.3}) {
    for (int i : free) theta[static_cast<std::size_t>(i)] *= scale;
    auto a = interpreted->Evaluate(theta);
    auto b = native->Evaluate(theta);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_TRUE(SameValue(a->loglik, b->loglik)) << a->loglik << " vs " << b->loglik;
    Eigen::VectorXd ga, gb;
    auto sa = interpreted->EvaluateWithScore(theta, {}, free, &ga);
    auto sb = native->EvaluateWithScore(theta, {}, free, &gb);
    ASSERT_TRUE(sa.ok() && sb.ok());
    EXPECT_TRUE(SameValue(sa->loglik, sb->loglik));
    ASSERT_EQ(ga.size(), gb.size());
    for (Eigen::Index k = 0; k < ga.size(); ++k)
      EXPECT_TRUE(SameValue(ga(k), gb(k))) << "score " << k << ": " << ga(k) << " vs " << gb(k);
  }
}

// A whole estimation on each path: the same iterations and estimates, bit for bit; the result
// says which ran (and why not native), and reads back.
TEST(NativeCode, AnEstimateOnNativeCodeIsTheInterpretersBitForBit) {
  const auto nm = testing::CompileTank(Json::parse(testing::kTank));
  auto lik = filter::Likelihood::Create(nm, {testing::SimulateTank(3, 150.0)});
  ASSERT_TRUE(lik.ok()) << lik.error().ToString();
  estimate::EstimateOptions options;
  options.threads = 1;
  auto native = estimate::Estimate(*lik, options);
  ASSERT_TRUE(native.ok()) << native.error().ToString();
  std::optional<Result<estimate::EstimateSummary>> interpreted;
  {
    const ScopedEnv off("GREYBENCH_NATIVE", "0");
    interpreted = estimate::Estimate(*lik, options);
  }
  ASSERT_TRUE(interpreted->ok()) << interpreted->error().ToString();
  const estimate::EstimateSummary& a = **interpreted;
  const estimate::EstimateSummary& b = *native;
  EXPECT_FALSE(a.native);
  EXPECT_EQ(a.native_note, "native code turned off by GREYBENCH_NATIVE");
  ASSERT_TRUE(b.native) << b.native_note;
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.evaluations, b.evaluations);
  EXPECT_TRUE(SameValue(a.loglik, b.loglik)) << a.loglik << " vs " << b.loglik;
  ASSERT_EQ(a.parameters.size(), b.parameters.size());
  for (std::size_t i = 0; i < a.parameters.size(); ++i) {
    EXPECT_TRUE(SameValue(a.parameters[i].estimate, b.parameters[i].estimate))
        << a.parameters[i].name;
    ASSERT_EQ(a.parameters[i].std_error.has_value(), b.parameters[i].std_error.has_value());
    if (a.parameters[i].std_error) {
      EXPECT_TRUE(SameValue(*a.parameters[i].std_error, *b.parameters[i].std_error));
    }
  }
  const Json j = b.ToJson();
  EXPECT_EQ(j["filter"]["code"], "native");
  EXPECT_EQ(a.ToJson()["filter"]["code"], "interpreter");
  auto back = estimate::EstimateSummary::FromJson(j, "result.json");
  ASSERT_TRUE(back.ok()) << back.error().ToString();
  EXPECT_TRUE(back->native);
  EXPECT_NE(b.Report().find("Model code: native"), std::string::npos);
  EXPECT_NE(a.Report().find("Model code: interpreter (native code turned off by GREYBENCH_NATIVE)"),
            std::string::npos);
}

TEST(NativeCode, ALibraryCompiledOnceIsLoadedFromTheCache) {
  const fs::path dir = fs::path(::testing::TempDir()) / "greybench-native-cache-test";
  fs::remove_all(dir);
  const ScopedEnv cache("GREYBENCH_NATIVE_CACHE", dir.string());
  const std::vector<NativeCode::Program> programs{{{Parse("a * b + 1").value()}, {}}};
  auto slot_of = [](const std::string& n) { return n == "a" ? 0 : n == "b" ? 1 : -1; };
  auto first = NativeCode::Compile(programs, slot_of);
  ASSERT_TRUE(first.ok()) << first.error().ToString();
  EXPECT_FALSE((*first)->cached());
  auto second = NativeCode::Compile(programs, slot_of);
  ASSERT_TRUE(second.ok()) << second.error().ToString();
  EXPECT_TRUE((*second)->cached());
  const double slots[] = {3.0, 4.0};
  double out = 0;
  (*second)->function(0)(slots, &out);
  EXPECT_EQ(out, 13.0);
  // The library and its source are left in the folder, under one name: no log or partial file.
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir)) files.push_back(e.path().filename().string());
  std::sort(files.begin(), files.end());
  ASSERT_EQ(files.size(), 2u);
  EXPECT_EQ(files[0].substr(files[0].size() - 2), ".c");
  EXPECT_EQ(files[1], files[0].substr(0, files[0].size() - 2) + ".so");
}

TEST(NativeCode, AMissingOrFailingCompilerIsAnErrorThatNamesIt) {
  const fs::path dir = fs::path(::testing::TempDir()) / "greybench-native-compiler-test";
  fs::remove_all(dir);
  const ScopedEnv cache("GREYBENCH_NATIVE_CACHE", dir.string());
  const std::vector<NativeCode::Program> programs{{{Parse("a + 2").value()}, {}}};
  auto slot_of = [](const std::string& n) { return n == "a" ? 0 : -1; };
  {
    const ScopedEnv cc("GREYBENCH_CC", "/nonexistent/greybench-cc");
    auto code = NativeCode::Compile(programs, slot_of);
    ASSERT_FALSE(code.ok());
    EXPECT_NE(code.error().message.find("cannot run the C compiler '/nonexistent/greybench-cc'"),
              std::string::npos)
        << code.error().message;
  }
  EXPECT_TRUE(fs::is_empty(dir));  // nothing left behind where no compiler ran
  {
    const ScopedEnv cc("GREYBENCH_CC", "false");
    auto code = NativeCode::Compile(programs, slot_of);
    ASSERT_FALSE(code.ok());
    EXPECT_NE(code.error().message.find("the C compiler 'false' failed"), std::string::npos)
        << code.error().message;
  }
  // The failing source is kept where the message says, and nothing else (the library's name,
  // and so the kept source's, hashes the compiler too); a working compiler then builds it.
  std::vector<fs::path> left;
  for (const auto& entry : fs::directory_iterator(dir)) left.push_back(entry.path());
  ASSERT_EQ(left.size(), 1u);
  EXPECT_TRUE(left[0].string().ends_with(".failed.c")) << left[0];
  {
    const ScopedEnv cc("GREYBENCH_CC", "false");
    const std::string message = NativeCode::Compile(programs, slot_of).error().message;
    EXPECT_NE(message.find("(kept as " + left[0].string() + ")"), std::string::npos) << message;
  }
  EXPECT_TRUE(NativeCode::Compile(programs, slot_of).ok());
}

TEST(NativeCode, AnUnknownNameIsAnErrorAtItsColumn) {
  const std::vector<NativeCode::Program> programs{{{Parse("a + bb").value()}, {}}};
  auto code = NativeCode::Compile(programs, [](const std::string& n) { return n == "a" ? 0 : -1; });
  ASSERT_FALSE(code.ok());
  EXPECT_EQ(code.error().message, "unknown name 'bb'");
  EXPECT_EQ(code.error().expr_col, 5);
}

TEST(NativeCode, TheEnvironmentTurnsItOff) {
  {
    const ScopedEnv off("GREYBENCH_NATIVE", "0");
    EXPECT_FALSE(NativeCode::Enabled());
  }
  {
    const ScopedEnv on("GREYBENCH_NATIVE", "1");
    EXPECT_TRUE(NativeCode::Enabled());
  }
}

}  // namespace
}  // namespace gb::expr
