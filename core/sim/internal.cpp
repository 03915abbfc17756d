#include "core/sim/internal.h"

#include <cassert>
#include <cmath>
#include <numbers>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "core/filter/discretize.h"

namespace gb::sim::internal {

FineSystem::FineSystem(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                       const Eigen::VectorXd& sigma2, double h) {
  const auto d =
      filter::Discretize(A, B, Eigen::VectorXd::Zero(A.rows()), sigma2, h, model::InputHold::kZoh);
  phi_ = d.Phi;
  gamma_ = d.Gamma0;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(d.Q);
  q_factor_ = es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  noisy_ = sigma2.maxCoeff() > 0;
  steady_ = -A.fullPivLu().solve(B);
}

void FineSystem::Step(Eigen::VectorXd& x, const Eigen::VectorXd& u, NormalRng& rng) const {
  Eigen::VectorXd next = phi_ * x + gamma_ * u;
  if (noisy_) {
    Eigen::VectorXd z(q_factor_.cols());
    for (Eigen::Index i = 0; i < z.size(); ++i) z(i) = rng.Normal();
    next += q_factor_ * z;
  }
  x = next;
}

AntiAliasFilter::AntiAliasFilter(const RecordingOptions& o, double h) : pass_(o.filter_hz <= 0) {
  if (pass_) return;
  const int n = o.filter_order;
  const double wc = 2 * std::numbers::pi * o.filter_hz;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(n, 1);
  for (int k = 0; k < n / 2; ++k) {
    const double zeta = std::sin((2 * k + 1) * std::numbers::pi / (2 * n));
    const int i = 2 * k;
    A(i, i + 1) = 1;
    A(i + 1, i) = -wc * wc;
    A(i + 1, i + 1) = -2 * zeta * wc;
    if (k == 0)
      B(i + 1, 0) = wc * wc;
    else
      A(i + 1, i - 2) = wc * wc;  // input of this section: output of the previous one
  }
  system_ = std::make_unique<FineSystem>(A, B, Eigen::VectorXd::Zero(n), h);
  x_ = Eigen::VectorXd::Zero(n);
}

void AntiAliasFilter::Reset(double u) {
  if (!pass_) x_ = system_->Steady(Eigen::VectorXd::Constant(1, u));
}

double AntiAliasFilter::Step(double u, NormalRng& rng) {
  if (pass_) return u;
  system_->Step(x_, Eigen::VectorXd::Constant(1, u), rng);
  return x_(x_.size() - 2);
}

PrbsLevel::PrbsLevel(int order, double bit_period, std::uint32_t seed)
    : register_(order, seed), bit_period_(bit_period), bit_(register_.Next()) {}

double PrbsLevel::At(double t) {
  const auto i = static_cast<std::uint64_t>(std::floor(t / bit_period_ + 1e-9));
  assert(i >= index_ && "PrbsLevel::At: time went back");
  for (; index_ < i; ++index_) bit_ = register_.Next();
  return bit_ ? 1.0 : -1.0;
}

bool ValidRecording(const RecordingOptions& r, std::string* why) {
  auto fail = [&](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (!(r.sample_time > 0 && std::isfinite(r.sample_time)))
    return fail(fmt::format("the sample time must be a finite number of seconds > 0, not {}",
                            r.sample_time));
  if (r.oversample < 1 || r.oversample > 1000) return fail("oversample must be 1..1000");
  if (!(r.sample_time / r.oversample >= kMinFineStep))
    return fail(fmt::format(
        "the simulated world's step, the sample time {} s / oversample {}, must be at least {} s",
        r.sample_time, r.oversample, kMinFineStep));
  if (r.filter_hz > 0 && (r.filter_order < 2 || r.filter_order > 8 || r.filter_order % 2))
    return fail("the filter order must be even, 2..8");
  if (r.filter_hz > 0 && r.filter_hz * r.sample_time > 0.25 * r.oversample)
    return fail("the filter cut-off must lie below a quarter of the fine grid's rate");
  return true;
}

bool ValidFuelSetup(const FuelExperiment& e, std::string* why) {
  auto fail = [&](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (!ValidRecording(e.recording, why)) return false;
  const auto& p = e.point;
  if (!(p.tau_fv > 0 && p.tau_ff > 0 && p.Kb > 0 && p.X >= 0 && p.X <= 1 && p.delay_s >= 0 &&
        p.s11 >= 0 && p.s12 >= 0 && p.s2 >= 0))
    return fail("the operating point needs τ_fv, τ_ff, K_b > 0, 0 <= X <= 1 and variances >= 0");
  if (e.prbs_order < design::kMinPrbsOrder || e.prbs_order > design::kMaxPrbsOrder)
    return fail(
        fmt::format("the PRBS order must be {}..{}", design::kMinPrbsOrder, design::kMaxPrbsOrder));
  if (!(e.bit_period >= e.recording.sample_time))
    return fail("the bit period must be >= the sample time");
  if (!(e.amplitude > 0 && e.amplitude < 1))
    return fail("the amplitude must be a fraction in (0, 1)");
  return true;
}

bool ValidCrankshaftSetup(const CrankshaftExperiment& e, std::string* why) {
  auto fail = [&](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (!ValidRecording(e.recording, why)) return false;
  const auto& p = e.point;
  if (!(p.tau_f > 0 && p.Je > 0 && p.Gp > 0 && p.s1 >= 0 && p.s21 >= 0 && p.s22 >= 0))
    return fail("the crankshaft needs τ_f, J_e, G_p > 0 and variances >= 0");
  if (e.prbs_order < design::kMinPrbsOrder || e.prbs_order > design::kMaxPrbsOrder)
    return fail("the PRBS order is out of range");
  if (!(e.bit_period > 0 && std::isfinite(e.bit_period)))
    return fail("the bit period must be a positive number");
  return true;
}

bool ValidDuration(double duration, const RecordingOptions& r, std::string* why) {
  auto fail = [&](std::string m) {
    if (why) *why = std::move(m);
    return false;
  };
  if (!(duration > 0 && std::isfinite(duration)))
    return fail(
        fmt::format("the duration must be a finite number of seconds > 0, not {}", duration));
  const double samples = std::ceil(duration / r.sample_time - 1e-9);
  if (samples < 1)
    return fail(fmt::format("{} s gives no sample (a sample every {} s)", duration, r.sample_time));
  if (!(samples <= kMaxSamples))
    return fail(
        fmt::format("{} s at {} s a sample is {:.3g} samples; at most {:.3g} are recorded "
                    "(a duration of at most {:.6g} s)",
                    duration, r.sample_time, samples, kMaxSamples, kMaxSamples * r.sample_time));
  if (!(samples * r.oversample <= kMaxFineSteps))
    return fail(fmt::format(
        "{} s at {} s a sample and {} steps a sample is {:.3g} steps of the simulated world; "
        "at most {:.3g} are taken (a duration of at most {:.6g} s, or a smaller oversample)",
        duration, r.sample_time, r.oversample, samples * r.oversample, kMaxFineSteps,
        kMaxFineSteps / r.oversample * r.sample_time));
  return true;
}

int SampleCount(double duration, const RecordingOptions& r) {
  return static_cast<int>(std::ceil(duration / r.sample_time - 1e-9));
}

double FineTime(std::int64_t i, int warmup_samples, const RecordingOptions& r) {
  return (static_cast<double>(i) / r.oversample - warmup_samples) * r.sample_time;
}

double SampleTime(std::int64_t k, double ts) {
  const double rate = 1.0 / ts;
  return std::abs(rate - std::round(rate)) < 1e-9 * rate ? k / std::round(rate) : k * ts;
}

std::string RecordingText(const RecordingOptions& r) {
  return r.filter_hz > 0
             ? fmt::format(
                   "every channel through a {}th-order Butterworth low-pass at {} Hz, "
                   "sampled every {} s (simulated on a {} s grid)",
                   r.filter_order, r.filter_hz, r.sample_time, r.sample_time / r.oversample)
             : fmt::format("no anti-alias filter, sampled every {} s", r.sample_time);
}

Status CheckFinite(const Record& record, const std::string& experiment) {
  const std::size_t rows = record.columns.empty() ? 0 : record.columns[0].size();
  for (std::size_t k = 0; k < rows; ++k)
    for (std::size_t c = 0; c < record.columns.size(); ++c)
      if (!std::isfinite(record.columns[c][k]))
        return NumericalError(fmt::format(
            "{}: the simulated record is not finite from t = {} s on (row {}: {} is {})",
            experiment, record.columns[0][k], k + 1, record.names[c], record.columns[c][k]));
  return Ok{};
}

}  // namespace gb::sim::internal
