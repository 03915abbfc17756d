// Tests of core/expr: parsing, printing, simplification, differentiation and the tape.
//
// Sections: helpers; ExprParse; ExprParseErrors; ExprToString; ExprSimplify; ExprDifferentiate;
// ExprSubstitute and the queries; ExprTape.
#include "core/expr/expr.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gb::expr {
namespace {

// ---------------------------------------------------------------------------------------------
// Helpers

using Vars = std::map<std::string, double>;

ExprPtr P(std::string_view text) {
  auto r = Parse(text);
  EXPECT_TRUE(r.ok()) << "'" << text << "': " << (r.ok() ? "" : r.error().ToString());
  return r.ok() ? *r : Constant(std::nan(""));
}

double Eval(const ExprPtr& e, const Vars& vars) {
  return EvaluateTree(e, [&](const std::string& name) { return vars.at(name); });
}

double Eval(std::string_view text, const Vars& vars = {}) { return Eval(P(text), vars); }

std::set<std::string> Names(const ExprPtr& e) {
  std::set<std::string> names;
  CollectNames(e, &names);
  return names;
}

std::uint64_t Bits(double v) { return std::bit_cast<std::uint64_t>(v); }

ExprPtr Node2(Op op, ExprPtr a, ExprPtr b) {
  auto n = std::make_shared<Node>();
  n->op = op;
  n->args = {std::move(a), std::move(b)};
  return n;
}

ExprPtr NegOf(ExprPtr a) {
  auto n = std::make_shared<Node>();
  n->op = Op::kNeg;
  n->args = {std::move(a)};
  return n;
}

// Random values for x, y, z in [lo, hi] from a fixed seed.
std::vector<Vars> RandomPoints(int count, double lo, double hi) {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<Vars> points;
  for (int i = 0; i < count; ++i) points.push_back({{"x", u(rng)}, {"y", u(rng)}, {"z", u(rng)}});
  return points;
}

// Smooth, nontrivial expressions of x, y, z, all defined on [0.5, 2]^3 (abs, min and max have
// their kinks away from the random points the tests use, which is checked there).
const std::vector<std::string> kSmoothExpressions = {
    "x*y + sin(x)*cos(y)",
    "x^y",
    "pow(x, y*z)",
    "2^x - x^2.5",
    "log(x*y)/z",
    "sqrt(x^2 + y^2)",
    "tanh(x*y - z)",
    "exp(-x/y)*z",
    "x/(y + z^2)",
    "tan(x/3)",
    "abs(x - 3*y)",
    "min(x, y^2) + max(x*z, y)",
    "(x + y)^3 - 2*x*z",
    "sqrt(log(1 + x*exp(y)))",
    "-x^-2 + 1/(1 + z)",
    "exp(sin(x*y))/(1 + abs(z))",
    "x^(y^z)",
    "1/(x*(1 - y/(z + 3)))",
    "-(x - y)*-(z - x)",
};

// ---------------------------------------------------------------------------------------------
// ExprParse

TEST(ExprParse, AppliesPrecedenceAndAssociativity) {
  EXPECT_EQ(Eval("2^3^2"), 512.0);
  EXPECT_EQ(Eval("-2^2"), -4.0);
  EXPECT_EQ(Eval("2*-3"), -6.0);
  EXPECT_EQ(Eval("1-2-3"), -4.0);
  EXPECT_EQ(Eval("8/4/2"), 1.0);
  EXPECT_EQ(Eval("2+3*4"), 14.0);
  EXPECT_EQ(Eval("(2+3)*4"), 20.0);
  EXPECT_EQ(Eval("2*3^2"), 18.0);
  EXPECT_EQ(Eval("2^3*2"), 16.0);
  EXPECT_EQ(Eval("2^-1"), 0.5);
  EXPECT_EQ(Eval("10/2*5"), 25.0);
  EXPECT_EQ(Eval("1 - -1"), 2.0);
  EXPECT_EQ(Eval("--2"), 2.0);
  EXPECT_EQ(Eval("+2"), 2.0);
  EXPECT_EQ(Eval("-2*3"), -6.0);
  EXPECT_EQ(Eval("(-2)^2"), 4.0);
  EXPECT_EQ(Eval("2^-1^2"), 0.5);  // 2^(-(1^2))
}

TEST(ExprParse, EvaluatesEveryFunction) {
  const double pi = std::numbers::pi;
  EXPECT_DOUBLE_EQ(Eval("exp(1)"), std::numbers::e);
  EXPECT_DOUBLE_EQ(Eval("log(x)", {{"x", std::numbers::e}}), 1.0);
  EXPECT_EQ(Eval("sqrt(16)"), 4.0);
  EXPECT_DOUBLE_EQ(Eval("sin(x)", {{"x", pi / 6}}), 0.5);
  EXPECT_DOUBLE_EQ(Eval("cos(x)", {{"x", pi / 3}}), 0.5);
  EXPECT_DOUBLE_EQ(Eval("tan(x)", {{"x", pi / 4}}), 1.0);
  EXPECT_DOUBLE_EQ(Eval("tanh(x)", {{"x", std::log(3.0)}}), 0.8);  // (9 - 1)/(9 + 1)
  EXPECT_EQ(Eval("abs(-3)"), 3.0);
  EXPECT_EQ(Eval("abs(3)"), 3.0);
  EXPECT_EQ(Eval("pow(2, 10)"), 1024.0);
  EXPECT_EQ(Eval("pow(4, 0.5)"), 2.0);
  EXPECT_EQ(Eval("min(3, -1)"), -1.0);
  EXPECT_EQ(Eval("min(-1, 3)"), -1.0);
  EXPECT_EQ(Eval("max(3, -1)"), 3.0);
  EXPECT_EQ(Eval("max(-1, 3)"), 3.0);
}

// a^2, a^3, a^4, a^-1 and a^-2 are products (internal::Power), some 20 times cheaper than
// std::pow: within 2 units in the last place of it on random finite values over the whole
// range, and its special values exactly (signed zeros, infinities, NaN, overflow).
TEST(ExprParse, SmallIntegerPowersAreProductsWithinTwoUlpsOfPow) {
  auto ulps = [](double a, double b) {
    const auto ia = std::bit_cast<std::int64_t>(a), ib = std::bit_cast<std::int64_t>(b);
    return ia > ib ? ia - ib : ib - ia;
  };
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> mantissa(1.0, 2.0);
  std::uniform_int_distribution<int> exponent(-330, 330);
  const double inf = std::numeric_limits<double>::infinity();
  for (const double k : {2.0, 3.0, 4.0, -1.0, -2.0}) {
    const ExprPtr e = P("x^k");
    std::int64_t worst = 0;
    for (int i = 0; i < 20000; ++i) {
      const double x = (i % 2 ? -1.0 : 1.0) * std::ldexp(mantissa(rng), exponent(rng));
      const double want = std::pow(x, k), got = Eval(e, {{"x", x}, {"k", k}});
      if (!std::isfinite(want) || std::abs(want) < std::numeric_limits<double>::min()) {
        EXPECT_TRUE(want == got || (std::isnan(want) && std::isnan(got)) ||
                    std::abs(got - want) <= std::numeric_limits<double>::denorm_min() * 2)
            << x << "^" << k << ": " << got << " against pow's " << want;
        continue;
      }
      worst = std::max(worst, ulps(got, want));
    }
    EXPECT_LE(worst, 2) << "x^" << k;
    for (const double x : {0.0, -0.0, inf, -inf, std::nan(""), 1e300, -1e300, 1e-300}) {
      const double want = std::pow(x, k), got = Eval(e, {{"x", x}, {"k", k}});
      EXPECT_TRUE(std::bit_cast<std::uint64_t>(want) == std::bit_cast<std::uint64_t>(got) ||
                  (std::isnan(want) && std::isnan(got)))
          << x << "^" << k << ": " << got << " against pow's " << want;
    }
  }
}

TEST(ExprParse, ReadsEveryNumberForm) {
  EXPECT_EQ(Eval(".5"), 0.5);
  EXPECT_EQ(Eval("5."), 5.0);
  EXPECT_EQ(Eval("007"), 7.0);
  EXPECT_EQ(Eval("1e-3"), 0.001);
  EXPECT_EQ(Eval("1E+2"), 100.0);
  EXPECT_EQ(Eval("2.5e1"), 25.0);
  EXPECT_EQ(Eval("0.1"), 0.1);
}

TEST(ExprParse, AcceptsSpacesAndTabsBetweenTokens) {
  EXPECT_EQ(Eval(" \t2 *\tx + exp ( 0 ) ", {{"x", 3.0}}), 7.0);
  EXPECT_EQ(Eval("min( 1 ,2 )"), 1.0);
}

TEST(ExprParse, TreatsNamesCaseSensitively) {
  EXPECT_EQ(Eval("X - x", {{"X", 5.0}, {"x", 2.0}}), 3.0);
  EXPECT_EQ(Names(P("tau_fv + x2 + _a")), (std::set<std::string>{"tau_fv", "x2", "_a"}));
  EXPECT_FALSE(Parse("Exp(1)").ok());
}

TEST(ExprParse, AllowsFunctionNamesAsVariables) { EXPECT_EQ(Eval("max + 1", {{"max", 2.0}}), 3.0); }

TEST(ExprParse, RecordsTheColumnWhereEachNodeStarts) {
  const ExprPtr e = P("a + -b*c");
  EXPECT_EQ(e->column, 1);
  ASSERT_EQ(e->op, Op::kAdd);
  const ExprPtr& product = e->args[1];
  ASSERT_EQ(product->op, Op::kMul);
  EXPECT_EQ(product->column, 5);
  EXPECT_EQ(product->args[0]->op, Op::kNeg);
  EXPECT_EQ(product->args[0]->args[0]->column, 6);
  EXPECT_EQ(product->args[1]->column, 8);
}

// ---------------------------------------------------------------------------------------------
// ExprParseErrors

struct BadInput {
  const char* text;
  int column;
  const char* message;
};

TEST(ExprParseErrors, ReportColumnAndReadableMessage) {
  const BadInput cases[] = {
      {"", 1, "empty expression"},
      {" \t ", 1, "empty expression"},
      {"2 3", 3, "unexpected '3'"},
      {"a b", 3, "unexpected 'b'"},
      {"(1+2", 5, "expected ')' to close '(' at column 1"},
      {"(1 2)", 4, "expected ')' to close '(' at column 1"},
      {"exp(x", 6, "expected ')' to close '(' at column 4"},
      {"1+2)", 4, "unmatched ')'"},
      {"()", 2, "unexpected ')'"},
      {"max(1, )", 8, "unexpected ')'"},
      {"2 +", 4, "unexpected end of expression"},
      {"x^", 3, "unexpected end of expression"},
      {"2 * * 3", 5, "unexpected '*'"},
      {"a + # b", 5, "unexpected character '#'"},
      {"expp(x)", 1, "unknown function 'expp'"},
      {"1 + Sin(x)", 5, "unknown function 'Sin'"},
      {"sign(x)", 1, "unknown function 'sign'"},
      {"min(1)", 1, "'min' takes 2 arguments"},
      {"2*exp(1, 2)", 3, "'exp' takes 1 argument"},
      {"sin()", 1, "'sin' takes 1 argument"},
      {"1e", 3, "malformed number '1e': the exponent has no digits"},
      {"1e+", 4, "malformed number '1e+': the exponent has no digits"},
      {"1.2.3", 4, "malformed number '1.2.3'"},
      {"2x", 2, "missing operator between '2' and 'x'"},
      {"1e999", 1, "number '1e999' is out of range"},
  };
  for (const BadInput& c : cases) {
    auto r = Parse(c.text);
    ASSERT_FALSE(r.ok()) << "'" << c.text << "' parsed";
    EXPECT_EQ(r.error().expr_col, c.column) << "'" << c.text << "'";
    EXPECT_EQ(r.error().message, c.message) << "'" << c.text << "'";
    EXPECT_EQ(r.error().kind, ErrorKind::kInput);
  }
}

TEST(ExprParseErrors, PrintWithTheColumn) {
  auto r = Parse("2 3");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().ToString(), "column 3: unexpected '3'");
}

