#include "core/model/nonlinear_model.h"

#include <cassert>
#include <cmath>
#include <set>

#include <fmt/format.h>

namespace gb::model {
namespace {

// The slot of a name: [x (n) | u (m) | θ (np) | t], -1 for a name that is none of them.
int SlotIndex(const ModelSpec& spec, const std::string& name) {
  const int n = static_cast<int>(spec.states.size());
  const int m = static_cast<int>(spec.inputs.size());
  const int np = static_cast<int>(spec.parameters.size());
  if (const int i = spec.StateIndex(name); i >= 0) return i;
  if (const int i = spec.InputIndex(name); i >= 0) return n + i;
  if (const int i = spec.ParameterIndex(name); i >= 0) return n + m + i;
  if (name == "t") return n + m + np;
  return -1;
}

}  // namespace

Result<NonlinearModel> NonlinearModel::Compile(ModelSpec spec) {
  NonlinearModel nm;
  const int n = static_cast<int>(spec.states.size());
  const int p = static_cast<int>(spec.outputs.size());

  Entries& dyn = nm.dynamics_entries_;
  for (int i = 0; i < n; ++i) {
    dyn.exprs.push_back(spec.drift[i].expr);
    dyn.names.push_back(spec.drift[i].path);
  }
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      dyn.exprs.push_back(expr::Differentiate(spec.drift[i].expr, spec.states[j]));
      dyn.names.push_back(fmt::format("the derivative of {} with respect to {}", spec.drift[i].path,
                                      spec.states[j]));
    }
  }
  for (int i = 0; i < n; ++i) {
    dyn.exprs.push_back(spec.diffusion[i].expr);
    dyn.names.push_back(spec.diffusion[i].path);
  }

  Entries& mea = nm.measurement_entries_;
  for (int o = 0; o < p; ++o) {
    mea.exprs.push_back(spec.observation[o].expr);
    mea.names.push_back(spec.observation[o].path);
  }
  for (int o = 0; o < p; ++o) {
    for (int j = 0; j < n; ++j) {
      mea.exprs.push_back(expr::Differentiate(spec.observation[o].expr, spec.states[j]));
      mea.names.push_back(fmt::format("the derivative of {} with respect to {}",
                                      spec.observation[o].path, spec.states[j]));
    }
  }
  for (int o = 0; o < p; ++o) {
    mea.exprs.push_back(spec.measurement_variance[o].expr);
    mea.names.push_back(spec.measurement_variance[o].path);
  }

  Entries& ini = nm.initial_entries_;
  for (int i = 0; i < n; ++i) {
    ini.exprs.push_back(spec.initial_state[i].expr);
    ini.names.push_back(spec.initial_state[i].path);
  }
  if (spec.initial_covariance == InitialCovariance::kExplicit) {
    for (int i = 0; i < n; ++i) {
      ini.exprs.push_back(spec.initial_variance[i].expr);
      ini.names.push_back(spec.initial_variance[i].path);
    }
  }

  Entries& noi = nm.noise_entries_;
  for (int i = 0; i < n; ++i) {
    noi.exprs.push_back(spec.diffusion[i].expr);
    noi.names.push_back(spec.diffusion[i].path);
  }
  for (int i = 0; i < n; ++i) {
    noi.exprs.push_back(expr::Differentiate(spec.diffusion[i].expr, spec.states[i]));
    noi.names.push_back(fmt::format("the derivative of {} with respect to {}",
                                    spec.diffusion[i].path, spec.states[i]));
  }

  auto slot_of = [&](const std::string& name) { return SlotIndex(spec, name); };
  for (auto [entries, tape] : {std::pair{&dyn, &nm.dynamics_}, std::pair{&mea, &nm.measurement_},
                               std::pair{&ini, &nm.initial_}, std::pair{&noi, &nm.noise_}}) {
    auto compiled = expr::Tape::Compile(entries->exprs, slot_of);
    if (!compiled) {
      Error e = compiled.error();
      e.file = spec.source;
      e.message = "the model cannot be compiled: " + e.message;
      return e;
    }
    *tape = std::move(*compiled);
  }
  nm.spec_ = std::move(spec);
  return nm;
}

int NonlinearModel::SlotOf(const std::string& name) const { return SlotIndex(spec_, name); }

std::vector<expr::NativeCode::Program> NonlinearModel::NativePrograms() const {
  std::vector<expr::NativeCode::Program> programs;
  for (const Entries* e :
       {&dynamics_entries_, &measurement_entries_, &initial_entries_, &noise_entries_})
    programs.push_back({e->exprs, {}});
  return programs;
}

void NonlinearModel::UseNative(std::shared_ptr<const expr::NativeCode> code, std::size_t first) {
  assert(code && first + native_functions_.size() <= code->size());
  for (std::size_t k = 0; k < native_functions_.size(); ++k)
    native_functions_[k] = code->function(first + k);
  native_ = std::move(code);
}

const NonlinearModel::Entries& NonlinearModel::EntriesOf(Program program) const {
  switch (program) {
    case Program::kDynamics:
      return dynamics_entries_;
    case Program::kMeasurement:
      return measurement_entries_;
    case Program::kNoise:
      return noise_entries_;
    case Program::kInitial:
      break;
  }
  return initial_entries_;
}

const expr::ExprPtr& NonlinearModel::Entry(Program program, std::size_t k) const {
  return EntriesOf(program).exprs.at(k);
}

std::string NonlinearModel::SlotName(int slot) const {
  const int n = n_states(), m = n_inputs();
  if (slot < n) return spec_.states[slot];
  if (slot < n + m) return spec_.inputs[slot - n];
  if (slot < time_slot()) return spec_.parameters[slot - n - m].name;
  return "t";
}

Error NotFiniteEntry(const std::string& name, double value, const expr::ExprPtr& e,
                     std::span<const std::string> slot_names, std::span<const double> slots,
                     const std::string& source) {
  std::set<std::string> used;
  expr::CollectNames(e, &used);
  std::string values;
  for (std::size_t slot = 0; slot < slot_names.size() && slot < slots.size(); ++slot) {
    if (!used.count(slot_names[slot])) continue;
    values += fmt::format("{}{} = {:g}", values.empty() ? "" : ", ", slot_names[slot], slots[slot]);
  }
  Error err = NumericalError(fmt::format("{} is {} at these values{}", name,
                                         std::isnan(value) ? "not a number" : "infinite",
                                         values.empty() ? "" : " (" + values + ")"));
  err.file = source;
  return err;
}

Error NonlinearModel::NotFinite(Program program, std::size_t k, double value,
                                std::span<const double> slots) const {
  const Entries& entries = EntriesOf(program);
  std::vector<std::string> names(static_cast<std::size_t>(n_slots()));
  for (int slot = 0; slot < n_slots(); ++slot)
    names[static_cast<std::size_t>(slot)] = SlotName(slot);
  return NotFiniteEntry(entries.names[k], value, entries.exprs[k], names, slots, spec_.source);
}

}  // namespace gb::model
