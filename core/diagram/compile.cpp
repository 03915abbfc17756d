// Sections: 1. expression building  2. the compiler (structure, signals, equations, model)
//           3. Compile  4. FromModel
#include <algorithm>
#include <map>
#include <set>
#include <unordered_set>

#include <fmt/format.h>

#include "core/diagram/diagram.h"
#include "core/diagram/internal.h"
#include "core/expr/expr.h"
#include "core/model/linear_model.h"
#include "core/model/nonlinear_model.h"

namespace gb::diagram {

std::string Problem::ToString() const {
  std::string out = block == 0 ? "diagram" : fmt::format("block {}", block);
  if (in_port >= 0) out += fmt::format(", in-port {}", in_port);
  if (!field.empty()) out += "." + field;
  if (expr_col > 0) out += fmt::format(", column {}", expr_col);
  return out + ": " + message;
}

std::string CompileResult::Message() const {
  std::string out;
  for (const auto& p : problems) out += p.ToString() + "\n";
  return out;
}

namespace {

// ---- 1. expression building ------------------------------------------------------------------

using expr::ExprPtr;
using expr::Node;
using expr::Op;

ExprPtr Binary(Op op, ExprPtr a, ExprPtr b) {
  auto n = std::make_shared<Node>();
  n->op = op;
  n->args = {std::move(a), std::move(b)};
  return n;
}

ExprPtr Call(expr::Func f, std::vector<ExprPtr> args) {
  auto n = std::make_shared<Node>();
  n->op = Op::kCall;
  n->func = f;
  n->args = std::move(args);
  return n;
}

// Replaces every variable named in `by` at once (so a replacement is never substituted again).
ExprPtr SubstituteAll(const ExprPtr& e, const std::map<std::string, ExprPtr>& by) {
  if (e->op == Op::kVar) {
    auto it = by.find(e->name);
    return it == by.end() ? e : it->second;
  }
  if (e->args.empty()) return e;
  auto n = std::make_shared<Node>(*e);
  for (auto& a : n->args) a = SubstituteAll(a, by);
  return n;
}

std::string Text(const ExprPtr& e) { return expr::ToString(expr::Simplify(e)); }

// ---- 2. the compiler -------------------------------------------------------------------------

class Compiler {
 public:
  explicit Compiler(const BlockDiagram& d) : d_(d) {}

  std::vector<Problem> problems;

  void Report(const Block& b, std::string message, int in_port = -1, std::string field = "",
              int expr_col = 0) {
    Problem p;
    p.block = b.id;
    p.in_port = in_port;
    p.field = std::move(field);
    p.expr_col = expr_col;
    p.message = std::move(message);
    problems.push_back(std::move(p));
  }
  void ReportDiagram(std::string message) {
    Problem p;
    p.message = std::move(message);
    problems.push_back(std::move(p));
  }

