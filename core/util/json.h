// JSON as greybench reads and writes it: objects keep the order of the file, so parameters,
// states and report tables appear in the order the user wrote them, and saved files diff cleanly.
#pragma once

#include <nlohmann/json.hpp>

namespace gb {
using Json = nlohmann::ordered_json;
}  // namespace gb
