// Sections: 1. parsing  2. the compiled derivatives  3. the steady state  4. linearise
#include "core/model/linearise.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include <Eigen/LU>
#include <fmt/format.h>

#include "core/expr/expr.h"

namespace gb::model {

// ---- 1. parsing -------------------------------------------------------------------------------

namespace {

std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t") - b + 1);
}

}  // namespace

Result<std::vector<std::pair<std::string, double>>> ParseOperatingPoint(const std::string& text,
                                                                        const ModelSpec& spec) {
  std::vector<std::string> names = spec.states;
  names.insert(names.end(), spec.inputs.begin(), spec.inputs.end());
  names.insert(names.end(), spec.outputs.begin(), spec.outputs.end());
  if (Trim(text).empty())
    return InputError(
        "operating point: empty; expected NAME=VALUE,... (states, inputs or outputs of the model)");
  std::vector<std::pair<std::string, double>> point;
  std::set<std::string> seen;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = Trim(text.substr(start, comma - start));
    start = comma + 1;
    if (item.empty())
      return InputError(fmt::format(
          "operating point '{}': an empty item (two commas together, or one at an end)", text));
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos)
      return InputError(fmt::format(
          "operating point: '{}' is not NAME=VALUE (a state, input or output of the model)", item));
    const std::string name = Trim(item.substr(0, eq));
    const std::string value = Trim(item.substr(eq + 1));
    if (name.empty())
      return InputError(fmt::format("operating point: '{}' has no name before '='", item));
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      std::string msg = fmt::format(
          "operating point: '{}' is not a state, input or output of the "
          "model",
          name);
      if (auto s = Suggest(name, names)) msg += fmt::format(" (did you mean '{}'?)", *s);
      return InputError(msg);
    }
    if (!seen.insert(name).second)
      return InputError(fmt::format("operating point: '{}' is given twice", name));
    double v = 0;
    const bool plus = value.size() > 1 && value[0] == '+' && value[1] != '+' && value[1] != '-';
    const char* end = value.data() + value.size();
    const auto [ptr, ec] = std::from_chars(value.data() + (plus ? 1 : 0), end, v);
    if (value.empty() || ec != std::errc() || ptr != end || !std::isfinite(v))
      return InputError(
          fmt::format("operating point: {}: '{}' is not a finite number", name, value));
    point.emplace_back(name, v);
  }
  return point;
}

