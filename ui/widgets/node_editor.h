// greybench's block-diagram editor widget, drawn with ImGui draw lists (no imnodes).
//
//   node_editor::Options opt;
//   opt.problems = &state.diagram_view.problems;      // drawn on the blocks and ports concerned
//   node_editor::NodeEditor(state.diagram_view.editor, "##canvas", ImVec2(-1, -1), diagram,
//                           opt, &state.diagram_view.pending);
//   ... after the view is drawn: ApplyDiagramEdits(state) applies the edits through core.
//
// The widget reads the diagram (blocks and links by their stable ids, positions from its
// layout) and never modifies it: it appends `DiagramEdit`s (a link drawn, blocks moved or
// deleted). Persistent UI-only state (pan, zoom, selection, the drag under way) lives in an
// `EditorContext` the caller owns (AppState).
//
// Mouse and keys
//   wheel                zoom about the cursor
//   middle drag, or space + left drag    pan
//   left click           select a block or link (shift/ctrl: add to or remove from the selection)
//   left drag on a block move the selected blocks (one kMove edit per block, on release)
//   left drag on empty canvas            box select (shift/ctrl: add)
//   drag from a port to a port           link them (out-port -> in-port; core refuses the rest)
//   Del, or right click > Delete         delete the selected blocks and links
//   right click on empty canvas          fit the view
//
// Geometry, in canvas units (the diagram's layout units; one unit is one pixel at zoom 1):
//   screen = origin + (canvas - scroll) * zoom
// A block is a box whose top-left corner is its layout position: a header with its title, one
// row per port (in-ports on the left edge, out-ports on the right edge), then one line per
// expression field ("tau = tau_fv"). Links are cubic Bézier curves leaving the out-port to the
// right and entering the in-port from the left.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include <imgui.h>

#include "core/diagram/diagram.h"
#include "ui/edits/diagram_edit.h"

namespace gb::ui::node_editor {

inline constexpr float kMinZoom = 0.25f;
inline constexpr float kMaxZoom = 3.0f;

// Persistent state of one editor, owned by the application.
struct EditorContext {
  // The canvas point at the widget's top-left corner, and pixels per canvas unit (before the DPI
  // scale). An editor that was never fitted fits the diagram into view at its first frame.
  ImVec2 scroll = ImVec2(0, 0);
  float zoom = 1.0f;
  bool fitted = false;
  bool fit_requested = false;
  std::vector<int> selected_blocks;
  std::vector<int> selected_links;
  enum class Drag { kNone, kPan, kMove, kLink, kBox };
  Drag drag = Drag::kNone;
  ImVec2 drag_start = ImVec2(0, 0);  // screen position where the drag began
  diagram::PortRef link_start;       // kLink: the port the link is drawn from
  int menu_block = 0;                // the block or link the context menu is for
  int menu_link = 0;
  // The centre of the visible canvas in the last frame (where the palette places blocks).
  ImVec2 view_centre = ImVec2(0, 0);

