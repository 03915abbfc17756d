#include "core/util/file.h"

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include "core/util/json.h"

namespace gb {
namespace fs = std::filesystem;

Error FileError(const std::string& file, std::string message, std::string path) {
  Error e = InputError(std::move(message));
  e.file = file;
  e.path = std::move(path);
  return e;
}

namespace {

// 1-based line and column of byte offset `pos` in `text`.
void LineCol(const std::string& text, std::size_t pos, int* line, int* col) {
  *line = 1;
  *col = 1;
  for (std::size_t i = 0; i < pos && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++*line;
      *col = 1;
    } else {
      ++*col;
    }
  }
}

// Builds a Json from nlohmann's SAX events as Json::parse does (a repeated key keeps its first
// place and takes its last value), but finds each key of an object through a hash table: an
// ordered_json object looks keys up by a scan, so Json::parse takes time quadratic in the keys of
// an object (a large diagram's layout has 100 000: docs/benchmarks.md, "Timings behind the
// code's limits").
class OrderedBuilder {
 public:
  explicit OrderedBuilder(Json* root) : root_(root) {}
  bool null() {
    Put(nullptr);
    return true;
  }
  bool boolean(bool v) {
    Put(v);
    return true;
  }
  bool number_integer(Json::number_integer_t v) {
    Put(v);
    return true;
  }
  bool number_unsigned(Json::number_unsigned_t v) {
    Put(v);
    return true;
  }
  bool number_float(Json::number_float_t v, const Json::string_t&) {
    Put(v);
    return true;
  }
  bool string(Json::string_t& v) {
    Put(std::move(v));
    return true;
  }
  bool binary(Json::binary_t& v) {
    Put(Json::binary(std::move(v)));
    return true;
  }
  bool start_object(std::size_t) {
    open_.push_back({Put(Json::object()), {}});
    return true;
  }
  bool key(Json::string_t& k) {
    Open& o = open_.back();
    auto& entries = static_cast<Json::object_t::Container&>(o.value->get_ref<Json::object_t&>());
    const auto [at, fresh] = o.keys.try_emplace(k, entries.size());
    if (fresh) entries.emplace_back(std::move(k), nullptr);
    slot_ = &entries[at->second].second;
    return true;
  }
  bool end_object() {
    open_.pop_back();
    return true;
  }
  bool start_array(std::size_t) {
    open_.push_back({Put(Json::array()), {}});
    return true;
  }
  bool end_array() {
    open_.pop_back();
    return true;
  }
  // Throws what Json::parse throws (parse_error, out_of_range for a number beyond a double).
  template <class Exception>
  bool parse_error(std::size_t, const std::string&, const Exception& ex) {
    throw ex;
  }

 private:
  struct Open {
    Json* value;  // an object or array being filled (its parent is not touched until it closes)
    std::unordered_map<std::string, std::size_t> keys;  // an object's keys -> their places
  };
  Json* Put(Json v) {
    if (open_.empty()) {
      *root_ = std::move(v);
      return root_;
    }
    Json* parent = open_.back().value;
    if (parent->is_array()) {
      parent->push_back(std::move(v));
      return &parent->back();
    }
    *slot_ = std::move(v);
    return slot_;
  }

  Json* root_;
  Json* slot_ = nullptr;  // the value of the object's last key
  std::vector<Open> open_;
};

// Json::parse(text) in time linear in the text (see OrderedBuilder); throws as it does.
Json ParseJson(std::string_view text) {
  Json j;
  OrderedBuilder builder(&j);
  Json::sax_parse(text, &builder);
  return j;
}

}  // namespace

