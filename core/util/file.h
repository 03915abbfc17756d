// Before reading a whole file into memory: is it a file that can be read to its end?
//
// A folder cannot; a device or a pipe (`/dev/zero`, `/dev/urandom`, a FIFO) may never end and
// would be read until memory runs out; a file larger than the reader's limit is not one of ours.
// WhyNotReadable says why, in the words an error message needs, or returns "" when it can be read
// (and then, given `size`, its size in bytes).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <system_error>

namespace gb {

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

}  // namespace gb
