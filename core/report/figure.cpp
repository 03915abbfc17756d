// Sections
//   1. Text: escaping, numbers, colours
//   2. Clipping to the x range
//   3. SVG: layout, axes, series, legend
//   4. CSV
#include "core/report/figure.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <utility>

#include <fmt/format.h>

namespace gb::report {
namespace {

// Text metrics of the SVG (font-size 12 in a sans-serif face): an average glyph is about 0.6 em
// wide. Layout only: a label a little wider or narrower than estimated still fits its margin.
constexpr double kFontSize = 12.0;
constexpr double kTitleFontSize = 14.0;
constexpr double kCharWidth = 0.6 * kFontSize;
constexpr double kTickLength = 4.0;
constexpr double kPad = 6.0;
constexpr int kMinSvgSize = 64;
// Pixels further than this outside the plot area are written at this distance (the clip path
// hides them; doubles far beyond it would lose the shape of the segments that leave the view).
constexpr double kPixelLimit = 1e6;
// Pixels per tick label along each axis, as the plot widget spaces them.
constexpr double kXPixelsPerTick = 90.0;
constexpr double kYPixelsPerTick = 36.0;

// ---------------------------------------------------------------------------------------------
// 1. Text

// Bytes that are not well-formed UTF-8 become '?': an XML document cannot hold them.
std::string ValidUtf8(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    int len = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 0;
    bool ok = len > 0 && i + len <= s.size();
    for (int k = 1; ok && k < len; ++k) ok = (static_cast<unsigned char>(s[i + k]) >> 6) == 0x2;
    if (!ok) {
      out += '?';
      ++i;
      continue;
    }
    out.append(s, i, static_cast<std::size_t>(len));
    i += static_cast<std::size_t>(len);
  }
  return out;
}

std::string Hex(Rgba c) { return fmt::format("#{:02x}{:02x}{:02x}", c.r, c.g, c.b); }

std::string Px(double v) { return fmt::format("{:.2f}", v); }

std::string AxisTitle(const std::string& label, const std::string& unit) {
  std::string s = label;
  if (!unit.empty()) s += (s.empty() ? "" : " ") + std::string("[") + unit + "]";
  return s;
}

Range Usable(Range r) {
  if (!std::isfinite(r.Span()) || !(r.max > r.min)) return {0.0, 1.0};
  return r;
}

std::string SeriesName(const FigureSeries& s, std::size_t index) {
  return s.label.empty() ? "series " + std::to_string(index + 1) : s.label;
}

const char* KindName(SeriesKind k) {
  switch (k) {
    case SeriesKind::kLine:
      return "line";
    case SeriesKind::kBand:
      return "band";
    case SeriesKind::kMarkers:
      return "markers";
    case SeriesKind::kStems:
      return "stems";
    case SeriesKind::kErrorBars:
      return "error-bars";
    case SeriesKind::kVLines:
      return "vertical-lines";
  }
  return "line";
}

// ---------------------------------------------------------------------------------------------
// 3. SVG

// Pixel geometry of the plot area and the mapping of data into it.
struct Frame {
  double left = 0, top = 0, right = 0, bottom = 0;
  Range x, y;
  double XToPixel(double v) const { return left + (v - x.min) / x.Span() * (right - left); }
  double YToPixel(double v) const { return bottom - (v - y.min) / y.Span() * (bottom - top); }
};

double TextWidth(const std::string& s) {
  // UTF-8 continuation bytes take no width of their own.
  double n = 0;
  for (char c : s) n += (static_cast<unsigned char>(c) >> 6) == 0x2 ? 0.0 : 1.0;
  return n * kCharWidth;
}

// Appends to an SVG document being built.
class SvgWriter {
 public:
  std::string out;

