// Sections: 1. kinds and ports  2. shared helpers (names, fields, loops)  3. edits
#include "core/diagram/diagram.h"

#include <algorithm>
#include <cctype>

#include <fmt/format.h>

#include "core/diagram/internal.h"

namespace gb::diagram {

// ---- 1. kinds and ports ----------------------------------------------------------------------

namespace {

struct KindInfo {
  BlockKind kind;
  const char* name;
};
constexpr KindInfo kKinds[] = {
    {BlockKind::kInput, "input"},
    {BlockKind::kOutput, "output"},
    {BlockKind::kGain, "gain"},
    {BlockKind::kSum, "sum"},
    {BlockKind::kLag, "lag"},
    {BlockKind::kIntegrator, "integrator"},
    {BlockKind::kState, "state"},
    {BlockKind::kSplit, "split"},
    {BlockKind::kDelay, "delay"},
    {BlockKind::kNoise, "noise"},
    {BlockKind::kProduct, "product"},
    {BlockKind::kQuotient, "quotient"},
    {BlockKind::kFunction, "function"},
    {BlockKind::kOrifice, "orifice"},
    {BlockKind::kSaturation, "saturation"},
};

bool HasModelName(BlockKind k) {
  return k == BlockKind::kInput || k == BlockKind::kOutput || HoldsState(k);
}

bool HasPortNames(BlockKind k) {
  return k == BlockKind::kState || k == BlockKind::kOutput || k == BlockKind::kFunction;
}

}  // namespace

const char* KindName(BlockKind kind) {
  for (const auto& k : kKinds)
    if (k.kind == kind) return k.name;
  return "?";
}

std::optional<BlockKind> KindFromName(const std::string& name) {
  for (const auto& k : kKinds)
    if (name == k.name) return k.kind;
  return std::nullopt;
}

bool HoldsState(BlockKind kind) {
  return kind == BlockKind::kLag || kind == BlockKind::kIntegrator || kind == BlockKind::kState;
}

const std::vector<std::string>& FieldsOf(BlockKind kind) {
  static const std::vector<std::string> kNone;
  static const std::vector<std::string> kOutput = {"h", "variance"};
  static const std::vector<std::string> kGain = {"k"};
  static const std::vector<std::string> kLag = {"K", "tau", "x0"};
  static const std::vector<std::string> kIntegrator = {"k", "x0"};
  static const std::vector<std::string> kState = {"f", "x0"};
  static const std::vector<std::string> kSplit = {"X"};
  static const std::vector<std::string> kNoise = {"sigma"};
  static const std::vector<std::string> kFunction = {"g"};
  static const std::vector<std::string> kOrifice = {"k"};
  static const std::vector<std::string> kSaturation = {"lower", "upper", "width"};
  switch (kind) {
    case BlockKind::kFunction:
      return kFunction;
    case BlockKind::kOrifice:
      return kOrifice;
    case BlockKind::kSaturation:
      return kSaturation;
    case BlockKind::kOutput:
      return kOutput;
    case BlockKind::kGain:
      return kGain;
    case BlockKind::kLag:
      return kLag;
    case BlockKind::kIntegrator:
      return kIntegrator;
    case BlockKind::kState:
      return kState;
    case BlockKind::kSplit:
      return kSplit;
    case BlockKind::kNoise:
      return kNoise;
    default:
      return kNone;
  }
}

Block MakeBlock(BlockKind kind, std::string name) {
  Block b;
  b.kind = kind;
  b.name = std::move(name);
  switch (kind) {
    case BlockKind::kOutput:
      b.ports = {"u"};
      b.fields = {{"h", "u"}, {"variance", ""}};
      break;
    case BlockKind::kGain:
      b.fields = {{"k", "1"}};
      break;
    case BlockKind::kSum:
      b.signs = "++";
      break;
    case BlockKind::kLag:
      b.fields = {{"K", "1"}, {"tau", "1"}, {"x0", "0"}};
      break;
    case BlockKind::kIntegrator:
      b.fields = {{"k", "1"}, {"x0", "0"}};
      break;
    case BlockKind::kState:
      b.fields = {{"f", "0"}, {"x0", "0"}};
      break;
    case BlockKind::kSplit:
      b.fields = {{"X", "0.5"}};
      break;
    case BlockKind::kNoise:
      b.fields = {{"sigma", "1"}};
      break;
    case BlockKind::kFunction:
      b.ports = {"u"};
      b.fields = {{"g", "u"}};
      break;
    case BlockKind::kOrifice:
      b.fields = {{"k", "1"}};
      break;
    case BlockKind::kSaturation:
      b.fields = {{"lower", "0"}, {"upper", "1"}, {"width", "0"}};
      break;
    default:
      break;
  }
  return b;
}

std::vector<PortInfo> InPorts(const Block& b) {
  std::vector<PortInfo> in;
  switch (b.kind) {
    case BlockKind::kInput:
    case BlockKind::kNoise:
      break;
    case BlockKind::kOutput:
      for (const auto& p : b.ports) in.push_back({p, PortType::kSignal, false});
      break;
    case BlockKind::kSum:
      for (std::size_t i = 0; i < b.signs.size(); ++i)
        in.push_back({fmt::format("{}u{}", b.signs[i], i + 1), PortType::kSignal, false});
      break;
    case BlockKind::kLag:
    case BlockKind::kIntegrator:
      in.push_back({"u", PortType::kSignal, false});
      in.push_back({"noise", PortType::kNoise, true});
      break;
    case BlockKind::kState:
      for (const auto& p : b.ports) in.push_back({p, PortType::kSignal, false});
      in.push_back({"noise", PortType::kNoise, true});
      break;
    case BlockKind::kFunction:
      for (const auto& p : b.ports) in.push_back({p, PortType::kSignal, false});
      break;
    case BlockKind::kProduct:
      in.push_back({"u1", PortType::kSignal, false});
      in.push_back({"u2", PortType::kSignal, false});
      break;
    case BlockKind::kQuotient:
      in.push_back({"num", PortType::kSignal, false});
      in.push_back({"den", PortType::kSignal, false});
      break;
    default:
      in.push_back({"u", PortType::kSignal, false});
      break;
  }
  return in;
}

std::vector<PortInfo> OutPorts(const Block& b) {
  switch (b.kind) {
    case BlockKind::kOutput:
      return {};
    case BlockKind::kNoise:
      return {{"noise", PortType::kNoise, false}};
    case BlockKind::kSplit:
      return {{"X", PortType::kSignal, false}, {"1-X", PortType::kSignal, false}};
    default:
      return {{"out", PortType::kSignal, false}};
  }
}

namespace {

std::uint64_t PortKey(const PortRef& p) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(p.block)) << 32) |
         (static_cast<std::uint64_t>(p.side == PortSide::kIn) << 31) |
         (static_cast<std::uint32_t>(p.index) & 0x7fffffffu);
}