TEST(ExprParseErrors, RefuseNestingDeeperThanTheLimit) {
  const std::string deep = std::string(300, '(') + "1" + std::string(300, ')');
  auto r = Parse(deep);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("nested too deeply"), std::string::npos);
  EXPECT_GT(r.error().expr_col, 1);

  const std::string fine = std::string(100, '(') + "1" + std::string(100, ')');
  EXPECT_EQ(Eval(fine), 1.0);
}

// Found by review for tests/fuzz/model_fuzz: a long chain is one tree level per operator, and
// every walk of the tree (even freeing it) recursed that deep; a 2 MB sum overflowed the stack.
TEST(ExprParseErrors, RefuseChainsTallerThanTheLimitAtTheOperator) {
  std::string sum = "x";
  for (int i = 0; i < 1'000'000; ++i) sum += "+x";
  auto r = Parse(sum);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("expression too long"), std::string::npos);
  // 1024 levels: 1023 operators fit, the 1024th '+' (at column 2*1024) is refused.
  EXPECT_EQ(r.error().expr_col, 2 * 1024);

  std::string product = "-y";
  for (int i = 0; i < 5000; ++i) product += "*y^2";
  EXPECT_FALSE(Parse(product).ok());

  // 1000 terms are fine, and so is any length grouped in parentheses.
  std::string fine = "1";
  for (int i = 0; i < 999; ++i) fine += "+1";
  EXPECT_EQ(Eval(fine), 1000.0);
  std::string grouped;
  for (int g = 0; g < 100; ++g) {
    grouped += g == 0 ? "(1" : "+(1";
    for (int i = 0; i < 99; ++i) grouped += "+1";
    grouped += ")";
  }
  EXPECT_EQ(Eval(grouped), 10000.0);
}