  template <class... Args>
  void Put(fmt::format_string<Args...> f, Args&&... args) {
    fmt::format_to(std::back_inserter(out), f, std::forward<Args>(args)...);
  }
  void Text(double x, double y, const std::string& text, const char* anchor, const char* fill,
            double size = kFontSize, const char* extra = "") {
    Put("<text x=\"{}\" y=\"{}\" text-anchor=\"{}\" fill=\"{}\" font-size=\"{}\"{}>{}</text>\n",
        Px(x), Px(y), anchor, fill, size, extra, XmlEscape(text));
  }
};

// Data to pixels, written in the shortest form that reads back as the same double, so the
// inverse mapping (figure.h) gives the values back.
struct Mapper {
  const Frame& fr;
  static double Clamp(double p, double lo, double hi) {
    return std::clamp(p, lo - kPixelLimit, hi + kPixelLimit);
  }
  std::string X(double x) const { return ShortestDouble(Clamp(fr.XToPixel(x), fr.left, fr.right)); }
  std::string Y(double y) const { return ShortestDouble(Clamp(fr.YToPixel(y), fr.top, fr.bottom)); }
  std::string Point(double x, double y) const { return X(x) + "," + Y(y); }
};

void WriteDots(SvgWriter& w, const FigureSeries& s, const Mapper& o, const std::string& stroke) {
  std::string d;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
    d += "M" + o.Point(s.x[i], s.y[i]) + "h0";
  }
  if (d.empty()) return;
  w.Put(
      "<path class=\"dots\" d=\"{}\" fill=\"none\" {} stroke-width=\"{}\" "
      "stroke-linecap=\"round\"/>\n",
      d, stroke, Px(2.0 * s.marker_radius));
}

void WriteSeries(SvgWriter& w, const FigureSeries& s, std::size_t index, const Frame& fr,
                 const Mapper& o) {
  const std::string colour = Hex(s.color);
  const double alpha = s.color.a / 255.0;
  const std::string stroke =
      fmt::format("stroke=\"{}\"{}", colour,
                  s.color.a < 255 ? fmt::format(" stroke-opacity=\"{:.3f}\"", alpha) : "");
  const auto finite = [&](std::size_t i) {
    if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) return false;
    return s.kind != SeriesKind::kBand || std::isfinite(s.y2[i]);
  };
  // Arrays of another length than x (a figure built by hand) leave the series out.
  const bool needs_y = s.kind != SeriesKind::kVLines;
  const bool needs_y2 = s.kind == SeriesKind::kBand || s.kind == SeriesKind::kErrorBars;
  if ((needs_y && s.y.size() != s.x.size()) || (needs_y2 && s.y2.size() != s.x.size())) return;
  w.Put("<g class=\"series {}\" id=\"series-{}\">\n<title>{}</title>\n", KindName(s.kind),
        index + 1, XmlEscape(SeriesName(s, index)));
  const std::size_t n = s.x.size();
  switch (s.kind) {
    case SeriesKind::kLine:
      for (std::size_t i = 0; i < n;) {
        if (!finite(i)) {
          ++i;
          continue;
        }
        std::string points;
        for (; i < n && finite(i); ++i) {
          if (!points.empty()) points += ' ';
          points += o.Point(s.x[i], s.y[i]);
        }
        w.Put(
            "<polyline points=\"{}\" fill=\"none\" {} stroke-width=\"{}\" "
            "stroke-linejoin=\"round\"/>\n",
            points, stroke, Px(s.line_weight));
      }
      break;
    case SeriesKind::kBand:
      for (std::size_t i = 0; i < n;) {
        if (!finite(i)) {
          ++i;
          continue;
        }
        const std::size_t begin = i;
        while (i < n && finite(i)) ++i;
        std::string points;
        for (std::size_t k = begin; k < i; ++k) points += o.Point(s.x[k], s.y2[k]) + " ";
        for (std::size_t k = i; k-- > begin;) {
          points += o.Point(s.x[k], s.y[k]);
          if (k > begin) points += ' ';
        }
        w.Put("<polygon points=\"{}\" fill=\"{}\" fill-opacity=\"{:.3f}\" stroke=\"none\"/>\n",
              points, colour, s.fill_alpha * alpha);
      }
      break;
    case SeriesKind::kMarkers:
      WriteDots(w, s, o, stroke);
      break;
    case SeriesKind::kStems:
    case SeriesKind::kErrorBars: {
      std::string d;
      for (std::size_t i = 0; i < n; ++i) {
        if (!finite(i)) continue;
        if (s.kind == SeriesKind::kStems) {
          d += "M" + o.Point(s.x[i], s.ref) + "V" + o.Y(s.y[i]);
        } else if (std::isfinite(s.y2[i])) {
          d += "M" + o.Point(s.x[i], s.y[i] - s.y2[i]) + "V" + o.Y(s.y[i] + s.y2[i]);
        }
      }
      if (!d.empty()) {
        w.Put(
            "<path d=\"{}\" fill=\"none\" {} stroke-width=\"{}\" "
            "/>\n",
            d, stroke, Px(s.line_weight));
      }
      WriteDots(w, s, o, stroke);
      break;
    }
    case SeriesKind::kVLines: {
      std::string d;
      for (std::size_t i = 0; i < n; ++i) {
        if (!std::isfinite(s.x[i])) continue;
        d += "M" + o.Point(s.x[i], fr.y.min) + "V" + o.Y(fr.y.max);
      }
      if (!d.empty()) {
        w.Put(
            "<path d=\"{}\" fill=\"none\" {} stroke-width=\"{}\" stroke-dasharray=\"4 3\" "
            "/>\n",
            d, stroke, Px(s.line_weight));
      }
      break;
    }
  }
  w.Put("</g>\n");
}

