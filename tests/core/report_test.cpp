#include "core/report/report.h"

#include <cstdio>
#include <string>

#include <gtest/gtest.h>

namespace gb::report {
namespace {

std::string G6(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// A result file's JSON as user guide §5 describes it, written by hand.
Json AResult() {
  Json r;
  r["greybench_result"] = 1;
  r["model"] = "tank <A&B>";
  r["datasets"] = {"run1.csv"};
  r["converged"] = true;
  r["message"] = "converged";
  r["loglik"] = 1527.5756951520316;
  r["n_obs"] = 486;
  r["n_free"] = 2;
  r["aic"] = -3051.151390304063;
  r["bic"] = -3042.8;
  r["parameters"]["tau"] = {{"estimate", 0.079194412345},
                            {"std_error", 0.00111783456},
                            {"t_value", 70.84},
                            {"p_value", 0.0},
                            {"lower", 0.005},
                            {"upper", nullptr},
                            {"fixed", false},
                            {"at_bound", false},
                            {"unit", "s"}};
  r["parameters"]["s2"] = {{"estimate", 1.0677412e-4}, {"std_error", nullptr}, {"t_value", nullptr},
                           {"p_value", nullptr},       {"lower", 0},           {"upper", 1},
                           {"fixed", false},           {"at_bound", true}};
  r["correlation"] = {{"names", {"tau", "s2"}}, {"matrix", {{1.0, -0.5274}, {-0.5274, 1.0}}}};
  r["warnings"] = {"s2 is at its lower bound"};
  return r;
}

TEST(WriteReport, MarkdownAndHtmlHoldTheEstimatesAsTheTextReportPrintsThem) {
  for (ReportFormat format : {ReportFormat::kMarkdown, ReportFormat::kHtml}) {
    gb::Result<std::string> text = WriteReport({AResult(), "fit.json", {}, "no data"}, format);
    ASSERT_TRUE(text.ok());
    for (const std::string& number :
         {G6(0.079194412345), G6(0.00111783456), G6(1.0677412e-4), std::string("1527.575695"),
          std::string("-3051.151"), std::string("-0.527"), std::string("<2e-16")}) {
      const std::string shown =
          format == ReportFormat::kHtml && number[0] == '<' ? "&lt;" + number.substr(1) : number;
      EXPECT_NE(text->find(shown), std::string::npos) << number;
    }
    // The Wald interval, estimate ± 1.96 SE, computed here.
    EXPECT_NE(text->find(G6(0.079194412345 - 1.959963984540054 * 0.00111783456)),
              std::string::npos);
    EXPECT_EQ(text->find("nan"), std::string::npos);
    EXPECT_EQ(text->find("inf"), std::string::npos);
    EXPECT_NE(text->find("AT BOUND"), std::string::npos);
    EXPECT_NE(text->find("no data"), std::string::npos);
  }
}

TEST(WriteReport, HtmlEscapesNamesAndMarkdownKeepsTablesWhole) {
  Json r = AResult();
  r["parameters"]["a|b"] = r["parameters"]["tau"];
  gb::Result<std::string> html = WriteReport({r, "", {}, ""}, ReportFormat::kHtml);
  ASSERT_TRUE(html.ok());
  EXPECT_NE(html->find("tank &lt;A&amp;B&gt;"), std::string::npos);
  EXPECT_EQ(html->find("<A&B>"), std::string::npos);
  gb::Result<std::string> md = WriteReport({r, "", {}, ""}, ReportFormat::kMarkdown);
  ASSERT_TRUE(md.ok());
  EXPECT_NE(md->find("a\\|b"), std::string::npos);
}

TEST(WriteReport, NothingNonFiniteIsPrintedEvenWhereTheIntervalOverflows) {
  Json r = AResult();
  r["parameters"]["big"] = {{"estimate", 1e308}, {"std_error", 1e308}, {"t_value", 1.0},
                            {"p_value", 0.3},    {"lower", nullptr},   {"upper", nullptr},
                            {"fixed", false},    {"at_bound", false}};
  r["correlation"]["matrix"][0][0] = "x";  // not a number: shown as missing
  for (ReportFormat format : {ReportFormat::kMarkdown, ReportFormat::kHtml}) {
    gb::Result<std::string> text = WriteReport({r, "", {}, ""}, format);
    ASSERT_TRUE(text.ok());
    EXPECT_EQ(text->find("inf"), std::string::npos);
    EXPECT_EQ(text->find("nan"), std::string::npos);
    EXPECT_NE(text->find("1e+308"), std::string::npos);
  }
}

TEST(WriteReport, AFileThatIsNotAResultIsRefusedWithItsNameAndPath) {
  Json model;
  model["states"] = Json::array();
  gb::Result<std::string> text =
      WriteReport({model, "model.json", {}, ""}, ReportFormat::kMarkdown);
  ASSERT_FALSE(text.ok());
  EXPECT_EQ(text.error().ToString(),
            "model.json: greybench_result: not a greybench result file (no \"greybench_result\")");
  Json no_parameters;
  no_parameters["greybench_result"] = 1;
  text = WriteReport({no_parameters, "r.json", {}, ""}, ReportFormat::kHtml);
  ASSERT_FALSE(text.ok());
  EXPECT_EQ(text.error().path, "parameters");
}

TEST(ParseReportFormat, KnowsMarkdownAndHtmlInAnyCase) {
  EXPECT_EQ(ParseReportFormat("MD"), ReportFormat::kMarkdown);
  EXPECT_EQ(ParseReportFormat("html"), ReportFormat::kHtml);
  EXPECT_EQ(ParseReportFormat("Htm"), ReportFormat::kHtml);
  EXPECT_FALSE(ParseReportFormat("pdf").has_value());
  EXPECT_FALSE(ParseReportFormat("").has_value());
}

}  // namespace
}  // namespace gb::report
