#include "core/util/output_guard.h"

#include <filesystem>
#include <optional>

#include <fmt/format.h>
#include <sys/stat.h>

namespace gb {
namespace {

namespace fs = std::filesystem;

// What makes a path one file: its device and inode when it exists, its resolved absolute name
// when it does not (yet).
struct Identity {
  bool exists = false;
  bool char_device = false;
  dev_t dev = 0;
  ino_t ino = 0;
  std::string name;
};

std::optional<Identity> IdentityOf(const std::string& path) {
  if (path.empty() || path == "-") return std::nullopt;
  Identity id;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    id.exists = true;
    id.char_device = S_ISCHR(st.st_mode);
    id.dev = st.st_dev;
    id.ino = st.st_ino;
    return id;
  }
  std::error_code ec;
  fs::path name = fs::weakly_canonical(fs::absolute(path, ec), ec);
  id.name = ec ? fs::absolute(path, ec).lexically_normal().string() : name.string();
  return id;
}

bool SameFile(const Identity& a, const Identity& b) {
  if (a.exists != b.exists) return false;
  return a.exists ? a.dev == b.dev && a.ino == b.ino : a.name == b.name;
}

}  // namespace

Status CheckOutputs(const std::vector<FileRole>& inputs, const std::vector<FileRole>& outputs) {
  std::vector<std::optional<Identity>> in, out;
  for (const FileRole& f : inputs) in.push_back(IdentityOf(f.path));
  for (const FileRole& f : outputs) out.push_back(IdentityOf(f.path));
  for (std::size_t o = 0; o < outputs.size(); ++o) {
    if (!out[o]) continue;
    const FileRole& output = outputs[o];
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      if (!in[i] || !SameFile(*out[o], *in[i])) continue;
      const std::string same =
          inputs[i].path == output.path ? "" : fmt::format(" ({})", inputs[i].path);
      return InputError(fmt::format(
          "{} {} is {}{}: writing it would destroy that input; choose another path for {}",
          output.role, output.path, inputs[i].role, same, output.role));
    }
    if (out[o]->char_device) continue;
    for (std::size_t p = 0; p < o; ++p) {
      if (!out[p] || !SameFile(*out[o], *out[p])) continue;
      return InputError(fmt::format(
          "{} {} is also the path of {} {}: one output would overwrite the other; give them "
          "different paths",
          output.role, output.path, outputs[p].role, outputs[p].path));
    }
  }
  return Ok{};
}

}  // namespace gb
