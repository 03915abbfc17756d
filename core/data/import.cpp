// Datasets as a project names them: the entry's keys (import.h), and reading and preparing the
// recording they describe.
//
// Contents
//   Keys          ParseDatasetSpec, DatasetSpecToJson
//   Reading       ReadDataset
//   Preparation   Prepare: map, range, detrend, resample (Decimate)
#include "core/data/import.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numbers>
#include <set>

#include <fmt/format.h>

#include "core/data/internal.h"
#include "core/data/mdf4.h"
#include "core/expr/expr.h"
#include "core/util/json.h"

namespace gb::data {
namespace {

Error KeyError(const DatasetSpec& spec, const std::string& key, std::string message) {
  Error e = InputError(std::move(message));
  e.file = spec.origin_file;
  e.path = spec.origin_path.empty() ? key
           : key.empty()            ? spec.origin_path
                                    : spec.origin_path + "." + key;
  return e;
}

}  // namespace

const char* RoleName(Role role) { return role == Role::kValidation ? "validation" : "estimation"; }

DatasetSpec PlainDataset(std::string file) {
  DatasetSpec spec;
  spec.file = std::move(file);
  return spec;
}

std::vector<std::string> Files(const std::vector<DatasetSpec>& datasets) {
  std::vector<std::string> files;
  files.reserve(datasets.size());
  for (const DatasetSpec& d : datasets) files.push_back(d.file);
  return files;
}

std::vector<DatasetSpec> WithRole(const std::vector<DatasetSpec>& datasets, Role role) {
  std::vector<DatasetSpec> out;
  std::copy_if(datasets.begin(), datasets.end(), std::back_inserter(out),
               [role](const DatasetSpec& d) { return d.role == role; });
  return out;
}

std::string DatasetSpec::DisplayName() const {
  return name.empty() ? std::filesystem::path(file).filename().string() : name;
}

// ---------------------------------------------------------------------------------------------
// Keys

Result<DatasetSpec> ParseDatasetSpec(const Json& entry, const std::string& origin_file,
                                     const std::string& origin_path) {
  DatasetSpec spec;
  spec.origin_file = origin_file;
  spec.origin_path = origin_path;
  if (entry.is_string()) {
    spec.file = entry.get<std::string>();
    if (spec.file.empty()) return KeyError(spec, "", "expected a file name, not \"\"");
    return spec;
  }
  if (!entry.is_object()) {
    return KeyError(
        spec, "", "expected a file name (a string) or an object such as {\"file\": \"run1.csv\"}");
  }
  spec.plain = false;
  const auto positive = [&](const Json& v, const std::string& key, double* out) -> Status {
    if (!v.is_number() || !(v.get<double>() > 0) || !std::isfinite(v.get<double>()))
      return KeyError(spec, key, "expected a number of seconds greater than 0");
    *out = v.get<double>();
    return Ok{};
  };
  const auto name_list = [&](const Json& v, const std::string& key,
                             std::vector<std::string>* out) -> Status {
    if (!v.is_array() || v.empty())
      return KeyError(spec, key, "expected a list of column names, such as [\"n\", \"load\"]");
    std::set<std::string> seen;
    for (std::size_t i = 0; i < v.size(); ++i) {
      const std::string at = fmt::format("{}[{}]", key, i);
      if (!v[i].is_string() || v[i].get<std::string>().empty())
        return KeyError(spec, at, "expected a column name (a string that is not empty)");
      if (!seen.insert(v[i].get<std::string>()).second)
        return KeyError(spec, at, fmt::format("'{}' is named twice", v[i].get<std::string>()));
      out->push_back(v[i].get<std::string>());
    }
    return Ok{};
  };

  for (auto it = entry.begin(); it != entry.end(); ++it) {
    const std::string& key = it.key();
    const Json& v = it.value();
    if (key == "file") {
      if (!v.is_string() || v.get<std::string>().empty())
        return KeyError(spec, key, "expected a file name (a string)");
      spec.file = v.get<std::string>();
    } else if (key == "name") {
      if (!v.is_string()) return KeyError(spec, key, "expected a string");
      spec.name = v.get<std::string>();
    } else if (key == "header") {
      if (!v.is_boolean()) return KeyError(spec, key, "expected true or false");
      spec.header = v.get<bool>();
    } else if (key == "separator") {
      const std::string s = v.is_string() ? v.get<std::string>() : "";
      if (s != "," && s != ";" && s != "\t")
        return KeyError(spec, key, "expected \",\", \";\" or \"\\t\"");
      spec.separator = s.front();
    } else if (key == "decimal") {
      const std::string s = v.is_string() ? v.get<std::string>() : "";
      if (s != "." && s != ",") return KeyError(spec, key, "expected \".\" or \",\"");
      spec.decimal = s.front();
    } else if (key == "columns") {
      if (Status s = name_list(v, key, &spec.columns); !s) return s.error();
    } else if (key == "time") {
      if (!v.is_string() || v.get<std::string>().empty())
        return KeyError(spec, key, "expected the name of the time column");
      spec.time = v.get<std::string>();
    } else if (key == "sample_time") {
      if (Status s = positive(v, key, &spec.sample_time); !s) return s.error();
    } else if (key == "map") {
      if (!v.is_object() || v.empty())
        return KeyError(spec, key, "expected an object such as {\"ilambda\": \"1/lambda\"}");
      for (auto m = v.begin(); m != v.end(); ++m) {
        if (m.key().empty()) return KeyError(spec, key, "a mapped name cannot be empty");
        if (!m.value().is_string() || m.value().get<std::string>().empty())
          return KeyError(spec, key + "." + m.key(),
                          "expected an expression of the file's columns (a string)");
        spec.map.emplace_back(m.key(), m.value().get<std::string>());
      }
    } else if (key == "range") {
      if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number())
        return KeyError(spec, key, "expected [t0, t1], two times in seconds");
      const double t0 = v[0].get<double>(), t1 = v[1].get<double>();
      if (!std::isfinite(t0) || !std::isfinite(t1) || !(t0 < t1))
        return KeyError(spec, key,
                        fmt::format("expected t0 < t1, both finite; got [{}, {}]", t0, t1));
      spec.range = std::array<double, 2>{t0, t1};
    } else if (key == "detrend") {
      const auto how = [&](const Json& w, const std::string& at) -> Result<Detrend> {
        const std::string s = w.is_string() ? w.get<std::string>() : "";
        if (s == "mean") return Detrend::kMean;
        if (s == "linear") return Detrend::kLinear;
        return KeyError(spec, at, "expected \"mean\" or \"linear\"");
      };
      if (v.is_string()) {
        Result<Detrend> d = how(v, key);
        if (!d) return d.error();
        spec.detrend.emplace_back("", *d);
      } else if (v.is_object() && !v.empty()) {
        for (auto d = v.begin(); d != v.end(); ++d) {
          Result<Detrend> h = how(d.value(), key + "." + d.key());
          if (!h) return h.error();
          spec.detrend.emplace_back(d.key(), *h);
        }
      } else {
        return KeyError(spec, key,
                        "expected \"mean\", \"linear\" or an object such as {\"Tex\": \"mean\"}");
      }
    } else if (key == "resample") {
      if (Status s = positive(v, key, &spec.resample); !s) return s.error();
    } else if (key == "interpolation") {
      const std::string s = v.is_string() ? v.get<std::string>() : "";
      if (s != "hold" && s != "linear")
        return KeyError(spec, key, "expected \"hold\" or \"linear\"");
      spec.interpolation = s;
    } else if (key == "role") {
      const std::string s = v.is_string() ? v.get<std::string>() : "";
      if (s == "estimation")
        spec.role = Role::kEstimation;
      else if (s == "validation")
        spec.role = Role::kValidation;
      else
        return KeyError(spec, key, "expected \"estimation\" or \"validation\"");
    } else {
      return KeyError(spec, key,
                      "unknown key (a dataset has file, name, header, separator, decimal, "
                      "columns, time, sample_time, map, range, detrend, resample, "
                      "interpolation and role)");
    }
  }
  if (spec.file.empty()) return KeyError(spec, "", "the dataset names no file: add \"file\"");
  if (!spec.time.empty() && spec.sample_time > 0)
    return KeyError(spec, "sample_time",
                    "give either \"time\" (a column) or \"sample_time\", not both");
  if (spec.decimal == ',' && spec.separator == ',')
    return KeyError(spec, "decimal", "a decimal comma needs another separator than \",\"");
  if (spec.header == false && spec.columns.empty() && !spec.time.empty()) {
    return KeyError(spec, "time",
                    "a file without a header names its columns with \"columns\" (else they are "
                    "c1, c2, ...): name the time column among them");
  }
  return spec;
}

