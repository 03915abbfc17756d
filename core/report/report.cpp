// Sections
//   1. A document as blocks (headings, paragraphs, tables, figures), written as Markdown or HTML
//   2. The result file's facts as blocks
//   3. The residual analysis as blocks
//   4. The figures
#include "core/report/report.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>
#include <variant>

#include <fmt/format.h>

namespace gb::report {
namespace {

constexpr const char* kMissing = "\u2013";    // "–": a value the result does not have
constexpr double kWaldZ = 1.959963984540054;  // the 95 % two-sided normal quantile

// ---------------------------------------------------------------------------------------------
// 1. Blocks

struct Heading {
  int level = 1;
  std::string text;
};
struct Paragraph {
  std::string text;
};
struct Bullets {
  std::vector<std::string> items;
};
struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::vector<bool> numeric;  // per column: right-aligned
};
struct SvgFigure {
  std::string caption;
  std::string svg;  // a standalone document; its XML declaration is dropped inline
};
using Block = std::variant<Heading, Paragraph, Bullets, Table, SvgFigure>;

std::string MdEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    // Only what would change the meaning in running text or a table cell.
    if (c == '|' || c == '*' || c == '\\' || c == '`' || c == '<') out += '\\';
    out += c == '\n' ? ' ' : c;
  }
  return out;
}

std::string ToMarkdown(const std::vector<Block>& blocks) {
  std::string out;
  for (const Block& b : blocks) {
    if (const auto* h = std::get_if<Heading>(&b)) {
      out +=
          std::string(static_cast<std::size_t>(h->level), '#') + " " + MdEscape(h->text) + "\n\n";
    } else if (const auto* p = std::get_if<Paragraph>(&b)) {
      out += MdEscape(p->text) + "\n\n";
    } else if (const auto* l = std::get_if<Bullets>(&b)) {
      for (const std::string& item : l->items) out += "- " + MdEscape(item) + "\n";
      out += "\n";
    } else if (const auto* t = std::get_if<Table>(&b)) {
      std::string head = "|", rule = "|";
      for (std::size_t c = 0; c < t->header.size(); ++c) {
        head += " " + MdEscape(t->header[c]) + " |";
        rule += t->numeric[c] ? " ---: |" : " --- |";
      }
      out += head + "\n" + rule + "\n";
      for (const auto& row : t->rows) {
        std::string line = "|";
        for (const std::string& cell : row) line += " " + MdEscape(cell) + " |";
        out += line + "\n";
      }
      out += "\n";
    } else if (const auto* f = std::get_if<SvgFigure>(&b)) {
      // Markdown holds no figure; it says where the figure is.
      out += "*Figure: " + MdEscape(f->caption) + " (in the HTML report)*\n\n";
    }
  }
  return out;
}

