// Symbolic differentiation by the textbook rules, built through the simplifying builders.
//
// A node whose operands all have the derivative 0 has the derivative 0 (the chain rule with the
// a*0 = 0 convention of Simplify). Checking this first makes the derivative of every term that
// does not mention the variable exactly the constant 0, even for terms such as log(0) that
// Simplify leaves unfolded, which callers rely on to decide "does not depend on".
#include <utility>
#include <vector>

#include "core/expr/expr.h"
#include "core/expr/internal.h"

namespace gb::expr {
namespace {

using internal::MakeBinary;
using internal::MakeCall;
using internal::MakeNeg;

bool IsZero(const ExprPtr& e) {
  double v = 1.0;
  return IsConstant(e, &v) && v == 0.0;
}

// The builders with the column of the node being differentiated.
struct Builder {
  int column;
  ExprPtr Num(double v) const { return Constant(v, column); }
  ExprPtr Neg(const ExprPtr& a) const { return MakeNeg(a, column); }
  ExprPtr Add(const ExprPtr& a, const ExprPtr& b) const {
    return MakeBinary(Op::kAdd, a, b, column);
  }
  ExprPtr Sub(const ExprPtr& a, const ExprPtr& b) const {
    return MakeBinary(Op::kSub, a, b, column);
  }
  ExprPtr Mul(const ExprPtr& a, const ExprPtr& b) const {
    return MakeBinary(Op::kMul, a, b, column);
  }
  ExprPtr Div(const ExprPtr& a, const ExprPtr& b) const {
    return MakeBinary(Op::kDiv, a, b, column);
  }
  ExprPtr Pow(const ExprPtr& a, const ExprPtr& b) const {
    return MakeBinary(Op::kPow, a, b, column);
  }
  ExprPtr Call(Func f, const ExprPtr& a) const { return MakeCall(f, {a}, column); }
};

// d(a^b) for the node e = a^b, given a' and b'.
ExprPtr DiffPow(const Builder& m, const ExprPtr& e, const ExprPtr& a, const ExprPtr& b,
                const ExprPtr& da, const ExprPtr& db) {
  if (IsZero(db)) return m.Mul(m.Mul(b, m.Pow(a, m.Sub(b, m.Num(1)))), da);  // b*a^(b-1)*a'
  // a^b*(b'*log(a) + b*a'/a)
  return m.Mul(e, m.Add(m.Mul(db, m.Call(Func::kLog, a)), m.Div(m.Mul(b, da), a)));
}

// d min(a,b) = (1 - sign(a-b))/2*a' + (1 + sign(a-b))/2*b'; max swaps the signs.
ExprPtr DiffMinMax(const Builder& m, bool is_min, const ExprPtr& a, const ExprPtr& b,
                   const ExprPtr& da, const ExprPtr& db) {
  const ExprPtr s = m.Call(Func::kSign, m.Sub(a, b));
  const ExprPtr one = m.Num(1);
  const ExprPtr two = m.Num(2);
  const ExprPtr wa = m.Div(is_min ? m.Sub(one, s) : m.Add(one, s), two);
  const ExprPtr wb = m.Div(is_min ? m.Add(one, s) : m.Sub(one, s), two);
  return m.Add(m.Mul(wa, da), m.Mul(wb, db));
}

ExprPtr DiffCall(const Builder& m, const ExprPtr& e, const std::vector<ExprPtr>& d) {
  const ExprPtr& a = e->args[0];
  const ExprPtr& da = d[0];
  switch (e->func) {
    case Func::kExp:
      return m.Mul(e, da);
    case Func::kLog:
      return m.Div(da, a);
    case Func::kSqrt:
      return m.Div(da, m.Mul(m.Num(2), e));
    case Func::kSin:
      return m.Mul(m.Call(Func::kCos, a), da);
    case Func::kCos:
      return m.Neg(m.Mul(m.Call(Func::kSin, a), da));
    case Func::kTan:  // 1 + tan^2
      return m.Mul(m.Add(m.Num(1), m.Pow(e, m.Num(2))), da);
    case Func::kTanh:  // 1 - tanh^2
      return m.Mul(m.Sub(m.Num(1), m.Pow(e, m.Num(2))), da);
    case Func::kAbs:
      return m.Mul(m.Call(Func::kSign, a), da);
    case Func::kSign:
      return m.Num(0);
    case Func::kPow:
      return DiffPow(m, e, a, e->args[1], da, d[1]);
    case Func::kMin:
    case Func::kMax:
      return DiffMinMax(m, e->func == Func::kMin, a, e->args[1], da, d[1]);
  }
  return m.Num(0);
}

// `e` is simplified, so every subexpression reused in the result is too.
ExprPtr Diff(const ExprPtr& e, std::string_view var) {
  const Builder m{e->column};
  if (e->op == Op::kConst) return m.Num(0);
  if (e->op == Op::kVar) return m.Num(e->name == var ? 1 : 0);

  std::vector<ExprPtr> d;
  d.reserve(e->args.size());
  bool all_zero = true;
  for (const ExprPtr& arg : e->args) {
    d.push_back(Diff(arg, var));
    all_zero = all_zero && IsZero(d.back());
  }
  if (all_zero) return m.Num(0);

  switch (e->op) {
    case Op::kNeg:
      return m.Neg(d[0]);
    case Op::kAdd:
      return m.Add(d[0], d[1]);
    case Op::kSub:
      return m.Sub(d[0], d[1]);
    case Op::kMul:  // a'*b + a*b'
      return m.Add(m.Mul(d[0], e->args[1]), m.Mul(e->args[0], d[1]));
    case Op::kDiv:  // a'/b - a*b'/b^2
      return m.Sub(m.Div(d[0], e->args[1]),
                   m.Div(m.Mul(e->args[0], d[1]), m.Pow(e->args[1], m.Num(2))));
    case Op::kPow:
      return DiffPow(m, e, e->args[0], e->args[1], d[0], d[1]);
    case Op::kCall:
      return DiffCall(m, e, d);
    default:
      break;
  }
  return m.Num(0);
}

}  // namespace

ExprPtr Differentiate(const ExprPtr& e, std::string_view var) { return Diff(Simplify(e), var); }

}  // namespace gb::expr
