// The diagram view driven through synthetic ImGui input, as a user would use it: build the fuel
// film of Fig. 1 from the palette (place blocks, type names and expressions, drag links), and
// the model it compiles to has the log-likelihood of the hand-written model on the f1 data;
// undo and redo walk back and forth through exactly the diagrams that were there; a link core
// refuses, a refused expression, Del, moves (layout only) and a project with a diagram.
//
// The reference log-likelihood comes from core, on the hand-written assets/models/fuel_film.json
// and assets/data/fuel_f1.csv, not from anything the GUI computed.
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/diagram/diagram.h"
#include "core/model/model.h"
#include "core/project/problem.h"
#include "core/project/project.h"
#include "core/util/file.h"
#include "tests/ui/workbench_driver.h"
#include "ui/widgets/node_editor.h"

#ifndef GREYBENCH_SOURCE_DIR
#error "GREYBENCH_SOURCE_DIR must name the source tree (tests/ui/CMakeLists.txt sets it)"
#endif

namespace gb::ui {
namespace {

using testing::kSource;
using testing::WorkbenchDriver;

const std::string kEquationsProject = kSource + "/assets/projects/fuel_f1.json";
const std::string kDiagramProject = kSource + "/assets/projects/fuel_film_diagram.json";
const std::string kHandWritten = kSource + "/assets/models/fuel_film.json";
const std::string kF1 = kSource + "/assets/data/fuel_f1.csv";
constexpr double kLoglikTol = 1e-9;  // relative: the same filter on the same numbers
constexpr int kDeleteKey = 14;       // our indices into io.KeysDown
constexpr int kZKey = 'Z';
constexpr int kYKey = 'Y';

// log L of `spec` on f1 at its start values (parameters looked up by name in `reference`, so
// the order of the table does not matter) with the given output delay.
double Loglik(const model::ModelSpec& spec, const model::ModelSpec& reference, int delay) {
  std::vector<double> theta;
  for (const model::Parameter& p : spec.parameters) {
    const int i = reference.ParameterIndex(p.name);
    EXPECT_GE(i, 0) << p.name;
    theta.push_back(i >= 0 ? reference.parameters[i].value : p.value);
  }
  auto problem = project::LoadProblem(spec, {kF1});
  EXPECT_TRUE(problem.ok()) << problem.error().ToString();
  auto lik = project::MakeLikelihood(*problem);
  EXPECT_TRUE(lik.ok()) << lik.error().ToString();
  const std::vector<int> delays = {delay};
  auto l = lik->Evaluate(theta, delays);
  EXPECT_TRUE(l.ok()) << l.error().ToString();
  return l.ok() ? l->loglik : NAN;
}

// Drives the diagram view: finds its palette, canvas and inspector, and the ports on screen.
class DiagramDriver {
 public:
  explicit DiagramDriver(const std::string& project) {
    d.Open(project);
    d.state.view = View::kDiagram;
    ImGuiIO& io = ImGui::GetIO();
    io.KeyMap[ImGuiKey_Delete] = kDeleteKey;
    io.KeyMap[ImGuiKey_Z] = kZKey;
    io.KeyMap[ImGuiKey_Y] = kYKey;
    d.Frame();
    d.Frame();
  }

  const diagram::BlockDiagram& diagram() const { return *d.state.diagram_view.diagram; }
  Json DiagramJson() const { return diagram::ToJson(diagram()); }

  static ImGuiWindow* Child(const char* name) {
    return WorkbenchDriver::FindWindow("##workbench/##view_", name);
  }

  // Scans `w` (the part of it between the fractions x0..x1 of its width, top to bottom) until
  // `id` is hovered.
  std::optional<ImVec2> FindIn(ImGuiWindow* w, ImGuiID id, float x0 = 0.0f, float x1 = 1.0f,
                               float step_x = 12.0f, float step_y = 4.0f, float max_y = FLT_MAX) {
    if (!w) return std::nullopt;
    const ImRect r = w->Rect();
    const float first_x = r.Min.x + x0 * r.GetWidth() + 2;
    const float last_x = std::max(first_x, r.Min.x + x1 * r.GetWidth());
    for (float y = r.Min.y + 2; y < std::min(r.Max.y, max_y); y += step_y) {
      for (float x = first_x; x <= last_x; x += step_x) {
        d.MouseTo(ImVec2(x, y));
        if (ImGui::GetHoveredID() == id) return ImVec2(x, y);
      }
    }
    return std::nullopt;
  }

