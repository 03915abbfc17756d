// Drives the whole workbench in a headless ImGui context (no GL): frames are drawn exactly as
// greybench draws them, input is synthetic (mouse position and buttons, characters, keys),
// and an item is found the way a user finds it, by moving the mouse until ImGui reports it
// hovered.
//
// Items are named by their ImGui id: the window they are drawn in (found by the name ImGui
// gives a child window, "<parent>/<child>_<hex id>") and the ids pushed on the way, hashed as
// ImGui hashes them (ImHashData for PushID(int), ImHashStr for labels). This ties the tests to
// the id structure of the panels (the view's child window, PushID(view), the labels), which is
// part of what they test.
#pragma once

#include <chrono>
#include <cstring>
#include <functional>
#include <optional>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <imgui.h>
#include <imgui_internal.h>

#include "core/util/json.h"
#include "core/util/sanitizers.h"
#include "ui/panels/panels.h"
#include "ui/state/app_state.h"
#include "ui/theme.h"
#include "ui/workbench.h"

namespace gb::ui::testing {

// Paths the workbench tests share (GREYBENCH_SOURCE_DIR: the source tree, set by CMake).
inline const std::string kSource = GREYBENCH_SOURCE_DIR;
inline const std::string kTestProject = kSource + "/tests/data/ui/project.json";
inline const std::string kCaseStudy = kSource + "/assets/projects/case_study.json";
// How soon Cancel must stop a job that is fitting.
inline constexpr std::chrono::milliseconds kCancelDeadline{100};

class WorkbenchDriver {
 public:
  static constexpr float kWidth = 1280.0f;
  static constexpr float kHeight = 800.0f;
  static constexpr int kEnterKey = 13;  // our index into io.KeysDown for ImGuiKey_Enter

  WorkbenchDriver() {
    context_ = ImGui::CreateContext();
    SetUpWorkbench(state, 1.0f);
    // Under the sanitizers (some 40x slower) the sweeps run the quick way (SweepState::quick:
    // the same estimates, delays and table in a fraction of the fits), as the snapshot test
    // runs them there (--quick-sweep); the release suite runs them in full.
    state.sweep.quick = kSanitized;
    ImGuiIO& io = ImGui::GetIO();
    unsigned char* pixels = nullptr;
    int w = 0, h = 0;
    io.Fonts->GetTexDataAsRGBA32(&pixels, &w, &h);  // builds the atlas (no renderer here)
    io.DisplaySize = ImVec2(kWidth, kHeight);
    io.DeltaTime = 1.0f / 60.0f;
    // As ui/render/fixed_gl_renderer.cpp: a plot of 10 000 points needs more than 65 536
    // vertices, which ImGui then draws in several parts of one draw list.
    io.BackendFlags |= ImGuiBackendFlags_RendererHasVtxOffset;
    io.KeyMap[ImGuiKey_Enter] = kEnterKey;
    io.MousePos = ImVec2(-FLT_MAX, -FLT_MAX);
  }
  ~WorkbenchDriver() {
    // Stop a run under way before ImGui goes (AppState's jobs wait for their threads).
    state.estimation.job.RequestCancel();
    state.estimation.job.Wait();
    ImGui::DestroyContext(context_);
  }
  WorkbenchDriver(const WorkbenchDriver&) = delete;
  WorkbenchDriver& operator=(const WorkbenchDriver&) = delete;

  void Open(const std::string& project) {
    OpenProject(state, project);
    state.load_job.Wait();
    Frame();
  }

  // One frame of the workbench.
  void Frame() {
    ImGui::NewFrame();
    DrawWorkbench(state);
    ImGui::Render();
  }

  // The text the current view draws (ImGui's log: one line per text row, the items of a row
  // separated by spaces, input fields in braces). ImGui ends a log at the end of a top-level
  // window, so this draws the view's panel alone in a window of the display's size (the
  // status bar and the sidebar are not in it).
  std::string Text() {
    ImGui::NewFrame();
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(kWidth, kHeight));
    ImGui::Begin("##text", nullptr,
                 ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoSavedSettings);
    ImGui::LogToBuffer();
    DrawPanel(state, state.view);
    std::string log = GImGui->LogBuffer.c_str();
    ImGui::LogFinish();
    ImGui::End();
    ImGui::Render();
    return log;
  }

