// The import dialog (import_dialog.h).
//
// Contents
//   1. The form as a dataset entry: ImportSpecOf
//   2. The check: CheckImport
//   3. The dialog: OpenImportDialog, DrawImportDialog, AddImportedDataset
#include "ui/shell/import_dialog.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <imgui.h>
#include <imgui_stdlib.h>

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

// The CSV keys of the form: header, separator, decimal mark, the columns' names where renamed,
// the time column or the sample time.
void CsvKeys(const ImportForm& f, data::DatasetSpec* out) {
  data::DatasetSpec& spec = *out;
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
}

// The rows an MDF file's form gives, as a line of the check ("5 rows, t = 0 … 0.4 s").
std::string RowsText(const data::Dataset& d, bool previewed) {
  return GroupedCount(static_cast<long long>(d.rows())) +
         (previewed ? " rows previewed" : " rows") + ", t = " + FormatSig(d.time.front(), 6) +
         " \xE2\x80\xA6 " + FormatSig(d.time.back(), 6) + " s";
}

// The check's verdict on the entry's rows as read: prepared (map, detrend, resample, with the
// range's row count checked) and bound to the model; `note` ends the rows' line.
void CheckRows(ImportForm* f, Result<std::shared_ptr<const data::Dataset>> read,
               const data::DatasetSpec& spec, const model::ModelSpec* model,
               const std::string& note) {
  if (read) read = data::Prepare(*read, spec);
  if (!read) {
    f->check = read.error().ToString();
    return;
  }
  std::string rows = RowsText(**read, f->truncated);
  if (model) {
    Result<std::shared_ptr<const data::Series>> bound =
        data::Bind(**read, model->inputs, model->outputs);
    if (!bound) {
      f->check = bound.error().ToString();
      return;
    }
    rows += "; they bind to the model's inputs and outputs";
  }
  f->check = rows + note;
  f->check_ok = true;
}