  void Select(int block) {
    selected_blocks = {block};
    selected_links.clear();
  }
  bool IsSelected(int block) const;
  void RequestFit() { fit_requested = true; }
};

// ---- geometry (pure functions, unit-tested) --------------------------------------------------

struct Transform {
  ImVec2 origin = ImVec2(0, 0);  // screen position of the widget's top-left corner
  ImVec2 scroll = ImVec2(0, 0);  // canvas point shown at `origin`
  float zoom = 1.0f;             // pixels per canvas unit
  ImVec2 ToScreen(ImVec2 canvas) const;
  ImVec2 ToCanvas(ImVec2 screen) const;
};
// The transform zoomed by `factor` about the screen point `anchor` (the canvas point under it
// stays under it); the zoom is clamped to [min_zoom, max_zoom].
Transform ZoomAbout(const Transform& t, ImVec2 anchor, float factor, float min_zoom,
                    float max_zoom);
// The transform showing the canvas box [min, max] centred in a widget of `size` pixels with
// `margin` pixels around it, zoomed out as needed but not in beyond `max_zoom`.
Transform Fit(ImVec2 origin, ImVec2 size, ImVec2 min, ImVec2 max, float margin, float max_zoom);

struct PortShape {
  diagram::PortRef ref;
  diagram::PortType type = diagram::PortType::kSignal;
  std::string label;  // "" when obvious (a lone signal in-port "u", a lone out-port)
  ImVec2 pos;         // canvas
};

struct FieldLine {
  std::string field;  // "tau", "delay", "signs"
  std::string text;   // "tau = tau_fv"
  bool missing = false;
};

struct BlockShape {
  int id = 0;
  diagram::BlockKind kind = diagram::BlockKind::kGain;
  ImVec2 min, max;  // canvas
  std::string title;
  std::vector<PortShape> ports;  // in-ports first, then out-ports
  std::vector<FieldLine> lines;
  float body_top = 0.0f;    // canvas y where the port rows start
  float fields_top = 0.0f;  // canvas y where the field lines start
};

// Canvas sizes of a block's parts.
struct Metrics {
  float text_size = 13.0f;  // font size
  float header = 22.0f;
  float row = 17.0f;
  float pad = 8.0f;
  float min_width = 72.0f;
  float max_width = 240.0f;
  float port_radius = 4.5f;
  float port_hit_radius = 8.0f;
  float link_hit_distance = 5.0f;
};

// Width of a text in canvas units (at Metrics::text_size).
using TextWidth = std::function<float(const std::string&)>;

BlockShape LayoutBlock(const diagram::Block& b, std::array<double, 2> position,
                       const TextWidth& width, const Metrics& m = {});
// Every block of `d` at its layout position (0, 0 when it has none), in block order.
std::vector<BlockShape> LayoutDiagram(const diagram::BlockDiagram& d, const TextWidth& width,
                                      const Metrics& m = {});

struct LinkShape {
  int id = 0;
  diagram::PortType type = diagram::PortType::kSignal;
  ImVec2 p0, p1, p2, p3;  // the Bézier control points (canvas): out-port ... in-port
};
LinkShape LinkCurve(ImVec2 from, ImVec2 to);
// The links of `d` between the ports of `blocks` (links to missing ports are left out).
std::vector<LinkShape> LayoutLinks(const diagram::BlockDiagram& d,
                                   const std::vector<BlockShape>& blocks);
ImVec2 BezierPoint(const LinkShape& l, float t);
// Distance from `p` to the curve (to a 32-segment polyline of it).
float DistanceToLink(const LinkShape& l, ImVec2 p);

struct Hit {
  enum class Kind { kNone, kPort, kBlock, kLink };
  Kind kind = Kind::kNone;
  int block = 0;
  int link = 0;
  diagram::PortRef port;
};
// What is under the canvas point `p`: a port (within port_hit_radius) before a block, a block
// before a link; among overlapping blocks the one drawn last (the last in `blocks`).
Hit HitTest(const std::vector<BlockShape>& blocks, const std::vector<LinkShape>& links, ImVec2 p,
            const Metrics& m = {});
// The ids of the blocks whose box intersects the box spanned by the canvas points a and b.
std::vector<int> BlocksInBox(const std::vector<BlockShape>& blocks, ImVec2 a, ImVec2 b);
// A top-left position near `desired` where a box of `size` overlaps no block (with a gap), found
// by scanning outwards in rows and columns of a grid.
ImVec2 FreeSpot(const std::vector<BlockShape>& blocks, ImVec2 desired, ImVec2 size);

// ---- the widget ------------------------------------------------------------------------------

struct Options {
  const std::vector<diagram::Problem>* problems = nullptr;  // marked on blocks and ports
  float scale = 1.0f;                                       // DPI scale
  ImFont* font = nullptr;                                   // nullptr: the current font
  // The font text is drawn with (nullptr: `font`), baked larger for a high zoom; `font` alone
  // measures the layout, so blocks keep their sizes whichever draws.
  ImFont* draw_font = nullptr;
  Metrics metrics;
};

// What a block of `kind` does, in one line ("first-order lag: dx = (K u - x)/tau dt").
const char* KindSummary(diagram::BlockKind kind);

// Text widths measured with `font` (nullptr: the current font) at m.text_size.
TextWidth FontTextWidth(ImFont* font, const Metrics& m = {});

// Draws the diagram into a child window of `size` (<= 0: the available space minus |size|),
// handles input and appends the user's edits to `edits`.
void NodeEditor(EditorContext& ctx, const char* id, ImVec2 size, const diagram::BlockDiagram& d,
                const Options& options, std::vector<DiagramEdit>* edits);

}  // namespace gb::ui::node_editor
