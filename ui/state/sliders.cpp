// The sliders' life in AppState (declared in ui/state/app_state.h): which parameters have one
// (the project's "sliders" list), the values they were moved to (a what-if the analysis is
// computed at), the ghost of a drag, and making the moved values the model's.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "ui/state/app_state.h"

namespace gb::ui {
namespace {

constexpr double kDecades = 2.0;  // a positive range this many decades wide is shown on a log scale
constexpr double kAround = 10.0;  // without bounds: a positive value's range, value / 10 .. x 10

const project::SliderSpec* FindSpec(const SlidersState& s, const std::string& parameter) {
  for (const project::SliderSpec& spec : s.shown)
    if (spec.parameter == parameter) return &spec;
  return nullptr;
}

void WriteSliders(AppState& state) {
  if (!state.project) return;
  if (!state.project->extra.is_object()) state.project->extra = Json::object();
  if (state.sliders.shown.empty())
    state.project->extra.erase(project::kSlidersKey);
  else
    state.project->extra[project::kSlidersKey] = project::SlidersToJson(state.sliders.shown);
  ++state.layout_revision;
}

}  // namespace

SliderScale SliderRange(const model::Parameter& p, double value, const project::SliderSpec& spec) {
  SliderScale s;
  const bool finite_value = std::isfinite(value);
  if (spec.min && spec.max) {
    s.min = *spec.min;
    s.max = *spec.max;
  } else if (p.lower && p.upper && std::isfinite(*p.lower) && std::isfinite(*p.upper) &&
             *p.lower < *p.upper) {
    s.min = *p.lower;
    s.max = *p.upper;
  } else if (finite_value && value > 0 && (!p.lower || *p.lower >= 0)) {
    s.min = value / kAround;
    s.max = value * kAround;
  } else {
    const double half = finite_value ? std::max(std::abs(value), 1.0) : 1.0;
    const double centre = finite_value ? value : 0.0;
    s.min = centre - half;
    s.max = centre + half;
  }
  // Within the bounds, and around the value.
  if (!spec.min) {
    if (p.lower && std::isfinite(*p.lower)) s.min = std::max(s.min, *p.lower);
    if (p.upper && std::isfinite(*p.upper)) s.max = std::min(s.max, *p.upper);
  }
  if (finite_value) {
    s.min = std::min(s.min, value);
    s.max = std::max(s.max, value);
  }
  if (!(s.min < s.max)) {  // a bound pair collapsed onto the value
    const double half = std::max(std::abs(s.min), 1.0) * 0.5;
    s.min -= half;
    s.max += half;
  }
  const bool positive = s.min > 0;
  s.log = spec.log ? *spec.log && positive : positive && s.max / s.min >= std::pow(10.0, kDecades);
  return s;
}

bool SliderShown(const AppState& state, const std::string& parameter) {
  return FindSpec(state.sliders, parameter) != nullptr;
}

void ShowSlider(AppState& state, const std::string& parameter, bool show) {
  SlidersState& s = state.sliders;
  auto it = std::find_if(s.shown.begin(), s.shown.end(), [&](const project::SliderSpec& spec) {
    return spec.parameter == parameter;
  });
  if (show == (it != s.shown.end())) return;
  if (show) {
    s.shown.push_back(project::SliderSpec{parameter, {}, {}, {}});
    s.open = true;
  } else {
    s.shown.erase(it);
    s.moved.erase(parameter);  // a hidden slider moves nothing
  }
  WriteSliders(state);
}

double SliderBaseValue(const AppState& state, std::size_t index) {
  if (!state.model || index >= state.model->parameters.size()) return 0.0;
  const FitResult* fit = state.estimation.result ? &*state.estimation.result : nullptr;
  if (fit && !state.analysis.use_current_values && FitMatchesModel(*fit, *state.model) &&
      index < fit->summary.theta.size())
    return fit->summary.theta[index];
  return state.model->parameters[index].value;
}

double SliderValue(const AppState& state, std::size_t index) {
  if (!state.model || index >= state.model->parameters.size()) return 0.0;
  const auto it = state.sliders.moved.find(state.model->parameters[index].name);
  return it != state.sliders.moved.end() ? it->second : SliderBaseValue(state, index);
}

void MoveSlider(AppState& state, const std::string& parameter, double value) {
  if (!std::isfinite(value) || !SliderShown(state, parameter)) return;
  state.sliders.moved[parameter] = value;
}

void BeginSliderDrag(AppState& state) {
  SlidersState& s = state.sliders;
  s.dragging = true;
  s.ghost = state.analysis.result;
}

void EndSliderDrag(AppState& state) {
  SlidersState& s = state.sliders;
  s.dragging = false;
  s.ghost.reset();
}

void ResetSliders(AppState& state) { state.sliders.moved.clear(); }

void UseSliderValuesAsStart(AppState& state) {
  SlidersState& s = state.sliders;
  if (!state.model || s.moved.empty()) return;
  for (const auto& [name, value] : s.moved) {
    ParameterEdit edit;
    edit.parameter = name;
    edit.field = ParameterField::kValue;
    edit.number = value;
    edit.text = fmt::format("{}", value);
    state.parameters_view.pending.push_back(std::move(edit));
  }
  s.moved.clear();
  // The views go on showing these values, now the model's, rather than the fit's estimates.
  if (state.estimation.result) state.analysis.use_current_values = true;
  ApplyParameterEdits(state);
}

void ApplySliders(const AppState& state, std::vector<double>* theta) {
  if (!state.model) return;
  const std::vector<model::Parameter>& ps = state.model->parameters;
  for (const auto& [name, value] : state.sliders.moved) {
    for (std::size_t i = 0; i < ps.size() && i < theta->size(); ++i)
      if (ps[i].name == name) (*theta)[i] = value;
  }
}

void InstallSliders(AppState& state) {
  SlidersState& s = state.sliders;
  s = SlidersState{};
  if (!state.project) return;
  for (project::SliderSpec& spec : project::ReadSliders(*state.project)) {
    const bool known =
        state.model &&
        std::any_of(state.model->parameters.begin(), state.model->parameters.end(),
                    [&](const model::Parameter& p) { return p.name == spec.parameter; });
    if (!known && state.model) {
      AddMessage(state, Severity::kWarning,
                 fmt::format("The project's slider for {} is not shown: the model has no such "
                             "parameter",
                             spec.parameter));
      continue;
    }
    s.shown.push_back(std::move(spec));
  }
  s.open = !s.shown.empty();
}

}  // namespace gb::ui
