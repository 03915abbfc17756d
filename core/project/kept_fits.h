// Fits kept with a project. Each fit the workbench finishes (or the user stops) is written as a
// result file that the command line reads, beside the model it was fitted with, in a folder
// beside the project file:
//
//   engine.json                        the project
//   engine.fits/fit-001.json           EstimateSummary::ToJson and the keys below
//   engine.fits/fit-001.model.json     the model as it was fitted ("model_file" names it)
//   engine.fits/fit-001.project.json   that model and the datasets as they were fitted: the
//                                      project `greybench-cli estimate` fits again
//
// Keys a kept fit adds to a result file: "model_file" ("fit-001.model.json"), "project_file"
// ("fit-001.project.json"), "finished" (local time, "2026-11-27 11:52:03"), "data_fingerprints",
// and what the caller puts in (the workbench: "settings", "initial_states"). A kept fit is never
// written over: the next fit takes the first number whose two files do not exist, and deleting a
// fit removes its two files only.
#pragma once

#include <string>
#include <vector>

#include "core/project/project.h"
#include "core/util/json.h"
#include "core/util/result.h"

namespace gb::project {

// "DIR/engine.fits" for "DIR/engine.json" ("" for an unsaved project: "").
std::string FitsFolder(const std::string& project_path);

// The implicit move constructor moves two ordered_json members (see Project, project.h).
// NOLINTNEXTLINE(bugprone-exception-escape)
struct KeptFitFile {
  std::string path;  // the result file
  int number = 0;    // NNN of fit-NNN.json
  Json result;
  Json model;  // the model file it names
};

// Writes `result`, `model` and `project` (its name, datasets and extra keys; its model is set to
// the model file written) as the next fit-NNN files of `folder` (created when missing), with
// "model_file", "project_file" and "finished" set in the result. Returns the result file and
// its number.
Result<KeptFitFile> WriteKeptFit(const std::string& folder, Json result, const Json& model,
                                 Project project);

// Every fit-NNN.json of `folder` with its model, in number order (none when the folder does not
// exist). A pair that cannot be read is left out and reported in `problems`, naming the file and
// what is wrong.
std::vector<KeptFitFile> ReadKeptFits(const std::string& folder, std::vector<Error>* problems);

// Removes a kept fit's files (only a fit-NNN.json of a fits folder: any other path is refused).
Status DeleteKeptFit(const std::string& result_path);

}  // namespace gb::project
