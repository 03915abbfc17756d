// Reading a result file (CONTRACT section 5) back: its estimates as start values or as the
// reference of a monitor (core/online/monitor.h).
#pragma once

#include <set>
#include <string>
#include <vector>

#include "core/model/model.h"
#include "core/util/json.h"
#include "core/util/result.h"

namespace gb::project {

// Copies the estimates of a result file into `spec`, except the parameters named in `keep`
// (those set by --set) and, with `free_only`, the model's fixed ones. Errors name the result
// file and the JSON path (not a result file, a parameter the model lacks, a free parameter of the
// model the result lacks, an estimate outside the model's bounds, a delay outside its range). Returns the delay per output the result names
// (-1: not named). With `json`, the parsed file.
Result<std::vector<int>> ApplyResultFile(const std::string& path, const std::set<std::string>& keep,
                                         model::ModelSpec* spec, bool free_only = false,
                                         Json* json = nullptr);

// An Error of a result file at a JSON path.
Error ResultFileError(const std::string& file, const std::string& path, const std::string& message);

}  // namespace gb::project
