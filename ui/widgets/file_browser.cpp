// The file browser popup.
//
// Sections
//   1. Reading and sorting a directory
//   2. Choosing: what the typed path or the selection means
//   3. Drawing
#include "ui/widgets/file_browser.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <system_error>

#include <imgui.h>
#include <imgui_stdlib.h>

namespace gb::ui {
namespace fs = std::filesystem;
namespace {

constexpr const char* kPopupId = "###file_browser";
constexpr float kBrowserWidth = 760.0f;                 // pixels at scale 1
constexpr float kListHeight = 360.0f;                   // pixels at scale 1
constexpr const char* kFolderMarker = "\xE2\x96\xB8 ";  // ▸

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// ---------------------------------------------------------------------------------------------
// 1. Reading and sorting a directory

// Three-way comparison under `sort`; ties broken by name so the order is total.
int Compare(const FileEntry& a, const FileEntry& b, FileSort sort) {
  if (sort == FileSort::kSize && a.size != b.size) return a.size < b.size ? -1 : 1;
  if (sort == FileSort::kDate && a.modified != b.modified) return a.modified < b.modified ? -1 : 1;
  const std::string an = Lower(a.name), bn = Lower(b.name);
  if (an != bn) return an < bn ? -1 : 1;
  return a.name.compare(b.name) < 0 ? -1 : a.name == b.name ? 0 : 1;
}

bool Before(const FileEntry& a, const FileEntry& b, FileSort sort, bool descending) {
  // Folders first whatever the order, as file managers do.
  if (a.directory != b.directory) return a.directory;
  const int c = Compare(a, b, sort);
  return descending ? c > 0 : c < 0;
}

void SortEntries(FileBrowserState& b) {
  const std::string selected = b.selected >= 0 && b.selected < static_cast<int>(b.entries.size())
                                   ? b.entries[b.selected].name
                                   : std::string();
  std::stable_sort(b.entries.begin(), b.entries.end(), [&](const FileEntry& x, const FileEntry& y) {
    return Before(x, y, b.sort, b.descending);
  });
  b.selected = -1;
  for (std::size_t i = 0; i < b.entries.size(); ++i) {
    if (b.entries[i].name == selected) b.selected = static_cast<int>(i);
  }
}

std::string FormatSize(std::uintmax_t bytes) {
  char buf[32];
  if (bytes < 1024) {
    std::snprintf(buf, sizeof buf, "%ju B", bytes);
  } else if (bytes < 1024 * 1024) {
    std::snprintf(buf, sizeof buf, "%.1f KB", static_cast<double>(bytes) / 1024.0);
  } else {
    std::snprintf(buf, sizeof buf, "%.1f MB", static_cast<double>(bytes) / (1024.0 * 1024.0));
  }
  return buf;
}

std::string FormatDate(fs::file_time_type t) {
  const auto sys = std::chrono::file_clock::to_sys(t);
  const std::time_t tt = std::chrono::system_clock::to_time_t(
      std::chrono::time_point_cast<std::chrono::system_clock::duration>(sys));
  std::tm tm{};
  if (!localtime_r(&tt, &tm)) return "";
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M", &tm);
  return buf;
}

// ---------------------------------------------------------------------------------------------
// 2. Choosing

fs::path Absolute(const FileBrowserState& b, const std::string& typed) {
  fs::path p(typed);
  if (!typed.empty() && typed[0] == '~')
    p = fs::path(HomeDirectory()) / typed.substr(typed.size() > 1 ? 2 : 1);
  if (p.is_relative()) p = fs::path(b.directory) / p;
  return p.lexically_normal();
}

const FileFilter* CurrentFilter(const FileBrowserState& b) {
  if (b.request.filters.empty()) return nullptr;
  return &b.request
              .filters[std::clamp(b.filter, 0, static_cast<int>(b.request.filters.size()) - 1)];
}

// Acts on what the user confirmed (the path field, or the selected entry when the field is
// empty): a folder is opened, a file is returned. Refusals go to b.error.
std::optional<std::string> Choose(FileBrowserState& b, std::string typed) {
  if (typed.empty() && b.selected >= 0 && b.selected < static_cast<int>(b.entries.size()))
    typed = b.entries[b.selected].name;
  if (typed.empty()) return std::nullopt;
  fs::path p = Absolute(b, typed);
  std::error_code ec;
  if (fs::is_directory(p, ec)) {
    if (ChangeDirectory(b, p.string())) b.path_field.clear();
    return std::nullopt;
  }
  if (b.request.mode == FileBrowserMode::kOpen) {
    if (!fs::exists(p, ec)) {
      b.error = "There is no file " + p.string() + ".";
      return std::nullopt;
    }
    if (!fs::is_regular_file(p, ec)) {
      b.error = p.string() + " is not a regular file.";
      return std::nullopt;
    }
    return p.string();
  }
  // Save: the folder must exist; a name without extension gets the filter's.
  if (!fs::is_directory(p.parent_path(), ec)) {
    b.error = "There is no folder " + p.parent_path().string() + ".";
    return std::nullopt;
  }
  if (const FileFilter* f = CurrentFilter(b);
      f && !f->extensions.empty() && p.extension().empty()) {
    p += f->extensions.front();
  }
  if (fs::exists(p, ec) && b.confirm_replace != p.string()) {
    if (fs::is_directory(p, ec)) {
      b.error = p.string() + " is a folder.";
      return std::nullopt;
    }
    b.confirm_replace = p.string();
    b.error.clear();
    return std::nullopt;
  }
  return p.string();
}

// ---------------------------------------------------------------------------------------------
// 3. Drawing

bool KeyPressed(ImGuiKey key) { return ImGui::IsKeyPressed(ImGui::GetKeyIndex(key)); }

void DrawToolbar(FileBrowserState& b) {
  const fs::path dir(b.directory);
  ImGui::BeginDisabled(dir == dir.root_path());
  if (ImGui::Button("\xE2\x86\x91 Parent")) ChangeDirectory(b, dir.parent_path().string());
  ImGui::EndDisabled();
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("The folder above (Backspace)");
  ImGui::SameLine();
  if (ImGui::Button("Home")) ChangeDirectory(b, HomeDirectory());
  ImGui::SameLine();
  if (ImGui::Button("Refresh")) ChangeDirectory(b, b.directory);
  ImGui::SameLine();
  if (ImGui::Checkbox("Hidden files", &b.show_hidden)) ChangeDirectory(b, b.directory);
  ImGui::SameLine();
  ImGui::TextDisabled("in");
  ImGui::SameLine();
  ImGui::TextUnformatted(b.directory.c_str());
}

// Returns the entry the user opened (double-click), or -1.
int DrawList(FileBrowserState& b, float scale) {
  int activated = -1;
  const ImGuiTableFlags flags = ImGuiTableFlags_ScrollY | ImGuiTableFlags_RowBg |
                                ImGuiTableFlags_BordersOuter | ImGuiTableFlags_Sortable |
                                ImGuiTableFlags_SizingFixedFit;
  if (!ImGui::BeginTable("##files", 3, flags, ImVec2(0, kListHeight * scale))) return -1;
  ImGui::TableSetupScrollFreeze(0, 1);
  ImGui::TableSetupColumn("Name",
                          ImGuiTableColumnFlags_WidthStretch | ImGuiTableColumnFlags_DefaultSort);
  ImGui::TableSetupColumn("Size", ImGuiTableColumnFlags_WidthFixed, 90.0f * scale);
  ImGui::TableSetupColumn("Modified", ImGuiTableColumnFlags_WidthFixed, 140.0f * scale);
  ImGui::TableHeadersRow();
  if (ImGuiTableSortSpecs* specs = ImGui::TableGetSortSpecs(); specs && specs->SpecsDirty) {
    if (specs->SpecsCount > 0) {
      const ImGuiTableColumnSortSpecs& s = specs->Specs[0];
      b.sort = s.ColumnIndex == 1   ? FileSort::kSize
               : s.ColumnIndex == 2 ? FileSort::kDate
                                    : FileSort::kName;
      b.descending = s.SortDirection == ImGuiSortDirection_Descending;
      SortEntries(b);
    }
    specs->SpecsDirty = false;
  }
  for (int i = 0; i < static_cast<int>(b.entries.size()); ++i) {
    const FileEntry& e = b.entries[i];
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::PushID(i);
    const std::string label = (e.directory ? kFolderMarker : "") + e.name;
    if (ImGui::Selectable(
            label.c_str(), b.selected == i,
            ImGuiSelectableFlags_SpanAllColumns | ImGuiSelectableFlags_AllowDoubleClick)) {
      b.selected = i;
      b.confirm_replace.clear();
      if (!e.directory) b.path_field = e.name;
      if (ImGui::IsMouseDoubleClicked(ImGuiMouseButton_Left)) activated = i;
    }
    if (b.selected == i && b.scroll_to_selected) {
      ImGui::SetScrollHereY();
      b.scroll_to_selected = false;
    }
    ImGui::PopID();
    ImGui::TableNextColumn();
    if (!e.directory) ImGui::TextDisabled("%s", FormatSize(e.size).c_str());
    ImGui::TableNextColumn();
    ImGui::TextDisabled("%s", FormatDate(e.modified).c_str());
  }
  if (b.entries.empty() && b.error.empty()) {
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextDisabled("No matching files in this folder.");
  }
  ImGui::EndTable();
  return activated;
}

}  // namespace

std::string HomeDirectory() {
  const char* home = std::getenv("HOME");
  return home && *home ? home : "/";
}

bool MatchesFilter(const FileFilter& filter, const std::string& name) {
  if (filter.extensions.empty()) return true;
  const std::string lower = Lower(name);
  for (const std::string& ext : filter.extensions) {
    const std::string e = Lower(ext);
    if (lower.size() >= e.size() && lower.compare(lower.size() - e.size(), e.size(), e) == 0)
      return true;
  }
  return false;
}

bool ChangeDirectory(FileBrowserState& b, const std::string& directory) {
  std::error_code ec;
  const fs::path dir = fs::absolute(fs::path(directory), ec).lexically_normal();
  fs::path clean = dir;
  if (clean.has_filename() == false && clean != clean.root_path()) clean = clean.parent_path();
  std::vector<FileEntry> entries;
  fs::directory_iterator it(clean, fs::directory_options::skip_permission_denied, ec);
  if (ec) {
    b.error = "Cannot read " + clean.string() + ": " + ec.message() + ".";
    return false;
  }
  const FileFilter* filter = CurrentFilter(b);
  for (const fs::directory_iterator end; it != end; it.increment(ec)) {
    if (ec) break;
    const fs::directory_entry& d = *it;
    FileEntry e;
    e.name = d.path().filename().string();
    if (!b.show_hidden && !e.name.empty() && e.name[0] == '.') continue;
    std::error_code entry_ec;
    e.directory = d.is_directory(entry_ec);  // follows links: a link to a folder is a folder
    if (entry_ec) continue;                  // e.g. a dangling link
    if (!e.directory) {
      if (!d.is_regular_file(entry_ec) || entry_ec) continue;
      if (filter && !MatchesFilter(*filter, e.name)) continue;
      e.size = d.file_size(entry_ec);
    }
    e.modified = d.last_write_time(entry_ec);
    entries.push_back(std::move(e));
  }
  if (ec) {
    b.error = "Cannot read " + clean.string() + ": " + ec.message() + ".";
    return false;
  }
  b.directory = clean.string();
  b.entries = std::move(entries);
  b.selected = -1;
  b.error.clear();
  b.confirm_replace.clear();
  SortEntries(b);
  return true;
}

void OpenFileBrowser(FileBrowserState& browser, FileBrowserRequest request) {
  browser.purpose = request.purpose;
  browser.filter = 0;
  browser.error.clear();
  browser.confirm_replace.clear();
  browser.path_field = request.mode == FileBrowserMode::kSave ? request.file_name : "";
  std::string start = request.start.empty() ? browser.directory : request.start;
  browser.request = std::move(request);
  std::error_code ec;
  std::string start_file;  // selected when the start names a file
  if (!start.empty() && !fs::is_directory(start, ec)) {
    start_file = fs::path(start).filename().string();
    start = fs::path(start).parent_path().string();
  }
  // Fall back to home, then to the working directory, when the start is not readable.
  if (start.empty() || !ChangeDirectory(browser, start)) {
    const std::string why = browser.error;
    if (!ChangeDirectory(browser, HomeDirectory())) ChangeDirectory(browser, ".");
    browser.error = why;
  }
  for (std::size_t i = 0; i < browser.entries.size(); ++i) {
    if (browser.entries[i].name != start_file) continue;
    browser.selected = static_cast<int>(i);
    browser.scroll_to_selected = true;
  }
  browser.open_requested = true;
}

std::optional<std::string> DrawFileBrowser(FileBrowserState& b, float scale) {
  const std::string popup = b.request.title + kPopupId;
  if (b.open_requested) {
    b.open_requested = false;
    ImGui::OpenPopup(popup.c_str());
  }
  const ImGuiViewport* vp = ImGui::GetMainViewport();
  ImGui::SetNextWindowPos(
      ImVec2(vp->WorkPos.x + vp->WorkSize.x * 0.5f, vp->WorkPos.y + vp->WorkSize.y * 0.45f),
      ImGuiCond_Appearing, ImVec2(0.5f, 0.5f));
  ImGui::SetNextWindowSize(ImVec2(kBrowserWidth * scale, 0.0f), ImGuiCond_Appearing);
  bool open = true;
  if (!ImGui::BeginPopupModal(popup.c_str(), &open, ImGuiWindowFlags_NoSavedSettings)) return {};
  std::optional<std::string> chosen;
  auto finish = [&](std::optional<std::string> path) {
    if (!path) return;
    chosen = std::move(path);
    ImGui::CloseCurrentPopup();
  };

  DrawToolbar(b);
  const int activated = DrawList(b, scale);
  if (activated >= 0) {
    b.path_field.clear();
    finish(Choose(b, b.entries[activated].name));
  }

  // The location field: a name in this folder, or a path (absolute, relative or ~/...).
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted(b.request.mode == FileBrowserMode::kSave ? "File name" : "Location");
  ImGui::SameLine();
  const float combo_w = b.request.filters.empty() ? 0.0f : 200.0f * scale;
  ImGui::SetNextItemWidth(-(combo_w > 0 ? combo_w + ImGui::GetStyle().ItemSpacing.x : 0.0f));
  // Saving starts by typing a name; opening starts in the list (arrow keys).
  if (ImGui::IsWindowAppearing() && b.request.mode == FileBrowserMode::kSave)
    ImGui::SetKeyboardFocusHere();
  if (ImGui::InputTextWithHint("##location", "a file name, or a path (Enter opens folders)",
                               &b.path_field, ImGuiInputTextFlags_EnterReturnsTrue)) {
    finish(Choose(b, b.path_field));
  }
  if (ImGui::IsItemEdited()) b.confirm_replace.clear();
  const bool typing = ImGui::IsItemActive();
  if (!b.request.filters.empty()) {
    ImGui::SameLine();
    ImGui::SetNextItemWidth(combo_w);
    const FileFilter* current = CurrentFilter(b);
    if (ImGui::BeginCombo("##filter", current->label.c_str())) {
      for (int i = 0; i < static_cast<int>(b.request.filters.size()); ++i) {
        if (ImGui::Selectable(b.request.filters[i].label.c_str(), i == b.filter)) {
          b.filter = i;
          ChangeDirectory(b, b.directory);
        }
      }
      ImGui::EndCombo();
    }
  }

  // Keyboard navigation of the list, unless the user is typing in the field.
  if (!typing && !chosen && ImGui::IsWindowFocused(ImGuiFocusedFlags_RootAndChildWindows)) {
    const int n = static_cast<int>(b.entries.size());
    int move = 0;
    if (KeyPressed(ImGuiKey_DownArrow)) move = 1;
    if (KeyPressed(ImGuiKey_UpArrow)) move = -1;
    if (move != 0 && n > 0) {
      b.selected =
          b.selected < 0 ? (move > 0 ? 0 : n - 1) : std::clamp(b.selected + move, 0, n - 1);
      b.scroll_to_selected = true;
      b.confirm_replace.clear();
      const FileEntry& e = b.entries[b.selected];
      b.path_field = e.directory ? "" : e.name;
    }
    if (KeyPressed(ImGuiKey_Backspace))
      ChangeDirectory(b, fs::path(b.directory).parent_path().string());
    if (KeyPressed(ImGuiKey_Enter)) finish(Choose(b, b.path_field));
  }
  if (KeyPressed(ImGuiKey_Escape) && !chosen) ImGui::CloseCurrentPopup();

  if (!b.error.empty()) {
    ImGui::PushTextWrapPos(0.0f);
    ImGui::TextColored(ImVec4(0.75f, 0.12f, 0.10f, 1.0f), "%s", b.error.c_str());
    ImGui::PopTextWrapPos();
  }
  if (!b.confirm_replace.empty()) {
    ImGui::TextColored(ImVec4(0.70f, 0.42f, 0.0f, 1.0f), "%s already exists.",
                       b.confirm_replace.c_str());
    ImGui::SameLine();
    if (ImGui::Button("Replace")) finish(Choose(b, b.confirm_replace));
  }

  ImGui::Separator();
  const bool can_confirm = !b.path_field.empty() || b.selected >= 0;
  ImGui::BeginDisabled(!can_confirm);
  if (ImGui::Button(b.request.confirm.c_str()) && !chosen) finish(Choose(b, b.path_field));
  ImGui::EndDisabled();
  ImGui::SameLine();
  if (ImGui::Button("Cancel")) ImGui::CloseCurrentPopup();
  ImGui::EndPopup();
  return chosen;
}

}  // namespace gb::ui
