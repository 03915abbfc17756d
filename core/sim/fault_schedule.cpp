#include "core/sim/fault_schedule.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <optional>

#include <fmt/format.h>

namespace gb::sim {
namespace {

// The whole of `s` as a finite number.
std::optional<double> Number(std::string_view s) {
  double value = 0;
  const char* end = s.data() + s.size();
  auto [ptr, ec] = std::from_chars(s.data(), end, value);
  if (s.empty() || ec != std::errc() || ptr != end || !std::isfinite(value)) return std::nullopt;
  return value;
}

}  // namespace

Error FuelFaultError(std::string_view option, const std::string& text, const std::string& what) {
  return InputError(fmt::format("{} '{}': {}", option, text, what));
}

Result<TimedFuelFault> ParseFuelFault(const std::string& text, std::string_view option) {
  TimedFuelFault f;
  f.text = text;
  const auto colon = text.find(':');
  if (colon == std::string::npos) return FuelFaultError(option, text, kFuelFaultForm);
  const std::string_view spec = std::string_view(text).substr(colon + 1);
  const std::string_view time = std::string_view(text).substr(0, colon);
  const auto at = Number(time);
  if (!at || *at < 0)
    return FuelFaultError(option, text,
                          fmt::format("the time '{}' is not a number of seconds >= 0", time));
  f.at_s = *at;
  const auto slash = spec.find('/');
  const std::string_view change = spec.substr(0, slash);
  if (slash != std::string_view::npos) {
    const std::string_view ramp = spec.substr(slash + 1);
    const auto r = Number(ramp);
    if (!r || *r < 0)
      return FuelFaultError(option, text,
                            fmt::format("the ramp '{}' is not a number of seconds >= 0", ramp));
    f.fault.ramp_s = *r;
  }
  if (change == "clear") {
    f.clear = true;
    return f;
  }
  const auto star = change.find('*');
  const std::string_view name = change.substr(0, star);
  using Kind = FuelFault::Kind;
  bool known = false;
  for (Kind kind : {Kind::kTauFF, Kind::kX, Kind::kSensorDelay, Kind::kSensorGain}) {
    if (name == FaultName(kind)) {
      f.fault.kind = kind;
      known = true;
    }
  }
  if (!known)
    return FuelFaultError(
        option, text,
        fmt::format("unknown parameter '{}' (tau_ff, X, delay, gain, or clear)", name));
  if (star == std::string_view::npos)
    return FuelFaultError(option, text, fmt::format("no factor: expected {}*FACTOR", name));
  const std::string_view factor = change.substr(star + 1);
  const auto x = Number(factor);
  if (!x)
    return FuelFaultError(option, text, fmt::format("the factor '{}' is not a number", factor));
  f.fault.factor = *x;
  return f;
}

Result<std::vector<TimedFuelFault>> ScheduleFuelFaults(std::vector<TimedFuelFault> faults,
                                                       const FuelOperatingPoint& point,
                                                       std::string_view option) {
  std::stable_sort(
      faults.begin(), faults.end(),
      [](const TimedFuelFault& a, const TimedFuelFault& b) { return a.at_s < b.at_s; });
  FuelFaults replay(point, LiveFuelDyno::MaxSensorDelay(point));
  for (const auto& f : faults) {
    const Status st =
        f.clear ? replay.Clear(f.at_s, f.fault.ramp_s) : replay.Inject(f.fault, f.at_s);
    if (!st) return FuelFaultError(option, f.text, st.error().message);
  }
  return faults;
}

std::string DescribeFuelFault(const TimedFuelFault& f) {
  const std::string ramp =
      f.fault.ramp_s > 0 ? fmt::format("linearly over {} s", f.fault.ramp_s) : "as a step";
  if (f.clear)
    return fmt::format("fault: at {} s every parameter back to nominal, {}", f.at_s, ramp);
  return fmt::format("fault: at {} s {} x {}, {}", f.at_s, FaultName(f.fault.kind), f.fault.factor,
                     ramp);
}

Status ApplyDueFuelFaults(const std::vector<TimedFuelFault>& faults, std::size_t* next,
                          LiveFuelDyno* dyno, std::string_view option) {
  const double ts = dyno->experiment().recording.sample_time;
  for (; *next < faults.size() && faults[*next].at_s <= dyno->Time() + 1e-6 * ts; ++*next) {
    const TimedFuelFault& f = faults[*next];
    const Status st = f.clear ? dyno->ClearFaults(f.fault.ramp_s) : dyno->Inject(f.fault);
    if (!st) return FuelFaultError(option, f.text, st.error().message);
  }
  return Ok{};
}

}  // namespace gb::sim
