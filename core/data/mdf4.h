// Measured data in ASAM MDF 4 files (.mf4): the numeric channels of every channel group, decoded
// to physical values, and a Dataset (dataset.h) built from some of them on one time base.
//
// What is read
//   - MDF 4.00 to 4.2x (id_ver 400-499: of 4.3's additions, zstd/lz4 DZ blocks are refused and
//     VLSC channels and strings with a byte order mark skipped, where met).
//   - DZ and HL blocks (MDF 4.10's) are read whatever version the file states.
//   - Every data group (DG), sorted (one channel group) or unsorted (several channel groups whose
//     records are told apart by a 1, 2, 4 or 8-byte record ID); the records of a VLSD channel
//     group in an unsorted DG are skipped by their u32 length prefix.
//   - Data in one DT, a DL chain of DT/DZ blocks (equal-length or offsets form), DZ alone (zlib
//     deflate, zip type 0, or transposition + deflate, zip type 1, whose last n mod C bytes are
//     not transposed), or an HL in front of a DL chain. Records may cross block boundaries.
//   - Channels of type fixed-length (0), master (2), virtual master (3) and virtual data (6), with
//     data type unsigned/signed integer (1..64 bits at any bit offset 0..7, little or big endian;
//     bit_offset + bit_count <= 64) or IEEE float (32, 64 bits; 16 bits from MDF 4.20), LE or BE.
//   - Conversions (y = physical, x = raw): identity (no CC or type 0); linear (1) y = p0 + p1 x;
//     rational (2) y = (p0 x^2 + p1 x + p2) / (p3 x^2 + p4 x + p5), NaN for a sample whose
//     denominator is 0, refused up front when p3 = p4 = p5 = 0; value-to-value with (4) and
//     without (5) interpolation (keys strictly increasing; type 5 takes the nearest key, the lower
//     one at a midpoint; both clamp outside the table); range-to-value (6).
//   - Invalidation: cn_flags bit 0 (every sample invalid) and bit 1 (the bit cn_inval_bit_pos of
//     the record's invalidation bytes); an invalid sample is NaN.
//   - A virtual master or virtual data channel has the value CC(k) for record k (0-based).
//   - Each group's master (type 2 or 3) gives Mdf4Group::time: seconds for sync type 1 (time);
//     angle (rad), distance (m) and index masters are read as they are (master_sync says which).
//
// What is skipped (not offered as a numeric channel; listed in Mdf4File::skipped with the reason,
// which Mdf4ToDataset gives when such a channel is asked for): strings, byte arrays, MIME,
// CANopen date/time and complex data types; VLSD, MLSD and synchronisation channels; channels
// with a composition (structures, arrays); algebraic and text conversions (types 3, 7-11).
//
// What is refused (an Error whose message names the block by type and file offset, e.g.
// `run.mf4: CN block at 0x1a8: link 2 (name) points past the end of the file (size 4096)`):
// not an MDF file, an unfinalized file (`UnFinMF `), MDF 3; a block header that is truncated or
// not a block; a link past the end of the file, into the identification block, to a block of the
// wrong type, or back into its own chain; a block shorter than its links and fields; unknown
// enumerations; a DZ that does not inflate or inflates to another size than it declares (or to
// more than 1032 times its compressed size, deflate's limit); a DL whose count disagrees with its
// links or whose sizes disagree with its offsets; data whose length disagrees with the cycle
// counts; an unknown record ID; a truncated record or VLSD item; a channel that does not fit in
// its record or whose bit count its data type cannot have; two masters in one group; a
// conversion with the wrong parameter count, non-finite parameters, non-increasing keys or an
// identically zero denominator; more than kMaxMdf4Values decoded values in all.
// Nothing is allocated before the counts it depends on are bounded by the file's size.
//
// Mdf4ToDataset: see Mdf4Format.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/data/dataset.h"
#include "core/util/result.h"

