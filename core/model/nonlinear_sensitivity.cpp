#include "core/model/nonlinear_sensitivity.h"

#include <cmath>
#include <set>

#include <fmt/format.h>

namespace gb::model {
namespace {

// Collects the entries of one program: `Add(position, expr, name)` keeps those not identically 0.
struct Builder {
  NonlinearSensitivity::Program* program;
  std::vector<std::size_t>* positions;
  std::vector<std::string>* names;
  std::vector<expr::ExprPtr>* exprs;

  void Add(std::size_t position, const expr::ExprPtr& e, std::string name) const {
    double value = 0.0;
    if (expr::IsConstant(e, &value) && value == 0.0) return;
    positions->push_back(position);
    exprs->push_back(e);
    names->push_back(std::move(name));
  }
};

std::string Derivative(const std::string& of, const std::string& by) {
  return fmt::format("the derivative of {} with respect to {}", of, by);
}

}  // namespace

void NonlinearSensitivity::Program::Eval(std::span<const double> slots, std::span<double> dense,
                                         std::span<double> scratch) const {
  assert(dense.size() == size_ && scratch.size() >= positions_.size());
  tape_.Eval(slots, scratch.first(positions_.size()));
  for (std::size_t k = 0; k < positions_.size(); ++k) dense[positions_[k]] = scratch[k];
}

Result<NonlinearSensitivity> NonlinearSensitivity::Compile(const NonlinearModel& model) {
  const ModelSpec& spec = model.spec();
  NonlinearSensitivity s;
  const int n = s.n_ = model.n_states();
  const int p = s.p_ = model.n_outputs();
  const int np = s.np_ = model.n_parameters();
  const int m_in = model.n_inputs();
  s.source_ = spec.source;
  for (int i = 0; i < n; ++i) s.slot_names_.push_back(spec.states[i]);
  for (int i = 0; i < m_in; ++i) s.slot_names_.push_back(spec.inputs[i]);
  for (int l = 0; l < np; ++l) s.slot_names_.push_back(spec.parameters[l].name);
  s.slot_names_.push_back("t");
  auto par = [&](int l) -> const std::string& { return spec.parameters[l].name; };
  auto builder = [](Program& program) {
    return Builder{&program, &program.positions_, &program.names_, &program.exprs_};
  };
  using std::size_t;

  // dynamics
  s.dynamics_.size_ = static_cast<size_t>(n * np + n * n * n + np * n * n + n * n + n * np);
  const Builder dyn = builder(s.dynamics_);
  for (int l = 0; l < np; ++l)
    for (int i = 0; i < n; ++i)
      dyn.Add(static_cast<size_t>(l * n + i), expr::Differentiate(spec.drift[i].expr, par(l)),
              Derivative(spec.drift[i].path, par(l)));
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const expr::ExprPtr Jij = expr::Differentiate(spec.drift[i].expr, spec.states[j]);
      double value = 0.0;
      if (expr::IsConstant(Jij, &value)) continue;  // its derivatives are all zero
      const std::string name = Derivative(spec.drift[i].path, spec.states[j]);
      for (int m = 0; m < n; ++m)
        dyn.Add(s.DynJx(m) + static_cast<size_t>(j * n + i), expr::Differentiate(Jij, spec.states[m]),
                Derivative(name, spec.states[m]));
      for (int l = 0; l < np; ++l)
        dyn.Add(s.DynJtheta(l) + static_cast<size_t>(j * n + i), expr::Differentiate(Jij, par(l)),
                Derivative(name, par(l)));
    }
  }
  for (int i = 0; i < n; ++i) {
    for (int m = 0; m < n; ++m)
      dyn.Add(s.DynSigmaX() + static_cast<size_t>(m * n + i),
              expr::Differentiate(spec.diffusion[i].expr, spec.states[m]),
              Derivative(spec.diffusion[i].path, spec.states[m]));
    for (int l = 0; l < np; ++l)
      dyn.Add(s.DynSigmaTheta() + static_cast<size_t>(l * n + i),
              expr::Differentiate(spec.diffusion[i].expr, par(l)),
              Derivative(spec.diffusion[i].path, par(l)));
  }

  // measurement
  s.measurement_.size_ = static_cast<size_t>(p * np + n * p * n + np * p * n + p * np);
  const Builder mea = builder(s.measurement_);
  for (int o = 0; o < p; ++o) {
    const std::string& path = spec.observation[o].path;
    for (int l = 0; l < np; ++l)
      mea.Add(static_cast<size_t>(l * p + o), expr::Differentiate(spec.observation[o].expr, par(l)),
              Derivative(path, par(l)));
    for (int j = 0; j < n; ++j) {
      const expr::ExprPtr Hoj = expr::Differentiate(spec.observation[o].expr, spec.states[j]);
      double value = 0.0;
      if (expr::IsConstant(Hoj, &value)) continue;
      const std::string name = Derivative(path, spec.states[j]);
      for (int m = 0; m < n; ++m)
        mea.Add(s.MeasHx(m) + static_cast<size_t>(j * p + o), expr::Differentiate(Hoj, spec.states[m]),
                Derivative(name, spec.states[m]));
      for (int l = 0; l < np; ++l)
        mea.Add(s.MeasHtheta(l) + static_cast<size_t>(j * p + o), expr::Differentiate(Hoj, par(l)),
                Derivative(name, par(l)));
    }
    for (int l = 0; l < np; ++l)
      mea.Add(s.MeasStheta() + static_cast<size_t>(l * p + o),
              expr::Differentiate(spec.measurement_variance[o].expr, par(l)),
              Derivative(spec.measurement_variance[o].path, par(l)));
  }

  // initial
  const bool explicit_p0 = spec.initial_covariance == InitialCovariance::kExplicit;
  s.initial_.size_ = static_cast<size_t>(n * np * (explicit_p0 ? 2 : 1));
  const Builder ini = builder(s.initial_);
  for (int l = 0; l < np; ++l) {
    for (int i = 0; i < n; ++i) {
      ini.Add(static_cast<size_t>(l * n + i), expr::Differentiate(spec.initial_state[i].expr, par(l)),
              Derivative(spec.initial_state[i].path, par(l)));
      if (explicit_p0)
        ini.Add(s.InitP0theta() + static_cast<size_t>(l * n + i),
                expr::Differentiate(spec.initial_variance[i].expr, par(l)),
                Derivative(spec.initial_variance[i].path, par(l)));
    }
  }

  auto slot_of = [&](const std::string& name) {
    for (int k = 0; k < static_cast<int>(s.slot_names_.size()); ++k)
      if (s.slot_names_[k] == name) return k;
    return -1;
  };
  for (Program* program : {&s.dynamics_, &s.measurement_, &s.initial_}) {
    auto compiled = expr::Tape::Compile(program->exprs_, slot_of);
    if (!compiled) {
      Error e = compiled.error();
      e.file = spec.source;
      e.message = "the model's derivatives cannot be compiled: " + e.message;
      return e;
    }
    program->tape_ = std::move(*compiled);
  }
  return s;
}

std::optional<Error> NonlinearSensitivity::NotFinite(const Program& program,
                                                     std::span<const double> dense,
                                                     std::span<const double> slots) const {
  for (std::size_t k = 0; k < program.positions_.size(); ++k) {
    const double value = dense[program.positions_[k]];
    if (std::isfinite(value)) continue;
    std::set<std::string> used;
    expr::CollectNames(program.exprs_[k], &used);
    std::string values;
    for (std::size_t slot = 0; slot < slot_names_.size() && slot < slots.size(); ++slot) {
      if (!used.count(slot_names_[slot])) continue;
      values += fmt::format("{}{} = {:g}", values.empty() ? "" : ", ", slot_names_[slot], slots[slot]);
    }
    Error e = NumericalError(fmt::format("{} is {} at these values{}", program.names_[k],
                                         std::isnan(value) ? "not a number" : "infinite",
                                         values.empty() ? "" : " (" + values + ")"));
    e.file = source_;
    return e;
  }
  return std::nullopt;
}

}  // namespace gb::model
