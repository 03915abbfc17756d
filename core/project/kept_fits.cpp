#include "core/project/kept_fits.h"

#include <algorithm>
#include <ctime>
#include <filesystem>
#include <optional>
#include <system_error>

#include <fmt/format.h>

#include "core/project/project.h"
#include "core/project/result_file.h"
#include "core/util/file.h"

namespace gb::project {
namespace {

namespace fs = std::filesystem;

constexpr int kMaxKeptFits = 9999;

std::string ResultName(int n) { return fmt::format("fit-{:03d}.json", n); }
std::string ModelName(int n) { return fmt::format("fit-{:03d}.model.json", n); }
std::string ProjectName(int n) { return fmt::format("fit-{:03d}.project.json", n); }

// NNN of "fit-NNN.json" (not of "fit-NNN.model.json"), or nothing.
std::optional<int> NumberOf(const std::string& file_name) {
  constexpr std::string_view kPrefix = "fit-", kSuffix = ".json";
  if (file_name.size() <= kPrefix.size() + kSuffix.size() || !file_name.starts_with(kPrefix) ||
      !file_name.ends_with(kSuffix))
    return std::nullopt;
  const std::string digits =
      file_name.substr(kPrefix.size(), file_name.size() - kPrefix.size() - kSuffix.size());
  if (digits.empty() || digits.size() > 4 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  return std::stoi(digits);
}

std::string LocalTime() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  localtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S", &tm);
  return text;
}

}  // namespace

std::string FitsFolder(const std::string& project_path) {
  if (project_path.empty()) return "";
  const fs::path p(project_path);
  return (p.parent_path() / (p.stem().string() + ".fits")).string();
}

Result<KeptFitFile> WriteKeptFit(const std::string& folder, Json result, const Json& model,
                                 Project project) {
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec || !fs::is_directory(folder))
    return FileError(folder, "cannot create the folder for the project's fits (" +
                                 (ec ? ec.message() : std::string("a file is in the way")) + ")");
  int n = 1;
  while (n <= kMaxKeptFits && (fs::exists(fs::path(folder) / ResultName(n), ec) ||
                               fs::exists(fs::path(folder) / ModelName(n), ec) ||
                               fs::exists(fs::path(folder) / ProjectName(n), ec)))
    ++n;
  if (n > kMaxKeptFits)
    return FileError(folder, fmt::format("holds {} fits already: delete some", kMaxKeptFits));
  KeptFitFile kept;
  kept.number = n;
  kept.path = (fs::path(folder) / ResultName(n)).string();
  result["model_file"] = ModelName(n);
  result["project_file"] = ProjectName(n);
  result["finished"] = LocalTime();
  const fs::path model_path = fs::path(folder) / ModelName(n);
  const fs::path project_path = fs::path(folder) / ProjectName(n);
  project.model_path = fs::absolute(model_path, ec).string();
  project.model_json = model;
  auto remove_written = [&] {
    fs::remove(model_path, ec);
    fs::remove(project_path, ec);
  };
  if (Status st = WriteFileAtomic(model_path.string(), model.dump(1) + "\n"); !st)
    return st.error();
  if (Status st = SaveProject(project, fs::absolute(project_path, ec).string()); !st) {
    remove_written();
    return st.error();
  }
  if (Status st = WriteFileAtomic(kept.path, result.dump(1) + "\n"); !st) {
    remove_written();
    return st.error();
  }
  kept.result = std::move(result);
  kept.model = model;
  return kept;
}

std::vector<KeptFitFile> ReadKeptFits(const std::string& folder, std::vector<Error>* problems) {
  std::vector<KeptFitFile> fits;
  std::error_code ec;
  if (folder.empty() || !fs::is_directory(folder, ec)) return fits;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
    const std::optional<int> n = NumberOf(entry.path().filename().string());
    if (!n) continue;
    KeptFitFile kept;
    kept.number = *n;
    kept.path = entry.path().string();
    Result<Json> result = ReadJsonFile(kept.path);
    if (!result) {
      problems->push_back(result.error());
      continue;
    }
    if (!result->is_object() || !result->contains("greybench_result")) {
      problems->push_back(FileError(kept.path, "not a greybench result file"));
      continue;
    }
    const auto model_file = result->find("model_file");
    if (model_file == result->end() || !model_file->is_string()) {
      problems->push_back(
          ResultFileError(kept.path, "model_file", "expected the model's file name"));
      continue;
    }
    Result<Json> model = ReadJsonFile(
        ResolvePath(fs::path(kept.path).parent_path().string(), model_file->get<std::string>()));
    if (!model) {
      problems->push_back(model.error());
      continue;
    }
    kept.result = std::move(result).value();
    kept.model = std::move(model).value();
    fits.push_back(std::move(kept));
  }
  if (ec) problems->push_back(FileError(folder, "cannot list the folder (" + ec.message() + ")"));
  std::sort(fits.begin(), fits.end(),
            [](const KeptFitFile& a, const KeptFitFile& b) { return a.number < b.number; });
  return fits;
}

Status DeleteKeptFit(const std::string& result_path) {
  const fs::path p(result_path);
  const std::optional<int> n = NumberOf(p.filename().string());
  if (!n || p.parent_path().extension() != ".fits")
    return FileError(result_path, "is not a kept fit (fit-NNN.json in a project's .fits folder)");
  std::error_code ec;
  fs::remove(p.parent_path() / ModelName(*n), ec);
  fs::remove(p.parent_path() / ProjectName(*n), ec);
  if (!fs::remove(p, ec) && ec)
    return FileError(result_path, "cannot delete the fit (" + ec.message() + ")");
  return Ok{};
}

}  // namespace gb::project
