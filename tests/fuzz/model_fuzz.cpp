// libFuzzer target for model files and their expression language.
//
// An input that starts with '{' is a model file: JSON -> ModelSpec (core/model/model.cpp) ->
// ToJson -> ModelSpec again (the round trip must reproduce the same JSON) -> LinearModel
// (symbolic differentiation, the tape) -> the state-space matrices at the start values.
// Any other input is one expression (core/expr):
//   - printing round trip: ToString(Parse(ToString(e))) == ToString(e);
//   - Simplify keeps the value (exactly, where the value is finite and no min/max could have
//     swallowed a NaN that a*0 -> 0 removed) and its text parses back;
//   - the Tape gives bit-for-bit the values of EvaluateTree, for e, Simplify(e) and d e/d name;
//   - Differentiate and Substitute terminate without a sanitizer report.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "core/expr/expr.h"
#include "core/model/linear_model.h"
#include "core/model/model.h"
#include "core/util/json.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

using gb::Json;
namespace expr = gb::expr;

bool SameValue(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

// Values for the names of an expression: distinct, positive and of order one.
double ValueOf(const std::vector<std::string>& names, const std::string& name) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return 0.3 + 0.7 * static_cast<double>(i);
  FUZZ_CHECK(false && "lookup of a name the expression does not use");
  return 0.0;
}

// Evaluates `e` by the tree and by the tape and checks they agree; returns the tree's value.
double EvaluateBothWays(const expr::ExprPtr& e, const std::vector<std::string>& names) {
  const double tree =
      expr::EvaluateTree(e, [&](const std::string& n) { return ValueOf(names, n); });
  const expr::ExprPtr list[] = {e};
  auto tape = expr::Tape::Compile(list, [&](const std::string& n) {
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] == n) return static_cast<int>(i);
    return -1;
  });
  if (!tape.ok()) return tree;  // an expression too deep for the tape's stack (documented)
  std::vector<double> slots(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) slots[i] = ValueOf(names, names[i]);
  double out = 0.0;
  tape->Eval(slots, std::span<double>(&out, 1));
  FUZZ_CHECK(SameValue(tree, out));
  return tree;
}

bool UsesMinOrMax(const expr::ExprPtr& e) {
  if (e->op == expr::Op::kCall && (e->func == expr::Func::kMin || e->func == expr::Func::kMax))
    return true;
  for (const expr::ExprPtr& a : e->args)
    if (UsesMinOrMax(a)) return true;
  return false;
}

void FuzzExpression(std::string_view text) {
  auto parsed = expr::Parse(text);
  if (!parsed.ok()) {
    const gb::Error& error = parsed.error();
    FUZZ_CHECK(!error.message.empty());
    FUZZ_CHECK(error.expr_col >= 1 && static_cast<std::size_t>(error.expr_col) <= text.size() + 1);
    return;
  }
  const expr::ExprPtr& e = *parsed;
  const std::string printed = expr::ToString(e);
  auto reparsed = expr::Parse(printed);
  FUZZ_CHECK(reparsed.ok());
  FUZZ_CHECK(expr::ToString(*reparsed) == printed);

  std::set<std::string> name_set;
  expr::CollectNames(e, &name_set);
  const std::vector<std::string> names(name_set.begin(), name_set.end());
  const double value = EvaluateBothWays(e, names);

  const expr::ExprPtr simple = expr::Simplify(e);
  const double simple_value = EvaluateBothWays(simple, names);
  if (std::isfinite(value) && !UsesMinOrMax(e)) FUZZ_CHECK(simple_value == value);
  FUZZ_CHECK(expr::Parse(expr::ToString(simple)).ok());

  // Derivatives may contain the internal `sign`, so they are not parsed back.
  for (std::size_t i = 0; i < names.size() && i < 3; ++i) {
    const expr::ExprPtr d = expr::Differentiate(e, names[i]);
    (void)expr::ToString(d);
    EvaluateBothWays(d, names);
    const expr::ExprPtr s = expr::Substitute(e, names[i], expr::Constant(1.5));
    (void)expr::ToString(s);
  }
}

void FuzzModel(std::string_view text) {
  const Json j = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return;
  auto spec = gb::model::ParseModel(j, "fuzz.json");
  if (!spec.ok()) {
    FUZZ_CHECK(!spec.error().ToString().empty());
    return;
  }
  const Json written = gb::model::ToJson(*spec);
  auto again = gb::model::ParseModel(written, "fuzz.json");
  FUZZ_CHECK(again.ok());
  FUZZ_CHECK(gb::model::ToJson(*again).dump() == written.dump());

  const std::vector<double> theta = spec->Values();
  auto linear = gb::model::LinearModel::Compile(std::move(spec).value());
  if (!linear.ok()) {
    FUZZ_CHECK(!linear.error().ToString().empty());
    return;
  }
  auto ss = linear->Evaluate(theta);
  if (ss.ok()) {
    FUZZ_CHECK(ss->A.rows() == linear->n_states() && ss->A.cols() == linear->n_states());
    FUZZ_CHECK(ss->C.rows() == linear->n_outputs());
    FUZZ_CHECK(ss->S.size() == linear->n_outputs());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  if (!text.empty() && text.front() == '{') {
    FuzzModel(text);
  } else {
    FuzzExpression(text);
  }
  return 0;
}
