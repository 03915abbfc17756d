// Pieces the dyno's experiments share (dyno.cpp, live_dyno.cpp); not part of the public API.
//
// The continuous world is simulated on a fine grid h = T_s / oversample. Fine step i runs from the
// start of a warm-up (negative times) on; the recorded samples are the fine steps i with
// i % oversample == 0 from t = 0 on.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Core>

#include "core/design/prbs.h"
#include "core/sim/dyno.h"
#include "core/sim/random.h"
#include "core/util/result.h"

namespace gb::sim::internal {

// dx = (A x + B u) dt + diag(σ) dω over steps h with u held: exact discretisation and a factor
// of Q for the noise.
class FineSystem {
 public:
  FineSystem(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::VectorXd& sigma2,
             double h);
  // Steady state for a constant input: x = -A⁻¹ B u.
  Eigen::VectorXd Steady(const Eigen::VectorXd& u) const { return steady_ * u; }
  // One step; draws one normal per state from `rng` when there is noise.
  void Step(Eigen::VectorXd& x, const Eigen::VectorXd& u, NormalRng& rng) const;

 private:
  Eigen::MatrixXd phi_, gamma_, q_factor_, steady_;
  bool noisy_ = false;
};

// A Butterworth low-pass of even order as a cascade of second-order sections
//   x1' = x2,  x2' = ωc² (u - x1) - 2 ζ_k ωc x2,  y = x1,   ζ_k = sin((2k - 1) π / (2 N)),
// with unit gain at DC. Order 0 (cut-off <= 0) passes the signal through.
class AntiAliasFilter {
 public:
  AntiAliasFilter(const RecordingOptions& o, double h);
  void Reset(double u);
  // Advances one fine step with input u held; returns the output at the end of the step.
  double Step(double u, NormalRng& rng);
  double Output(double u_if_passing) const { return pass_ ? u_if_passing : x_(x_.size() - 2); }

 private:
  bool pass_;
  std::unique_ptr<FineSystem> system_;
  Eigen::VectorXd x_;
};

// A PRBS level at times t >= 0 that never decrease: +1 or -1 for bit floor(t / T_prbs) of the
// register's sequence, which repeats after 2^n - 1 bits. O(1) memory: the register runs along.
class PrbsLevel {
 public:
  PrbsLevel(int order, double bit_period, std::uint32_t seed);
  double At(double t);

 private:
  design::PrbsRegister register_;
  double bit_period_;
  std::uint64_t index_ = 0;  // the bit `bit_` is
  std::uint8_t bit_;
};

// T_s finite and > 0, oversample 1..1000, the fine step h >= kMinFineStep, the filter's order and
// cut-off.
bool ValidRecording(const RecordingOptions& r, std::string* why);

// The checks of FuelExperiment::IsValid and CrankshaftExperiment::IsValid but the duration's
// (a live experiment has none).
bool ValidFuelSetup(const FuelExperiment& e, std::string* why);
bool ValidCrankshaftSetup(const CrankshaftExperiment& e, std::string* why);

// The duration's check of every recorded experiment (finite, > 0, within kMaxSamples and
// kMaxFineSteps), and the number of samples it gives (t = k T_s < duration).
bool ValidDuration(double duration, const RecordingOptions& r, std::string* why);
int SampleCount(double duration, const RecordingOptions& r);

// Time of fine step i (negative during the warm-up).
double FineTime(std::int64_t i, int warmup_samples, const RecordingOptions& r);

// Time of sample k: k / rate when the rate 1 / T_s is a whole number (so that files show 0.0375
// rather than 3 * 0.0125 = 0.037500000000000006), k T_s otherwise.
double SampleTime(std::int64_t k, double ts);

std::string RecordingText(const RecordingOptions& r);

// Every value of the record finite, or a numerical Error "EXPERIMENT: the simulated record is not
// finite from t = T s on (column C is V)" at the first row with one that is not.
Status CheckFinite(const Record& record, const std::string& experiment);

}  // namespace gb::sim::internal
