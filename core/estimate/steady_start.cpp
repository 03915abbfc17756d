#include "core/estimate/steady_start.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <fmt/format.h>

#include "core/model/linearise.h"
#include "core/util/json.h"

namespace gb::estimate {

namespace {

// The mean inputs and outputs of one window of a record.
struct Window {
  Eigen::VectorXd u, y;   // y: NaN where the window has no observation of that output
  Eigen::VectorXd guess;  // the last steady state found here
  std::string where;      // "engine_points.csv, t 0-5 s" (for messages)
};

std::vector<Window> CutWindows(const std::vector<std::shared_ptr<const data::Series>>& series,
                               double seconds) {
  std::vector<Window> windows;
  for (const auto& s : series) {
    const std::size_t n = s->size();
    std::size_t begin = 0;
    while (begin < n) {
      std::size_t end = begin;
      while (end < n && s->time[end] < s->time[begin] + seconds) ++end;
      if (end == begin) ++end;
      Window w;
      w.u =
          s->U.middleCols(static_cast<Eigen::Index>(begin), static_cast<Eigen::Index>(end - begin))
              .rowwise()
              .mean();
      w.y.resize(s->Y.rows());
      for (Eigen::Index o = 0; o < s->Y.rows(); ++o) {
        double sum = 0;
        int count = 0;
        for (std::size_t k = begin; k < end; ++k) {
          const double v = s->Y(o, static_cast<Eigen::Index>(k));
          if (std::isfinite(v)) sum += v, ++count;
        }
        w.y(o) = count > 0 ? sum / count : std::numeric_limits<double>::quiet_NaN();
      }
      w.where = fmt::format("{}, t {:g}-{:g} s", s->source, s->time[begin], s->time[end - 1]);
      windows.push_back(std::move(w));
      begin = end;
    }
  }
  return windows;
}

// Each output's standard deviation over all the records (1 where it does not vary).
Eigen::VectorXd OutputScales(const std::vector<std::shared_ptr<const data::Series>>& series,
                             Eigen::Index outputs) {
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(outputs);
  for (Eigen::Index o = 0; o < outputs; ++o) {
    double sum = 0, sum2 = 0;
    long count = 0;
    for (const auto& s : series)
      for (Eigen::Index k = 0; k < s->Y.cols(); ++k)
        if (const double v = s->Y(o, k); std::isfinite(v)) sum += v, sum2 += v * v, ++count;
    if (count < 2) continue;
    const double mean = sum / static_cast<double>(count);
    const double var = sum2 / static_cast<double>(count) - mean * mean;
    if (var > 0 && std::isfinite(var)) scale(o) = std::sqrt(var);
  }
  return scale;
}

class Residuals {
 public:
  Residuals(model::SteadyStateSolver& solver, std::vector<Window>& windows, Eigen::VectorXd scale)
      : solver_(solver), windows_(windows), scale_(std::move(scale)) {}

  // The scaled residuals of every window at θ; false when a window has no steady state there.
  // Each window's solution becomes its next guess when `keep`, or later by KeepLast().
  bool At(std::span<const double> theta, Eigen::VectorXd* r, bool keep) {
    const auto p = scale_.size();
    r->resize(static_cast<Eigen::Index>(windows_.size()) * p);
    last_.resize(windows_.size());
    Eigen::VectorXd y;
    for (std::size_t w = 0; w < windows_.size(); ++w) {
      Window& win = windows_[w];
      auto x = solver_.Solve(theta, win.u, win.guess, &y);
      if (!x) return false;
      last_[w] = *x;
      if (keep) win.guess = *x;
      for (Eigen::Index o = 0; o < p; ++o) {
        const double d = (y(o) - win.y(o)) / scale_(o);
        (*r)(static_cast<Eigen::Index>(w) * p + o) = std::isfinite(win.y(o)) ? d : 0.0;
      }
      if (!r->segment(static_cast<Eigen::Index>(w) * p, p).allFinite()) return false;
    }
    return true;
  }
  // The solutions of the last successful At become the windows' next guesses.
  void KeepLast() {
    for (std::size_t w = 0; w < windows_.size() && w < last_.size(); ++w)
      windows_[w].guess = last_[w];
  }

