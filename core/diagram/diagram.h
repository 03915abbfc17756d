// Block diagrams of grey-box models: the semantics a diagram editor draws and edits. A diagram
// whose state blocks are linear compiles to a linear model (the exact filter); a state block's f
// may be any expression, and the model then runs through the extended Kalman filter.
//
// A `BlockDiagram` is a value: blocks and links with stable integer ids (never reused within a
// diagram), the parameter table (model::Parameter, as in a model file) and the model options.
// Positions live apart in `Layout`: moving a block never changes what the diagram means.
//
// Blocks, their ports (in-ports numbered from 0, then out-ports numbered from 0) and meaning.
// u, u_i are the signals arriving at the in-ports; x is the block's own state; every field
// (k, K, tau, X, ...) is an expression of the model parameters.
//
//   input       out: y = the model input `name`
//   output      in: one per entry of `ports` (default one port "u");
//               the model output `name`: y_k = h(ports) + e_k, e_k ~ N(0, variance)
//               fields: variance (required), h (default: the single port's name);
//               an optional transport delay of its own (`delay`, whole samples, fixed or a range)
//   gain        in: u            out: k u
//   sum         in: one per sign out: Σ_i s_i u_i with s_i = +1 or -1 from `signs` ("+-+")
//   lag         in: u, noise     out: x     dx = (K u - x)/tau dt     (a state named `name`)
//   integrator  in: u, noise     out: x     dx = k u dt               (a state named `name`)
//   state       in: `ports`..., noise   out: x   dx = f(ports, x, θ) dt   (a state named `name`)
//               f reads its ports by name, its own state by `name`, and parameters
//   split       in: u            out 0: X u,  out 1: (1 - X) u
//   product     in: u1, u2       out: u1 u2
//   quotient    in: num, den     out: num / den
//   function    in: `ports`...   out: g(ports, θ)   a static nonlinearity written as an expression
//   orifice     in: u (a level)  out: k sqrt(max(u, 0))   flow through an orifice (Torricelli)
//   saturation  in: u            out: u clipped to [lower, upper]; with width w > 0 the smooth
//               lower + w log(1 + e^{(u-lower)/w}) - w log(1 + e^{(u-upper)/w}) (differentiable
//               everywhere, so the extended Kalman filter's linearisation is defined; w = 0 gives
//               min/max, whose derivative jumps at the limits)
//   delay       in: u            out: u delayed by `delay` whole samples; allowed only directly in
//               front of output blocks (user guide §1: y_k = h(x_{k-d}, u_{k-d}) + e_k)
//   noise       out (a noise port): σ = sigma; linked to the noise in-port of a lag, integrator
//               or state block it adds σ dω to that state's equation (diffusion.<state> = sigma)
//
// Every state block's initial state is its field x0 (default "0").
// Decision: measurement noise is the `variance` field of the output block (every output has
// exactly one), not a separate block; process noise is a block, because a state may have none.
//
// Ports are typed: signal or noise, in or out. An in-port takes exactly one link; an out-port fans
// out to any number. A state block's noise in-port may stay unconnected (no diffusion, σ = 0);
// every signal in-port must be connected before the diagram compiles.
//
// Ownership: everything is held by value; a BlockDiagram owns its blocks, links, parameters and
// layout. Pointers from FindBlock/FindLink/LinkInto are valid until the next edit.
//
// Edits (AddBlock, Connect, ...) are free functions that either apply the whole edit or refuse it
// with an Error whose `path` names the block ("block 7.tau") and, for expressions, `expr_col`.
// They keep these invariants: links join an out-port to an in-port of the same type, no in-port
// holds two links, no cycle runs through blocks without a state (an algebraic loop), a delay block
// feeds only output blocks, and expressions parse and use only names they may use.
// A diagram read from a file may break them; `Compile` reports every break as a `Problem`.
//
// Compile (diagram -> model::ModelSpec): the signal at every out-port is an expression of states,
// inputs and parameters, composed along the links and simplified (expr::Simplify); then
//   drift.<state>      = the block's equation above
//   diffusion.<state>  = sigma of the noise block linked to it, else 0
//   observation.<out>  = h with each port replaced by its signal
//   measurement_variance.<out> = variance
//   output_delay.<out> = the delay of the delay block in front (or the output's own delay)
// States, inputs and outputs appear in block order. The model is written as JSON and read back by
// model::ParseModel, and model::LinearModel::Compile or else model::NonlinearModel::Compile must
// accept it.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/model/model.h"
#include "core/project/project.h"
#include "core/util/json.h"
#include "core/util/result.h"

