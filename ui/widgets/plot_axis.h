// The plot widget's axis arithmetic: core/report/axis.h (shared with the SVG figures), under the
// widget's names.
#pragma once

#include "core/report/axis.h"

namespace gb::ui::plot {

using report::FormatTick;
using report::FormatValue;
using report::kMinTicks;
using report::NiceTicks;
using report::Range;
using report::Ticks;

}  // namespace gb::ui::plot