// ---------------------------------------------------------------------------------------------
// ExprToString

TEST(ExprToString, UsesMinimalParentheses) {
  EXPECT_EQ(ToString(P("((a))+((b*c))")), "a + b*c");
  EXPECT_EQ(ToString(P("(a+b)*c")), "(a + b)*c");
  EXPECT_EQ(ToString(P("a-(b+c)")), "a - (b + c)");
  EXPECT_EQ(ToString(P("a+(b+c)")), "a + (b + c)");  // kept: floating point is not associative
  EXPECT_EQ(ToString(P("(a-b)-c")), "a - b - c");
  EXPECT_EQ(ToString(P("a/(b*c)")), "a/(b*c)");
  EXPECT_EQ(ToString(P("(a/b)*c")), "a/b*c");
  EXPECT_EQ(ToString(P("-(a*b)")), "-a*b");  // (-a)*b: the same number
  EXPECT_EQ(ToString(P("-(a/b)*c")), "-a/b*c");
  EXPECT_EQ(ToString(P("-(a + b)")), "-(a + b)");
  EXPECT_EQ(ToString(P("-(a^b)")), "-a^b");
  EXPECT_EQ(ToString(P("(-a)^b")), "(-a)^b");
  EXPECT_EQ(ToString(P("a^(b^c)")), "a^b^c");
  EXPECT_EQ(ToString(P("(a^b)^c")), "(a^b)^c");
  EXPECT_EQ(ToString(P("a^(-b)")), "a^-b");
  EXPECT_EQ(ToString(P("a*(-b)")), "a*-b");
  EXPECT_EQ(ToString(P("-(-a)")), "- -a");
  EXPECT_EQ(ToString(P("-(-2*a)")), "- -2*a");
  EXPECT_EQ(ToString(P("c^-(a*b)")), "c^(-a*b)");
  EXPECT_EQ(ToString(P("c*-(a*b)")), "c*(-a*b)");
  EXPECT_EQ(ToString(P("c - -(a*b)")), "c - -a*b");
  EXPECT_EQ(ToString(P("exp(-x) + min(a, b)")), "exp(-x) + min(a, b)");
}

