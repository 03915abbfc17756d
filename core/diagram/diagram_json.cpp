// Sections: 1. writing  2. reading  3. files and projects
#include <cstdint>
#include <filesystem>
#include <limits>
#include <set>

#include <fmt/format.h>

#include "core/diagram/diagram.h"
#include "core/diagram/internal.h"
#include "core/project/project.h"
#include "core/util/file.h"

namespace gb::diagram {

// ---- 1. writing ------------------------------------------------------------------------------

Json ToJson(const BlockDiagram& d) {
  Json j;
  j["greybench_diagram"] = 1;
  if (!d.name.empty()) j["name"] = d.name;
  j["input_hold"] = d.input_hold == model::InputHold::kFoh ? "foh" : "zoh";
  j["initial_covariance"] = internal::InitialCovarianceJson(d);
  if (d.robust_huber) j["robust_huber"] = *d.robust_huber;
  if (!d.ekf.is_null()) j["ekf"] = d.ekf;
  // The parameter table in the model file's form.
  model::ModelSpec m;
  m.parameters = d.parameters;
  j["parameters"] = model::ToJson(m)["parameters"];
  Json blocks = Json::array();
  for (const auto& b : d.blocks) {
    Json jb;
    jb["id"] = b.id;
    jb["kind"] = KindName(b.kind);
    if (!b.name.empty()) jb["name"] = b.name;
    if (b.kind == BlockKind::kState || b.kind == BlockKind::kOutput ||
        b.kind == BlockKind::kFunction)
      jb["ports"] = b.ports;
    if (b.kind == BlockKind::kSum) jb["signs"] = b.signs;
    for (const auto& field : FieldsOf(b.kind)) {
      auto it = b.fields.find(field);
      if (it != b.fields.end()) jb[field] = it->second;
    }
    if (b.kind == BlockKind::kDelay ||
        (b.kind == BlockKind::kOutput && (b.delay.min != 0 || b.delay.max != 0)))
      jb["delay"] = internal::DelayJson(b.delay);
    blocks.push_back(jb);
  }
  j["blocks"] = blocks;
  Json links = Json::array();
  for (const auto& l : d.links)
    links.push_back(
        {{"id", l.id}, {"from", {l.from.block, l.from.index}}, {"to", {l.to.block, l.to.index}}});
  j["links"] = links;
  // The ids are unique, so the entries are appended as they are: a JSON object's operator[]
  // looks for the key by a scan, which made writing the layout quadratic in the blocks.
  Json layout = Json::object();
  auto& entries = static_cast<Json::object_t::Container&>(layout.get_ref<Json::object_t&>());
  entries.reserve(d.layout.positions.size());
  for (const auto& [id, xy] : d.layout.positions)
    entries.emplace_back(std::to_string(id), Json{xy[0], xy[1]});
  j["layout"] = std::move(layout);
  return j;
}

// ---- 2. reading ------------------------------------------------------------------------------

namespace {

std::string TypeName(const Json& v) {
  if (v.is_null()) return "null";
  if (v.is_boolean()) return "true/false";
  if (v.is_number()) return "a number";
  if (v.is_string()) return "a string";
  if (v.is_array()) return "a list";
  return "an object";
}

class Reader {
 public:
  Reader(std::string source, std::string prefix)
      : source_(std::move(source)), prefix_(std::move(prefix)) {}

  Error Fail(const std::string& path, std::string message) const {
    Error e = InputError(std::move(message));
    e.file = source_;
    e.path = Path(path);
    return e;
  }
  std::string Path(const std::string& path) const {
    if (prefix_.empty()) return path;
    if (path.empty()) return prefix_;
    return path[0] == '[' ? prefix_ + path : prefix_ + "." + path;
  }

  Result<int> Int(const Json& v, const std::string& path) const {
    if (!v.is_number_integer()) return Fail(path, "expected a whole number, found " + TypeName(v));
    // get<int>() would wrap a larger number silently (4294967297 reads as 1).
    constexpr auto kMin = std::numeric_limits<int>::min();
    constexpr auto kMax = std::numeric_limits<int>::max();
    const bool fits = v.is_number_unsigned()
                          ? v.get<std::uint64_t>() <= std::uint64_t{kMax}
                          : v.get<std::int64_t>() >= kMin && v.get<std::int64_t>() <= kMax;
    if (!fits) return Fail(path, "the number " + v.dump() + " is out of range");
    return v.get<int>();
  }

