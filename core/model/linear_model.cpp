#include "core/model/linear_model.h"

#include <cmath>
#include <mutex>
#include <set>

#include <fmt/format.h>

namespace gb::model {
namespace {

Error ModelError(const ModelSpec& spec, const Formula& f, std::string message, int expr_col) {
  Error e = InputError(std::move(message));
  e.file = spec.source;
  e.path = f.path;
  e.expr_col = expr_col;
  return e;
}

// Splits an affine expression f(v) = Σ_j a_j v_j + b into coefficients a_j and constant b.
// Refuses f when some ∂f/∂v_j still depends on a variable in `vars`.
Status SplitAffine(const ModelSpec& spec, const Formula& f, const std::vector<std::string>& vars,
                   const std::set<std::string>& var_set, std::vector<expr::ExprPtr>* coefficients,
                   expr::ExprPtr* constant) {
  coefficients->clear();
  for (const auto& v : vars) {
    expr::ExprPtr dv = expr::Differentiate(f.expr, v);
    std::set<std::string> used;
    expr::CollectNames(dv, &used);
    for (const auto& w : var_set) {
      if (!used.count(w)) continue;
      const expr::Node* at = expr::FindFirstVariable(f.expr, {v});
      const std::string how = w == v ? fmt::format("it is not linear in '{}'", v)
                                     : fmt::format("it multiplies '{}' by '{}'", v, w);
      return ModelError(spec, f,
                        fmt::format("the model is not affine in the states and inputs: {}", how),
                        at ? at->column : 0);
    }
    coefficients->push_back(dv);
  }
  expr::ExprPtr rest = f.expr;
  for (const auto& v : vars) rest = expr::Substitute(rest, v, expr::Constant(0.0));
  *constant = expr::Simplify(rest);
  std::set<std::string> used;
  expr::CollectNames(*constant, &used);
  for (const auto& w : var_set) {
    if (!used.count(w)) continue;
    const expr::Node* at = expr::FindFirstVariable(f.expr, {w});
    return ModelError(spec, f,
                      fmt::format("the model is not linear: {} depends on '{}'", f.path, w),
                      at ? at->column : 0);
  }
  return Ok{};
}

// Refuses f when it uses a name other than a parameter (a state, an input or the time).
Status ParametersOnly(const ModelSpec& spec, const Formula& f) {
  std::set<std::string> used;
  expr::CollectNames(f.expr, &used);
  std::set<std::string> others;
  for (const auto& name : used)
    if (spec.ParameterIndex(name) < 0) others.insert(name);
  if (others.empty()) return Ok{};
  const expr::Node* at = expr::FindFirstVariable(f.expr, others);
  return ModelError(spec, f,
                    fmt::format("the model is not linear: {} depends on '{}'", f.path, at->name),
                    at->column);
}

}  // namespace

Result<LinearModel> LinearModel::Compile(ModelSpec spec) {
  LinearModel lm;
  const int n = static_cast<int>(spec.states.size());
  const int m = static_cast<int>(spec.inputs.size());
  const int p = static_cast<int>(spec.outputs.size());

  std::vector<std::string> vars = spec.states;
  vars.insert(vars.end(), spec.inputs.begin(), spec.inputs.end());
  std::set<std::string> var_set(vars.begin(), vars.end());
  // The time makes a model time-varying: not linear time-invariant (the EKF takes it).
  if (spec.ParameterIndex("t") < 0 && spec.StateIndex("t") < 0 && spec.InputIndex("t") < 0)
    var_set.insert("t");
  for (const auto* list : {&spec.diffusion, &spec.measurement_variance, &spec.initial_state})
    for (const Formula& f : *list)
      if (auto s = ParametersOnly(spec, f); !s) return s.error();

  // Split drift and observation rows into [A B | c] and [C D | d].
  std::vector<std::vector<expr::ExprPtr>> f_coef(n), h_coef(p);
  std::vector<expr::ExprPtr> f_const(n), h_const(p);
  for (int i = 0; i < n; ++i) {
    if (auto s = SplitAffine(spec, spec.drift[i], vars, var_set, &f_coef[i], &f_const[i]); !s)
      return s.error();
  }
  for (int i = 0; i < p; ++i) {
    if (auto s = SplitAffine(spec, spec.observation[i], vars, var_set, &h_coef[i], &h_const[i]); !s)
      return s.error();
  }

  auto add = [&](expr::ExprPtr e, std::string name) {
    lm.entries_.push_back(std::move(e));
    lm.entry_names_.push_back(std::move(name));
  };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      add(f_coef[i][j],
          fmt::format("A[{},{}] (from drift.{})", spec.states[i], spec.states[j], spec.states[i]));
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j)
      add(f_coef[i][n + j],
          fmt::format("B[{},{}] (from drift.{})", spec.states[i], spec.inputs[j], spec.states[i]));
  for (int i = 0; i < n; ++i)
    add(f_const[i], fmt::format("the constant term of drift.{}", spec.states[i]));
  for (int i = 0; i < p; ++i)
    for (int j = 0; j < n; ++j)
      add(h_coef[i][j], fmt::format("C[{},{}] (from observation.{})", spec.outputs[i],
                                    spec.states[j], spec.outputs[i]));
  for (int i = 0; i < p; ++i)
    for (int j = 0; j < m; ++j)
      add(h_coef[i][n + j], fmt::format("D[{},{}] (from observation.{})", spec.outputs[i],
                                        spec.inputs[j], spec.outputs[i]));
  for (int i = 0; i < p; ++i)
    add(h_const[i], fmt::format("the constant term of observation.{}", spec.outputs[i]));
  for (int i = 0; i < n; ++i) add(spec.diffusion[i].expr, spec.diffusion[i].path);
  for (int i = 0; i < p; ++i)
    add(spec.measurement_variance[i].expr, spec.measurement_variance[i].path);
  for (int i = 0; i < n; ++i) add(spec.initial_state[i].expr, spec.initial_state[i].path);
  if (spec.initial_covariance == InitialCovariance::kExplicit)
    for (int i = 0; i < n; ++i) add(spec.initial_variance[i].expr, spec.initial_variance[i].path);