  // Links, names and ports: everything that does not need expressions.
  void CheckStructure() {
    std::map<std::string, const Block*> shared_names;  // inputs, states
    std::map<std::string, const Block*> output_names;
    std::set<std::string> params;
    for (const auto& p : d_.parameters) params.insert(p.name);
    // Links into each in-port (block, index), counted once: a scan per port was O(ports × links).
    std::map<std::pair<int, int>, int> into;
    for (const auto& l : d_.links)
      if (l.to.side == PortSide::kIn) ++into[{l.to.block, l.to.index}];
    for (const auto& b : d_.blocks) {
      const bool named =
          b.kind == BlockKind::kInput || b.kind == BlockKind::kOutput || HoldsState(b.kind);
      if (named) {
        if (!internal::IsIdentifier(b.name) || internal::IsFunctionName(b.name)) {
          Report(b,
                 fmt::format("'{}' is not a valid name for a model {}", b.name,
                             b.kind == BlockKind::kInput    ? "input"
                             : b.kind == BlockKind::kOutput ? "output"
                                                            : "state"),
                 -1, "name");
        } else {
          auto& space = b.kind == BlockKind::kOutput ? output_names : shared_names;
          if (auto [it, fresh] = space.emplace(b.name, &b); !fresh)
            Report(b,
                   fmt::format("'{}' is also the name of {}", b.name,
                               internal::BlockLabel(*it->second)),
                   -1, "name");
          else if (b.kind != BlockKind::kOutput && params.count(b.name))
            Report(b, fmt::format("'{}' is also a parameter", b.name), -1, "name");
        }
      }
      if (b.kind == BlockKind::kSum &&
          (b.signs.empty() || b.signs.find_first_not_of("+-") != std::string::npos))
        Report(b, "a sum needs one '+' or '-' per input", -1, "signs");
      const auto ins = InPorts(b);
      for (std::size_t i = 0; i < ins.size(); ++i) {
        const auto counted = into.find({b.id, static_cast<int>(i)});
        const int n = counted == into.end() ? 0 : counted->second;
        if (n == 0 && !ins[i].optional)
          Report(b, fmt::format("in-port '{}' is not connected", ins[i].name), static_cast<int>(i));
        if (n > 1)
          Report(b,
                 fmt::format("in-port '{}' holds {} links (an in-port takes one)", ins[i].name, n),
                 static_cast<int>(i));
      }
    }
    for (const auto& l : d_.links) {
      const Block* a = d_.FindBlock(l.from.block);
      const Block* b = d_.FindBlock(l.to.block);
      if (!a || !b) {
        ReportDiagram(fmt::format("link {} joins a block that does not exist", l.id));
        continue;
      }
      const auto outs = OutPorts(*a);
      const auto ins = InPorts(*b);
      if (l.from.side != PortSide::kOut || l.to.side != PortSide::kIn || l.from.index < 0 ||
          l.from.index >= static_cast<int>(outs.size()) || l.to.index < 0 ||
          l.to.index >= static_cast<int>(ins.size())) {
        Report(*b, fmt::format("link {} joins a port that does not exist", l.id));
        continue;
      }
      if (outs[l.from.index].type != ins[l.to.index].type)
        Report(*b, fmt::format("link {} joins a noise port to a signal port", l.id), l.to.index);
      if (a->kind == BlockKind::kDelay && b->kind != BlockKind::kOutput)
        Report(*a, fmt::format("a delay may only sit directly in front of an output (a sensor), "
                               "but it feeds {}",
                               internal::BlockLabel(*b)));
    }
    if (shared_names.empty() || std::none_of(d_.blocks.begin(), d_.blocks.end(),
                                             [](const Block& b) { return HoldsState(b.kind); }))
      ReportDiagram("the diagram has no lag, integrator or state block: a model needs a state");
    if (output_names.empty()) ReportDiagram("the diagram has no output block");
    std::size_t states = 0, inputs = 0, outputs = 0;
    for (const auto& b : d_.blocks) {
      states += HoldsState(b.kind);
      inputs += b.kind == BlockKind::kInput;
      outputs += b.kind == BlockKind::kOutput;
    }
    for (const auto& [count, what] :
         {std::pair{states, "lag, integrator and state blocks"}, std::pair{inputs, "input blocks"},
          std::pair{outputs, "output blocks"}})
      if (count > kMaxModelSize)
        ReportDiagram(fmt::format("the diagram has {} {}: a model takes at most {}", count, what,
                                  kMaxModelSize));
  }

  // A field's expression (parsed, names checked), or nullptr after reporting why not.
  ExprPtr Field(const Block& b, const std::string& field, const char* missing) {
    auto it = b.fields.find(field);
    if (it == b.fields.end() || it->second.empty()) {
      Report(b, missing, -1, field);
      return nullptr;
    }
    auto e = internal::ParseField(d_, b, field, it->second);
    if (!e) {
      Report(b, e.error().message, -1, field, e.error().expr_col);
      return nullptr;
    }
    return *e;
  }