// Vertical lines' tags, in pixels beside the top of each line (inside the clipped area).
void WriteTags(SvgWriter& w, const FigureSeries& s, const Frame& fr) {
  const std::string colour = Hex(s.color);
  for (std::size_t i = 0; i < s.x.size() && i < s.tags.size(); ++i) {
    if (!std::isfinite(s.x[i]) || s.tags[i].empty()) continue;
    w.Text(fr.XToPixel(s.x[i]) + 3.0, fr.top + kFontSize + 2.0, s.tags[i], "start", colour.c_str());
  }
}

void WriteLegend(SvgWriter& w, const Figure& f, const Frame& fr) {
  std::vector<std::size_t> entries;
  double text_w = 0;
  for (std::size_t i = 0; i < f.series.size(); ++i) {
    if (f.series[i].label.empty()) continue;
    entries.push_back(i);
    text_w = std::max(text_w, TextWidth(f.series[i].label));
  }
  if (!f.legend || entries.empty()) return;
  const double row = kFontSize + 5.0, swatch = 20.0;
  const double width = swatch + text_w + 3.0 * kPad;
  const double height = row * static_cast<double>(entries.size()) + kPad;
  const double x = fr.right - kPad - width, y = fr.top + kPad;
  w.Put("<g class=\"legend\">\n");
  w.Put(
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" rx=\"3\" fill=\"#ffffff\" "
      "fill-opacity=\"0.88\" stroke=\"#c4c8ce\"/>\n",
      Px(x), Px(y), Px(width), Px(height));
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const FigureSeries& s = f.series[entries[k]];
    const double cy = y + kPad / 2 + row * (static_cast<double>(k) + 0.5);
    const double sx = x + kPad;
    const std::string colour = Hex(s.color);
    switch (s.kind) {
      case SeriesKind::kBand:
        w.Put(
            "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\" "
            "fill-opacity=\"{:.3f}\"/>\n",
            Px(sx), Px(cy - 4), Px(swatch), Px(8.0), colour, std::max(0.35f, s.fill_alpha));
        break;
      case SeriesKind::kMarkers:
        w.Put("<circle cx=\"{}\" cy=\"{}\" r=\"{}\" fill=\"{}\"/>\n", Px(sx + swatch / 2), Px(cy),
              Px(s.marker_radius), colour);
        break;
      default:
        w.Put("<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{}\" stroke-width=\"{}\"/>\n",
              Px(sx), Px(cy), Px(sx + swatch), Px(cy), colour, Px(s.line_weight));
        break;
    }
    w.Text(sx + swatch + kPad, cy + 0.35 * kFontSize, s.label, "start", "#1e2228");
  }
  w.Put("</g>\n");
}