  // Draws frames until `done` or `timeout`; false on timeout.
  bool FramesUntil(const std::function<bool()>& done, std::chrono::milliseconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      Frame();
      if (done()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return false;
  }

  // The window whose name starts with `prefix` and contains `part` (nullptr: anything).
  static ImGuiWindow* FindWindow(const char* prefix, const char* part = nullptr) {
    for (ImGuiWindow* w : GImGui->Windows) {
      if (std::strncmp(w->Name, prefix, std::strlen(prefix)) != 0) continue;
      if (part && !std::strstr(w->Name, part)) continue;
      return w;
    }
    return nullptr;
  }
  // The view area (the child window DrawWorkbench draws the current view in).
  static ImGuiWindow* ViewWindow() { return FindWindow("##workbench/##view_"); }

  // The id of `label` drawn directly in the view area under PushID(view).
  ImGuiID ViewItemId(const char* label) const {
    ImGuiWindow* w = ViewWindow();
    if (!w) return 0;
    const int view = static_cast<int>(state.view);
    return ImHashStr(label, 0, ImHashData(&view, sizeof view, w->ID));
  }

  // Moves the mouse over `window` (rows `step_y` apart, from the top; or only the row at `y`)
  // until `id` is hovered. Returns the mouse position, or nothing.
  std::optional<ImVec2> Find(ImGuiWindow* window, ImGuiID id, std::optional<float> y = {}) {
    if (!window || id == 0) return std::nullopt;
    const ImRect r = window->Rect();
    const float step_x = 10.0f, step_y = 7.0f;
    for (float py = y ? *y : r.Min.y + 1.0f; py < r.Max.y; py += step_y) {
      for (float px = r.Min.x + 1.0f; px < r.Max.x; px += step_x) {
        ImGui::GetIO().MousePos = ImVec2(px, py);
        Frame();
        if (ImGui::GetHoveredID() == id) return ImVec2(px, py);
      }
      if (y) break;
    }
    return std::nullopt;
  }

  void MouseTo(ImVec2 p) {
    ImGui::GetIO().MousePos = p;
    Frame();
  }
  void Press() {
    ImGui::GetIO().MouseDown[0] = true;
    Frame();
  }
  // A button acts when the mouse is released over it.
  void Release() {
    ImGui::GetIO().MouseDown[0] = false;
    Frame();
  }
  void Click(ImVec2 p) {
    MouseTo(p);
    Press();
    Release();
  }
  void Type(const char* text) {
    for (const char* c = text; *c; ++c) ImGui::GetIO().AddInputCharacter(static_cast<unsigned>(*c));
    Frame();
  }
  void PressEnter() {
    ImGui::GetIO().KeysDown[kEnterKey] = true;
    Frame();
    ImGui::GetIO().KeysDown[kEnterKey] = false;
    Frame();
  }

  AppState state;

 private:
  ImGuiContext* context_ = nullptr;
};

// The button (or other item) labelled `label` in the view's window, optionally on the row at
// height `row`; nullopt when it is not drawn.
inline std::optional<ImVec2> FindButton(WorkbenchDriver& d, const char* label,
                                        std::optional<float> row = {}) {
  return d.Find(WorkbenchDriver::ViewWindow(), d.ViewItemId(label), row);
}

// A cancelled estimation ended as a cancel: either before the run had reported any point
// (nothing kept, the failure says "cancelled"), or after it (the best point kept as a fit
// marked stopped). Which one depends on how far the run got before the cancel was seen, which
// no test can fix on a loaded machine.
inline ::testing::AssertionResult EndedAsCancelled(const AppState& state) {
  const EstimationState& e = state.estimation;
  if (e.last_failure.find("cancelled") != std::string::npos) {
    if (e.fits.empty() || !e.fits.back().fit.summary.cancelled)
      return ::testing::AssertionSuccess() << "cancelled before any point was reported";
  }
  if (!e.fits.empty() && e.fits.back().fit.summary.cancelled &&
      !e.fits.back().fit.summary.converged)
    return ::testing::AssertionSuccess() << "stopped: the best point kept";
  return ::testing::AssertionFailure() << "neither cancelled nor stopped; last failure: '"
                                       << e.last_failure << "', " << e.fits.size() << " fits";
}

}  // namespace gb::ui::testing