  // The signal arriving at an in-port (nullptr if it cannot be formed; reported elsewhere).
  ExprPtr InSignal(const Block& b, int index) {
    const Link* l = d_.LinkInto(In(b.id, index));
    if (!l) return nullptr;
    return Signal(l->from.block, l->from.index);
  }

  // The signal at an out-port, composed backwards along the links.
  ExprPtr Signal(int block, int out) {
    const auto key = std::make_pair(block, out);
    if (auto it = signals_.find(key); it != signals_.end()) return it->second;
    const Block* b = d_.FindBlock(block);
    if (!b) return nullptr;
    if (b->kind == BlockKind::kInput || HoldsState(b->kind)) return expr::Variable(b->name);
    if (visiting_.count(block)) {
      if (loop_reported_.insert(block).second)
        Report(*b,
               "this block is on an algebraic loop (a cycle with no lag, integrator or state "
               "block on it)");
      return nullptr;
    }
    // Composing recurses once per block along the chain, and the formula grows with it: a chain
    // from a hostile file could overflow the stack. Real diagrams are a few blocks deep.
    if (visiting_.size() >= kMaxChain) {
      if (!chain_reported_) {
        chain_reported_ = true;
        Report(*b, fmt::format("the signal here passes through more than {} blocks from the "
                               "nearest input or state: the chain is too long to compile",
                               kMaxChain));
      }
      return nullptr;
    }
    visiting_.insert(block);
    ExprPtr s = Compose(*b, out);
    visiting_.erase(block);
    if (s && TooLarge(*b, s)) s = nullptr;
    if (s) s = expr::Simplify(s);
    signals_[key] = s;
    return s;
  }

  // Whether `e`, formed at block `b`, is too large a formula to go on with (then reported on b).
  // Every walk of a tree recurses once per level, and a shared signal (a split feeding both
  // inputs of a sum, stage after stage) is written out in full wherever it is used.
  bool TooLarge(const Block& b, const ExprPtr& e) {
    const expr::Extent x = expr::Measure(e);
    if (x.height <= expr::kMaxHeight && x.nodes <= kMaxNodes) return false;
    Report(b, x.height > expr::kMaxHeight
                  ? fmt::format("the formula here is more than {} levels of operations tall: the "
                                "chain of blocks before it is too long to compile",
                                expr::kMaxHeight)
                  : fmt::format("the formula here, written out, has more than {} operations: the "
                                "blocks before it use the same signals too many times over",
                                kMaxNodes));
    return true;
  }

  ExprPtr Compose(const Block& b, int out) {
    switch (b.kind) {
      case BlockKind::kGain: {
        ExprPtr u = InSignal(b, 0);
        ExprPtr k = Field(b, "k", "the gain k is not set");
        return u && k ? Binary(Op::kMul, k, u) : nullptr;
      }
      case BlockKind::kSum: {
        ExprPtr total;
        bool ok = true;
        for (std::size_t i = 0; i < b.signs.size(); ++i) {
          ExprPtr u = InSignal(b, static_cast<int>(i));
          if (!u) {
            ok = false;
            continue;
          }
          if (!total)
            total = b.signs[i] == '-' ? Binary(Op::kSub, expr::Constant(0), u) : u;
          else
            total = Binary(b.signs[i] == '-' ? Op::kSub : Op::kAdd, total, u);
        }
        return ok ? total : nullptr;
      }
      case BlockKind::kSplit: {
        ExprPtr u = InSignal(b, 0);
        ExprPtr x = Field(b, "X", "the split fraction X is not set");
        if (!u || !x) return nullptr;
        ExprPtr gain = out == 0 ? x : Binary(Op::kSub, expr::Constant(1), x);
        return Binary(Op::kMul, gain, u);
      }
      case BlockKind::kDelay:
        return InSignal(b, 0);
      case BlockKind::kProduct:
      case BlockKind::kQuotient: {
        ExprPtr a = InSignal(b, 0);
        ExprPtr c = InSignal(b, 1);
        if (!a || !c) return nullptr;
        return Binary(b.kind == BlockKind::kProduct ? Op::kMul : Op::kDiv, a, c);
      }
      case BlockKind::kFunction: {
        ExprPtr g = Field(b, "g", "the function g is not set");
        auto by = PortSignals(b);
        if (!g || !by) return nullptr;
        return SubstituteAll(g, *by);
      }
      case BlockKind::kOrifice: {
        ExprPtr u = InSignal(b, 0);
        ExprPtr k = Field(b, "k", "the orifice coefficient k is not set");
        if (!u || !k) return nullptr;
        return Binary(Op::kMul, k,
                      Call(expr::Func::kSqrt, {Call(expr::Func::kMax, {u, expr::Constant(0)})}));
      }
      case BlockKind::kSaturation:
        return Saturate(b);
      default:
        return nullptr;  // outputs and noise blocks have no signal out-port
    }
  }

