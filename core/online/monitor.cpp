#include "core/online/monitor.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "core/online/augmented.h"
#include "core/online/ekf_stream.h"
#include "core/online/internal.h"
#include "core/util/json.h"

namespace gb::online {
namespace {

using internal::kNaN;

// A parameter's score test sums blocks of rows so that the change it looks for is about this many
// SDs of a block's standardised score (at most kMaxBlock rows: a smaller change is refused).
constexpr double kBlockShift = 0.5;
constexpr int kMaxBlock = 100000;
// The largest change a score test is designed for, in SDs of one row's standardised score (see
// the header: the CUSUM's false alarms then come from sums of 2h/δ² >= 1000 rows, close enough
// to normal). With it every block has at least (kBlockShift / kMaxRowShift)² = 25 rows. At 3 (the
// value before issue 32) the tests of data matching the reference alarmed 90 times (h = 9) to 630
// times (h = 12) as often as designed; at 0.2, 1.7 times for a variance parameter; at 0.1 and
// 0.05 at or below the rate (tests/core/monitor_test.cpp). 0.05 makes the change tested so small
// (0.05 √n reference SEs) that the reference's own estimation error starts to alarm.
constexpr double kMaxRowShift = 0.1;
// A tracked block whose scaled covariance has an eigenvalue below this (a combination of the
// tracked parameters with less than this share of their variance) is singular.
constexpr double kSingular = 1e-8;
// An eigenvector's components at least this large name the parameters of its combination.
constexpr double kInvolved = 0.1;

}  // namespace

std::string CombinationOf(const Eigen::VectorXd& v, const std::vector<std::string>& names) {
  std::vector<std::string> listed;
  for (Eigen::Index a = 0; a < v.size(); ++a)
    if (std::abs(v(a)) >= kInvolved) listed.push_back(names[static_cast<std::size_t>(a)]);
  std::string out;
  for (std::size_t a = 0; a < listed.size(); ++a)
    out += (a == 0 ? "" : a + 1 == listed.size() ? " and " : ", ") + listed[a];
  return out;
}

namespace {

// The score tests standardise by the tracked block's covariance given the other free parameters
// (cov, NaN-free), which says how much each row tells about each tracked parameter. When it is
// singular the reference claims that a combination of tracked parameters is known exactly (its
// information infinite): a test designed from it would alarm at nothing or at everything. The
// tracked parameters with a reference SE are scaled by their marginal SDs (marginal), so that
// the eigenvalues are shares of variance; those below kSingular are refused, naming the
// parameters of their combinations.
Status RefuseSingular(const Eigen::MatrixXd& cov, const Eigen::MatrixXd& marginal,
                      const std::vector<std::string>& names, const Reference& reference) {
  std::vector<Eigen::Index> with_se;
  for (Eigen::Index a = 0; a < cov.rows(); ++a)
    if (marginal(a, a) > 0.0) with_se.push_back(a);
  const auto k = static_cast<Eigen::Index>(with_se.size());
  if (k == 0) return Ok{};
  Eigen::MatrixXd scaled(k, k);
  std::vector<std::string> scaled_names;
  for (Eigen::Index a = 0; a < k; ++a) {
    scaled_names.push_back(names[static_cast<std::size_t>(with_se[a])]);
    for (Eigen::Index b = 0; b < k; ++b)
      scaled(a, b) = cov(with_se[a], with_se[b]) /
                     std::sqrt(marginal(with_se[a], with_se[a]) * marginal(with_se[b], with_se[b]));
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scaled);
  if (eigen.eigenvalues()(0) > kSingular) return Ok{};
  std::string involved;
  for (Eigen::Index e = 0; e < k && eigen.eigenvalues()(e) <= kSingular; ++e) {
    const std::string these = CombinationOf(eigen.eigenvectors().col(e), scaled_names);
    if (involved.find(these) == std::string::npos)
      involved += (involved.empty() ? "" : "; ") + these;
  }
  Error e = InputError(fmt::format(
      "the reference's correlations make {} linearly dependent (with the other free parameters "
      "held at the reference): it says a combination of them is known exactly, and their score "
      "tests cannot be designed from it. Leave them out of the tracked parameters (track only "
      "those you watch), or fit the reference again",
      involved));
  e.file = reference.source;
  e.path = "correlation";
  return e;
}

}  // namespace

bool MonitorOptions::IsValid(std::string* why) const {
  if (!(false_alarms_per_hour > 0.0) || !std::isfinite(false_alarms_per_hour)) {
    *why = fmt::format("the false-alarm rate must be a positive number per hour, not {:g}",
                       false_alarms_per_hour);
    return false;
  }
  if (!(recursive.forgetting > 0.0 && recursive.forgetting <= 1.0)) {
    *why = fmt::format("the forgetting factor must be in (0, 1], not {:g}", recursive.forgetting);
    return false;
  }
  if (!(parameter_change > 0.0) || !std::isfinite(parameter_change)) {
    *why = fmt::format(
        "the parameter change worth an alarm must be a positive relative change, "
        "not {:g}",
        parameter_change);
    return false;
  }
  return true;
}

Result<Monitor> Monitor::Create(const model::LinearModel& model, const Reference& reference,
                                const MonitorOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) return InputError(why);
  auto estimator = RecursiveMl::Create(model, reference, options.recursive, /*adapt=*/true);
  if (!estimator) return estimator.error();
  // The reference filter: held at the reference, with the scores of the same parameters.
  RecursiveOptions held = options.recursive;
  held.hold = true;
  held.track = estimator->tracked_names();
  auto ref = RecursiveMl::Create(model, reference, held, /*adapt=*/!held.track.empty());
  if (!ref) return ref.error();
  return Build(std::make_unique<RecursiveMl>(std::move(*estimator)),
               std::make_unique<RecursiveMl>(std::move(*ref)), reference, options);
}

