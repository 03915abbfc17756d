// The virtual dyno: simulated versions of the experiments of Melgaard, Hendricks & Madsen
// (section 3 and 5) on a 1.1 L four-cylinder SI engine. We have no dynamometer; these
// simulations stand in for it, with the paper's estimates as the truth.
//
// Fuel experiment (eq. 13-14), per operating point:
//   injected fuel  mfi(t) = bias · (1 ± 10 %) PRBS (order n, bit period T_prbs), bias = 1/K_b g/s
//                  so that 1/λ ≈ 1 at the operating point
//   fuel film      dmfv = (-mfv + (1-X) mfi)/τ_fv dt + σ11 dω1,  dmff = (-mff + X mfi)/τ_ff dt +
//   σ12 dω2 λ sensor       1/λ(t) = K_b (mfv + mff)(t - Δt)     (exhaust transport delay Δt; linear
//   sensor) recording      every channel (mfi and 1/λ) through the same 4th-order Butterworth
//   low-pass
//                  (20 Hz), sampled at 80 Hz (T_s = 0.0125 s); white noise of variance σ2² added at
//                  the samples (the converter's noise)
// The continuous world is simulated on a grid T_s / oversample with exact discretisation (the
// signals into the filters are held over each fine step). Because input and output pass identical
// filters, the filters' group delay (≈ 1.7 samples) cancels between them and the delay estimated
// from the record is Δt. What the filters do change: the recorded input is smooth, not a step
// held over the sample interval, and the process noise reaches the samples low-pass filtered;
// both bias estimates a little (docs/case-study.md quantifies it).
//
// Crankshaft experiment (eq. 15-16): throttle (and in a second run the load torque) perturbed by
// PRBS; engine speed N and manifold pressure P_man recorded through the same filters at 16 Hz
// (T_s = 0.0625 s).
//
// The fuel and crankshaft experiments also run live, one sample at a time and with faults
// injected while they run (live_dyno.h); the records here are those live runs, without faults,
// for `duration`.
//
// Square-wave test (Fig. 2): ±10 % square wave on the fuel at 43.5°, 3380 rpm, with an
// instantaneous vapour path (τ_fv = 0): 1/λ = K_b ((1-X) mfi + mff), τ_ff = 0.25 s, X = 0.22.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/util/result.h"

namespace gb::sim {

// One operating point of the paper's Table 2 (time constants in s, K_b in s/g, the process
// variances in (g/s)²/s, σ2² in the units of 1/λ squared).
struct FuelOperatingPoint {
  std::string name;         // "f1"
  double speed_rpm = 0;     // n
  double throttle_deg = 0;  // α
  double delay_s = 0;       // Δt
  double tau_fv = 0, tau_ff = 0, X = 0;
  double s11 = 0, s12 = 0, s2 = 0;  // σ11², σ12², σ2²
  double Kb = 0;
};

// The six operating points of Table 2 (f1, f2, f3, f4, f7, f8).
const std::vector<FuelOperatingPoint>& PaperFuelPoints();
// The operating point named `name`, or an Error listing the names.
Result<FuelOperatingPoint> FindFuelPoint(const std::string& name);

// Fig. 3: the exhaust transport delay falls with speed; Δt ≈ c / n with c fitted by least
// squares to Table 2 (Δt n ≈ 167 rpm·s). For operating points the table does not have.
double ExhaustDelay(double speed_rpm);

struct RecordingOptions {
  double sample_time = 0.0125;  // T_s
  int oversample = 10;          // fine grid T_s / oversample
  double filter_hz = 20.0;      // Butterworth cut-off; <= 0 disables the anti-alias filters
  int filter_order = 4;         // even, 2..8
};

// Limits of a recorded experiment, checked (IsValid) before anything is allocated or run:
//   kMaxSamples     the record's rows, duration / T_s (a column of doubles is 80 MB at the limit)
//   kMaxFineSteps   the simulated world's steps, duration / T_s · oversample, after the warm-up:
//                   the run's time (a minute or so at the limit: docs/benchmarks.md,
//                   "Timings behind the code's limits")
//   kMinFineStep    h = T_s / oversample in s: the delay lines hold their history at every fine
//                   step (1.3 MB for the engine at the limit)
inline constexpr double kMaxSamples = 1e7;
inline constexpr double kMaxFineSteps = 1e8;
inline constexpr double kMinFineStep = 1e-5;

struct FuelExperiment {
  FuelOperatingPoint point;
  int prbs_order = 6;
  double bit_period = 0.5;
  double amplitude = 0.10;  // ± fraction of the bias
  double duration = 125.0;  // s (10 000 samples at 80 Hz); the live dyno does not use it
  std::uint64_t seed = 1;
  RecordingOptions recording;
  bool IsValid(std::string* why) const;
};

// A recorded experiment: named columns (the first is t) and comment lines that state the truth
// and the settings (written at the top of the CSV).
struct Record {
  std::vector<std::string> names;
  std::vector<std::vector<double>> columns;
  std::vector<std::string> comments;
};

Result<Record> RunFuelExperiment(const FuelExperiment& e);
// The comment lines of its record: the truth and the settings.
std::vector<std::string> FuelExperimentComments(const FuelExperiment& e);

// The crankshaft model's values of section 5.
struct CrankshaftPoint {
  double tau_f = 4.1358;   // s
  double Je = 0.6028;      // N m s / rpm
  double Gp = 6.3570;      // N m / kPa
  double Kn = 0.008746;    // kPa / rpm
  double Ktheta = 3.6403;  // kPa / deg
  double s1 = 74.70;       // rpm² (per s)
  double s21 = 14.43;      // rpm²
  double s22 = 0.6988;     // kPa²
};

struct CrankshaftExperiment {
  CrankshaftPoint point;
  bool perturb_load = true;
  double throttle_amplitude = 1.0;  // ± deg around the bias
  double load_amplitude = 5.0;      // ± N m around the bias
  int prbs_order = 7;
  double bit_period = 1.0;
  double duration = 600.0;  // s; the live dyno does not use it
  std::uint64_t seed = 1;
  RecordingOptions recording{0.0625, 10, 20.0, 4};
  bool IsValid(std::string* why) const;
};

Result<Record> RunCrankshaftExperiment(const CrankshaftExperiment& e);

struct SquareWaveTest {
  double speed_rpm = 3380;
  double throttle_deg = 43.5;
  double tau_ff = 0.25;
  double X = 0.22;
  double Kb = 0.85;
  double period = 4.0;      // s
  double amplitude = 0.10;  // ± fraction of the bias
  double duration = 16.0;
  double s12 = 2e-4;  // film process noise
  double s2 = 5e-5;   // measurement noise
  std::uint64_t seed = 1;
  RecordingOptions recording;
};

Result<Record> RunSquareWaveTest(const SquareWaveTest& e);

}  // namespace gb::sim