  Result<std::string> String(const Json& v, const std::string& path) const {
    if (!v.is_string()) return Fail(path, "expected a string, found " + TypeName(v));
    return v.get<std::string>();
  }

  Result<model::DelaySpec> Delay(const Json& v, const std::string& path) const {
    model::DelaySpec d;
    if (v.is_number_integer()) {
      d.min = d.max = v.get<int>();
    } else if (v.is_object() && v.contains("min") && v.contains("max") && v.size() == 2) {
      auto lo = Int(v["min"], path + ".min");
      if (!lo) return lo.error();
      auto hi = Int(v["max"], path + ".max");
      if (!hi) return hi.error();
      d.min = *lo;
      d.max = *hi;
    } else {
      return Fail(path, "expected a whole number of samples or {\"min\": a, \"max\": b}");
    }
    if (d.min < 0 || d.max < d.min) return Fail(path, "the delay range is not 0 <= min <= max");
    return d;
  }

  // [block id, port index]
  Result<PortRef> Port(const Json& v, const std::string& path, PortSide side) const {
    if (!v.is_array() || v.size() != 2)
      return Fail(path, "expected [block id, port index], found " + TypeName(v));
    auto block = Int(v[0], path + "[0]");
    if (!block) return block.error();
    auto index = Int(v[1], path + "[1]");
    if (!index) return index.error();
    return PortRef{*block, side, *index};
  }

  // The parameter table, validated exactly as a model file's (through model::ParseModel).
  Result<std::vector<model::Parameter>> Parameters(const Json& ps) const {
    const std::string x = "gb_diagram_state_", y = "gb_diagram_output_";
    Json m = {{"greybench_model", 1},
              {"states", {x}},
              {"outputs", {y}},
              {"parameters", ps},
              {"drift", {{x, "0"}}},
              {"observation", {{y, "0"}}},
              {"measurement_variance", {{y, "1"}}}};
    auto spec = model::ParseModel(m, source_);
    if (!spec) {
      Error e = spec.error();
      e.path = Path(e.path);
      return e;
    }
    return spec->parameters;
  }

 private:
  std::string source_;
  std::string prefix_;
};

}  // namespace

Result<BlockDiagram> FromJson(const Json& j, const std::string& source,
                              const std::string& path_prefix) {
  const Reader r(source, path_prefix);
  if (!j.is_object()) return r.Fail("", "a diagram is a JSON object, found " + TypeName(j));
  static const std::set<std::string> kKeys = {"greybench_diagram",
                                              "name",
                                              "input_hold",
                                              "initial_covariance",
                                              "robust_huber",
                                              "ekf",
                                              "parameters",
                                              "blocks",
                                              "links",
                                              "layout"};
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (kKeys.count(it.key())) continue;
    std::string msg = fmt::format("unknown key '{}'", it.key());
    if (auto s = model::Suggest(it.key(), {kKeys.begin(), kKeys.end()}))
      msg += fmt::format(" (did you mean '{}'?)", *s);
    return r.Fail(it.key(), msg);
  }
  if (j.contains("greybench_diagram") && (!j["greybench_diagram"].is_number_integer() ||
                                          j["greybench_diagram"].get<std::int64_t>() != 1))
    return r.Fail("greybench_diagram", "unsupported diagram version (this greybench reads 1)");