Result<Monitor> Monitor::Create(std::shared_ptr<const model::NonlinearModel> model,
                                const Reference& reference, const MonitorOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) return InputError(why);
  auto estimator = AugmentedEkf::Create(model, reference, options.recursive);
  if (!estimator) return estimator.error();
  auto ref =
      HeldEkf::Create(std::move(model), reference, estimator->tracked(), options.recursive.start);
  if (!ref) return ref.error();
  return Build(std::make_unique<AugmentedEkf>(std::move(*estimator)),
               std::make_unique<HeldEkf>(std::move(*ref)), reference, options);
}

Result<Monitor> Monitor::Create(const model::ModelSpec& spec, const Reference& reference,
                                const MonitorOptions& options) {
  if (auto linear = model::LinearModel::Compile(spec)) return Create(*linear, reference, options);
  auto nonlinear = model::NonlinearModel::Compile(spec);
  if (!nonlinear) return nonlinear.error();
  return Create(std::make_shared<const model::NonlinearModel>(std::move(*nonlinear)), reference,
                options);
}

Result<Monitor> Monitor::Build(std::unique_ptr<OnlineEstimator> estimator,
                               std::unique_ptr<OnlineEstimator> held, const Reference& reference,
                               const MonitorOptions& options) {
  Monitor m(std::move(estimator), std::move(held), options);
  // The reference covariance of the tracked parameters (zero where unknown) and their SEs (NaN).
  const std::vector<int>& tracked = m.estimator_->tracked();
  const Eigen::MatrixXd marginal = reference.CovarianceOf(tracked);
  m.ref_cov_ = reference.ConditionalCovarianceOf(tracked);
  for (std::size_t a = 0; a < tracked.size(); ++a) {
    const auto i = static_cast<Eigen::Index>(a);
    m.ref_theta_.push_back(reference.theta[tracked[a]]);
    m.ref_sd_.push_back(std::sqrt(std::max(marginal(i, i), 0.0)));  // NaN stays NaN
    m.test_sd_.push_back(std::sqrt(std::max(m.ref_cov_(i, i), 0.0)));
  }
  m.ref_cov_ = m.ref_cov_.unaryExpr([](double v) { return std::isnan(v) ? 0.0 : v; });
  if (Status s = RefuseSingular(m.ref_cov_, marginal, m.estimator_->tracked_names(), reference); !s)
    return s.error();
  const std::size_t k = m.ref_theta_.size();
  m.delta_.resize(k);
  m.block_.assign(k, 0);
  m.h_par_.assign(k, 0.0);
  m.sum_s_.assign(k * k, 0.0);
  m.in_block_.assign(k, 0);
  m.up_.assign(k, 0.0);
  m.down_.assign(k, 0.0);
  const int outputs = static_cast<int>(m.estimator_->spec().outputs.size());
  const double ref_rows = static_cast<double>(reference.n_obs) / std::max(1, outputs);
  m.ref_rows_ = ref_rows;
  for (std::size_t a = 0; a < k; ++a) {
    m.delta_[a] = options.parameter_change * std::abs(m.ref_theta_[a]);
    if (!(m.test_sd_[a] > 0.0) || !(ref_rows > 0.0) || !(m.delta_[a] > 0.0)) continue;
    const double info_per_row = 1.0 / (m.test_sd_[a] * m.test_sd_[a] * ref_rows);
    // A change one row alone shows at more than kMaxRowShift SDs is tested as one of that many
    // (the test is then more sensitive than asked, and its design stays within reach).
    m.delta_[a] = std::min(m.delta_[a], kMaxRowShift / std::sqrt(info_per_row));
    const double delta_row = m.delta_[a] * std::sqrt(info_per_row);
    const double block = std::ceil(kBlockShift * kBlockShift / (delta_row * delta_row));
    if (!(block <= kMaxBlock))
      return InputError(fmt::format(
          "a change of {} by {:.3g} ({:.3g} %) is too small to test: its score test would sum "
          "blocks of more than {} rows; ask for a larger change",
          m.estimator_->tracked_names()[a], m.delta_[a], 100.0 * options.parameter_change,
          kMaxBlock));
    m.block_[a] = std::max(1, static_cast<int>(block));
  }
  return m;
}