Json DatasetSpecToJson(const DatasetSpec& spec, const std::string& file) {
  if (spec.plain) return file;
  Json j = Json::object();
  j["file"] = file;
  if (!spec.name.empty()) j["name"] = spec.name;
  if (spec.header) j["header"] = *spec.header;
  if (spec.separator) j["separator"] = std::string(1, *spec.separator);
  if (spec.decimal) j["decimal"] = std::string(1, *spec.decimal);
  if (!spec.columns.empty()) j["columns"] = spec.columns;
  if (!spec.time.empty()) j["time"] = spec.time;
  if (spec.sample_time > 0) j["sample_time"] = spec.sample_time;
  if (!spec.map.empty()) {
    Json m = Json::object();
    for (const auto& [target, expression] : spec.map) m[target] = expression;
    j["map"] = std::move(m);
  }
  if (spec.range) j["range"] = {(*spec.range)[0], (*spec.range)[1]};
  if (!spec.detrend.empty()) {
    const auto word = [](Detrend d) { return d == Detrend::kMean ? "mean" : "linear"; };
    if (spec.detrend.size() == 1 && spec.detrend.front().first.empty()) {
      j["detrend"] = word(spec.detrend.front().second);
    } else {
      Json d = Json::object();
      for (const auto& [column, how] : spec.detrend) d[column] = word(how);
      j["detrend"] = std::move(d);
    }
  }
  if (spec.resample > 0) j["resample"] = spec.resample;
  if (!spec.interpolation.empty()) j["interpolation"] = spec.interpolation;
  if (spec.role != Role::kEstimation) j["role"] = RoleName(spec.role);
  return j;
}

