// Files as every part of greybench reads and writes them: whether a file can be read to its end,
// a JSON file read with errors that point into it, a file written atomically, and a file's
// fingerprint. (Below every other core folder: data, model, diagram and project files all go
// through these.)
//
// Before reading a whole file into memory: is it a file that can be read to its end?
//
// A folder cannot; a device or a pipe (`/dev/zero`, `/dev/urandom`, a FIFO) may never end and
// would be read until memory runs out; a file larger than the reader's limit is not one of ours.
// WhyNotReadable says why, in the words an error message needs, or returns "" when it can be read
// (and then, given `size`, its size in bytes).
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

#include "core/util/json_fwd.h"
#include "core/util/result.h"

namespace gb {

// An input error in `file`; `path`, when given, the JSON path in it ("datasets[2].file").
Error FileError(const std::string& file, std::string message, std::string path = "");

// Reads a JSON file with errors of the form `FILE:LINE:COL: JSON syntax error: ...`. Objects keep
// the order of the file (core/util/json.h); a key repeated in an object keeps its first place and
// takes its last value.
Result<Json> ReadJsonFile(const std::string& path);

// Writes `text` to `path` atomically: a temporary file beside it (unique to this call), written,
// fsync'ed, closed, then renamed over `path`, and the directory fsync'ed. On any failure `path`
// keeps its old content, the temporary is removed, and the Error names `path` and the reason
// (e.g. "cannot write the file (cannot create ...: Permission denied)"). The new file gets the
// default permissions (0666 less the umask), not those of the file it replaces. A symlink to a
// regular file stays a link: the file it names is replaced. What is not a regular file (a device
// such as /dev/null, a FIFO, a terminal, or a link to one) is written in place, never renamed
// over. Callers check first that `path` is none of their inputs (core/util/output_guard.h).
Status WriteFileAtomic(const std::string& path, const std::string& text);

// Whether WriteFileAtomic(path, ...) could write now: creates and removes the temporary it would
// use, and refuses a folder in the way. For commands that write after a long run, so that a bad
// --out is reported before the run, not after. Same messages as WriteFileAtomic.
Status CheckWritable(const std::string& path);

inline std::string WhyNotReadable(const std::string& path, std::uintmax_t max_bytes,
                                  std::uintmax_t* size_out = nullptr) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec) return "cannot read the file: " + ec.message();
  if (std::filesystem::is_directory(status)) return "cannot read the file: it is a folder";
  if (!std::filesystem::is_regular_file(status))
    return "cannot read the file: it is a device or a pipe, not a regular file (it may never end)";
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return "cannot read the file: " + ec.message();
  if (size > max_bytes) {
    return "cannot read the file: it holds " + std::to_string(size >> 20) +
           " MiB, and files of this kind are read up to " + std::to_string(max_bytes >> 20) +
           " MiB";
  }
  if (size_out) *size_out = size;
  return "";
}

// The file's bytes as a 64-bit FNV-1a hash in 16 hex digits ("" when it cannot be read): what
// a result file records of its data, so that `compare` can tell fits to other data apart.
inline std::string FileFingerprint(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return "";
  std::uint64_t h = 0xcbf29ce484222325ULL;
  unsigned char buf[1 << 16];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0)
    for (std::size_t i = 0; i < n; ++i) h = (h ^ buf[i]) * 0x100000001b3ULL;
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) return "";
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

}  // namespace gb