Status Monitor::Design(double sample_time) {
  CusumOptions o;
  o.outputs = static_cast<int>(estimator_->spec().outputs.size());
  o.sample_time = sample_time;
  o.false_alarms_per_hour = options_.false_alarms_per_hour;
  o.mean_shift = options_.mean_shift;
  o.variance_ratio = options_.variance_ratio;
  // Half of the rate for the innovation tests, half for the parameters (when any are tracked).
  const std::size_t k = ref_theta_.size();
  if (std::any_of(block_.begin(), block_.end(), [](int b) { return b > 0; }))
    o.false_alarms_per_hour *= 0.5;
  auto design = DesignCusum(o);
  if (!design) return design.error();
  design_ = *design;
  detector_.emplace(*design_);
  // Each parameter's up and down tests share the other half of the rate (Bonferroni over the
  // 2k statistics); a block of B rows is one step of its CUSUM.
  for (std::size_t a = 0; a < k; ++a) {
    if (block_[a] == 0) continue;
    const double per_hour = 0.5 * options_.false_alarms_per_hour / (2.0 * static_cast<double>(k));
    const double arl0_blocks = 3600.0 / (per_hour * sample_time * block_[a]);
    const double info_block = block_[a] / (test_sd_[a] * test_sd_[a] * ref_rows_);
    const CusumChange change{CusumKind::kMeanUp, delta_[a] * std::sqrt(info_block)};
    auto h = ThresholdForArl0(change, arl0_blocks);
    if (!h)
      return InputError(fmt::format(
          "the score test of {} for a change of {:.3g} ({:.3g} %) sums blocks of {} rows ({:.3g} "
          "s), too long to keep to {:.3g} false alarms per hour ({}): ask for a larger change or "
          "fewer false alarms",
          estimator_->tracked_names()[a], delta_[a], 100.0 * delta_[a] / std::abs(ref_theta_[a]),
          block_[a], block_[a] * sample_time, per_hour, h.error().message));
    h_par_[a] = *h;
  }
  return Ok{};
}