// ---------------------------------------------------------------------------------------------
// Reading

CsvFormat FormatOf(const DatasetSpec& spec, std::string_view text) {
  // What is not given is told from the text; what is given wins.
  CsvFormat format;
  if (!spec.header || !spec.separator || !spec.decimal) format = SniffCsv(text);
  if (spec.header) format.header = *spec.header;
  if (spec.separator) format.separator = *spec.separator;
  if (spec.decimal) format.decimal = *spec.decimal;
  if (format.decimal == ',' && format.separator == ',') {
    // A guessed decimal comma gives way to a given ',' separator, and the other way round.
    if (spec.separator)
      format.decimal = '.';
    else
      format.separator = ';';
  }
  format.columns = spec.columns;
  format.time = spec.time;
  format.sample_time = spec.sample_time;
  format.range = spec.range;
  return format;
}

bool IsMdfFile(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  using internal::EqualsIgnoringCase;
  if (EqualsIgnoringCase(ext, ".mf4") || EqualsIgnoringCase(ext, ".mdf")) return true;
  std::ifstream in(path, std::ios::binary);
  unsigned char head[8] = {};
  if (!in.read(reinterpret_cast<char*>(head), sizeof head)) return false;
  return LooksLikeMdf(head);
}

namespace {

Result<std::shared_ptr<const Dataset>> ReadMdfDataset(const DatasetSpec& spec) {
  for (const auto& [key, set] : {std::pair{"header", spec.header.has_value()},
                                 std::pair{"separator", spec.separator.has_value()},
                                 std::pair{"decimal", spec.decimal.has_value()}}) {
    if (set)
      return KeyError(spec, key,
                      fmt::format("a key of CSV files, and {} is an ASAM MDF file (its channels "
                                  "are chosen by \"columns\", its time base by \"time\")",
                                  spec.file));
  }
  Result<Mdf4File> file = ReadMdf4File(spec.file);
  if (!file) return file.error();
  return Mdf4ToDataset(*file, spec.file, Mdf4FormatOf(spec));
}

}  // namespace

