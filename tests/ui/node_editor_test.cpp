// The node editor's geometry: the screen <-> canvas transform, zoom about a point, fitting,
// block layout, and hit tests, checked against closed forms (the affine map written out, the
// Bézier midpoint (p0 + 3 p1 + 3 p2 + p3)/8) and brute force (every pair of placed boxes).
#include "ui/widgets/node_editor.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gb::ui::node_editor {
namespace {

constexpr float kTol = 1e-4f;
constexpr float kCharWidth = 7.0f;  // a monospaced stand-in for the font

float Chars(const std::string& s) { return kCharWidth * static_cast<float>(s.size()); }

diagram::Block Lag(int id, const std::string& name) {
  diagram::Block b = diagram::MakeBlock(diagram::BlockKind::kLag, name);
  b.id = id;
  return b;
}

TEST(NodeEditorTransform, MapsCanvasToScreenAsTheAffineMapItIs) {
  Transform t;
  t.origin = ImVec2(100, 50);
  t.scroll = ImVec2(-20, 30);
  t.zoom = 1.5f;
  const ImVec2 s = t.ToScreen(ImVec2(40, 10));
  EXPECT_NEAR(s.x, 100 + (40 + 20) * 1.5f, kTol);
  EXPECT_NEAR(s.y, 50 + (10 - 30) * 1.5f, kTol);
  const ImVec2 c = t.ToCanvas(s);
  EXPECT_NEAR(c.x, 40, kTol);
  EXPECT_NEAR(c.y, 10, kTol);
  // The widget's corner shows the scroll point.
  EXPECT_NEAR(t.ToCanvas(t.origin).x, -20, kTol);
  EXPECT_NEAR(t.ToCanvas(t.origin).y, 30, kTol);
}

TEST(NodeEditorTransform, ZoomKeepsTheCanvasPointUnderTheCursor) {
  Transform t;
  t.origin = ImVec2(10, 20);
  t.scroll = ImVec2(5, -7);
  t.zoom = 1.0f;
  const ImVec2 anchor(300, 140);
  const ImVec2 before = t.ToCanvas(anchor);
  const Transform z = ZoomAbout(t, anchor, 2.0f, 0.25f, 3.0f);
  EXPECT_NEAR(z.zoom, 2.0f, kTol);
  const ImVec2 after = z.ToCanvas(anchor);
  EXPECT_NEAR(after.x, before.x, kTol);
  EXPECT_NEAR(after.y, before.y, kTol);
  // Distances from the anchor scale by the factor.
  const ImVec2 p = z.ToScreen(ImVec2(before.x + 10, before.y));
  EXPECT_NEAR(p.x - anchor.x, 20.0f, kTol);
  // Clamped at the limits, still about the anchor.
  const Transform far = ZoomAbout(z, anchor, 100.0f, 0.25f, 3.0f);
  EXPECT_NEAR(far.zoom, 3.0f, kTol);
  EXPECT_NEAR(far.ToCanvas(anchor).x, before.x, kTol);
}

TEST(NodeEditorTransform, FitCentresTheBoxAndZoomsOutOnlyAsNeeded) {
  // A 1000 x 200 box in a 520 x 400 widget with a 10-pixel margin: zoom (520 - 20)/1000.
  const Transform t = Fit(ImVec2(0, 0), ImVec2(520, 400), ImVec2(0, 0), ImVec2(1000, 200), 10, 1);
  EXPECT_NEAR(t.zoom, 0.5f, kTol);
  const ImVec2 centre = t.ToScreen(ImVec2(500, 100));
  EXPECT_NEAR(centre.x, 260, kTol);
  EXPECT_NEAR(centre.y, 200, kTol);
  // A small box is not blown up beyond the maximum zoom.
  const Transform small = Fit(ImVec2(0, 0), ImVec2(520, 400), ImVec2(0, 0), ImVec2(50, 50), 10, 1);
  EXPECT_NEAR(small.zoom, 1.0f, kTol);
}

TEST(NodeEditorLayout, PutsInPortsOnTheLeftEdgeAndOutPortsOnTheRight) {
  diagram::Block lag = Lag(3, "mfv");
  lag.fields["tau"] = "tau_fv";
  const Metrics m;
  const BlockShape s = LayoutBlock(lag, {360, 40}, Chars, m);
  EXPECT_NEAR(s.min.x, 360, kTol);
  EXPECT_NEAR(s.min.y, 40, kTol);
  ASSERT_EQ(s.ports.size(), 3u);  // u, noise | out
  EXPECT_EQ(s.ports[0].ref, diagram::In(3, 0));
  EXPECT_EQ(s.ports[1].ref, diagram::In(3, 1));
  EXPECT_EQ(s.ports[1].type, diagram::PortType::kNoise);
  EXPECT_EQ(s.ports[2].ref, diagram::Out(3, 0));
  EXPECT_NEAR(s.ports[0].pos.x, s.min.x, kTol);
  EXPECT_NEAR(s.ports[2].pos.x, s.max.x, kTol);
  EXPECT_NEAR(s.ports[0].pos.y, 40 + m.header + 0.5f * m.row, kTol);
  EXPECT_NEAR(s.ports[1].pos.y, 40 + m.header + 1.5f * m.row, kTol);
  // Two port rows and three field lines (K, tau, x0), the widest line sets the width.
  ASSERT_EQ(s.lines.size(), 3u);
  EXPECT_EQ(s.lines[1].text, "tau = tau_fv");
  EXPECT_NEAR(s.max.y - s.min.y, m.header + 5 * m.row + 0.5f * m.pad, kTol);
  EXPECT_NEAR(s.max.x - s.min.x, std::max(m.min_width, Chars("tau = tau_fv") + 2 * m.pad), kTol);
}

TEST(NodeEditorHitTest, PortsComeBeforeBlocksAndTheTopBlockWins) {
  const Metrics m;
  std::vector<BlockShape> blocks = {LayoutBlock(Lag(1, "a"), {0, 0}, Chars, m),
                                    LayoutBlock(Lag(2, "b"), {30, 10}, Chars, m)};
  // On block 2's first in-port (it lies inside block 1's box as well).
  const ImVec2 port = blocks[1].ports[0].pos;
  Hit hit = HitTest(blocks, {}, ImVec2(port.x + 2, port.y - 2), m);
  EXPECT_EQ(hit.kind, Hit::Kind::kPort);
  EXPECT_EQ(hit.port, diagram::In(2, 0));
  // Inside both boxes, away from ports: block 2, drawn last.
  hit = HitTest(blocks, {}, ImVec2(60, 60), m);
  EXPECT_EQ(hit.kind, Hit::Kind::kBlock);
  EXPECT_EQ(hit.block, 2);
  // Inside block 1 only.
  hit = HitTest(blocks, {}, ImVec2(15, 5), m);
  EXPECT_EQ(hit.block, 1);
  // Nothing far away.
  EXPECT_EQ(HitTest(blocks, {}, ImVec2(900, 900), m).kind, Hit::Kind::kNone);
}

TEST(NodeEditorHitTest, FindsALinkAtItsBezierMidpoint) {
  LinkShape l = LinkCurve(ImVec2(100, 40), ImVec2(300, 140));
  l.id = 17;
  const ImVec2 mid((l.p0.x + 3 * l.p1.x + 3 * l.p2.x + l.p3.x) / 8,
                   (l.p0.y + 3 * l.p1.y + 3 * l.p2.y + l.p3.y) / 8);
  EXPECT_NEAR(BezierPoint(l, 0.5f).x, mid.x, kTol);
  EXPECT_NEAR(BezierPoint(l, 0.5f).y, mid.y, kTol);
  EXPECT_LT(DistanceToLink(l, mid), 0.5f);
  const Metrics m;
  Hit hit = HitTest({}, {l}, ImVec2(mid.x, mid.y + 2), m);
  EXPECT_EQ(hit.kind, Hit::Kind::kLink);
  EXPECT_EQ(hit.link, 17);
  // The curve crosses its midpoint at 45 degrees here, so 20 units above it is about 14 units
  // from the curve: beyond the tolerance.
  EXPECT_EQ(HitTest({}, {l}, ImVec2(mid.x, mid.y - 20), m).kind, Hit::Kind::kNone);
  // The tangents are horizontal at both ends (the curve leaves and enters sideways).
  EXPECT_NEAR(l.p1.y, l.p0.y, kTol);
  EXPECT_NEAR(l.p2.y, l.p3.y, kTol);
}

TEST(NodeEditorHitTest, BoxSelectsTheBlocksItTouches) {
  const Metrics m;
  std::vector<BlockShape> blocks = {LayoutBlock(Lag(1, "a"), {0, 0}, Chars, m),
                                    LayoutBlock(Lag(2, "b"), {300, 0}, Chars, m),
                                    LayoutBlock(Lag(3, "c"), {0, 300}, Chars, m)};
  // Dragged from bottom-right to top-left: the same box.
  EXPECT_EQ(BlocksInBox(blocks, ImVec2(350, 50), ImVec2(-10, -10)), (std::vector<int>{1, 2}));
  EXPECT_TRUE(BlocksInBox(blocks, ImVec2(200, 200), ImVec2(250, 250)).empty());
}

TEST(NodeEditorLayout, FreeSpotsNeverOverlapAPlacedBlock) {
  const Metrics m;
  std::vector<BlockShape> blocks;
  for (int i = 1; i <= 12; ++i) {
    BlockShape probe = LayoutBlock(Lag(i, "x" + std::to_string(i)), {0, 0}, Chars, m);
    const ImVec2 size(probe.max.x - probe.min.x, probe.max.y - probe.min.y);
    const ImVec2 at = FreeSpot(blocks, ImVec2(100, 100), size);
    blocks.push_back(LayoutBlock(Lag(i, "x" + std::to_string(i)), {at.x, at.y}, Chars, m));
  }
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    for (std::size_t j = i + 1; j < blocks.size(); ++j) {
      const BlockShape& a = blocks[i];
      const BlockShape& b = blocks[j];
      const bool overlap =
          a.min.x < b.max.x && b.min.x < a.max.x && a.min.y < b.max.y && b.min.y < a.max.y;
      EXPECT_FALSE(overlap) << "blocks " << a.id << " and " << b.id;
    }
  }
  // The first one goes exactly where it was asked.
  EXPECT_NEAR(blocks[0].min.x, 100, kTol);
  EXPECT_NEAR(blocks[0].min.y, 100, kTol);
}

}  // namespace
}  // namespace gb::ui::node_editor