constexpr const char* kStyle = R"(body{font-family:"DejaVu Sans",Helvetica,Arial,sans-serif;
max-width:1000px;margin:24px auto;padding:0 16px;color:#1e2228;font-size:14px}
h1{font-size:22px}h2{font-size:18px;margin-top:28px;border-bottom:1px solid #d8dbe0}
h3{font-size:15px}table{border-collapse:collapse;margin:8px 0 16px}
th,td{border:1px solid #d8dbe0;padding:3px 8px}th{background:#f2f3f5;text-align:left}
td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
figure{margin:12px 0}figcaption{color:#585e68;font-size:13px}
)";

std::string ToHtml(const std::vector<Block>& blocks, const std::string& title) {
  std::string out =
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>" +
      XmlEscape(title) + "</title>\n<style>\n" + kStyle + "</style>\n</head>\n<body>\n";
  for (const Block& b : blocks) {
    if (const auto* h = std::get_if<Heading>(&b)) {
      out += fmt::format("<h{0}>{1}</h{0}>\n", h->level, XmlEscape(h->text));
    } else if (const auto* p = std::get_if<Paragraph>(&b)) {
      out += "<p>" + XmlEscape(p->text) + "</p>\n";
    } else if (const auto* l = std::get_if<Bullets>(&b)) {
      out += "<ul>\n";
      for (const std::string& item : l->items) out += "<li>" + XmlEscape(item) + "</li>\n";
      out += "</ul>\n";
    } else if (const auto* t = std::get_if<Table>(&b)) {
      out += "<table>\n<tr>";
      for (const std::string& h : t->header) out += "<th>" + XmlEscape(h) + "</th>";
      out += "</tr>\n";
      for (const auto& row : t->rows) {
        out += "<tr>";
        for (std::size_t c = 0; c < row.size(); ++c)
          out += (t->numeric[c] ? "<td class=\"num\">" : "<td>") + XmlEscape(row[c]) + "</td>";
        out += "</tr>\n";
      }
      out += "</table>\n";
    } else if (const auto* f = std::get_if<SvgFigure>(&b)) {
      std::string svg = f->svg;
      if (svg.rfind("<?xml", 0) == 0) svg.erase(0, svg.find('\n') + 1);
      out += "<figure>\n" + svg + "<figcaption>" + XmlEscape(f->caption) +
             "</figcaption>\n</figure>\n";
    }
  }
  return out + "</body>\n</html>\n";
}

// ---------------------------------------------------------------------------------------------
// 2. The result's facts

std::string Num(double v) { return fmt::format("{:.6g}", v); }

std::string PValue(double p) {
  if (p < 2.2e-16) return "<2e-16";
  return fmt::format("{:.3g}", p);
}

// A finite number at j[key], or nothing (absent, null, not a number).
std::optional<double> Number(const Json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return std::nullopt;
  const double v = j[key].get<double>();
  return std::isfinite(v) ? std::optional<double>(v) : std::nullopt;
}

std::string Text(const Json& j, const char* key) {
  return j.is_object() && j.contains(key) && j[key].is_string() ? j[key].get<std::string>() : "";
}

bool Flag(const Json& j, const char* key) {
  return j.is_object() && j.contains(key) && j[key].is_boolean() && j[key].get<bool>();
}

std::string Cell(const std::optional<double>& v, std::string (*format)(double) = Num) {
  return v ? format(*v) : kMissing;
}

std::string T3(double v) { return fmt::format("{:.3g}", v); }
std::string F6(double v) { return fmt::format("{:.6f}", v); }
std::string F3(double v) { return fmt::format("{:.3f}", v); }

void Summary(const Json& r, std::vector<Block>* out) {
  std::vector<std::string> facts;
  std::string data;
  if (r.contains("datasets") && r["datasets"].is_array()) {
    for (const Json& d : r["datasets"])
      if (d.is_string()) data += (data.empty() ? "" : ", ") + d.get<std::string>();
  }
  if (!data.empty()) {
    const std::optional<double> n = Number(r, "n_obs");
    facts.push_back("Data: " + data + (n ? fmt::format(" ({:.0f} observations)", *n) : ""));
  }
  if (Flag(r, "partial")) {
    facts.push_back("A checkpoint of a fit still running or stopped (\"partial\"), not its end.");
  } else if (r.contains("converged")) {
    facts.push_back(std::string(Flag(r, "converged") ? "Converged" : "NOT converged") + ": " +
                    Text(r, "message"));
  }
  const std::optional<double> it = Number(r, "iterations"), ev = Number(r, "evaluations");
  if (it && ev)
    facts.push_back(fmt::format("{:.0f} iterations, {:.0f} log-likelihood evaluations", *it, *ev));
  if (r.contains("filter") && r["filter"].is_object()) {
    const Json& f = r["filter"];
    facts.push_back(Text(f, "kind") == "ekf"
                        ? "Filter: extended Kalman filter (nonlinear model), ODE " + Text(f, "ode")
                        : "Filter: Kalman filter, exact discretisation (the model is linear)");
  }
  if (!facts.empty()) out->push_back(Bullets{facts});

  Table fit{{"Log-likelihood", "AIC", "BIC", "free parameters", "observations"}, {}, {}};
  fit.numeric.assign(5, true);
  fit.rows.push_back({Cell(Number(r, "loglik"), F6), Cell(Number(r, "aic"), F3),
                      Cell(Number(r, "bic"), F3),
                      Cell(Number(r, "n_free"), [](double v) { return fmt::format("{:.0f}", v); }),
                      Cell(Number(r, "n_obs"), [](double v) { return fmt::format("{:.0f}", v); })});
  out->push_back(Heading{2, "Fit"});
  out->push_back(std::move(fit));
  if (const std::optional<double> lp = Number(r, "log_posterior"))
    out->push_back(Paragraph{"MAP estimate (priors on some parameters): log posterior " + F6(*lp)});
}

void Estimates(const Json& params, std::vector<Block>* out) {
  bool any_profile = false;
  double level = 0.95;
  for (const auto& [name, p] : params.items()) {
    if (p.is_object() && p.contains("profile_interval") && p["profile_interval"].is_object()) {
      any_profile = true;
      level = Number(p["profile_interval"], "level").value_or(level);
    }
  }
  Table t;
  t.header = {"Parameter", "Estimate", "Std. error", "t value", "Pr(>|t|)", "95 % Wald interval"};
  if (any_profile) t.header.push_back(fmt::format("{:.0f} % profile interval", 100 * level));
  t.header.push_back("Bounds");
  t.numeric = {false, true, true, true, true, true};
  if (any_profile) t.numeric.push_back(true);
  t.numeric.push_back(false);
  for (const auto& [name, p] : params.items()) {
    if (!p.is_object()) continue;
    const bool fixed = Flag(p, "fixed");
    const std::optional<double> est = Number(p, "estimate"), se = Number(p, "std_error");
    std::string label = name;
    if (const std::string unit = Text(p, "unit"); !unit.empty()) label += " [" + unit + "]";
    std::string wald = kMissing;
    if (est && se && !fixed) {
      const double lo = *est - kWaldZ * *se, hi = *est + kWaldZ * *se;
      if (std::isfinite(lo) && std::isfinite(hi)) wald = "[" + Num(lo) + ", " + Num(hi) + "]";
    }
    std::vector<std::string> row = {label,
                                    Cell(est),
                                    fixed ? "" : Cell(se),
                                    fixed ? "" : Cell(Number(p, "t_value"), T3),
                                    fixed ? "" : Cell(Number(p, "p_value"), PValue),
                                    fixed ? "" : wald};
    if (any_profile) {
      std::string profile;
      if (p.contains("profile_interval") && p["profile_interval"].is_object()) {
        const Json& pi = p["profile_interval"];
        const Json side = p.contains("profile") ? p["profile"] : Json::object();
        const auto end = [&](const char* key, const char* at_bound) {
          if (const auto v = Number(pi, key)) return Num(*v);
          return std::string(Flag(side, at_bound) ? "(bound)" : "(none)");
        };
        profile =
            "[" + end("lower", "lower_at_bound") + ", " + end("upper", "upper_at_bound") + "]";
      }
      row.push_back(profile);
    }
    std::string bounds = "fixed";
    if (!fixed) {
      const std::optional<double> lo = Number(p, "lower"), hi = Number(p, "upper");
      bounds = (lo ? "[" + Num(*lo) : std::string("(\u2212\u221e")) + ", " +
               (hi ? Num(*hi) + "]" : std::string("\u221e)"));
      if (Flag(p, "at_bound")) bounds += " AT BOUND";
    }
    row.push_back(bounds);
    t.rows.push_back(std::move(row));
  }
  out->push_back(Heading{2, "Estimates"});
  out->push_back(std::move(t));
  out->push_back(Paragraph{
      "p-values: two-sided, Student's t with n_obs - n_free degrees of freedom. Wald interval: "
      "estimate \u00b1 1.96 SE." +
      std::string(any_profile ? " Profile interval: likelihood ratio; (bound): the profile stays "
                                "within the threshold up to the parameter's bound."
                              : "")});
}

void Delays(const Json& r, std::vector<Block>* out) {
  if (!r.contains("output_delay") || !r["output_delay"].is_object()) return;
  Table t{{"Output", "Delay [samples]", "How"}, {}, {false, true, false}};
  for (const auto& [output, d] : r["output_delay"].items()) {
    const std::optional<double> est = d.is_object()   ? Number(d, "estimate")
                                      : d.is_number() ? std::optional<double>(d.get<double>())
                                                      : std::nullopt;
    if (!est) continue;
    const bool scanned = Flag(d, "scanned");
    if (!scanned && *est == 0) continue;
    t.rows.push_back({output, fmt::format("{:.0f}", *est),
                      scanned ? "estimated by profile likelihood" : "fixed"});
  }
  if (t.rows.empty()) return;
  out->push_back(Heading{2, "Output delays"});
  out->push_back(std::move(t));
}

void Correlation(const Json& r, std::vector<Block>* out) {
  if (!r.contains("correlation") || !r["correlation"].is_object()) return;
  const Json& c = r["correlation"];
  if (!c.contains("names") || !c["names"].is_array() || !c.contains("matrix") ||
      !c["matrix"].is_array())
    return;
  std::vector<std::string> names;
  for (const Json& n : c["names"]) names.push_back(n.is_string() ? n.get<std::string>() : "?");
  if (names.empty() || c["matrix"].size() != names.size()) return;
  Table t;
  t.header.push_back("");
  t.numeric.push_back(false);
  for (const std::string& n : names) {
    t.header.push_back(n);
    t.numeric.push_back(true);
  }
  for (std::size_t a = 0; a < names.size(); ++a) {
    const Json& row = c["matrix"][a];
    std::vector<std::string> cells = {names[a]};
    for (std::size_t b = 0; b < names.size(); ++b) {
      const bool shown = b <= a && row.is_array() && b < row.size() && row[b].is_number() &&
                         std::isfinite(row[b].get<double>());
      cells.push_back(b > a ? "" : shown ? F3(row[b].get<double>()) : kMissing);
    }
    t.rows.push_back(std::move(cells));
  }
  out->push_back(Heading{2, "Correlation of the estimates"});
  out->push_back(std::move(t));
}

void Warnings(const Json& r, std::vector<Block>* out) {
  if (!r.contains("warnings") || !r["warnings"].is_array() || r["warnings"].empty()) return;
  Bullets list;
  for (const Json& w : r["warnings"])
    if (w.is_string()) list.items.push_back(w.get<std::string>());
  out->push_back(Heading{2, "Warnings"});
  out->push_back(std::move(list));
}

// ---------------------------------------------------------------------------------------------
// 3. Residuals

std::string G4(double v) { return std::isfinite(v) ? fmt::format("{:.4g}", v) : kMissing; }

void Residuals(const ReportInput& in, std::vector<Block>* out) {
  out->push_back(Heading{2, "Residual analysis"});
  if (in.residuals.empty()) {
    out->push_back(Paragraph{in.residuals_note.empty() ? "Not computed." : in.residuals_note});
    return;
  }
  out->push_back(Paragraph{
      "Standardised one-step residuals z = (y - \u0177) / sd at the estimates; white noise if "
      "the model is right. Every band and test at the 5 % level."});
  for (const ResidualSection& s : in.residuals) {
    const diagnose::ResidualDiagnostics& d = s.diagnostics;
    out->push_back(Heading{3, s.output + " (" + s.dataset + ")"});
    Table t{{"Test", "Statistic", "Reference", "p-value", "Result"}, {}, {}};
    t.numeric = {false, true, true, true, false};
    t.rows.push_back(
        {fmt::format("Ljung-Box, {} lags", d.ljung_box.lags), G4(d.ljung_box.statistic),
         fmt::format("\u03c7\u00b2 with {} df", d.ljung_box.df), PValue(d.ljung_box.p_value),
         d.ljung_box.p_value >= 0.05 ? "white" : "correlated"});
    t.rows.push_back({"Cumulated periodogram, largest deviation", G4(d.periodogram.max_deviation),
                      "band " + G4(d.periodogram.band), "",
                      d.periodogram.inside ? "inside the band" : "leaves the band"});
    t.rows.push_back({"Jarque-Bera (normality)", G4(d.normality.jarque_bera),
                      "\u03c7\u00b2 with 2 df", PValue(d.normality.p_value),
                      d.normality.p_value >= 0.05 ? "normal" : "not normal"});
    t.rows.push_back(
        {"Mean, sd of z", G4(d.normality.mean) + ", " + G4(d.normality.sd), "0, 1", "", ""});
    t.rows.push_back({"Skewness, excess kurtosis",
                      G4(d.normality.skewness) + ", " + G4(d.normality.excess_kurtosis), "0, 0", "",
                      ""});
    out->push_back(std::move(t));
    out->push_back(Paragraph{"Verdict: " + d.verdict});
    out->push_back(SvgFigure{"One-step predictions of " + s.output + " with \u00b1 2 SD",
                             FigureToSvg(s.predictions, {900, 320})});
    out->push_back(SvgFigure{"Autocorrelation of z for " + s.output + " with its 95 % band",
                             FigureToSvg(s.acf, {900, 260})});
  }
}

Error ReportError(const std::string& file, const std::string& path, const std::string& message) {
  Error e = InputError(message);
  e.file = file;
  e.path = path;
  return e;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Public

std::optional<ReportFormat> ParseReportFormat(const std::string& name) {
  std::string lower;
  for (char c : name) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (lower == "md" || lower == "markdown") return ReportFormat::kMarkdown;
  if (lower == "html" || lower == "htm") return ReportFormat::kHtml;
  return std::nullopt;
}

Status CheckResultJson(const Json& r, const std::string& file) {
  if (!r.is_object() || !r.contains("greybench_result"))
    return ReportError(file, "greybench_result",
                       "not a greybench result file (no \"greybench_result\")");
  if (!r.contains("parameters") || !r["parameters"].is_object())
    return ReportError(file, "parameters", "the result has no \"parameters\" object");
  return Ok{};
}

Result<std::string> WriteReport(const ReportInput& in, ReportFormat format) {
  const Json& r = in.result;
  if (Status st = CheckResultJson(r, in.result_file); !st) return st.error();
  const std::string model = Text(r, "model");
  const std::string title = "Estimation report: " + (model.empty() ? "(unnamed model)" : model);
  std::vector<Block> blocks;
  blocks.push_back(Heading{1, title});
  if (!in.result_file.empty()) blocks.push_back(Paragraph{"Result file: " + in.result_file});
  Summary(r, &blocks);
  Estimates(r["parameters"], &blocks);
  Delays(r, &blocks);
  Correlation(r, &blocks);
  Warnings(r, &blocks);
  Residuals(in, &blocks);
  return format == ReportFormat::kHtml ? ToHtml(blocks, title) : ToMarkdown(blocks);
}

// ---------------------------------------------------------------------------------------------
// 4. Figures

Figure PredictionFigure(const std::string& output, const std::string& time_unit,
                        const std::vector<double>& t, const std::vector<double>& y,
                        const std::vector<double>& y_pred, const std::vector<double>& lower,
                        const std::vector<double>& upper) {
  Figure f;
  f.title = output + ": one-step predictions";
  f.x_label = "t";
  f.x_unit = time_unit;
  f.y_label = output;
  const std::size_t n = t.size();
  FigureSeries band, line, measured;
  band.kind = SeriesKind::kBand;
  band.label = "\u00b1 2 sd";
  band.color = {31, 119, 180, 255};
  line.label = "one-step prediction";
  line.color = {31, 119, 180, 255};
  measured.kind = SeriesKind::kMarkers;
  measured.label = "measured";
  measured.color = {60, 64, 72, 255};
  measured.marker_radius = 1.5f;
  band.x = line.x = measured.x = t;
  measured.y = y;
  line.y = y_pred;
  band.y = lower;
  band.y2 = upper;
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t i = 0; i < n; ++i) {
    for (double v : {y[i], band.y[i], band.y2[i], y_pred[i]}) {
      if (!std::isfinite(v)) continue;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  f.x = n > 0 ? Range{t.front(), t.back()} : Range{0, 1};
  const double pad = hi > lo ? 0.05 * (hi - lo) : 0.5;
  f.y = hi >= lo ? Range{lo - pad, hi + pad} : Range{0, 1};
  f.series = {band, line, measured};
  return f;
}

Figure AcfFigure(const std::string& output, const diagnose::Correlogram& acf) {
  Figure f;
  f.title = "Autocorrelation of z (" + output + ")";
  f.x_label = "lag";
  f.x_unit = "samples";
  f.legend = false;
  FigureSeries band, stems;
  band.kind = SeriesKind::kBand;
  band.label = "95 % band";
  band.color = {127, 127, 127, 255};
  const double last = acf.lag.empty() ? 1.0 : acf.lag.back();
  band.x = {0.0, last + 1.0};
  band.y = {-acf.band, -acf.band};
  band.y2 = {acf.band, acf.band};
  stems.kind = SeriesKind::kStems;
  stems.label = "ACF";
  stems.color = {31, 119, 180, 255};
  double lo = -acf.band, hi = acf.band;
  for (std::size_t k = 0; k < acf.lag.size() && k < acf.value.size(); ++k) {
    stems.x.push_back(acf.lag[k]);
    stems.y.push_back(acf.value[k]);
    if (std::isfinite(acf.value[k])) {
      lo = std::min(lo, acf.value[k]);
      hi = std::max(hi, acf.value[k]);
    }
  }
  f.x = {0.0, last + 1.0};
  const double pad = hi > lo ? 0.08 * (hi - lo) : 0.1;
  f.y = {std::min(lo, 0.0) - pad, std::max(hi, 0.0) + pad};
  f.series = {band, stems};
  return f;
}

}  // namespace gb::report
