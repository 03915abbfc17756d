// The import dialog (File > Add dataset…): a recording read as the user says, checked against the
// model as the form changes, and added to the project as a dataset entry with those keys
// (core/data/import.h). The raw file is never rewritten.
//
//   OpenImportDialog(state, path);  // after the file browser: reads the file's first 64 KB
//   DrawImportDialog(state);        // every frame, with the shell's dialogs
//
// The form starts from what SniffCsv tells of the text (header, separator, decimal mark) and
// the time column it finds (or none: rows a sample time apart). The user can change each, name
// the columns, give a model input or output an expression of the columns, a name and a role.
// The check (CheckImport) reads the previewed rows with the entry the form makes, maps them and
// binds them to the model, and says in words what is wrong, or how the rows read; *Add* reads
// the whole file in the background (as Add dataset did) and installs it.
#pragma once

#include <string>
#include <vector>

#include "core/data/import.h"
#include "core/model/model.h"
#include "ui/state/app_state.h"

namespace gb::ui {

// The dataset entry the form describes (file, header, separator, decimal, columns, time or
// sample time, map, name, role).
data::DatasetSpec ImportSpecOf(const ImportForm& form, const model::ModelSpec* model);

// Reads the form's preview with it: the raw fields (names and the first rows, for the table),
// then the entry's rows mapped and bound to `model` (may be null: not bound). Fills
// form->fields, form->check, form->check_ok.
void CheckImport(ImportForm* form, const model::ModelSpec* model);

void OpenImportDialog(AppState& state, const std::string& path);
void DrawImportDialog(AppState& state);
// Adds the dataset the form describes: read whole in the background, then installed.
void AddImportedDataset(AppState& state);

}  // namespace gb::ui
