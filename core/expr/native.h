// Expressions compiled to machine code: C generated from the expression graph, compiled by the
// system's C compiler into a shared library and loaded with dlopen (issue 37).
//
//   NativeCode::Program p{exprs, positions, dense_size};       // positions empty: out[i] =
//   exprs[i] auto code = NativeCode::Compile({p, ...}, slot_of);         // Result<shared_ptr<const
//   NativeCode>> code.value()->function(0)(slots.data(), out.data());
//
// Each program becomes one C function `void f(const double* slots, double* out)` that computes
// every distinct subexpression once (structural identity, as Tape's common subexpressions) and
// writes expression i to out[positions[i]] (out[i] without positions). The C code performs the
// operations of Tape::Eval in the same order on the same operands, calls the same C library
// functions (exp, log, pow, ...) and is compiled without contraction into fused multiply-adds
// (-ffp-contract=off) or other value-changing optimisations, so its values are bit for bit
// Tape::Eval's (and EvaluateTree's): tests/core/native_test.cpp checks that on every bundled
// model's programs.
//
// Why C and the system compiler, not LLVM's ORC JIT: docs/benchmarks.md ("Native code for the
// model", issue 37) has the measurement.
//
// The compiler: $GREYBENCH_CC, else $CC, else `cc` on the PATH; flags -O2 -fPIC -shared
// -ffp-contract=off. The library is kept in a cache folder under the source's hash:
// $GREYBENCH_NATIVE_CACHE, else $XDG_CACHE_HOME/greybench/native, else ~/.cache/greybench/native
// (created with mode 0700), with its C source beside it (gb-HASH.so, gb-HASH.c): a model compiled
// once loads in milliseconds after that, in this process and the next. The library is written under
// a temporary name and renamed, so processes that compile the same model at once do not see each
// other's half-written files.
//
// Compile fails (a kNumerical Error whose message says why: no compiler, the compiler's first
// error lines, dlopen's message) and callers then keep the interpreter (Tape). GREYBENCH_NATIVE=0
// in the environment turns native code off (Enabled() is false).
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/expr/expr.h"
#include "core/util/result.h"

namespace gb::expr {

class NativeCode {
 public:
  using Function = void (*)(const double* slots, double* out);

  struct Program {
    std::vector<ExprPtr> exprs;
    // Where expression i is written (out[positions[i]]); empty: out[i].
    std::vector<std::size_t> positions;
  };

  // Whether native code is wanted: false where GREYBENCH_NATIVE is "0" (or "off").
  static bool Enabled();

  // One library for the programs, `slot_of(name)` the slot of a variable (-1: unknown, an
  // error naming it, as Tape::Compile).
  static Result<std::shared_ptr<const NativeCode>> Compile(
      std::span<const Program> programs, const std::function<int(const std::string&)>& slot_of);

  // The C source Compile builds for these programs (for tests and for reading).
  static Result<std::string> Source(std::span<const Program> programs,
                                    const std::function<int(const std::string&)>& slot_of);

  ~NativeCode();
  NativeCode(const NativeCode&) = delete;
  NativeCode& operator=(const NativeCode&) = delete;

  Function function(std::size_t program) const { return functions_[program]; }
  std::size_t size() const { return functions_.size(); }
  // Whether the library came from the cache (compiled by an earlier call or process).
  bool cached() const { return cached_; }

 private:
  NativeCode() = default;
  void* handle_ = nullptr;
  std::vector<Function> functions_;
  bool cached_ = false;
};

// Runs the system's C compiler (the one NativeCode uses: $GREYBENCH_CC, else $CC, else cc) on
// `source` with `flags` (and -lm) into `output`, its messages into `log`. Errors (kNumerical) say
// why: no compiler, or the compiler's first error lines, naming `what` ("the model's generated
// C"). *ran: whether the compiler ran (so a failure is the code's, not a missing compiler).
Status RunCCompiler(const std::filesystem::path& source, const std::filesystem::path& output,
                    std::span<const std::string> flags, const std::filesystem::path& log,
                    const std::string& what, bool* ran);

}  // namespace gb::expr