  // lower + w log(1 + e^{(u-lower)/w}) - w log(1 + e^{(u-upper)/w}), or min(max(u, lower), upper)
  // when the width w is the constant 0.
  ExprPtr Saturate(const Block& b) {
    ExprPtr u = InSignal(b, 0);
    ExprPtr lo = Field(b, "lower", "the lower limit is not set");
    ExprPtr hi = Field(b, "upper", "the upper limit is not set");
    ExprPtr w = Field(b, "width", "the width is not set (0 for a sharp saturation)");
    if (!u || !lo || !hi || !w) return nullptr;
    double width = 0.0;
    if (expr::IsConstant(expr::Simplify(w), &width) && width == 0.0)
      return Call(expr::Func::kMin, {Call(expr::Func::kMax, {u, lo}), hi});
    auto softplus = [&](const ExprPtr& limit) {  // w log(1 + e^{(u - limit)/w})
      ExprPtr arg = Binary(Op::kDiv, Binary(Op::kSub, u, limit), w);
      return Binary(Op::kMul, w,
                    Call(expr::Func::kLog,
                         {Binary(Op::kAdd, expr::Constant(1), Call(expr::Func::kExp, {arg}))}));
    };
    return Binary(Op::kSub, Binary(Op::kAdd, lo, softplus(lo)), softplus(hi));
  }

  // dx/dt of a state block (without noise).
  ExprPtr Drift(const Block& b) {
    const ExprPtr x = expr::Variable(b.name);
    switch (b.kind) {
      case BlockKind::kLag: {
        ExprPtr u = InSignal(b, 0);
        ExprPtr K = Field(b, "K", "the gain K is not set");
        ExprPtr tau = Field(b, "tau", "the time constant tau is not set");
        if (!u || !K || !tau) return nullptr;
        return Binary(Op::kDiv, Binary(Op::kSub, Binary(Op::kMul, K, u), x), tau);
      }
      case BlockKind::kIntegrator: {
        ExprPtr u = InSignal(b, 0);
        ExprPtr k = Field(b, "k", "the gain k is not set");
        if (!u || !k) return nullptr;
        return Binary(Op::kMul, k, u);
      }
      case BlockKind::kState: {
        ExprPtr f = Field(b, "f", "the drift f is not set");
        auto by = PortSignals(b);
        if (!f || !by) return nullptr;
        return SubstituteAll(f, *by);
      }
      default:
        return nullptr;
    }
  }

  // Each named in-port of a state or output block -> the signal arriving there.
  std::optional<std::map<std::string, ExprPtr>> PortSignals(const Block& b) {
    std::map<std::string, ExprPtr> by;
    bool ok = true;
    for (std::size_t i = 0; i < b.ports.size(); ++i) {
      ExprPtr s = InSignal(b, static_cast<int>(i));
      if (!s) ok = false;
      by[b.ports[i]] = s;
    }
    if (!ok) return std::nullopt;
    return by;
  }

