// Tape: expressions compiled to postfix code for a stack machine.
//
// Each expression's code is emitted by a post-order walk (operands left to right, then the
// operator) and ends in a store to its output. Operators use the arithmetic of internal.h, the
// same as EvaluateTree, so the two agree bit for bit.
//
// Common subexpressions are computed once per evaluation: every node gets a structural id (equal
// trees, equal ids, whether or not they share memory), and a node met again after its first
// evaluation, anywhere in the tape's expressions, is kept in a temporary when first computed
// (kTee) and pushed from it afterwards (kPushTemp). The derivatives of a model repeat its terms
// many times (the Jacobian of a drift, the derivatives of a parameter's working-coordinate
// expression), so this removes most of the work of evaluating them; the values are unchanged
// (the same operations on the same operands).
#include <algorithm>
#include <bit>
#include <cassert>
#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/expr/expr.h"
#include "core/expr/internal.h"

namespace gb::expr {
namespace {

// Common subexpressions kept per evaluation; beyond, a repeat is recomputed. On Eval's stack.
constexpr int kMaxTemps = 4096;

enum Code : int {
  kPushConst,  // arg: index into constants_
  kPushSlot,   // arg: slot index
  kNeg,
  kAdd,
  kSub,
  kMul,
  kDiv,
  kPow,
  kCall1,     // arg: Func
  kCall2,     // arg: Func
  kStore,     // arg: output index; pops
  kTee,       // arg: temporary index; copies the top of the stack there
  kPushTemp,  // arg: temporary index
};

Code BinaryCode(Op op) {
  switch (op) {
    case Op::kAdd:
      return kAdd;
    case Op::kSub:
      return kSub;
    case Op::kMul:
      return kMul;
    case Op::kDiv:
      return kDiv;
    default:
      return kPow;
  }
}

}  // namespace

namespace internal {

int StructuralIds::Of(const Node& n) {
  if (auto it = by_node_.find(&n); it != by_node_.end()) return it->second;
  std::string key;
  key.reserve(32);
  key += static_cast<char>('a' + static_cast<int>(n.op));
  switch (n.op) {
    case Op::kConst: {
      const auto bits = std::bit_cast<std::uint64_t>(n.value);
      key.append(reinterpret_cast<const char*>(&bits), sizeof bits);
      break;
    }
    case Op::kVar:
      key += n.name;
      break;
    default:
      if (n.op == Op::kCall) key += static_cast<char>('a' + static_cast<int>(n.func));
      for (const ExprPtr& a : n.args) {
        const int child = Of(*a);
        key.append(reinterpret_cast<const char*>(&child), sizeof child);
      }
      break;
  }
  const auto [it, inserted] = by_key_.emplace(std::move(key), static_cast<int>(by_key_.size()));
  by_node_.emplace(&n, it->second);
  return it->second;
}

}  // namespace internal

Result<Tape> Tape::Compile(std::span<const ExprPtr> exprs,
                           const std::function<int(const std::string&)>& slot_of) {
  // Emits code for one tree (a local class, so that it may use the private Instr).
  struct Compiler {
    std::vector<Instr>* code;
    std::vector<double>* constants;
    const std::function<int(const std::string&)>* slot_of;
    internal::StructuralIds ids;
    std::vector<int> uses;  // per id: occurrences evaluated (a node's operands once)
    std::vector<int> temp;  // per id: its temporary, -1 none
    int n_temps = 0;
    int max_slot = -1;
    int height = 0;  // stack height at the current point of the program
    int max_height = 0;
    std::optional<Error> error = std::nullopt;

    bool Push(const Node& n) {
      if (++height > Tape::kMaxStack) {
        Error e = InputError("expression is nested too deeply to evaluate (it needs more than " +
                             std::to_string(Tape::kMaxStack) + " intermediate values)");
        e.expr_col = n.column;
        error = std::move(e);
        return false;
      }
      max_height = std::max(max_height, height);
      return true;
    }

    int ConstantIndex(double v) {
      for (std::size_t i = 0; i < constants->size(); ++i) {  // same bits: one entry
        if (std::bit_cast<std::uint64_t>((*constants)[i]) == std::bit_cast<std::uint64_t>(v)) {
          return static_cast<int>(i);
        }
      }
      constants->push_back(v);
      return static_cast<int>(constants->size()) - 1;
    }

    // Counts, per id, the occurrences the code will evaluate: a node's operands only at its first.
    void Count(const Node& n) {
      const int id = ids.Of(n);
      if (id >= static_cast<int>(uses.size())) uses.resize(static_cast<std::size_t>(id) + 1, 0);
      if (uses[id]++ > 0) return;
      for (const ExprPtr& a : n.args) Count(*a);
    }

    bool Emit(const Node& n) {
      const int id = ids.Of(n);
      if (temp[id] >= 0) {
        if (!Push(n)) return false;
        code->push_back({kPushTemp, temp[id]});
        return true;
      }
      switch (n.op) {
        case Op::kConst:
          if (!Push(n)) return false;
          code->push_back({kPushConst, ConstantIndex(n.value)});
          return true;
        case Op::kVar: {
          const int slot = (*slot_of)(n.name);
          if (slot < 0) {
            Error e = InputError("unknown name '" + n.name + "'");
            e.expr_col = n.column;
            error = std::move(e);
            return false;
          }
          if (!Push(n)) return false;
          max_slot = std::max(max_slot, slot);
          code->push_back({kPushSlot, slot});
          return true;
        }
        default:
          break;
      }
      for (const ExprPtr& a : n.args) {
        if (!Emit(*a)) return false;
      }
      height -= static_cast<int>(n.args.size()) - 1;
      switch (n.op) {
        case Op::kNeg:
          code->push_back({kNeg, 0});
          break;
        case Op::kCall:
          code->push_back({n.args.size() == 1 ? kCall1 : kCall2, static_cast<int>(n.func)});
          break;
        default:
          code->push_back({BinaryCode(n.op), 0});
          break;
      }
      if (uses[id] > 1 && n_temps < kMaxTemps) {
        temp[id] = n_temps++;
        code->push_back({kTee, temp[id]});
      }
      return true;
    }
  };

  Tape tape;
  Compiler c{&tape.code_, &tape.constants_, &slot_of, internal::StructuralIds{}, {}, {}};
  for (const ExprPtr& e : exprs) {
    assert(e && "Tape::Compile: null expression");
    c.Count(*e);
  }
  c.temp.assign(c.uses.size(), -1);
  for (std::size_t i = 0; i < exprs.size(); ++i) {
    assert(exprs[i] && "Tape::Compile: null expression");
    if (!c.Emit(*exprs[i])) return *c.error;
    tape.code_.push_back({kStore, static_cast<int>(i)});
    --c.height;
    assert(c.height == 0);
  }
  tape.n_outputs_ = exprs.size();
  tape.n_slots_ = static_cast<std::size_t>(c.max_slot) + 1;
  tape.max_stack_ = c.max_height;
  return tape;
}

void Tape::Eval(std::span<const double> slots, std::span<double> out) const {
  assert(out.size() == n_outputs_ && "Tape::Eval: one output per compiled expression");
  assert(slots.size() >= n_slots_ && "Tape::Eval: fewer slots than the tape uses");
  // Zeroed so that no path can read an unwritten entry (the compiler checked the tape's
  // height; the analyzer cannot see that). One evaluation per parameter vector: cheap.
  double stack[kMaxStack] = {};
  double temps[kMaxTemps];  // each written (kTee) before it is read (kPushTemp)
  int sp = 0;               // stack[sp - 1] is the top
  for (const Instr& in : code_) {
    switch (in.code) {
      case kPushConst:
        stack[sp++] = constants_[in.arg];
        break;
      case kPushSlot:
        stack[sp++] = slots[in.arg];
        break;
      case kNeg:
        stack[sp - 1] = -stack[sp - 1];
        break;
      case kAdd:
        --sp;
        stack[sp - 1] = stack[sp - 1] + stack[sp];
        break;
      case kSub:
        --sp;
        stack[sp - 1] = stack[sp - 1] - stack[sp];
        break;
      case kMul:
        --sp;
        stack[sp - 1] = stack[sp - 1] * stack[sp];
        break;
      case kDiv:
        --sp;
        stack[sp - 1] = stack[sp - 1] / stack[sp];
        break;
      case kPow:
        --sp;
        stack[sp - 1] = internal::ApplyBinary(Op::kPow, stack[sp - 1], stack[sp]);
        break;
      case kCall1:
        stack[sp - 1] = internal::ApplyFunc(static_cast<Func>(in.arg), stack[sp - 1], 0.0);
        break;
      case kCall2:
        --sp;
        stack[sp - 1] = internal::ApplyFunc(static_cast<Func>(in.arg), stack[sp - 1], stack[sp]);
        break;
      case kStore:
        out[in.arg] = stack[--sp];
        break;
      case kTee:
        temps[in.arg] = stack[sp - 1];
        break;
      case kPushTemp:
        stack[sp++] = temps[in.arg];
        break;
    }
  }
}

}  // namespace gb::expr