void WriteGrid(SvgWriter& w, const Frame& fr, const Ticks& xt, const Ticks& yt) {
  w.Put("<g class=\"grid\" stroke=\"#e8eaee\" stroke-width=\"1\">\n");
  for (double v : xt.values) {
    const double px = fr.XToPixel(v);
    w.Put("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\"/>\n", Px(px), Px(fr.top),
          Px(fr.bottom));
  }
  for (double v : yt.values) {
    const double py = fr.YToPixel(v);
    w.Put("<line x1=\"{1}\" y1=\"{0}\" x2=\"{2}\" y2=\"{0}\"/>\n", Px(py), Px(fr.left),
          Px(fr.right));
  }
  w.Put("</g>\n");
}

void WriteTicksAndTitles(SvgWriter& w, const Figure& f, const Frame& fr, const Ticks& xt,
                         const Ticks& yt, SvgSize size) {
  const char* tick_text = "#585e68";
  w.Put(
      "<rect class=\"frame\" x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" "
      "stroke=\"#c4c8ce\"/>\n",
      Px(fr.left), Px(fr.top), Px(fr.right - fr.left), Px(fr.bottom - fr.top));
  w.Put("<g class=\"ticks\" stroke=\"#c4c8ce\">\n");
  for (double v : xt.values) {
    w.Put("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\"/>\n", Px(fr.XToPixel(v)),
          Px(fr.bottom), Px(fr.bottom + kTickLength));
  }
  for (double v : yt.values) {
    w.Put("<line x1=\"{1}\" y1=\"{0}\" x2=\"{2}\" y2=\"{0}\"/>\n", Px(fr.YToPixel(v)),
          Px(fr.left - kTickLength), Px(fr.left));
  }
  w.Put("</g>\n<g class=\"tick-labels\">\n");
  for (double v : xt.values) {
    w.Text(fr.XToPixel(v), fr.bottom + kTickLength + kFontSize + 1.0, FormatTick(v, xt), "middle",
           tick_text);
  }
  for (double v : yt.values) {
    w.Text(fr.left - kTickLength - 3.0, fr.YToPixel(v) + 0.35 * kFontSize, FormatTick(v, yt), "end",
           tick_text);
  }
  w.Put("</g>\n");
  if (xt.exponent != 0) {
    w.Text(fr.right - 3.0, fr.bottom - 4.0, "\u00d71e" + std::to_string(xt.exponent), "end",
           tick_text);
  }
  if (yt.exponent != 0) {
    w.Text(fr.left + 3.0, fr.top + kFontSize + 2.0, "\u00d71e" + std::to_string(yt.exponent),
           "start", tick_text);
  }
  const std::string x_title = AxisTitle(f.x_label, f.x_unit);
  if (!x_title.empty()) {
    w.Text(0.5 * (fr.left + fr.right), size.height - kPad, x_title, "middle", tick_text);
  }
  const std::string y_title = AxisTitle(f.y_label, f.y_unit);
  if (!y_title.empty()) {
    const double cx = kPad + kFontSize, cy = 0.5 * (fr.top + fr.bottom);
    w.Text(cx, cy, y_title, "middle", tick_text, kFontSize,
           fmt::format(" transform=\"rotate(-90 {} {})\"", Px(cx), Px(cy)).c_str());
  }
  if (!f.title.empty()) {
    w.Text(fr.left, kPad + kTitleFontSize, f.title, "start", "#1e2228", kTitleFontSize,
           " font-weight=\"bold\" xml:space=\"preserve\"");
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 1. Text (public)

std::string XmlEscape(const std::string& text) {
  const std::string valid = ValidUtf8(text);
  std::string out;
  out.reserve(valid.size());
  for (char c : valid) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\n') break;
        out += c;
    }
  }
  return out;
}