 private:
  std::vector<Eigen::VectorXd> last_;
  model::SteadyStateSolver& solver_;
  std::vector<Window>& windows_;
  Eigen::VectorXd scale_;
};

double Rms(const Eigen::VectorXd& r) {
  return r.size() > 0 ? std::sqrt(r.squaredNorm() / static_cast<double>(r.size())) : 0.0;
}

// A free parameter the steady states depend on, moved on the scale z = θ / scale.
struct Free {
  int index;
  double scale, lower, upper;
};

// ∂r/∂z by forward differences at θ (where the residuals are r); empty when a window loses its
// steady state on the way.
Eigen::MatrixXd Jacobian(Residuals& residuals, const std::vector<Free>& free,
                         std::vector<double> theta, const Eigen::VectorXd& r) {
  Eigen::MatrixXd J(r.size(), static_cast<Eigen::Index>(free.size()));
  for (std::size_t k = 0; k < free.size(); ++k) {
    const Free& f = free[k];
    const auto i = static_cast<std::size_t>(f.index);
    const double at = theta[i];
    const double h = 1e-6 * std::max(std::abs(at) / f.scale, 1.0);
    const double sign = at + h * f.scale > f.upper ? -1.0 : 1.0;
    theta[i] = at + sign * h * f.scale;
    Eigen::VectorXd rk;
    if (!residuals.At(theta, &rk, false)) return {};
    theta[i] = at;
    J.col(static_cast<Eigen::Index>(k)) = (rk - r) / (sign * h);
  }
  return J;
}

// Levenberg-Marquardt from θ (residuals r) on a, with z = z(θ) + B a, steps clipped to the
// bounds; B's columns are directions in z (the identity: every free parameter). Returns the
// iterations taken; θ and r are the result.
int Minimise(Residuals& residuals, const std::vector<Free>& free, const Eigen::MatrixXd& B,
             int max_iterations, std::vector<double>* theta, Eigen::VectorXd* r) {
  double cost = r->squaredNorm();
  double lambda = 1e-3;
  int it = 0;
  while (it < max_iterations) {
    ++it;
    const Eigen::MatrixXd Jz = Jacobian(residuals, free, *theta, *r);
    if (Jz.size() == 0) break;
    const Eigen::MatrixXd J = Jz * B;
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * *r;
    bool accepted = false;
    while (!accepted && lambda < 1e12) {
      Eigen::MatrixXd M = JtJ;
      M.diagonal() += lambda * JtJ.diagonal().cwiseMax(1e-12);
      const Eigen::VectorXd dz = B * M.ldlt().solve(-g);
      std::vector<double> trial = *theta;
      for (std::size_t k = 0; k < free.size(); ++k) {
        const Free& f = free[k];
        const auto i = static_cast<std::size_t>(f.index);
        trial[i] =
            std::clamp(trial[i] + dz(static_cast<Eigen::Index>(k)) * f.scale, f.lower, f.upper);
      }
      Eigen::VectorXd rt;
      if (dz.allFinite() && residuals.At(trial, &rt, false) && rt.squaredNorm() < cost) {
        residuals.KeepLast();  // the new guesses
        const double decrease = cost - rt.squaredNorm();
        *theta = trial;
        *r = rt;
        const double previous = cost;
        cost = r->squaredNorm();
        lambda = std::max(lambda / 3, 1e-12);
        accepted = true;
        if (decrease <= 1e-12 * previous) return it;  // converged
      } else {
        lambda *= 4;
      }
    }
    if (!accepted) break;
  }
  return it;
}

}  // namespace

std::string SteadyStartResult::Report() const {
  std::string out = fmt::format(
      "Steady-state start: {} parameter{} from {} windows of length {:g}{}, scaled RMS misfit "
      "{:.4g} -> {:.4g} ({} iteration{})",
      fitted.size(), fitted.size() == 1 ? "" : "s", windows, window_seconds,
      windows_left_out > 0
          ? fmt::format(" ({} left out: no steady state at the starts)", windows_left_out)
          : "",
      misfit_start, misfit, iterations, iterations == 1 ? "" : "s");
  if (undetermined > 0)
    out += fmt::format(
        ", {} combination{} of them left at the starts (the levels do not fix "
        "{})",
        undetermined, undetermined == 1 ? "" : "s", undetermined == 1 ? "it" : "them");
  for (std::size_t k = 0; k < fitted.size(); ++k)
    out += fmt::format("{} {} {:.6g} -> {:.6g}", k == 0 ? ":" : ",", fitted[k].name, fitted[k].from,
                       fitted[k].to);
  return out;
}

Json SteadyStartResult::ToJson() const {
  Json moved = Json::object();
  for (const Moved& m : fitted) moved[m.name] = {{"from", m.from}, {"to", m.to}};
  return {
      {"window", window_seconds},     {"windows", windows}, {"windows_left_out", windows_left_out},
      {"misfit_start", misfit_start}, {"misfit", misfit},   {"iterations", iterations},
      {"undetermined", undetermined}, {"parameters", moved}};
}

Result<SteadyStartResult> SteadyStart(const filter::Likelihood& likelihood,
                                      std::span<const double> theta,
                                      const SteadyStartOptions& options) {
  if (const model::NonlinearModel* nonlinear = likelihood.nonlinear())
    return SteadyStart(*nonlinear, theta, likelihood.series(), options);
  auto compiled = model::NonlinearModel::Compile(likelihood.spec());
  if (!compiled) return compiled.error();
  return SteadyStart(*compiled, theta, likelihood.series(), options);
}

Result<SteadyStartResult> SteadyStart(
    const model::NonlinearModel& model, std::span<const double> theta,
    const std::vector<std::shared_ptr<const data::Series>>& series,
    const SteadyStartOptions& options) {
  const model::ModelSpec& spec = model.spec();
  if (static_cast<int>(theta.size()) != model.n_parameters())
    return InputError("steady-state start: one value per parameter is needed");
  if (!(options.window_seconds > 0))
    return InputError("steady-state start: the window must be longer than 0 s");
  auto solver = model::SteadyStateSolver::Make(model);
  if (!solver) return solver.error();

  std::vector<Window> all = CutWindows(series, options.window_seconds);
  const Eigen::VectorXd x0 = solver->InitialState(theta);
  // The windows with a steady state at the starts, each solved from the one before it in its
  // record (then from the initial state).
  std::vector<Window> windows;
  std::string first_failure;
  Eigen::VectorXd guess = x0;
  for (Window& w : all) {
    Eigen::VectorXd y;
    auto x = solver->Solve(theta, w.u, guess, &y);
    if (!x) x = solver->Solve(theta, w.u, x0, &y);
    if (!x || !y.allFinite()) {
      if (first_failure.empty())
        first_failure = fmt::format("{}: {}", w.where,
                                    x ? "the outputs are not finite there" : x.error().message);
      continue;
    }
    w.guess = guess = *x;
    windows.push_back(std::move(w));
  }
  SteadyStartResult result;
  result.theta.assign(theta.begin(), theta.end());
  result.window_seconds = options.window_seconds;
  result.windows = static_cast<int>(windows.size());
  result.windows_left_out = static_cast<int>(all.size() - windows.size());
  if (windows.empty())
    return InputError(
        fmt::format("steady-state start: no window of the records has a steady "
                    "state at the start values (the first: {})",
                    first_failure.empty() ? "the records are empty" : first_failure));

  Residuals residuals(*solver, windows, OutputScales(series, model.n_outputs()));
  Eigen::VectorXd r0;
  if (!residuals.At(theta, &r0, true))
    return InputError("steady-state start: the steady states do not hold at the start values");
  result.misfit_start = result.misfit = Rms(r0);

  // The free parameters the steady states depend on: a relative step of 1e-4 moves some
  // residual by more than 1e-9 of the scale.
  std::vector<Free> free;
  std::vector<double> th(theta.begin(), theta.end());
  for (std::size_t i = 0; i < spec.parameters.size(); ++i) {
    const model::Parameter& p = spec.parameters[i];
    if (p.fixed) continue;
    const double scale = th[i] != 0 ? std::abs(th[i]) : 1.0;
    const double lower = p.lower.value_or(-std::numeric_limits<double>::infinity());
    const double upper = p.upper.value_or(std::numeric_limits<double>::infinity());
    const double step = 1e-4 * scale * (th[i] + 1e-4 * scale > upper ? -1 : 1);
    th[i] += step;
    Eigen::VectorXd r;
    const bool moved = residuals.At(th, &r, false) && (r - r0).cwiseAbs().maxCoeff() > 1e-9;
    th[i] = theta[i];
    if (moved) {
      free.push_back({static_cast<int>(i), scale > 0 ? scale : 1.0, lower, upper});
      result.fitted.push_back({p.name, theta[i], theta[i]});
    }
  }
  if (free.empty())
    return InputError(
        "steady-state start: no free parameter moves the model's steady states "
        "(they are set by the inputs alone)");

  // Levenberg-Marquardt on z_k = θ_k / scale_k over every such parameter.
  const auto nf = static_cast<Eigen::Index>(free.size());
  std::vector<double> th_all(theta.begin(), theta.end());
  Eigen::VectorXd r_all = r0;
  const auto all_windows = windows;  // each window's first guess, for the second pass
  int iterations = Minimise(residuals, free, Eigen::MatrixXd::Identity(nf, nf),
                            options.max_iterations, &th_all, &r_all);

  // The combinations the levels determine. Levels from windows that are not quite steady fix
  // some combinations of the parameters and leave others free to follow whatever the means
  // carry (an engine's efficiency and friction along λ = 1, where fuel and speed rise
  // together). At the minimum, with σ the residuals' standard deviation, the combination v_i of
  // the scaled Jacobian's SVD (singular value s_i) is known to ± σ / s_i in relative terms; one
  // known to better than kDetermined is moved, the others stay at the starts: the fit is
  // repeated from the starts along the determined combinations only.
  Eigen::VectorXd r = r_all;
  std::vector<double> best = th_all;
  const Eigen::MatrixXd J = Jacobian(residuals, free, th_all, r_all);
  const auto dof = r_all.size() - nf;
  if (J.size() > 0 && dof > 0) {
    const double sigma = std::sqrt(r_all.squaredNorm() / static_cast<double>(dof));
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(J, Eigen::ComputeThinV);
    const Eigen::VectorXd& sv = svd.singularValues();
    Eigen::Index kept = 0;
    while (kept < sv.size() && sv(kept) > 0 && sigma / sv(kept) <= options.determined) ++kept;
    result.undetermined = static_cast<int>(nf - kept);
    if (kept < nf) {
      windows = all_windows;
      best.assign(theta.begin(), theta.end());
      r = r0;
      if (kept > 0)
        iterations += Minimise(residuals, free, svd.matrixV().leftCols(kept),
                               options.max_iterations, &best, &r);
    }
  }
  result.theta = best;
  result.iterations = iterations;
  result.misfit = Rms(r);
  for (std::size_t k = 0; k < free.size(); ++k)
    result.fitted[k].to = result.theta[static_cast<std::size_t>(free[k].index)];
  return result;
}

}  // namespace gb::estimate
