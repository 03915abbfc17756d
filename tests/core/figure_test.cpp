#include "core/report/figure.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

namespace gb::report {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A figure of a predictions plot: a band, a line with a missing value, markers.
Figure PredictionFigure() {
  Figure f;
  f.title = "y <1> & \"quoted\"";
  f.x_label = "t";
  f.x_unit = "s";
  f.y_label = "temperature";
  f.y_unit = "\u00b0C";
  f.x = {3600.5, 3608.5};
  f.y = {-2.0, 3.0};
  FigureSeries band;
  band.kind = SeriesKind::kBand;
  band.label = "\u00b12 sd";
  FigureSeries line;
  line.label = "predicted";
  line.color = {255, 127, 14, 255};
  FigureSeries markers;
  markers.kind = SeriesKind::kMarkers;
  markers.label = "measured";
  for (int i = 0; i < 12; ++i) {
    const double t = 3599.0 + i;
    const double v = std::sin(0.7 * i) + 1.0 / 3.0;
    band.x.push_back(t);
    band.y.push_back(v - 0.5);
    band.y2.push_back(v + 0.5);
    line.x.push_back(t);
    line.y.push_back(i == 6 ? kNaN : v);
    markers.x.push_back(t);
    markers.y.push_back(v + 0.1);
  }
  f.series = {band, line, markers};
  return f;
}

std::vector<double> Numbers(const std::string& text) {
  std::vector<double> out;
  std::istringstream in(text);
  std::string word;
  while (std::getline(in, word, ' ')) {
    const std::size_t comma = word.find(',');
    out.push_back(std::stod(word.substr(0, comma)));
    out.push_back(std::stod(word.substr(comma + 1)));
  }
  return out;
}

std::string Attribute(const std::string& svg, const std::string& name) {
  std::smatch m;
  EXPECT_TRUE(std::regex_search(svg, m, std::regex(name + "=\"([^\"]*)\""))) << name;
  return m[1];
}

TEST(FigureToSvg, PolylinesReadBackGiveThePlottedValuesAndANaNBreaksTheLine) {
  const Figure f = ClipToXRange(PredictionFigure());
  const std::string svg = FigureToSvg(f, {640, 360});
  // The inverse of the mapping figure.h documents, from the attributes of plot-data.
  std::istringstream area(Attribute(svg, "gb:plot-area")), xr(Attribute(svg, "gb:x-range")),
      yr(Attribute(svg, "gb:y-range"));
  double left = 0, top = 0, right = 0, bottom = 0, x0 = 0, x1 = 0, y0 = 0, y1 = 0;
  area >> left >> top >> right >> bottom;
  xr >> x0 >> x1;
  yr >> y0 >> y1;
  EXPECT_EQ(x0, 3600.5);
  EXPECT_EQ(x1, 3608.5);
  EXPECT_EQ(y0, -2.0);
  EXPECT_EQ(y1, 3.0);
  const auto data_x = [&](double px) { return x0 + (px - left) / (right - left) * (x1 - x0); };
  const auto data_y = [&](double py) { return y0 + (bottom - py) / (bottom - top) * (y1 - y0); };
  constexpr double kTolerance = 1e-13;  // of the spans, 8 and 5

  // The line's polylines: samples 3600..3604 and 3606..3609 (3599 is more than one sample
  // outside the range, 3605 is missing, 3609 is the neighbour that reaches the frame).
  std::vector<std::vector<double>> runs;
  const std::regex polyline("<polyline points=\"([^\"]*)\"");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), polyline);
       it != std::sregex_iterator(); ++it) {
    runs.push_back(Numbers((*it)[1]));
  }
  ASSERT_EQ(runs.size(), 2u);
  const std::vector<int> first = {1, 2, 3, 4, 5}, second = {7, 8, 9, 10};
  ASSERT_EQ(runs[0].size(), 2 * first.size());
  ASSERT_EQ(runs[1].size(), 2 * second.size());
  const auto check = [&](const std::vector<double>& run, const std::vector<int>& samples) {
    for (std::size_t k = 0; k < samples.size(); ++k) {
      const int i = samples[k];
      const double t = 3599.0 + i;
      const double v = std::sin(0.7 * i) + 1.0 / 3.0;
      EXPECT_NEAR(data_x(run[2 * k]), t, kTolerance * 8);
      EXPECT_NEAR(data_y(run[2 * k + 1]), v, kTolerance * 5);
    }
  };
  check(runs[0], first);
  check(runs[1], second);

  // The band: one polygon, upper left to right, then lower right to left.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(svg, m, std::regex("<polygon points=\"([^\"]*)\"")));
  const std::vector<double> band = Numbers(m[1]);
  ASSERT_EQ(band.size(), 2u * 2u * 10u);  // samples 3600..3609, twice
  const double v1 = std::sin(0.7) + 1.0 / 3.0;
  EXPECT_NEAR(data_x(band[0]), 3600.0, kTolerance * 8);
  EXPECT_NEAR(data_y(band[1]), v1 + 0.5, kTolerance * 5);
  EXPECT_NEAR(data_y(band.back()), v1 - 0.5, kTolerance * 5);

  // The title and the unit are escaped and kept.
  EXPECT_NE(svg.find("y &lt;1&gt; &amp; &quot;quoted&quot;"), std::string::npos);
  EXPECT_NE(svg.find("temperature [\u00b0C]"), std::string::npos);
}

