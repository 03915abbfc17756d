#include "core/model/nonlinear_sensitivity.h"

#include <cassert>
#include <cmath>

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
  if (native_) {
    native_(slots.data(), dense.data());
    return;
  }
  tape_.Eval(slots, scratch.first(positions_.size()));
  for (std::size_t k = 0; k < positions_.size(); ++k) dense[positions_[k]] = scratch[k];
}

std::vector<expr::NativeCode::Program> NonlinearSensitivity::NativePrograms() const {
  std::vector<expr::NativeCode::Program> programs;
  for (const Program* p : {&dynamics_, &measurement_, &initial_})
    programs.push_back({p->exprs_, p->positions_});
  return programs;
}

void NonlinearSensitivity::UseNative(std::shared_ptr<const expr::NativeCode> code,
                                     std::size_t first) {
  assert(code && first + 3 <= code->size());
  std::size_t k = first;
  for (Program* p : {&dynamics_, &measurement_, &initial_}) p->native_ = code->function(k++);
  native_ = std::move(code);
}

Result<NonlinearSensitivity> NonlinearSensitivity::Compile(const NonlinearModel& model) {
  using std::size_t;
  const ModelSpec& spec = model.spec();
  NonlinearSensitivity s;
  const size_t n = s.n_ = spec.states.size();
  const size_t p = s.p_ = spec.outputs.size();
  const size_t np = s.np_ = spec.parameters.size();
  s.source_ = spec.source;
  s.slot_names_ = spec.states;
  s.slot_names_.insert(s.slot_names_.end(), spec.inputs.begin(), spec.inputs.end());
  for (const Parameter& par : spec.parameters) s.slot_names_.push_back(par.name);
  s.slot_names_.push_back("t");
  auto par = [&](size_t l) -> const std::string& { return spec.parameters[l].name; };
  auto builder = [](Program& program) {
    return Builder{&program, &program.positions_, &program.names_, &program.exprs_};
  };
  auto at = [](size_t offset, size_t column, size_t rows, size_t row) {
    return offset + column * rows + row;
  };
  auto constant = [](const expr::ExprPtr& e) {
    double value = 0.0;
    return expr::IsConstant(e, &value);
  };

  // dynamics
  s.dynamics_.size_ = n * np + n * n * n + np * n * n + n * n + n * np;
  const Builder dyn = builder(s.dynamics_);
  for (size_t i = 0; i < n; ++i) {
    const Formula& drift = spec.drift[i];
    for (size_t l = 0; l < np; ++l)
      dyn.Add(at(0, l, n, i), expr::Differentiate(drift.expr, par(l)),
              Derivative(drift.path, par(l)));
    for (size_t j = 0; j < n; ++j) {
      const expr::ExprPtr Jij = expr::Differentiate(drift.expr, spec.states[j]);
      if (constant(Jij)) continue;  // its derivatives are all zero
      const std::string name = Derivative(drift.path, spec.states[j]);
      for (size_t m = 0; m < n; ++m)
        dyn.Add(at(s.DynJx(static_cast<int>(m)), j, n, i), expr::Differentiate(Jij, spec.states[m]),
                Derivative(name, spec.states[m]));
      for (size_t l = 0; l < np; ++l)
        dyn.Add(at(s.DynJtheta(static_cast<int>(l)), j, n, i), expr::Differentiate(Jij, par(l)),
                Derivative(name, par(l)));
    }
    const Formula& diffusion = spec.diffusion[i];
    for (size_t m = 0; m < n; ++m)
      dyn.Add(at(s.DynSigmaX(), m, n, i), expr::Differentiate(diffusion.expr, spec.states[m]),
              Derivative(diffusion.path, spec.states[m]));
    for (size_t l = 0; l < np; ++l)
      dyn.Add(at(s.DynSigmaTheta(), l, n, i), expr::Differentiate(diffusion.expr, par(l)),
              Derivative(diffusion.path, par(l)));
  }

  // measurement
  s.measurement_.size_ = p * np + n * p * n + np * p * n + p * np;
  const Builder mea = builder(s.measurement_);
  for (size_t o = 0; o < p; ++o) {
    const Formula& observation = spec.observation[o];
    for (size_t l = 0; l < np; ++l)
      mea.Add(at(0, l, p, o), expr::Differentiate(observation.expr, par(l)),
              Derivative(observation.path, par(l)));
    for (size_t j = 0; j < n; ++j) {
      const expr::ExprPtr Hoj = expr::Differentiate(observation.expr, spec.states[j]);
      if (constant(Hoj)) continue;
      const std::string name = Derivative(observation.path, spec.states[j]);
      for (size_t m = 0; m < n; ++m)
        mea.Add(at(s.MeasHx(static_cast<int>(m)), j, p, o),
                expr::Differentiate(Hoj, spec.states[m]), Derivative(name, spec.states[m]));
      for (size_t l = 0; l < np; ++l)
        mea.Add(at(s.MeasHtheta(static_cast<int>(l)), j, p, o), expr::Differentiate(Hoj, par(l)),
                Derivative(name, par(l)));
    }
    const Formula& variance = spec.measurement_variance[o];
    for (size_t l = 0; l < np; ++l)
      mea.Add(at(s.MeasStheta(), l, p, o), expr::Differentiate(variance.expr, par(l)),
              Derivative(variance.path, par(l)));
  }

  // initial
  const bool explicit_p0 = spec.initial_covariance == InitialCovariance::kExplicit;
  s.initial_.size_ = n * np * (explicit_p0 ? 2 : 1);
  const Builder ini = builder(s.initial_);
  for (size_t i = 0; i < n; ++i) {
    for (size_t l = 0; l < np; ++l) {
      ini.Add(at(0, l, n, i), expr::Differentiate(spec.initial_state[i].expr, par(l)),
              Derivative(spec.initial_state[i].path, par(l)));
      if (explicit_p0)
        ini.Add(at(s.InitP0theta(), l, n, i),
                expr::Differentiate(spec.initial_variance[i].expr, par(l)),
                Derivative(spec.initial_variance[i].path, par(l)));
    }
  }

  auto slot_of = [&model](const std::string& name) { return model.SlotOf(name); };
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
    if (!std::isfinite(value))
      return NotFiniteEntry(program.names_[k], value, program.exprs_[k], slot_names_, slots,
                            source_);
  }
  return std::nullopt;
}

}  // namespace gb::model
