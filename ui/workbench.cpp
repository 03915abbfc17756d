// The workbench frame around the panels.
//
// Sections
//   1. Menu bar
//   2. Sidebar: project, views, datasets
//   3. Status bar and the messages window
//   4. Dialogs: about (the File menu's dialogs are in ui/shell/shell.cpp)
//   5. DrawWorkbench
#include "ui/workbench.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>

#include <imgui_stdlib.h>

#include "ui/panels/common.h"
#include "ui/panels/panels.h"
#include "ui/shell/shell.h"
#include "ui/theme.h"

#ifndef GREYBENCH_VERSION
#define GREYBENCH_VERSION "unknown"
#endif

namespace gb::ui {
namespace {

constexpr float kSidebarWidth = 220.0f;        // pixels at scale 1
constexpr float kNarrowSidebarWidth = 176.0f;  // ... in a window narrower than kNarrowWindow
constexpr float kNarrowWindow = 1200.0f;
constexpr float kSlidersWidth = 250.0f;  // the sliders beside a view, pixels at scale 1
constexpr const char* kAboutPopup = "About greybench";

// ---------------------------------------------------------------------------------------------
// 1. Menu bar

void DrawMenuBar(AppState& state) {
  if (!ImGui::BeginMainMenuBar()) return;
  if (ImGui::BeginMenu("File")) {
    DrawFileMenu(state);
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("View")) {
    for (View v : kAllViews) {
      const std::string title(ViewTitle(v));
      const std::string keys = ViewShortcut(v);
      if (ImGui::MenuItem(title.c_str(), keys.c_str(), state.view == v)) state.view = v;
    }
    ImGui::Separator();
    if (ImGui::MenuItem("Messages", nullptr, state.show_messages)) {
      state.show_messages = !state.show_messages;
    }
    if (ImGui::MenuItem("Sliders", nullptr, state.sliders.open, state.model.has_value())) {
      state.sliders.open = !state.sliders.open;
      // Shown beside the views they act on: from any other, go to the predictions.
      if (state.sliders.open && !SlidersPanelShown(state)) state.view = View::kPredictions;
    }
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "Parameters as sliders beside the Data, Predictions, Residuals and "
          "Parameters views");
    ImGui::Separator();
    if (ImGui::MenuItem("Sidebar", "Ctrl+B", state.shell.show_sidebar))
      state.shell.show_sidebar = !state.shell.show_sidebar;
    if (ImGui::BeginMenu("Theme")) {
      for (ThemeKind t : kThemes)
        if (ImGui::MenuItem(ThemeTitle(t), nullptr, state.shell.theme == t)) SetTheme(state, t);
      ImGui::EndMenu();
    }
    DrawZoomMenuItems(state);
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Help")) {
    if (ImGui::MenuItem("User guide", "F1", state.shell.show_help))
      state.shell.show_help = !state.shell.show_help;
    if (ImGui::MenuItem("Keyboard shortcuts", nullptr, state.shell.show_shortcuts))
      state.shell.show_shortcuts = !state.shell.show_shortcuts;
    if (ImGui::MenuItem("About greybench")) state.show_about = true;
    ImGui::EndMenu();
  }
  ImGui::EndMainMenuBar();
}

// ---------------------------------------------------------------------------------------------
// 2. Sidebar

void SidebarCaption(const char* text) {
  ImGui::Spacing();
  ImGui::TextDisabled("%s", text);
}

void DrawSidebar(AppState& state) {
  const float s = state.fonts.scale;
  SidebarCaption("PROJECT");
  if (state.project) {
    const project::Project& p = *state.project;
    ImGui::PushFont(state.fonts.bold);
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextUnformatted(p.name.empty() ? FileName(p.path).c_str() : p.name.c_str());
    ImGui::PopTextWrapPos();
    ImGui::PopFont();
    ImGui::TextDisabled("%s", FileName(p.path).c_str());
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", p.path.c_str());
  } else {
    ImGui::TextDisabled("none open");
  }
  if (state.load_job.active()) {
    ImGui::TextDisabled("Opening %s\xE2\x80\xA6", FileName(state.loading_path).c_str());
    ImGui::ProgressBar(state.load_job.progress(), ImVec2(-1, 4.0f * s), "");
  }

  ImGui::Spacing();
  SidebarCaption("VIEWS");
  ImGui::PushStyleVar(ImGuiStyleVar_ItemSpacing, ImVec2(0, 2.0f * s));
  const float row_h = ImGui::GetTextLineHeight() + 8.0f * s;
  for (View v : kAllViews) {
    const std::string title(ViewTitle(v));
    if (ImGui::Selectable(title.c_str(), state.view == v, 0, ImVec2(0, row_h))) state.view = v;
  }
  ImGui::PopStyleVar();

  if (!state.project) return;
  ImGui::Spacing();
  SidebarCaption("DATASETS");
  if (state.datasets.empty()) ImGui::TextDisabled("none");
  // One row per dataset: its name, "validation" for a record that is not fitted, its rows; a
  // right click (or the row's menu key) changes its role or removes it from the project.
  std::optional<std::pair<std::size_t, data::Role>> set_role;
  std::optional<std::size_t> remove;
  for (std::size_t i = 0; i < state.datasets.size(); ++i) {
    const LoadedDataset& d = state.datasets[i];
    const std::string name = d.spec.DisplayName();
    const bool validation = d.spec.role == data::Role::kValidation;
    ImGui::PushID(static_cast<int>(i));
    const ImVec2 row_min = ImGui::GetCursorScreenPos();
    ImGui::Selectable("##dataset", false, ImGuiSelectableFlags_AllowItemOverlap,
                      ImVec2(0, ImGui::GetTextLineHeight()));
    const bool hovered = ImGui::IsItemHovered();
    if (ImGui::BeginPopupContextItem("dataset-menu")) {
      ImGui::TextDisabled("%s", name.c_str());
      ImGui::Separator();
      if (ImGui::MenuItem("Fit it (estimation record)", nullptr, !validation))
        set_role = {i, data::Role::kEstimation};
      if (ImGui::MenuItem("Validate on it (not fitted)", nullptr, validation))
        set_role = {i, data::Role::kValidation};
      ImGui::Separator();
      if (ImGui::MenuItem("Remove from the project")) remove = i;
      ImGui::EndPopup();
    }
    ImGui::SetCursorScreenPos(row_min);
    if (d.data) {
      std::string right = GroupedCount(static_cast<long long>(d.summary.rows));
      if (validation) right = "validation \xC2\xB7 " + right;
      const float right_w = ImGui::CalcTextSize(right.c_str()).x;
      const float name_w = ImGui::GetContentRegionMax().x - ImGui::GetCursorPosX() - right_w -
                           ImGui::GetFontSize() * 0.5f;
      ImGui::TextUnformatted(FitToWidth(name, name_w).c_str());
      ImGui::SameLine(ImGui::GetContentRegionMax().x - right_w);
      ImGui::TextDisabled("%s", right.c_str());
    } else {
      ImGui::TextColored(SeverityColor(Severity::kError), "%s (unreadable)", name.c_str());
    }
    if (hovered) {
      ImGui::SetTooltip("%s\n%s%s\nRight-click: fit it, validate on it, or remove it",
                        d.path.c_str(),
                        validation ? "validation record: not fitted, shown at the estimates"
                                   : "estimation record: fitted",
                        d.data ? "" : ("\n" + d.error).c_str());
    }
    ImGui::PopID();
  }
  std::string why;
  if (set_role && !SetDatasetRole(state, set_role->first, set_role->second, &why))
    AddMessage(state, Severity::kWarning, "The dataset's role was not changed: " + why);
  if (remove && !RemoveDataset(state, *remove, &why))
    AddMessage(state, Severity::kWarning, "The dataset was not removed: " + why);
}

// ---------------------------------------------------------------------------------------------
// 3. Status bar and messages

void DrawStatusBar(AppState& state, float height) {
  const float s = state.fonts.scale;
  const ImVec2 min = ImGui::GetCursorScreenPos();
  const ImVec2 max(min.x + ImGui::GetWindowWidth(), min.y + height);
  ImDrawList* dl = ImGui::GetWindowDrawList();
  dl->AddRectFilled(min, max, ImGui::GetColorU32(ImGuiCol_MenuBarBg));
  dl->AddLine(min, ImVec2(max.x, min.y), ImGui::GetColorU32(ImGuiCol_Border));

  const float pad = 10.0f * s;
  const float text_y = min.y + 0.5f * (height - ImGui::GetTextLineHeight());
  const std::string text = StatusText(state);
  ImU32 color = ImGui::GetColorU32(ImGuiCol_TextDisabled);
  if (const Message* m = StatusMessage(state)) {
    if (m->severity != Severity::kInfo)
      color = ImGui::ColorConvertFloat4ToU32(SeverityColor(m->severity));
    const float r = 3.5f * s;
    dl->AddCircleFilled(ImVec2(min.x + pad + r, min.y + 0.5f * height), r,
                        ImGui::ColorConvertFloat4ToU32(SeverityColor(m->severity)), 12);
  }

  const std::string button = std::to_string(state.messages.size()) +
                             (state.messages.size() == 1 ? " message" : " messages") +
                             "###messages";
  const float button_w = ImGui::CalcTextSize(button.c_str(), nullptr, true).x +
                         2.0f * ImGui::GetStyle().FramePadding.x;
  const float text_x = min.x + pad + 12.0f * s;
  const ImVec4 clip(text_x, min.y, max.x - button_w - 2.0f * pad, max.y);
  dl->AddText(nullptr, 0.0f, ImVec2(text_x, text_y), color, text.c_str(), nullptr, 0.0f, &clip);

  ImGui::SetCursorScreenPos(
      ImVec2(max.x - button_w - pad, min.y + 0.5f * (height - ImGui::GetFrameHeight())));
  ImGui::PushStyleColor(ImGuiCol_Button, IM_COL32(0, 0, 0, 0));
  if (ImGui::Button(button.c_str())) state.show_messages = !state.show_messages;
  ImGui::PopStyleColor();
}

void DrawMessagesWindow(AppState& state) {
  if (!state.show_messages) return;
  const float s = state.fonts.scale;
  const ImGuiViewport* vp = ImGui::GetMainViewport();
  ImGui::SetNextWindowSize(ImVec2(680.0f * s, 300.0f * s), ImGuiCond_Appearing);
  ImGui::SetNextWindowPos(
      ImVec2(vp->WorkPos.x + vp->WorkSize.x * 0.5f, vp->WorkPos.y + vp->WorkSize.y * 0.5f),
      ImGuiCond_Appearing, ImVec2(0.5f, 0.5f));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowBorderSize, 1.0f);
  const bool open = ImGui::Begin("Messages", &state.show_messages, ImGuiWindowFlags_NoCollapse);
  ImGui::PopStyleVar();
  if (open && ImGui::IsWindowFocused(ImGuiFocusedFlags_RootAndChildWindows)) {
    state.shell.tool_window_focused = true;  // Esc is this window's (shell.cpp)
    if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Escape), false))
      state.show_messages = false;
  }
  if (open) {
    if (ImGui::Button("Clear")) state.messages.clear();
    ImGui::Separator();
    ImGui::BeginChild("##list");
    if (state.messages.empty()) ImGui::TextDisabled("No messages.");
    for (const Message& m : state.messages) {
      const char* tag = m.severity == Severity::kError     ? "error  "
                        : m.severity == Severity::kWarning ? "warning"
                                                           : "info   ";
      if (!m.time.empty()) {
        ImGui::TextDisabled("%s", m.time.c_str());
        ImGui::SameLine();
      }
      ImGui::TextColored(
          m.resolved ? ImGui::GetStyle().Colors[ImGuiCol_TextDisabled] : SeverityColor(m.severity),
          "%s", tag);
      ImGui::SameLine();
      ImGui::PushTextWrapPos(0.0f);
      if (m.resolved) {
        ImGui::TextDisabled("%s (resolved since)", m.text.c_str());
      } else {
        ImGui::TextUnformatted(m.text.c_str());
      }
      ImGui::PopTextWrapPos();
    }
    ImGui::EndChild();
  }
  ImGui::End();
}

