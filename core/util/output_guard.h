// The output guard: a command refuses, before it opens anything for writing, an output path that
// would destroy one of its inputs or another of its outputs.
//
// Two paths are the same file when both exist and stat() gives one device and inode (so a
// symlink, a hard link, `./x` and `x` are all caught), or when neither exists and their absolute
// forms, with the existing part of each resolved through links, are equal. A character device
// (`/dev/null`, a terminal) may be written by several outputs: writing it destroys nothing.
//
// Paths that are empty or "-" (standard input or output) are not files and are skipped.
#pragma once

#include <string>
#include <vector>

#include "core/util/result.h"

namespace gb {

// A file a command reads or writes, with the role a message names it by: "the model file",
// "the data file", "--out", "--states".
struct FileRole {
  std::string path;
  std::string role;
};

// An InputError naming the output, its role and the input or output it would destroy, for the
// first such output; Ok when none would. Checks names only: it opens nothing.
Status CheckOutputs(const std::vector<FileRole>& inputs, const std::vector<FileRole>& outputs);

}  // namespace gb