Result<Quantity> ParseQuantity(const std::string& text) {
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos || Trim(text.substr(0, eq)).empty())
    return InputError(fmt::format("quantity '{}': expected NAME=EXPRESSION", text));
  Quantity q{Trim(text.substr(0, eq)), Trim(text.substr(eq + 1))};
  const bool identifier =
      (std::isalpha(static_cast<unsigned char>(q.name[0])) || q.name[0] == '_') &&
      std::all_of(q.name.begin(), q.name.end(),
                  [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
  if (!identifier)
    return InputError(fmt::format(
        "quantity '{}': the name '{}' is not a name (letters, digits and _, not first a digit)",
        text, q.name));
  if (q.text.empty())
    return InputError(fmt::format("quantity {}: no expression after '='", q.name));
  if (auto e = expr::Parse(q.text); !e) {
    Error err = e.error();
    err.message = fmt::format("quantity {}: {}", q.name, err.message);
    return err;
  }
  return q;
}

// ---- 2. the compiled derivatives --------------------------------------------------------------

namespace {

// ∂f/∂u (n x m) and ∂h/∂u (p x m), row-major, over the model's slots.
Result<expr::Tape> InputDerivatives(const NonlinearModel& model) {
  const ModelSpec& s = model.spec();
  std::vector<expr::ExprPtr> exprs;
  for (const auto& f : s.drift)
    for (const auto& u : s.inputs) exprs.push_back(expr::Differentiate(f.expr, u));
  for (const auto& h : s.observation)
    for (const auto& u : s.inputs) exprs.push_back(expr::Differentiate(h.expr, u));
  auto slot_of = [&](const std::string& name) {
    if (int i = s.StateIndex(name); i >= 0) return i;
    if (int i = s.InputIndex(name); i >= 0) return model.input_slot() + i;
    if (int i = s.ParameterIndex(name); i >= 0) return model.parameter_slot() + i;
    if (name == "t") return model.time_slot();
    return -1;
  };
  return expr::Tape::Compile(exprs, slot_of);
}

struct Evaluated {
  Eigen::VectorXd f, h;
  Eigen::MatrixXd A, B, C, D;
};

class Point {
 public:
  Point(const NonlinearModel& model, const expr::Tape& input_tape)
      : model_(model),
        input_tape_(input_tape),
        n_(model.n_states()),
        m_(model.n_inputs()),
        p_(model.n_outputs()),
        slots_(static_cast<std::size_t>(model.n_slots()), 0.0),
        dyn_(model.dynamics_size()),
        mea_(model.measurement_size()),
        inp_(input_tape.size()) {}

  void SetTheta(std::span<const double> theta) {
    std::copy(theta.begin(), theta.end(), slots_.begin() + model_.parameter_slot());
  }
  void SetState(const Eigen::VectorXd& x, const Eigen::VectorXd& u) {
    for (int i = 0; i < n_; ++i) slots_[static_cast<std::size_t>(i)] = x(i);
    for (int j = 0; j < m_; ++j)
      slots_[static_cast<std::size_t>(model_.input_slot()) + static_cast<std::size_t>(j)] = u(j);
  }
  Evaluated Evaluate() {
    model_.Dynamics(slots_, dyn_);
    model_.Measurement(slots_, mea_);
    input_tape_.Eval(slots_, inp_);
    Evaluated e;
    e.f = Eigen::Map<const Eigen::VectorXd>(dyn_.data(), n_);
    e.A =
        Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(dyn_.data() + n_, n_, n_);
    e.h = Eigen::Map<const Eigen::VectorXd>(mea_.data(), p_);
    e.C =
        Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(mea_.data() + p_, p_, n_);
    e.B = Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(inp_.data(), n_, m_);
    e.D = Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(
        inp_.data() + static_cast<std::ptrdiff_t>(n_) * m_, p_, m_);
    return e;
  }

 private:
  const NonlinearModel& model_;
  const expr::Tape& input_tape_;
  int n_, m_, p_;
  std::vector<double> slots_, dyn_, mea_, inp_;
};

// ---- 3. the steady state ----------------------------------------------------------------------

constexpr int kNewtonIterations = 200;
constexpr int kHalvings = 40;

struct Unknowns {
  std::vector<int> states, inputs;              // indices solved for
  std::vector<std::pair<int, double>> outputs;  // output index, value it must take
};

struct Steady {
  Eigen::VectorXd x, u;
  Evaluated at;
};

// F = [f; h_o - value_o] and its Jacobian in the unknowns, at x, u.
void Residual(const Evaluated& e, const Unknowns& k, Eigen::VectorXd* F, Eigen::MatrixXd* J) {
  const auto n = e.f.size();
  const auto q = static_cast<Eigen::Index>(k.outputs.size());
  const auto nk = static_cast<Eigen::Index>(k.states.size() + k.inputs.size());
  F->resize(n + q);
  J->resize(n + q, nk);
  F->head(n) = e.f;
  for (Eigen::Index r = 0; r < q; ++r) {
    const auto& [o, value] = k.outputs[static_cast<std::size_t>(r)];
    (*F)(n + r) = e.h(o) - value;
  }
  Eigen::Index c = 0;
  for (int i : k.states) {
    J->col(c).head(n) = e.A.col(i);
    for (Eigen::Index r = 0; r < q; ++r)
      (*J)(n + r, c) = e.C(k.outputs[static_cast<std::size_t>(r)].first, i);
    ++c;
  }
  for (int j : k.inputs) {
    J->col(c).head(n) = e.B.col(j);
    for (Eigen::Index r = 0; r < q; ++r)
      (*J)(n + r, c) = e.D(k.outputs[static_cast<std::size_t>(r)].first, j);
    ++c;
  }
}

// Damped Newton from x, u on the unknowns; the merit is the sum of squares of the residuals,
// each divided by its row's scale at the start (so that kPa/s and rpm/s weigh alike).
Result<Steady> SolveSteady(Point& point, const Unknowns& k, Eigen::VectorXd x, Eigen::VectorXd u) {
  point.SetState(x, u);
  Evaluated e = point.Evaluate();
  Eigen::VectorXd F;
  Eigen::MatrixXd J;
  Residual(e, k, &F, &J);
  Eigen::VectorXd scale = J.rowwise().lpNorm<Eigen::Infinity>();
  for (Eigen::Index r = 0; r < scale.size(); ++r)
    if (!(scale(r) > 0) || !std::isfinite(scale(r))) scale(r) = 1;
  auto merit = [&](const Eigen::VectorXd& r) { return r.cwiseQuotient(scale).squaredNorm(); };
  double m = merit(F);
  auto apply = [&](const Eigen::VectorXd& z, Eigen::VectorXd* xs, Eigen::VectorXd* us) {
    Eigen::Index c = 0;
    for (int i : k.states) (*xs)(i) = z(c++);
    for (int j : k.inputs) (*us)(j) = z(c++);
  };
  auto current = [&] {
    Eigen::VectorXd z(static_cast<Eigen::Index>(k.states.size() + k.inputs.size()));
    Eigen::Index c = 0;
    for (int i : k.states) z(c++) = x(i);
    for (int j : k.inputs) z(c++) = u(j);
    return z;
  };
  for (int it = 0; it < kNewtonIterations; ++it) {
    if (!std::isfinite(m)) break;
    const Eigen::FullPivLU<Eigen::MatrixXd> lu(J);
    if (lu.rank() < J.cols())
      return InputError(
          "the steady-state equations are singular at this point (the values given do not fix "
          "the others)");
    const Eigen::VectorXd step = -lu.solve(F);
    const Eigen::VectorXd z = current();
    double t = 1;
    bool accepted = false;
    for (int hv = 0; hv < kHalvings && !accepted; ++hv, t *= 0.5) {
      Eigen::VectorXd xt = x, ut = u;
      apply(z + t * step, &xt, &ut);
      point.SetState(xt, ut);
      Evaluated et = point.Evaluate();
      Eigen::VectorXd Ft;
      Eigen::MatrixXd Jt;
      Residual(et, k, &Ft, &Jt);
      const double mt = merit(Ft);
      if (std::isfinite(mt) && (mt < m || mt == 0)) {
        x = xt, u = ut, e = std::move(et), F = Ft, J = Jt;
        m = mt;
        accepted = true;
      }
    }
    const bool small = (t * 2 * step).norm() <= 1e-13 * (1 + z.norm());
    if (m <= 1e-26 || small) return Steady{x, u, e};
    if (!accepted) break;
  }
  if (std::sqrt(m) <= 1e-9) return Steady{x, u, e};
  if (!std::isfinite(m))
    return InputError(
        "no steady state found at this point: the model's equations are not finite where the "
        "search starts (the values given and the first guess of the others); the values "
        "given may be out of the model's range");
  return InputError(fmt::format(
      "no steady state found at this point (the scaled residual stopped at {:.3g}): the values "
      "given may not be reachable",
      std::sqrt(m)));
}

// ---- 4. linearise -----------------------------------------------------------------------------

// The values quantities may name, at one linearisation.
std::map<std::string, double> Names(const ModelSpec& s, const Steady& st,
                                    std::span<const double> theta) {
  std::map<std::string, double> v;
  const auto n = static_cast<int>(s.states.size()), m = static_cast<int>(s.inputs.size()),
             p = static_cast<int>(s.outputs.size());
  for (int i = 0; i < n; ++i) v[s.states[i]] = st.x(i);
  for (int j = 0; j < m; ++j) v[s.inputs[j]] = st.u(j);
  for (int o = 0; o < p; ++o) v[s.outputs[o]] = st.at.h(o);
  for (std::size_t k = 0; k < s.parameters.size(); ++k) v[s.parameters[k].name] = theta[k];
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) v["A_" + s.states[i] + "_" + s.states[j]] = st.at.A(i, j);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) v["B_" + s.states[i] + "_" + s.inputs[j]] = st.at.B(i, j);
  for (int o = 0; o < p; ++o)
    for (int j = 0; j < n; ++j) v["C_" + s.outputs[o] + "_" + s.states[j]] = st.at.C(o, j);
  for (int o = 0; o < p; ++o)
    for (int j = 0; j < m; ++j) v["D_" + s.outputs[o] + "_" + s.inputs[j]] = st.at.D(o, j);
  return v;
}

