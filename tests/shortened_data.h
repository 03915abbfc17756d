// Shorter records for the tests that run on smaller data under the sanitizers (core/util/
// sanitizers.h). A test whose point under the sanitizers is the code path, not the statistics,
// fits the first rows of a bundled data file there; the release suite fits the whole record.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include "core/util/sanitizers.h"

namespace gb::testing {

// A copy of `file`'s comment lines (the operating-point tags), its header and its first `rows`
// data rows, written to a temporary folder of this process.
inline std::string ShortenedCopy(const std::string& file, int rows) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("greybench-shortened-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path copy = dir / std::filesystem::path(file).filename();
  std::ifstream in(file);
  std::ofstream out(copy);
  bool header = false;
  int kept = 0;
  for (std::string line; std::getline(in, line) && kept < rows;) {
    out << line << '\n';
    if (line.empty() || line[0] == '#') continue;
    if (header) ++kept;
    header = true;
  }
  return copy.string();
}

// `file` itself, or under the sanitizers its ShortenedCopy.
inline std::string ShortenedUnderSanitizers(const std::string& file, int rows) {
  return kSanitized ? ShortenedCopy(file, rows) : file;
}

}  // namespace gb::testing