Result<std::vector<MonitorUpdate>> Monitor::Push(const Sample& row) {
  if (rows_ == 0) first_t_ = row.t;
  ++rows_;
  if (rows_ == 2 && !design_) {
    if (Status s = Design(row.t - first_t_); !s) return s.error();
  }
  auto estimates = estimator_->Push(row);
  if (!estimates) return estimates.error();
  auto held = reference_->Push(row);
  if (!held) return held.error();
  const std::vector<std::string>& outputs = estimator_->spec().outputs;
  const int p = static_cast<int>(outputs.size());
  const std::vector<std::string>& names = estimator_->tracked_names();
  std::vector<MonitorUpdate> out;
  for (std::size_t u = 0; u < estimates->size(); ++u) {
    MonitorUpdate m;
    m.estimate = std::move((*estimates)[u]);
    const RecursiveUpdate& r = (*held)[u];
    m.z.assign(static_cast<std::size_t>(p), kNaN);
    m.cusum.assign(3 * static_cast<std::size_t>(p), 0.0);
    for (int o = 0; o < p; ++o) m.z[o] = r.innovation[o] / r.innovation_sd[o];
    const bool watching = !m.estimate.warming_up && detector_.has_value();
    if (watching) {
      for (int o = 0; o < p; ++o) {
        for (const CusumAlarm& a : detector_->Update(o, m.z[o])) {
          MonitorAlarm alarm;
          alarm.what = fmt::format("{}: {}", outputs[o], a.name());
          alarm.message = fmt::format(
              "the innovations of {} drift ({}): the system no longer behaves as the reference "
              "model says (t = {:g})",
              outputs[o], a.name(), m.estimate.t);
          m.alarms.push_back(std::move(alarm));
        }
      }
    }
    if (detector_) {
      for (int o = 0; o < p; ++o)
        for (int c = 0; c < kCusumKinds; ++c)
          m.cusum[3 * static_cast<std::size_t>(o) + static_cast<std::size_t>(c)] =
              detector_->Statistic(o, static_cast<CusumKind>(c));
    }
    const RecursiveUpdate& r_held = (*held)[u];
    const std::size_t k = ref_theta_.size();
    for (std::size_t a = 0; a < ref_theta_.size(); ++a) {
      m.parameter_cusum.push_back(h_par_[a] > 0.0 ? up_[a] / h_par_[a] : 0.0);
      m.parameter_cusum.push_back(h_par_[a] > 0.0 ? down_[a] / h_par_[a] : 0.0);
      if (!watching || h_par_[a] <= 0.0) continue;
      for (std::size_t b = 0; b < ref_theta_.size(); ++b) sum_s_[a * k + b] += r_held.score[b];
      if (++in_block_[a] < block_[a]) continue;
      // The efficient score of θ_a over the block (the other tracked parameters free):
      // Δ̂_a = (Ī⁻¹ Σ s)_a / B, Ī⁻¹ = n Σ_T, with variance n Σ_T,aa / B; z = Δ̂_a / SD, and the
      // log-likelihood ratios of ±Δ_a are ±δ z - δ²/2 with δ = Δ_a / SD.
      double estimate = 0.0;
      for (std::size_t b = 0; b < k; ++b)
        estimate += ref_cov_(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) *
                    sum_s_[a * k + b];
      estimate *= ref_rows_ / block_[a];
      const double sd = test_sd_[a] * std::sqrt(ref_rows_ / block_[a]);
      const double z = estimate / sd, delta = delta_[a] / sd;
      const double llr_up = delta * z - 0.5 * delta * delta;
      const double llr_down = -delta * z - 0.5 * delta * delta;
      std::fill(sum_s_.begin() + static_cast<std::ptrdiff_t>(a * k),
                sum_s_.begin() + static_cast<std::ptrdiff_t>((a + 1) * k), 0.0);
      in_block_[a] = 0;
      up_[a] = std::max(0.0, up_[a] + llr_up);
      down_[a] = std::max(0.0, down_[a] + llr_down);
      for (int side = 0; side < 2; ++side) {
        double& stat = side == 0 ? up_[a] : down_[a];
        if (!(stat > h_par_[a])) continue;
        stat = 0.0;
        MonitorAlarm alarm;
        alarm.kind = MonitorAlarm::Kind::kParameter;
        alarm.what = fmt::format("{}: {}", names[a], side == 0 ? "up" : "down");
        alarm.message = fmt::format(
            "{} has moved {} from its reference {:.4g} (by {:.2g}, {:.3g} %, or more, score test; "
            "the on-line estimate is {:.4g} ± {:.2g}; t = {:g})",
            names[a], side == 0 ? "up" : "down", ref_theta_[a], delta_[a],
            100.0 * delta_[a] / std::abs(ref_theta_[a]), m.estimate.theta[a], m.estimate.sd[a],
            m.estimate.t);
        m.alarms.push_back(std::move(alarm));
      }
    }
    for (std::size_t a = 0; a < ref_theta_.size(); ++a) {
      const double se2 = std::isnan(ref_sd_[a]) ? 0.0 : ref_sd_[a] * ref_sd_[a];
      const double sd = std::sqrt(m.estimate.sd[a] * m.estimate.sd[a] + se2);
      const double z = sd > 0.0 ? (m.estimate.theta[a] - ref_theta_[a]) / sd : 0.0;
      m.parameter_z.push_back(z);
    }
    if (!m.alarms.empty()) {
      alarm_ = true;
      alarm_count_ += static_cast<long long>(m.alarms.size());
    }
    m.alarm = alarm_;
    out.push_back(std::move(m));
  }
  return out;
}