Mdf4Format Mdf4FormatOf(const DatasetSpec& spec) {
  Mdf4Format format;
  format.channels = spec.columns;
  format.time_base = spec.time;
  format.sample_time = spec.sample_time;
  format.interpolation = spec.interpolation == "linear" ? Mdf4Format::Interpolation::kLinear
                                                        : Mdf4Format::Interpolation::kHold;
  format.range = spec.range;
  return format;
}

Result<std::shared_ptr<const Dataset>> ReadDataset(const DatasetSpec& spec) {
  const bool mdf = IsMdfFile(spec.file);
  if (!mdf && !spec.interpolation.empty())
    return KeyError(spec, "interpolation",
                    "a key of ASAM MDF files (channels at different rates); " + spec.file +
                        " is read as a CSV file");
  if (!mdf && spec.plain) return ReadCsvFile(spec.file);
  Result<std::shared_ptr<const Dataset>> read =
      mdf ? ReadMdfDataset(spec)
          : ReadCsvFile(spec.file, [&spec](std::string_view text) { return FormatOf(spec, text); });
  if (!read) return read.error();
  return Prepare(std::move(*read), spec);
}

// ---------------------------------------------------------------------------------------------
// Preparation

namespace {

std::string ColumnNames(const Dataset& d) {
  std::string out;
  for (const Column& c : d.columns) out += (out.empty() ? "" : ", ") + c.name;
  return out;
}

// Adds the columns of spec.map to *d.
Status Map(const DatasetSpec& spec, Dataset* d) {
  std::vector<Column> mapped;
  for (const auto& [target, text] : spec.map) {
    const std::string key = "map." + target;
    Column out;
    if (const int index = d->Find(text); index >= 0) {  // a column's name, whatever it holds
      out = d->columns[static_cast<std::size_t>(index)];
      out.name = target;
      mapped.push_back(std::move(out));
      continue;
    }
    out.name = target;
    Result<expr::ExprPtr> e = expr::Parse(text);
    if (!e) {
      Error err = KeyError(spec, key, e.error().message);
      err.expr_col = e.error().expr_col;
      return err;
    }
    std::set<std::string> names;
    expr::CollectNames(*e, &names);
    std::vector<const Column*> used;
    for (const std::string& n : names) {
      const int index = d->Find(n);
      if (index == -2)
        return KeyError(spec, key,
                        fmt::format("column '{}' appears more than once in the file", n));
      if (index < 0) {
        Error err = KeyError(
            spec, key,
            fmt::format("column '{}' is not in the file; its columns are {}", n, ColumnNames(*d)));
        if (const expr::Node* at = expr::FindFirstVariable(*e, {n})) err.expr_col = at->column;
        return err;
      }
      used.push_back(&d->columns[static_cast<std::size_t>(index)]);
    }
    const std::vector<std::string> slot_names(names.begin(), names.end());
    Result<expr::Tape> tape =
        expr::Tape::Compile(std::span<const expr::ExprPtr>(&*e, 1), [&](const std::string& n) {
          const auto at = std::find(slot_names.begin(), slot_names.end(), n);
          return at == slot_names.end() ? -1 : static_cast<int>(at - slot_names.begin());
        });
    if (!tape) {
      Error err = KeyError(spec, key, tape.error().message);
      err.expr_col = tape.error().expr_col;
      return err;
    }
    std::vector<double> slots(used.size());
    out.values.resize(d->rows());
    for (std::size_t k = 0; k < d->rows(); ++k) {
      bool present = true;
      for (std::size_t i = 0; i < used.size(); ++i) {
        slots[i] = used[i]->values[k];
        present = present && !std::isnan(slots[i]);
      }
      double v = std::numeric_limits<double>::quiet_NaN();
      if (present) tape->Eval(slots, std::span<double>(&v, 1));
      const int line = k < d->row_line.size() ? d->row_line[k] : 0;
      if (!present) {
        if (out.n_missing++ == 0) out.first_missing_line = line;
      } else if (!std::isfinite(v)) {
        if (out.bad_line == 0) {
          out.bad_line = line;
          out.bad_text = fmt::format("{} = {}", text, v);
        }
        v = std::numeric_limits<double>::quiet_NaN();
      }
      out.values[k] = v;
    }
    // A cell that is not a number in a column used makes the mapped column not a number there.
    for (const Column* c : used) {
      if (c->bad_line != 0 && (out.bad_line == 0 || c->bad_line < out.bad_line)) {
        out.bad_line = c->bad_line;
        out.bad_text = c->bad_text;
      }
    }
    mapped.push_back(std::move(out));
  }
  // A mapped name replaces a column of the same name.
  for (Column& m : mapped) {
    std::erase_if(d->columns, [&](const Column& c) { return c.name == m.name; });
    d->columns.push_back(std::move(m));
  }
  return Ok{};
}

// Subtracts a column's mean or least-squares line (over its present cells).
void Detrend1(const std::vector<double>& time, Detrend how, std::vector<double>* values) {
  double n = 0, st = 0, sv = 0;
  for (std::size_t k = 0; k < values->size(); ++k) {
    if (std::isnan((*values)[k])) continue;
    n += 1;
    st += time[k];
    sv += (*values)[k];
  }
  if (n == 0) return;
  const double mean_t = st / n, mean_v = sv / n;
  double slope = 0;
  if (how == Detrend::kLinear && n >= 2) {
    double stt = 0, stv = 0;
    for (std::size_t k = 0; k < values->size(); ++k) {
      if (std::isnan((*values)[k])) continue;
      stt += (time[k] - mean_t) * (time[k] - mean_t);
      stv += (time[k] - mean_t) * ((*values)[k] - mean_v);
    }
    slope = stt > 0 ? stv / stt : 0;
  }
  for (std::size_t k = 0; k < values->size(); ++k)
    (*values)[k] -= mean_v + slope * (time[k] - mean_t);
}

Status DetrendColumns(const DatasetSpec& spec, Dataset* d) {
  for (const auto& [name, how] : spec.detrend) {
    if (name.empty()) {
      for (Column& c : d->columns) Detrend1(d->time, how, &c.values);
      continue;
    }
    const int index = d->Find(name);
    if (index == -2)
      return KeyError(spec, "detrend." + name, "the column appears more than once in the file");
    if (index < 0) {
      return KeyError(
          spec, "detrend." + name,
          fmt::format("column '{}' is not in the file; its columns are {}", name, ColumnNames(*d)));
    }
    Detrend1(d->time, how, &d->columns[static_cast<std::size_t>(index)].values);
  }
  return Ok{};
}

Status Resample(const DatasetSpec& spec, Dataset* d) {
  const std::size_t n = d->rows();
  const double old_dt = (d->time.back() - d->time.front()) / static_cast<double>(n - 1);
  double lo = old_dt, hi = old_dt;
  for (std::size_t k = 1; k < n; ++k) {
    lo = std::min(lo, d->time[k] - d->time[k - 1]);
    hi = std::max(hi, d->time[k] - d->time[k - 1]);
  }
  if (hi - lo > 0.01 * old_dt) {
    return KeyError(spec, "resample",
                    fmt::format("the record is not regularly sampled (its intervals run from {:g} "
                                "to {:g} s); it cannot be resampled",
                                lo, hi));
  }
  if (spec.resample < old_dt * (1 - 1e-9)) {
    return KeyError(spec, "resample",
                    fmt::format("{:g} s is shorter than the record's sample time, {:g} s: only "
                                "decimation (a longer sample time) is done",
                                spec.resample, old_dt));
  }
  if (spec.resample <= old_dt * (1 + 1e-9)) return Ok{};
  std::vector<double> time;
  std::vector<int> lines;
  for (std::size_t k = 0;; ++k) {
    const double t = d->time.front() + static_cast<double>(k) * spec.resample;
    if (t > d->time.back() * (1 + 1e-12) + 1e-300) break;
    time.push_back(t);
    // The line of the nearest old row, for messages.
    const auto at = static_cast<std::size_t>(
        std::clamp(std::round((t - d->time.front()) / old_dt), 0.0, static_cast<double>(n - 1)));
    lines.push_back(d->row_line.empty() ? 0 : d->row_line[at]);
  }
  if (time.size() < 2) {
    return KeyError(spec, "resample",
                    fmt::format("{:g} s leaves fewer than 2 samples of a record {:g} s long",
                                spec.resample, d->time.back() - d->time.front()));
  }
  for (Column& c : d->columns) {
    c.values = Decimate(d->time, c.values, spec.resample);
    c.n_missing = 0;
    c.first_missing_line = 0;
    for (std::size_t k = 0; k < c.values.size(); ++k)
      if (std::isnan(c.values[k]) && c.n_missing++ == 0) c.first_missing_line = lines[k];
  }
  d->time = std::move(time);
  d->row_line = std::move(lines);
  return Ok{};
}

}  // namespace

