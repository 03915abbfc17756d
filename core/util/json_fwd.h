// The name greybench's JSON type goes by (core/util/json.h), for headers that only declare
// functions taking or returning it by reference or in a Result: they include this, and the
// sources that build or read JSON include json.h. Keeps the whole JSON library (a large header)
// out of the translation units that never touch JSON.
#pragma once

#include <nlohmann/json_fwd.hpp>

namespace gb {
using Json = nlohmann::ordered_json;
}  // namespace gb