Result<Json> ReadJsonFile(const std::string& path) {
  // Model, project and diagram files are a few KB; 256 MiB leaves room for inline data tables.
  constexpr std::uintmax_t kMaxJsonBytes = std::uintmax_t{256} << 20;
  if (const std::string why = WhyNotReadable(path, kMaxJsonBytes); !why.empty())
    return FileError(path, why);
  std::ifstream in(path, std::ios::binary);
  if (!in) return FileError(path, "cannot open the file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  Json j;
  try {
    j = ParseJson(text);
  } catch (const Json::parse_error& ex) {
    Error e = FileError(path, "JSON syntax error");
    LineCol(text, ex.byte > 0 ? ex.byte - 1 : 0, &e.line, &e.col);
    // nlohmann's message: "[json.exception.parse_error.101] parse error at line 1, column 5:
    // syntax error while parsing value - invalid literal; last read: 'x'". Keep the tail.
    const std::string what = ex.what();
    const auto at = what.find("syntax error while parsing ");
    if (at != std::string::npos) e.message += ": " + what.substr(at + 27);
    return e;
  } catch (const Json::out_of_range& ex) {
    // A number beyond the range of a double ("1e999"): nlohmann names the literal but not its
    // place, so the first occurrence of that literal is reported.
    const std::string what = ex.what();
    const auto open = what.find('\'');
    const auto close = what.rfind('\'');
    const std::string literal =
        open != std::string::npos && close > open ? what.substr(open + 1, close - open - 1) : "";
    Error e = FileError(path, "the number " + literal + " is out of range for a double");
    const auto pos = literal.empty() ? std::string::npos : text.find(literal);
    if (pos != std::string::npos) LineCol(text, pos, &e.line, &e.col);
    return e;
  } catch (const Json::exception& ex) {
    return FileError(path, std::string("cannot read the JSON: ") + ex.what());
  }
  return j;
}

namespace {

// The temporary beside `path` that one write uses: a name no other writer uses (process id and a
// counter), so that two saves of the same file never share a temporary.
std::string TemporaryFor(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  return fmt::format("{}.tmp-greybench-{}-{}", path, static_cast<long>(::getpid()), counter++);
}

Error CannotCreate(const std::string& path, const std::string& tmp, int err) {
  return FileError(
      path, fmt::format("cannot write the file (cannot create {}: {})", tmp, std::strerror(err)));
}

// Where a write of `path` lands: the path itself, or, through symlinks, the file they name (so
// that replacing it keeps the link). `through` is true for what is not a regular file and so is
// written in place (a device such as /dev/null, a FIFO, a terminal), never renamed over.
struct WriteTarget {
  std::string path;
  bool through = false;
};

WriteTarget TargetOf(const std::string& path) {
  std::error_code ec;
  const fs::file_status link = fs::symlink_status(path, ec);
  if (ec || !fs::exists(link)) return {path, false};
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) return {path, true};  // a dangling link: created through it
  std::string target = path;
  if (fs::is_symlink(link)) {
    const fs::path resolved = fs::canonical(path, ec);
    if (!ec) target = resolved.string();
  }
  return {target, !fs::is_regular_file(st) && !fs::is_directory(st)};
}

// Writes all of `text` to `fd`; 0 or the errno of the failure.
int WriteAll(int fd, const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return n < 0 ? errno : EIO;
    done += static_cast<std::size_t>(n);
  }
  return 0;
}

Status WriteThrough(const std::string& path, const std::string& text) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0)
    return FileError(path, fmt::format("cannot write the file: {}", std::strerror(errno)));
  const int err = WriteAll(fd, text);
  const bool closed = ::close(fd) == 0;
  if (err || !closed)
    return FileError(path,
                     fmt::format("cannot write the file: {}", std::strerror(err ? err : errno)));
  return Ok{};
}

}  // namespace

Status CheckWritable(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec))
    return FileError(path, fmt::format("cannot replace the file: {}", std::strerror(EISDIR)));
  const WriteTarget target = TargetOf(path);
  if (target.through) {
    if (::access(target.path.c_str(), W_OK) != 0 && errno != ENOENT)
      return FileError(path, fmt::format("cannot write the file: {}", std::strerror(errno)));
    return Ok{};
  }
  const std::string tmp = TemporaryFor(target.path);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) return CannotCreate(path, tmp, errno);
  ::close(fd);
  ::unlink(tmp.c_str());
  return Ok{};
}

Status WriteFileAtomic(const std::string& path, const std::string& text) {
  const WriteTarget target = TargetOf(path);
  if (target.through) return WriteThrough(target.path, text);
  const std::string tmp = TemporaryFor(target.path);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) return CannotCreate(path, tmp, errno);
  // Every byte reaches the disk before the rename makes the new file visible: after a crash or
  // a power cut the path holds either the old content or the new, never a truncated file.
  const int write_errno = WriteAll(fd, text);
  const bool synced = write_errno == 0 && ::fsync(fd) == 0;
  const int sync_errno = synced ? 0 : errno;
  const bool closed = ::close(fd) == 0;
  if (!synced || !closed) {
    const int err = write_errno ? write_errno : sync_errno ? sync_errno : errno;
    ::unlink(tmp.c_str());
    return FileError(path, fmt::format("cannot write the file: {}", std::strerror(err)));
  }
  if (::rename(tmp.c_str(), target.path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    return FileError(path, fmt::format("cannot replace the file: {}", std::strerror(err)));
  }
  // The rename itself is durable once the directory is synced. A failure here loses nothing
  // that is not already visible, so it is not reported.
  const fs::path dir = fs::path(target.path).parent_path();
  const int dir_fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    ::fsync(dir_fd);
    ::close(dir_fd);
  }
  return Ok{};
}
}  // namespace gb
