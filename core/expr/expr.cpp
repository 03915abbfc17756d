// Nodes, the function table, printing, queries and the tree evaluator. Parsing is in parse.cpp,
// Simplify/Substitute in simplify.cpp, Differentiate in differentiate.cpp, Tape in tape.cpp.
#include "core/expr/expr.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/expr/internal.h"

namespace gb::expr {
namespace internal {
namespace {

// Indexed by Func.
constexpr std::array<FuncInfo, 12> kFuncs = {{
    {"exp", 1},
    {"log", 1},
    {"sqrt", 1},
    {"sin", 1},
    {"cos", 1},
    {"tan", 1},
    {"tanh", 1},
    {"abs", 1},
    {"pow", 2},
    {"min", 2},
    {"max", 2},
    {"sign", 1},
}};
static_assert(static_cast<int>(Func::kSign) == 11, "kFuncs follows the order of Func");

}  // namespace

FuncInfo Info(Func f) { return kFuncs[static_cast<std::size_t>(f)]; }

std::optional<Func> FindParseableFunc(std::string_view name) {
  for (std::size_t i = 0; i < kFuncs.size(); ++i) {
    const Func f = static_cast<Func>(i);
    if (f != Func::kSign && kFuncs[i].name == name) return f;
  }
  return std::nullopt;
}

ExprPtr MakeNode(Op op, std::vector<ExprPtr> args, int column) {
  auto n = std::make_shared<Node>();
  n->op = op;
  n->args = std::move(args);
  n->column = column;
  return n;
}

ExprPtr MakeRawCall(Func f, std::vector<ExprPtr> args, int column) {
  auto n = std::make_shared<Node>();
  n->op = Op::kCall;
  n->func = f;
  n->args = std::move(args);
  n->column = column;
  return n;
}

}  // namespace internal

ExprPtr Constant(double value, int column) {
  auto n = std::make_shared<Node>();
  n->op = Op::kConst;
  n->value = value;
  n->column = column;
  return n;
}

ExprPtr Variable(std::string name, int column) {
  auto n = std::make_shared<Node>();
  n->op = Op::kVar;
  n->name = std::move(name);
  n->column = column;
  return n;
}

Extent Measure(const ExprPtr& e) {
  // Post-order over an explicit stack: a node is finished once all its operands are.
  constexpr std::size_t kSaturated = std::numeric_limits<std::size_t>::max();
  std::unordered_map<const Node*, Extent> done;
  std::vector<const Node*> stack = {e.get()};
  while (!stack.empty()) {
    const Node* n = stack.back();
    if (done.count(n)) {
      stack.pop_back();
      continue;
    }
    Extent x{0, 1};
    bool ready = true;
    for (const auto& a : n->args) {
      const auto it = done.find(a.get());
      if (it == done.end()) {
        stack.push_back(a.get());
        ready = false;
      } else if (ready) {
        x.height = std::max(x.height, it->second.height);
        x.nodes = it->second.nodes > kSaturated - x.nodes ? kSaturated : x.nodes + it->second.nodes;
      }
    }
    if (!ready) continue;
    ++x.height;
    done[n] = x;
    stack.pop_back();
  }
  return done[e.get()];
}

// ---------------------------------------------------------------------------------------------
// Printing

namespace {

// Binding strength, matching the grammar: an operand binds at least as tightly as its context
// requires or gets parentheses.
enum Prec { kSum = 1, kProduct = 2, kUnary = 3, kPower = 4, kAtom = 5 };

bool IsProduct(const Node& n) { return n.op == Op::kMul || n.op == Op::kDiv; }

Prec PrecOf(const Node& n) {
  switch (n.op) {
    case Op::kAdd:
    case Op::kSub:
      return kSum;
    case Op::kMul:
    case Op::kDiv:
      return kProduct;
    case Op::kNeg:  // -(a*b) is written -a*b, which binds as a product
      return IsProduct(*n.args[0]) ? kProduct : kUnary;
    case Op::kPow:
      return kPower;
    case Op::kConst:
      return std::signbit(n.value) && std::isfinite(n.value) ? kUnary : kAtom;
    default:
      return kAtom;
  }
}

void AppendNumber(double v, std::string* out) {
  // The grammar has no literal for these; the spelled-out division evaluates to the same value.
  if (std::isnan(v)) {
    *out += "(0/0)";
    return;
  }
  if (std::isinf(v)) {
    *out += v > 0 ? "(1/0)" : "(-1/0)";
    return;
  }
  // Shortest text that reads back to exactly v (at most 17 significant digits).
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out->append(buf, r.ptr);
}

void Print(const Node& n, std::string* out);

void PrintOperand(const Node& n, bool parens, std::string* out) {
  if (parens) *out += '(';
  Print(n, out);
  if (parens) *out += ')';
}

void Print(const Node& n, std::string* out) {
  switch (n.op) {
    case Op::kConst:
      AppendNumber(n.value, out);
      return;
    case Op::kVar:
      *out += n.name;
      return;
    case Op::kNeg: {
      // -(a*b) is written -a*b and -(a/b) is -a/b: the parser reads them as (-a)*b and (-a)/b,
      // which are the same numbers, since negation commutes exactly with rounding. A second
      // minus gets a space ("- -x"), not parentheses. Neither adds a level of nesting the
      // source did not have, so text that parsed prints to text that parses (nesting is
      // limited, parse.cpp).
      *out += '-';
      const std::size_t start = out->size();
      PrintOperand(*n.args[0], PrecOf(*n.args[0]) == kSum, out);
      if ((*out)[start] == '-') out->insert(start, 1, ' ');
      return;
    }
    case Op::kCall:
      *out += internal::Info(n.func).name;
      *out += '(';
      for (std::size_t i = 0; i < n.args.size(); ++i) {
        if (i > 0) *out += ", ";
        Print(*n.args[i], out);
      }
      *out += ')';
      return;
    case Op::kPow:  // power := atom '^' unary
      PrintOperand(*n.args[0], PrecOf(*n.args[0]) < kAtom, out);
      *out += '^';
      PrintOperand(*n.args[1], PrecOf(*n.args[1]) < kUnary, out);
      return;
    default:
      break;
  }
  // Left-associative binary operators: the right operand needs parentheses at equal strength.
  const Prec p = PrecOf(n);
  const char* op = n.op == Op::kAdd   ? " + "
                   : n.op == Op::kSub ? " - "
                   : n.op == Op::kMul ? "*"
                                      : "/";
  PrintOperand(*n.args[0], PrecOf(*n.args[0]) < p, out);
  *out += op;
  PrintOperand(*n.args[1], PrecOf(*n.args[1]) <= p, out);
}

}  // namespace

std::string ToString(const ExprPtr& e) {
  std::string out;
  Print(*e, &out);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Queries and the tree evaluator

void CollectNames(const ExprPtr& e, std::set<std::string>* names) {
  if (e->op == Op::kVar) names->insert(e->name);
  for (const ExprPtr& a : e->args) CollectNames(a, names);
}

const Node* FindFirstVariable(const ExprPtr& e, const std::set<std::string>& names) {
  if (e->op == Op::kVar) return names.count(e->name) ? e.get() : nullptr;
  for (const ExprPtr& a : e->args) {
    if (const Node* found = FindFirstVariable(a, names)) return found;
  }
  return nullptr;
}

bool IsConstant(const ExprPtr& e, double* value) {
  if (e->op != Op::kConst) return false;
  if (value) *value = e->value;
  return true;
}

double EvaluateTree(const ExprPtr& e, const std::function<double(const std::string&)>& lookup) {
  switch (e->op) {
    case Op::kConst:
      return e->value;
    case Op::kVar:
      return lookup(e->name);
    case Op::kNeg:
      return -EvaluateTree(e->args[0], lookup);
    case Op::kCall: {
      const double a = EvaluateTree(e->args[0], lookup);
      const double b = e->args.size() > 1 ? EvaluateTree(e->args[1], lookup) : 0.0;
      return internal::ApplyFunc(e->func, a, b);
    }
    default: {
      const double a = EvaluateTree(e->args[0], lookup);
      const double b = EvaluateTree(e->args[1], lookup);
      return internal::ApplyBinary(e->op, a, b);
    }
  }
}

}  // namespace gb::expr
