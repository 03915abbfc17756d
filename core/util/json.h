// JSON as greybench reads and writes it: objects keep the order of the file, so parameters,
// states and report tables appear in the order the user wrote them, and saved files diff cleanly.
// Headers that only name Json (parameters by reference, a Result<Json>) include json_fwd.h.
#pragma once

#include <nlohmann/json.hpp>

#include "core/util/json_fwd.h"