// The element `map` puts at `key` when `ok` says it is the one asked for; else, when the index
// is stale (`fresh` false), the first element `ok` accepts, by a scan; else nullptr.
template <class T, class Key, class Ok>
const T* Look(const std::vector<T>& v, const std::unordered_map<Key, std::size_t>& map, Key key,
              bool fresh, Ok ok) {
  if (auto it = map.find(key); it != map.end() && it->second < v.size() && ok(v[it->second]))
    return &v[it->second];
  if (fresh) return nullptr;
  for (const T& e : v)
    if (ok(e)) return &e;
  return nullptr;
}

}  // namespace

const Block* BlockDiagram::FindBlock(int id) const {
  return Look(blocks, index.block, id, index.blocks == blocks.size(),
              [id](const Block& b) { return b.id == id; });
}

const Link* BlockDiagram::FindLink(int id) const {
  return Look(links, index.link, id, index.links == links.size(),
              [id](const Link& l) { return l.id == id; });
}

const Link* BlockDiagram::LinkInto(const PortRef& in) const {
  return Look(links, index.into, PortKey(in), index.links == links.size(),
              [&in](const Link& l) { return l.to == in; });
}

std::vector<const Link*> BlockDiagram::LinksFrom(int block) const {
  std::vector<const Link*> out;
  if (index.links == links.size()) {
    if (auto it = index.from.find(block); it != index.from.end())
      for (std::size_t i : it->second)
        if (i < links.size() && links[i].from.block == block) out.push_back(&links[i]);
    return out;
  }
  for (const Link& l : links)
    if (l.from.block == block) out.push_back(&l);
  return out;
}

