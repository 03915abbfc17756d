// Reading a result file (user guide §5) back: its estimates as start values or as the
// reference of a monitor (core/online/monitor.h), and what a likelihood-ratio test needs of it.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/model/model.h"
#include "core/online/estimator.h"
#include "core/util/json_fwd.h"
#include "core/util/result.h"

namespace gb::project {

// Copies the estimates of a result file into `spec`, except the parameters named in `keep`
// (those set by --set) and, with `free_only`, the model's fixed ones. Errors name the result
// file and the JSON path (not a result file, a parameter the model lacks, a free parameter of the
// model the result lacks, an estimate outside the model's bounds, a delay outside its range).
// Returns the delay per output the result names
// (-1: not named). With `json`, the parsed file.
Result<std::vector<int>> ApplyResultFile(const std::string& path, const std::set<std::string>& keep,
                                         model::ModelSpec* spec, bool free_only = false,
                                         Json* json = nullptr);

// An Error of a result file at a JSON path.
Error ResultFileError(const std::string& file, const std::string& path, const std::string& message);

// The reference of a result file for `spec` (the model a monitor runs, core/online/monitor.h):
// every parameter's estimate (fixed ones as the model has them), the delays, the covariance of the
// free parameters from their standard errors and correlations, and n_obs. Errors name the file and
// JSON path. The "correlation" ({"names": [...], "matrix": [[...], ...]}) is required when two or
// more free parameters have standard errors (without it they would be taken as uncorrelated: wrong
// alarms, wrong delta-method SEs); its names must cover every one of them, each once; the matrix
// must be square (one row per name), symmetric, with unit diagonal, entries in [-1, 1], and
// positive semi-definite, each to within 1e-8 (eigenvalues within it below 0 are taken as 0). A
// singular matrix is read: where it is used decides (the monitor refuses a singular tracked block).
Result<online::Reference> LoadReference(const std::string& path, const model::ModelSpec& spec);

// What a likelihood-ratio test needs of a result file (`greybench-cli compare`, the workbench's
// Fits list).
struct NestedFit {
  std::string path;  // how messages name it (a file, or "fit 2")
  std::string model;
  double loglik = 0;
  int n_free = 0;
  long n_obs = 0;
  std::vector<std::string> datasets;      // file names, sorted
  std::vector<std::string> fingerprints;  // the data files' fingerprints, sorted (may be empty)
  std::map<std::string, std::optional<double>> parameters;  // name: its value if fixed, else none
};

// Refuses a partial result (a checkpoint) and a fit stopped by the user ("cancelled"): their
// log L is not an optimum, so a likelihood-ratio test on them means nothing. Errors name `path`
// and the JSON path.
Result<NestedFit> ReadNestedFit(const Json& result, const std::string& path);

// Why a likelihood-ratio test of `restricted` (fewer free parameters) against `full` is
// meaningless, or "": the two were fitted to other data, or `restricted` is not `full` with some
// of its free parameters fixed. `by_name_only`: the data could be matched by file name only (a
// result without fingerprints).
std::string WhyNotNested(const NestedFit& restricted, const NestedFit& full, bool* by_name_only);

}  // namespace gb::project