// ---------------------------------------------------------------------------------------------
// 4. Dialogs

void DrawAboutDialog(AppState& state) {
  if (state.show_about) {
    state.show_about = false;
    ImGui::OpenPopup(kAboutPopup);
  }
  if (!ImGui::BeginPopupModal(kAboutPopup, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return;
  ImGui::PushFont(state.fonts.heading);
  ImGui::TextUnformatted("greybench " GREYBENCH_VERSION);
  ImGui::PopFont();
  ImGui::TextUnformatted("Identification of continuous-time stochastic grey-box models");
  ImGui::TextUnformatted("from measured data.");
  ImGui::TextDisabled("Dear ImGui %s", ImGui::GetVersion());
  if (ImGui::Button("Close")) ImGui::CloseCurrentPopup();
  ImGui::EndPopup();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 5. DrawWorkbench

void DrawPanel(AppState& state, View view) {
  switch (view) {
    case View::kData:
      DrawDataPanel(state);
      break;
    case View::kDiagram:
      DrawDiagramPanel(state);
      break;
    case View::kEquations:
      DrawEquationsPanel(state);
      break;
    case View::kEstimate:
      DrawEstimatePanel(state);
      break;
    case View::kPredictions:
      DrawPredictionsPanel(state);
      break;
    case View::kResiduals:
      DrawResidualsPanel(state);
      break;
    case View::kParameters:
      DrawParametersPanel(state);
      break;
    case View::kOperatingPoints:
      DrawOperatingPointsPanel(state);
      break;
    case View::kLive:
      DrawLivePanel(state);
      break;
    case View::kDesign:
      DrawDesignPanel(state);
      break;
  }
}

void DrawWorkbench(AppState& state) {
  PollJobs(state);
  UpdateShell(state);
  DrawMenuBar(state);

  const float s = state.fonts.scale;
  const ImGuiViewport* vp = ImGui::GetMainViewport();
  ImGui::SetNextWindowPos(vp->WorkPos);
  ImGui::SetNextWindowSize(vp->WorkSize);
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(0, 0));
  ImGui::PushStyleVar(ImGuiStyleVar_ItemSpacing, ImVec2(0, 0));
  const ImGuiWindowFlags frame_flags =
      ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoSavedSettings |
      ImGuiWindowFlags_NoBringToFrontOnFocus | ImGuiWindowFlags_NoScrollWithMouse;
  ImGui::Begin("##workbench", nullptr, frame_flags);
  ImGui::PopStyleVar(2);

  const float status_h = std::round(ImGui::GetFrameHeight() + 6.0f * s);
  const float body_h = std::max(1.0f, ImGui::GetContentRegionAvail().y - status_h);
  // Narrower in a narrow window (1024 x 768: a projector), hidden by View › Sidebar.
  const bool narrow = vp->WorkSize.x < kNarrowWindow * s;
  const float sidebar_w = std::round((narrow ? kNarrowSidebarWidth : kSidebarWidth) * s);

  // Sidebar.
  if (state.shell.show_sidebar) {
    ImGui::PushStyleColor(ImGuiCol_ChildBg, Colors(state.shell.theme).sidebar_bg);
    ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2((narrow ? 8.0f : 12.0f) * s, 8.0f * s));
    ImGui::BeginChild("##sidebar", ImVec2(sidebar_w, body_h), false,
                      ImGuiWindowFlags_AlwaysUseWindowPadding);
    DrawSidebar(state);
    ImGui::EndChild();
    ImGui::PopStyleVar();
    ImGui::PopStyleColor();
    {
      const ImVec2 a = ImGui::GetItemRectMin();
      const ImVec2 b = ImGui::GetItemRectMax();
      ImGui::GetWindowDrawList()->AddLine(ImVec2(b.x - 0.5f, a.y), ImVec2(b.x - 0.5f, b.y),
                                          ImGui::GetColorU32(ImGuiCol_Border));
    }
    ImGui::SameLine(0, 0);
  }

  // The current view.
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(16.0f * s, 10.0f * s));
  ImGui::BeginChild("##view", ImVec2(0, body_h), false,
                    ImGuiWindowFlags_AlwaysUseWindowPadding | ImGuiWindowFlags_NoScrollbar);
  ImGui::PopStyleVar();
  ImGui::PushStyleVar(ImGuiStyleVar_ItemSpacing, ImVec2(8.0f * s, 6.0f * s));
  ImGui::PushFont(state.fonts.heading);
  const std::string title(ViewTitle(state.view));
  ImGui::TextUnformatted(title.c_str());
  ImGui::PopFont();
  ImGui::Spacing();
  if (SlidersPanelShown(state)) {
    // The view beside the sliders: each in its own child, the sliders on the right.
    const float panel_w = std::round(kSlidersWidth * s);
    const float gap = std::round(10.0f * s);
    const float view_w = std::max(1.0f, ImGui::GetContentRegionAvail().x - panel_w - gap);
    ImGui::BeginChild("##view-body", ImVec2(view_w, 0), false, ImGuiWindowFlags_NoScrollbar);
    ImGui::PushID(static_cast<int>(state.view));
    DrawPanel(state, state.view);
    ImGui::PopID();
    ImGui::EndChild();
    ImGui::SameLine(0, gap);
    ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(10.0f * s, 8.0f * s));
    ImGui::PushStyleColor(ImGuiCol_ChildBg, Colors(state.shell.theme).side_panel_bg);
    ImGui::BeginChild("##sliders", ImVec2(0, 0), true, ImGuiWindowFlags_AlwaysUseWindowPadding);
    DrawSlidersPanel(state);
    ImGui::EndChild();
    ImGui::PopStyleColor();
    ImGui::PopStyleVar();
  } else {
    ImGui::PushID(static_cast<int>(state.view));
    DrawPanel(state, state.view);
    ImGui::PopID();
  }
  ImGui::PopStyleVar();
  ImGui::EndChild();

  ImGui::SetCursorScreenPos(ImVec2(ImGui::GetWindowPos().x,
                                   ImGui::GetWindowPos().y + ImGui::GetWindowHeight() - status_h));
  DrawStatusBar(state, status_h);
  DrawShellDialogs(state);
  DrawAboutDialog(state);
  ImGui::End();

  DrawMessagesWindow(state);
}

}  // namespace gb::ui
