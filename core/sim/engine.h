// The nonlinear virtual dyno: a mean-value model of the paper's 1.1 L four-cylinder SI engine
// over its whole operating range, the engine the paper's linear models (eq. 13-16) linearise.
// Structure from Hendricks & Sorenson (1990), "Mean value SI engine model for control studies",
// ACC pp. 1882-1887 (the paper's reference for the model its method was used to refine); the
// compressible throttle flow and the speed-density port flow as in Guzzella & Onder (2010),
// "Introduction to modeling and control of internal combustion engine systems", ch. 2.
// docs/case-study-mvem.md gives the values and how they were chosen.
//
// States: manifold pressure p (kPa), crankshaft speed n (rpm), the fuel flows mfv, mff (g/s)
// of eq. 13. Inputs: throttle angle α (deg), injected fuel mfi (g/s), load torque T_l (N m).
//   throttle flow   m_at = C_th (1 - cos α) β(p / p_a)          β: the compressible-flow function
//                   β(r) = ψ(max(r, r_c)) / ψ(r_c), ψ(r) = sqrt(r^(2/κ) - r^((κ+1)/κ)),
//                   r_c = (2/(κ+1))^(κ/(κ-1)) (choked below the critical pressure ratio)
//   port air flow   m_ap = e_v V_d n p / (120 R T)                  (speed density)
//   manifold        dp = R T / V_i (m_at - m_ap) dt + σ_p dω
//   fuel film       dmfv = ((1 - X) mfi - mfv) / τ_fv dt + σ_fv dω,
//                   dmff = (X mfi - mff) / τ_ff dt + σ_ff dω,  X = X60 + dX (p - 60) / 10
//   crankshaft      J_e dn = (T_i - T_f - T_p - T_l) dt + J_e σ_n dω, with
//                   T_i = η H_u (mfv + mff) / ω   (indicated torque, ω = π n / 30)
//                   T_f = f0 + f1 n / 1000        (friction)
//                   T_p = V_d (p_a - p) / (4 π)   (pumping)
//   λ sensor        1/λ(t) = L_th (mfv + mff) / m_ap at t - Δt, Δt = c_d / n (Fig. 3), the
//                   exhaust's transport delay, which shortens as the engine speeds up
// Recorded: α, mfi, T_l, N = n, P_man = p and 1/λ, every channel through the same anti-alias
// filter (RecordingOptions) and sampled; the outputs get the converter's white noise.
//
// Experiments run along a path of operating points (n, α): at each the dyno holds the load that
// keeps the engine at speed n (or holds the speed itself: EngineExperiment::hold_speed) and
// injects the fuel of λ = 1 there (EngineSteadyState); between points it ramps both. PRBS
// perturbations ride on the fuel (±10 % like the paper's) and on the throttle (± 1°). One point:
// the paper's experiment at that point. Several: a slow sweep.
//
// The continuous world is simulated by Euler-Maruyama on the fine grid h = T_s / oversample
// (h <= kMaxEngineStep: the wide-open manifold at 10 000 rpm has a time constant of 14 ms, and
// its pressure's mean is 30 % off at h = 5 ms, within 0.1 % of h = 0.5 ms's at 2.5 ms); the
// delay line holds the port's 1/λ at every fine step and is read with linear interpolation (with
// SensorDelay::kPade the port's 1/λ, linear over each fine step, drives the approximant instead).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/sim/dyno.h"
#include "core/util/result.h"