  BlockDiagram d;
  if (j.contains("name")) {
    auto name = r.String(j["name"], "name");
    if (!name) return name.error();
    d.name = *name;
  }
  if (j.contains("input_hold")) {
    const auto& v = j["input_hold"];
    if (v == "foh")
      d.input_hold = model::InputHold::kFoh;
    else if (v == "zoh")
      d.input_hold = model::InputHold::kZoh;
    else
      return r.Fail("input_hold", "expected \"zoh\" or \"foh\"");
  }
  if (j.contains("initial_covariance")) {
    const auto& v = j["initial_covariance"];
    if (v == "ctsm")
      d.initial_covariance = model::InitialCovariance::kCtsm;
    else if (v == "stationary")
      d.initial_covariance = model::InitialCovariance::kStationary;
    else if (!v.is_object())
      return r.Fail("initial_covariance",
                    "expected \"ctsm\", \"stationary\" or an object of variances by state");
    for (auto it = v.begin(); v.is_object() && it != v.end(); ++it) {
      const std::string path = "initial_covariance." + it.key();
      if (it->is_number()) {
        d.initial_variance[it.key()] = fmt::format("{}", it->get<double>());
      } else if (it->is_string()) {
        d.initial_variance[it.key()] = it->get<std::string>();
      } else {
        return r.Fail(path,
                      "expected a variance (a number or an expression), found " + TypeName(*it));
      }
    }
    if (v.is_object()) d.initial_covariance = model::InitialCovariance::kExplicit;
  }
  if (j.contains("ekf")) {
    if (!j["ekf"].is_object())
      return r.Fail("ekf",
                    "expected an object such as {\"rtol\": 1e-6}, found " + TypeName(j["ekf"]));
    d.ekf = j["ekf"];
  }
  if (j.contains("robust_huber")) {
    const auto& v = j["robust_huber"];
    if (!v.is_number() || v.get<double>() <= 0)
      return r.Fail("robust_huber", "expected a positive number");
    d.robust_huber = v.get<double>();
  }
  if (j.contains("parameters")) {
    auto ps = r.Parameters(j["parameters"]);
    if (!ps) return ps.error();
    d.parameters = std::move(*ps);
  }

  int max_id = 0;
  std::set<int> ids;
  auto claim_id = [&](const Json& v, const std::string& path) -> Result<int> {
    auto id = r.Int(v, path);
    if (!id) return id.error();
    // The largest int is refused too: the next id (max + 1) must exist.
    if (*id < 1 || *id == std::numeric_limits<int>::max())
      return r.Fail(path, fmt::format("ids are whole numbers from 1 to {}",
                                      std::numeric_limits<int>::max() - 1));
    if (!ids.insert(*id).second) return r.Fail(path, fmt::format("id {} is used twice", *id));
    max_id = std::max(max_id, *id);
    return *id;
  };

  if (j.contains("blocks")) {
    const auto& bs = j["blocks"];
    if (!bs.is_array()) return r.Fail("blocks", "expected a list of blocks, found " + TypeName(bs));
    for (std::size_t i = 0; i < bs.size(); ++i) {
      const std::string path = fmt::format("blocks[{}]", i);
      const auto& jb = bs[i];
      if (!jb.is_object()) return r.Fail(path, "expected a block object, found " + TypeName(jb));
      if (!jb.contains("kind")) return r.Fail(path, "the block has no \"kind\"");
      auto kind_name = r.String(jb["kind"], path + ".kind");
      if (!kind_name) return kind_name.error();
      auto kind = KindFromName(*kind_name);
      if (!kind)
        return r.Fail(path + ".kind",
                      fmt::format("unknown kind '{}' (input, output, gain, sum, lag, integrator, "
                                  "state, split, delay, noise)",
                                  *kind_name));
      Block b = MakeBlock(*kind);
      if (!jb.contains("id")) return r.Fail(path, "the block has no \"id\"");
      auto id = claim_id(jb["id"], path + ".id");
      if (!id) return id.error();
      b.id = *id;
      const auto& fields = FieldsOf(*kind);
      for (auto it = jb.begin(); it != jb.end(); ++it) {
        const std::string& key = it.key();
        const std::string kpath = path + "." + key;
        if (key == "id" || key == "kind") continue;
        if (key == "name") {
          auto s = r.String(*it, kpath);
          if (!s) return s.error();
          b.name = *s;
        } else if (key == "ports" && (*kind == BlockKind::kState || *kind == BlockKind::kOutput ||
                                      *kind == BlockKind::kFunction)) {
          if (!it->is_array()) return r.Fail(kpath, "expected a list of port names");
          b.ports.clear();
          for (std::size_t p = 0; p < it->size(); ++p) {
            auto s = r.String((*it)[p], fmt::format("{}[{}]", kpath, p));
            if (!s) return s.error();
            b.ports.push_back(*s);
          }
        } else if (key == "signs" && *kind == BlockKind::kSum) {
          auto s = r.String(*it, kpath);
          if (!s) return s.error();
          if (auto why = internal::SignsProblem(*s); !why.empty()) return r.Fail(kpath, why);
          b.signs = *s;
        } else if (key == "delay" && (*kind == BlockKind::kDelay || *kind == BlockKind::kOutput)) {
          auto dl = r.Delay(*it, kpath);
          if (!dl) return dl.error();
          b.delay = *dl;
        } else if (std::find(fields.begin(), fields.end(), key) != fields.end()) {
          auto s = r.String(*it, kpath);
          if (!s) return s.error();
          b.fields[key] = *s;
        } else {
          return r.Fail(kpath, fmt::format("a {} block has no '{}'", *kind_name, key));
        }
      }
      // An output's h defaults to its single port.
      if (*kind == BlockKind::kOutput && !jb.contains("h"))
        b.fields["h"] = b.ports.size() == 1 ? b.ports[0] : "";
      d.blocks.push_back(std::move(b));
      d.AppendedBlock();
    }
  }

