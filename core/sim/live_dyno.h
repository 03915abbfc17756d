// The virtual dyno running live: the fuel and crankshaft experiments of dyno.h as sources that
// give one recorded sample at a time, without end, and take faults while they run (an injector
// that clogs, a λ sensor that ages), for an on-line condition monitor to watch.
//
// The world is the batch experiments' (dyno.h): the continuous world is stepped on the fine grid
// h = T_s / oversample after the same warm-up, every channel passes the same anti-alias filter and
// gets the converter's noise at the samples, and the PRBS runs on (it repeats after 2^n - 1 bits).
// RunFuelExperiment and RunCrankshaftExperiment are these dynos run for `duration` without faults,
// so with no fault the live samples are bit-identical to the batch record of the same experiment.
//
// Faults act on the continuous world, on the fine grid. A fault moves one parameter p from its
// value at the time of injection t0 (the time of the next sample, Time()) to p1 = p(t0) · factor:
//   step (ramp_s = 0):  p(t) = p1                                      t >= t0
//   ramp (ramp_s > 0):  p(t) = p(t0) + (p1 - p(t0)) (t - t0) / ramp_s    t0 <= t <= t0 + ramp_s
//                       p(t) = p1                                      t >= t0 + ramp_s
// Faults on different parameters run side by side; a fault on a parameter that is still ramping
// starts from where that ramp has got to and replaces the rest of it. ClearFaults moves every
// parameter from its value back to the nominal one by the same rules. Where they act, in the fine
// step from t_i to t_i + h:
//   fuel film, τ_ff and X (eq. 13):  at the step's midpoint t_i + h/2, held over the step (exact
//       discretisation), so a step fault at t0 acts from t0 on exactly
//   λ sensor, Δt and K_b (eq. 14):   1/λ(t_i) = K_b(t_i) (mfv + mff)(t_i - Δt(t_i)), Δt rounded to
//       whole fine steps. The gain is the sensor's: a change shows at once. The delay reads the
//       exhaust's history: lengthening it repeats past values, shortening it skips some.
//   crankshaft, τ_f and J_e (eq. 15): at the step's midpoint, held over the step
// The fuel bias stays 1/K_b at the nominal K_b (the engine does not know its sensor aged), so a
// gain fault moves 1/λ away from 1.
//
// The delay line holds the last MaxSensorDelay = max(1 s, 2 Δt_nominal) of the exhaust's fuel flow
// (max / h + 1 numbers, allocated at the start); a fault that would take Δt beyond it is refused.
// τ_ff and K_b (and the crankshaft's τ_f and J_e) stay within kMaxFaultRatio of their nominal
// values, either way: a fault that would take one beyond is refused (a film 100 times slower or
// a sensor 100 times more sensitive is no longer the engine; far beyond it the simulation's
// numbers overflow: τ_ff × 1e-320 gives NaN rows).
//
// Deterministic: the same experiment (seed) with the same faults injected before the same sample
// indices gives the same samples. Next() takes `oversample` fine steps: O(1) time and no memory
// per sample (while τ_ff, X, τ_f or J_e ramps, each fine step also discretises its system anew).
#pragma once

#include <cstdint>
#include <memory>

#include "core/sim/dyno.h"
#include "core/util/result.h"

namespace gb::sim {

inline constexpr double kMaxFaultRatio = 100;

// One parameter's value over time under faults (see above): `from` until t0, then linearly to
// `to` at t0 + ramp (at once for ramp 0), `to` after.
class ParameterPath {
 public:
  explicit ParameterPath(double nominal) : nominal_(nominal), from_(nominal), to_(nominal) {}
  double At(double t) const;
  // From its value at `now` to `target`; `now` is not before the previous move's.
  void MoveTo(double target, double now, double ramp_s);
  double nominal() const { return nominal_; }