namespace gb::sim {

// The longest fine step of the engine's Euler-Maruyama scheme, s (see above).
inline constexpr double kMaxEngineStep = 0.0025;

// Constants of the engine and of air and fuel (not estimated).
struct EngineConstants {
  static constexpr double kAmbientKPa = 100.0;      // p_a
  static constexpr double kRT = 86.1;               // R T (kPa L / g): R = 0.287 J/(g K), T = 300 K
  static constexpr double kDisplacementL = 1.1;     // V_d
  static constexpr double kHeatingValue = 43000;    // H_u (J/g)
  static constexpr double kStoichiometric = 14.67;  // L_th
  static constexpr double kKappa = 1.4;
};

// The true values (names as in the bundled model, assets/models/engine_mvem.json).
struct EngineTruth {
  double Cth = 137.5;     // g/s: throttle flow at (1 - cos α) = 1, choked
  double ev = 0.80;       // volumetric efficiency
  double Vi = 1.0;        // L: intake manifold volume
  double Je = 0.08;       // N m s / rpm: inertia (engine and dyno)
  double eta = 0.30;      // indicated efficiency
  double f0 = 8.0;        // N m: friction at rest
  double f1 = 3.0;        // N m per 1000 rpm
  double tau_fv = 0.085;  // s (Table 2's mean)
  double tau_ff = 0.296;  // s (Table 2's mean)
  double X60 = 0.115;     // X at 60 kPa
  double dX = 0.061;      // X's rise per 10 kPa
  double cd = 167.0;      // rpm s: Δt = cd / n (Fig. 3)
  double sp = 3.0;        // kPa / √s
  double sn = 8.64;       // rpm / √s (√σ1² of section 5)
  double sfv = 0.033;     // g/s / √s
  double sff = 0.020;     // g/s / √s
  double rp = 0.70;       // kPa² (σ22² of section 5)
  double rn = 14.4;       // rpm² (σ21² of section 5)
  double rl = 1.26e-4;    // (1/λ)² (σ2² of f1)
  // name = value pairs in the order above.
  std::vector<std::pair<std::string, double>> Named() const;
};

// The model's functions at a state and input (no noise).
double ThrottleFlow(const EngineTruth& e, double alpha_deg, double p);  // m_at, g/s
double PortAirFlow(const EngineTruth& e, double p, double n);           // m_ap, g/s
struct EngineState {
  double p = 0, n = 0, mfv = 0, mff = 0;
};
struct EngineInput {
  double alpha = 0, mfi = 0, Tl = 0;
};
EngineState EngineDrift(const EngineTruth& e, const EngineState& x, const EngineInput& u);
// 1/λ at the port (before the transport delay).
double PortInverseLambda(const EngineTruth& e, const EngineState& x);

// The steady state at speed n and throttle α with the fuel of λ = 1: p from m_at = m_ap, the
// fuel flows, and the load torque that holds the speed. Fails where the throttle cannot feed
// the engine at that speed or the engine makes no positive torque there.
struct EngineSteady {
  EngineState x;
  EngineInput u;
};
Result<EngineSteady> EngineSteadyState(const EngineTruth& e, double n_rpm, double alpha_deg);

struct EnginePoint {
  std::string name;
  double speed_rpm = 0;
  double throttle_deg = 0;
};
// The six operating points of Table 2 as (n, α).
std::vector<EnginePoint> PaperEnginePoints();
// "f1" (a Table 2 point) or "n=3000,alpha=30" (any point: each of n and alpha once, finite);
// errors say which.
Result<EnginePoint> ParseEnginePoint(const std::string& text);

struct EngineExperiment {
  EngineTruth truth;
  std::vector<EnginePoint> path;  // one point, or a sweep through several
  double hold_s = 20;             // a sweep: time at each point
  double ramp_s = 40;             // a sweep: time from one point to the next
  double fuel_amplitude = 0.10;   // ± fraction of the fuel of λ = 1
  int fuel_order = 6;
  double fuel_bit = 0.5;            // s
  double throttle_amplitude = 1.0;  // ± deg, 0..10
  int throttle_order = 7;
  double throttle_bit = 1.0;  // s
  // The dyno's load: false holds the torque of the steady state (the speed then answers the
  // throttle and the fuel, through the crankshaft's dynamics); true makes the dyno hold the speed
  // (a PI controller on the true speed, closed-loop bandwidth about 10 rad/s), as for the paper's
  // fuel experiments, so that the air flow stays at the operating point. Either way the load
  // applied is recorded as T_l.
  bool hold_speed = false;
  // The λ sensor's transport delay Δt = c_d / n: an exact delay line (the physical exhaust), or
  // the [3/3] Padé approximant the bundled models use for it (engine_mvem.json,
  // fuel_film_pade.json), which makes the models' sensor exact, so that a fit's bias can be told
  // apart from the approximant's phase error.
  enum class SensorDelay { kExact, kPade };
  SensorDelay sensor_delay = SensorDelay::kExact;
  double duration = 125.0;  // s
  std::uint64_t seed = 1;
  RecordingOptions recording;
  bool IsValid(std::string* why) const;
};

// Columns t, alpha, mfi, Tl, N, Pman, ilambda; the comments state the truth, the path and the
// settings, and (for one point) its `# greybench: {"operating_point": ...}` tag.
Result<Record> RunEngineExperiment(const EngineExperiment& e);

}  // namespace gb::sim
