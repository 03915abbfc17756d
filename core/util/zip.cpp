#include "core/util/zip.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <zlib.h>

#include "core/util/file.h"

namespace gb {
namespace {

// APPNOTE 6.3 values that every entry shares (zip.h).
constexpr std::uint32_t kZipLocalSignature = 0x04034b50;
constexpr std::uint32_t kZipCentralSignature = 0x02014b50;
constexpr std::uint32_t kZipEndSignature = 0x06054b50;
constexpr std::uint16_t kZipVersionNeeded = 20;             // 2.0: deflate, folders
constexpr std::uint16_t kZipVersionMadeBy = (3 << 8) | 20;  // Unix, 2.0
constexpr std::uint16_t kZipFlagUtf8 = 1 << 11;             // the name is UTF-8
constexpr std::uint16_t kZipStored = 0;
constexpr std::uint16_t kZipDeflated = 8;
constexpr std::uint16_t kZipDosTime = 0;                        // 00:00:00
constexpr std::uint16_t kZipDosDate = (0 << 9) | (1 << 5) | 1;  // 1980-01-01
constexpr std::uint32_t kZipUnixFile0644 = 0100644u << 16;      // S_IFREG | 0644, high half
constexpr std::size_t kZipLocalHeaderBytes = 30;
constexpr std::size_t kZipCentralHeaderBytes = 46;
constexpr std::size_t kZipEndBytes = 22;
// Without ZIP64: 0xFFFF and 0xFFFFFFFF mean "see the ZIP64 record", so values stay below them.
constexpr std::size_t kZipMaxEntries = 0xFFFE;
constexpr std::size_t kZipMaxNameBytes = 0xFFFF;
constexpr std::uint64_t kZipMaxOffset = 0xFFFFFFFE;

void ZipPut16(std::string* out, std::uint16_t v) {
  out->push_back(static_cast<char>(v & 0xFF));
  out->push_back(static_cast<char>(v >> 8));
}

void ZipPut32(std::string* out, std::uint32_t v) {
  for (int shift = 0; shift < 32; shift += 8)
    out->push_back(static_cast<char>((v >> shift) & 0xFF));
}

// The entry as an error message names it: its name in quotes (the first 80 bytes of a long one),
// or its place (from 1) when it has none.
std::string ZipEntryLabel(const ZipEntry& entry, std::size_t index) {
  if (entry.name.empty()) return fmt::format("zip entry number {}", index + 1);
  if (entry.name.size() > 80) return fmt::format("zip entry \"{}...\"", entry.name.substr(0, 80));
  return fmt::format("zip entry \"{}\"", entry.name);
}

// Why the entries cannot make an archive without ZIP64 ("" when they can), sizes of the
// compressed data aside (ZipArchive checks those as it goes).
std::string ZipWhyNot(std::span<const ZipEntry> entries) {
  if (entries.size() > kZipMaxEntries)
    return fmt::format("a zip archive without ZIP64 holds at most {} entries, not {}",
                       kZipMaxEntries, entries.size());
  std::unordered_map<std::string_view, std::size_t> seen;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const ZipEntry& e = entries[i];
    const std::string label = ZipEntryLabel(e, i);
    if (e.name.empty()) return label + ": its name is empty";
    if (e.name.front() == '/') return label + ": its name starts with '/'";
    if (e.name.find("..") != std::string::npos) return label + ": its name contains \"..\"";
    if (e.name.size() > kZipMaxNameBytes)
      return fmt::format("{}: its name has {} bytes, and a zip entry's name at most {}", label,
                         e.name.size(), kZipMaxNameBytes);
    if (e.bytes.size() > kZipMaxOffset)
      return fmt::format("{}: it holds {} bytes, and without ZIP64 an entry holds at most {}",
                         label, e.bytes.size(), kZipMaxOffset);
    const auto [at, fresh] = seen.try_emplace(e.name, i);
    if (!fresh)
      return fmt::format("{}: the name is also that of entry number {}", label, at->second + 1);
  }
  return "";
}

std::uint32_t ZipCrc32(const std::string& bytes) {
  return static_cast<std::uint32_t>(
      crc32_z(crc32_z(0, nullptr, 0), reinterpret_cast<const Bytef*>(bytes.data()), bytes.size()));
}

// `bytes` as raw deflate at zlib's default level, or "" when zlib fails or the result is not
// smaller (the entry is then stored).
std::string ZipDeflate(const std::string& bytes) {
  if (bytes.empty()) return "";
  z_stream z{};
  if (deflateInit2(&z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY) !=
      Z_OK)
    return "";
  std::string out(bytes.size(), '\0');  // anything as large as the input is of no use
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  std::size_t in_left = bytes.size();
  std::size_t out_left = out.size();
  int rc = Z_OK;
  // avail_in and avail_out are 32 bits: fed in pieces of at most 1 GiB.
  constexpr std::size_t kPiece = std::size_t{1} << 30;
  while (rc == Z_OK) {
    if (z.avail_in == 0) {
      z.avail_in = static_cast<uInt>(std::min(in_left, kPiece));
      in_left -= z.avail_in;
    }
    if (z.avail_out == 0) {
      if (out_left == 0) break;  // not smaller
      z.avail_out = static_cast<uInt>(std::min(out_left, kPiece));
      out_left -= z.avail_out;
    }
    rc = deflate(&z, in_left == 0 ? Z_FINISH : Z_NO_FLUSH);
    if (rc == Z_BUF_ERROR && z.avail_out == 0) rc = Z_OK;  // no room left: see above
  }
  const std::size_t produced = out.size() - out_left - z.avail_out;
  deflateEnd(&z);
  if (rc != Z_STREAM_END || produced >= bytes.size()) return "";
  out.resize(produced);
  return out;
}

// What the central directory keeps of an entry written.
struct ZipWritten {
  std::uint16_t method = kZipStored;
  std::uint32_t crc = 0;
  std::uint32_t compressed = 0;
  std::uint32_t size = 0;
  std::uint32_t offset = 0;
};

// The fields the local and central headers share, from "version needed" to "extra field length".
void ZipPutCommon(std::string* out, const ZipWritten& w, const std::string& name) {
  ZipPut16(out, kZipVersionNeeded);
  ZipPut16(out, kZipFlagUtf8);
  ZipPut16(out, w.method);
  ZipPut16(out, kZipDosTime);
  ZipPut16(out, kZipDosDate);
  ZipPut32(out, w.crc);
  ZipPut32(out, w.compressed);
  ZipPut32(out, w.size);
  ZipPut16(out, static_cast<std::uint16_t>(name.size()));
  ZipPut16(out, 0);  // extra field length
}

}  // namespace