 private:
  double nominal_, from_, to_;
  double t0_ = 0, ramp_s_ = 0;
};

// ---- fuel experiment ----------------------------------------------------------------------------

struct FuelFault {
  enum class Kind {
    kTauFF,        // τ_ff, the film's time constant (a clogging injector wets the port more)
    kX,            // X, the fraction of the fuel that goes into the film
    kSensorDelay,  // Δt, the λ sensor's delay
    kSensorGain,   // K_b, the λ sensor's gain
  };
  Kind kind = Kind::kTauFF;
  double factor = 1;  // > 0; X and Δt may also go to 0
  double ramp_s = 0;  // 0: a step; > 0: linearly over ramp_s seconds
};

// The name the command line and messages use: tau_ff, X, delay, gain.
const char* FaultName(FuelFault::Kind kind);

// The fuel experiment's true values at one time: the "truth" lines of a monitor's plots.
struct FuelTruth {
  double tau_fv = 0;  // s, never faulted
  double tau_ff = 0;  // s
  double X = 0;
  double delay_s = 0;  // Δt, s
  double Kb = 0;       // s/g
};

// The faulted values of an operating point over time, without the simulation: the live dyno keeps
// one, and a caller can replay a fault schedule on one to check it before a run.
class FuelFaults {
 public:
  FuelFaults(const FuelOperatingPoint& nominal, double max_delay_s);
  // `f` from `now` on (`now` not before the previous call's). Refused, changing nothing, when the
  // factor or the ramp is not a finite number in range, when X would leave [0, 1], when Δt
  // would pass max_delay_s, or when τ_ff or K_b would leave 1/kMaxFaultRatio..kMaxFaultRatio
  // times its nominal value.
  Status Inject(const FuelFault& f, double now);
  // Every parameter back to its nominal value from `now` on (ramp_s >= 0, as for a fault).
  Status Clear(double now, double ramp_s = 0);
  FuelTruth At(double t) const;

 private:
  double tau_fv_, max_delay_s_;
  ParameterPath tau_ff_, X_, delay_, Kb_;
};

// One recorded sample: the columns of RunFuelExperiment's record.
struct FuelSample {
  double t = 0;        // s
  double mfi = 0;      // g/s, injected fuel (filtered as recorded)
  double ilambda = 0;  // 1/λ (filtered, with the converter's noise)
};

class LiveFuelDyno {
 public:
  // Checks `e` as FuelExperiment::IsValid does but for `duration`, which is not used (the dyno
  // runs until the caller stops asking), and runs the warm-up: the first Next() is t = 0.
  static Result<LiveFuelDyno> Create(const FuelExperiment& e);
  // The longest Δt the delay line holds: max(1 s, 2 Δt).
  static double MaxSensorDelay(const FuelOperatingPoint& p);

  LiveFuelDyno(LiveFuelDyno&&) noexcept;
  LiveFuelDyno& operator=(LiveFuelDyno&&) noexcept;
  ~LiveFuelDyno();

  // The sample at Time(); then advances the world to the next sample's time.
  FuelSample Next();
  // The time of the sample Next() gives next, and its index (the samples given so far).
  double Time() const;
  std::int64_t SampleIndex() const;

  // A fault from Time() on (see FuelFaults::Inject for what is refused).
  Status Inject(const FuelFault& f);
  Status ClearFaults(double ramp_s = 0);
  // The true values at Time().
  FuelTruth Truth() const;
  const FuelExperiment& experiment() const;

 private:
  struct State;
  explicit LiveFuelDyno(std::unique_ptr<State> state);
  std::unique_ptr<State> s_;
};

// ---- crankshaft experiment ----------------------------------------------------------------------

struct CrankshaftFault {
  enum class Kind {
    kTauF,  // τ_f, the friction time constant
    kJe,    // J_e, the inertia
  };
  Kind kind = Kind::kTauF;
  double factor = 1;  // > 0
  double ramp_s = 0;  // 0: a step; > 0: linearly over ramp_s seconds
};

struct CrankshaftTruth {
  double tau_f = 0;  // s
  double Je = 0;     // N m s / rpm
};

// One recorded sample: the columns of RunCrankshaftExperiment's record (deviations from the bias).
struct CrankshaftSample {
  double t = 0;      // s
  double theta = 0;  // deg, throttle
  double Tl = 0;     // N m, load torque
  double N = 0;      // rpm, engine speed
  double Pman = 0;   // kPa, manifold pressure
};

class LiveCrankshaftDyno {
 public:
  // Checks `e` as CrankshaftExperiment::IsValid does but for `duration` (not used); runs the
  // warm-up.
  static Result<LiveCrankshaftDyno> Create(const CrankshaftExperiment& e);

  LiveCrankshaftDyno(LiveCrankshaftDyno&&) noexcept;
  LiveCrankshaftDyno& operator=(LiveCrankshaftDyno&&) noexcept;
  ~LiveCrankshaftDyno();

  CrankshaftSample Next();
  double Time() const;
  std::int64_t SampleIndex() const;

  // Refused, changing nothing, when the factor is not finite and > 0, the ramp not finite and
  // >= 0, or the parameter would leave 1/kMaxFaultRatio..kMaxFaultRatio times its nominal value.
  Status Inject(const CrankshaftFault& f);
  Status ClearFaults(double ramp_s = 0);
  CrankshaftTruth Truth() const;
  const CrankshaftExperiment& experiment() const;

 private:
  struct State;
  explicit LiveCrankshaftDyno(std::unique_ptr<State> state);
  std::unique_ptr<State> s_;
};

}  // namespace gb::sim