  // A button of the toolbar (drawn in the view area under PushID(view)). Toolbar and palette
  // buttons stay where they are, so each is looked for once.
  bool ClickToolbar(const char* label) {
    ImGuiWindow* view = WorkbenchDriver::ViewWindow();
    if (!view) return false;
    return ClickCached(label, view, d.ViewItemId(label), 0.0f, 0.6f, view->Pos.y + 90);
  }

  bool Place(const char* palette_label) {
    ImGuiWindow* palette = Child("/##palette_");
    if (!palette) return false;
    return ClickCached(palette_label, palette, ImHashStr(palette_label, 0, palette->ID), 0.5f, 0.5f,
                       FLT_MAX);
  }

  // Types `text` into the inspector field `field` of the selected block and presses Enter.
  bool TypeField(const std::string& field, const std::string& text) {
    ImGuiWindow* inspector = Child("/##inspector_");
    if (!inspector) return false;
    // The field's table sits in the left column of the inspector's two-column table.
    const ImGuiID columns = ImHashStr("##inspector_columns", 0, inspector->ID);
    const ImGuiID table = ImHashStr("##fields", 0, columns);
    const auto at = FindIn(inspector, ImHashStr(("##" + field).c_str(), 0, table), 0.3f, 0.3f);
    if (!at) return false;
    d.Click(*at);
    d.Type(text.c_str());
    d.PressEnter();
    d.MouseTo(ImVec2(1, 1));
    return true;
  }

  node_editor::Transform CanvasTransform() const {
    ImGuiWindow* canvas = Child("/##canvas_");
    node_editor::Transform t;
    t.origin = canvas ? canvas->DC.CursorStartPos : ImVec2(0, 0);
    t.scroll = d.state.diagram_view.editor.scroll;
    t.zoom = d.state.diagram_view.editor.zoom * d.state.fonts.scale;
    return t;
  }

  ImVec2 PortOnScreen(const diagram::PortRef& ref) const {
    const auto shapes =
        node_editor::LayoutDiagram(diagram(), node_editor::FontTextWidth(d.state.fonts.regular));
    for (const auto& s : shapes)
      for (const auto& p : s.ports)
        if (p.ref == ref) return CanvasTransform().ToScreen(p.pos);
    ADD_FAILURE() << "no port " << ref.block << "/" << ref.index;
    return ImVec2(-1, -1);
  }

  ImVec2 BlockOnScreen(int id) const {
    const auto shapes =
        node_editor::LayoutDiagram(diagram(), node_editor::FontTextWidth(d.state.fonts.regular));
    for (const auto& s : shapes)
      if (s.id == id)
        return CanvasTransform().ToScreen(ImVec2(0.5f * (s.min.x + s.max.x), s.min.y + 8));
    ADD_FAILURE() << "no block " << id;
    return ImVec2(-1, -1);
  }

  void Drag(ImVec2 from, ImVec2 to) {
    d.MouseTo(from);
    d.Press();
    d.MouseTo(ImVec2(0.5f * (from.x + to.x), 0.5f * (from.y + to.y)));
    d.MouseTo(to);
    d.Release();
    d.MouseTo(ImVec2(1, 1));
  }

  void Link(diagram::PortRef from, diagram::PortRef to) {
    Drag(PortOnScreen(from), PortOnScreen(to));
  }

  void Key(int key, bool ctrl = false) {
    ImGuiIO& io = ImGui::GetIO();
    io.KeyCtrl = ctrl;
    io.KeysDown[key] = true;
    d.Frame();
    io.KeysDown[key] = false;
    d.Frame();
    io.KeyCtrl = false;
    d.Frame();
  }

  int Selected() const {
    const auto& s = d.state.diagram_view.editor.selected_blocks;
    return s.size() == 1 ? s[0] : 0;
  }

  WorkbenchDriver d;

 private:
  bool ClickCached(const std::string& key, ImGuiWindow* w, ImGuiID id, float x0, float x1,
                   float max_y) {
    auto it = found_.find(key);
    if (it == found_.end()) {
      const auto at = FindIn(w, id, x0, x1, 10.0f, 5.0f, max_y);
      if (!at) return false;
      it = found_.emplace(key, *at).first;
    }
    d.Click(it->second);
    return true;
  }