void BlockDiagram::AppendedBlock() {
  if (index.blocks + 1 != blocks.size()) return Reindex();
  index.block.emplace(blocks.back().id, blocks.size() - 1);
  index.blocks = blocks.size();
}

void BlockDiagram::AppendedLink() {
  if (index.links + 1 != links.size()) return Reindex();
  index.link.emplace(links.back().id, links.size() - 1);
  index.into.emplace(PortKey(links.back().to), links.size() - 1);
  index.from[links.back().from.block].push_back(links.size() - 1);
  index.links = links.size();
}

void BlockDiagram::Reindex() {
  index.block.clear();
  index.link.clear();
  index.into.clear();
  index.from.clear();
  for (std::size_t i = 0; i < blocks.size(); ++i) index.block.emplace(blocks[i].id, i);
  for (std::size_t i = 0; i < links.size(); ++i) {
    index.link.emplace(links[i].id, i);
    index.into.emplace(PortKey(links[i].to), i);  // the first, as a scan finds it
    index.from[links[i].from.block].push_back(i);
  }
  index.blocks = blocks.size();
  index.links = links.size();
}

// ---- 2. shared helpers -----------------------------------------------------------------------

namespace internal {

bool IsIdentifier(const std::string& s) {
  if (s.empty() || std::isdigit(static_cast<unsigned char>(s[0]))) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

bool IsFunctionName(const std::string& s) {
  static const std::set<std::string> kFunctions = {"exp",  "log", "sqrt", "sin", "cos", "tan",
                                                   "tanh", "abs", "pow",  "min", "max", "sign"};
  return kFunctions.count(s) > 0;
}

std::string BlockLabel(const Block& b) {
  if (b.name.empty()) return fmt::format("block {} ({})", b.id, KindName(b.kind));
  return fmt::format("block {} ({} {})", b.id, KindName(b.kind), b.name);
}

std::string FieldPath(const Block& b, const std::string& field) {
  return fmt::format("block {}.{}", b.id, field);
}

std::set<std::string> AllowedNames(const BlockDiagram& d, const Block& b,
                                   const std::string& field) {
  std::set<std::string> names;
  for (const auto& p : d.parameters) names.insert(p.name);
  if ((b.kind == BlockKind::kState && field == "f") ||
      (b.kind == BlockKind::kOutput && field == "h") ||
      (b.kind == BlockKind::kFunction && field == "g"))
    names.insert(b.ports.begin(), b.ports.end());
  if (b.kind == BlockKind::kState && field == "f") names.insert(b.name);
  return names;
}

Result<expr::ExprPtr> ParseField(const BlockDiagram& d, const Block& b, const std::string& field,
                                 const std::string& text) {
  auto parsed = expr::Parse(text);
  if (!parsed) {
    Error e = parsed.error();
    e.path = FieldPath(b, field);
    return e;
  }
  const std::set<std::string> allowed = AllowedNames(d, b, field);
  std::set<std::string> used;
  expr::CollectNames(*parsed, &used);
  std::set<std::string> unknown;
  for (const auto& n : used)
    if (!allowed.count(n)) unknown.insert(n);
  if (unknown.empty()) return parsed;
  const expr::Node* first = expr::FindFirstVariable(*parsed, unknown);
  const std::string name = first ? first->name : *unknown.begin();
  std::string msg = fmt::format("unknown name '{}'", name);
  if (auto s = model::Suggest(name, {allowed.begin(), allowed.end()}))
    msg += fmt::format(" (did you mean '{}'?)", *s);
  else if (b.kind == BlockKind::kState && field == "f")
    msg += " (f reads parameters, the block's ports and its own state)";
  else if (b.kind == BlockKind::kOutput && field == "h")
    msg += " (h reads parameters and the block's ports)";
  else if (b.kind == BlockKind::kFunction && field == "g")
    msg += " (g reads parameters and the block's ports)";
  else
    msg += " (not a parameter of the diagram)";
  Error e = InputError(msg);
  e.path = FieldPath(b, field);
  e.expr_col = first ? first->column : 0;
  return e;
}

std::string SignsProblem(const std::string& signs) {
  if (signs.empty() || signs.find_first_not_of("+-") != std::string::npos)
    return "a sum needs one '+' or '-' per input, e.g. \"+-\"";
  if (signs.size() > kMaxSumInputs)
    return fmt::format("a sum takes at most {} inputs, not {}", kMaxSumInputs, signs.size());
  return "";
}

bool ClosesAlgebraicLoop(const BlockDiagram& d, int from_block, int to_block) {
  const Block* from = d.FindBlock(from_block);
  const Block* to = d.FindBlock(to_block);
  if (!from || !to || HoldsState(from->kind) || HoldsState(to->kind)) return false;
  // Search forward from `to` through stateless blocks; reaching `from` closes the loop.
  std::vector<int> stack = {to_block};
  std::set<int> seen;
  while (!stack.empty()) {
    const int id = stack.back();
    stack.pop_back();
    if (id == from_block) return true;
    if (!seen.insert(id).second) continue;
    for (const Link* l : d.LinksFrom(id)) {
      const Block* next = d.FindBlock(l->to.block);
      if (next && !HoldsState(next->kind)) stack.push_back(next->id);
    }
  }
  return false;
}

Json DelayJson(const model::DelaySpec& d) {
  if (d.IsScan()) return {{"min", d.min}, {"max", d.max}};
  return d.min;
}

Json InitialCovarianceJson(const BlockDiagram& d) {
  switch (d.initial_covariance) {
    case model::InitialCovariance::kStationary:
      return "stationary";
    case model::InitialCovariance::kExplicit: {
      Json j = Json::object();
      for (const auto& [state, variance] : d.initial_variance) j[state] = variance;
      return j;
    }
    case model::InitialCovariance::kCtsm:
      break;
  }
  return "ctsm";
}

}  // namespace internal

// ---- 3. edits --------------------------------------------------------------------------------

namespace {

using internal::BlockLabel;

Error Refuse(const std::string& path, std::string message) {
  Error e = InputError(std::move(message));
  e.path = path;
  return e;
}

Block* FindMutable(BlockDiagram* d, int id) {
  return const_cast<Block*>(d->FindBlock(id));  // NOLINT: d is not const
}

Error NoSuchBlock(int id) { return Refuse("", fmt::format("there is no block {}", id)); }

// A model name for block `b` (ignoring block `self`): an identifier, not a function, and unique in
// its namespace (outputs among outputs; inputs, states and parameters together).
Status CheckModelName(const BlockDiagram& d, const Block& b, const std::string& name, int self) {
  const std::string path = fmt::format("block {}.name", b.id);
  if (!internal::IsIdentifier(name))
    return Refuse(path, fmt::format("'{}' is not a valid name (letters, digits and _, not "
                                    "starting with a digit)",
                                    name));
  if (internal::IsFunctionName(name))
    return Refuse(path, fmt::format("'{}' is the name of a function", name));
  const bool is_output = b.kind == BlockKind::kOutput;
  for (const auto& other : d.blocks) {
    if (other.id == self || !HasModelName(other.kind) || other.name != name) continue;
    if ((other.kind == BlockKind::kOutput) != is_output) continue;
    return Refuse(path, fmt::format("'{}' is already the name of {}", name, BlockLabel(other)));
  }
  if (!is_output)
    for (const auto& p : d.parameters)
      if (p.name == name) return Refuse(path, fmt::format("'{}' is already a parameter", name));
  return Ok{};
}

Status CheckPortNames(const BlockDiagram& d, const Block& b) {
  std::set<std::string> seen;
  for (const auto& p : b.ports) {
    const std::string path = fmt::format("block {}.ports", b.id);
    if (!internal::IsIdentifier(p) || internal::IsFunctionName(p))
      return Refuse(path, fmt::format("'{}' is not a valid port name", p));
    if (!seen.insert(p).second) return Refuse(path, fmt::format("port '{}' is listed twice", p));
    if (b.kind == BlockKind::kState && p == b.name)
      return Refuse(path, fmt::format("port '{}' has the name of the block's own state", p));
    for (const auto& par : d.parameters)
      if (par.name == p) return Refuse(path, fmt::format("port '{}' has a parameter's name", p));
  }
  return Ok{};
}

Status CheckBlock(const BlockDiagram& d, const Block& b, int self) {
  if (HasModelName(b.kind)) {
    if (auto s = CheckModelName(d, b, b.name, self); !s) return s;
  }
  if (HasPortNames(b.kind)) {
    if (auto s = CheckPortNames(d, b); !s) return s;
  }
  for (const auto& [field, text] : b.fields) {
    const auto& known = FieldsOf(b.kind);
    if (std::find(known.begin(), known.end(), field) == known.end())
      return Refuse(internal::FieldPath(b, field),
                    fmt::format("a {} block has no field '{}'", KindName(b.kind), field));
    if (text.empty()) continue;  // not set yet: Compile reports it
    if (auto e = internal::ParseField(d, b, field, text); !e) return e.error();
  }
  if (b.kind == BlockKind::kSum) {
    if (auto why = internal::SignsProblem(b.signs); !why.empty())
      return Refuse(fmt::format("block {}.signs", b.id), why);
  }
  if (b.delay.min < 0 || b.delay.max < b.delay.min)
    return Refuse(
        fmt::format("block {}.delay", b.id),
        fmt::format("the delay range [{}, {}] is not 0 <= min <= max", b.delay.min, b.delay.max));
  return Ok{};
}

}  // namespace

Result<int> AddBlock(BlockDiagram* d, Block block, std::array<double, 2> position) {
  block.id = d->next_id;
  if (auto s = CheckBlock(*d, block, block.id); !s) return s.error();
  ++d->next_id;
  d->layout.positions[block.id] = position;
  d->blocks.push_back(std::move(block));
  d->AppendedBlock();
  return d->blocks.back().id;
}

Status RemoveBlock(BlockDiagram* d, int block) {
  auto it = std::find_if(d->blocks.begin(), d->blocks.end(),
                         [&](const Block& b) { return b.id == block; });
  if (it == d->blocks.end()) return NoSuchBlock(block);
  if (HoldsState(it->kind)) d->initial_variance.erase(it->name);
  d->blocks.erase(it);
  std::erase_if(d->links,
                [&](const Link& l) { return l.from.block == block || l.to.block == block; });
  d->layout.positions.erase(block);
  d->Reindex();
  return Ok{};
}

Result<int> Connect(BlockDiagram* d, PortRef from, PortRef to) {
  if (from.side != PortSide::kOut || to.side != PortSide::kIn)
    return Refuse("", from.side == PortSide::kIn && to.side == PortSide::kIn
                          ? "cannot link an in-port to an in-port: a link runs from an out-port"
                      : from.side == PortSide::kOut && to.side == PortSide::kOut
                          ? "cannot link an out-port to an out-port: a link ends at an in-port"
                          : "a link runs from an out-port to an in-port");
  const Block* a = d->FindBlock(from.block);
  const Block* b = d->FindBlock(to.block);
  if (!a) return NoSuchBlock(from.block);
  if (!b) return NoSuchBlock(to.block);
  const auto outs = OutPorts(*a);
  const auto ins = InPorts(*b);
  if (from.index < 0 || from.index >= static_cast<int>(outs.size()))
    return Refuse("", fmt::format("{} has no out-port {}", BlockLabel(*a), from.index));
  if (to.index < 0 || to.index >= static_cast<int>(ins.size()))
    return Refuse("", fmt::format("{} has no in-port {}", BlockLabel(*b), to.index));
  const PortInfo& out = outs[from.index];
  const PortInfo& in = ins[to.index];
  if (out.type != in.type)
    return Refuse("", out.type == PortType::kNoise
                          ? fmt::format("a noise block attaches only to the noise port of a lag, "
                                        "integrator or state block, not to '{}' of {}",
                                        in.name, BlockLabel(*b))
                          : fmt::format("the noise port of {} takes a noise block, not a signal",
                                        BlockLabel(*b)));
  if (const Link* held = d->LinkInto(to)) {
    const Block* src = d->FindBlock(held->from.block);
    return Refuse("", fmt::format("in-port '{}' of {} is already connected (from {}); an in-port "
                                  "takes one link",
                                  in.name, BlockLabel(*b), src ? BlockLabel(*src) : "?"));
  }
  if (a->kind == BlockKind::kDelay && b->kind != BlockKind::kOutput)
    return Refuse("", fmt::format("{} may only feed output blocks: a transport delay sits "
                                  "directly in front of a sensor, not in front of {}",
                                  BlockLabel(*a), BlockLabel(*b)));
  if (out.type == PortType::kSignal && internal::ClosesAlgebraicLoop(*d, a->id, b->id))
    return Refuse("", fmt::format("linking {} to {} closes an algebraic loop (a cycle with no "
                                  "lag, integrator or state block on it)",
                                  BlockLabel(*a), BlockLabel(*b)));
  Link l;
  l.id = d->next_id++;
  l.from = from;
  l.to = to;
  d->links.push_back(l);
  d->AppendedLink();
  return l.id;
}

Status Disconnect(BlockDiagram* d, int link) {
  const auto n = std::erase_if(d->links, [&](const Link& l) { return l.id == link; });
  if (n == 0) return Refuse("", fmt::format("there is no link {}", link));
  d->Reindex();
  return Ok{};
}

Status SetBlockParameter(BlockDiagram* d, int block, const std::string& field,
                         const std::string& text) {
  Block* b = FindMutable(d, block);
  if (!b) return NoSuchBlock(block);
  const auto& known = FieldsOf(b->kind);
  if (std::find(known.begin(), known.end(), field) == known.end())
    return Refuse(internal::FieldPath(*b, field),
                  fmt::format("a {} block has no field '{}'", KindName(b->kind), field));
  if (!text.empty()) {
    if (auto e = internal::ParseField(*d, *b, field, text); !e) return e.error();
  }
  b->fields[field] = text;
  return Ok{};
}

Status RenameBlock(BlockDiagram* d, int block, const std::string& name) {
  Block* b = FindMutable(d, block);
  if (!b) return NoSuchBlock(block);
  if (HasModelName(b->kind)) {
    if (auto s = CheckModelName(*d, *b, name, b->id); !s) return s;
  }
  Block renamed = *b;
  renamed.name = name;
  if (b->kind == BlockKind::kState) {  // f reads the state by name
    if (auto s = CheckBlock(*d, renamed, b->id); !s)
      return Refuse(s.error().path, s.error().message + " (rename the state in f as well)");
  }
  if (HoldsState(b->kind)) {  // the state's initial variance goes with its name
    if (auto v = d->initial_variance.extract(b->name)) {
      v.key() = name;
      d->initial_variance.insert(std::move(v));
    }
  }
  b->name = name;
  return Ok{};
}

Status SetDelay(BlockDiagram* d, int block, model::DelaySpec delay) {
  Block* b = FindMutable(d, block);
  if (!b) return NoSuchBlock(block);
  if (b->kind != BlockKind::kDelay && b->kind != BlockKind::kOutput)
    return Refuse(fmt::format("block {}.delay", block),
                  fmt::format("{} has no delay (only delay and output blocks do)", BlockLabel(*b)));
  if (delay.min < 0 || delay.max < delay.min)
    return Refuse(
        fmt::format("block {}.delay", block),
        fmt::format("the delay range [{}, {}] is not 0 <= min <= max", delay.min, delay.max));
  b->delay = delay;
  return Ok{};
}

Status SetPortNames(BlockDiagram* d, int block, const std::vector<std::string>& ports) {
  Block* b = FindMutable(d, block);
  if (!b) return NoSuchBlock(block);
  if (!HasPortNames(b->kind))
    return Refuse(
        fmt::format("block {}.ports", block),
        BlockLabel(*b) + " has fixed ports (only state, output and function blocks name theirs)");
  Block renamed = *b;
  renamed.ports = ports;
  if (auto s = CheckBlock(*d, renamed, b->id); !s) return s;
  const int old_count = static_cast<int>(b->ports.size());
  const int new_count = static_cast<int>(ports.size());
  // A state block's noise port is the last in-port: it moves with the count.
  std::erase_if(d->links, [&](const Link& l) {
    return l.to.block == block && l.to.index >= new_count && l.to.index < old_count;
  });
  if (b->kind == BlockKind::kState)
    for (auto& l : d->links)
      if (l.to.block == block && l.to.index == old_count) l.to.index = new_count;
  b->ports = ports;
  d->Reindex();
  return Ok{};
}

Status SetSumSigns(BlockDiagram* d, int block, const std::string& signs) {
  Block* b = FindMutable(d, block);
  if (!b) return NoSuchBlock(block);
  if (b->kind != BlockKind::kSum)
    return Refuse(fmt::format("block {}.signs", block), BlockLabel(*b) + " is not a sum");
  if (auto why = internal::SignsProblem(signs); !why.empty())
    return Refuse(fmt::format("block {}.signs", block), why);
  b->signs = signs;
  const int n = static_cast<int>(signs.size());
  std::erase_if(d->links, [&](const Link& l) { return l.to.block == block && l.to.index >= n; });
  d->Reindex();
  return Ok{};
}

Status SetParameterEntry(BlockDiagram* d, model::Parameter parameter) {
  const std::string path = "parameters." + parameter.name;
  if (!internal::IsIdentifier(parameter.name) || internal::IsFunctionName(parameter.name))
    return Refuse(path, fmt::format("'{}' is not a valid parameter name", parameter.name));
  if (parameter.lower && parameter.upper && *parameter.lower > *parameter.upper)
    return Refuse(path, "the bounds are inverted");
  if ((parameter.lower && parameter.value < *parameter.lower) ||
      (parameter.upper && parameter.value > *parameter.upper))
    return Refuse(path + ".value", "the value is outside the bounds");
  for (const auto& b : d->blocks) {
    if (b.kind != BlockKind::kOutput && HasModelName(b.kind) && b.name == parameter.name)
      return Refuse(path,
                    fmt::format("'{}' is already the name of {}", parameter.name, BlockLabel(b)));
    for (const auto& p : b.ports)
      if (p == parameter.name)
        return Refuse(
            path, fmt::format("'{}' is the name of a port of {}", parameter.name, BlockLabel(b)));
  }
  for (auto& p : d->parameters) {
    if (p.name == parameter.name) {
      p = std::move(parameter);
      return Ok{};
    }
  }
  d->parameters.push_back(std::move(parameter));
  return Ok{};
}

Status Move(BlockDiagram* d, int block, std::array<double, 2> position) {
  if (!d->FindBlock(block)) return NoSuchBlock(block);
  d->layout.positions[block] = position;
  return Ok{};
}

}  // namespace gb::diagram