namespace gb::diagram {

enum class BlockKind {
  kInput,
  kOutput,
  kGain,
  kSum,
  kLag,
  kIntegrator,
  kState,
  kSplit,
  kDelay,
  kNoise,
  kProduct,
  kQuotient,
  kFunction,
  kOrifice,
  kSaturation
};
enum class PortType { kSignal, kNoise };
enum class PortSide { kIn, kOut };

// "input", "output", "gain", "sum", "lag", "integrator", "state", "split", "delay", "noise",
// "product", "quotient", "function", "orifice", "saturation".
const char* KindName(BlockKind kind);
std::optional<BlockKind> KindFromName(const std::string& name);
// Lag, integrator and state blocks hold a state.
bool HoldsState(BlockKind kind);
// The expression fields a kind has, e.g. lag: {"K", "tau", "x0"}.
const std::vector<std::string>& FieldsOf(BlockKind kind);

struct Block {
  int id = 0;
  BlockKind kind = BlockKind::kGain;
  std::string name;                           // model name (input, output, state); else a label
  std::map<std::string, std::string> fields;  // expression texts, keys from FieldsOf(kind)
  std::vector<std::string> ports;             // state, output, function blocks: in-port names
  std::string signs;                          // sum blocks: one '+' or '-' per in-port
  model::DelaySpec delay;                     // delay blocks; output blocks' own delay
};

// A block with the defaults of its kind (gain k = 1, lag K = 1, tau = 1, sum "++", output with
// one port "u" and h = "u" and no variance yet, ...). The id is set by AddBlock.
Block MakeBlock(BlockKind kind, std::string name = "");

struct PortRef {
  int block = 0;
  PortSide side = PortSide::kOut;
  int index = 0;
  bool operator==(const PortRef&) const = default;
};
inline PortRef Out(int block, int index = 0) { return {block, PortSide::kOut, index}; }
inline PortRef In(int block, int index = 0) { return {block, PortSide::kIn, index}; }

struct PortInfo {
  std::string name;  // "u", "noise", "out", "X", "1-X", or a state/output block's port name
  PortType type = PortType::kSignal;
  bool optional = false;  // may stay unconnected (noise in-ports)
};
std::vector<PortInfo> InPorts(const Block& b);
std::vector<PortInfo> OutPorts(const Block& b);

struct Link {
  int id = 0;
  PortRef from;  // an out-port
  PortRef to;    // an in-port
};

// Positions of blocks by id (editor units), saved apart from the semantics.
struct Layout {
  std::map<int, std::array<double, 2>> positions;
};

// clang-tidy's bugprone-exception-escape reports the implicit move constructor, as for
// project::Project: `ekf` is an nlohmann::ordered_json, whose storage is not declared
// noexcept-movable; such a move can only throw std::bad_alloc.
// NOLINTNEXTLINE(bugprone-exception-escape)
struct BlockDiagram {
  std::string name;
  std::vector<model::Parameter> parameters;  // the parameter table, in order (θ order)
  std::vector<Block> blocks;                 // in order of creation
  std::vector<Link> links;
  model::InputHold input_hold = model::InputHold::kZoh;
  // kCtsm, kStationary, or kExplicit with the initial variance of each state as an expression,
  // by state name (a model file's "initial_covariance" object; a state without one starts at 0).
  // Renaming or removing a state block renames or drops its entry.
  model::InitialCovariance initial_covariance = model::InitialCovariance::kCtsm;
  std::map<std::string, std::string> initial_variance;
  std::optional<double> robust_huber;
  // A model file's "ekf" object (how the extended Kalman filter integrates the model), handed to
  // the compiled model as it is; null when absent. Compile reports what is wrong in it.
  Json ekf;
  int next_id = 1;  // ids of blocks and links come from one counter
  Layout layout;