  std::vector<std::string> params;
  for (const auto& par : spec.parameters) params.push_back(par.name);
  auto tape = expr::Tape::Compile(lm.entries_, [&](const std::string& name) {
    for (std::size_t k = 0; k < params.size(); ++k)
      if (params[k] == name) return static_cast<int>(k);
    return -1;
  });
  if (!tape) {
    // Cannot happen for a validated spec (only parameters remain after the split), but a
    // message beats an assertion if it ever does.
    Error e = tape.error();
    e.file = spec.source;
    return e;
  }
  lm.tape_ = std::move(*tape);
  lm.spec_ = std::move(spec);
  lm.jacobian_ = std::make_shared<JacobianTape>();
  return lm;
}

// Names the entry and the values of the parameters it uses, so that the user sees the cause
// ("log(p)" with p = -1) without evaluating the expression by hand.
Error LinearModel::NotFinite(std::size_t k, double value, std::span<const double> theta) const {
  std::set<std::string> used;
  expr::CollectNames(entries_[k], &used);
  std::string values;
  for (const auto& name : used) {
    const int i = spec_.ParameterIndex(name);
    if (i < 0) continue;
    values += fmt::format("{}{} = {:g}", values.empty() ? "" : ", ", name, theta[i]);
  }
  Error e = NumericalError(fmt::format("{} is {} at these parameter values{}", entry_names_[k],
                                       std::isnan(value) ? "not a number" : "infinite",
                                       values.empty() ? "" : " (" + values + ")"));
  e.file = spec_.source;
  return e;
}

StateSpace LinearModel::Unpack(std::span<const double> v) const {
  const int n = n_states(), m = n_inputs(), p = n_outputs();
  StateSpace ss;
  std::size_t k = 0;
  auto take = [&](Eigen::MatrixXd* M, int rows, int cols) {
    M->resize(rows, cols);
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < cols; ++j) (*M)(i, j) = v[k++];
  };
  auto take_vec = [&](Eigen::VectorXd* x, int size) {
    x->resize(size);
    for (int i = 0; i < size; ++i) (*x)(i) = v[k++];
  };
  take(&ss.A, n, n);
  take(&ss.B, n, m);
  take_vec(&ss.c, n);
  take(&ss.C, p, n);
  take(&ss.D, p, m);
  take_vec(&ss.d, p);
  take_vec(&ss.sigma, n);
  take_vec(&ss.S, p);
  take_vec(&ss.x0, n);
  if (spec_.initial_covariance == InitialCovariance::kExplicit) take_vec(&ss.P0_diag, n);
  assert(k == v.size());
  return ss;
}

