// Grouping sample intervals and binding a Dataset's columns to a model's inputs and outputs.
#include <cassert>
#include <cmath>
#include <iterator>
#include <map>
#include <utility>

#include <fmt/format.h>

#include "core/data/dataset.h"

namespace gb::data {
namespace {

Error DataError(const Dataset& data, int line, int col, std::string message) {
  Error e = InputError(std::move(message));
  e.file = data.source;
  e.line = line;
  e.col = col;
  return e;
}

bool SameInterval(double dt, double group_value) {
  return std::abs(dt - group_value) < Intervals::kIntervalRelTol * group_value;
}

// The header's names in file order.
std::string ColumnList(const Dataset& data) {
  std::string out;
  const auto append = [&out](const std::string& name) {
    if (!out.empty()) out += ", ";
    out += name.empty() ? std::string("\"\"") : name;
  };
  bool time_listed = data.time_field == 0;  // rows timed by a sample time: no time column
  for (const Column& c : data.columns) {
    if (!time_listed && c.field > data.time_field) {
      append(data.time_name);
      time_listed = true;
    }
    append(c.name);
  }
  if (!time_listed) append(data.time_name);
  return out;
}

// A column to bind, and what it is to the model (for messages).
struct Binding {
  const Column* column;
  const char* role;  // "input" or "output"
};

// Finds `name`, or says why it cannot be bound.
Result<const Column*> FindColumn(const Dataset& data, const std::string& name, const char* role) {
  const int index = data.Find(name);
  if (index >= 0) return &data.columns[static_cast<std::size_t>(index)];
  if (index == -2) {
    std::vector<int> fields;
    for (const Column& c : data.columns) {
      if (c.name == name) fields.push_back(c.field);
    }
    return DataError(data, data.header_line, fields[1],
                     fmt::format("column '{}' (an {} of the model) appears more than once in the "
                                 "header, as fields {}",
                                 name, role, fmt::join(fields, ", ")));
  }
  if (data.time_field > 0 && name == data.time_name) {
    return DataError(
        data, data.header_line, data.time_field,
        fmt::format("column '{}' is the time column; it cannot be an {} of the model", name, role));
  }
  return DataError(data, data.header_line, 0,
                   fmt::format("column '{}' (an {} of the model) is not in the file; its columns "
                               "are {}",
                               name, role, ColumnList(data)));
}

}  // namespace

Intervals GroupIntervals(std::span<const double> time) {
  Intervals out;
  if (time.size() < 2) return out;
  out.group.resize(time.size() - 1);
  // Groups by value, for irregular data; the previous interval's group is tried first.
  std::map<double, int> by_value;
  int previous = -1;
  for (std::size_t k = 0; k + 1 < time.size(); ++k) {
    const double dt = time[k + 1] - time[k];
    assert(dt > 0 && "GroupIntervals: time must be strictly increasing");
    int g = -1;
    if (previous >= 0 && SameInterval(dt, out.distinct[static_cast<std::size_t>(previous)])) {
      g = previous;
    } else {
      // Group values are more than the tolerance apart, so only the neighbours of dt can match;
      // of two matches the older group wins, as a scan in creation order would choose.
      const auto above = by_value.lower_bound(dt);
      if (above != by_value.end() && SameInterval(dt, above->first)) g = above->second;
      if (above != by_value.begin()) {
        const auto below = std::prev(above);
        if (SameInterval(dt, below->first) && (g < 0 || below->second < g)) g = below->second;
      }
      if (g < 0) {
        g = static_cast<int>(out.distinct.size());
        out.distinct.push_back(dt);
        by_value.emplace(dt, g);
      }
    }
    out.group[k] = g;
    previous = g;
  }
  return out;
}

Result<std::shared_ptr<const Series>> Bind(const Dataset& data, std::span<const std::string> inputs,
                                           std::span<const std::string> outputs) {
  const std::size_t n = data.rows();
  if (n < 2) {
    return DataError(
        data, data.header_line, 0,
        fmt::format("the file has {} data row{}; at least 2 are needed", n, n == 1 ? "" : "s"));
  }

  std::vector<Binding> bindings;
  bindings.reserve(inputs.size() + outputs.size());
  for (const auto& [names, role] : {std::pair{inputs, "input"}, std::pair{outputs, "output"}}) {
    for (const std::string& name : names) {
      Result<const Column*> column = FindColumn(data, name, role);
      if (!column) return column.error();
      bindings.push_back({*column, role});
    }
  }
  for (const Binding& b : bindings) {
    const Column& c = *b.column;
    if (c.bad_line != 0) {
      return DataError(data, c.bad_line, c.field,
                       fmt::format("in column '{}' (an {} of the model), {}", c.name, b.role,
                                   NotANumberReason(c.bad_text, data.decimal)));
    }
  }

  // A missing input: report the earliest, and how many there are in all.
  const Column* first_missing = nullptr;
  int n_missing_inputs = 0;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const Column& c = *bindings[i].column;
    if (c.n_missing == 0) continue;
    n_missing_inputs += c.n_missing;
    if (first_missing == nullptr || c.first_missing_line < first_missing->first_missing_line) {
      first_missing = &c;
    }
  }
  if (first_missing != nullptr) {
    return DataError(
        data, first_missing->first_missing_line, first_missing->field,
        fmt::format("input '{}' is missing at line {}; inputs must be given at every row ({} "
                    "input cell{} missing in all)",
                    first_missing->name, first_missing->first_missing_line, n_missing_inputs,
                    n_missing_inputs == 1 ? " is" : "s are"));
  }

  auto series = std::make_shared<Series>();
  series->source = data.source;
  series->time = data.time;
  series->U.resize(static_cast<Eigen::Index>(inputs.size()), static_cast<Eigen::Index>(n));
  series->Y.resize(static_cast<Eigen::Index>(outputs.size()), static_cast<Eigen::Index>(n));
  // Column-major: fill one sample (matrix column) at a time.
  for (std::size_t k = 0; k < n; ++k) {
    const auto col = static_cast<Eigen::Index>(k);
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      series->U(static_cast<Eigen::Index>(i), col) = bindings[i].column->values[k];
    }
    for (std::size_t j = 0; j < outputs.size(); ++j) {
      series->Y(static_cast<Eigen::Index>(j), col) = bindings[inputs.size() + j].column->values[k];
    }
  }
  series->intervals = GroupIntervals(series->time);
  series->outputs.assign(outputs.begin(), outputs.end());
  series->row_line = data.row_line;
  return std::shared_ptr<const Series>(std::move(series));
}

Error AtRow(Error e, const Series& series, int j) {
  const bool in_range = j >= 0 && j < static_cast<int>(series.size());
  const int line = in_range && j < static_cast<int>(series.row_line.size())
                       ? series.row_line[static_cast<std::size_t>(j)]
                       : 0;
  if (e.file.empty() || e.file == series.source) {
    e.file = series.source;
    e.line = line;
    return e;
  }
  if (series.source.empty() || !in_range) return e;
  const double t = series.time[static_cast<std::size_t>(j)];
  e.message += line > 0 ? fmt::format(" (at {} line {}, t = {:g})", series.source, line, t)
                        : fmt::format(" (at row {} of {}, t = {:g})", j + 1, series.source, t);
  return e;
}

}  // namespace gb::data