// Every quantity at one linearisation; unknown names are an error naming the quantity.
Result<std::vector<double>> EvaluateQuantities(const std::vector<expr::ExprPtr>& exprs,
                                               const std::vector<Quantity>& qs,
                                               const std::map<std::string, double>& names) {
  std::vector<double> out;
  for (std::size_t k = 0; k < exprs.size(); ++k) {
    std::set<std::string> used;
    expr::CollectNames(exprs[k], &used);
    for (const auto& u : used) {
      if (names.count(u)) continue;
      std::vector<std::string> all;
      all.reserve(names.size());
      for (const auto& [name, _] : names) all.push_back(name);
      std::string msg = fmt::format(
          "quantity {}: unknown name '{}' (a quantity names A_<state>_<state>, B_<state>_<input>, "
          "C_<output>_<state>, D_<output>_<input>, states, inputs, outputs or parameters)",
          qs[k].name, u);
      if (auto s = Suggest(u, all)) msg += fmt::format("; did you mean '{}'?", *s);
      return InputError(msg);
    }
    out.push_back(expr::EvaluateTree(exprs[k], [&](const std::string& n) { return names.at(n); }));
  }
  return out;
}

// Every value of a linearisation (or with `se` every standard error) finite, or a numerical Error
// naming the first that is not.
Status CheckFinite(const ModelSpec& s, const Linearisation& lin,
                   const std::vector<Quantity>& quantities, bool se) {
  auto fail = [](const std::string& what, double v) -> Status {
    return NumericalError(
        fmt::format("the linearisation is not finite at this point: {} is {}", what, v));
  };
  auto vector = [&](const char* kind, const std::vector<std::string>& names,
                    const Eigen::VectorXd& v) -> Status {
    for (Eigen::Index i = 0; i < v.size(); ++i)
      if (!std::isfinite(v(i)))
        return fail(fmt::format("{}the steady state's {} {}", se ? "the standard error of " : "",
                                kind, names[static_cast<std::size_t>(i)]),
                    v(i));
    return Ok{};
  };
  auto matrix = [&](const char* m, const std::vector<std::string>& rows,
                    const std::vector<std::string>& cols, const Eigen::MatrixXd& v) -> Status {
    for (Eigen::Index i = 0; i < v.rows(); ++i)
      for (Eigen::Index j = 0; j < v.cols(); ++j)
        if (!std::isfinite(v(i, j)))
          return fail(
              fmt::format("{}{}_{}_{}", se ? "the standard error of " : "", m,
                          rows[static_cast<std::size_t>(i)], cols[static_cast<std::size_t>(j)]),
              v(i, j));
    return Ok{};
  };
  for (const Status& st : {vector("state", s.states, se ? lin.se_x : lin.x),
                           vector("input", s.inputs, se ? lin.se_u : lin.u),
                           se ? Status(Ok{}) : vector("output", s.outputs, lin.y),
                           matrix("A", s.states, s.states, se ? lin.se_A : lin.A),
                           matrix("B", s.states, s.inputs, se ? lin.se_B : lin.B),
                           matrix("C", s.outputs, s.states, se ? lin.se_C : lin.C),
                           matrix("D", s.outputs, s.inputs, se ? lin.se_D : lin.D)})
    if (!st) return st;
  const std::vector<double>& q = se ? lin.se_quantities : lin.quantities;
  for (std::size_t k = 0; k < q.size(); ++k)
    if (!std::isfinite(q[k]))
      return fail(fmt::format("{}quantity {} = {}", se ? "the standard error of " : "",
                              quantities[k].name, quantities[k].text),
                  q[k]);
  return Ok{};
}

}  // namespace

