// A model whose drift and observation are affine in the states and inputs:
//
//   dx = (A x + B u + c) dt + diag(σ) dω          A: n x n, B: n x m, c: n, σ: n
//   y  = C x + D u + d + e,   e ~ N(0, diag(S))     C: p x n, D: p x m, d: p, S: p (variances)
//   x(t_0) ~ N(x0, P0)
//
// Every entry is an expression of the parameters θ (all of them, fixed ones included, in the
// order of ModelSpec::parameters, on their natural scale). `Compile` derives the entries by
// symbolic differentiation, A_ij = ∂f_i/∂x_j, B_ij = ∂f_i/∂u_j, c_i = f_i(x=0, u=0) (likewise
// C, D, d from h), and refuses a model when a derivative still depends on a state or an input,
// naming the equation and the variable. All entries are compiled into one expr::Tape, so
// `Evaluate` costs one pass over a flat program.
//
// Derivatives: `EvaluateJacobian` gives ∂(every entry)/∂θ_i for chosen parameters i, from the
// symbolic derivatives of the entries (expr::Differentiate), compiled into a second Tape the
// first time it is asked for (the value-only path never pays for them); the tape holds only the
// derivatives that are not identically zero.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/model/model.h"
#include "core/util/result.h"

namespace gb::model {

// The numbers of a linear model at one θ.
struct StateSpace {
  Eigen::MatrixXd A, B, C, D;
  Eigen::VectorXd c, d;
  Eigen::VectorXd sigma;  // diffusion coefficients (σσ' = diag(sigma²))
  Eigen::VectorXd S;      // measurement variances, >= 0
  Eigen::VectorXd x0;
  Eigen::VectorXd P0_diag;  // initial variances when the model gives them explicitly, else empty
  int n_states() const { return static_cast<int>(A.rows()); }
  int n_inputs() const { return static_cast<int>(B.cols()); }
  int n_outputs() const { return static_cast<int>(C.rows()); }
};

class LinearModel {
 public:
  // Fails (kInput) when f or h is not affine in states and inputs, e.g.
  //   fuel.json: drift.mfv, column 3: the model must be linear in the states and inputs, but this
  //   equation is not linear in 'mfv' (nonlinear models are not supported yet)
  static Result<LinearModel> Compile(ModelSpec spec);

  // Evaluates every entry at θ. Fails (kNumerical) when an entry is not finite or a variance is
  // negative, naming it: "measurement_variance.y = -0.1 is negative at these parameter values",
  // "diffusion.x is not a number at these parameter values (p = -1)".
  Result<StateSpace> Evaluate(std::span<const double> theta) const;

  // The derivatives of every entry at θ with respect to θ_i for each i in `parameters` (indices
  // into ModelSpec::parameters): out[f] holds ∂A/∂θ_i, ∂B/∂θ_i, ... ∂P0_diag/∂θ_i with
  // i = parameters[f], in the shapes of Evaluate's result (P0_diag empty unless explicit).
  // Fails (kNumerical) when a derivative is not finite ("the derivative of diffusion.x with
  // respect to s is infinite at these parameter values (s = 0)": sqrt(s) at s = 0), or (kInput)
  // when a derivative is too deeply nested to compile.
  Result<std::vector<StateSpace>> EvaluateJacobian(std::span<const double> theta,
                                                   std::span<const int> parameters) const;

  const ModelSpec& spec() const { return spec_; }
  int n_states() const { return static_cast<int>(spec_.states.size()); }
  int n_inputs() const { return static_cast<int>(spec_.inputs.size()); }
  int n_outputs() const { return static_cast<int>(spec_.outputs.size()); }
  int n_parameters() const { return static_cast<int>(spec_.parameters.size()); }

  // The entries as expressions (for display and for the diagram compiler's tests).
  // Order: A (row-major), B, c, C, D, d, sigma, S, x0, P0 (explicit only).
  const std::vector<expr::ExprPtr>& entries() const { return entries_; }

 private:
  struct JacobianTape;
  Error NotFinite(std::size_t k, double value, std::span<const double> theta) const;
  // The entries in tape order (as Evaluate's tape writes them) laid out as a StateSpace.
  StateSpace Unpack(std::span<const double> v) const;
  const JacobianTape& Jacobian() const;

  ModelSpec spec_;
  std::vector<expr::ExprPtr> entries_;
  std::vector<std::string> entry_names_;  // "A[mfv,mff]" or the formula path, for messages
  expr::Tape tape_;
  std::shared_ptr<JacobianTape> jacobian_;  // compiled on first use; shared by copies
};

}  // namespace gb::model
