// The expression language of model files (user guide §2).
//
//   expr    := sum
//   sum     := product (('+' | '-') product)*
//   product := unary (('*' | '/') unary)*
//   unary   := '-' unary | '+' unary | power
//   power   := atom ('^' unary)?              -- right-associative: a^b^c = a^(b^c); -a^2 = -(a^2)
//   atom    := NUMBER | NAME | NAME '(' expr (',' expr)* ')' | '(' expr ')'
//   NUMBER  := digits ['.' digits] [('e'|'E') ['+'|'-'] digits]   (also '.5', '5.')
//   NAME    := [A-Za-z_][A-Za-z0-9_]*
// Functions: exp log sqrt sin cos tan tanh abs (one argument), pow min max (two arguments).
//
// Expressions are immutable trees shared through `ExprPtr`. Nodes remember the 1-based column
// where they start in the source text, so later checks (an unknown name, a nonlinear term) can
// point at the place. Derived expressions (derivatives, simplifications) keep the column of the
// node they came from where one exists, else 0.
//
// Evaluation for many parameter values goes through `Tape`: a list of expressions compiled once
// into flat stack-machine code over numbered slots; evaluating it walks no strings and no maps.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/util/result.h"

namespace gb::expr {

enum class Op { kConst, kVar, kNeg, kAdd, kSub, kMul, kDiv, kPow, kCall };
enum class Func { kExp, kLog, kSqrt, kSin, kCos, kTan, kTanh, kAbs, kPow, kMin, kMax, kSign };

struct Node;
using ExprPtr = std::shared_ptr<const Node>;

struct Node {
  Op op = Op::kConst;
  double value = 0.0;         // kConst
  std::string name;           // kVar
  Func func = Func::kExp;     // kCall
  std::vector<ExprPtr> args;  // operands: kNeg 1, binary ops 2, kCall 1 or 2
  int column = 0;             // 1-based start column in the source text, 0 if synthetic
};

// Constructors for synthetic expressions (column 0 unless given).
ExprPtr Constant(double value, int column = 0);
ExprPtr Variable(std::string name, int column = 0);

// Parses `text`. On error: Error with expr_col = the 1-based column of the offending character
// (or one past the end for "unexpected end of expression") and a message such as
// "expected ')' to close '(' at column 3", "unknown function 'expp'", "'min' takes 2 arguments",
// "unexpected character '#'", "empty expression". `file`/`path` are left empty for the caller.
// The `sign` function is internal (it appears in derivatives of abs) and is not accepted by Parse.
// Nesting deeper than 256 levels (parentheses, unary minus, a^b^c...) is refused, and so is a
// tree more than 1024 levels tall (a chain a+b+c+... of over 1000 operators, at column of the
// operator that passes the limit): "expression too long: more than 1024 levels of operations".
Result<ExprPtr> Parse(std::string_view text);

// The tallest tree Parse accepts. Every function that walks a tree recurses once per level, so
// code that builds trees (the diagram compiler) keeps to it too.
inline constexpr int kMaxHeight = 1024;

// The size of a tree as every walk sees it: its height (a leaf is 1) and its number of nodes
// with each shared subtree counted every time it occurs (saturating at SIZE_MAX), which is the
// length of its printed form and the work of simplifying it. Found without recursion, visiting
// each shared subtree once, so it is cheap even when `nodes` is astronomical (a diagram whose
// split blocks feed sums doubles the written-out formula at every stage).
struct Extent {
  int height = 0;
  std::size_t nodes = 0;
};
Extent Measure(const ExprPtr& e);

// Text that parses back to an equal tree (except that a negative constant reads back as a negated
// positive one, the same value); minimal parentheses; each number in the shortest form that reads
// back exactly (at most 17 significant digits, integers as "2"). A non-finite constant, which only
// a caller can construct, prints as (1/0), (-1/0) or (0/0).
std::string ToString(const ExprPtr& e);

// Constant folding and algebraic identities: 0+a=a, a*1=a, a*0=0, 0/a=0, a^1=a, a^0=1, -(-a)=a,
// a-0=a, 0-a=-a, a/1=a, and any call or operator whose arguments are all constants. Like other
// symbolic tools it folds a*0 to 0 (this only differs where a is infinite or NaN). It folds only
// to finite values: c/0, log(0) or an overflow are left as they are, so evaluation reports them.
// It also writes pow(a,b) as a^b, moves a constant factor to the left (x*2 -> 2*x) and minus signs
// outwards (a*-b -> -(a*b), a + -b -> a - b, -(2*x) -> -2*x); these never change a value.
ExprPtr Simplify(const ExprPtr& e);

// d e / d var, simplified. Rules: d(a^b) = b*a^(b-1)*a' when b does not depend on var, otherwise
// a^b*(b'*log(a) + b*a'/a); d|a| = sign(a)*a'; d min(a,b) uses `a <= b ? a' : b'` expressed with
// sign: (1 - sign(a-b))/2*a' + (1 + sign(a-b))/2*b'  (and symmetrically for max).
ExprPtr Differentiate(const ExprPtr& e, std::string_view var);

// Replaces every variable named `var` by `replacement`, simplified.
ExprPtr Substitute(const ExprPtr& e, std::string_view var, const ExprPtr& replacement);

// All variable names used in `e` (inserted into *names).
void CollectNames(const ExprPtr& e, std::set<std::string>* names);

// The first (leftmost in source order) variable node of `e` whose name is in `names`, or nullptr.
const Node* FindFirstVariable(const ExprPtr& e, const std::set<std::string>& names);

// True if e is a constant node (after Simplify a constant expression with a finite value is one).
bool IsConstant(const ExprPtr& e, double* value = nullptr);

// Evaluates directly (slow path: for tests and one-off values). `lookup(name)` gives a variable's
// value; it is only called for names present in e.
double EvaluateTree(const ExprPtr& e, const std::function<double(const std::string&)>& lookup);

// A list of expressions compiled to one flat program.
//   Tape tape = Tape::Compile(exprs, slot_of).value();   // slot_of(name) -> slot index or -1
//   tape.Eval(slots, out);                                // out[i] = value of exprs[i]
// `slots` holds variable values by slot index (at least as many as the highest slot used + 1).
// Compile fails (Error with expr_col = the column of the variable) when slot_of returns -1 for a
// name used. Eval does no allocation: it works on a stack array of kMaxStack values, and Compile
// fails (Error with expr_col = the column of the operand that would overflow it) for an expression
// that needs more (only pathological nesting does: a-(b-(c-...)) with over 255 operands).
// Values are bit-for-bit those of EvaluateTree.
class Tape {
 public:
  static constexpr int kMaxStack = 256;

  Tape() = default;
  static Result<Tape> Compile(std::span<const ExprPtr> exprs,
                              const std::function<int(const std::string&)>& slot_of);
  void Eval(std::span<const double> slots, std::span<double> out) const;
  std::size_t size() const { return n_outputs_; }

 private:
  struct Instr {
    int code;  // opcode
    int arg;   // slot index, constant index, or output index
  };
  std::vector<Instr> code_;
  std::vector<double> constants_;
  std::size_t n_outputs_ = 0;
  std::size_t n_slots_ = 0;  // highest slot used + 1
  int max_stack_ = 0;
};

}  // namespace gb::expr