  if (j.contains("links")) {
    const auto& ls = j["links"];
    if (!ls.is_array()) return r.Fail("links", "expected a list of links, found " + TypeName(ls));
    for (std::size_t i = 0; i < ls.size(); ++i) {
      const std::string path = fmt::format("links[{}]", i);
      const auto& jl = ls[i];
      if (!jl.is_object() || !jl.contains("id") || !jl.contains("from") || !jl.contains("to"))
        return r.Fail(path, "expected {\"id\": n, \"from\": [block, port], \"to\": [block, port]}");
      Link l;
      auto id = claim_id(jl["id"], path + ".id");
      if (!id) return id.error();
      l.id = *id;
      auto from = r.Port(jl["from"], path + ".from", PortSide::kOut);
      if (!from) return from.error();
      auto to = r.Port(jl["to"], path + ".to", PortSide::kIn);
      if (!to) return to.error();
      l.from = *from;
      l.to = *to;
      const Block* a = d.FindBlock(l.from.block);
      const Block* b = d.FindBlock(l.to.block);
      if (!a) return r.Fail(path + ".from[0]", fmt::format("there is no block {}", l.from.block));
      if (!b) return r.Fail(path + ".to[0]", fmt::format("there is no block {}", l.to.block));
      if (l.from.index < 0 || l.from.index >= static_cast<int>(OutPorts(*a).size()))
        return r.Fail(path + ".from[1]",
                      fmt::format("{} has no out-port {}", internal::BlockLabel(*a), l.from.index));
      if (l.to.index < 0 || l.to.index >= static_cast<int>(InPorts(*b).size()))
        return r.Fail(path + ".to[1]",
                      fmt::format("{} has no in-port {}", internal::BlockLabel(*b), l.to.index));
      d.links.push_back(l);
      d.AppendedLink();
    }
  }

  if (j.contains("layout")) {
    const auto& lay = j["layout"];
    if (!lay.is_object()) return r.Fail("layout", "expected {\"<block id>\": [x, y], ...}");
    for (auto it = lay.begin(); it != lay.end(); ++it) {
      const std::string path = "layout." + it.key();
      int id = 0;
      try {
        std::size_t used = 0;
        id = std::stoi(it.key(), &used);
        if (used != it.key().size()) throw std::invalid_argument("id");
      } catch (const std::exception&) {
        return r.Fail(path, "expected a block id as the key");
      }
      if (!d.FindBlock(id)) return r.Fail(path, fmt::format("there is no block {}", id));
      const auto& v = *it;
      if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number())
        return r.Fail(path, "expected [x, y]");
      d.layout.positions[id] = {v[0].get<double>(), v[1].get<double>()};
    }
  }
  d.next_id = max_id + 1;
  return d;
}

// ---- 3. files and projects -------------------------------------------------------------------

Result<BlockDiagram> LoadDiagramFile(const std::string& path) {
  auto j = ReadJsonFile(path);
  if (!j) return j.error();
  return FromJson(*j, path);
}

Result<BlockDiagram> LoadProjectDiagram(const project::Project& p) {
  if (!p.extra.is_object() || !p.extra.contains("diagram")) {
    Error e = InputError("the project has no diagram (no \"diagram\" key)");
    e.file = p.path;
    return e;
  }
  const auto& v = p.extra["diagram"];
  if (v.is_string()) {
    namespace fs = std::filesystem;
    fs::path file(v.get<std::string>());
    if (!file.is_absolute() && !p.base_dir.empty()) file = fs::path(p.base_dir) / file;
    return LoadDiagramFile(file.lexically_normal().string());
  }
  if (v.is_object()) return FromJson(v, p.path, "diagram");
  Error e = InputError("expected a diagram object or the name of a diagram file");
  e.file = p.path;
  e.path = "diagram";
  return e;
}

}  // namespace gb::diagram