Json Monitor::ToJson(const MonitorUpdate& u) const {
  auto number = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  Json j;
  j["t"] = u.estimate.t;
  j["line"] = u.estimate.line;
  j["index"] = u.estimate.index;
  j["warming_up"] = u.estimate.warming_up;
  Json params = Json::object();
  const std::vector<std::string>& names = estimator_->tracked_names();
  for (std::size_t a = 0; a < names.size(); ++a) {
    params[names[a]] = {
        {"estimate", number(u.estimate.theta[a])},
        {"sd", number(u.estimate.sd[a])},
        {"reference", number(ref_theta_[a])},
        {"z", number(u.parameter_z[a])},
        {"cusum", {{"up", u.parameter_cusum[2 * a]}, {"down", u.parameter_cusum[2 * a + 1]}}}};
  }
  j["parameters"] = params;
  Json innovations = Json::object();
  Json cusum = Json::object();
  const auto& outputs = estimator_->spec().outputs;
  for (std::size_t o = 0; o < outputs.size(); ++o) {
    innovations[outputs[o]] = {{"value", number(u.estimate.innovation[o])},
                               {"sd", number(u.estimate.innovation_sd[o])},
                               {"z", number(u.z[o])}};
    cusum[outputs[o]] = {{"mean up", u.cusum[3 * o]},
                         {"mean down", u.cusum[3 * o + 1]},
                         {"variance up", u.cusum[3 * o + 2]}};
  }
  j["innovations"] = innovations;
  j["cusum"] = cusum;
  Json alarms = Json::array();
  for (const MonitorAlarm& a : u.alarms)
    alarms.push_back(
        {{"kind", a.kind == MonitorAlarm::Kind::kParameter ? "parameter" : "innovations"},
         {"what", a.what},
         {"message", a.message}});
  j["alarms"] = alarms;
  j["alarm"] = u.alarm;
  return j;
}

}  // namespace gb::online
