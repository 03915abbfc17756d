// libFuzzer target: bytes -> ParseMdf4 (core/data/mdf4.cpp) -> Mdf4ToDataset on the default time
// base with hold and with linear interpolation, and on a sample-time grid.
//
// Properties checked beyond "no crash, hang or sanitizer report": a refusal has a message that
// names the file; a parsed file's indices are consistent (each channel's group exists and lists
// it, a group's master has one value per record like its channels); a Dataset keeps its
// documented invariants (finite, strictly increasing time; one row_line and one value per row in
// every column).
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "core/data/mdf4.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

void CheckFile(const gb::data::Mdf4File& f) {
  for (std::size_t g = 0; g < f.groups.size(); ++g) {
    const gb::data::Mdf4Group& group = f.groups[g];
    FUZZ_CHECK(group.number == static_cast<int>(g) + 1);
    for (int c : group.channels) {
      FUZZ_CHECK(c >= 0 && static_cast<std::size_t>(c) < f.channels.size());
      const gb::data::Mdf4Channel& ch = f.channels[static_cast<std::size_t>(c)];
      FUZZ_CHECK(ch.group == static_cast<int>(g));
      if (group.has_master) FUZZ_CHECK(ch.values.size() == group.time.size());
    }
  }
  for (const gb::data::Mdf4Channel& ch : f.channels)
    FUZZ_CHECK(ch.group >= 0 && static_cast<std::size_t>(ch.group) < f.groups.size());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  auto file = gb::data::ParseMdf4(std::span<const unsigned char>(data, size), "fuzz.mf4");
  if (!file.ok()) {
    FUZZ_CHECK(file.error().ToString().rfind("fuzz.mf4: ", 0) == 0);
    return 0;
  }
  CheckFile(*file);
  gb::data::Mdf4Format hold, linear, grid;
  linear.interpolation = gb::data::Mdf4Format::Interpolation::kLinear;
  grid.sample_time = 0.01;
  grid.range = std::array<double, 2>{0, 1e3};
  for (const gb::data::Mdf4Format& format : {hold, linear, grid}) {
    auto d = gb::data::Mdf4ToDataset(*file, "fuzz.mf4", format);
    if (!d.ok()) {
      FUZZ_CHECK(!d.error().ToString().empty());
      continue;
    }
    CheckDataset(**d);
  }
  return 0;
}
