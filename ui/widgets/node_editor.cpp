// The block-diagram editor widget: see node_editor.h for the API, the controls and the geometry.
//
// Sections
//   1. Geometry: transform, block layout, links, hit tests, free spots
//   2. Input: pan, zoom, select, move, link, box select, delete, context menus
//   3. Drawing: grid, links, blocks, ports, problems, the drag under way
//   4. NodeEditor
#include "ui/widgets/node_editor.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <unordered_map>
#include <unordered_set>

#include <imgui_internal.h>  // SetItemUsingMouseWheel: the wheel zooms instead of scrolling

namespace gb::ui::node_editor {

using diagram::Block;
using diagram::BlockKind;
using diagram::PortRef;
using diagram::PortSide;
using diagram::PortType;

bool EditorContext::IsSelected(int block) const {
  return std::find(selected_blocks.begin(), selected_blocks.end(), block) != selected_blocks.end();
}

namespace {

constexpr float kWheelZoom = 1.15f;    // zoom factor per wheel notch
constexpr float kGrid = 20.0f;         // canvas units between grid lines
constexpr float kFitMargin = 24.0f;    // pixels around a fitted diagram
constexpr float kClickSlop = 3.0f;     // pixels a press may move and still be a click
constexpr float kFreeSpotGap = 24.0f;  // canvas units kept free around a placed block
constexpr int kCurveSegments = 32;

ImVec2 Add(ImVec2 a, ImVec2 b) { return ImVec2(a.x + b.x, a.y + b.y); }
ImVec2 Sub(ImVec2 a, ImVec2 b) { return ImVec2(a.x - b.x, a.y - b.y); }
ImVec2 Mul(ImVec2 a, float s) { return ImVec2(a.x * s, a.y * s); }
float Length(ImVec2 a) { return std::sqrt(a.x * a.x + a.y * a.y); }

bool Inside(ImVec2 p, ImVec2 min, ImVec2 max) {
  return p.x >= min.x && p.x <= max.x && p.y >= min.y && p.y <= max.y;
}

bool Overlap(ImVec2 a_min, ImVec2 a_max, ImVec2 b_min, ImVec2 b_max) {
  return a_min.x <= b_max.x && b_min.x <= a_max.x && a_min.y <= b_max.y && b_min.y <= a_max.y;
}

float DistanceToSegment(ImVec2 p, ImVec2 a, ImVec2 b) {
  const ImVec2 ab = Sub(b, a);
  const float len2 = ab.x * ab.x + ab.y * ab.y;
  float t = len2 > 0 ? ((p.x - a.x) * ab.x + (p.y - a.y) * ab.y) / len2 : 0.0f;
  t = std::clamp(t, 0.0f, 1.0f);
  return Length(Sub(p, Add(a, Mul(ab, t))));
}

std::string FieldText(const Block& b, const std::string& field) {
  const auto it = b.fields.find(field);
  return it == b.fields.end() ? std::string() : it->second;
}

std::string DelayText(const model::DelaySpec& d) {
  char buf[48];
  if (d.IsScan()) {
    std::snprintf(buf, sizeof buf, "%d..%d samples", d.min, d.max);
  } else {
    std::snprintf(buf, sizeof buf, "%d samples", d.min);
  }
  return buf;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 1. Geometry

ImVec2 Transform::ToScreen(ImVec2 c) const {
  return ImVec2(origin.x + (c.x - scroll.x) * zoom, origin.y + (c.y - scroll.y) * zoom);
}

ImVec2 Transform::ToCanvas(ImVec2 s) const {
  return ImVec2(scroll.x + (s.x - origin.x) / zoom, scroll.y + (s.y - origin.y) / zoom);
}

Transform ZoomAbout(const Transform& t, ImVec2 anchor, float factor, float min_zoom,
                    float max_zoom) {
  const ImVec2 c = t.ToCanvas(anchor);
  Transform out = t;
  out.zoom = std::clamp(t.zoom * factor, min_zoom, max_zoom);
  // Solve anchor = origin + (c - scroll') * zoom' for scroll'.
  out.scroll =
      ImVec2(c.x - (anchor.x - t.origin.x) / out.zoom, c.y - (anchor.y - t.origin.y) / out.zoom);
  return out;
}

Transform Fit(ImVec2 origin, ImVec2 size, ImVec2 min, ImVec2 max, float margin, float max_zoom) {
  Transform t;
  t.origin = origin;
  const float w = std::max(1.0f, max.x - min.x), h = std::max(1.0f, max.y - min.y);
  const float avail_w = std::max(1.0f, size.x - 2 * margin);
  const float avail_h = std::max(1.0f, size.y - 2 * margin);
  t.zoom = std::min({max_zoom, avail_w / w, avail_h / h});
  const ImVec2 centre = Mul(Add(min, max), 0.5f);
  t.scroll = ImVec2(centre.x - 0.5f * size.x / t.zoom, centre.y - 0.5f * size.y / t.zoom);
  return t;
}

BlockShape LayoutBlock(const Block& b, std::array<double, 2> position, const TextWidth& width,
                       const Metrics& m) {
  BlockShape s;
  s.id = b.id;
  s.kind = b.kind;
  s.title = b.name.empty() ? diagram::KindName(b.kind) : b.name;
  const std::vector<diagram::PortInfo> ins = diagram::InPorts(b);
  const std::vector<diagram::PortInfo> outs = diagram::OutPorts(b);
  // A lone signal in-port named "u" needs no label.
  auto label = [](const diagram::PortInfo& p, const char* obvious, std::size_t count) {
    return count == 1 && p.name == obvious ? std::string() : p.name;
  };
  std::size_t signal_ins = 0;
  for (const auto& p : ins) signal_ins += p.type == PortType::kSignal;
  for (const std::string& f : diagram::FieldsOf(b.kind)) {
    const std::string text = FieldText(b, f);
    s.lines.push_back({f, f + " = " + (text.empty() ? "?" : text), text.empty()});
  }
  if (b.kind == BlockKind::kDelay ||
      (b.kind == BlockKind::kOutput && (b.delay.min != 0 || b.delay.max != 0))) {
    s.lines.push_back({"delay", "delay = " + DelayText(b.delay), false});
  }

  float w = m.min_width;
  w = std::max(w, width(s.title) + 2 * m.pad);
  const std::size_t rows = std::max(ins.size(), outs.size());
  std::vector<std::string> in_labels, out_labels;
  for (const auto& p : ins)
    in_labels.push_back(p.type == PortType::kNoise ? p.name : label(p, "u", signal_ins));
  // A lone out-port is the block's output: no label ("out", or a noise block's "noise").
  for (const auto& p : outs) out_labels.push_back(outs.size() == 1 ? std::string() : p.name);
  for (std::size_t r = 0; r < rows; ++r) {
    const float a = r < in_labels.size() ? width(in_labels[r]) : 0.0f;
    const float c = r < out_labels.size() ? width(out_labels[r]) : 0.0f;
    w = std::max(w, a + c + 3 * m.pad);
  }
  for (const FieldLine& l : s.lines) w = std::max(w, width(l.text) + 2 * m.pad);
  w = std::min(w, m.max_width);

  s.min = ImVec2(static_cast<float>(position[0]), static_cast<float>(position[1]));
  s.body_top = s.min.y + m.header;
  s.fields_top = s.body_top + static_cast<float>(rows) * m.row;
  const float h = m.header + static_cast<float>(rows + s.lines.size()) * m.row + 0.5f * m.pad;
  s.max = ImVec2(s.min.x + w, s.min.y + h);
  for (std::size_t i = 0; i < ins.size(); ++i) {
    PortShape p;
    p.ref = diagram::In(b.id, static_cast<int>(i));
    p.type = ins[i].type;
    p.label = in_labels[i];
    p.pos = ImVec2(s.min.x, s.body_top + (static_cast<float>(i) + 0.5f) * m.row);
    s.ports.push_back(p);
  }
  for (std::size_t i = 0; i < outs.size(); ++i) {
    PortShape p;
    p.ref = diagram::Out(b.id, static_cast<int>(i));
    p.type = outs[i].type;
    p.label = out_labels[i];
    p.pos = ImVec2(s.max.x, s.body_top + (static_cast<float>(i) + 0.5f) * m.row);
    s.ports.push_back(p);
  }
  return s;
}

std::vector<BlockShape> LayoutDiagram(const diagram::BlockDiagram& d, const TextWidth& width,
                                      const Metrics& m) {
  std::vector<BlockShape> shapes;
  shapes.reserve(d.blocks.size());
  for (const Block& b : d.blocks) {
    const auto it = d.layout.positions.find(b.id);
    const std::array<double, 2> pos =
        it == d.layout.positions.end() ? std::array<double, 2>{0, 0} : it->second;
    shapes.push_back(LayoutBlock(b, pos, width, m));
  }
  return shapes;
}

LinkShape LinkCurve(ImVec2 from, ImVec2 to) {
  // The tangents leave the out-port to the right and enter the in-port from the left, longer
  // when the link runs backwards so it loops around instead of cutting through the blocks.
  const float dx = to.x - from.x;
  const float reach = std::max(30.0f, dx > 0 ? 0.5f * dx : 0.5f * std::abs(dx) + 40.0f);
  LinkShape l;
  l.p0 = from;
  l.p1 = ImVec2(from.x + reach, from.y);
  l.p2 = ImVec2(to.x - reach, to.y);
  l.p3 = to;
  return l;
}

std::vector<LinkShape> LayoutLinks(const diagram::BlockDiagram& d,
                                   const std::vector<BlockShape>& blocks) {
  std::unordered_map<int, const BlockShape*> by_id;  // a scan per link was O(links × blocks)
  by_id.reserve(blocks.size());
  for (const BlockShape& b : blocks) by_id.emplace(b.id, &b);
  auto find_port = [&](const PortRef& ref) -> const PortShape* {
    auto it = by_id.find(ref.block);
    if (it == by_id.end()) return nullptr;
    for (const PortShape& p : it->second->ports)
      if (p.ref == ref) return &p;
    return nullptr;
  };
  std::vector<LinkShape> links;
  for (const diagram::Link& link : d.links) {
    const PortShape* a = find_port(link.from);
    const PortShape* b = find_port(link.to);
    if (!a || !b) continue;
    LinkShape l = LinkCurve(a->pos, b->pos);
    l.id = link.id;
    l.type = a->type;
    links.push_back(l);
  }
  return links;
}

ImVec2 BezierPoint(const LinkShape& l, float t) {
  const float u = 1.0f - t;
  const float a = u * u * u, b = 3 * u * u * t, c = 3 * u * t * t, e = t * t * t;
  return ImVec2(a * l.p0.x + b * l.p1.x + c * l.p2.x + e * l.p3.x,
                a * l.p0.y + b * l.p1.y + c * l.p2.y + e * l.p3.y);
}

float DistanceToLink(const LinkShape& l, ImVec2 p) {
  float best = FLT_MAX;
  ImVec2 prev = l.p0;
  for (int i = 1; i <= kCurveSegments; ++i) {
    const ImVec2 next = BezierPoint(l, static_cast<float>(i) / kCurveSegments);
    best = std::min(best, DistanceToSegment(p, prev, next));
    prev = next;
  }
  return best;
}

Hit HitTest(const std::vector<BlockShape>& blocks, const std::vector<LinkShape>& links, ImVec2 p,
            const Metrics& m) {
  Hit hit;
  float best = m.port_hit_radius;
  for (const BlockShape& b : blocks) {
    for (const PortShape& port : b.ports) {
      const float dist = Length(Sub(p, port.pos));
      if (dist <= best) {
        best = dist;
        hit.kind = Hit::Kind::kPort;
        hit.block = b.id;
        hit.port = port.ref;
      }
    }
  }
  if (hit.kind == Hit::Kind::kPort) return hit;
  for (auto it = blocks.rbegin(); it != blocks.rend(); ++it) {
    if (Inside(p, it->min, it->max)) {
      hit.kind = Hit::Kind::kBlock;
      hit.block = it->id;
      return hit;
    }
  }
  best = m.link_hit_distance;
  for (const LinkShape& l : links) {
    const float dist = DistanceToLink(l, p);
    if (dist <= best) {
      best = dist;
      hit.kind = Hit::Kind::kLink;
      hit.link = l.id;
    }
  }
  return hit;
}

std::vector<int> BlocksInBox(const std::vector<BlockShape>& blocks, ImVec2 a, ImVec2 b) {
  const ImVec2 min(std::min(a.x, b.x), std::min(a.y, b.y));
  const ImVec2 max(std::max(a.x, b.x), std::max(a.y, b.y));
  std::vector<int> ids;
  for (const BlockShape& s : blocks)
    if (Overlap(min, max, s.min, s.max)) ids.push_back(s.id);
  return ids;
}

ImVec2 FreeSpot(const std::vector<BlockShape>& blocks, ImVec2 desired, ImVec2 size) {
  auto free = [&](ImVec2 at) {
    const ImVec2 lo(at.x - kFreeSpotGap, at.y - kFreeSpotGap);
    const ImVec2 hi(at.x + size.x + kFreeSpotGap, at.y + size.y + kFreeSpotGap);
    for (const BlockShape& b : blocks)
      if (Overlap(lo, hi, b.min, b.max)) return false;
    return true;
  };
  // Rings of grid cells around `desired`, nearest ring first; within a ring, rows top to bottom.
  const float step_x = size.x + kFreeSpotGap, step_y = size.y + kFreeSpotGap;
  constexpr int kMaxRing = 30;
  for (int ring = 0; ring <= kMaxRing; ++ring) {
    for (int j = -ring; j <= ring; ++j) {
      for (int i = -ring; i <= ring; ++i) {
        if (std::max(std::abs(i), std::abs(j)) != ring) continue;
        const ImVec2 at(desired.x + static_cast<float>(i) * step_x,
                        desired.y + static_cast<float>(j) * step_y);
        if (free(at)) return at;
      }
    }
  }
  return desired;
}

TextWidth FontTextWidth(ImFont* font, const Metrics& m) {
  return [font, size = m.text_size](const std::string& text) {
    ImFont* f = font ? font : ImGui::GetFont();
    return f->CalcTextSizeA(size, FLT_MAX, 0.0f, text.c_str()).x;
  };
}

namespace {

// ---------------------------------------------------------------------------------------------
// 2. Input

struct Colours {
  ImU32 canvas = IM_COL32(250, 251, 252, 255);
  ImU32 grid = IM_COL32(234, 236, 240, 255);
  ImU32 grid_major = IM_COL32(220, 223, 228, 255);
  ImU32 block = IM_COL32(255, 255, 255, 255);
  ImU32 border = IM_COL32(150, 156, 166, 255);
  ImU32 selected = IM_COL32(47, 111, 219, 255);
  ImU32 problem = IM_COL32(214, 39, 40, 255);
  ImU32 text = IM_COL32(30, 34, 40, 255);
  ImU32 dim = IM_COL32(100, 106, 116, 255);
  ImU32 link = IM_COL32(70, 76, 86, 255);
  ImU32 noise_link = IM_COL32(214, 120, 20, 255);
  ImU32 box = IM_COL32(47, 111, 219, 40);
};

// Header colours by what a block does: signals in and out, dynamics, static maps, noise.
ImU32 HeaderColour(BlockKind kind) {
  switch (kind) {
    case BlockKind::kInput:
    case BlockKind::kOutput:
      return IM_COL32(214, 228, 247, 255);
    case BlockKind::kLag:
    case BlockKind::kIntegrator:
    case BlockKind::kState:
      return IM_COL32(214, 238, 218, 255);
    case BlockKind::kNoise:
      return IM_COL32(252, 229, 204, 255);
    case BlockKind::kDelay:
      return IM_COL32(236, 226, 246, 255);
    default:
      return IM_COL32(232, 234, 238, 255);
  }
}

}  // namespace

const char* KindSummary(BlockKind kind) {
  switch (kind) {
    case BlockKind::kInput:
      return "input u";
    case BlockKind::kOutput:
      return "output y = h(ports) + e, e ~ N(0, variance)";
    case BlockKind::kGain:
      return "gain: out = k u";
    case BlockKind::kSum:
      return "sum: out = \xCE\xA3 \xC2\xB1u_i";
    case BlockKind::kLag:
      return "first-order lag: dx = (K u \xE2\x88\x92 x)/tau dt";
    case BlockKind::kIntegrator:
      return "integrator: dx = k u dt";
    case BlockKind::kState:
      return "state: dx = f(ports, x) dt";
    case BlockKind::kSplit:
      return "split: X u and (1 \xE2\x88\x92 X) u";
    case BlockKind::kDelay:
      return "transport delay (in front of an output)";
    case BlockKind::kNoise:
      return "process noise: adds sigma d\xCF\x89 to a state";
    case BlockKind::kProduct:
      return "product: out = u1 u2";
    case BlockKind::kQuotient:
      return "quotient: out = num / den";
    case BlockKind::kFunction:
      return "static function: out = g(ports)";
    case BlockKind::kOrifice:
      return "orifice: out = k sqrt(max(u, 0))";
    case BlockKind::kSaturation:
      return "saturation: u clipped to [lower, upper] (smooth with width > 0)";
  }
  return "";
}

namespace {

const PortShape* FindPort(const std::vector<BlockShape>& blocks, const PortRef& ref) {
  for (const BlockShape& b : blocks) {
    if (b.id != ref.block) continue;
    for (const PortShape& p : b.ports)
      if (p.ref == ref) return &p;
  }
  return nullptr;
}

// Everything one frame of the editor works with.
struct Frame {
  EditorContext& ctx;
  const diagram::BlockDiagram& d;
  const Options& options;
  std::vector<DiagramEdit>* edits;
  Transform t;
  ImVec2 min, max;  // the widget on screen
  std::vector<BlockShape> blocks;
  std::vector<LinkShape> links;
  ImDrawList* dl = nullptr;
  Colours colours;
  bool hovered = false;
  // The selection as sets (NoteSelection), for the per-block and per-link tests of a frame.
  std::unordered_set<int> selected_blocks{}, selected_links{};
};

void NoteSelection(Frame& f) {
  f.selected_blocks = {f.ctx.selected_blocks.begin(), f.ctx.selected_blocks.end()};
  f.selected_links = {f.ctx.selected_links.begin(), f.ctx.selected_links.end()};
}

bool Selected(const Frame& f, int block) { return f.selected_blocks.count(block) > 0; }

ImVec2 MoveOffset(const Frame& f) {
  if (f.ctx.drag != EditorContext::Drag::kMove) return ImVec2(0, 0);
  return Mul(Sub(ImGui::GetIO().MousePos, f.ctx.drag_start), 1.0f / f.t.zoom);
}

void SaveTransform(Frame& f) {
  f.ctx.scroll = f.t.scroll;
  f.ctx.zoom = f.t.zoom / f.options.scale;
}

void DeleteSelection(Frame& f) {
  NoteSelection(f);
  for (int id : f.ctx.selected_blocks) {
    DiagramEdit e;
    e.kind = DiagramEditKind::kRemoveBlock;
    e.id = id;
    f.edits->push_back(std::move(e));
  }
  for (int id : f.ctx.selected_links) {
    const diagram::Link* l = f.d.FindLink(id);
    if (!l || Selected(f, l->from.block) || Selected(f, l->to.block)) continue;
    DiagramEdit e;
    e.kind = DiagramEditKind::kDisconnect;
    e.id = id;
    f.edits->push_back(std::move(e));
  }
  f.ctx.selected_blocks.clear();
  f.ctx.selected_links.clear();
}

void Toggle(std::vector<int>& ids, int id) {
  const auto it = std::find(ids.begin(), ids.end(), id);
  if (it == ids.end()) {
    ids.push_back(id);
  } else {
    ids.erase(it);
  }
}

void FinishDrag(Frame& f) {
  EditorContext& ctx = f.ctx;
  const ImGuiIO& io = ImGui::GetIO();
  const ImVec2 mouse = io.MousePos;
  switch (ctx.drag) {
    case EditorContext::Drag::kMove: {
      const ImVec2 delta = MoveOffset(f);
      if (Length(Sub(mouse, ctx.drag_start)) < kClickSlop) break;
      for (int id : ctx.selected_blocks) {
        const auto it = f.d.layout.positions.find(id);
        const std::array<double, 2> at =
            it == f.d.layout.positions.end() ? std::array<double, 2>{0, 0} : it->second;
        DiagramEdit e;
        e.kind = DiagramEditKind::kMove;
        e.id = id;
        e.position = {std::round(at[0] + delta.x), std::round(at[1] + delta.y)};
        f.edits->push_back(std::move(e));
      }
      break;
    }
    case EditorContext::Drag::kLink: {
      const Hit hit = HitTest(f.blocks, {}, f.t.ToCanvas(mouse), f.options.metrics);
      if (hit.kind != Hit::Kind::kPort || hit.port == ctx.link_start) break;
      DiagramEdit e;
      e.kind = DiagramEditKind::kConnect;
      // Drawn from an in-port back to an out-port: the same link. Any other pair goes to core
      // as drawn, and core says why it cannot be linked.
      const bool reversed = ctx.link_start.side == PortSide::kIn && hit.port.side == PortSide::kOut;
      e.from = reversed ? hit.port : ctx.link_start;
      e.to = reversed ? ctx.link_start : hit.port;
      f.edits->push_back(std::move(e));
      break;
    }
    case EditorContext::Drag::kBox: {
      const std::vector<int> ids =
          BlocksInBox(f.blocks, f.t.ToCanvas(ctx.drag_start), f.t.ToCanvas(mouse));
      for (int id : ids)
        if (!ctx.IsSelected(id)) ctx.selected_blocks.push_back(id);
      break;
    }
    default:
      break;
  }
  ctx.drag = EditorContext::Drag::kNone;
}

void HandleInput(Frame& f) {
  EditorContext& ctx = f.ctx;
  const ImGuiIO& io = ImGui::GetIO();
  const ImVec2 mouse = io.MousePos;
  const bool additive = io.KeyShift || io.KeyCtrl;
  const bool space = ImGui::IsKeyDown(ImGui::GetKeyIndex(ImGuiKey_Space)) && !io.WantTextInput;

  if (f.hovered && io.MouseWheel != 0.0f) {
    f.t = ZoomAbout(f.t, mouse, std::pow(kWheelZoom, io.MouseWheel), kMinZoom * f.options.scale,
                    kMaxZoom * f.options.scale);
    SaveTransform(f);
  }

  if (ctx.drag == EditorContext::Drag::kPan) {
    f.t.scroll = Sub(f.t.scroll, Mul(io.MouseDelta, 1.0f / f.t.zoom));
    SaveTransform(f);
    if (!ImGui::IsMouseDown(ImGuiMouseButton_Left) && !ImGui::IsMouseDown(ImGuiMouseButton_Middle))
      ctx.drag = EditorContext::Drag::kNone;
  } else if (ctx.drag != EditorContext::Drag::kNone && !ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
    FinishDrag(f);
  }

  // The keyboard acts on the editor that has focus, wherever the mouse is.
  if (ImGui::IsWindowFocused() && !io.WantTextInput &&
      ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Delete), false)) {
    DeleteSelection(f);
  }

  if (!f.hovered) return;
  if (ImGui::IsMouseClicked(ImGuiMouseButton_Middle) ||
      (space && ImGui::IsMouseClicked(ImGuiMouseButton_Left))) {
    ctx.drag = EditorContext::Drag::kPan;
    return;
  }
  const Hit hit = HitTest(f.blocks, f.links, f.t.ToCanvas(mouse), f.options.metrics);
  if (ImGui::IsMouseClicked(ImGuiMouseButton_Left)) {
    ctx.drag_start = mouse;
    switch (hit.kind) {
      case Hit::Kind::kPort:
        ctx.drag = EditorContext::Drag::kLink;
        ctx.link_start = hit.port;
        break;
      case Hit::Kind::kBlock:
        if (additive) {
          Toggle(ctx.selected_blocks, hit.block);
        } else if (!ctx.IsSelected(hit.block)) {
          ctx.Select(hit.block);
        }
        ctx.drag =
            ctx.IsSelected(hit.block) ? EditorContext::Drag::kMove : EditorContext::Drag::kNone;
        break;
      case Hit::Kind::kLink:
        if (additive) {
          Toggle(ctx.selected_links, hit.link);
        } else {
          ctx.selected_blocks.clear();
          ctx.selected_links = {hit.link};
        }
        break;
      case Hit::Kind::kNone:
        if (!additive) {
          ctx.selected_blocks.clear();
          ctx.selected_links.clear();
        }
        ctx.drag = EditorContext::Drag::kBox;
        break;
    }
  }
  if (ImGui::IsMouseClicked(ImGuiMouseButton_Right)) {
    ctx.menu_block = hit.kind == Hit::Kind::kBlock || hit.kind == Hit::Kind::kPort ? hit.block : 0;
    ctx.menu_link = hit.kind == Hit::Kind::kLink ? hit.link : 0;
    if (ctx.menu_block && !ctx.IsSelected(ctx.menu_block)) ctx.Select(ctx.menu_block);
    if (ctx.menu_link) {
      ctx.selected_blocks.clear();
      ctx.selected_links = {ctx.menu_link};
    }
    ImGui::OpenPopup("##node_editor_menu");
  }
}

void DrawContextMenu(Frame& f) {
  if (!ImGui::BeginPopup("##node_editor_menu")) return;
  EditorContext& ctx = f.ctx;
  if (ctx.menu_block || ctx.menu_link) {
    const std::size_t n = ctx.selected_blocks.size() + ctx.selected_links.size();
    const std::string label =
        n > 1 ? "Delete " + std::to_string(n) + " items" : std::string("Delete");
    if (ImGui::MenuItem(label.c_str(), "Del")) DeleteSelection(f);
  } else {
    if (ImGui::MenuItem("Fit view")) ctx.RequestFit();
    if (ImGui::MenuItem("Select all", nullptr, false, !f.d.blocks.empty())) {
      ctx.selected_blocks.clear();
      for (const Block& b : f.d.blocks) ctx.selected_blocks.push_back(b.id);
    }
  }
  ImGui::EndPopup();
}

// ---------------------------------------------------------------------------------------------
// 3. Drawing

void DrawGrid(const Frame& f) {
  f.dl->AddRectFilled(f.min, f.max, f.colours.canvas);
  const float step = kGrid * f.t.zoom;
  if (step < 6.0f) return;  // too dense to help
  const ImVec2 c0 = f.t.ToCanvas(f.min);
  const float first_x = std::floor(c0.x / kGrid) * kGrid;
  const float first_y = std::floor(c0.y / kGrid) * kGrid;
  for (float x = first_x;; x += kGrid) {
    const float sx = f.t.ToScreen(ImVec2(x, 0)).x;
    if (sx > f.max.x) break;
    const bool major = std::fmod(std::abs(x), 5 * kGrid) < 0.5f;
    f.dl->AddLine(ImVec2(sx, f.min.y), ImVec2(sx, f.max.y),
                  major ? f.colours.grid_major : f.colours.grid);
  }
  for (float y = first_y;; y += kGrid) {
    const float sy = f.t.ToScreen(ImVec2(0, y)).y;
    if (sy > f.max.y) break;
    const bool major = std::fmod(std::abs(y), 5 * kGrid) < 0.5f;
    f.dl->AddLine(ImVec2(f.min.x, sy), ImVec2(f.max.x, sy),
                  major ? f.colours.grid_major : f.colours.grid);
  }
}

void DrawCurve(const Frame& f, const LinkShape& l, ImU32 colour, float thickness, bool arrow) {
  const ImVec2 p0 = f.t.ToScreen(l.p0), p1 = f.t.ToScreen(l.p1);
  const ImVec2 p2 = f.t.ToScreen(l.p2), p3 = f.t.ToScreen(l.p3);
  f.dl->AddBezierCubic(p0, p1, p2, p3, colour, thickness);
  if (!arrow) return;
  const float a = 6.0f * f.t.zoom;
  f.dl->AddTriangleFilled(ImVec2(p3.x, p3.y), ImVec2(p3.x - a, p3.y - 0.55f * a),
                          ImVec2(p3.x - a, p3.y + 0.55f * a), colour);
}

bool BlockHasProblem(const Frame& f, int id) {
  if (!f.options.problems) return false;
  for (const diagram::Problem& p : *f.options.problems)
    if (p.block == id && p.in_port < 0) return true;
  return false;
}

bool PortHasProblem(const Frame& f, const PortRef& ref) {
  if (!f.options.problems || ref.side != PortSide::kIn) return false;
  for (const diagram::Problem& p : *f.options.problems)
    if (p.block == ref.block && p.in_port == ref.index) return true;
  return false;
}

bool FieldHasProblem(const Frame& f, int id, const std::string& field) {
  if (!f.options.problems) return false;
  for (const diagram::Problem& p : *f.options.problems)
    if (p.block == id && p.field == field) return true;
  return false;
}

void DrawText(const Frame& f, ImVec2 canvas, ImU32 colour, const std::string& text, float clip_x) {
  const float size = f.options.metrics.text_size * f.t.zoom;
  if (size < 4.0f) return;  // unreadable: leave the boxes
  ImFont* font = f.options.draw_font ? f.options.draw_font
                 : f.options.font    ? f.options.font
                                     : ImGui::GetFont();
  const ImVec2 at = f.t.ToScreen(canvas);
  const ImVec4 clip(at.x, at.y - size, clip_x, at.y + 2 * size);
  f.dl->AddText(font, size, at, colour, text.c_str(), nullptr, 0.0f, &clip);
}

void DrawBlock(const Frame& f, const BlockShape& s, ImVec2 offset) {
  const Metrics& m = f.options.metrics;
  const Colours& c = f.colours;
  const float z = f.t.zoom;
  const ImVec2 min = f.t.ToScreen(Add(s.min, offset));
  const ImVec2 max = f.t.ToScreen(Add(s.max, offset));
  const float rounding = 4.0f * z;
  const bool selected = Selected(f, s.id);
  const bool problem = BlockHasProblem(f, s.id);
  f.dl->AddRectFilled(Add(min, ImVec2(2 * z, 2 * z)), Add(max, ImVec2(2 * z, 2 * z)),
                      IM_COL32(0, 0, 0, 18), rounding);
  f.dl->AddRectFilled(min, max, c.block, rounding);
  f.dl->AddRectFilled(min, ImVec2(max.x, min.y + m.header * z), HeaderColour(s.kind), rounding,
                      ImDrawFlags_RoundCornersTop);
  f.dl->AddLine(ImVec2(min.x, min.y + m.header * z), ImVec2(max.x, min.y + m.header * z),
                IM_COL32(0, 0, 0, 30));
  const ImU32 outline = problem ? c.problem : selected ? c.selected : c.border;
  f.dl->AddRect(min, max, outline, rounding, 0, (problem || selected ? 2.0f : 1.0f));
  if (problem && selected)
    f.dl->AddRect(Sub(min, ImVec2(3, 3)), Add(max, ImVec2(3, 3)), c.selected, rounding, 0, 1.5f);

  const float clip_x = max.x - 0.5f * m.pad * z;
  const float text_dy = 0.5f * (m.row - m.text_size);
  DrawText(f, Add(Add(s.min, offset), ImVec2(m.pad, 0.5f * (m.header - m.text_size))), c.text,
           s.title, clip_x);
  for (const PortShape& p : s.ports) {
    if (p.label.empty()) continue;
    const float w = FontTextWidth(f.options.font, m)(p.label);
    const float x = p.ref.side == PortSide::kIn ? s.min.x + m.pad : s.max.x - m.pad - w;
    DrawText(f, Add(ImVec2(x, p.pos.y - 0.5f * m.row + text_dy), offset),
             PortHasProblem(f, p.ref) ? c.problem : c.dim, p.label, clip_x);
  }
  for (std::size_t i = 0; i < s.lines.size(); ++i) {
    const FieldLine& l = s.lines[i];
    const float y = s.fields_top + static_cast<float>(i) * m.row + text_dy;
    const bool bad = l.missing || FieldHasProblem(f, s.id, l.field);
    DrawText(f, Add(ImVec2(s.min.x + m.pad, y), offset), bad ? c.problem : c.text, l.text, clip_x);
  }
  for (const PortShape& p : s.ports) {
    const ImVec2 at = f.t.ToScreen(Add(p.pos, offset));
    const float r = m.port_radius * z;
    const bool bad = PortHasProblem(f, p.ref);
    const ImU32 fill = p.type == PortType::kNoise ? c.noise_link : c.link;
    if (p.type == PortType::kNoise) {  // a diamond: noise ports take only noise
      f.dl->AddQuadFilled(ImVec2(at.x, at.y - r * 1.2f), ImVec2(at.x + r * 1.2f, at.y),
                          ImVec2(at.x, at.y + r * 1.2f), ImVec2(at.x - r * 1.2f, at.y), fill);
    } else {
      f.dl->AddCircleFilled(at, r, p.ref.side == PortSide::kIn ? c.block : fill, 12);
      f.dl->AddCircle(at, r, fill, 12, 1.5f);
    }
    if (bad) f.dl->AddCircle(at, r + 3.0f * z, c.problem, 16, 2.0f);
  }
}

// Tooltips on what is under the mouse: the problems of a block or port, else the block's kind.
void DrawTooltip(const Frame& f) {
  if (!f.hovered || f.ctx.drag != EditorContext::Drag::kNone) return;
  const Hit hit =
      HitTest(f.blocks, f.links, f.t.ToCanvas(ImGui::GetIO().MousePos), f.options.metrics);
  if (hit.kind == Hit::Kind::kNone || hit.kind == Hit::Kind::kLink) return;
  const Block* b = f.d.FindBlock(hit.block);
  if (!b) return;
  std::vector<std::string> lines;
  if (f.options.problems) {
    for (const diagram::Problem& p : *f.options.problems) {
      if (p.block != hit.block) continue;
      if (hit.kind == Hit::Kind::kPort &&
          (hit.port.side != PortSide::kIn || p.in_port != hit.port.index))
        continue;
      lines.push_back(p.message);
    }
  }
  ImGui::BeginTooltip();
  if (hit.kind == Hit::Kind::kPort) {
    const auto ports =
        hit.port.side == PortSide::kIn ? diagram::InPorts(*b) : diagram::OutPorts(*b);
    if (hit.port.index < static_cast<int>(ports.size())) {
      const diagram::PortInfo& p = ports[hit.port.index];
      ImGui::Text("%s-port '%s' (%s)%s", hit.port.side == PortSide::kIn ? "in" : "out",
                  p.name.c_str(), p.type == PortType::kNoise ? "noise" : "signal",
                  p.optional ? ", may stay unconnected" : "");
    }
  } else {
    ImGui::TextUnformatted(KindSummary(b->kind));
  }
  for (const std::string& l : lines)
    ImGui::TextColored(ImVec4(0.84f, 0.15f, 0.16f, 1.0f), "%s", l.c_str());
  ImGui::EndTooltip();
}

void Draw(Frame& f) {
  NoteSelection(f);
  DrawGrid(f);
  const ImVec2 offset = MoveOffset(f);
  const bool moving = f.ctx.drag == EditorContext::Drag::kMove;
  for (const LinkShape& l : f.links) {
    LinkShape shown = l;
    if (moving) {  // links follow the blocks being dragged
      const diagram::Link* link = f.d.FindLink(l.id);
      if (link && Selected(f, link->from.block)) shown.p0 = Add(shown.p0, offset);
      if (link && Selected(f, link->to.block)) shown.p3 = Add(shown.p3, offset);
      const LinkShape curve = LinkCurve(shown.p0, shown.p3);
      shown.p1 = curve.p1;
      shown.p2 = curve.p2;
    }
    const bool selected = f.selected_links.count(l.id) > 0;
    const ImU32 colour = selected                     ? f.colours.selected
                         : l.type == PortType::kNoise ? f.colours.noise_link
                                                      : f.colours.link;
    DrawCurve(f, shown, colour, (selected ? 3.0f : 1.6f) * std::sqrt(f.t.zoom), true);
  }
  for (const BlockShape& s : f.blocks)
    DrawBlock(f, s, moving && Selected(f, s.id) ? offset : ImVec2(0, 0));

  const ImVec2 mouse = ImGui::GetIO().MousePos;
  if (f.ctx.drag == EditorContext::Drag::kLink) {
    if (const PortShape* start = FindPort(f.blocks, f.ctx.link_start)) {
      const ImVec2 end = f.t.ToCanvas(mouse);
      const bool from_in = start->ref.side == PortSide::kIn;
      const LinkShape l = from_in ? LinkCurve(end, start->pos) : LinkCurve(start->pos, end);
      DrawCurve(f, l, f.colours.selected, 2.0f, false);
      const Hit hit = HitTest(f.blocks, {}, end, f.options.metrics);
      if (hit.kind == Hit::Kind::kPort && !(hit.port == f.ctx.link_start)) {
        if (const PortShape* target = FindPort(f.blocks, hit.port))
          f.dl->AddCircle(f.t.ToScreen(target->pos),
                          (f.options.metrics.port_radius + 4.0f) * f.t.zoom, f.colours.selected, 16,
                          2.0f);
      }
    }
  }
  if (f.ctx.drag == EditorContext::Drag::kBox) {
    const ImVec2 a = f.ctx.drag_start;
    const ImVec2 lo(std::min(a.x, mouse.x), std::min(a.y, mouse.y));
    const ImVec2 hi(std::max(a.x, mouse.x), std::max(a.y, mouse.y));
    f.dl->AddRectFilled(lo, hi, f.colours.box);
    f.dl->AddRect(lo, hi, f.colours.selected);
  }
  if (f.d.blocks.empty()) {
    const char* text = "Empty diagram: place blocks from the palette on the left.";
    const ImVec2 size = ImGui::CalcTextSize(text);
    f.dl->AddText(ImVec2(0.5f * (f.min.x + f.max.x - size.x), 0.5f * (f.min.y + f.max.y)),
                  f.colours.dim, text);
  }
}

void DropStaleSelection(EditorContext& ctx, const diagram::BlockDiagram& d) {
  std::erase_if(ctx.selected_blocks, [&](int id) { return d.FindBlock(id) == nullptr; });
  std::erase_if(ctx.selected_links, [&](int id) { return d.FindLink(id) == nullptr; });
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 4. NodeEditor

void NodeEditor(EditorContext& ctx, const char* id, ImVec2 size, const diagram::BlockDiagram& d,
                const Options& options, std::vector<DiagramEdit>* edits) {
  IM_ASSERT(edits != nullptr);
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(0, 0));
  const bool open = ImGui::BeginChild(
      id, size, true,
      ImGuiWindowFlags_NoScrollbar | ImGuiWindowFlags_NoScrollWithMouse | ImGuiWindowFlags_NoMove);
  ImGui::PopStyleVar();
  if (!open) {
    ImGui::EndChild();
    return;
  }
  DropStaleSelection(ctx, d);
  Frame f{ctx, d, options, edits, {}, {}, {}, {}, {}, ImGui::GetWindowDrawList(), {}, false};
  f.min = ImGui::GetCursorScreenPos();
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  f.max = Add(f.min, ImVec2(std::max(avail.x, 1.0f), std::max(avail.y, 1.0f)));
  f.blocks = LayoutDiagram(d, FontTextWidth(options.font, options.metrics), options.metrics);
  f.links = LayoutLinks(d, f.blocks);

  if (!ctx.fitted || ctx.fit_requested) {
    ImVec2 lo(0, 0), hi(400, 300);
    if (!f.blocks.empty()) {
      lo = ImVec2(FLT_MAX, FLT_MAX);
      hi = ImVec2(-FLT_MAX, -FLT_MAX);
      for (const BlockShape& s : f.blocks) {
        lo = ImVec2(std::min(lo.x, s.min.x), std::min(lo.y, s.min.y));
        hi = ImVec2(std::max(hi.x, s.max.x), std::max(hi.y, s.max.y));
      }
    }
    const Transform fit =
        Fit(f.min, Sub(f.max, f.min), lo, hi, kFitMargin * options.scale, options.scale);
    ctx.scroll = fit.scroll;
    ctx.zoom = std::max(kMinZoom, fit.zoom / options.scale);
    ctx.fitted = true;
    ctx.fit_requested = false;
  }
  f.t.origin = f.min;
  f.t.scroll = ctx.scroll;
  f.t.zoom = ctx.zoom * options.scale;

  ImGui::InvisibleButton("##canvas", Sub(f.max, f.min),
                         ImGuiButtonFlags_MouseButtonLeft | ImGuiButtonFlags_MouseButtonRight |
                             ImGuiButtonFlags_MouseButtonMiddle);
  ImGui::SetItemUsingMouseWheel();
  f.hovered = ImGui::IsItemHovered();
  HandleInput(f);
  f.dl->PushClipRect(f.min, f.max, true);
  Draw(f);
  f.dl->PopClipRect();
  DrawTooltip(f);
  DrawContextMenu(f);
  ctx.view_centre = f.t.ToCanvas(Mul(Add(f.min, f.max), 0.5f));
  ImGui::EndChild();
}

}  // namespace gb::ui::node_editor