  // Look-ups in O(1) (a diagram of 20 000 blocks opened in seconds with linear ones). They read
  // `index`, which the edits below and FromJson keep; code that changes `blocks` or `links` by
  // hand calls Reindex. A look-up never returns a wrong element (each hit is checked), and scans
  // the vectors when their sizes show that the index is stale.
  const Block* FindBlock(int id) const;  // nullptr if absent
  const Link* FindLink(int id) const;
  const Link* LinkInto(const PortRef& in) const;  // the link holding an in-port, or nullptr
  // The links leaving a block's out-ports, in the order of `links` (O(links out of the block)).
  std::vector<const Link*> LinksFrom(int block) const;
  void Reindex();
  void AppendedBlock();  // after blocks.push_back: indexes it (Reindex when the index is stale)
  void AppendedLink();   // after links.push_back
  struct Index {
    std::unordered_map<int, std::size_t> block, link;        // id -> position
    std::unordered_map<std::uint64_t, std::size_t> into;     // in-port -> its (first) link
    std::unordered_map<int, std::vector<std::size_t>> from;  // block -> its links out
    std::size_t blocks = 0, links = 0;                       // the sizes it was made for
  } index;
};

// ---- edits: each applies entirely or refuses with a reason ----------------------------------

// Adds `block` (its id is assigned) at `position`; returns the id. Refuses a model name that is not
// an identifier or is taken (inputs, states and parameters share one namespace; outputs another),
// and fields that SetBlockParameter would refuse.
Result<int> AddBlock(BlockDiagram* d, Block block, std::array<double, 2> position = {0, 0});
// Removes the block, its links and its position.
Status RemoveBlock(BlockDiagram* d, int block);
// Links an out-port to an in-port; returns the link id. Refuses: an unknown block or port, a link
// from an in-port or into an out-port, signal to noise (or back), an in-port that already holds a
// link, a link that closes a cycle with no state block on it (an algebraic loop), and a delay
// block feeding anything but an output block.
Result<int> Connect(BlockDiagram* d, PortRef from, PortRef to);
Status Disconnect(BlockDiagram* d, int link);
// Sets one expression field. Refuses an unknown field, a syntax error or an unknown name (with
// the column in `expr_col` and a suggestion). An empty text unsets the field (Compile then
// reports it, e.g. an output with no variance).
Status SetBlockParameter(BlockDiagram* d, int block, const std::string& field,
                         const std::string& text);
// Renames an input, output or state block (same rules as AddBlock).
Status RenameBlock(BlockDiagram* d, int block, const std::string& name);
// Sets the delay of a delay block or an output block (0 <= min <= max).
Status SetDelay(BlockDiagram* d, int block, model::DelaySpec delay);
// Sets the in-port names of a state or output block (identifiers, unique, not parameters, not the
// state's own name); links into ports past the new count are removed. Port i keeps its links, so
// renaming a port keeps its wiring; f or h must then read the new names (they are re-checked).
Status SetPortNames(BlockDiagram* d, int block, const std::vector<std::string>& ports);
// Sets the signs of a sum block (one per in-port); links into ports that disappear are removed.
Status SetSumSigns(BlockDiagram* d, int block, const std::string& signs);

// The most inputs a sum block takes (each is a port drawn on the block).
inline constexpr std::size_t kMaxSumInputs = 64;
// Adds a parameter or replaces the one of the same name (bounds checked as in a model file).
Status SetParameterEntry(BlockDiagram* d, model::Parameter parameter);
// Layout only.
Status Move(BlockDiagram* d, int block, std::array<double, 2> position);

// ---- compile ---------------------------------------------------------------------------------

// Something that keeps a diagram from compiling, located so the UI can mark it.
struct Problem {
  int block = 0;      // 0: the diagram as a whole
  int in_port = -1;   // the in-port concerned, -1 if none
  std::string field;  // the expression field concerned ("tau"), or ""
  int expr_col = 0;   // column in that field's expression, 0 if none
  std::string message;
  std::string ToString() const;  // "block 6, in-port 0: in-port 'u' is not connected"
};

struct CompileResult {
  std::optional<model::ModelSpec> model;  // set when problems is empty
  std::vector<Problem> problems;
  bool ok() const { return model.has_value(); }
  // The problems, one a line (for the command line).
  std::string Message() const;
};

// The most states, inputs and outputs a diagram compiles to. The model's matrices hold n^2
// entries and compiling them takes time that grows faster still (model::LinearModel::Compile;
// docs/benchmarks.md, "Timings behind the code's limits"), and the filter takes O(n^3)
// operations a row. A larger diagram is a Problem, not a compile that seems to hang.
inline constexpr std::size_t kMaxModelSize = 256;

// Checking and compiling take O(n log n) time in the number of blocks and links n, whatever the
// diagram holds (unconnected blocks, long chains, a problem on every block): a pass over the
// blocks and one over the links, each signal composed once (its formula bounded in size and
// depth, see the Problems about chains and formulas), each problem compared with the others
// through a hash set.
// `source` names the model's origin in later errors (e.g. the project file).
CompileResult Compile(const BlockDiagram& d, const std::string& source = "");

// An equations-only model as a diagram: one input block per input, one general state block per
// state (in-ports: the other states and inputs its drift reads), a noise block per state with a
// nonzero diffusion, one output block per output (in-ports: the states and inputs its
// observation reads); laid out in columns: inputs, noise, states, outputs. The initial covariance
// and the "ekf" options are carried over.
Result<BlockDiagram> FromModel(const model::ModelSpec& m);

// ---- JSON ------------------------------------------------------------------------------------
//   {"greybench_diagram": 1, "name": ..., "input_hold": "foh", "initial_covariance": "ctsm",
//    "robust_huber": 3, "ekf": {as in a model file}, "parameters": {as in a model file},
//    (initial_covariance: "ctsm", "stationary" or {state: variance expression, ...})
//    "blocks": [{"id": 3, "kind": "lag", "name": "mfv", "K": "1", "tau": "tau_fv", "x0": "0"},
//               {"id": 5, "kind": "sum", "signs": "++"}, {"id": 9, "kind": "delay",
//               "delay": {"min": 0, "max": 10}}, {"id": 10, "kind": "output", "name": "y",
//               "ports": ["a", "b"], "h": "a + b", "variance": "s2"}, ...],
//    "links": [{"id": 12, "from": [3, 0], "to": [5, 0]}, ...],     [block id, port index]
//    "layout": {"3": [120, 40], ...}}
Json ToJson(const BlockDiagram& d);
// Errors name `source` and the JSON path below `path_prefix` (e.g. "diagram.blocks[2].kind").
// Reads the structure only (ids unique, links between existing ports); the rules are Compile's.
Result<BlockDiagram> FromJson(const Json& j, const std::string& source = "",
                              const std::string& path_prefix = "");
Result<BlockDiagram> LoadDiagramFile(const std::string& path);

// A project's diagram: its "diagram" key holds the diagram object inline or the path of a
// diagram file (relative to the project file). Error when the project has no diagram.
Result<BlockDiagram> LoadProjectDiagram(const project::Project& p);

}  // namespace gb::diagram