namespace gb::data {

// The most values (samples of all channels and masters) one file may decode to: 2 GiB of doubles.
inline constexpr std::uint64_t kMaxMdf4Values = std::uint64_t{1} << 28;

// One numeric channel, decoded to physical values.
struct Mdf4Channel {
  std::string name, unit, comment;
  int group = 0;               // 0-based index into Mdf4File::groups
  std::vector<double> values;  // physical values (conversion applied), NaN where invalid
};

// One channel group (CG): one time base.
struct Mdf4Group {
  std::string name;          // acquisition name (TX), may be empty
  int number = 0;            // 1-based, in file order over all DGs and their CGs
  std::vector<double> time;  // the master's physical values, one per record (cycle count);
                             // empty when the group has no master
  std::string master_name;   // "" without a master; the master's name, also when virtual
  bool has_master = false;
  bool virtual_master = false;  // time[k] = CC(k)
  int master_sync = 0;          // 1 time (s), 2 angle (rad), 3 distance (m), 4 index; 0 none
  std::vector<int> channels;    // indices into Mdf4File::channels (not the master)
};

// A channel that is not read as numbers, and why ("a UTF-8 string channel").
struct Mdf4Skipped {
  std::string name;
  int group = 0;  // 0-based index into Mdf4File::groups
  std::string reason;
};

struct Mdf4File {
  int version = 0;  // id_ver: 400, 410, 411, 420, ...
  std::vector<Mdf4Group> groups;
  std::vector<Mdf4Channel> channels;
  std::vector<Mdf4Skipped> skipped;

  // Index into `channels` of the channel named `name`; `name@G` names the one in group G, G
  // being the group's 1-based number or its acquisition name (a name without '@' that occurs in
  // several groups must be written so). -1 absent, -2 ambiguous.
  int Find(std::string_view name) const;
};

// Parses a whole file held in memory; `source` names it in messages (Error::file).
Result<Mdf4File> ParseMdf4(std::span<const unsigned char> bytes, const std::string& source);
// Reads the file at `path` (refused, naming it, when it is not a readable regular file).
Result<Mdf4File> ReadMdf4File(const std::string& path);
// Whether `head` (a file's first bytes) starts with the MDF magic "MDF     " or "UnFinMF ".
bool LooksLikeMdf(std::span<const unsigned char> head);

// Channels brought onto one time base as a Dataset.
//
// The Dataset: source = `source`, header_line 0, time_name "t", time_field 0, time_scale 1; time
// strictly increasing (seconds for time masters); row_line[k] = 1 + the row's index in the time
// base (its record index in the time base group, its grid index with a sample time); columns[i]
// named as the user wrote the channel (or, for every channel, its name when unique in the file,
// else name@G), field i + 1.
// Refused: an absent channel (the message lists the file's channels), an ambiguous one, a skipped
// one (with the reason), a channel of a group without a master, groups of different master
// kinds, and a master used here that is not finite or not strictly increasing (named by group and
// sample: exact duplicates are refused too, since a row would have two values).
struct Mdf4Format {
  // Names or name@G. Empty: every channel of every group with a master.
  std::vector<std::string> channels;
  // A group (its 1-based number or its acquisition name) or a channel name (its group) whose
  // master gives the rows' times. "": the group with the most records among the channels'
  // groups (the lowest number on a tie).
  std::string time_base;
  // > 0: the rows are instead on the grid t0 + k * sample_time from t0, the latest first sample of
  // the channels' groups, up to the earliest last sample (at most 1e8 rows).
  double sample_time = 0;
  // A channel's value at row time t: kHold, its last sample at or before t (NaN before its first
  // sample; the last sample holds after its end); kLinear, linear between the samples either
  // side of t (a sample's own value at its time; NaN outside [first, last] sample time and when
  // either neighbour is NaN).
  enum class Interpolation { kHold, kLinear } interpolation = Interpolation::kHold;
  // Only the rows with range[0] <= t <= range[1] are kept (maybe none).
  std::optional<std::array<double, 2>> range;
};

Result<std::shared_ptr<const Dataset>> Mdf4ToDataset(const Mdf4File& file,
                                                     const std::string& source,
                                                     const Mdf4Format& format = {});

}  // namespace gb::data
