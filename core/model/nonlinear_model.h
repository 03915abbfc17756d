// Any model (user guide §2) compiled for the extended Kalman filter (core/filter/ekf.h):
//
//   dx = f(x, u, θ, t) dt + diag(σ(x, u, θ, t)) dω
//   y  = h(x, u, θ, t) + e,   e ~ N(0, diag(S(u, θ, t)))
//   x(t_0) ~ N(x0(θ), P0)
//
// `Compile` differentiates f and h symbolically with respect to the states (expr::Differentiate)
// and compiles three flat programs (expr::Tape), each evaluated in one pass:
//   dynamics     f (n), J = ∂f/∂x (n x n, row-major), σ (n)
//   measurement  h (p), H = ∂h/∂x (p x n, row-major), S (p)
//   initial      x0 (n), and the explicit initial variances (n) when the model gives them
//   noise        σ (n), ∂σ_i/∂x_i (n): for the Milstein scheme of sample paths (core/sim/sde.h)
// over the slots [x (n) | u (m) | θ (all parameters, natural scale) | t]. Every model compiles,
// linear ones included (the EKF of a linear model is its Kalman filter, with the moment
// equations integrated numerically instead of discretised exactly).
#pragma once

#include <array>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/expr/expr.h"
#include "core/expr/native.h"
#include "core/model/model.h"
#include "core/util/result.h"

namespace gb::model {

// "NAME is not a number at these values (h1 = -0.2, k1 = 0.5)" (or "infinite"), listing the
// slots `e` uses, with `source` as the error's file.
Error NotFiniteEntry(const std::string& name, double value, const expr::ExprPtr& e,
                     std::span<const std::string> slot_names, std::span<const double> slots,
                     const std::string& source);

class NonlinearModel {
 public:
  // Fails (kInput) only when an expression or a derivative is too deeply nested to compile.
  static Result<NonlinearModel> Compile(ModelSpec spec);

  const ModelSpec& spec() const { return spec_; }
  int n_states() const { return static_cast<int>(spec_.states.size()); }
  int n_inputs() const { return static_cast<int>(spec_.inputs.size()); }
  int n_outputs() const { return static_cast<int>(spec_.outputs.size()); }
  int n_parameters() const { return static_cast<int>(spec_.parameters.size()); }

  // The slots: [x | u | θ | t]. Fill them with these offsets; the programs read nothing else.
  int n_slots() const { return n_states() + n_inputs() + n_parameters() + 1; }
  int input_slot() const { return n_states(); }
  int parameter_slot() const { return n_states() + n_inputs(); }
  int time_slot() const { return n_states() + n_inputs() + n_parameters(); }

  // out: f, J (row-major), σ; size n + n² + n.
  void Dynamics(std::span<const double> slots, std::span<double> out) const {
    Run(kDynamicsProgram, dynamics_, slots, out);
  }
  // out: h, H (row-major), S; size p + p n + p.
  void Measurement(std::span<const double> slots, std::span<double> out) const {
    Run(kMeasurementProgram, measurement_, slots, out);
  }
  // out: x0, then the explicit initial variances if any; size n or 2n. Reads only θ.
  void Initial(std::span<const double> slots, std::span<double> out) const {
    Run(kInitialProgram, initial_, slots, out);
  }
  // out: σ, then ∂σ_i/∂x_i; size 2n.
  void Noise(std::span<const double> slots, std::span<double> out) const {
    Run(kNoiseProgram, noise_, slots, out);
  }

  // Native code (core/expr/native.h): the four programs above, in that order, for
  // expr::NativeCode::Compile; UseNative(code, first) then runs functions first..first+3 of
  // `code` in their place (the same values, bit for bit). SlotOf names the slots as above.
  std::vector<expr::NativeCode::Program> NativePrograms() const;
  void UseNative(std::shared_ptr<const expr::NativeCode> code, std::size_t first);
  bool native() const { return native_ != nullptr; }
  int SlotOf(const std::string& name) const;
  std::size_t dynamics_size() const { return dynamics_.size(); }
  std::size_t measurement_size() const { return measurement_.size(); }
  std::size_t initial_size() const { return initial_.size(); }

  // Names entry k of a program's output for messages, e.g. "drift.h1", "the derivative of
  // drift.h1 with respect to h2", "diffusion.h1", and lists the values of the names it uses:
  //   "drift.h1 is not a number at these values (h1 = -0.2, k1 = 0.5)".
  enum class Program { kDynamics, kMeasurement, kInitial, kNoise };
  Error NotFinite(Program program, std::size_t k, double value,
                  std::span<const double> slots) const;

  // The expression of entry k (for tests and display).
  const expr::ExprPtr& Entry(Program program, std::size_t k) const;

 private:
  struct Entries {
    std::vector<expr::ExprPtr> exprs;
    std::vector<std::string> names;
  };
  const Entries& EntriesOf(Program program) const;
  enum NativeIndex { kDynamicsProgram, kMeasurementProgram, kInitialProgram, kNoiseProgram };
  void Run(NativeIndex which, const expr::Tape& tape, std::span<const double> slots,
           std::span<double> out) const {
    if (native_) {
      native_functions_[which](slots.data(), out.data());
    } else {
      tape.Eval(slots, out);
    }
  }
  std::string SlotName(int slot) const;

  ModelSpec spec_;
  Entries dynamics_entries_, measurement_entries_, initial_entries_, noise_entries_;
  expr::Tape dynamics_, measurement_, initial_, noise_;
  std::shared_ptr<const expr::NativeCode> native_;  // keeps the library loaded
  std::array<expr::NativeCode::Function, 4> native_functions_{};
};

}  // namespace gb::model