// The check of an MDF file's form: its channels on the time base, prepared and bound.
void CheckMdf(ImportForm* f, const model::ModelSpec* model) {
  f->names.clear();
  for (std::size_t c = 0; c < f->channels.size() && c < f->use.size(); ++c)
    if (f->use[c]) f->names.push_back(f->channels[c]);
  if (f->names.empty()) {
    f->check = "choose the channels to read";
    return;
  }
  const data::DatasetSpec spec = ImportSpecOf(*f, model);
  CheckRows(f, data::Mdf4ToDataset(*f->mdf_file, f->path, data::Mdf4FormatOf(spec)), spec, model,
            ".");
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 1. The form as a dataset entry

data::DatasetSpec ImportSpecOf(const ImportForm& f, const model::ModelSpec* model) {
  data::DatasetSpec spec;
  spec.file = f.path;
  spec.plain = false;
  spec.name = f.name;
  if (f.mdf) {
    for (std::size_t c = 0; c < f.channels.size() && c < f.use.size(); ++c)
      if (f.use[c]) spec.columns.push_back(f.channels[c]);
    if (f.time_base > 0)
      spec.time = std::to_string(f.time_base);
    else
      spec.sample_time = f.sample_time;
    if (f.interpolation == 1) spec.interpolation = "linear";
  } else {
    CsvKeys(f, &spec);
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
  if (f->mdf) {
    CheckMdf(f, model);
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
  std::string note;
  if (range_later)
    note = "; the range t = " + FormatSig(f->range_from, 6) + " \xE2\x80\xA6 " +
           FormatSig(f->range_to, 6) + " s is applied to the whole file";
  note += f->truncated ? " (the whole file is read when it is added)." : ".";
  CheckRows(f, data::ParseCsv(f->preview, f->path, data::FormatOf(spec, f->preview)), spec, model,
            note);
}

// ---------------------------------------------------------------------------------------------
// 3. The dialog

namespace {

// An MDF file's channels for the form: every numeric channel of a group with a master, picked;
// the time base the group with the most samples (as the reader chooses it).
void OpenMdf(ImportForm* f) {
  f->mdf = true;
  Result<data::Mdf4File> file = data::ReadMdf4File(f->path);
  if (!file) {
    f->read_error = file.error().ToString();
    return;
  }
  f->mdf_file = std::make_shared<const data::Mdf4File>(std::move(file).value());
  const data::Mdf4File& m = *f->mdf_file;
  std::size_t most = 0;
  for (const data::Mdf4Channel& c : m.channels) {
    int same = 0;
    for (const data::Mdf4Channel& o : m.channels) same += o.name == c.name ? 1 : 0;
    const data::Mdf4Group& g = m.groups[static_cast<std::size_t>(c.group)];
    f->channels.push_back(same > 1 ? c.name + "@" + std::to_string(g.number) : c.name);
    f->use.push_back(g.has_master);
    if (g.has_master && g.time.size() > most) {
      most = g.time.size();
      f->time_base = g.number;
    }
  }
}

// The CSV part of the form: header, separator, decimal mark, time, and the first rows under
// the columns' names.
bool DrawCsvFields(ImportForm& f, float s) {
  bool changed = false;
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
  const std::string time_label = f.time > 0 && f.time <= static_cast<int>(f.names.size())
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
    ImGui::TextDisabled(
        "Type over a name to rename the column; a blank or \xE2\x80\x94 cell is missing.");
  }
  return changed;
}

// The MDF part of the form: the time base, the interpolation and the channels to read.
bool DrawMdfFields(ImportForm& f, float s) {
  bool changed = false;
  const data::Mdf4File& m = *f.mdf_file;
  const auto rate = [](const data::Mdf4Group& g) {
    const std::size_t n = g.time.size();
    return n >= 2 && g.time.back() > g.time.front()
               ? static_cast<double>(n - 1) / (g.time.back() - g.time.front())
               : 0.0;
  };
  const auto group_label = [&](const data::Mdf4Group& g) {
    std::string label = "group " + std::to_string(g.number);
    if (!g.name.empty()) label += " " + g.name;
    label += ": " + GroupedCount(static_cast<long long>(g.time.size())) + " samples";
    if (const double r = rate(g); r > 0) label += " at " + FormatSig(r, 4) + " Hz";
    return label;
  };
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Time base");
  ImGui::SameLine(110 * s);
  ImGui::SetNextItemWidth(330 * s);
  std::string current = "a uniform grid";
  for (const data::Mdf4Group& g : m.groups)
    if (g.number == f.time_base) current = group_label(g);
  if (ImGui::BeginCombo("##time-base", current.c_str())) {
    for (const data::Mdf4Group& g : m.groups) {
      if (!g.has_master) continue;
      if (ImGui::Selectable(group_label(g).c_str(), g.number == f.time_base)) {
        f.time_base = g.number;
        changed = true;
      }
    }
    if (ImGui::Selectable("a uniform grid", f.time_base == 0)) {
      f.time_base = 0;
      changed = true;
    }
    ImGui::EndCombo();
  }
  if (f.time_base == 0) {
    ImGui::SameLine();
    ImGui::TextUnformatted("every");
    ImGui::SameLine();
    ImGui::SetNextItemWidth(90 * s);
    if (ImGui::InputDouble("s##grid", &f.sample_time, 0, 0, "%g")) {
      f.sample_time = f.sample_time > 0 && std::isfinite(f.sample_time) ? f.sample_time : 0.1;
      changed = true;
    }
  }
  ImGui::SameLine(0, 24 * s);
  ImGui::TextUnformatted("Other rates");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(150 * s);
  changed |= ImGui::Combo("##interpolation", &f.interpolation, "hold\0linear\0");
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "A channel of another group at a row's time: its last sample (hold) or "
        "the line between the samples either side (linear); missing before its "
        "first sample");

  constexpr ImGuiTableFlags kFlags = ImGuiTableFlags_ScrollY | ImGuiTableFlags_BordersInnerH |
                                     ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingFixedFit;
  const float height = ImGui::GetFrameHeightWithSpacing() *
                           static_cast<float>(std::min<std::size_t>(f.channels.size(), 8)) +
                       1.6f * ImGui::GetTextLineHeightWithSpacing();
  if (ImGui::BeginTable("##channels", 5, kFlags, ImVec2(760 * s, height))) {
    ImGui::TableSetupScrollFreeze(0, 1);
    for (const char* c : {"Read", "Channel", "Group", "Unit", "Samples"})
      ImGui::TableSetupColumn(c);
    ImGui::TableHeadersRow();
    for (std::size_t c = 0; c < m.channels.size() && c < f.use.size(); ++c) {
      const data::Mdf4Channel& ch = m.channels[c];
      const data::Mdf4Group& g = m.groups[static_cast<std::size_t>(ch.group)];
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::PushID(static_cast<int>(c));
      bool use = f.use[c];
      ImGui::BeginDisabled(!g.has_master);
      if (ImGui::Checkbox("##use", &use)) {
        f.use[c] = use;
        changed = true;
      }
      ImGui::EndDisabled();
      ImGui::PopID();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(f.channels[c].c_str());
      ImGui::TableNextColumn();
      ImGui::TextDisabled("%s", group_label(g).c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(ch.unit.c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(GroupedCount(static_cast<long long>(ch.values.size())).c_str());
    }
    ImGui::EndTable();
  }
  if (!m.skipped.empty())
    ImGui::TextDisabled("%zu channel%s not numeric (strings, arrays, ...): not offered.",
                        m.skipped.size(), m.skipped.size() == 1 ? " is" : "s are");
  return changed;
}

}  // namespace

void OpenImportDialog(AppState& state, const std::string& path) {
  ImportForm f;
  f.requested = true;
  f.path = path;  // as the browser gave it (absolute); AddDataset makes it so in any case
  const model::ModelSpec* model = state.model ? &*state.model : nullptr;
  f.map.assign(ModelNames(model).size(), "");
  if (data::IsMdfFile(path)) {
    OpenMdf(&f);
    CheckImport(&f, model);
    state.shell.import = std::move(f);
    return;
  }
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
  ImGui::SetNextWindowSizeConstraints(ImVec2(0, 0),
                                      ImVec2(viewport->Size.x * 0.95f, viewport->Size.y * 0.95f));
  if (!ImGui::BeginPopupModal(kImportPopup, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return;
  const float s = state.fonts.scale;
  const model::ModelSpec* model = state.model ? &*state.model : nullptr;
  bool changed = false;

  ImGui::TextDisabled("%s", f.path.c_str());
  ImGui::Spacing();
  if (f.mdf) {
    if (f.mdf_file) changed |= DrawMdfFields(f, s);
  } else {
    changed |= DrawCsvFields(f, s);
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
      const bool has_column = std::find(f.names.begin(), f.names.end(), names[i]) != f.names.end();
      changed |=
          ImGui::InputTextWithHint("##map",
                                   has_column ? "its column (or an expression of the columns)"
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
    ImGui::SetTooltip(
        "From every column (inputs and outputs), as a model linearised about the "
        "operating point's mean values expects");
  ImGui::SameLine(0, 24 * s);
  ImGui::AlignTextToFramePadding();
  ImGui::TextUnformatted("Resample to");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90 * s);
  changed |= ImGui::InputDouble("##resample", &f.resample, 0, 0, "%g");
  f.resample = std::max(0.0, f.resample);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "A new sample time in seconds (0: keep the record's); a longer one "
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
                     "%s", f.check.c_str());
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