Result<StateSpace> LinearModel::Evaluate(std::span<const double> theta) const {
  assert(theta.size() == spec_.parameters.size() && "θ has one entry per parameter");
  std::vector<double> v(tape_.size());
  tape_.Eval(theta, v);
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (!std::isfinite(v[k])) return NotFinite(k, v[k], theta);
  }
  StateSpace ss = Unpack(v);
  // S and P0_diag are the last entries but n of x0 (and n of P0_diag).
  const std::size_t s_offset = v.size() - ss.S.size() - ss.x0.size() - ss.P0_diag.size();
  const std::size_t p0_offset = v.size() - ss.P0_diag.size();
  for (int i = 0; i < ss.S.size(); ++i) {
    if (ss.S(i) < 0)
      return NumericalError(
          fmt::format("{} = {:g} is negative at these parameter values (a "
                      "variance)",
                      entry_names_[s_offset + i], ss.S(i)));
  }
  for (int i = 0; i < ss.P0_diag.size(); ++i) {
    if (ss.P0_diag(i) < 0)
      return NumericalError(
          fmt::format("{} = {:g} is negative at these parameter values (a "
                      "variance)",
                      entry_names_[p0_offset + i], ss.P0_diag(i)));
  }
  return ss;
}

// ---- derivatives ------------------------------------------------------------------------------

struct LinearModel::JacobianTape {
  std::once_flag once;
  expr::Tape tape;
  std::vector<int> entry;      // per tape output: the entry it differentiates
  std::vector<int> parameter;  // per tape output: the parameter it differentiates by
  std::optional<Error> error;  // when the derivatives could not be compiled
};

const LinearModel::JacobianTape& LinearModel::Jacobian() const {
  assert(jacobian_ && "a LinearModel comes from Compile");
  std::call_once(jacobian_->once, [this] {
    JacobianTape& jt = *jacobian_;
    std::vector<expr::ExprPtr> derivatives;
    for (std::size_t k = 0; k < entries_.size(); ++k) {
      std::set<std::string> used;
      expr::CollectNames(entries_[k], &used);
      for (const auto& name : used) {
        const int i = spec_.ParameterIndex(name);
        if (i < 0) continue;
        expr::ExprPtr d = expr::Differentiate(entries_[k], name);
        double value = 0.0;
        if (expr::IsConstant(d, &value) && value == 0.0) continue;
        derivatives.push_back(std::move(d));
        jt.entry.push_back(static_cast<int>(k));
        jt.parameter.push_back(i);
      }
    }
    auto tape = expr::Tape::Compile(
        derivatives, [&](const std::string& name) { return spec_.ParameterIndex(name); });
    if (tape) {
      jt.tape = std::move(*tape);
    } else {
      jt.error = tape.error();
      jt.error->file = spec_.source;
      jt.error->message = "the derivatives of the model cannot be compiled: " + jt.error->message;
    }
  });
  return *jacobian_;
}

Result<std::vector<StateSpace>> LinearModel::EvaluateJacobian(
    std::span<const double> theta, std::span<const int> parameters) const {
  assert(theta.size() == spec_.parameters.size() && "θ has one entry per parameter");
  const JacobianTape& jt = Jacobian();
  if (jt.error) return *jt.error;
  std::vector<double> v(jt.tape.size());
  jt.tape.Eval(theta, v);
  // Column f of `columns` is ∂(entries)/∂θ_{parameters[f]}.
  std::vector<int> column_of(spec_.parameters.size(), -1);
  for (std::size_t f = 0; f < parameters.size(); ++f)
    column_of[parameters[f]] = static_cast<int>(f);
  std::vector<std::vector<double>> columns(parameters.size(),
                                           std::vector<double>(entries_.size(), 0.0));
  for (std::size_t q = 0; q < v.size(); ++q) {
    const int f = column_of[jt.parameter[q]];
    if (f < 0) continue;
    if (!std::isfinite(v[q])) {
      const std::string& name = spec_.parameters[jt.parameter[q]].name;
      Error e = NumericalError(fmt::format(
          "the derivative of {} with respect to {} is {} at these parameter values ({} = {:g})",
          entry_names_[jt.entry[q]], name, std::isnan(v[q]) ? "not a number" : "infinite", name,
          theta[jt.parameter[q]]));
      e.file = spec_.source;
      return e;
    }
    columns[f][jt.entry[q]] = v[q];
  }
  std::vector<StateSpace> out;
  out.reserve(parameters.size());
  for (const auto& column : columns) out.push_back(Unpack(column));
  return out;
}

}  // namespace gb::model
