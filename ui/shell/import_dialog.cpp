// The import dialog (import_dialog.h).
//
// Contents
//   1. The form as a dataset entry: ImportSpecOf
//   2. The check: CheckImport
//   3. The dialog: OpenImportDialog, DrawImportDialog, AddImportedDataset
#include "ui/shell/import_dialog.h"

#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "ui/format.h"
#include "ui/panels/common.h"
#include "ui/shell/shell.h"

namespace gb::ui {
namespace {

constexpr std::size_t kPreviewBytes = 64 * 1024;
constexpr int kPreviewRows = 8;
constexpr const char* kImportPopup = "Import a dataset";
constexpr char kSeparators[] = {',', ';', '\t'};
constexpr const char* kSeparatorNames[] = {"comma  ,", "semicolon  ;", "tab"};
constexpr char kDecimals[] = {'.', ','};
constexpr const char* kDecimalNames[] = {"point  1.5", "comma  1,5"};

// The model's inputs, then its outputs (the rows of the form's `map`).
std::vector<std::string> ModelNames(const model::ModelSpec* model) {
  std::vector<std::string> names;
  if (!model) return names;
  names = model->inputs;
  names.insert(names.end(), model->outputs.begin(), model->outputs.end());
  return names;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 1. The form as a dataset entry

data::DatasetSpec ImportSpecOf(const ImportForm& f, const model::ModelSpec* model) {
  data::DatasetSpec spec;
  spec.file = f.path;
  spec.plain = false;
  spec.name = f.name;
  spec.header = f.header;
  spec.separator = kSeparators[std::clamp(f.separator, 0, 2)];
  spec.decimal = kDecimals[std::clamp(f.decimal, 0, 1)];
  // Names are written when they differ from what the file gives (a header's, or c1, c2, ...).
  bool renamed = false;
  for (std::size_t i = 0; i < f.names.size() && i < f.fields.size(); ++i)
    renamed = renamed || f.names[i] != f.fields[i].name;
  if (renamed || (!f.header && !f.names.empty())) spec.columns = f.names;
  if (f.time > 0 && f.time <= static_cast<int>(f.names.size())) {
    spec.time = f.names[static_cast<std::size_t>(f.time - 1)];
  } else {
    spec.sample_time = f.sample_time;
  }
  const std::vector<std::string> names = ModelNames(model);
  for (std::size_t i = 0; i < names.size() && i < f.map.size(); ++i)
    if (!f.map[i].empty()) spec.map.emplace_back(names[i], f.map[i]);
  if (f.use_range) spec.range = std::array<double, 2>{f.range_from, f.range_to};
  if (f.detrend > 0)
    spec.detrend.emplace_back("", f.detrend == 1 ? data::Detrend::kMean : data::Detrend::kLinear);
  spec.resample = f.resample;
  spec.role = f.validation ? data::Role::kValidation : data::Role::kEstimation;
  return spec;
}

// ---------------------------------------------------------------------------------------------
// 2. The check

void CheckImport(ImportForm* f, const model::ModelSpec* model) {
  f->fields.clear();
  f->fields_error.clear();
  f->check_ok = false;
  if (!f->read_error.empty()) {
    f->check = f->read_error;
    return;
  }
  // The raw fields: every field a column (no time column), with the form's names.
  data::CsvFormat raw;
  raw.header = f->header;
  raw.separator = kSeparators[std::clamp(f->separator, 0, 2)];
  raw.decimal = kDecimals[std::clamp(f->decimal, 0, 1)];
  raw.sample_time = 1;
  Result<std::shared_ptr<const data::Dataset>> fields = data::ParseCsv(f->preview, f->path, raw);
  if (fields && !f->names.empty() && f->names.size() != (*fields)->columns.size())
    f->names.clear();  // another separator: another count of fields
  if (!fields) {
    f->fields_error = fields.error().ToString();
  } else {
    for (const data::Column& c : (*fields)->columns) {
      ImportForm::Field field;
      field.name = c.name;
      const std::size_t n = std::min<std::size_t>(c.values.size(), kPreviewRows);
      field.values.assign(c.values.begin(), c.values.begin() + static_cast<std::ptrdiff_t>(n));
      f->fields.push_back(std::move(field));
    }
    if (f->names.empty())
      for (const ImportForm::Field& field : f->fields) f->names.push_back(field.name);
  }
  if (f->time > static_cast<int>(f->names.size())) f->time = 0;

  // The entry's rows, mapped and bound.
  data::DatasetSpec spec = ImportSpecOf(*f, model);
  // A range beyond the preview's rows is checked on the whole file when it is added.
  const bool range_later = f->truncated && spec.range.has_value();
  if (range_later) spec.range.reset();
  Result<std::shared_ptr<const data::Dataset>> read =
      data::ParseCsv(f->preview, f->path, data::FormatOf(spec, f->preview));
  if (read) read = data::Prepare(*read, spec);
  if (!read) {
    f->check = read.error().ToString();
    return;
  }
  const data::Dataset& d = **read;
  std::string rows = GroupedCount(static_cast<long long>(d.rows())) +
                     (f->truncated ? " rows previewed" : " rows") + ", t = " +
                     FormatSig(d.time.front(), 6) + " \xE2\x80\xA6 " + FormatSig(d.time.back(), 6) +
                     " s";
  if (model) {
    Result<std::shared_ptr<const data::Series>> bound = data::Bind(d, model->inputs, model->outputs);
    if (!bound) {
      f->check = bound.error().ToString();
      return;
    }
    rows += "; they bind to the model's inputs and outputs";
  }
  if (range_later)
    rows += "; the range t = " + FormatSig(f->range_from, 6) + " \xE2\x80\xA6 " +
            FormatSig(f->range_to, 6) + " s is applied to the whole file";
  f->check = rows + (f->truncated ? " (the whole file is read when it is added)." : ".");
  f->check_ok = true;
}

// ---------------------------------------------------------------------------------------------
// 3. The dialog

void OpenImportDialog(AppState& state, const std::string& path) {
  ImportForm f;
  f.requested = true;
  f.path = path;  // as the browser gave it (absolute); AddDataset makes it so in any case
  Result<std::string> text = data::ReadFileHead(f.path, kPreviewBytes, &f.truncated);
  if (!text) {
    f.read_error = text.error().ToString();
  } else {
    f.preview = std::move(*text);
    if (f.truncated) f.preview.erase(f.preview.find_last_of('\n') + 1);
    const data::CsvFormat sniffed = data::SniffCsv(f.preview);
    f.header = sniffed.header;
    f.separator = sniffed.separator == ';' ? 1 : sniffed.separator == '\t' ? 2 : 0;
    f.decimal = sniffed.decimal == ',' ? 1 : 0;
  }
  const model::ModelSpec* model = state.model ? &*state.model : nullptr;
  f.map.assign(ModelNames(model).size(), "");
  CheckImport(&f, model);
  // The time column the reader would take, if there is one.
  for (std::size_t i = 0; i < f.names.size() && f.time == 0; ++i)
    if (data::TimeUnitScale(f.names[i])) f.time = static_cast<int>(i) + 1;
  CheckImport(&f, model);
  state.shell.import = std::move(f);
}

void AddImportedDataset(AppState& state) {
  ImportForm& f = state.shell.import;
  data::DatasetSpec spec = ImportSpecOf(f, state.model ? &*state.model : nullptr);
  AddDataset(state, std::move(spec));
}

void DrawImportDialog(AppState& state) {
  ImportForm& f = state.shell.import;
  if (f.requested) {
    f.requested = false;
    ImGui::OpenPopup(kImportPopup);
  }
  const ImGuiViewport* viewport = ImGui::GetMainViewport();
  ImGui::SetNextWindowPos(viewport->GetCenter(), ImGuiCond_Appearing, ImVec2(0.5f, 0.5f));
  ImGui::SetNextWindowSizeConstraints(ImVec2(0, 0), ImVec2(viewport->Size.x * 0.95f,
                                                           viewport->Size.y * 0.95f));
  if (!ImGui::BeginPopupModal(kImportPopup, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return;
  const float s = state.fonts.scale;
  const model::ModelSpec* model = state.model ? &*state.model : nullptr;
  bool changed = false;

  ImGui::TextDisabled("%s", f.path.c_str());
  ImGui::Spacing();
  // Format.
  changed |= ImGui::Checkbox("The first row names the columns", &f.header);
  ImGui::SameLine(0, 24 * s);
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Separator");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(130 * s);
  changed |= ImGui::Combo("##separator", &f.separator, kSeparatorNames, 3);
  ImGui::SameLine(0, 24 * s);
  ImGui::TextUnformatted("Decimal mark");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(120 * s);
  changed |= ImGui::Combo("##decimal", &f.decimal, kDecimalNames, 2);

  // Time.
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Time");
  ImGui::SameLine(110 * s);
  ImGui::SetNextItemWidth(270 * s);
  const std::string time_label =
      f.time > 0 && f.time <= static_cast<int>(f.names.size())
          ? "column " + f.names[static_cast<std::size_t>(f.time - 1)]
          : std::string("none: rows a sample time apart");
  if (ImGui::BeginCombo("##time", time_label.c_str())) {
    if (ImGui::Selectable("none: rows a sample time apart", f.time == 0)) {
      f.time = 0;
      changed = true;
    }
    for (std::size_t i = 0; i < f.names.size(); ++i) {
      if (ImGui::Selectable(("column " + f.names[i] + "##" + std::to_string(i)).c_str(),
                            f.time == static_cast<int>(i) + 1)) {
        f.time = static_cast<int>(i) + 1;
        changed = true;
      }
    }
    ImGui::EndCombo();
  }
  if (f.time == 0) {
    ImGui::SameLine();
    ImGui::TextUnformatted("every");
    ImGui::SameLine();
    ImGui::SetNextItemWidth(100 * s);
    if (ImGui::InputDouble("s##sample_time", &f.sample_time, 0, 0, "%g")) {
      f.sample_time = f.sample_time > 0 && std::isfinite(f.sample_time) ? f.sample_time : 0.1;
      changed = true;
    }
  } else if (const auto scale = data::TimeUnitScale(f.names[static_cast<std::size_t>(f.time - 1)]);
             scale && *scale != 1) {
    ImGui::SameLine();
    ImGui::TextDisabled("(converted to seconds: \xC3\x97 %s)", FormatSig(*scale, 6).c_str());
  }

  // The columns: names (editable) over the first rows.
  ImGui::Spacing();
  if (!f.fields_error.empty()) {
    ImGui::PushTextWrapPos(ImGui::GetCursorPosX() + 760 * s);
    ImGui::TextColored(SeverityColor(Severity::kError), "%s", f.fields_error.c_str());
    ImGui::PopTextWrapPos();
  } else if (!f.fields.empty()) {
    const int n = static_cast<int>(f.fields.size());
    constexpr ImGuiTableFlags kFlags = ImGuiTableFlags_ScrollX | ImGuiTableFlags_BordersInnerV |
                                       ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingFixedFit;
    const float height = ImGui::GetFrameHeightWithSpacing() +
                         ImGui::GetTextLineHeightWithSpacing() * (kPreviewRows + 1.5f);
    if (ImGui::BeginTable("##preview", std::min(n, 64), kFlags, ImVec2(760 * s, height))) {
      ImGui::TableNextRow();
      for (int c = 0; c < std::min(n, 64); ++c) {
        ImGui::TableNextColumn();
        ImGui::PushID(c);
        ImGui::SetNextItemWidth(96 * s);
        changed |= ImGui::InputText("##name", &f.names[static_cast<std::size_t>(c)]);
        ImGui::PopID();
      }
      for (int r = 0; r < kPreviewRows; ++r) {
        ImGui::TableNextRow();
        for (int c = 0; c < std::min(n, 64); ++c) {
          ImGui::TableNextColumn();
          const std::vector<double>& v = f.fields[static_cast<std::size_t>(c)].values;
          if (r < static_cast<int>(v.size()))
            ImGui::TextUnformatted(std::isnan(v[static_cast<std::size_t>(r)])
                                       ? "\xE2\x80\x94"
                                       : FormatSig(v[static_cast<std::size_t>(r)], 6).c_str());
        }
      }
      ImGui::EndTable();
    }
    ImGui::TextDisabled("Type over a name to rename the column; a blank or \xE2\x80\x94 cell is missing.");
  }

  // The model's inputs and outputs: a column of their name, or an expression of the columns.
  const std::vector<std::string> names = ModelNames(model);
  if (!names.empty()) {
    ImGui::Spacing();
    ImGui::TextUnformatted("The model's inputs and outputs");
    for (std::size_t i = 0; i < names.size() && i < f.map.size(); ++i) {
      ImGui::PushID(static_cast<int>(i));
      ImGui::AlignTextToFramePadding();
      ImGui::TextDisabled("%s", i < model->inputs.size() ? "input " : "output");
      ImGui::SameLine(70 * s);
      ImGui::TextUnformatted(names[i].c_str());
      ImGui::SameLine(180 * s);
      ImGui::TextDisabled("\xE2\x86\x90");
      ImGui::SameLine();
      ImGui::SetNextItemWidth(380 * s);
      const bool has_column =
          std::find(f.names.begin(), f.names.end(), names[i]) != f.names.end();
      changed |= ImGui::InputTextWithHint(
          "##map", has_column ? "its column (or an expression of the columns)"
                              : "an expression of the columns, such as 1/Lambda",
          &f.map[i]);
      ImGui::PopID();
    }
  }

  // Preparation: a range, means or trends removed, a new sample time.
  ImGui::Spacing();
  changed |= ImGui::Checkbox("Only t from", &f.use_range);
  ImGui::SameLine();
  ImGui::BeginDisabled(!f.use_range);
  ImGui::SetNextItemWidth(90 * s);
  changed |= ImGui::InputDouble("##range-from", &f.range_from, 0, 0, "%g");
  ImGui::SameLine();
  ImGui::TextUnformatted("to");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90 * s);
  changed |= ImGui::InputDouble("##range-to", &f.range_to, 0, 0, "%g");
  ImGui::SameLine();
  ImGui::TextUnformatted("s");
  ImGui::EndDisabled();
  ImGui::SameLine(0, 24 * s);
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Remove");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(130 * s);
  changed |= ImGui::Combo("##detrend", &f.detrend, "nothing\0the means\0linear trends\0");
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("From every column (inputs and outputs), as a model linearised about the "
                      "operating point's mean values expects");
  ImGui::SameLine(0, 24 * s);
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Resample to");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90 * s);
  changed |= ImGui::InputDouble("##resample", &f.resample, 0, 0, "%g");
  f.resample = std::max(0.0, f.resample);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("A new sample time in seconds (0: keep the record's); a longer one "
                      "decimates after a windowed-sinc anti-alias filter");
  ImGui::SameLine();
  ImGui::TextDisabled("s (0: keep)");

  // Name and role.
  ImGui::Spacing();
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Name");
  ImGui::SameLine(110 * s);
  ImGui::SetNextItemWidth(260 * s);
  ImGui::InputTextWithHint("##dataset-name", "the file's name when empty", &f.name);
  ImGui::SameLine(0, 24 * s);
  int role = f.validation ? 1 : 0;
  ImGui::RadioButton("Fit it", &role, 0);
  ImGui::SameLine();
  ImGui::RadioButton("Validate on it (not fitted)", &role, 1);
  f.validation = role == 1;

  if (changed) CheckImport(&f, model);
  ImGui::Spacing();
  ImGui::PushTextWrapPos(ImGui::GetCursorPosX() + 760 * s);
  ImGui::TextColored(f.check_ok ? SeverityColor(Severity::kInfo) : SeverityColor(Severity::kError),
                     "%s%s", f.check_ok ? "\xE2\x9C\x93 " : "", f.check.c_str());
  ImGui::PopTextWrapPos();
  ImGui::Separator();
  ImGui::BeginDisabled(!f.check_ok || state.shell.dataset_job.active() || !state.project);
  if (ImGui::Button("Add to the project")) {
    AddImportedDataset(state);
    ImGui::CloseCurrentPopup();
  }
  ImGui::EndDisabled();
  ImGui::SameLine();
  if (ImGui::Button("Cancel") || ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Escape)))
    ImGui::CloseCurrentPopup();
  ImGui::EndPopup();
}

}  // namespace gb::ui