std::string ShortestDouble(double v) {
  if (v == 0.0) return "0";  // also -0
  return fmt::format("{}", v);
}

// ---------------------------------------------------------------------------------------------
// 2. Clipping

Figure ClipToXRange(Figure f) {
  const Range r = f.x;
  for (FigureSeries& s : f.series) {
    const std::size_t n = s.x.size();
    const bool joined = s.kind == SeriesKind::kLine || s.kind == SeriesKind::kBand;
    const auto inside = [&](std::size_t i) { return i < n && r.Contains(s.x[i]); };
    std::vector<std::size_t> keep;
    for (std::size_t i = 0; i < n; ++i) {
      if (inside(i) || (joined && (inside(i + 1) || (i > 0 && inside(i - 1))))) keep.push_back(i);
    }
    const auto pick = [&](std::vector<double>& v) {
      if (v.size() != n) return;
      std::vector<double> out;
      out.reserve(keep.size());
      for (std::size_t i : keep) out.push_back(v[i]);
      v = std::move(out);
    };
    std::vector<std::string> tags;
    if (s.tags.size() == n) {
      for (std::size_t i : keep) tags.push_back(s.tags[i]);
    }
    s.tags = std::move(tags);
    pick(s.y);
    pick(s.y2);
    pick(s.x);
  }
  return f;
}

// ---------------------------------------------------------------------------------------------
// 3. SVG (public)

std::string FigureToSvg(const Figure& f, SvgSize size) {
  size.width = std::max(size.width, kMinSvgSize);
  size.height = std::max(size.height, kMinSvgSize);
  Frame fr;
  fr.x = Usable(f.x);
  fr.y = Usable(f.y);

  fr.top = f.title.empty() ? kPad * 2 : kTitleFontSize + 2.5 * kPad;
  fr.bottom = size.height - kPad - kTickLength - kFontSize - 3.0;
  if (!AxisTitle(f.x_label, f.x_unit).empty()) fr.bottom -= kFontSize + 4.0;
  fr.bottom = std::max(fr.bottom, fr.top + 8.0);
  const Ticks yt = NiceTicks(fr.y, static_cast<int>((fr.bottom - fr.top) / kYPixelsPerTick) + 1);
  double label_w = 0;
  for (double v : yt.values) label_w = std::max(label_w, TextWidth(FormatTick(v, yt)));
  fr.left = kPad + label_w + kTickLength + 4.0;
  if (!AxisTitle(f.y_label, f.y_unit).empty()) fr.left += kFontSize + kPad;
  fr.right = std::max(size.width - 2.0 * kPad, fr.left + 8.0);
  const Ticks xt = NiceTicks(fr.x, static_cast<int>((fr.right - fr.left) / kXPixelsPerTick) + 1);

  SvgWriter w;
  w.out.reserve(4096);
  w.Put("<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"no\"?>\n");
  w.Put(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" xmlns:gb=\"https://greybench.org/figure\" "
      "version=\"1.1\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\" font-size=\"{2}\">\n",
      size.width, size.height, kFontSize);
  if (!f.title.empty()) w.Put("<title>{}</title>\n", XmlEscape(f.title));
  w.Put("<desc>Drawn by greybench from the plotted values: see the group plot-data.</desc>\n");
  w.Put("<rect width=\"{}\" height=\"{}\" fill=\"#ffffff\"/>\n", size.width, size.height);
  w.Put(
      "<defs><clipPath id=\"plot-area\"><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/>"
      "</clipPath></defs>\n",
      Px(fr.left), Px(fr.top), Px(fr.right - fr.left), Px(fr.bottom - fr.top));
  WriteGrid(w, fr, xt, yt);

  // Data, in pixels that map back to the values by the attributes of plot-data.
  const Mapper mapper{fr};
  w.Put("<g clip-path=\"url(#plot-area)\">\n");
  w.Put(
      "<g id=\"plot-data\" gb:plot-area=\"{} {} {} {}\" gb:x-range=\"{} {}\" "
      "gb:y-range=\"{} {}\">\n",
      ShortestDouble(fr.left), ShortestDouble(fr.top), ShortestDouble(fr.right),
      ShortestDouble(fr.bottom), ShortestDouble(fr.x.min), ShortestDouble(fr.x.max),
      ShortestDouble(fr.y.min), ShortestDouble(fr.y.max));
  for (std::size_t i = 0; i < f.series.size(); ++i) WriteSeries(w, f.series[i], i, fr, mapper);
  w.Put("</g>\n");
  for (const FigureSeries& s : f.series) {
    if (s.kind == SeriesKind::kVLines) WriteTags(w, s, fr);
  }
  w.Put("</g>\n");
  WriteTicksAndTitles(w, f, fr, xt, yt, size);
  WriteLegend(w, f, fr);
  w.Put("</svg>\n");
  return std::move(w.out);
}

