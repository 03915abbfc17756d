// Fault schedules of the live fuel dyno (live_dyno.h), written as the command line writes them
// (greybench-cli dyno fuel --live --fault, greybench-snapshot --live-fault):
//
//   TIME:PARAMETER*FACTOR[/RAMP]   PARAMETER one of tau_ff, X, delay, gain (FaultName); e.g.
//                                  60:tau_ff*1.5 a step at 60 s, 60:tau_ff*1.5/30 a ramp over 30 s
//   TIME:clear[/RAMP]              every parameter back to nominal (LiveFuelDyno::ClearFaults)
//
// TIME and RAMP in seconds (>= 0), FACTOR any finite number (the dyno refuses what it cannot do).
// A fault at TIME acts from the first sample at or after TIME (ApplyDueFuelFaults).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "core/sim/live_dyno.h"
#include "core/util/result.h"

namespace gb::sim {

struct TimedFuelFault {
  std::string text;  // as given
  double at_s = 0;
  bool clear = false;  // every parameter back to nominal over fault.ramp_s
  FuelFault fault;
};

// What a fault looks like, for messages.
inline constexpr const char* kFuelFaultForm =
    "expected TIME:PARAMETER*FACTOR[/RAMP] (PARAMETER tau_ff, X, delay or gain; e.g. "
    "60:tau_ff*1.5 for a step at 60 s, 60:tau_ff*1.5/30 for a ramp over 30 s) or TIME:clear[/RAMP]";

// An input Error "OPTION 'TEXT': WHAT", OPTION naming the argument ("--fault").
Error FuelFaultError(std::string_view option, const std::string& text, const std::string& what);

// One fault. Errors (FuelFaultError) say which part is wrong: the form, the time, the ramp, an
// unknown parameter, a missing or non-numeric factor.
Result<TimedFuelFault> ParseFuelFault(const std::string& text, std::string_view option);

// The faults in time order (their given order at equal times), checked by replaying them on the
// operating point's values: a fault the dyno would refuse (FuelFaults::Inject) is refused here,
// before a run, naming that fault.
Result<std::vector<TimedFuelFault>> ScheduleFuelFaults(std::vector<TimedFuelFault> faults,
                                                       const FuelOperatingPoint& point,
                                                       std::string_view option);

// "fault: at 60 s tau_ff x 1.5, as a step" (a line of the record's comments).
std::string DescribeFuelFault(const TimedFuelFault& f);

// Applies the scheduled faults (time order) from faults[*next] on that are due before the dyno's
// next sample (at_s <= Time() + 1e-6 T_s) and moves *next past them. An error names the fault the
// dyno refused (*next then indexes it).
Status ApplyDueFuelFaults(const std::vector<TimedFuelFault>& faults, std::size_t* next,
                          LiveFuelDyno* dyno, std::string_view option);

}  // namespace gb::sim
