// The derivatives of a NonlinearModel's programs with respect to the parameters and (for the
// Jacobians and the diffusion) the states, for the exact scores of the extended Kalman filter
// (core/filter/ekf_score.h). Derived symbolically from the model's expressions (expr::
// Differentiate) and compiled into three programs over the model's slots [x | u | θ | t]:
//
//   dynamics     ∂f/∂θ, ∂J/∂x, ∂J/∂θ, ∂σ/∂x, ∂σ/∂θ
//   measurement  ∂h/∂θ, ∂H/∂x, ∂H/∂θ, ∂S/∂θ
//   initial      ∂x0/∂θ, and ∂P0_ii/∂θ when the model gives the initial variances
//
// for every parameter (fixed ones too: the estimator chooses which are free per fit). Only the
// entries that are not identically zero are computed: Eval writes those into a dense array
// whose other entries the caller zeroes once (Zeroed). The layouts (all column-major blocks, so
// that Eigen maps them directly; np = all parameters):
//
//   dynamics     fθ  n x np           at 0                   column l = ∂f/∂θ_l
//                Jx  n blocks n x n    at DynJx(m)            block m = ∂J/∂x_m
//                Jθ  np blocks n x n   at DynJtheta(l)        block l = ∂J/∂θ_l
//                σx  n x n             at DynSigmaX()         (i, m) = ∂σ_i/∂x_m
//                σθ  n x np            at DynSigmaTheta()     (i, l) = ∂σ_i/∂θ_l
//   measurement  hθ  p x np            at 0
//                Hx  n blocks p x n    at MeasHx(m)           block m = ∂H/∂x_m
//                Hθ  np blocks p x n   at MeasHtheta(l)
//                Sθ  p x np            at MeasStheta()
//   initial      x0θ n x np            at 0
//                P0θ n x np            at InitP0theta()       (explicit initial variances only)
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/expr/expr.h"
#include "core/expr/native.h"
#include "core/model/nonlinear_model.h"
#include "core/util/result.h"

namespace gb::model {

class NonlinearSensitivity {
 public:
  // Fails (kInput) only when a derivative is too deeply nested to compile.
  static Result<NonlinearSensitivity> Compile(const NonlinearModel& model);

  // A program: its dense size, the positions it writes, the compiled nonzero entries.
  class Program {
   public:
    std::size_t size() const { return size_; }
    // Writes the nonzero entries into `dense` (size()), leaving the others as they are.
    void Eval(std::span<const double> slots, std::span<double> dense,
              std::span<double> scratch) const;
    std::size_t nonzeros() const { return positions_.size(); }
    // Where in the dense array the nonzero entries are, in Eval's order.
    std::span<const std::size_t> positions() const { return positions_; }
    // A dense array for Eval: zero where Eval never writes.
    std::vector<double> Zeroed() const { return std::vector<double>(size_, 0.0); }

   private:
    friend class NonlinearSensitivity;
    std::size_t size_ = 0;
    std::vector<std::size_t> positions_;
    std::vector<std::string> names_;  // of the nonzero entries, for messages
    std::vector<expr::ExprPtr> exprs_;
    expr::Tape tape_;
    expr::NativeCode::Function native_ = nullptr;  // writes the dense array's entries directly
  };

  const Program& dynamics() const { return dynamics_; }
  const Program& measurement() const { return measurement_; }
  const Program& initial() const { return initial_; }

  // Native code (core/expr/native.h): the three programs, in the order above, for
  // expr::NativeCode::Compile (each writing its dense array directly); UseNative(code, first)
  // then runs functions first..first+2 of `code` in their place (the same values, bit for bit).
  std::vector<expr::NativeCode::Program> NativePrograms() const;
  void UseNative(std::shared_ptr<const expr::NativeCode> code, std::size_t first);

  // Offsets into the dense arrays (see above).
  std::size_t DynJx(int m) const { return n_ * np_ + Z(m) * n_ * n_; }
  std::size_t DynJtheta(int l) const { return n_ * np_ + n_ * n_ * n_ + Z(l) * n_ * n_; }
  std::size_t DynSigmaX() const { return DynJtheta(static_cast<int>(np_)); }
  std::size_t DynSigmaTheta() const { return DynSigmaX() + n_ * n_; }
  std::size_t MeasHx(int m) const { return p_ * np_ + Z(m) * p_ * n_; }
  std::size_t MeasHtheta(int l) const { return p_ * np_ + n_ * p_ * n_ + Z(l) * p_ * n_; }
  std::size_t MeasStheta() const { return MeasHtheta(static_cast<int>(np_)); }
  std::size_t InitP0theta() const { return n_ * np_; }

  // The first entry of a program's nonzeros at which `dense` is not finite, as an error naming
  // it ("the derivative of drift.h1 with respect to k1 is infinite at these values (...)"), or
  // nothing.
  std::optional<Error> NotFinite(const Program& program, std::span<const double> dense,
                                 std::span<const double> slots) const;

 private:
  static std::size_t Z(int i) { return static_cast<std::size_t>(i); }

  std::vector<std::string> slot_names_;
  std::string source_;
  std::size_t n_ = 0, p_ = 0, np_ = 0;
  Program dynamics_, measurement_, initial_;
  std::shared_ptr<const expr::NativeCode> native_;  // keeps the library loaded
};

}  // namespace gb::model