TEST(ExprToString, PrintsNumbersExactlyAndIntegersPlainly) {
  EXPECT_EQ(ToString(Constant(2.0)), "2");
  EXPECT_EQ(ToString(Constant(-3.0)), "-3");
  EXPECT_EQ(ToString(Constant(0.1)), "0.1");
  for (double v : {1.0 / 3.0, std::numbers::pi, 1e-300, 6.02214076e23, 4.9e-324, -0.1}) {
    const ExprPtr e = P(ToString(Constant(v)));
    EXPECT_EQ(Bits(Eval(e, {})), Bits(v)) << ToString(Constant(v));
  }
}

TEST(ExprToString, ParenthesizesSyntheticNegativeConstants) {
  const ExprPtr x = Variable("x");
  EXPECT_EQ(ToString(Node2(Op::kPow, Constant(-2.0), x)), "(-2)^x");
  EXPECT_EQ(ToString(Node2(Op::kPow, x, Constant(-2.0))), "x^-2");
  EXPECT_EQ(ToString(Node2(Op::kSub, x, Constant(-2.0))), "x - -2");
  EXPECT_EQ(ToString(NegOf(Constant(-2.0))), "- -2");
}

// Found by tests/fuzz/model_fuzz (CI, 2026-11-22): "-(-(-x))" was printed for "---x", two
// levels of nesting per minus, so 130 minus signs printed to text over the nesting limit.
TEST(ExprToString, NeverNestsDeeperThanTheTextItWasParsedFrom) {
  for (const std::string& text :
       {"2 - " + std::string(250, '-') + "x", std::string(255, '-') + "x*y",
        "a^-" + std::string(200, '-') + "(b*c)",
        std::string(127, '(') + "-x*-y" + std::string(127, ')')}) {
    auto e = Parse(text);
    ASSERT_TRUE(e.ok()) << e.error().ToString();
    auto again = Parse(ToString(*e));
    ASSERT_TRUE(again.ok()) << again.error().ToString();
    EXPECT_EQ(ToString(*again), ToString(*e));
    auto simple = Parse(ToString(Simplify(*e)));
    EXPECT_TRUE(simple.ok()) << simple.error().ToString();
  }
}

