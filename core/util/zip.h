// ZIP archives as greybench writes them: an FMI 2.0 FMU is one (`modelDescription.xml` and
// `binaries/linux64/NAME.so`), and nothing else is needed of the format.
//
// The format is PKWARE's APPNOTE 6.3 without its extensions: a local header before each entry's
// data, then the central directory, then the end record; no ZIP64, no data descriptors, no extra
// fields, no comments, no encryption. Every entry is
//   version needed 20, version made by 3<<8 | 20 (Unix), general-purpose flag bit 11 (the name is
//   UTF-8), method 8 (raw deflate, zlib's default level) or 0 (stored) when deflating does not
//   make it smaller (so an empty entry is stored), CRC-32 as zlib computes it, the fixed time
//   1980-01-01 00:00 (DOS time 0, date 0x21), and external attributes giving a regular file of
//   Unix mode 0644.
// So the same entries, in the same order, give the same bytes (with the same zlib).
//
// The entries are written in the order given. A name is a path inside the archive: '/'-separated,
// not empty, no leading '/', no "..", at most 65 535 bytes, and no two entries share one. Without
// ZIP64 an archive holds at most 65 534 entries, and no size or offset in it may reach 4 GiB
// (0xFFFFFFFF, the value ZIP64 reserves for "see the ZIP64 record"): an archive that would
// have 0xFFFFFFFF bytes or more is refused. Names are not otherwise checked (UTF-8,
// control characters and '\' are the caller's business).
#pragma once

#include <span>
#include <string>

#include "core/util/result.h"

namespace gb {

// One file in an archive.
struct ZipEntry {
  std::string name;   // path inside the archive, '/'-separated, no leading '/', not empty
  std::string bytes;  // the file's contents
};

// The archive's bytes, as WriteZipFile writes them. An entry breaking the rules above is an
// InputError naming it (`zip entry "a/../b": its name contains ".."`; an entry
// without a name by its place, from 1: `zip entry number 2: its name is empty`), as is an archive
// that would need ZIP64. Should zlib fail to deflate an entry (out of memory), the entry is stored.
Result<std::string> ZipArchive(std::span<const ZipEntry> entries);

// Writes the archive of `entries` (ZipArchive) to `path` atomically (WriteFileAtomic, core/util/
// file.h): the archive appears complete or not at all. Every Error names `path`: the entry errors
// of ZipArchive, and those of WriteFileAtomic ("cannot write the file (cannot create ...: No such
// file or directory)" for a folder that does not exist).
Status WriteZipFile(const std::string& path, std::span<const ZipEntry> entries);

}  // namespace gb