// ---------------------------------------------------------------------------------------------
// 4. CSV

namespace {

std::string CsvCell(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::string CsvNumber(double v) { return std::isfinite(v) ? ShortestDouble(v) : ""; }

}  // namespace

std::string FigureToCsv(const Figure& f) {
  // Rows are keyed by (x, k): the k-th sample at that x within one series.
  using Key = std::pair<double, int>;
  std::map<Key, std::vector<std::string>> rows;
  std::vector<std::string> header;
  const std::string x_title = AxisTitle(f.x_label, f.x_unit);
  header.push_back(x_title.empty() ? "x" : x_title);
  struct Column {
    std::size_t series;
    int which;  // 0: y, 1: y2, 2: tag
  };
  std::vector<Column> columns;
  for (std::size_t i = 0; i < f.series.size(); ++i) {
    const FigureSeries& s = f.series[i];
    const std::string name = SeriesName(s, i);
    switch (s.kind) {
      case SeriesKind::kBand:
        columns.push_back({i, 0});
        header.push_back(name + " lower");
        columns.push_back({i, 1});
        header.push_back(name + " upper");
        break;
      case SeriesKind::kErrorBars:
        columns.push_back({i, 0});
        header.push_back(name);
        columns.push_back({i, 1});
        header.push_back(name + " error");
        break;
      case SeriesKind::kVLines:
        columns.push_back({i, 2});
        header.push_back(name);
        break;
      default:
        columns.push_back({i, 0});
        header.push_back(name);
    }
  }
  const std::size_t width = columns.size();
  for (std::size_t c = 0; c < width; ++c) {
    const FigureSeries& s = f.series[columns[c].series];
    std::map<double, int> seen;
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      const double x = s.x[i];
      if (!std::isfinite(x) || !f.x.Contains(x)) continue;
      const Key key{x, seen[x]++};
      std::vector<std::string>& row = rows[key];
      row.resize(width);
      switch (columns[c].which) {
        case 0:
          row[c] = i < s.y.size() ? CsvNumber(s.y[i]) : "";
          break;
        case 1:
          row[c] = i < s.y2.size() ? CsvNumber(s.y2[i]) : "";
          break;
        default:
          row[c] = i < s.tags.size() && !s.tags[i].empty() ? s.tags[i] : "|";
      }
    }
  }
  std::string out;
  for (std::size_t c = 0; c < header.size(); ++c) {
    out += (c ? "," : "") + CsvCell(header[c]);
  }
  out += '\n';
  for (const auto& [key, cells] : rows) {
    out += ShortestDouble(key.first);
    for (const std::string& cell : cells) out += "," + CsvCell(cell);
    out += '\n';
  }
  return out;
}

}  // namespace gb::report