  ExprPtr Observation(const Block& b) {
    ExprPtr h = Field(b, "h", "the observation h is not set");
    auto by = PortSignals(b);
    if (!h || !by) return nullptr;
    return SubstituteAll(h, *by);
  }

  // The output's delay: a delay block in front of every port (all the same), or its own.
  std::optional<model::DelaySpec> Delay(const Block& b) {
    std::optional<model::DelaySpec> via_block;
    bool direct = false;
    for (std::size_t i = 0; i < b.ports.size(); ++i) {
      const Link* l = d_.LinkInto(In(b.id, static_cast<int>(i)));
      const Block* src = l ? d_.FindBlock(l->from.block) : nullptr;
      if (!src) continue;
      if (src->kind != BlockKind::kDelay) {
        direct = true;
        continue;
      }
      if (via_block && (via_block->min != src->delay.min || via_block->max != src->delay.max)) {
        Report(b, "the delay blocks in front of this output differ (an output has one delay)");
        return std::nullopt;
      }
      via_block = src->delay;
    }
    if (!via_block) return b.delay;
    if (direct) {
      Report(b,
             "some in-ports of this output come through a delay block and some do not (the "
             "delay applies to the whole output)");
      return std::nullopt;
    }
    if (b.delay.min != 0 || b.delay.max != 0) {
      Report(b, "this output has a delay of its own and a delay block in front of it");
      return std::nullopt;
    }
    return via_block;
  }

