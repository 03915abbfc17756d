#include "core/design/experiment.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <charconv>
#include <cmath>
#include <complex>
#include <map>
#include <numbers>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <fmt/format.h>
#include <unsupported/Eigen/FFT>

namespace gb::design {

namespace {

bool Fail(std::string* why, std::string message) {
  if (why) *why = std::move(message);
  return false;
}

// "%.17g" without a trailing exponent's noise: the shortest text that reads back to the bit.
std::string Exact(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

}  // namespace

const char* ShapeName(InputShape shape) {
  switch (shape) {
    case InputShape::kPrbs:
      return "prbs";
    case InputShape::kSquare:
      return "square";
    case InputShape::kStep:
      return "step";
  }
  return "prbs";
}

bool InputDesign::IsValid(std::string* why) const {
  auto finite = [&](double v, const char* key, bool positive) {
    if (!std::isfinite(v)) return Fail(why, fmt::format("{}: must be a finite number", key));
    if (positive && !(v > 0)) return Fail(why, fmt::format("{}: must be positive, not {}", key, v));
    return true;
  };
  if (!finite(level, "level", false) || !finite(amplitude, "amplitude", true) ||
      !finite(sample_time, "ts", true) || !finite(duration, "duration", true))
    return false;
  if (duration / sample_time > kMaxDesignSamples)
    return Fail(why, fmt::format("duration: {} at ts {} would give more than {:.0f} samples",
                                 duration, sample_time, kMaxDesignSamples));
  if (std::ceil(duration / sample_time - 1e-9) < 2)
    return Fail(why, fmt::format("duration: {} at ts {} gives fewer than 2 samples", duration,
                                 sample_time));
  switch (shape) {
    case InputShape::kPrbs: {
      if (order < kMinPrbsOrder || order > kMaxPrbsOrder)
        return Fail(why, fmt::format("order: {} is not offered (use {} to {})", order,
                                     kMinPrbsOrder, kMaxPrbsOrder));
      if (!finite(bit_period, "bit", true)) return false;
      if (bit_period < sample_time * (1 - 1e-9))
        return Fail(why, fmt::format("bit: the bit period {} is shorter than the sample time {}",
                                     bit_period, sample_time));
      return true;
    }
    case InputShape::kSquare:
      if (!finite(period, "period", true)) return false;
      if (period < 2 * sample_time * (1 - 1e-9))
        return Fail(why, fmt::format("period: {} is shorter than two samples ({})", period,
                                     2 * sample_time));
      return true;
    case InputShape::kStep:
      if (!finite(step_time, "at", false)) return false;
      if (step_time < 0 || step_time >= duration)
        return Fail(why, fmt::format("at: the step at {} is not within the record (0 to {})",
                                     step_time, duration));
      return true;
  }
  return true;
}

std::string InputDesign::Describe() const {
  const auto samples = static_cast<long>(std::ceil(duration / sample_time - 1e-9));
  std::string common = fmt::format("{:.4g} ± {:.4g}, {} samples every {:.4g} over {:.4g}", level,
                                   amplitude, samples, sample_time, duration);
  switch (shape) {
    case InputShape::kPrbs:
      return fmt::format("PRBS n = {}, bit {:.4g}, {}", order, bit_period, common);
    case InputShape::kSquare:
      return fmt::format("square wave, period {:.4g}, {}", period, common);
    case InputShape::kStep:
      return fmt::format("step at {:.4g}, {}", step_time, common);
  }
  return common;
}

Result<InputDesign> ParseInputDesign(std::string_view text) {
  const std::string whole(text);
  auto bad = [&](const std::string& what) {
    return InputError(fmt::format("input design '{}': {}", whole, what));
  };
  const auto colon = text.find(':');
  const std::string_view shape = text.substr(0, colon);
  InputDesign d;
  if (shape == "prbs") {
    d.shape = InputShape::kPrbs;
  } else if (shape == "square") {
    d.shape = InputShape::kSquare;
  } else if (shape == "step") {
    d.shape = InputShape::kStep;
  } else {
    return bad(
        fmt::format("unknown shape '{}' (use prbs, square or step, then ':' and the "
                    "settings, e.g. prbs:order=6,bit=0.5,level=1,amplitude=0.1)",
                    shape));
  }
  std::map<std::string, double*> numbers = {{"level", &d.level},
                                            {"amplitude", &d.amplitude},
                                            {"ts", &d.sample_time},
                                            {"duration", &d.duration}};
  double order = d.order, seed = d.seed;
  if (d.shape == InputShape::kPrbs) {
    numbers["order"] = &order;
    numbers["bit"] = &d.bit_period;
    numbers["seed"] = &seed;
  } else if (d.shape == InputShape::kSquare) {
    numbers["period"] = &d.period;
  } else {
    numbers["at"] = &d.step_time;
  }
  std::map<std::string, bool> seen;
  std::string_view rest = colon == std::string_view::npos ? "" : text.substr(colon + 1);
  while (!rest.empty()) {
    const auto comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    rest = comma == std::string_view::npos ? "" : rest.substr(comma + 1);
    const auto eq = item.find('=');
    const std::string key(item.substr(0, eq));
    if (eq == std::string_view::npos || key.empty())
      return bad(fmt::format("'{}' is not KEY=VALUE", item));
    const auto it = numbers.find(key);
    if (it == numbers.end()) {
      std::string keys;
      for (const auto& [k, _] : numbers) keys += (keys.empty() ? "" : ", ") + k;
      return bad(fmt::format("unknown key '{}' for {} (its keys: {})", key, shape, keys));
    }
    if (seen[key]) return bad(fmt::format("'{}' is given twice", key));
    seen[key] = true;
    const std::string_view value = item.substr(eq + 1);
    double v = 0;
    const auto r = std::from_chars(value.data(), value.data() + value.size(), v);
    if (r.ec != std::errc() || r.ptr != value.data() + value.size() || !std::isfinite(v))
      return bad(fmt::format("'{}' must be a finite number, not '{}'", key, value));
    *it->second = v;
  }
  if (d.shape == InputShape::kPrbs) {
    if (order != std::floor(order) || order < kMinPrbsOrder || order > kMaxPrbsOrder)
      return bad(fmt::format("'order' must be a whole number from {} to {}, not {}", kMinPrbsOrder,
                             kMaxPrbsOrder, order));
    if (seed != std::floor(seed) || seed < 0 || seed > 4294967295.0)
      return bad(fmt::format("'seed' must be a whole number from 0 to 2^32 - 1, not {}", seed));
    d.order = static_cast<int>(order);
    d.seed = static_cast<std::uint32_t>(seed);
  }
  std::string why;
  if (!d.IsValid(&why)) return bad(why);
  return d;
}

std::string FormatInputDesign(const InputDesign& d) {
  std::string s = ShapeName(d.shape);
  switch (d.shape) {
    case InputShape::kPrbs:
      s += fmt::format(":order={},bit={},seed={},", d.order, Exact(d.bit_period), d.seed);
      break;
    case InputShape::kSquare:
      s += fmt::format(":period={},", Exact(d.period));
      break;
    case InputShape::kStep:
      s += fmt::format(":at={},", Exact(d.step_time));
      break;
  }
  s += fmt::format("level={},amplitude={},ts={},duration={}", Exact(d.level), Exact(d.amplitude),
                   Exact(d.sample_time), Exact(d.duration));
  return s;
}

Result<Signal> MakeInput(const InputDesign& d) {
  std::string why;
  if (!d.IsValid(&why)) return InputError(why);
  const double low = d.level - d.amplitude, high = d.level + d.amplitude;
  switch (d.shape) {
    case InputShape::kPrbs: {
      PrbsOptions o;
      o.order = d.order;
      o.bit_period = d.bit_period;
      o.sample_time = d.sample_time;
      o.duration = d.duration;
      o.low = low;
      o.high = high;
      o.seed = d.seed;
      return MakePrbs(o);
    }
    case InputShape::kSquare:
      return MakeSquareWave(d.period, d.sample_time, d.duration, low, high);
    case InputShape::kStep: {
      auto s = MakeSquareWave(2 * d.duration, d.sample_time, d.duration, low, low);
      if (!s) return s.error();
      for (std::size_t k = 0; k < s->t.size(); ++k)
        if (s->t[k] >= d.step_time * (1 - 1e-12)) s->u[k] = high;
      return s;
    }
  }
  return InputError("unknown input shape");
}

data::Series DesignSeries(const model::ModelSpec& spec, int input, const Signal& signal,
                          std::span<const double> hold) {
  const auto m = static_cast<Eigen::Index>(spec.inputs.size());
  const auto p = static_cast<Eigen::Index>(spec.outputs.size());
  assert(input >= 0 && input < m && static_cast<Eigen::Index>(hold.size()) == m);
  const auto N = static_cast<Eigen::Index>(signal.t.size());
  data::Series s;
  s.source = "the design";
  s.time = signal.t;
  s.U.resize(m, N);
  for (Eigen::Index i = 0; i < m; ++i) s.U.row(i).setConstant(hold[i]);
  s.U.row(input) = Eigen::Map<const Eigen::RowVectorXd>(signal.u.data(), N);
  s.Y = Eigen::MatrixXd::Zero(p, N);
  s.outputs = spec.outputs;
  s.intervals = data::GroupIntervals(s.time);
  return s;
}

Spectrum InputSpectrum(const Signal& s, int bands) {
  Spectrum out;
  const std::size_t N = s.u.size();
  if (N < 4 || bands < 1) return out;
  const double ts = s.t[1] - s.t[0];
  double mean = 0;
  for (double v : s.u) mean += v;
  mean /= static_cast<double>(N);
  std::vector<double> x(N);
  for (std::size_t k = 0; k < N; ++k) x[k] = s.u[k] - mean;
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> X;
  fft.fwd(X, x);
  // One-sided periodogram: 2 |X_f|² ts / N at f = i / (N ts), 0 < i < N/2.
  const double df = 1.0 / (static_cast<double>(N) * ts);
  const double f_lo = df, f_hi = 0.5 / ts;
  const double step = std::log(f_hi / f_lo) / bands;
  std::vector<double> sum(static_cast<std::size_t>(bands), 0.0);
  std::vector<int> count(static_cast<std::size_t>(bands), 0);
  for (std::size_t i = 1; 2 * i < N; ++i) {
    const double f = static_cast<double>(i) * df;
    const auto b = std::min(bands - 1, static_cast<int>(std::log(f / f_lo) / step));
    sum[static_cast<std::size_t>(b)] += 2.0 * std::norm(X[i]) * ts / static_cast<double>(N);
    ++count[static_cast<std::size_t>(b)];
  }
  for (int b = 0; b < bands; ++b) {
    if (count[static_cast<std::size_t>(b)] == 0) continue;
    out.frequency.push_back(f_lo * std::exp(step * (b + 0.5)));
    out.power.push_back(sum[static_cast<std::size_t>(b)] / count[static_cast<std::size_t>(b)]);
  }
  return out;
}

std::vector<double> GainSquared(const model::StateSpace& ss, int input, int output,
                                std::span<const double> frequency) {
  const int n = ss.n_states();
  std::vector<double> out;
  out.reserve(frequency.size());
  const Eigen::MatrixXcd A = ss.A.cast<std::complex<double>>();
  const Eigen::VectorXcd b = ss.B.col(input).cast<std::complex<double>>();
  const Eigen::RowVectorXcd c = ss.C.row(output).cast<std::complex<double>>();
  for (double f : frequency) {
    const std::complex<double> s(0.0, 2 * std::numbers::pi * f);
    const Eigen::MatrixXcd M = s * Eigen::MatrixXcd::Identity(n, n) - A;
    const std::complex<double> G = (c * M.partialPivLu().solve(b)).value() + ss.D(output, input);
    out.push_back(std::norm(G));
  }
  return out;
}

std::vector<double> TimeConstants(const Eigen::MatrixXd& A) {
  std::vector<double> out;
  if (A.rows() == 0) return out;
  const Eigen::EigenSolver<Eigen::MatrixXd> eig(A, false);
  if (eig.info() != Eigen::Success) return out;
  for (Eigen::Index i = 0; i < A.rows(); ++i) {
    const std::complex<double> l = eig.eigenvalues()(i);
    if (l.real() < 0 && l.imag() >= 0) out.push_back(-1.0 / l.real());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::optional<double> Bandwidth(const model::StateSpace& ss, int input, int output) {
  const std::vector<double> tau = TimeConstants(ss.A);
  if (static_cast<int>(tau.size()) == 0) return std::nullopt;
  const Eigen::EigenSolver<Eigen::MatrixXd> eig(ss.A, false);
  for (Eigen::Index i = 0; i < ss.A.rows(); ++i)
    if (!(eig.eigenvalues()(i).real() < 0)) return std::nullopt;  // no finite steady gain
  const double dc = GainSquared(ss, input, output, std::array{0.0})[0];
  if (!(dc > 0) || !std::isfinite(dc)) return std::nullopt;
  // Scan from a thousandth of the slowest mode's corner to a thousand times the fastest's, 20
  // points a decade, then bisect the first crossing on log f.
  const double f_lo = 1e-3 / (2 * std::numbers::pi * tau.back());
  const double f_hi = 1e3 / (2 * std::numbers::pi * tau.front());
  const int points = static_cast<int>(std::ceil(20 * std::log10(f_hi / f_lo)));
  double prev = f_lo;
  for (int i = 1; i <= points; ++i) {
    const double f = f_lo * std::pow(10.0, i / 20.0);
    if (GainSquared(ss, input, output, std::array{f})[0] > 0.5 * dc) {
      prev = f;
      continue;
    }
    double lo = prev, hi = f;
    for (int it = 0; it < 60; ++it) {
      const double mid = std::sqrt(lo * hi);
      (GainSquared(ss, input, output, std::array{mid})[0] > 0.5 * dc ? lo : hi) = mid;
    }
    return std::sqrt(lo * hi);
  }
  return std::nullopt;
}

Result<DesignEvaluation> EvaluateDesign(const model::LinearModel& model, const InputDesign& design,
                                        int input, std::span<const double> hold,
                                        const filter::FilterSettings& settings) {
  const model::ModelSpec& spec = model.spec();
  auto signal = MakeInput(design);
  if (!signal) return signal.error();
  DesignEvaluation out;
  out.design = design;
  std::vector<double> theta;
  for (int i = 0; i < static_cast<int>(spec.parameters.size()); ++i) {
    theta.push_back(spec.parameters[static_cast<std::size_t>(i)].value);
    if (!spec.parameters[static_cast<std::size_t>(i)].fixed) out.free.push_back(i);
  }
  const data::Series series = DesignSeries(spec, input, *signal, hold);
  auto info = ExpectedFisherInformation(model, theta, out.free, series, settings);
  if (!info) return info.error();
  out.info = std::move(*info);
  out.spectrum = InputSpectrum(*signal);
  out.signal = std::move(*signal);
  return out;
}

}  // namespace gb::design
