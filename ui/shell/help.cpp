// Help › User guide: the user guide (docs/user-guide.md) inside the application, a section at a
// time. The Markdown is shown as the guide uses it: headings, paragraphs (wrapped; `code`,
// **bold** and *emphasis* marks dropped), bullets, tables and code blocks (monospaced).
#include "ui/shell/help.h"

#include <algorithm>
#include <string>
#include <string_view>
#include <vector>

#include <imgui.h>

#include "core/data/dataset.h"

namespace gb::ui {

const char* const kUserGuideFile = GREYBENCH_DOCS_DIR "/user-guide.md";

namespace {

constexpr std::size_t kMaxGuideBytes = 4 << 20;

// The text of a Markdown line without its inline marks: `code`, **bold**, *emphasis*, and
// links [text](target) as their text.
std::string Plain(std::string_view line) {
  std::string out;
  out.reserve(line.size());
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (c == '`') continue;
    if (c == '*' && (i + 1 < line.size() && line[i + 1] == '*')) {
      ++i;
      continue;
    }
    // A single * that opens or closes emphasis (next to a letter); "a * b" stays.
    if (c == '*' && ((i + 1 < line.size() && line[i + 1] != ' ') || (i > 0 && line[i - 1] != ' ')))
      continue;
    if (c == '[') {
      const auto close = line.find("](", i);
      const auto end = close == std::string_view::npos ? close : line.find(')', close);
      if (end != std::string_view::npos) {
        out += Plain(line.substr(i + 1, close - i - 1));
        i = end;
        continue;
      }
    }
    out += c;
  }
  return out;
}

std::vector<std::string> Cells(std::string_view row) {
  std::vector<std::string> cells;
  std::size_t start = row.find('|') + 1;
  while (start < row.size()) {
    const auto bar = row.find('|', start);
    if (bar == std::string_view::npos) break;
    std::string cell = Plain(row.substr(start, bar - start));
    cell.erase(0, cell.find_first_not_of(' '));
    cell.erase(cell.find_last_not_of(' ') + 1);
    cells.push_back(cell);
    start = bar + 1;
  }
  return cells;
}

bool IsRule(const std::string& row) { return row.find_first_not_of("|-: ") == std::string::npos; }

void DrawTable(const std::vector<std::string>& rows, int id) {
  const std::vector<std::string> header = Cells(rows[0]);
  const int columns = std::clamp(static_cast<int>(header.size()), 1, 32);
  ImGui::PushID(id);
  if (ImGui::BeginTable(
          "##table", columns,
          ImGuiTableFlags_Borders | ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingStretchProp)) {
    for (const std::string& h : header) ImGui::TableSetupColumn(h.c_str());
    ImGui::TableHeadersRow();
    for (std::size_t r = 1; r < rows.size(); ++r) {
      if (IsRule(rows[r])) continue;
      ImGui::TableNextRow();
      const std::vector<std::string> cells = Cells(rows[r]);
      for (int c = 0; c < columns; ++c) {
        ImGui::TableNextColumn();
        if (c < static_cast<int>(cells.size())) ImGui::TextWrapped("%s", cells[c].c_str());
      }
    }
    ImGui::EndTable();
  }
  ImGui::PopID();
}

// One section's Markdown.
void DrawSection(AppState& state, const GuideSection& section) {
  ImGui::PushFont(state.fonts.heading);
  ImGui::TextWrapped("%s", Plain(section.title).c_str());
  ImGui::PopFont();
  ImGui::Spacing();
  const auto& lines = section.lines;
  std::string paragraph;
  auto flush = [&] {
    if (paragraph.empty()) return;
    ImGui::TextWrapped("%s", Plain(paragraph).c_str());
    ImGui::Spacing();
    paragraph.clear();
  };
  int tables = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    if (line.rfind("```", 0) == 0) {  // a code block, to its closing fence
      flush();
      ImGui::PushFont(state.fonts.mono);
      for (++i; i < lines.size() && lines[i].rfind("```", 0) != 0; ++i)
        ImGui::TextUnformatted(lines[i].c_str());
      ImGui::PopFont();
      ImGui::Spacing();
      continue;
    }
    if (line.rfind("|", 0) == 0) {  // a table: its rows
      flush();
      std::vector<std::string> rows;
      for (; i < lines.size() && lines[i].rfind("|", 0) == 0; ++i) rows.push_back(lines[i]);
      --i;
      DrawTable(rows, tables++);
      ImGui::Spacing();
      continue;
    }
    if (line.rfind("    ", 0) == 0 && paragraph.empty()) {  // an indented code block
      ImGui::PushFont(state.fonts.mono);
      ImGui::TextUnformatted(line.c_str() + 4);
      ImGui::PopFont();
      continue;
    }
    const auto first = line.find_first_not_of(' ');
    if (first == std::string::npos) {
      flush();
      continue;
    }
    if (line.rfind("![", first) == first) continue;  // a picture: not in the window
    if (line.compare(first, 2, "- ") == 0) {
      flush();
      // The bullet's continuation lines are indented.
      std::string item = line.substr(first + 2);
      while (i + 1 < lines.size() && lines[i + 1].size() > first + 2 &&
             lines[i + 1].find_first_not_of(' ') >= first + 2 &&
             lines[i + 1].find_first_not_of(' ') != std::string::npos) {
        ++i;
        item += " " + lines[i].substr(lines[i].find_first_not_of(' '));
      }
      ImGui::Indent(static_cast<float>(first) * 6.0f * state.fonts.scale);
      ImGui::Bullet();
      ImGui::SameLine();
      ImGui::TextWrapped("%s", Plain(item).c_str());
      ImGui::Unindent(static_cast<float>(first) * 6.0f * state.fonts.scale);
      continue;
    }
    paragraph += (paragraph.empty() ? "" : " ") + line.substr(first);
  }
  flush();
}

}  // namespace