// "t" is the time unless the model names a state, input or parameter so.
Status CheckTimeInvariant(const ModelSpec& s) {
  if (s.StateIndex("t") >= 0 || s.InputIndex("t") >= 0 || s.ParameterIndex("t") >= 0) return Ok{};
  for (const std::vector<Formula>* formulas : {&s.drift, &s.observation}) {
    for (const Formula& f : *formulas) {
      std::set<std::string> used;
      expr::CollectNames(f.expr, &used);
      if (!used.count("t")) continue;
      Error e = InputError(fmt::format(
          "'{}' uses the time t: a model that changes with time has no steady state (to take it "
          "at one time, replace t by a fixed parameter)",
          f.text));
      e.file = s.source;
      e.path = f.path;
      return e;
    }
  }
  return Ok{};
}

Result<Linearisation> Linearise(const NonlinearModel& model, std::span<const double> theta,
                                const std::vector<std::pair<std::string, double>>& point,
                                const LinearisationOptions& options) {
  const ModelSpec& s = model.spec();
  const int n = model.n_states(), m = model.n_inputs();
  if (static_cast<int>(theta.size()) != model.n_parameters())
    return InputError("linearise: one value per parameter is needed");
  if (auto st = CheckTimeInvariant(s); !st) return st.error();
  for (std::size_t a = 0; a < options.quantities.size(); ++a)
    for (std::size_t b = 0; b < a; ++b)
      if (options.quantities[a].name == options.quantities[b].name)
        return InputError(fmt::format("quantity {} is given twice ('{}' and '{}')",
                                      options.quantities[a].name, options.quantities[b].text,
                                      options.quantities[a].text));

  auto tape = InputDerivatives(model);
  if (!tape) return tape.error();
  Point at(model, *tape);
  at.SetTheta(theta);

  // Start: the model's initial state at θ, the inputs at 0; then the values given.
  std::vector<double> init(model.initial_size());
  {
    std::vector<double> slots(static_cast<std::size_t>(model.n_slots()), 0.0);
    std::copy(theta.begin(), theta.end(), slots.begin() + model.parameter_slot());
    model.Initial(slots, init);
  }
  Eigen::VectorXd x0(n), u0 = Eigen::VectorXd::Zero(m);
  for (int i = 0; i < n; ++i) x0(i) = init[static_cast<std::size_t>(i)];
  std::vector<bool> state_given(static_cast<std::size_t>(n)),
      input_given(static_cast<std::size_t>(m));
  Unknowns k;
  for (const auto& [name, value] : point) {
    if (int i = s.StateIndex(name); i >= 0) {
      x0(i) = value;
      state_given[static_cast<std::size_t>(i)] = true;
    } else if (int j = s.InputIndex(name); j >= 0) {
      u0(j) = value;
      input_given[static_cast<std::size_t>(j)] = true;
    } else if (int o = s.OutputIndex(name); o >= 0) {
      k.outputs.emplace_back(o, value);
    } else {
      return InputError(fmt::format("operating point: '{}' is not a state, input or output", name));
    }
  }
  for (int i = 0; i < n; ++i)
    if (!state_given[static_cast<std::size_t>(i)]) k.states.push_back(i);
  for (int j = 0; j < m; ++j)
    if (!input_given[static_cast<std::size_t>(j)]) k.inputs.push_back(j);
  const std::size_t unknowns = k.states.size() + k.inputs.size();
  const std::size_t equations = static_cast<std::size_t>(n) + k.outputs.size();
  if (unknowns != equations) {
    std::vector<std::string> free_names;
    for (int i : k.states) free_names.push_back(s.states[static_cast<std::size_t>(i)]);
    for (int j : k.inputs) free_names.push_back(s.inputs[static_cast<std::size_t>(j)]);
    std::string list;
    for (const auto& f : free_names) list += (list.empty() ? "" : ", ") + f;
    return InputError(fmt::format(
        "operating point: {} unknowns ({}) but {} equations (the {} steady-state equations and "
        "one per output given): give {} {} value{}",
        unknowns, list.empty() ? "none" : list, equations, n,
        unknowns > equations ? unknowns - equations : equations - unknowns,
        unknowns > equations ? "more" : "fewer",
        (unknowns > equations ? unknowns - equations : equations - unknowns) == 1 ? "" : "s"));
  }

  std::vector<expr::ExprPtr> qexprs;
  for (const auto& q : options.quantities) {
    auto e = expr::Parse(q.text);
    if (!e) return InputError(fmt::format("quantity {}: {}", q.name, e.error().message));
    qexprs.push_back(*e);
  }

  auto nominal = SolveSteady(at, k, x0, u0);
  if (!nominal) return nominal.error();
  auto values = EvaluateQuantities(qexprs, options.quantities, Names(s, *nominal, theta));
  if (!values) return values.error();

  Linearisation lin;
  lin.x = nominal->x;
  lin.u = nominal->u;
  lin.y = nominal->at.h;
  lin.A = nominal->at.A;
  lin.B = nominal->at.B;
  lin.C = nominal->at.C;
  lin.D = nominal->at.D;
  lin.quantities = *values;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  lin.se_A = Eigen::MatrixXd::Constant(lin.A.rows(), lin.A.cols(), nan);
  lin.se_B = Eigen::MatrixXd::Constant(lin.B.rows(), lin.B.cols(), nan);
  lin.se_C = Eigen::MatrixXd::Constant(lin.C.rows(), lin.C.cols(), nan);
  lin.se_D = Eigen::MatrixXd::Constant(lin.D.rows(), lin.D.cols(), nan);
  lin.se_x = Eigen::VectorXd::Constant(n, nan);
  lin.se_u = Eigen::VectorXd::Constant(m, nan);
  lin.se_quantities.assign(lin.quantities.size(), nan);
  const auto nf = static_cast<Eigen::Index>(options.free.size());
  if (auto st = CheckFinite(s, lin, options.quantities, /*se=*/false); !st) return st.error();
  if (nf == 0 || options.covariance.rows() != nf || options.covariance.cols() != nf) return lin;

  // The delta method: one column of derivatives per free parameter, of everything flattened.
  const auto flat_size = lin.A.size() + lin.B.size() + lin.C.size() + lin.D.size() + n + m +
                         static_cast<Eigen::Index>(lin.quantities.size());
  auto flatten = [&](const Steady& st, const std::vector<double>& q) {
    Eigen::VectorXd v(flat_size);
    Eigen::Index c = 0;
    for (const Eigen::MatrixXd* mat : {&st.at.A, &st.at.B, &st.at.C, &st.at.D})
      for (Eigen::Index j = 0; j < mat->cols(); ++j)
        for (Eigen::Index i = 0; i < mat->rows(); ++i) v(c++) = (*mat)(i, j);
    v.segment(c, n) = st.x, c += n;
    v.segment(c, m) = st.u, c += m;
    for (double d : q) v(c++) = d;
    return v;
  };
  Eigen::MatrixXd G(flat_size, nf);
  std::vector<double> th(theta.begin(), theta.end());
  for (Eigen::Index j = 0; j < nf; ++j) {
    const int idx = options.free[static_cast<std::size_t>(j)];
    const double sd = std::sqrt(std::max(options.covariance(j, j), 0.0));
    const double step = 1e-4 * std::max({std::abs(th[static_cast<std::size_t>(idx)]), sd, 1e-8});
    Eigen::VectorXd side[2];
    for (int sgn = 0; sgn < 2; ++sgn) {
      th[static_cast<std::size_t>(idx)] =
          theta[static_cast<std::size_t>(idx)] + (sgn ? step : -step);
      at.SetTheta(th);
      auto st = SolveSteady(at, k, nominal->x, nominal->u);
      if (!st) return st.error();
      auto q = EvaluateQuantities(qexprs, options.quantities, Names(s, *st, th));
      if (!q) return q.error();
      side[sgn] = flatten(*st, *q);
    }
    th[static_cast<std::size_t>(idx)] = theta[static_cast<std::size_t>(idx)];
    G.col(j) = (side[1] - side[0]) / (2 * step);
  }
  const Eigen::VectorXd var = (G * options.covariance).cwiseProduct(G).rowwise().sum();
  const Eigen::VectorXd se = var.cwiseMax(0).cwiseSqrt();
  Eigen::Index c = 0;
  for (Eigen::MatrixXd* mat : {&lin.se_A, &lin.se_B, &lin.se_C, &lin.se_D})
    for (Eigen::Index j = 0; j < mat->cols(); ++j)
      for (Eigen::Index i = 0; i < mat->rows(); ++i) (*mat)(i, j) = se(c++);
  lin.se_x = se.segment(c, n), c += n;
  lin.se_u = se.segment(c, m), c += m;
  for (double& q : lin.se_quantities) q = se(c++);
  if (auto st = CheckFinite(s, lin, options.quantities, /*se=*/true); !st) return st.error();
  return lin;
}