  std::map<std::string, ImVec2> found_;
};

TEST(WorkbenchDiagram, FuelFilmBuiltFromThePaletteHasTheLoglikOfTheHandWrittenModel) {
  DiagramDriver dd(kEquationsProject);
  AppState& state = dd.d.state;
  ASSERT_TRUE(state.model) << state.model_error;
  ASSERT_TRUE(state.diagram_view.diagram) << state.diagram_view.error;
  EXPECT_TRUE(state.diagram_view.from_model);  // FromModel's picture of the equations
  EXPECT_EQ(dd.diagram().blocks.size(), 6u);   // input, 2 states, 2 noises, output

  // Every accepted step, so undo and redo can be checked against exactly these diagrams.
  std::vector<Json> history = {dd.DiagramJson()};
  auto step = [&](const char* what) {
    const Json now = dd.DiagramJson();
    EXPECT_NE(now, history.back()) << what << " changed nothing";
    EXPECT_FALSE(state.diagram_view.refusal) << what << ": " << state.diagram_view.refusal->reason;
    history.push_back(now);
  };

  ASSERT_TRUE(dd.ClickToolbar("New diagram"));
  step("new diagram");
  EXPECT_TRUE(dd.diagram().blocks.empty());
  EXPECT_EQ(dd.diagram().parameters.size(), state.model->parameters.size());

  struct Placed {
    const char* palette;
    std::vector<std::pair<std::string, std::string>> fields;
  };
  const std::vector<Placed> blocks = {
      {"Input", {{"name", "mfi"}}},
      {"Split X / 1\xE2\x88\x92X", {{"X", "X"}}},
      {"First-order lag", {{"name", "mfv"}, {"tau", "tau_fv"}, {"x0", "(1 - X)*mfi0"}}},
      {"First-order lag", {{"name", "mff"}, {"tau", "tau_ff"}, {"x0", "X*mfi0"}}},
      {"Sum", {}},
      {"Gain", {{"k", "Kb"}}},
      {"Transport delay", {{"delay", "0..10"}}},
      {"Output / sensor", {{"name", "ilambda"}, {"variance", "s2"}}},
      {"Process noise", {{"sigma", "sqrt(s11)"}}},
      {"Process noise", {{"sigma", "sqrt(s12)"}}},
  };
  std::vector<int> ids;
  for (const Placed& p : blocks) {
    ASSERT_TRUE(dd.Place(p.palette)) << "palette button " << p.palette;
    step(p.palette);
    ids.push_back(dd.diagram().blocks.back().id);
    ASSERT_EQ(dd.Selected(), ids.back()) << "the placed block is selected";
    for (const auto& [field, text] : p.fields) {
      ASSERT_TRUE(dd.TypeField(field, text)) << p.palette << "." << field;
      step((std::string(p.palette) + "." + field).c_str());
    }
  }
  // Placed blocks never overlap.
  const auto shapes =
      node_editor::LayoutDiagram(dd.diagram(), node_editor::FontTextWidth(state.fonts.regular));
  for (std::size_t i = 0; i < shapes.size(); ++i)
    for (std::size_t j = i + 1; j < shapes.size(); ++j)
      EXPECT_FALSE(shapes[i].min.x < shapes[j].max.x && shapes[j].min.x < shapes[i].max.x &&
                   shapes[i].min.y < shapes[j].max.y && shapes[j].min.y < shapes[i].max.y)
          << "blocks " << shapes[i].id << " and " << shapes[j].id << " overlap";

  ASSERT_TRUE(dd.ClickToolbar("Fit view"));
  const int input = ids[0], split = ids[1], mfv = ids[2], mff = ids[3], sum = ids[4], gain = ids[5],
            delay = ids[6], output = ids[7], n11 = ids[8], n12 = ids[9];
  using diagram::In;
  using diagram::Out;
  const std::vector<std::pair<diagram::PortRef, diagram::PortRef>> links = {
      {Out(input), In(split)}, {Out(split, 1), In(mfv)}, {Out(split, 0), In(mff)},
      {Out(mfv), In(sum, 0)},  {In(sum, 1), Out(mff)},  // drawn backwards: the same link
      {Out(sum), In(gain)},    {Out(gain), In(delay)},   {Out(delay), In(output)},
      {Out(n11), In(mfv, 1)},  {Out(n12), In(mff, 1)},
  };
  const int revision_before_links = state.model_revision;
  for (const auto& [a, b] : links) {
    dd.Link(a, b);
    step("link");
  }
  EXPECT_EQ(dd.diagram().links.size(), links.size());

  // The last link made it compile: the model is the diagram's.
  EXPECT_TRUE(state.diagram_view.problems.empty())
      << state.diagram_view.problems.front().ToString();
  EXPECT_TRUE(state.diagram_view.model_from_diagram);
  EXPECT_GT(state.model_revision, revision_before_links);
  ASSERT_TRUE(state.model);
  const auto hand = model::LoadModelFile(kHandWritten);
  ASSERT_TRUE(hand.ok()) << hand.error().ToString();
  for (int lag : {0, 6}) {
    const double want = Loglik(*hand, *hand, lag);
    const double got = Loglik(*state.model, *hand, lag);
    EXPECT_TRUE(std::isfinite(want));
    EXPECT_NEAR(got, want, kLoglikTol * std::abs(want)) << "delay " << lag;
  }
  // The project holds the diagram as it now is (File > Save writes it).
  EXPECT_EQ(state.project->extra["diagram"], dd.DiagramJson());
  EXPECT_EQ(state.project->model_json, model::ToJson(*state.model));

  // Undo walks back through exactly the recorded diagrams (Ctrl+Z and the button), redo forward.
  const Json built = dd.DiagramJson();
  for (std::size_t k = history.size() - 1; k-- > 0;) {
    if (k % 2 == 0) {
      dd.Key(kZKey, /*ctrl=*/true);
    } else {
      ASSERT_TRUE(dd.ClickToolbar("Undo"));
    }
    ASSERT_EQ(dd.DiagramJson(), history[k]) << "after undoing to step " << k;
  }
  for (std::size_t k = 1; k < history.size(); ++k) {
    if (k % 2 == 0) {
      dd.Key(kYKey, /*ctrl=*/true);
    } else {
      ASSERT_TRUE(dd.ClickToolbar("Redo"));
    }
    ASSERT_EQ(dd.DiagramJson(), history[k]) << "after redoing to step " << k;
  }
  EXPECT_EQ(dd.DiagramJson(), built);
  EXPECT_TRUE(state.diagram_view.problems.empty());
  EXPECT_NEAR(Loglik(*state.model, *hand, 6), Loglik(*hand, *hand, 6),
              kLoglikTol * std::abs(Loglik(*hand, *hand, 6)));
}

TEST(WorkbenchDiagram, AProjectDiagramSuppliesTheModelAndTheEquationsViewSaysSo) {
  DiagramDriver dd(kDiagramProject);
  AppState& state = dd.d.state;
  ASSERT_TRUE(state.diagram_view.diagram) << state.diagram_view.error;
  EXPECT_FALSE(state.diagram_view.from_model);
  EXPECT_TRUE(state.diagram_view.model_from_diagram);
  EXPECT_TRUE(state.diagram_view.problems.empty());
  ASSERT_TRUE(state.model);
  const auto hand = model::LoadModelFile(kHandWritten);
  ASSERT_TRUE(hand.ok());
  EXPECT_NEAR(Loglik(*state.model, *hand, 6), Loglik(*hand, *hand, 6),
              kLoglikTol * std::abs(Loglik(*hand, *hand, 6)));
  state.view = View::kEquations;
  dd.d.Frame();
  const std::string log = dd.d.Text();
  EXPECT_NE(log.find("compiled from the block diagram"), std::string::npos) << log;
}

TEST(WorkbenchDiagram, ALinkCoreRefusesLeavesTheDiagramUnchangedAndSaysWhy) {
  DiagramDriver dd(kDiagramProject);
  AppState& state = dd.d.state;
  const Json before = dd.DiagramJson();
  const int revision = state.model_revision;
  // Out-port of the gain (block 6) to the out-port of the sum (block 5).
  dd.Link(diagram::Out(6), diagram::Out(5));
  EXPECT_EQ(dd.DiagramJson(), before);
  EXPECT_EQ(state.model_revision, revision);
  ASSERT_TRUE(state.diagram_view.refusal);
  EXPECT_NE(state.diagram_view.refusal->reason.find("out-port to an out-port"), std::string::npos)
      << state.diagram_view.refusal->reason;
  EXPECT_TRUE(state.diagram_view.undo.empty()) << "a refused edit is not a step";
  EXPECT_NE(dd.d.Text().find("Refused: "), std::string::npos);

  // Into an in-port that already holds a link (the film lag's input, from the split).
  dd.Link(diagram::Out(1), diagram::In(4));
  EXPECT_EQ(dd.DiagramJson(), before);
  ASSERT_TRUE(state.diagram_view.refusal);
  EXPECT_NE(state.diagram_view.refusal->reason.find("already connected"), std::string::npos)
      << state.diagram_view.refusal->reason;
}

TEST(WorkbenchDiagram, ARefusedExpressionIsShownWithCoresReasonAndChangesNothing) {
  DiagramDriver dd(kDiagramProject);
  AppState& state = dd.d.state;
  const Json before = dd.DiagramJson();
  dd.d.Click(dd.BlockOnScreen(3));  // the vapour lag
  ASSERT_EQ(dd.Selected(), 3);
  ASSERT_TRUE(dd.TypeField("tau", "tau_fvv"));
  EXPECT_EQ(dd.DiagramJson(), before);
  ASSERT_TRUE(state.diagram_view.refusal);
  const std::string reason = state.diagram_view.refusal->reason;
  EXPECT_NE(reason.find("tau_fvv"), std::string::npos) << reason;
  EXPECT_NE(reason.find("tau_fv"), std::string::npos) << "suggests the near name: " << reason;
  EXPECT_NE(dd.d.Text().find(reason), std::string::npos) << "the inspector shows the reason";
  // Corrected, it is accepted and the refusal goes.
  ASSERT_TRUE(dd.TypeField("tau", "tau_ff"));
  EXPECT_FALSE(state.diagram_view.refusal);
  EXPECT_EQ(dd.diagram().FindBlock(3)->fields.at("tau"), "tau_ff");
}

TEST(WorkbenchDiagram, MovingBlocksChangesOnlyTheLayoutAndDelDeletes) {
  DiagramDriver dd(kDiagramProject);
  AppState& state = dd.d.state;
  const int model_revision = state.model_revision;
  const int layout_revision = state.layout_revision;
  const auto before = dd.diagram().layout.positions.at(6);
  const ImVec2 grab = dd.BlockOnScreen(6);
  dd.Drag(grab, ImVec2(grab.x + 30, grab.y + 40));
  const auto after = dd.diagram().layout.positions.at(6);
  const float zoom = dd.CanvasTransform().zoom;
  EXPECT_NEAR(after[0] - before[0], 30 / zoom, 1.0);
  EXPECT_NEAR(after[1] - before[1], 40 / zoom, 1.0);
  EXPECT_EQ(state.model_revision, model_revision);
  EXPECT_EQ(state.layout_revision, layout_revision + 1);
  EXPECT_EQ(state.project->extra["diagram"], dd.DiagramJson());

  // Del removes the selected block and its links; the diagram no longer compiles and the
  // workbench keeps the last model that did.
  ASSERT_EQ(dd.Selected(), 6);
  const std::size_t links = dd.diagram().links.size();
  dd.Key(kDeleteKey);
  EXPECT_EQ(dd.diagram().FindBlock(6), nullptr);
  EXPECT_EQ(dd.diagram().links.size(), links - 2);
  EXPECT_FALSE(state.diagram_view.problems.empty());
  EXPECT_EQ(state.model_revision, model_revision);
  ASSERT_TRUE(state.model);
}

TEST(WorkbenchDiagram, AStartValueEditedInTheParametersViewSurvivesTheNextRecompile) {
  DiagramDriver dd(kDiagramProject);
  AppState& state = dd.d.state;
  ParameterEdit edit;
  edit.parameter = "tau_fv";
  edit.number = 0.12;
  edit.text = "0.12";
  state.parameters_view.pending.push_back(edit);
  ApplyParameterEdits(state);
  ASSERT_EQ(state.model->parameters[state.model->ParameterIndex("tau_fv")].value, 0.12);
  const auto& table = dd.diagram().parameters;
  const auto it = std::find_if(table.begin(), table.end(),
                               [](const model::Parameter& p) { return p.name == "tau_fv"; });
  ASSERT_NE(it, table.end());
  EXPECT_EQ(it->value, 0.12);
  EXPECT_EQ(state.project->extra["diagram"], dd.DiagramJson());
  // A diagram edit recompiles from the diagram's table: the new start value stays.
  dd.d.Click(dd.BlockOnScreen(6));  // the gain
  ASSERT_EQ(dd.Selected(), 6);
  ASSERT_TRUE(dd.TypeField("k", "2*Kb"));
  EXPECT_FALSE(state.diagram_view.refusal);
  EXPECT_EQ(state.model->parameters[state.model->ParameterIndex("tau_fv")].value, 0.12);
}

TEST(WorkbenchDiagram, BoxSelectThenDragMovesTheSelectionAsOneUndoStep) {
  DiagramDriver dd(kDiagramProject);
  AppState& state = dd.d.state;
  const Json before = dd.DiagramJson();
  // A box around the gain (6) and the delay (7), dragged from empty canvas above-left of the gain
  // to below-right of the delay.
  const auto shapes =
      node_editor::LayoutDiagram(dd.diagram(), node_editor::FontTextWidth(state.fonts.regular));
  ImVec2 lo(FLT_MAX, FLT_MAX), hi(-FLT_MAX, -FLT_MAX);
  for (const auto& s : shapes) {
    if (s.id != 6 && s.id != 7) continue;
    lo = ImVec2(std::min(lo.x, s.min.x), std::min(lo.y, s.min.y));
    hi = ImVec2(std::max(hi.x, s.max.x), std::max(hi.y, s.max.y));
  }
  const node_editor::Transform t = dd.CanvasTransform();
  dd.Drag(t.ToScreen(ImVec2(lo.x - 5, lo.y - 30)), t.ToScreen(ImVec2(hi.x - 5, hi.y + 20)));
  auto selected = state.diagram_view.editor.selected_blocks;
  std::sort(selected.begin(), selected.end());
  EXPECT_EQ(selected, (std::vector<int>{6, 7}));
  EXPECT_EQ(dd.DiagramJson(), before) << "selecting is not an edit";

  const auto gain = dd.diagram().layout.positions.at(6);
  const auto delay = dd.diagram().layout.positions.at(7);
  const ImVec2 grab = dd.BlockOnScreen(7);
  dd.Drag(grab, ImVec2(grab.x, grab.y + 60));
  const double dy = dd.diagram().layout.positions.at(6)[1] - gain[1];
  EXPECT_NEAR(dy, 60 / t.zoom, 1.0);
  EXPECT_EQ(dd.diagram().layout.positions.at(7)[1] - delay[1], dy) << "moved together";
  EXPECT_EQ(dd.diagram().layout.positions.at(6)[0], gain[0]);
  ASSERT_EQ(state.diagram_view.undo.size(), 1u);
  ASSERT_TRUE(dd.ClickToolbar("Undo"));
  EXPECT_EQ(dd.DiagramJson(), before);
}

TEST(WorkbenchDiagram, WheelZoomsAboutTheCursorAndMiddleDragPans) {
  DiagramDriver dd(kDiagramProject);
  AppState& state = dd.d.state;
  const Json before = dd.DiagramJson();
  const node_editor::Transform t0 = dd.CanvasTransform();
  const ImVec2 cursor = ImFloor(dd.BlockOnScreen(5));  // ImGui floors the mouse position
  const ImVec2 under = t0.ToCanvas(cursor);
  dd.d.MouseTo(cursor);
  ImGuiIO& io = ImGui::GetIO();
  io.MouseWheel = 2.0f;
  dd.d.Frame();
  io.MouseWheel = 0.0f;
  dd.d.Frame();
  const node_editor::Transform t1 = dd.CanvasTransform();
  EXPECT_GT(t1.zoom, t0.zoom * 1.2f);
  EXPECT_NEAR(t1.ToCanvas(cursor).x, under.x, 0.01);
  EXPECT_NEAR(t1.ToCanvas(cursor).y, under.y, 0.01);

  // Middle drag by (40, -25) pixels: the canvas follows the mouse.
  io.MouseDown[2] = true;
  dd.d.Frame();
  dd.d.MouseTo(ImVec2(cursor.x + 40, cursor.y - 25));
  io.MouseDown[2] = false;
  dd.d.Frame();
  const node_editor::Transform t2 = dd.CanvasTransform();
  EXPECT_NEAR(t2.ToCanvas(ImVec2(cursor.x + 40, cursor.y - 25)).x, under.x, 0.01);
  EXPECT_NEAR(t2.ToCanvas(ImVec2(cursor.x + 40, cursor.y - 25)).y, under.y, 0.01);
  EXPECT_EQ(dd.DiagramJson(), before) << "the view is not the diagram";
  EXPECT_EQ(state.layout_revision, 0);
}

TEST(WorkbenchDiagram, AnUnreadableDiagramIsNamedAndTheModelFileIsUsed) {
  const std::string path = ::testing::TempDir() + "/greybench_bad_diagram_project.json";
  {
    Json project = {
        {"greybench_project", 1},
        {"name", "bad diagram"},
        {"model", kHandWritten},
        {"datasets", Json::array({kF1})},
        {"diagram",
         {{"greybench_diagram", 1}, {"blocks", Json::array({{{"id", 1}, {"kind", "spilt"}}})}}}};
    ASSERT_TRUE(WriteFileAtomic(path, project.dump()).ok());
  }
  DiagramDriver dd(path);
  AppState& state = dd.d.state;
  EXPECT_FALSE(state.diagram_view.diagram);
  EXPECT_NE(state.diagram_view.error.find("diagram.blocks[0].kind"), std::string::npos)
      << state.diagram_view.error;
  EXPECT_NE(state.diagram_view.error.find("spilt"), std::string::npos);
  ASSERT_TRUE(state.model) << "the model file is still used";
  EXPECT_FALSE(state.diagram_view.model_from_diagram);
  const std::string log = dd.d.Text();
  EXPECT_NE(log.find("spilt"), std::string::npos) << log;
}

TEST(WorkbenchDiagram, AtAHighZoomTheCanvasTextGetsAFontBakedForTheZoom) {
  // The regular font scaled up blurs; the view asks for a font baked at the zoom (rounded up to
  // a half, at most 3x) once the zoom has settled for 0.3 s, and the window rebuilds the atlas
  // with it (here as the window does, without a renderer); back at zoom 1 it goes.
  WorkbenchDriver d;
  d.Open(kDiagramProject);
  ASSERT_TRUE(d.state.diagram_view.diagram);
  d.state.view = View::kDiagram;
  d.Frame();
  auto rebuild = [&d] {
    ImGuiIO& io = ImGui::GetIO();
    io.Fonts->Clear();
    SetUpWorkbench(d.state, 1.0f);
    unsigned char* pixels = nullptr;
    int w = 0, h = 0;
    io.Fonts->GetTexDataAsRGBA32(&pixels, &w, &h);
  };
  auto settle = [&d] {
    for (int i = 0; i < 30; ++i) d.Frame();  // half a second at 60 frames a second
  };
  d.state.diagram_view.editor.zoom = 2.2f;
  d.Frame();
  EXPECT_EQ(d.state.fonts.wanted_canvas_zoom, 1.0f);  // not while the zoom may still move
  settle();
  EXPECT_EQ(d.state.fonts.wanted_canvas_zoom, 2.5f);
  rebuild();
  ASSERT_NE(d.state.fonts.canvas, nullptr);
  EXPECT_EQ(d.state.fonts.canvas_zoom, 2.5f);
  EXPECT_NEAR(d.state.fonts.canvas->FontSize, 2.5f * d.state.fonts.regular->FontSize, 1.0f);
  settle();  // draws with it
  EXPECT_EQ(d.state.fonts.wanted_canvas_zoom, 2.5f);

  d.state.diagram_view.editor.zoom = 9.0f;  // beyond the limit
  settle();
  EXPECT_EQ(d.state.fonts.wanted_canvas_zoom, kMaxCanvasZoom);
  d.state.diagram_view.editor.zoom = 0.8f;
  settle();
  EXPECT_EQ(d.state.fonts.wanted_canvas_zoom, 1.0f);
  rebuild();
  EXPECT_EQ(d.state.fonts.canvas, nullptr);
  EXPECT_EQ(d.state.fonts.canvas_zoom, 1.0f);
}

}  // namespace
}  // namespace gb::ui
