// A dataset as a project names it: a recording plus how to read and prepare it.
//
// A project's `datasets` entry is a file name (read as a CSV in the default form, dataset.h) or
// an object (docs/user-guide.md, "Datasets"):
//
//   {"file": "run1.csv",          the recording (never rewritten)
//    "name": "run 1",             shown in the workbench (default: the file's name)
//    "header": false,             whether the first line names the columns (default: detected)
//    "separator": ";",            ",", ";" or "\t" (default: detected)
//    "decimal": ",",              "." or "," (default: detected)
//    "columns": ["n", "load"],    the fields' names (a headerless file; or replacing the header's)
//    "time": "Zeit [ms]",         the time column (default: t or time, with a unit or not)
//    "sample_time": 0.1,          or: no time column, row k at k * sample_time seconds
//    "map": {"ilambda": "1/lambda"},  model input or output <- an expression of columns
//    "range": [10, 600],          the rows with t0 <= t <= t1 are used (seconds)
//    "detrend": {"Tex": "mean"},  "mean" or "linear", per column; or one word for every column
//    "resample": 0.5,             a new sample time, after an anti-alias filter
//    "role": "validation"}        "estimation" (default: fitted) or "validation" (not fitted)
//
// An ASAM MDF 4 file (`.mf4`, `.mdf`, or a file that starts with MDF's magic; mdf4.h) takes the
// same keys but header, separator and decimal, with these meanings: `columns` the channels to
// read (names, or name@G for a name in several channel groups; default every channel of every
// group with a master), `time` the time base (a channel group by its number or name, or a
// channel, whose master gives the rows' times; default the channels' group with the most
// samples), `sample_time` a uniform grid instead, and
//    "interpolation": "linear"    how a channel at another rate is brought onto the rows' times:
//                                 "hold" (default: its last sample) or "linear" (MDF only)
//
// Preparation runs in that order: the file is read (header, separator, decimal, columns, time
// or sample_time), keeping the rows of `range` (every row is still checked), then `map` adds its
// columns (replacing one of the same name), `detrend` subtracts each named column's mean or
// least-squares line over those rows (missing cells left out), and `resample` decimates. The result
// is a Dataset like any other: Bind binds its columns by name.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/data/dataset.h"
#include "core/util/json_fwd.h"
#include "core/util/result.h"

namespace gb::data {

enum class Role { kEstimation, kValidation };
const char* RoleName(Role role);  // "estimation", "validation"

enum class Detrend { kMean, kLinear };

struct DatasetSpec {
  std::string file;  // the recording, as resolved by the project (or as given)
  // Written back as a plain file name: the entry was one, and no key has been set since.
  bool plain = true;
  std::string name;
  std::optional<bool> header;
  std::optional<char> separator;
  std::optional<char> decimal;
  std::vector<std::string> columns;
  std::string time;
  double sample_time = 0;
  std::vector<std::pair<std::string, std::string>> map;  // target <- expression, in order
  std::optional<std::array<double, 2>> range;
  // (column, how); the column "" is every column (the one-word form).
  std::vector<std::pair<std::string, Detrend>> detrend;
  double resample = 0;
  std::string interpolation;  // MDF only: "hold" or "linear"; "": hold
  Role role = Role::kEstimation;

  // Where the entry was written, for messages: the project file and the JSON path of the entry
  // ("datasets[1]"); both empty for a spec built in code.
  std::string origin_file;
  std::string origin_path;

  // The name shown for the dataset: `name`, else the file's name.
  std::string DisplayName() const;
};

// A dataset read in the default form: a plain file name.
DatasetSpec PlainDataset(std::string file);

// The files of `datasets`, in order.
std::vector<std::string> Files(const std::vector<DatasetSpec>& datasets);
// The datasets of `role`, in order.
std::vector<DatasetSpec> WithRole(const std::vector<DatasetSpec>& datasets, Role role);

// A `datasets` entry (a string or an object) of project file `origin_file` at JSON path
// `origin_path`. Errors name both, with the key: `case.json: datasets[1].decimal: expected "."
// or ","`. `file` is returned as written (the project resolves it).
Result<DatasetSpec> ParseDatasetSpec(const Json& entry, const std::string& origin_file,
                                     const std::string& origin_path);

// The entry for `spec` with `file` written as given: a plain string when spec.plain, else an
// object with the keys that are set. ParseDatasetSpec(DatasetSpecToJson(s, f)) gives s back.
Json DatasetSpecToJson(const DatasetSpec& spec, const std::string& file);

// How the entry's file is read: its header, separator and decimal keys where given, what SniffCsv
// tells from `text` where not; its columns, time, sample time and range.
CsvFormat FormatOf(const DatasetSpec& spec, std::string_view text);

// How the entry's MDF file is brought onto one time base (mdf4.h): columns, time, sample_time,
// interpolation and range.
struct Mdf4Format;
Mdf4Format Mdf4FormatOf(const DatasetSpec& spec);

// Whether `path` is an ASAM MDF file: its name ends in .mf4 or .mdf (any case), or its first
// bytes are MDF's magic.
bool IsMdfFile(const std::string& path);

// Reads and prepares the recording (a CSV file, or an MDF file: mdf4.h's Mdf4ToDataset). A plain
// spec reads exactly as ReadCsvFile(spec.file). Errors in the file name the file and line; errors
// of a key name the project file and the key's JSON path (`case.json: datasets[0].map.ilambda:
// column 'Lamda' is not in the file; ...`).
Result<std::shared_ptr<const Dataset>> ReadDataset(const DatasetSpec& spec);

// The preparation steps on a dataset already read, in the rows of its range (map, detrend and
// resample of `spec`). A range that kept fewer than 2 rows is an error of the key `range`.
Result<std::shared_ptr<const Dataset>> Prepare(std::shared_ptr<const Dataset> data,
                                               const DatasetSpec& spec);

// Decimation onto the grid t0 + k * sample_time (k = 0, 1, ... while within the record) of a
// regularly sampled column: each new value is the windowed-sinc low-pass (cut-off at 0.8 of the
// new Nyquist frequency, Hamming window 8 new sample times either side) of the old values,
// normalised by the weights of the cells present, so a constant stays exact and the record's
// ends are not pulled towards zero. A value whose present weights are less than half the window's
// is missing (NaN). `time` regular (checked by the caller); sample_time >= its interval.
std::vector<double> Decimate(std::span<const double> time, std::span<const double> values,
                             double sample_time);

}  // namespace gb::data
