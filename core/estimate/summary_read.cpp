// EstimateSummary::FromJson: a result file (user guide §5) read back into the summary that
// wrote it, so that a kept fit reopens with its report, table and correlations. The inverse of
// ToJson (summary_format.cpp) for everything ToJson writes; what it does not write (the ODE
// solver's rejected steps and right-hand sides, the steady-state start's θ) stays empty.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "core/estimate/estimate.h"
#include "core/util/json.h"

namespace gb::estimate {
namespace {

// Reads members of one JSON object, each refusal naming the file and the member's JSON path.
class Reader {
 public:
  Reader(const Json& j, std::string file, std::string path)
      : j_(j), file_(std::move(file)), path_(std::move(path)) {}

  std::string At(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  Error Fail(const std::string& key, const std::string& what) const {
    Error e = InputError(what);
    e.file = file_;
    e.path = At(key);
    return e;
  }
  const Json* Find(const std::string& key) const {
    const auto it = j_.find(key);
    return it == j_.end() ? nullptr : &*it;
  }
  Reader Object(const std::string& key, const Json& v) const { return {v, file_, At(key)}; }

  Status Number(const std::string& key, double* out) const {
    const Json* v = Find(key);
    if (!v || !v->is_number()) return Fail(key, "expected a number");
    *out = v->get<double>();
    if (!std::isfinite(*out)) return Fail(key, "expected a finite number");
    return Ok{};
  }
  // null or absent: no value.
  Status OptNumber(const std::string& key, std::optional<double>* out) const {
    const Json* v = Find(key);
    if (!v || v->is_null()) return Ok{};
    if (!v->is_number()) return Fail(key, "expected a number or null");
    *out = v->get<double>();
    return Ok{};
  }
  template <class Int>
  Status Whole(const std::string& key, Int* out, bool required = true) const {
    const Json* v = Find(key);
    if (!v) return required ? Fail(key, "expected a whole number") : Status{Ok{}};
    if (!v->is_number_integer()) return Fail(key, "expected a whole number");
    *out = v->get<Int>();
    return Ok{};
  }
  Status Bool(const std::string& key, bool* out, bool required = true) const {
    const Json* v = Find(key);
    if (!v) return required ? Fail(key, "expected true or false") : Status{Ok{}};
    if (!v->is_boolean()) return Fail(key, "expected true or false");
    *out = v->get<bool>();
    return Ok{};
  }
  Status String(const std::string& key, std::string* out, bool required = true) const {
    const Json* v = Find(key);
    if (!v) return required ? Fail(key, "expected a string") : Status{Ok{}};
    if (!v->is_string()) return Fail(key, "expected a string");
    *out = v->get<std::string>();
    return Ok{};
  }
  Status Strings(const std::string& key, std::vector<std::string>* out) const {
    const Json* v = Find(key);
    if (!v) return Ok{};
    if (!v->is_array()) return Fail(key, "expected an array of strings");
    for (std::size_t i = 0; i < v->size(); ++i) {
      if (!(*v)[i].is_string()) return Fail(fmt::format("{}[{}]", key, i), "expected a string");
      out->push_back((*v)[i].get<std::string>());
    }
    return Ok{};
  }
  const Json& json() const { return j_; }

 private:
  const Json& j_;
  std::string file_;
  std::string path_;
};

#define GB_TRY(expr)                                   \
  do {                                                 \
    if (Status st_ = (expr); !st_) return st_.error(); \
  } while (false)

Status ReadFilter(const Reader& r, EstimateSummary* s) {
  const Json* f = r.Find("filter");
  if (!f) return Ok{};
  if (!f->is_object()) return r.Fail("filter", "expected an object");
  const Reader fr = r.Object("filter", *f);
  std::string kind = "kalman", scores = "exact";
  GB_TRY(fr.String("kind", &kind, false));
  GB_TRY(fr.String("scores", &scores, false));
  if (scores != "exact" && scores != "differences")
    return fr.Fail("scores", "expected \"exact\" or \"differences\"");
  s->exact_scores = scores == "exact";
  if (kind == "kalman") return Ok{};
  if (kind != "ekf") return fr.Fail("kind", "expected \"kalman\" or \"ekf\"");
  s->extended = true;
  std::string ode = "auto";
  GB_TRY(fr.String("ode", &ode));
  if (ode == "explicit")
    s->ekf.method = model::OdeMethod::kExplicit;
  else if (ode == "bdf")
    s->ekf.method = model::OdeMethod::kBdf;
  else if (ode == "auto")
    s->ekf.method = model::OdeMethod::kAuto;
  else
    return fr.Fail("ode", "expected \"auto\", \"explicit\" or \"bdf\"");
  GB_TRY(fr.Number("rtol", &s->ekf.rtol));
  GB_TRY(fr.Number("atol", &s->ekf.atol));
  GB_TRY(fr.Whole("iterations", &s->ekf.iterations));
  GB_TRY(fr.Whole("ode_steps", &s->ode.steps, false));
  GB_TRY(fr.Whole("ode_intervals", &s->ode.intervals, false));
  GB_TRY(fr.Whole("stiff_intervals", &s->ode.stiff_intervals, false));
  std::string code = "interpreter";
  GB_TRY(fr.String("code", &code, false));
  if (code != "native" && code != "interpreter")
    return fr.Fail("code", "expected \"native\" or \"interpreter\"");
  s->native = code == "native";
  return Ok{};
}

Status ReadProfile(const Reader& e, ProfileInterval* pi) {
  const Json* iv = e.Find("profile_interval");
  if (!iv->is_object()) return e.Fail("profile_interval", "expected an object");
  const Reader ir = e.Object("profile_interval", *iv);
  GB_TRY(ir.OptNumber("lower", &pi->lower));
  GB_TRY(ir.OptNumber("upper", &pi->upper));
  GB_TRY(ir.Number("level", &pi->level));
  const Json* prof = e.Find("profile");
  if (!prof) return Ok{};
  if (!prof->is_object()) return e.Fail("profile", "expected an object");
  const Reader pr = e.Object("profile", *prof);
  GB_TRY(pr.Bool("lower_at_bound", &pi->lower_at_bound, false));
  GB_TRY(pr.Bool("upper_at_bound", &pi->upper_at_bound, false));
  const Json* points = pr.Find("points");
  if (!points) return Ok{};
  if (!points->is_array())
    return pr.Fail("points", "expected an array of [value, log L, converged]");
  for (std::size_t i = 0; i < points->size(); ++i) {
    const Json& p = (*points)[i];
    if (!p.is_array() || p.size() != 3 || !p[0].is_number() || !p[1].is_number() ||
        !p[2].is_boolean())
      return pr.Fail(fmt::format("points[{}]", i), "expected [value, log L, converged]");
    pi->curve.push_back({p[0].get<double>(), p[1].get<double>(), p[2].get<bool>()});
  }
  return Ok{};
}

Status ReadParameters(const Reader& r, EstimateSummary* s) {
  const Json* params = r.Find("parameters");
  if (!params || !params->is_object())
    return r.Fail("parameters", "expected an object of parameter estimates");
  const Reader pr = r.Object("parameters", *params);
  for (const auto& [name, entry] : params->items()) {
    if (!entry.is_object()) return pr.Fail(name, "expected an object");
    const Reader e = pr.Object(name, entry);
    ParameterEstimate p;
    p.name = name;
    GB_TRY(e.Number("estimate", &p.estimate));
    GB_TRY(e.OptNumber("std_error", &p.std_error));
    GB_TRY(e.OptNumber("t_value", &p.t_value));
    GB_TRY(e.OptNumber("p_value", &p.p_value));
    GB_TRY(e.OptNumber("lower", &p.lower));
    GB_TRY(e.OptNumber("upper", &p.upper));
    GB_TRY(e.Bool("fixed", &p.fixed, false));
    GB_TRY(e.Bool("at_bound", &p.at_bound, false));
    GB_TRY(e.String("unit", &p.unit, false));
    if (e.Find("profile_interval")) {
      p.profile.emplace();
      GB_TRY(ReadProfile(e, &*p.profile));
    }
    s->theta.push_back(p.estimate);
    s->parameters.push_back(std::move(p));
  }
  return Ok{};
}

Status ReadOptima(const Reader& r, EstimateSummary* s) {
  const Json* optima = r.Find("optima");
  if (!optima) return Ok{};
  if (!optima->is_array()) return r.Fail("optima", "expected an array");
  for (std::size_t o = 0; o < optima->size(); ++o) {
    const std::string at = fmt::format("optima[{}]", o);
    if (!(*optima)[o].is_object()) return r.Fail(at, "expected an object");
    const Reader orr = r.Object(at, (*optima)[o]);
    Optimum opt;
    GB_TRY(orr.Number("loglik", &opt.loglik));
    GB_TRY(orr.Whole("starts", &opt.starts, false));
    GB_TRY(orr.Bool("converged", &opt.converged, false));
    const Json* values = orr.Find("parameters");
    if (!values || !values->is_object()) return orr.Fail("parameters", "expected an object");
    const Reader vr = orr.Object("parameters", *values);
    for (const ParameterEstimate& p : s->parameters) {
      double v = 0;
      GB_TRY(vr.Number(p.name, &v));
      opt.theta.push_back(v);
    }
    s->optima.push_back(std::move(opt));
  }
  return Ok{};
}

// The correlation matrix, and the covariance from it and the standard errors.
Status ReadCorrelation(const Reader& r, EstimateSummary* s) {
  const Json* c = r.Find("correlation");
  if (!c) return Ok{};
  if (!c->is_object()) return r.Fail("correlation", "expected an object");
  const Reader cr = r.Object("correlation", *c);
  GB_TRY(cr.Strings("names", &s->correlation_names));
  const auto n = static_cast<Eigen::Index>(s->correlation_names.size());
  const Json* m = cr.Find("matrix");
  if (!m || !m->is_array() || static_cast<Eigen::Index>(m->size()) != n)
    return cr.Fail("matrix", fmt::format("expected {} rows, one per name", n));
  s->correlation.resize(n, n);
  Eigen::VectorXd se(n);
  for (Eigen::Index a = 0; a < n; ++a) {
    const Json& row = (*m)[static_cast<std::size_t>(a)];
    const std::string at = fmt::format("matrix[{}]", a);
    if (!row.is_array() || static_cast<Eigen::Index>(row.size()) != n)
      return cr.Fail(at, fmt::format("expected {} numbers", n));
    for (Eigen::Index b = 0; b < n; ++b) {
      const Json& v = row[static_cast<std::size_t>(b)];
      if (!v.is_number()) return cr.Fail(fmt::format("{}[{}]", at, b), "expected a number");
      s->correlation(a, b) = v.get<double>();
    }
    const std::string& name = s->correlation_names[static_cast<std::size_t>(a)];
    const auto p = std::find_if(s->parameters.begin(), s->parameters.end(),
                                [&](const ParameterEstimate& e) { return e.name == name; });
    if (p == s->parameters.end() || !p->std_error)
      return cr.Fail(fmt::format("names[{}]", a),
                     fmt::format("'{}' is not a parameter with a standard error", name));
    se(a) = *p->std_error;
  }
  s->covariance = se.asDiagonal() * s->correlation * se.asDiagonal();
  return Ok{};
}

Status ReadDelays(const Reader& r, EstimateSummary* s) {
  const Json* delays = r.Find("output_delay");
  if (!delays) return Ok{};
  if (!delays->is_object()) return r.Fail("output_delay", "expected an object");
  const Reader dr = r.Object("output_delay", *delays);
  for (const auto& [output, entry] : delays->items()) {
    if (!entry.is_object()) return dr.Fail(output, "expected an object");
    const Reader e = dr.Object(output, entry);
    DelayEstimate d;
    d.output = output;
    GB_TRY(e.Whole("estimate", &d.estimate));
    GB_TRY(e.Bool("scanned", &d.scanned, false));
    const Json* prof = e.Find("profile");
    if (prof && !prof->is_array()) return e.Fail("profile", "expected an array");
    for (std::size_t i = 0; prof && i < prof->size(); ++i) {
      const std::string at = fmt::format("profile[{}]", i);
      if (!(*prof)[i].is_object()) return e.Fail(at, "expected an object");
      const Reader pr = e.Object(at, (*prof)[i]);
      DelayProfilePoint pt;
      GB_TRY(pr.Whole("delay", &pt.delay));
      GB_TRY(pr.OptNumber("loglik", &pt.loglik));
      GB_TRY(pr.Bool("converged", &pt.converged, false));
      d.profile.push_back(pt);
    }
    s->delays.push_back(std::move(d));
  }
  return Ok{};
}

Status ReadSteadyStart(const Reader& r, EstimateSummary* s) {
  const Json* v = r.Find("steady_start");
  if (!v) return Ok{};
  if (!v->is_object()) return r.Fail("steady_start", "expected an object");
  const Reader sr = r.Object("steady_start", *v);
  SteadyStartResult st;
  GB_TRY(sr.Number("window", &st.window_seconds));
  GB_TRY(sr.Whole("windows", &st.windows));
  GB_TRY(sr.Whole("windows_left_out", &st.windows_left_out, false));
  GB_TRY(sr.Number("misfit_start", &st.misfit_start));
  GB_TRY(sr.Number("misfit", &st.misfit));
  GB_TRY(sr.Whole("iterations", &st.iterations, false));
  GB_TRY(sr.Whole("undetermined", &st.undetermined, false));
  if (const Json* moved = sr.Find("parameters")) {
    if (!moved->is_object()) return sr.Fail("parameters", "expected an object");
    const Reader mr = sr.Object("parameters", *moved);
    for (const auto& [name, m] : moved->items()) {
      if (!m.is_object()) return mr.Fail(name, "expected {\"from\": ..., \"to\": ...}");
      const Reader e = mr.Object(name, m);
      SteadyStartResult::Moved mv;
      mv.name = name;
      GB_TRY(e.Number("from", &mv.from));
      GB_TRY(e.Number("to", &mv.to));
      st.fitted.push_back(std::move(mv));
    }
  }
  s->steady_start = std::move(st);
  return Ok{};
}

}  // namespace

Result<EstimateSummary> EstimateSummary::FromJson(const Json& j, const std::string& file) {
  const Reader r(j, file, "");
  if (!j.is_object() || !j.contains("greybench_result"))
    return r.Fail("", "not a greybench result file (no \"greybench_result\")");
  if (j.value("partial", false))
    return r.Fail("partial",
                  "a partial result (a checkpoint of a fit that did not finish) holds "
                  "estimates only");
  EstimateSummary s;
  GB_TRY(r.String("model", &s.model_name, false));
  GB_TRY(r.Strings("datasets", &s.datasets));
  GB_TRY(r.Bool("converged", &s.converged));
  GB_TRY(r.Bool("cancelled", &s.cancelled, false));
  GB_TRY(r.String("message", &s.message, false));
  GB_TRY(r.Number("loglik", &s.loglik));
  if (r.Find("log_posterior")) {
    double lp = 0;
    GB_TRY(r.Number("log_posterior", &lp));
    s.log_posterior = lp;
  }
  GB_TRY(r.Whole("n_obs", &s.n_obs));
  GB_TRY(r.Whole("n_free", &s.n_free));
  GB_TRY(r.Number("aic", &s.aic));
  GB_TRY(r.Number("bic", &s.bic));
  GB_TRY(r.Whole("iterations", &s.iterations, false));
  GB_TRY(r.Whole("evaluations", &s.evaluations, false));
  if (r.Find("elapsed_s")) GB_TRY(r.Number("elapsed_s", &s.elapsed_s));
  GB_TRY(ReadFilter(r, &s));
  if (const Json* starts = r.Find("starts")) {
    if (!starts->is_object()) return r.Fail("starts", "expected an object");
    const Reader st = r.Object("starts", *starts);
    GB_TRY(st.Whole("total", &s.starts, false));
    GB_TRY(st.Whole("at_best", &s.starts_at_best, false));
    GB_TRY(st.Bool("on_bound", &s.starts_for_bound, false));
    GB_TRY(st.Whole("releases", &s.releases, false));
    GB_TRY(st.Whole("released", &s.released_starts, false));
    GB_TRY(st.Whole("relaxed", &s.relaxed_starts, false));
    GB_TRY(st.Bool("relaxed_better", &s.relaxed_better, false));
  }
  GB_TRY(r.Strings("log_scale", &s.log_scale));
  GB_TRY(ReadParameters(r, &s));
  GB_TRY(ReadOptima(r, &s));
  GB_TRY(ReadSteadyStart(r, &s));
  GB_TRY(ReadCorrelation(r, &s));
  GB_TRY(ReadDelays(r, &s));
  GB_TRY(r.Strings("warnings", &s.warnings));
  return s;
}

#undef GB_TRY

}  // namespace gb::estimate