std::vector<double> Decimate(std::span<const double> time, std::span<const double> values,
                             double sample_time) {
  const std::size_t n = time.size();
  const double dt = (time[n - 1] - time[0]) / static_cast<double>(n - 1);
  const double cutoff = 0.4 / sample_time;  // Hz: 0.8 of the new Nyquist frequency
  const double half_width = 8 * sample_time;
  const auto weight = [&](double tau) {
    const double x = 2 * cutoff * tau;
    const double sinc = x == 0 ? 1 : std::sin(std::numbers::pi * x) / (std::numbers::pi * x);
    return sinc * (0.54 + 0.46 * std::cos(std::numbers::pi * tau / half_width));
  };
  std::vector<double> out;
  for (std::size_t k = 0;; ++k) {
    const double t = time[0] + static_cast<double>(k) * sample_time;
    if (t > time[n - 1] * (1 + 1e-12) + 1e-300) break;
    const double centre = (t - time[0]) / dt;
    const auto first = static_cast<std::size_t>(std::max(0.0, std::ceil(centre - half_width / dt)));
    const auto last = static_cast<std::size_t>(
        std::min(static_cast<double>(n - 1), std::floor(centre + half_width / dt)));
    double sum = 0, weights = 0, all = 0;
    for (std::size_t i = first; i <= last; ++i) {
      const double tau = time[i] - t;
      if (std::abs(tau) >= half_width) continue;
      const double w = weight(tau);
      all += w;
      if (std::isnan(values[i])) continue;
      sum += w * values[i];
      weights += w;
    }
    out.push_back(weights >= 0.5 * all && weights > 0 ? sum / weights
                                                      : std::numeric_limits<double>::quiet_NaN());
  }
  return out;
}

Result<std::shared_ptr<const Dataset>> Prepare(std::shared_ptr<const Dataset> data,
                                               const DatasetSpec& spec) {
  if (spec.range && data->rows() < 2) {
    const std::size_t n = data->rows();
    return KeyError(spec, "range",
                    fmt::format("[{:g}, {:g}] holds {} row{} of the record; at least 2 are needed",
                                (*spec.range)[0], (*spec.range)[1], n, n == 1 ? "" : "s"));
  }
  if (spec.map.empty() && spec.detrend.empty() && spec.resample == 0) return data;
  auto d = std::make_shared<Dataset>(*data);
  if (!spec.map.empty())
    if (Status s = Map(spec, d.get()); !s) return s.error();
  if (!spec.detrend.empty())
    if (Status s = DetrendColumns(spec, d.get()); !s) return s.error();
  if (spec.resample > 0 && d->rows() >= 2)
    if (Status s = Resample(spec, d.get()); !s) return s.error();
  return std::shared_ptr<const Dataset>(std::move(d));
}

}  // namespace gb::data