TEST(FigureToSvg, IsWellFormedXmlAsXmllintReadsIt) {
  if (access("/usr/bin/xmllint", X_OK) != 0) GTEST_SKIP() << "xmllint is not installed";
  Figure f = PredictionFigure();
  FigureSeries stems;
  stems.kind = SeriesKind::kStems;
  stems.label = "acf";
  stems.x = {3601, 3602};
  stems.y = {0.5, -0.25};
  FigureSeries events;
  events.kind = SeriesKind::kVLines;
  events.label = "alarms";
  events.x = {3603};
  events.tags = {"a<b\x01"};
  FigureSeries bars;
  bars.kind = SeriesKind::kErrorBars;
  bars.label = "bad \xff utf-8";
  bars.x = {3604};
  bars.y = {1};
  bars.y2 = {0.2};
  f.series.push_back(stems);
  f.series.push_back(events);
  f.series.push_back(bars);
  const std::string path =
      (std::filesystem::temp_directory_path() / ("gb_figure_" + std::to_string(getpid()) + ".svg"))
          .string();
  std::ofstream(path) << FigureToSvg(ClipToXRange(f), {400, 300});
  const int status = std::system(("/usr/bin/xmllint --noout '" + path + "' 2>&1").c_str());
  std::filesystem::remove(path);
  EXPECT_EQ(status, 0);
}

TEST(FigureToSvg, EmptyOrInvertedRangesStillGiveADocument) {
  Figure f;
  f.x = {1.0, 1.0};
  f.y = {kNaN, 2.0};
  FigureSeries line;
  line.x = {0.5, 1.0, 2.0};
  line.y = {1e308, -1e308, kNaN};
  f.series = {line};
  FigureSeries short_band;  // y2 missing: left out, not read past its end
  short_band.kind = SeriesKind::kBand;
  short_band.x = {0.1, 0.2};
  short_band.y = {0.0, 0.0};
  f.series.push_back(short_band);
  for (Range x : {Range{1.0, 1.0}, Range{-1e308, 1e308}}) {
    f.x = x;
    const std::string svg = FigureToSvg(f, {10, 10});
    EXPECT_NE(svg.find("width=\"64\""), std::string::npos);
    EXPECT_EQ(svg.find("nan"), std::string::npos);
    EXPECT_EQ(svg.find("inf"), std::string::npos);
  }
}

std::vector<std::vector<std::string>> ParseCsv(const std::string& text) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::string cell;
    bool quoted = false;
    for (std::size_t i = 0; i < line.size(); ++i) {
      const char c = line[i];
      if (quoted) {
        if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
          cell += '"';
          ++i;
        } else if (c == '"') {
          quoted = false;
        } else {
          cell += c;
        }
      } else if (c == '"') {
        quoted = true;
      } else if (c == ',') {
        cells.push_back(cell);
        cell.clear();
      } else {
        cell += c;
      }
    }
    cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

TEST(FigureToCsv, MergesTheXColumnAndRoundTripsTheValuesInsideTheRange) {
  Figure f = PredictionFigure();
  FigureSeries sparse;
  sparse.kind = SeriesKind::kMarkers;
  sparse.label = "a, \"b\"";
  sparse.x = {3600.75, 3602};
  sparse.y = {0.1, 0.2};
  f.series.push_back(sparse);
  const auto rows = ParseCsv(FigureToCsv(ClipToXRange(f)));
  ASSERT_FALSE(rows.empty());
  EXPECT_EQ(rows[0], (std::vector<std::string>{"t [s]", "\u00b12 sd lower", "\u00b12 sd upper",
                                               "predicted", "measured", "a, \"b\""}));
  // x in [3600.5, 3608.5]: 3601..3608 and 3600.75.
  ASSERT_EQ(rows.size(), 1u + 8u + 1u);
  EXPECT_EQ(rows[1][0], "3600.75");
  EXPECT_EQ(rows[1][5], "0.1");
  EXPECT_EQ(rows[1][3], "");  // no sample of "predicted" there
  for (std::size_t r = 2; r < rows.size(); ++r) {
    const int i = static_cast<int>(r);  // t = 3599 + i
    const double v = std::sin(0.7 * i) + 1.0 / 3.0;
    ASSERT_EQ(rows[r].size(), 6u);
    EXPECT_EQ(std::stod(rows[r][0]), 3599.0 + i);
    EXPECT_EQ(std::stod(rows[r][1]), v - 0.5);  // exactly: the shortest round-trip form
    EXPECT_EQ(std::stod(rows[r][2]), v + 0.5);
    if (i == 6) {
      EXPECT_EQ(rows[r][3], "");  // missing
    } else {
      EXPECT_EQ(std::stod(rows[r][3]), v);
    }
    EXPECT_EQ(std::stod(rows[r][4]), v + 0.1);
  }
}

TEST(FigureToCsv, ASampleTwiceAtOneXGetsTwoRows) {
  Figure f;
  f.x = {0, 1};
  FigureSeries band;
  band.kind = SeriesKind::kBand;
  band.label = "bound";
  band.x = {0.5, 0.5};
  band.y = {-1, -2};
  band.y2 = {1, 2};
  f.series = {band};
  EXPECT_EQ(FigureToCsv(f), "x,bound lower,bound upper\n0.5,-1,1\n0.5,-2,2\n");
}

}  // namespace
}  // namespace gb::report
