// Simplify and Substitute: the identities of expr.h, applied bottom-up by the Make* builders.
//
// Besides the documented identities, the builders move minus signs outwards (a*-b -> -(a*b),
// a + -b -> a - b, -(2*x) -> -2*x). Negation commutes exactly with +, -, * and / and their
// rounding, so these rewrites never change a value; they keep derivatives short and readable.
#include <cmath>
#include <utility>

#include "core/expr/expr.h"
#include "core/expr/internal.h"

namespace gb::expr {
namespace internal {
namespace {

bool IsConst(const ExprPtr& e) { return e->op == Op::kConst; }
bool IsValue(const ExprPtr& e, double v) { return IsConst(e) && e->value == v; }

// log(0), c/0 and overflow stay as written so that evaluation reports them, and ToString of a
// simplified expression always parses.
ExprPtr FoldIfFinite(double v, int column) {
  return std::isfinite(v) ? Constant(v, column) : nullptr;
}

// For a negation in one of the canonical forms -x, c, c*x or c/x with c < 0: the expression
// without its minus sign. Otherwise nullptr.
ExprPtr Positive(const ExprPtr& e) {
  switch (e->op) {
    case Op::kNeg:
      return e->args[0];
    case Op::kConst:
      return e->value < 0 ? Constant(-e->value, e->column) : nullptr;
    case Op::kMul:
    case Op::kDiv: {
      const ExprPtr& c = e->args[0];
      if (!IsConst(c) || !(c->value < 0)) return nullptr;
      if (e->op == Op::kMul && c->value == -1) return e->args[1];
      return MakeNode(e->op, {Constant(-c->value, c->column), e->args[1]}, e->column);
    }
    default:
      return nullptr;
  }
}

ExprPtr MakeSub(const ExprPtr& a, const ExprPtr& b, int column);

ExprPtr MakeAdd(const ExprPtr& a, const ExprPtr& b, int column) {
  if (IsValue(a, 0)) return b;
  if (IsValue(b, 0)) return a;
  if (ExprPtr p = Positive(b)) return MakeSub(a, p, column);
  return MakeNode(Op::kAdd, {a, b}, column);
}

ExprPtr MakeSub(const ExprPtr& a, const ExprPtr& b, int column) {
  if (IsValue(b, 0)) return a;
  if (IsValue(a, 0)) return MakeNeg(b, column);
  if (ExprPtr p = Positive(b)) return MakeAdd(a, p, column);
  return MakeNode(Op::kSub, {a, b}, column);
}

ExprPtr MakeMul(const ExprPtr& a, const ExprPtr& b, int column) {
  if (IsValue(a, 0) || IsValue(b, 0)) return Constant(0.0, column);
  if (IsValue(a, 1)) return b;
  if (IsValue(b, 1)) return a;
  ExprPtr pa = Positive(a);
  ExprPtr pb = Positive(b);
  if (pa || pb) {
    ExprPtr m = MakeMul(pa ? pa : a, pb ? pb : b, column);
    return (pa && pb) ? m : MakeNeg(m, column);
  }
  if (IsConst(b) && !IsConst(a)) return MakeNode(Op::kMul, {b, a}, column);  // 2*x, not x*2
  return MakeNode(Op::kMul, {a, b}, column);
}

ExprPtr MakeDiv(const ExprPtr& a, const ExprPtr& b, int column) {
  if (IsValue(a, 0) && !IsValue(b, 0)) return Constant(0.0, column);
  if (IsValue(b, 1)) return a;
  ExprPtr pa = Positive(a);
  ExprPtr pb = Positive(b);
  if (pa || pb) {
    ExprPtr q = MakeDiv(pa ? pa : a, pb ? pb : b, column);
    return (pa && pb) ? q : MakeNeg(q, column);
  }
  return MakeNode(Op::kDiv, {a, b}, column);
}

// a^0 = 1 and 1^b = 1 hold for every a and b in std::pow, NaN included.
ExprPtr MakePow(const ExprPtr& a, const ExprPtr& b, int column) {
  if (IsValue(b, 0) || IsValue(a, 1)) return Constant(1.0, column);
  if (IsValue(b, 1)) return a;
  return MakeNode(Op::kPow, {a, b}, column);
}

// Rebuilds `e` bottom-up through the builders; `leaf` maps each variable node.
template <class Leaf>
ExprPtr Rebuild(const ExprPtr& e, const Leaf& leaf) {
  switch (e->op) {
    case Op::kConst:
      return e;
    case Op::kVar:
      return leaf(e);
    case Op::kNeg:
      return MakeNeg(Rebuild(e->args[0], leaf), e->column);
    case Op::kCall: {
      std::vector<ExprPtr> args;
      args.reserve(e->args.size());
      for (const ExprPtr& a : e->args) args.push_back(Rebuild(a, leaf));
      return MakeCall(e->func, std::move(args), e->column);
    }
    default:
      return MakeBinary(e->op, Rebuild(e->args[0], leaf), Rebuild(e->args[1], leaf), e->column);
  }
}

}  // namespace

ExprPtr MakeNeg(const ExprPtr& a, int column) {
  if (IsConst(a)) return Constant(-a->value, column);
  if (ExprPtr p = Positive(a)) return p;
  if ((a->op == Op::kMul || a->op == Op::kDiv) && IsConst(a->args[0])) {
    const ExprPtr& c = a->args[0];
    return MakeNode(a->op, {Constant(-c->value, c->column), a->args[1]}, a->column);
  }
  return MakeNode(Op::kNeg, {a}, column);
}

ExprPtr MakeBinary(Op op, const ExprPtr& a, const ExprPtr& b, int column) {
  if (IsConst(a) && IsConst(b)) {
    if (ExprPtr c = FoldIfFinite(ApplyBinary(op, a->value, b->value), column)) return c;
  }
  switch (op) {
    case Op::kAdd:
      return MakeAdd(a, b, column);
    case Op::kSub:
      return MakeSub(a, b, column);
    case Op::kMul:
      return MakeMul(a, b, column);
    case Op::kDiv:
      return MakeDiv(a, b, column);
    case Op::kPow:
      return MakePow(a, b, column);
    default:
      break;
  }
  assert(false && "MakeBinary: not a binary operator");
  return nullptr;
}

ExprPtr MakeCall(Func f, std::vector<ExprPtr> args, int column) {
  assert(static_cast<int>(args.size()) == Info(f).arity && "wrong number of arguments");
  if (f == Func::kPow) return MakeBinary(Op::kPow, args[0], args[1], column);
  bool all_constant = true;
  for (const ExprPtr& a : args) all_constant = all_constant && IsConst(a);
  if (all_constant) {
    const double b = args.size() > 1 ? args[1]->value : 0.0;
    if (ExprPtr c = FoldIfFinite(ApplyFunc(f, args[0]->value, b), column)) return c;
  }
  return MakeRawCall(f, std::move(args), column);
}

}  // namespace internal

ExprPtr Simplify(const ExprPtr& e) {
  return internal::Rebuild(e, [](const ExprPtr& v) { return v; });
}

ExprPtr Substitute(const ExprPtr& e, std::string_view var, const ExprPtr& replacement) {
  const ExprPtr r = Simplify(replacement);
  return internal::Rebuild(e, [&](const ExprPtr& v) { return v->name == var ? r : v; });
}

}  // namespace gb::expr
