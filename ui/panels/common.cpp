#include "ui/panels/common.h"

#include <algorithm>
#include <filesystem>

#include "core/util/json.h"
#include "ui/theme.h"

namespace gb::ui {

bool DrawNoProjectNotice(AppState& state) {
  if (state.project) return false;
  if (state.load_job.active()) {
    DrawNotice(state, "Opening project",
               "Reading " + state.loading_path + " and its datasets\xE2\x80\xA6");
  } else if (!state.open_error.empty()) {
    DrawNotice(state, "The project could not be opened", state.open_error, Severity::kError);
  } else {
    std::string text = state.start_note.empty() ? "" : state.start_note + "\n\n";
    text +=
        "Open a project with File \xE2\x80\xBA Open project\xE2\x80\xA6, or start greybench "
        "with one: greybench PROJECT.json";
    DrawNotice(state, "No project open", text);
  }
  return true;
}

void DrawNotice(AppState& state, const char* title, const std::string& text, Severity severity) {
  const float s = state.fonts.scale;
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  const float width = std::min(avail.x - 40.0f * s, 560.0f * s);
  const float x = ImGui::GetCursorPosX() + std::max(0.0f, 0.5f * (avail.x - width));
  ImGui::Dummy(ImVec2(0, std::max(0.0f, 0.18f * avail.y)));
  const ImVec2 top = ImGui::GetCursorScreenPos();
  ImDrawList* dl = ImGui::GetWindowDrawList();
  dl->ChannelsSplit(2);
  dl->ChannelsSetCurrent(1);
  const float pad = 20.0f * s;
  ImGui::SetCursorPosX(x + pad);
  ImGui::Dummy(ImVec2(0, pad - ImGui::GetStyle().ItemSpacing.y));
  ImGui::SetCursorPosX(x + pad);
  ImGui::PushFont(state.fonts.heading);
  if (severity == Severity::kInfo) {
    ImGui::TextUnformatted(title);
  } else {
    ImGui::TextColored(SeverityColor(severity), "%s", title);
  }
  ImGui::PopFont();
  ImGui::SetCursorPosX(x + pad);
  ImGui::PushTextWrapPos(x + width - pad);
  ImGui::TextUnformatted(text.c_str());
  ImGui::PopTextWrapPos();
  ImGui::Dummy(ImVec2(0, pad - ImGui::GetStyle().ItemSpacing.y));
  const float bottom = ImGui::GetItemRectMax().y;
  dl->ChannelsSetCurrent(0);
  const ImVec2 min(ImGui::GetWindowPos().x + x - ImGui::GetScrollX(), top.y);
  const ImVec2 max(min.x + width, bottom);
  dl->AddRectFilled(min, max, Colors(state.shell.theme).card_bg, 6.0f * s);
  dl->AddRect(min, max, ImGui::GetColorU32(ImGuiCol_Border), 6.0f * s);
  if (severity != Severity::kInfo) {
    dl->AddRectFilled(min, ImVec2(min.x + 4.0f * s, max.y),
                      ImGui::ColorConvertFloat4ToU32(SeverityColor(severity)), 6.0f * s,
                      ImDrawFlags_RoundCornersLeft);
  }
  dl->ChannelsMerge();
}

void StatusLine(AppState& state, ImU32 color, const char* word, const std::string& rest) {
  const float r = 4.0f * state.fonts.scale;
  const ImVec2 p = ImGui::GetCursorScreenPos();
  ImGui::GetWindowDrawList()->AddCircleFilled(
      ImVec2(p.x + r, p.y + 0.5f * ImGui::GetTextLineHeight()), r, color, 12);
  ImGui::Dummy(ImVec2(2.0f * r, ImGui::GetTextLineHeight()));
  ImGui::SameLine(0, 0.6f * ImGui::GetFontSize());
  ImGui::PushFont(state.fonts.bold);
  ImGui::TextUnformatted(word);
  ImGui::PopFont();
  if (rest.empty()) return;
  ImGui::SameLine(0, 0.6f * ImGui::GetFontSize());
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextDisabled("%s", rest.c_str());
  ImGui::PopTextWrapPos();
}

bool PrimaryButton(const char* label, ImVec2 size) {
  ImGui::PushStyleColor(ImGuiCol_Button, IM_COL32(47, 111, 219, 255));
  ImGui::PushStyleColor(ImGuiCol_ButtonHovered, IM_COL32(66, 129, 235, 255));
  ImGui::PushStyleColor(ImGuiCol_ButtonActive, IM_COL32(33, 92, 190, 255));
  ImGui::PushStyleColor(ImGuiCol_Text, IM_COL32(255, 255, 255, 255));
  const bool clicked = ImGui::Button(label, size);
  ImGui::PopStyleColor(4);
  return clicked;
}

void SectionHeading(AppState& state, const char* text) {
  ImGui::Dummy(ImVec2(0, 4.0f * state.fonts.scale));
  ImGui::PushFont(state.fonts.bold);
  ImGui::TextUnformatted(text);
  ImGui::PopFont();
  const ImVec2 p = ImGui::GetCursorScreenPos();
  ImGui::GetWindowDrawList()->AddLine(
      ImVec2(p.x, p.y - 2.0f * state.fonts.scale),
      ImVec2(p.x + ImGui::GetContentRegionAvail().x, p.y - 2.0f * state.fonts.scale),
      ImGui::GetColorU32(ImGuiCol_Separator));
  ImGui::Dummy(ImVec2(0, 2.0f * state.fonts.scale));
}

void LabelValue(const char* label, const std::string& value) {
  ImGui::TextDisabled("%s", label);
  ImGui::SameLine(0, 0.5f * ImGui::GetFontSize());
  ImGui::TextUnformatted(value.c_str());
}

ImVec4 SeverityColor(Severity severity) {
  switch (severity) {
    case Severity::kError:
      return ImVec4(0.78f, 0.16f, 0.16f, 1.0f);
    case Severity::kWarning:
      return ImVec4(0.72f, 0.45f, 0.02f, 1.0f);
    case Severity::kInfo:
      break;
  }
  return ImVec4(0.18f, 0.44f, 0.86f, 1.0f);
}

void SameLineIfFits(float width, float spacing) {
  if (ImGui::GetItemRectMax().x + spacing + width <=
      ImGui::GetWindowPos().x + ImGui::GetWindowContentRegionMax().x)
    ImGui::SameLine(0, spacing);
}

float CheckboxWidth(const char* label) {
  return ImGui::GetFrameHeight() + ImGui::GetStyle().ItemInnerSpacing.x +
         ImGui::CalcTextSize(label, nullptr, true).x;
}

std::string FitToWidth(const std::string& text, float width) {
  if (ImGui::CalcTextSize(text.c_str()).x <= width) return text;
  constexpr const char* kEllipsis = "\xE2\x80\xA6";
  std::string cut = text;
  while (!cut.empty()) {
    // Drop one UTF-8 character: its continuation bytes (10xxxxxx), then its first byte.
    while (!cut.empty() && (static_cast<unsigned char>(cut.back()) & 0xC0) == 0x80) cut.pop_back();
    if (!cut.empty()) cut.pop_back();
    if (ImGui::CalcTextSize((cut + kEllipsis).c_str()).x <= width) break;
  }
  return cut + kEllipsis;
}

std::string FileName(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

std::string GroupedCount(long long n) {
  std::string digits = std::to_string(n < 0 ? -n : n);
  std::string out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return n < 0 ? "-" + out : out;
}

void UndoRedoButtons(bool can_undo, bool can_redo, bool* undo, bool* redo) {
  ImGui::BeginDisabled(!can_undo);
  if (ImGui::Button("Undo")) *undo = true;
  ImGui::EndDisabled();
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) ImGui::SetTooltip("Ctrl+Z");
  ImGui::SameLine();
  ImGui::BeginDisabled(!can_redo);
  if (ImGui::Button("Redo")) *redo = true;
  ImGui::EndDisabled();
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) ImGui::SetTooltip("Ctrl+Y");
  ImGui::SameLine();
}

}  // namespace gb::ui
