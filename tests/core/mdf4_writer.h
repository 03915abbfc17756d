// A small MDF 4.10 writer for tests (core/data/mdf4.h reads what it writes): data groups of
// channel groups with a float64 time master or a virtual master, numeric channels of any integer
// or float layout with an optional conversion, sorted (one group per DG) or unsorted (several
// groups per DG told apart by record IDs, records interleaved by time), the data in one DT, a DL
// of several DTs (offsets or equal-length form), a DZ (deflate or transposition + deflate), or
// an HL in front of a DL of DZs. The offsets of the blocks it wrote are returned by label, so
// that a test can break one field of one block.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace gb::data::mdf4_testing {

// cn_data_type codes.
inline constexpr int kUintLe = 0, kUintBe = 1, kIntLe = 2, kIntBe = 3, kFloatLe = 4, kFloatBe = 5,
                     kUtf8 = 7;

struct WConversion {
  int type = -1;  // -1: no CC block; else cc_type with cc_val = p
  std::vector<double> p;
};

struct WChannel {
  std::string name, unit;
  int cn_type = 0;  // 0 data, 2 master, 3 virtual master, 6 virtual data
  int sync = 0;     // 1 time for a master
  int data_type = kFloatLe;
  int bit_count = 64;
  int bit_offset = 0;
  int byte_offset = -1;  // -1: the byte after the previous channel's
  WConversion conversion;
  std::vector<std::uint64_t> raw;  // the raw bits of each record (a float's bit pattern)
  int inval_bit = -1;              // >= 0: cn_flags bit 1, this invalidation bit
  std::vector<bool> invalid;       // per record, when inval_bit >= 0
  std::uint32_t flags = 0;         // more cn_flags bits
};

// Channels of the usual kinds; raw holds `values` as the data type stores them.
WChannel TimeMaster(const std::vector<double>& seconds, std::string name = "t");
WChannel VirtualMaster(double period, std::string name = "t");  // t = period * k (a linear CC)
WChannel Float64(std::string name, const std::vector<double>& values, bool big_endian = false);
WChannel Float32(std::string name, const std::vector<float>& values, bool big_endian = false);
WChannel Integer(std::string name, int data_type, int bit_count, int bit_offset,
                 const std::vector<std::int64_t>& values);

struct WGroup {
  std::string name;  // acquisition name ("" writes no TX)
  std::size_t records = 0;
  std::vector<WChannel> channels;
  int data_bytes = -1;                  // -1: what the channels need
  int inval_bytes = -1;                 // -1: what the invalidation bits need
  std::uint64_t record_id = 0;          // unsorted DG: 0 gives the group's 1-based index in its DG
  std::vector<std::string> vlsd_items;  // non-empty: a VLSD group (cg_flags bit 0) of these items
};

inline WGroup Group(std::string name, std::size_t records, std::vector<WChannel> channels) {
  WGroup g;
  g.name = std::move(name);
  g.records = records;
  g.channels = std::move(channels);
  return g;
}

enum class Storage { kDt, kDl, kDlEqual, kDz, kDzTransposed, kHlDz };

struct WDataGroup {
  std::vector<WGroup> groups;  // more than one: unsorted
  int rec_id_size = -1;        // -1: 0 when sorted, 1 when unsorted
  Storage storage = Storage::kDt;
  int blocks = 3;  // the DL's blocks
};

struct WFile {
  std::vector<WDataGroup> data_groups;
  int version = 410;
};

struct Written {
  std::vector<unsigned char> bytes;
  // Block offsets by label: "HD", "DG1" (1-based DG), "CG1.2" (DG 1's second CG), "CN:name",
  // "CC:name", "TX:name" (a channel's name TX; the first channel of that name), "DATA1" (the block
  // DG 1's data link points to), "DT1.0" / "DZ1.0" (list members), "DL1", "HL1".
  std::map<std::string, std::uint64_t> blocks;
  std::uint64_t At(const std::string& label) const { return blocks.at(label); }
};

Written WriteMdf4(const WFile& file);
void WriteBytes(const std::string& path, const std::vector<unsigned char>& bytes);

// Little-endian patches of written bytes (for the malformed-file tests).
void Put(std::vector<unsigned char>& bytes, std::uint64_t at, std::uint64_t value, int size);

}  // namespace gb::data::mdf4_testing