Result<std::string> ZipArchive(std::span<const ZipEntry> entries) {
  if (const std::string why = ZipWhyNot(entries); !why.empty()) return InputError(why);
  std::string out;
  std::vector<ZipWritten> written;
  written.reserve(entries.size());
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const ZipEntry& e = entries[i];
    std::string deflated = ZipDeflate(e.bytes);
    const bool stored = deflated.empty();
    const std::string& data = stored ? e.bytes : deflated;
    // This entry's end, and the central directory's share of it, must stay below 4 GiB.
    const std::uint64_t end = std::uint64_t{out.size()} + kZipLocalHeaderBytes + e.name.size() +
                              data.size() + kZipCentralHeaderBytes + e.name.size();
    if (end > kZipMaxOffset)
      return InputError(ZipEntryLabel(e, i) +
                        ": with it the archive would reach 4 GiB, the most without ZIP64");
    ZipWritten w;
    w.method = stored ? kZipStored : kZipDeflated;
    w.crc = ZipCrc32(e.bytes);
    w.compressed = static_cast<std::uint32_t>(data.size());
    w.size = static_cast<std::uint32_t>(e.bytes.size());
    w.offset = static_cast<std::uint32_t>(out.size());
    ZipPut32(&out, kZipLocalSignature);
    ZipPutCommon(&out, w, e.name);
    out += e.name;
    out += data;
    written.push_back(w);
  }
  const std::size_t central = out.size();
  for (std::size_t i = 0; i < entries.size(); ++i) {
    ZipPut32(&out, kZipCentralSignature);
    ZipPut16(&out, kZipVersionMadeBy);
    ZipPutCommon(&out, written[i], entries[i].name);
    ZipPut16(&out, 0);  // file comment length
    ZipPut16(&out, 0);  // disk number start
    ZipPut16(&out, 0);  // internal file attributes
    ZipPut32(&out, kZipUnixFile0644);
    ZipPut32(&out, written[i].offset);
    out += entries[i].name;
  }
  const std::size_t central_bytes = out.size() - central;
  if (out.size() + kZipEndBytes > kZipMaxOffset)
    return InputError("the zip archive would reach 4 GiB, the most without ZIP64");
  const auto count = static_cast<std::uint16_t>(entries.size());
  ZipPut32(&out, kZipEndSignature);
  ZipPut16(&out, 0);      // number of this disk
  ZipPut16(&out, 0);      // disk where the central directory starts
  ZipPut16(&out, count);  // entries on this disk
  ZipPut16(&out, count);  // entries in all
  ZipPut32(&out, static_cast<std::uint32_t>(central_bytes));
  ZipPut32(&out, static_cast<std::uint32_t>(central));
  ZipPut16(&out, 0);  // comment length
  return out;
}

Status WriteZipFile(const std::string& path, std::span<const ZipEntry> entries) {
  Result<std::string> archive = ZipArchive(entries);
  if (!archive.ok()) return FileError(path, archive.error().message);
  return WriteFileAtomic(path, *archive);
}

}  // namespace gb