std::vector<GuideSection> ParseGuide(std::string_view markdown) {
  std::vector<GuideSection> out;
  bool fence = false;
  std::size_t start = 0;
  while (start <= markdown.size()) {
    auto end = markdown.find('\n', start);
    if (end == std::string_view::npos) end = markdown.size();
    const std::string line(markdown.substr(start, end - start));
    start = end + 1;
    if (line.rfind("```", 0) == 0) fence = !fence;
    const int level = fence                        ? 0
                      : line.rfind("### ", 0) == 0 ? 3
                      : line.rfind("## ", 0) == 0  ? 2
                                                   : 0;
    if (level > 0) {
      out.push_back({line.substr(static_cast<std::size_t>(level) + 1), level, {}});
    } else if (!out.empty()) {
      out.back().lines.push_back(line);
    }
    if (end == markdown.size()) break;
  }
  return out;
}

void DrawHelpWindow(AppState& state) {
  ShellState& sh = state.shell;
  if (!sh.show_help) return;
  if (sh.guide.empty() && sh.guide_error.empty()) {
    const std::string file = sh.guide_file.empty() ? std::string(kUserGuideFile) : sh.guide_file;
    bool truncated = false;
    Result<std::string> text = data::ReadFileHead(file, kMaxGuideBytes, &truncated);
    if (!text)
      sh.guide_error = "The user guide could not be read: " + text.error().ToString();
    else
      sh.guide = ParseGuide(*text);
    if (sh.guide.empty() && sh.guide_error.empty())
      sh.guide_error = file + " has no sections (## headings)";
    // Open at the workbench's section.
    for (std::size_t i = 0; i < sh.guide.size() && sh.guide_section < 0; ++i)
      if (sh.guide[i].title.find("The workbench") != std::string::npos)
        sh.guide_section = static_cast<int>(i);
    if (sh.guide_section < 0) sh.guide_section = 0;
  }
  if (!sh.guide_section_wanted.empty()) {
    for (std::size_t i = 0; i < sh.guide.size(); ++i)
      if (sh.guide[i].title.rfind(sh.guide_section_wanted, 0) == 0)
        sh.guide_section = static_cast<int>(i);
    sh.guide_section_wanted.clear();
  }
  const float s = state.fonts.scale;
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowSize(
      ImVec2(std::min(display.x - 40 * s, 980 * s), std::min(display.y - 60 * s, 680 * s)),
      ImGuiCond_Appearing);
  ImGui::SetNextWindowPos(ImVec2(display.x * 0.5f, display.y * 0.5f), ImGuiCond_Appearing,
                          ImVec2(0.5f, 0.5f));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowBorderSize, 1.0f);
  const bool open = ImGui::Begin("User guide", &sh.show_help, ImGuiWindowFlags_NoCollapse);
  ImGui::PopStyleVar();
  if (open && ImGui::IsWindowFocused(ImGuiFocusedFlags_RootAndChildWindows)) {
    sh.tool_window_focused = true;
    if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Escape), false)) sh.show_help = false;
  }
  if (open) {
    if (!sh.guide_error.empty()) {
      ImGui::TextWrapped("%s", sh.guide_error.c_str());
    } else {
      // The contents on the left, the section on the right.
      const float list_w = std::min(260.0f * s, ImGui::GetContentRegionAvail().x * 0.35f);
      ImGui::BeginChild("##contents", ImVec2(list_w, 0), true);
      for (std::size_t i = 0; i < sh.guide.size(); ++i) {
        const GuideSection& g = sh.guide[i];
        if (g.level == 3) ImGui::Indent(10.0f * s);
        ImGui::PushID(static_cast<int>(i));
        const std::string title = Plain(g.title);
        if (ImGui::Selectable(title.c_str(), sh.guide_section == static_cast<int>(i)))
          sh.guide_section = static_cast<int>(i);
        if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", title.c_str());
        ImGui::PopID();
        if (g.level == 3) ImGui::Unindent(10.0f * s);
      }
      ImGui::EndChild();
      ImGui::SameLine();
      ImGui::BeginChild("##section", ImVec2(0, 0), false);
      const auto k = static_cast<std::size_t>(
          std::clamp(sh.guide_section, 0, static_cast<int>(sh.guide.size()) - 1));
      ImGui::PushTextWrapPos(0.0f);
      DrawSection(state, sh.guide[k]);
      ImGui::PopTextWrapPos();
      ImGui::EndChild();
    }
  }
  ImGui::End();
}

}  // namespace gb::ui