TEST(ExprToString, RoundTripsToIdenticalValues) {
  std::vector<ExprPtr> exprs;
  for (const std::string& t : kSmoothExpressions) exprs.push_back(P(t));
  const ExprPtr x = Variable("x"), y = Variable("y"), z = Variable("z");
  exprs.push_back(Node2(Op::kSub, x, Node2(Op::kSub, y, z)));
  exprs.push_back(Node2(Op::kAdd, x, Node2(Op::kAdd, y, z)));
  exprs.push_back(Node2(Op::kDiv, x, Node2(Op::kDiv, y, z)));
  exprs.push_back(Node2(Op::kPow, Node2(Op::kPow, x, y), z));
  exprs.push_back(Node2(Op::kPow, NegOf(x), Constant(3.0)));
  exprs.push_back(Node2(Op::kMul, Constant(-0.7), Node2(Op::kAdd, x, Constant(-1e-7))));
  exprs.push_back(NegOf(NegOf(Node2(Op::kPow, x, NegOf(y)))));
  // A negated product prints as a product (-x*y): every place it can stand.
  const ExprPtr neg_xy = NegOf(Node2(Op::kMul, x, y));
  const ExprPtr neg_x_over_y = NegOf(Node2(Op::kDiv, x, y));
  for (const ExprPtr& n : {neg_xy, neg_x_over_y, NegOf(Node2(Op::kMul, Constant(-2.0), x))}) {
    exprs.push_back(n);
    exprs.push_back(NegOf(n));
    for (Op op : {Op::kAdd, Op::kSub, Op::kMul, Op::kDiv, Op::kPow}) {
      exprs.push_back(Node2(op, n, z));
      exprs.push_back(Node2(op, z, n));
    }
  }
  for (const char* v : {"x", "y", "z"}) exprs.push_back(Differentiate(exprs[1], v));

  for (const ExprPtr& e : exprs) {
    const std::string text = ToString(e);
    auto again = Parse(text);
    ASSERT_TRUE(again.ok()) << text << ": " << again.error().ToString();
    EXPECT_EQ(ToString(*again), text);
    for (const Vars& at : RandomPoints(5, 0.5, 2.0)) {
      EXPECT_EQ(Bits(Eval(*again, at)), Bits(Eval(e, at))) << text;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// ExprSimplify

TEST(ExprSimplify, FoldsConstantOperationsAndCalls) {
  double v = 0.0;
  EXPECT_TRUE(IsConstant(Simplify(P("2*3 + 1")), &v));
  EXPECT_EQ(v, 7.0);
  EXPECT_TRUE(IsConstant(Simplify(P("exp(0) + pow(2, 10) + min(2, -3) + -(4)")), &v));
  EXPECT_EQ(v, 1.0 + 1024.0 - 3.0 - 4.0);
  EXPECT_TRUE(IsConstant(Simplify(P("x*0 + sqrt(9)")), &v));
  EXPECT_EQ(v, 3.0);
}

TEST(ExprSimplify, AppliesTheDocumentedIdentities) {
  const std::pair<const char*, const char*> cases[] = {
      {"x + 0", "x"},       {"0 + x", "x"},     {"x*1", "x"},        {"1*x", "x"},
      {"x*0", "0"},         {"0*x", "0"},       {"0/x", "0"},        {"x^1", "x"},
      {"x^0", "1"},         {"1^x", "1"},       {"-(-x)", "x"},      {"x - 0", "x"},
      {"0 - x", "-x"},      {"x/1", "x"},       {"x + -y", "x - y"}, {"x - -y", "x + y"},
      {"x*2", "2*x"},       {"-(2*x)", "-2*x"}, {"x*-y", "-x*y"},    {"-x/-y", "x/y"},
      {"pow(x, 2)", "x^2"},
  };
  for (const auto& [in, out] : cases) EXPECT_EQ(ToString(Simplify(P(in))), out) << in;
}

TEST(ExprSimplify, LeavesNonFiniteConstantsForEvaluationToReport) {
  for (const char* text : {"1/0", "0/0", "log(0)", "sqrt(-1)", "1e300*1e300", "0/0*0 + 1/0"}) {
    const ExprPtr s = Simplify(P(text));
    EXPECT_FALSE(IsConstant(s)) << text;
    EXPECT_FALSE(std::isfinite(Eval(s, {}))) << text;
    EXPECT_TRUE(Parse(ToString(s)).ok()) << ToString(s);
  }
}

TEST(ExprSimplify, PreservesValues) {
  for (const std::string& t : kSmoothExpressions) {
    const ExprPtr e = P(t);
    const ExprPtr s = Simplify(e);
    for (const Vars& at : RandomPoints(5, 0.5, 2.0)) EXPECT_EQ(Eval(s, at), Eval(e, at)) << t;
  }
}

// ---------------------------------------------------------------------------------------------
// ExprDifferentiate

constexpr double kFdRelativeStep = 1e-5;
constexpr double kFdTolerance = 1e-6;  // relative to 1 + |derivative|

TEST(ExprDifferentiate, MatchesCentralFiniteDifferences) {
  const std::vector<Vars> points = RandomPoints(20, 0.5, 2.0);
  for (const std::string& t : kSmoothExpressions) {
    const ExprPtr e = P(t);
    for (const char* v : {"x", "y", "z"}) {
      const ExprPtr d = Differentiate(e, v);
      for (const Vars& at : points) {
        if (std::abs(at.at("x") - 3 * at.at("y")) < 0.05) continue;  // kink of abs(x - 3*y)
        if (std::abs(at.at("x") - at.at("y") * at.at("y")) < 0.05) continue;  // of min(x, y^2)
        if (std::abs(at.at("x") * at.at("z") - at.at("y")) < 0.05) continue;  // of max(x*z, y)
        const double h = kFdRelativeStep * std::max(1.0, std::abs(at.at(v)));
        Vars up = at, down = at;
        up[v] += h;
        down[v] -= h;
        const double fd = (Eval(e, up) - Eval(e, down)) / (2 * h);
        const double exact = Eval(d, at);
        EXPECT_NEAR(exact, fd, kFdTolerance * (1 + std::abs(fd)))
            << "d/d" << v << " of " << t << " = " << ToString(d);
      }
    }
  }
}

TEST(ExprDifferentiate, MatchesClosedForms) {
  const Vars at = {{"x", 0.7}, {"y", 1.3}};
  const double x = 0.7, y = 1.3;
  EXPECT_DOUBLE_EQ(Eval(Differentiate(P("x^3"), "x"), at), 3 * x * x);
  EXPECT_DOUBLE_EQ(Eval(Differentiate(P("x^y"), "y"), at), std::pow(x, y) * std::log(x));
  EXPECT_DOUBLE_EQ(Eval(Differentiate(P("log(x)"), "x"), at), 1 / x);
  EXPECT_DOUBLE_EQ(Eval(Differentiate(P("sqrt(x)"), "x"), at), 0.5 / std::sqrt(x));
  // 1 - tanh^2 and 1 + tan^2 against 1/cosh^2 and 1/cos^2: equal up to a few roundings.
  EXPECT_NEAR(Eval(Differentiate(P("tanh(x)"), "x"), at), 1 / std::pow(std::cosh(x), 2), 1e-14);
  EXPECT_NEAR(Eval(Differentiate(P("tan(x)"), "x"), at), 1 / std::pow(std::cos(x), 2), 1e-14);
  EXPECT_DOUBLE_EQ(Eval(Differentiate(P("y/x"), "x"), at), -y / (x * x));
  EXPECT_EQ(Eval(Differentiate(P("abs(x)"), "x"), {{"x", -2.0}}), -1.0);
  EXPECT_EQ(Eval(Differentiate(P("abs(x)"), "x"), {{"x", 3.0}}), 1.0);
  EXPECT_EQ(Eval(Differentiate(P("min(x, y)"), "x"), at), 1.0);
  EXPECT_EQ(Eval(Differentiate(P("min(x, y)"), "y"), at), 0.0);
  EXPECT_EQ(Eval(Differentiate(P("max(x, y)"), "x"), at), 0.0);
  EXPECT_EQ(Eval(Differentiate(P("max(x, y)"), "y"), at), 1.0);
  EXPECT_EQ(ToString(Differentiate(P("x^2"), "x")), "2*x");
  EXPECT_EQ(ToString(Differentiate(P("3*x + 1"), "x")), "3");
}

TEST(ExprDifferentiate, GivesExactlyZeroForTermsWithoutTheVariable) {
  for (const char* text : {"a*b + exp(c)", "7", "y", "log(0) + 1/0*y", "abs(min(a, b))^c"}) {
    double v = 1.0;
    EXPECT_TRUE(IsConstant(Differentiate(P(text), "x"), &v)) << text;
    EXPECT_EQ(v, 0.0) << text;
  }
}

TEST(ExprDifferentiate, GivesStateFreeCoefficientsForAffineModels) {
  const Vars par = {{"Ci", 1.7}, {"Rim", 0.3}, {"Rh", 2.2}, {"tau_fv", 0.08},
                    {"X", 0.2},  {"a", 1.5},   {"b", 0.4},  {"c", 9.0}};

  const ExprPtr room = P("1/(Ci*Rim)*(Tm-x) + 1/Ci*Rh*u");
  const ExprPtr room_x = Differentiate(room, "x");
  const ExprPtr room_u = Differentiate(room, "u");
  EXPECT_EQ(Names(room_x), (std::set<std::string>{"Ci", "Rim"}));
  EXPECT_EQ(Names(room_u), (std::set<std::string>{"Ci", "Rh"}));
  EXPECT_DOUBLE_EQ(Eval(room_x, par), -1 / (1.7 * 0.3));
  EXPECT_DOUBLE_EQ(Eval(room_u, par), 2.2 / 1.7);

  const ExprPtr film = P("(-mfv + (1 - X)*mfi)/tau_fv");
  const ExprPtr film_mfv = Differentiate(film, "mfv");
  const ExprPtr film_mfi = Differentiate(film, "mfi");
  EXPECT_EQ(Names(film_mfv), (std::set<std::string>{"tau_fv"}));
  EXPECT_EQ(Names(film_mfi), (std::set<std::string>{"X", "tau_fv"}));
  EXPECT_DOUBLE_EQ(Eval(film_mfv, par), -1 / 0.08);
  EXPECT_DOUBLE_EQ(Eval(film_mfi, par), (1 - 0.2) / 0.08);

  const ExprPtr lin = Differentiate(P("a*x - b*(x - c)"), "x");
  EXPECT_EQ(Names(lin), (std::set<std::string>{"a", "b"}));
  EXPECT_DOUBLE_EQ(Eval(lin, par), 1.5 - 0.4);
}

TEST(ExprDifferentiate, KeepsTheVariableInNonlinearTerms) {
  EXPECT_TRUE(Names(Differentiate(P("a*x*x"), "x")).count("x"));
  EXPECT_TRUE(Names(Differentiate(P("x*u"), "x")).count("u"));
  EXPECT_TRUE(Names(Differentiate(P("exp(-x/tau)"), "x")).count("x"));
  EXPECT_TRUE(Names(Differentiate(P("sqrt(x)"), "x")).count("x"));
}

// ---------------------------------------------------------------------------------------------
// ExprSubstitute and the queries

TEST(ExprSubstitute, ReplacesEveryOccurrence) {
  const ExprPtr e = Substitute(P("x*y + exp(x)"), "x", P("2*z"));
  EXPECT_EQ(Names(e), (std::set<std::string>{"y", "z"}));
  EXPECT_DOUBLE_EQ(Eval(e, {{"y", 3.0}, {"z", 0.25}}), 0.5 * 3.0 + std::exp(0.5));
}

TEST(ExprSubstitute, SimplifiesTheResult) {
  EXPECT_EQ(ToString(Substitute(P("a*x + b"), "x", Constant(0.0))), "b");
  EXPECT_EQ(ToString(Substitute(P("(-mfv + (1 - X)*mfi)/tau"), "mfv", Constant(0.0))),
            "(1 - X)*mfi/tau");
  double v = 0.0;
  EXPECT_TRUE(IsConstant(Substitute(P("x^2 + 1"), "x", Constant(3.0)), &v));
  EXPECT_EQ(v, 10.0);
}

TEST(ExprCollectNames, FindsEveryNameOnce) {
  std::set<std::string> names = {"already"};
  CollectNames(P("a*exp(b) + min(c, a) - 2"), &names);
  EXPECT_EQ(names, (std::set<std::string>{"already", "a", "b", "c"}));
  EXPECT_TRUE(Names(P("1 + 2")).empty());
}

TEST(ExprFindFirstVariable, ReturnsTheLeftmostMatchInTheSource) {
  const ExprPtr e = P("k*(y + x) + x");
  const Node* n = FindFirstVariable(e, {"x", "y"});
  ASSERT_NE(n, nullptr);
  EXPECT_EQ(n->name, "y");
  EXPECT_EQ(n->column, 4);
  n = FindFirstVariable(e, {"x"});
  ASSERT_NE(n, nullptr);
  EXPECT_EQ(n->column, 8);
  EXPECT_EQ(FindFirstVariable(e, {"z"}), nullptr);
}

TEST(ExprIsConstant, RecognizesOnlyConstantNodes) {
  double v = 0.0;
  EXPECT_TRUE(IsConstant(P("2.5"), &v));
  EXPECT_EQ(v, 2.5);
  EXPECT_TRUE(IsConstant(P("2.5")));
  EXPECT_FALSE(IsConstant(P("x")));
  EXPECT_FALSE(IsConstant(P("1 + 1")));  // before Simplify
}

// ---------------------------------------------------------------------------------------------
// ExprTape

int SlotOfXyz(const std::string& name) {
  if (name == "x") return 0;
  if (name == "y") return 1;
  if (name == "z") return 2;
  return -1;
}

TEST(ExprTape, MatchesEvaluateTreeBitForBit) {
  std::vector<ExprPtr> exprs;
  for (const std::string& t : kSmoothExpressions) {
    exprs.push_back(P(t));
    for (const char* v : {"x", "y", "z"}) exprs.push_back(Differentiate(exprs.back(), v));
  }
  for (const char* t : {"log(x - 1)", "sqrt(y - 1)", "x/(y - y)", "min(x, 1/0)", "-0*x", "7"})
    exprs.push_back(P(t));
  auto tape = Tape::Compile(exprs, SlotOfXyz);
  ASSERT_TRUE(tape.ok()) << tape.error().ToString();
  ASSERT_EQ(tape->size(), exprs.size());

  std::vector<double> out(exprs.size());
  for (const Vars& at : RandomPoints(50, 0.3, 2.0)) {
    const double slots[] = {at.at("x"), at.at("y"), at.at("z")};
    tape->Eval(slots, out);
    for (std::size_t i = 0; i < exprs.size(); ++i)
      EXPECT_EQ(Bits(out[i]), Bits(Eval(exprs[i], at))) << ToString(exprs[i]);
  }
}

TEST(ExprTape, ReadsVariablesFromTheirSlots) {
  const ExprPtr exprs[] = {P("b - a"), P("2^c"), P("1.5")};
  auto tape = Tape::Compile(exprs, [](const std::string& name) {
    return name == "a" ? 2 : name == "b" ? 0 : name == "c" ? 1 : -1;
  });
  ASSERT_TRUE(tape.ok());
  const double slots[] = {10.0, 3.0, 4.0};
  double out[3] = {};
  tape->Eval(slots, out);
  EXPECT_EQ(out[0], 6.0);
  EXPECT_EQ(out[1], 8.0);
  EXPECT_EQ(out[2], 1.5);
}

TEST(ExprTape, ReportsColumnOfUnknownName) {
  const ExprPtr exprs[] = {P("x + 1"), P("x + y*zz")};
  auto tape = Tape::Compile(exprs, SlotOfXyz);
  ASSERT_FALSE(tape.ok());
  EXPECT_EQ(tape.error().expr_col, 7);
  EXPECT_EQ(tape.error().message, "unknown name 'zz'");
}

TEST(ExprTape, RefusesExpressionsNeedingMoreThanItsStack) {
  // x + x*(x + x*(...)) keeps two values on the stack per level.
  std::string text = "x";
  for (int i = 0; i < 150; ++i) text = "x + x*(" + text + ")";
  const ExprPtr e = P(text);
  auto tape = Tape::Compile(std::span<const ExprPtr>(&e, 1), SlotOfXyz);
  ASSERT_FALSE(tape.ok());
  EXPECT_NE(tape.error().message.find("nested too deeply"), std::string::npos);
  EXPECT_GT(tape.error().expr_col, 1);

  std::string shallow = "x";
  for (int i = 0; i < 100; ++i) shallow = "x + x*(" + shallow + ")";
  const ExprPtr ok = P(shallow);
  EXPECT_TRUE(Tape::Compile(std::span<const ExprPtr>(&ok, 1), SlotOfXyz).ok());
}

TEST(ExprMeasure, CountsHeightAndWrittenOutNodesWithoutExpandingSharedSubtrees) {
  auto e = Parse("a + b*c");
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(Measure(*e).height, 3);
  EXPECT_EQ(Measure(*e).nodes, 5u);
  // s_{k+1} = s_k + s_k, shared: 2^(k+1) - 1 nodes written out, k + 1 levels.
  ExprPtr s = Variable("u");
  for (int k = 0; k < 20; ++k) {
    auto n = std::make_shared<Node>();
    n->op = Op::kAdd;
    n->args = {s, s};
    s = n;
  }
  EXPECT_EQ(Measure(s).height, 21);
  EXPECT_EQ(Measure(s).nodes, (std::size_t{1} << 21) - 1);
  for (int k = 20; k < 200; ++k) {  // 2^200 nodes: the count saturates, in 200 steps
    auto n = std::make_shared<Node>();
    n->op = Op::kAdd;
    n->args = {s, s};
    s = n;
  }
  EXPECT_EQ(Measure(s).height, 201);
  EXPECT_EQ(Measure(s).nodes, std::numeric_limits<std::size_t>::max());
}

}  // namespace
}  // namespace gb::expr