 private:
  const BlockDiagram& d_;
  std::map<std::pair<int, int>, ExprPtr> signals_;
  static constexpr std::size_t kMaxChain = 256;
  static constexpr std::size_t kMaxNodes = 100'000;
  std::set<int> visiting_;
  std::set<int> loop_reported_;
  bool chain_reported_ = false;
};

// Maps a model error ("drift.mfv", "observation.y") back to the block it came from.
Problem ProblemFromModelError(const BlockDiagram& d, const Error& e) {
  Problem p;
  p.message = e.message;
  p.expr_col = 0;  // the column is in the composed equation, not in a field the user typed
  const auto dot = e.path.find('.');
  if (dot != std::string::npos) {
    const std::string key = e.path.substr(0, dot);
    const std::string name = e.path.substr(dot + 1);
    const bool about_output =
        key == "observation" || key == "measurement_variance" || key == "output_delay";
    for (const auto& b : d.blocks) {
      if (b.name != name) continue;
      if (about_output ? b.kind == BlockKind::kOutput : HoldsState(b.kind)) p.block = b.id;
    }
    p.message = fmt::format("{}: {}", e.path, e.message);
  }
  return p;
}

}  // namespace

// ---- 3. Compile ------------------------------------------------------------------------------

CompileResult Compile(const BlockDiagram& d, const std::string& source) {
  CompileResult result;
  Compiler c(d);
  c.CheckStructure();

  // The model file's entries by name, in block order. Kept in lists until every block is checked:
  // a JSON object looks a name up by a scan, which would make this loop quadratic in the blocks.
  using Entries = std::vector<std::pair<std::string, std::string>>;
  Entries drift, diffusion, initial, observation, variance;
  std::vector<std::pair<std::string, Json>> delays;
  std::vector<std::string> states, inputs, outputs;
  for (const auto& b : d.blocks) {
    if (b.kind == BlockKind::kInput) inputs.push_back(b.name);
    if (HoldsState(b.kind)) {
      states.push_back(b.name);
      if (ExprPtr f = c.Drift(b); f && !c.TooLarge(b, f)) drift.emplace_back(b.name, Text(f));
      if (ExprPtr x0 = c.Field(b, "x0", "the initial state x0 is not set"))
        initial.emplace_back(b.name, Text(x0));
    } else if (b.kind == BlockKind::kOutput) {
      outputs.push_back(b.name);
      if (ExprPtr h = c.Observation(b); h && !c.TooLarge(b, h))
        observation.emplace_back(b.name, Text(h));
      if (ExprPtr s = c.Field(b, "variance", "the output has no measurement variance"))
        variance.emplace_back(b.name, Text(s));
      if (auto delay = c.Delay(b); delay && (delay->min != 0 || delay->max != 0))
        delays.emplace_back(b.name, internal::DelayJson(*delay));
    } else if (b.kind == BlockKind::kNoise) {
      ExprPtr sigma = c.Field(b, "sigma", "the noise intensity sigma is not set");
      bool attached = false;
      for (const Link* l : d.LinksFrom(b.id)) {
        const Block* target = d.FindBlock(l->to.block);
        if (!target || !HoldsState(target->kind)) continue;
        attached = true;
        if (sigma) diffusion.emplace_back(target->name, Text(sigma));
      }
      if (!attached) c.Report(b, "this noise block is attached to no state");
    } else if (b.kind == BlockKind::kDelay) {
      if (d.LinksFrom(b.id).empty())
        c.Report(b, "this delay feeds nothing: a delay sits directly in front of an output");
    } else {
      for (int k = 0; k < static_cast<int>(OutPorts(b).size()); ++k) c.Signal(b.id, k);
    }
  }
  if (!c.problems.empty()) {
    std::unordered_set<std::string> seen;  // a field read by two out-ports is reported once
    for (auto& p : c.problems)
      if (seen.insert(p.ToString()).second) result.problems.push_back(std::move(p));
    return result;
  }

  // No problem: the names are unique (CheckStructure) and at most kMaxModelSize of each kind.
  auto object = [](const auto& entries) {
    Json o = Json::object();
    for (const auto& [name, value] : entries) o[name] = value;
    return o;
  };
  Json j;
  j["greybench_model"] = 1;
  if (!d.name.empty()) j["name"] = d.name;
  j["states"] = states;
  j["inputs"] = inputs;
  j["outputs"] = outputs;
  j["parameters"] = model::ParametersToJson(d.parameters);
  j["drift"] = object(drift);
  j["diffusion"] = object(diffusion);
  j["observation"] = object(observation);
  j["measurement_variance"] = object(variance);
  if (!delays.empty()) j["output_delay"] = object(delays);
  j["initial_state"] = object(initial);
  j["initial_covariance"] = internal::InitialCovarianceJson(d);
  j["input_hold"] = d.input_hold == model::InputHold::kFoh ? "foh" : "zoh";
  if (d.robust_huber) j["robust_huber"] = *d.robust_huber;
  if (!d.ekf.is_null()) j["ekf"] = d.ekf;

  auto spec = model::ParseModel(j, source);
  if (!spec) {
    result.problems.push_back(ProblemFromModelError(d, spec.error()));
    return result;
  }
  // Round trip through the file form, as a saved model would be read.
  auto reread = model::ParseModel(model::ToJson(*spec), source);
  if (!reread) {
    result.problems.push_back(ProblemFromModelError(d, reread.error()));
    return result;
  }
  // A linear model compiles for the exact filter; any other for the extended one (the state
  // block's f may be nonlinear), which refuses only expressions too deep to compile.
  if (!model::LinearModel::Compile(*reread)) {
    if (auto nonlinear = model::NonlinearModel::Compile(*reread); !nonlinear) {
      result.problems.push_back(ProblemFromModelError(d, nonlinear.error()));
      return result;
    }
  }
  result.model = std::move(*reread);
  return result;
}

// ---- 4. FromModel ----------------------------------------------------------------------------

Result<BlockDiagram> FromModel(const model::ModelSpec& m) {
  constexpr double kColumn = 220.0;
  constexpr double kRow = 120.0;
  BlockDiagram d;
  d.name = m.name;
  d.parameters = m.parameters;
  d.input_hold = m.input_hold;
  d.initial_covariance = m.initial_covariance;
  if (m.initial_covariance == model::InitialCovariance::kExplicit) {
    for (std::size_t i = 0; i < m.states.size() && i < m.initial_variance.size(); ++i)
      d.initial_variance[m.states[i]] = m.initial_variance[i].text;
  }
  d.robust_huber = m.robust_huber;
  if (m.ekf != model::EkfOptions{}) d.ekf = model::ToJson(m)["ekf"];

  // What reads what: the states and inputs (in model order) an expression uses, except `self`.
  auto reads = [&](const model::Formula& f, const std::string& self) {
    std::set<std::string> used;
    expr::CollectNames(f.expr, &used);
    std::vector<std::string> out;
    for (const auto& s : m.states)
      if (s != self && used.count(s)) out.push_back(s);
    for (const auto& u : m.inputs)
      if (used.count(u)) out.push_back(u);
    return out;
  };
  auto fail = [&](const Error& e) {
    Error out = e;
    out.file = m.source;
    return out;
  };

  std::map<std::string, int> source_block;  // state or input name -> block id
  for (std::size_t i = 0; i < m.inputs.size(); ++i) {
    auto id = AddBlock(&d, MakeBlock(BlockKind::kInput, m.inputs[i]), {0.0, kRow * i});
    if (!id) return fail(id.error());
    source_block[m.inputs[i]] = *id;
  }
  std::vector<int> state_blocks;
  for (std::size_t i = 0; i < m.states.size(); ++i) {
    Block b = MakeBlock(BlockKind::kState, m.states[i]);
    b.ports = reads(m.drift[i], m.states[i]);
    b.fields["f"] = m.drift[i].text;
    b.fields["x0"] = m.initial_state[i].text;
    auto id = AddBlock(&d, std::move(b), {2 * kColumn, kRow * i});
    if (!id) return fail(id.error());
    source_block[m.states[i]] = *id;
    state_blocks.push_back(*id);
  }
  std::vector<int> output_blocks;
  for (std::size_t o = 0; o < m.outputs.size(); ++o) {
    Block b = MakeBlock(BlockKind::kOutput, m.outputs[o]);
    b.ports = reads(m.observation[o], "");
    b.fields["h"] = m.observation[o].text;
    b.fields["variance"] = m.measurement_variance[o].text;
    b.delay = m.output_delay[o];
    auto id = AddBlock(&d, std::move(b), {3 * kColumn, kRow * o});
    if (!id) return fail(id.error());
    output_blocks.push_back(*id);
  }
  auto wire = [&](int block) -> Status {
    const Block copy = *d.FindBlock(block);
    for (std::size_t p = 0; p < copy.ports.size(); ++p) {
      auto l = Connect(&d, Out(source_block.at(copy.ports[p])), In(block, static_cast<int>(p)));
      if (!l) return l.error();
    }
    return Ok{};
  };
  for (int id : state_blocks)
    if (auto s = wire(id); !s) return fail(s.error());
  for (int id : output_blocks)
    if (auto s = wire(id); !s) return fail(s.error());
  for (std::size_t i = 0; i < m.states.size(); ++i) {
    double sigma = 1.0;
    if (expr::IsConstant(expr::Simplify(m.diffusion[i].expr), &sigma) && sigma == 0.0) continue;
    Block noise = MakeBlock(BlockKind::kNoise);
    noise.fields["sigma"] = m.diffusion[i].text;
    auto id = AddBlock(&d, std::move(noise), {kColumn, kRow * i});
    if (!id) return fail(id.error());
    const Block* state = d.FindBlock(state_blocks[i]);
    const int noise_port = static_cast<int>(InPorts(*state).size()) - 1;
    auto l = Connect(&d, Out(*id), In(state_blocks[i], noise_port));
    if (!l) return fail(l.error());
  }
  return d;
}

}  // namespace gb::diagram
