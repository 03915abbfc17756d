// An in-app file browser (ImGui, no native dialog): a modal popup listing one directory,
// folders first, with a path field, parent / home shortcuts, an extension filter, sorting by
// name or date, and keyboard navigation. Errors (an unreadable directory, a name that is not
// there) are shown inside the popup.
//
//   FileBrowserRequest r;                       // what to ask for
//   r.title = "Open project"; r.filters = {{"Projects (*.json)", {".json"}}};
//   OpenFileBrowser(state.file_browser, r);     // e.g. from a menu item
//   ...every frame:
//   if (auto path = DrawFileBrowser(state.file_browser, scale)) Use(*path);
//
// Keys (when the path field is not being typed into): Up/Down move the selection, Enter opens
// the selected folder or chooses the selected file, Backspace goes to the parent folder, Esc
// closes the browser. Double-click does what Enter does.
//
// State: everything lives in FileBrowserState (owned by AppState). The directory is read when
// it changes (or on Refresh), never every frame.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace gb::ui {

struct FileFilter {
  std::string label;                    // "Projects (*.json)"
  std::vector<std::string> extensions;  // ".json"; empty: every file
};

enum class FileBrowserMode {
  kOpen,  // choose an existing file
  kSave,  // choose a file name (asks before replacing an existing file)
};

struct FileBrowserRequest {
  std::string title = "Open";    // the popup's title, and what the purpose is
  std::string confirm = "Open";  // the confirm button's label ("Save", "Add")
  FileBrowserMode mode = FileBrowserMode::kOpen;
  std::vector<FileFilter> filters;  // the first is selected; empty: every file
  std::string start;                // a directory or a file in it; "" = the last directory
  std::string file_name;            // kSave: the proposed name
  int purpose = 0;                  // the caller's tag, returned in FileBrowserState::purpose
};

enum class FileSort { kName, kSize, kDate };

struct FileEntry {
  std::string name;  // without the directory
  bool directory = false;
  std::uintmax_t size = 0;
  std::filesystem::file_time_type modified{};
};

struct FileBrowserState {
  FileBrowserRequest request;
  int purpose = 0;              // request.purpose of the browser last opened
  bool open_requested = false;  // OpenFileBrowser was called; the popup opens next frame
  std::string directory;        // absolute, shown in the path field's label
  std::string path_field;       // what the user types: a name, or a path (absolute or not)
  int filter = 0;               // index into request.filters
  FileSort sort = FileSort::kName;
  bool descending = false;
  bool show_hidden = false;
  std::vector<FileEntry> entries;  // directories first, then files, sorted, filtered
  int selected = -1;               // index into entries
  bool scroll_to_selected = false;
  std::string error;            // why the directory could not be read, or the choice refused
  std::string confirm_replace;  // kSave: a file that exists, waiting for "Replace"
};

// Sets up the browser for `request` and opens it at the next DrawFileBrowser.
void OpenFileBrowser(FileBrowserState& browser, FileBrowserRequest request);

// Draws the browser's popup when it is open. Returns the chosen path (absolute) on the frame
// the user confirms a choice, otherwise nothing. `scale` is the DPI scale of the fonts.
std::optional<std::string> DrawFileBrowser(FileBrowserState& browser, float scale);

// Reads `directory` into browser.entries (or sets browser.error), keeping the filter and sort.
// Returns false when the directory cannot be read.
bool ChangeDirectory(FileBrowserState& browser, const std::string& directory);

// Whether `name` passes `filter` (case-insensitive extension match).
bool MatchesFilter(const FileFilter& filter, const std::string& name);

// The user's home directory ($HOME), or "/" when it is not set.
std::string HomeDirectory();

}  // namespace gb::ui
