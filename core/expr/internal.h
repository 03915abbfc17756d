// Shared by the sources of core/expr; not part of the public API.
//
// The arithmetic lives here once so that every evaluator (EvaluateTree, Tape, constant folding in
// Simplify) computes bit-for-bit the same values. The `Make*` builders construct a node from
// already simplified operands and apply the identities of Simplify locally; Simplify, Substitute
// and Differentiate build all their results through them.
#pragma once

#include <cassert>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "core/expr/expr.h"

namespace gb::expr::internal {

struct FuncInfo {
  std::string_view name;
  int arity = 1;
};
FuncInfo Info(Func f);
// The function a model file may call by `name`; `sign` is internal and not found.
std::optional<Func> FindParseableFunc(std::string_view name);

// -1, 0 or 1; sign(±0) = ±0 and sign(NaN) = NaN, so NaN propagates through derivatives of abs.
inline double Sign(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : x); }

// a^b, with the small integer powers as products: a^2 = a a, a^3 = (a a) a, a^4 = (a a)(a a),
// a^-1 = 1 / a, a^-2 = 1 / (a a); std::pow otherwise. Products are some 20 times cheaper than
// std::pow (19 % of the engine model's filter, docs/benchmarks.md) and within 2 units in the
// last place of it (at most two roundings against pow's one; tests/core/expr_test.cpp).
// NativeCode's gb_pow does the same operations in the same order, so native code and the
// interpreter stay equal bit for bit.
inline double Power(double a, double b) {
  if (b == 2.0) return a * a;
  if (b == 3.0) return a * a * a;
  if (b == 4.0) {
    const double s = a * a;
    return s * s;
  }
  if (b == -1.0) return 1.0 / a;
  if (b == -2.0) return 1.0 / (a * a);
  return std::pow(a, b);
}

inline double ApplyBinary(Op op, double a, double b) {
  switch (op) {
    case Op::kAdd:
      return a + b;
    case Op::kSub:
      return a - b;
    case Op::kMul:
      return a * b;
    case Op::kDiv:
      return a / b;
    case Op::kPow:
      return Power(a, b);
    default:
      break;
  }
  assert(false && "ApplyBinary: not a binary operator");
  return 0.0;
}

// `b` is ignored by one-argument functions. min and max return NaN if either argument is NaN
// (std::min would return one or the other depending on the order).
inline double ApplyFunc(Func f, double a, double b) {
  switch (f) {
    case Func::kExp:
      return std::exp(a);
    case Func::kLog:
      return std::log(a);
    case Func::kSqrt:
      return std::sqrt(a);
    case Func::kSin:
      return std::sin(a);
    case Func::kCos:
      return std::cos(a);
    case Func::kTan:
      return std::tan(a);
    case Func::kTanh:
      return std::tanh(a);
    case Func::kAbs:
      return std::fabs(a);
    case Func::kSign:
      return Sign(a);
    case Func::kPow:
      return Power(a, b);
    case Func::kMin:
      return (a <= b || std::isnan(a)) ? a : b;
    case Func::kMax:
      return (a >= b || std::isnan(a)) ? a : b;
  }
  return 0.0;
}

// Structural ids: equal trees get equal ids, whether or not they share memory; ids are dense
// from 0. Common subexpressions are found by them (Tape, NativeCode).
class StructuralIds {
 public:
  int Of(const Node& n);
  int size() const { return static_cast<int>(by_key_.size()); }

 private:
  std::unordered_map<const Node*, int> by_node_;
  std::unordered_map<std::string, int> by_key_;
};

// A node exactly as given, without simplification.
ExprPtr MakeNode(Op op, std::vector<ExprPtr> args, int column);
ExprPtr MakeRawCall(Func f, std::vector<ExprPtr> args, int column);

// Builders over simplified operands; the result is simplified and carries `column` where a new
// node is made.
ExprPtr MakeNeg(const ExprPtr& a, int column);
ExprPtr MakeBinary(Op op, const ExprPtr& a, const ExprPtr& b, int column);
ExprPtr MakeCall(Func f, std::vector<ExprPtr> args, int column);

}  // namespace gb::expr::internal
