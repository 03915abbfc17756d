// Opening a large block diagram (issue 18: a 20 000-block diagram took about 3 s to open): the
// look-ups by id that reading, compiling and drawing it make, through the diagram's index
// (BlockDiagram::FindBlock, LinkInto) and, side by side, through the linear scans they replaced;
// and the whole read of the diagram's JSON, which makes one look-up per link and per layout entry.
//
//   build/bench/diagram_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// The diagram: 80 chains of 247 gains from one input, each into a lag and an output (19 921
// blocks, 19 920 links), built through AddBlock and Connect.
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "core/diagram/diagram.h"

namespace {

using gb::diagram::Block;
using gb::diagram::BlockDiagram;
using gb::diagram::BlockKind;
using gb::diagram::Link;
using gb::diagram::PortRef;

constexpr int kChains = 80;
constexpr int kDepth = 247;

const BlockDiagram& Big() {
  static const BlockDiagram d = [] {
    BlockDiagram d;
    gb::model::Parameter tau;
    tau.name = "tau";
    tau.value = 1.0;
    d.parameters = {tau};
    const int u = *AddBlock(&d, gb::diagram::MakeBlock(BlockKind::kInput, "u"));
    for (int c = 0; c < kChains; ++c) {
      int prev = u;
      for (int g = 0; g < kDepth; ++g) {
        const int id = *AddBlock(&d, gb::diagram::MakeBlock(BlockKind::kGain));
        (void)*Connect(&d, gb::diagram::Out(prev), gb::diagram::In(id));
        prev = id;
      }
      Block lag = gb::diagram::MakeBlock(BlockKind::kLag, "x" + std::to_string(c));
      lag.fields["tau"] = "tau";
      const int x = *AddBlock(&d, lag);
      (void)*Connect(&d, gb::diagram::Out(prev), gb::diagram::In(x));
      Block out = gb::diagram::MakeBlock(BlockKind::kOutput, "y" + std::to_string(c));
      out.fields["variance"] = "1";
      const int y = *AddBlock(&d, out);
      (void)*Connect(&d, gb::diagram::Out(x), gb::diagram::In(y));
    }
    return d;
  }();
  return d;
}

// The look-ups of the code before the index: a scan of the vectors.
const Block* ScanBlock(const BlockDiagram& d, int id) {
  for (const Block& b : d.blocks)
    if (b.id == id) return &b;
  return nullptr;
}
const Link* ScanInto(const BlockDiagram& d, const PortRef& in) {
  for (const Link& l : d.links)
    if (l.to == in) return &l;
  return nullptr;
}

// Every link's two blocks, as reading the file and drawing the links do.
void BM_LinkEndsIndexed(benchmark::State& state) {
  const BlockDiagram& d = Big();
  for (auto _ : state) {
    for (const Link& l : d.links) {
      benchmark::DoNotOptimize(d.FindBlock(l.from.block));
      benchmark::DoNotOptimize(d.FindBlock(l.to.block));
    }
  }
  state.counters["links"] = static_cast<double>(d.links.size());
}
BENCHMARK(BM_LinkEndsIndexed)->Unit(benchmark::kMillisecond);

void BM_LinkEndsScanned(benchmark::State& state) {
  const BlockDiagram& d = Big();
  for (auto _ : state) {
    for (const Link& l : d.links) {
      benchmark::DoNotOptimize(ScanBlock(d, l.from.block));
      benchmark::DoNotOptimize(ScanBlock(d, l.to.block));
    }
  }
  state.counters["links"] = static_cast<double>(d.links.size());
}
BENCHMARK(BM_LinkEndsScanned)->Unit(benchmark::kMillisecond)->Iterations(3);

// The link into every block's first in-port, as compiling does for every signal.
void BM_LinkIntoIndexed(benchmark::State& state) {
  const BlockDiagram& d = Big();
  for (auto _ : state)
    for (const Block& b : d.blocks) benchmark::DoNotOptimize(d.LinkInto(gb::diagram::In(b.id)));
}
BENCHMARK(BM_LinkIntoIndexed)->Unit(benchmark::kMillisecond);

void BM_LinkIntoScanned(benchmark::State& state) {
  const BlockDiagram& d = Big();
  for (auto _ : state)
    for (const Block& b : d.blocks) benchmark::DoNotOptimize(ScanInto(d, gb::diagram::In(b.id)));
}
BENCHMARK(BM_LinkIntoScanned)->Unit(benchmark::kMillisecond)->Iterations(3);

// Reading the diagram from its JSON (structure checks, one look-up per link and layout entry).
void BM_ReadJson(benchmark::State& state) {
  const gb::Json j = ToJson(Big());
  for (auto _ : state) {
    auto d = gb::diagram::FromJson(j);
    if (!d) state.SkipWithError("FromJson failed");
    benchmark::DoNotOptimize(d);
  }
}
BENCHMARK(BM_ReadJson)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