// ---- 5. steady states for many points ---------------------------------------------------------

struct SteadyStateSolver::Impl {
  Impl(const NonlinearModel& m, expr::Tape t) : model(m), tape(std::move(t)), point(model, tape) {
    for (int i = 0; i < model.n_states(); ++i) all_states.states.push_back(i);
  }
  const NonlinearModel& model;
  expr::Tape tape;
  Point point;
  Unknowns all_states;
};

Result<SteadyStateSolver> SteadyStateSolver::Make(const NonlinearModel& model) {
  if (auto st = CheckTimeInvariant(model.spec()); !st) return st.error();
  auto tape = InputDerivatives(model);
  if (!tape) return tape.error();
  return SteadyStateSolver(std::make_unique<Impl>(model, std::move(*tape)));
}

SteadyStateSolver::SteadyStateSolver(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SteadyStateSolver::SteadyStateSolver(SteadyStateSolver&&) noexcept = default;
SteadyStateSolver& SteadyStateSolver::operator=(SteadyStateSolver&&) noexcept = default;
SteadyStateSolver::~SteadyStateSolver() = default;

Eigen::VectorXd SteadyStateSolver::InitialState(std::span<const double> theta) const {
  const NonlinearModel& model = impl_->model;
  std::vector<double> slots(static_cast<std::size_t>(model.n_slots()), 0.0);
  std::copy(theta.begin(), theta.end(), slots.begin() + model.parameter_slot());
  std::vector<double> init(model.initial_size());
  model.Initial(slots, init);
  return Eigen::Map<const Eigen::VectorXd>(init.data(), model.n_states());
}

Result<Eigen::VectorXd> SteadyStateSolver::Solve(std::span<const double> theta,
                                                 const Eigen::VectorXd& u,
                                                 const Eigen::VectorXd& guess, Eigen::VectorXd* y) {
  impl_->point.SetTheta(theta);
  auto st = SolveSteady(impl_->point, impl_->all_states, guess, u);
  if (!st) return st.error();
  if (y) *y = st->at.h;
  return st->x;
}

}  // namespace gb::model
