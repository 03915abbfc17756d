// Reading ASAM MDF 4 files (what is read and refused: mdf4.h). Written from the block layouts in
// the project's notes on the format; every field is read through bounds-checked accessors, and
// every count is bounded by the file's size before anything is allocated for it.
//
// Contents
//   Bytes and blocks     little-endian reads, block headers, links, cycle guard
//   Texts                TX and MD blocks
//   Conversions          CC blocks: parsing, checks, applying
//   Structure            DG, CG and CN blocks
//   Data                 DT, DZ (inflate, transposition), DL, HL: one byte stream per DG
//   Records              sorted and unsorted DGs: each record's place in the stream
//   Values               decoding integers and floats, invalidation bits, the groups' masters
//   File                 ParseMdf4, ReadMdf4File, LooksLikeMdf, Mdf4File::Find
//   Dataset              Mdf4ToDataset: channels on one time base
#include "core/data/mdf4.h"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <map>
#include <set>
#include <system_error>

#include <fmt/format.h>
#include <zlib.h>

#include "core/util/file.h"

namespace gb::data {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::uint64_t kIdSize = 64;      // the identification block, which has no header
constexpr std::uint64_t kHeaderSize = 24;  // "##XY", reserved, length, link count
// Deflate cannot expand data by more than about 1032:1; a DZ declaring more is refused before
// its output buffer is allocated.
constexpr std::uint64_t kMaxInflateRatio = 1032;
constexpr std::uint64_t kMaxFileBytes = std::uint64_t{1} << 40;
constexpr double kMaxGridRows = 1e8;

std::string Hex(std::uint64_t v) { return fmt::format("{:#x}", v); }

// ---------------------------------------------------------------------------------------------
// Bytes and blocks

struct Block {
  std::uint64_t at = 0;      // file offset; 0 = no block (a link that was 0)
  std::string type;          // "CN"
  std::uint64_t length = 0;  // header + links + data section
  std::uint64_t links = 0;
  std::uint64_t data() const { return at + kHeaderSize + 8 * links; }  // the data section
  std::uint64_t end() const { return at + length; }
  std::string Name() const { return type + " block at " + Hex(at); }
};

// One conversion (CC), reduced to what decoding needs.
struct Conversion {
  int type = 0;           // 0 identity, 1 linear, 2 rational, 4/5 value tables, 6 ranges
  std::vector<double> p;  // cc_val
  double Apply(double x, bool integer_raw) const;
};

struct Channel {  // one CN block
  Block block;
  std::string name, unit, comment;
  int type = 0, sync = 0, data_type = 0, bit_offset = 0;
  std::uint32_t byte_offset = 0, bit_count = 0, flags = 0, inval_pos = 0;
  Conversion conversion;
  std::string skip;  // non-empty: not read as numbers, and why
  bool Virtual() const { return type == 3 || type == 6; }
};

struct Group {  // one CG block and where its records lie in the DG's stream
  Block block;
  std::string name;
  std::uint64_t record_id = 0, cycles = 0;
  std::uint16_t flags = 0;
  std::uint32_t data_bytes = 0, inval_bytes = 0;
  std::vector<Channel> channels;
  int master = -1;  // index into channels
  bool Vlsd() const { return (flags & 1) != 0; }
  // Record k's channel bytes start at stream offset first + k * stride (sorted), or at[k].
  std::uint64_t first = 0, stride = 0;
  std::vector<std::uint64_t> at;
  std::uint64_t Record(std::uint64_t k) const { return at.empty() ? first + k * stride : at[k]; }
};

class Parser {
 public:
  Parser(std::span<const unsigned char> bytes, const std::string& source)
      : bytes_(bytes), size_(bytes.size()), source_(source) {}
  Result<Mdf4File> Run();

 private:
  // Little-endian reads at file offsets; the callers have checked the range (Need, Link).
  std::uint64_t Le(std::uint64_t at, int n) const {
    std::uint64_t v = 0;
    for (int i = n - 1; i >= 0; --i) v = (v << 8) | bytes_[at + static_cast<std::uint64_t>(i)];
    return v;
  }
  std::uint8_t U8(std::uint64_t at) const { return bytes_[at]; }
  std::uint16_t U16(std::uint64_t at) const { return static_cast<std::uint16_t>(Le(at, 2)); }
  std::uint32_t U32(std::uint64_t at) const { return static_cast<std::uint32_t>(Le(at, 4)); }
  std::uint64_t U64(std::uint64_t at) const { return Le(at, 8); }
  double F64(std::uint64_t at) const { return std::bit_cast<double>(Le(at, 8)); }

  // The first error wins; every step returns false once there is one.
  bool Fail(std::string message) {
    if (!error_) {
      error_ = InputError(std::move(message));
      error_->file = source_;
    }
    return false;
  }
  bool Fail(const Block& b, const std::string& message) { return Fail(b.Name() + ": " + message); }

  bool ReadHeader(std::uint64_t at, std::initializer_list<std::string_view> types,
                  const std::string& via, Block* b);
  bool Link(const Block& from, std::uint64_t index, const char* field, std::uint64_t* link);
  bool Follow(const Block& from, std::uint64_t index, const char* field,
              std::initializer_list<std::string_view> types, Block* b);
  bool Need(const Block& b, std::uint64_t links, std::uint64_t data_bytes);
  bool Visit(const Block& from, const char* field, const Block& b);
  bool Text(const Block& from, std::uint64_t index, const char* field, std::string* text);
  bool ReadConversion(const Block& cn, Conversion* c, std::string* skip);
  bool ReadGroups(const Block& dg, int rec_id_size, std::vector<Group>* groups);
  bool ReadChannel(const Group& g, const Block& b, Channel* cn);
  bool CheckNumeric(const Group& g, Channel* cn);
  bool Inflate(const Block& dz, std::vector<unsigned char>* out);
  bool AppendBlock(const Block& b, std::vector<unsigned char>* out);
  bool ReadData(const Block& dg, std::vector<unsigned char>* owned,
                std::span<const unsigned char>* stream);
  bool SplitRecords(const Block& dg, int rec_id_size, std::span<const unsigned char> stream,
                    std::vector<Group>* groups);
  bool Decode(const Group& g, const Channel& cn, std::span<const unsigned char> stream,
              std::vector<double>* values);
  bool Emit(std::vector<Group>& groups, std::span<const unsigned char> stream);

  std::span<const unsigned char> bytes_;
  std::uint64_t size_;
  const std::string& source_;
  std::optional<Error> error_;
  int version_ = 0;
  std::set<std::uint64_t>
      visited_;  // chain and data blocks already read: a second visit is a cycle
  std::map<std::uint64_t, std::pair<Conversion, std::string>> conversions_;  // by CC offset
  std::uint64_t values_ = 0;  // decoded so far, against kMaxMdf4Values
  Mdf4File file_;
};

// The header of the block at `at`, which `via` ("CN block at 0x1a8: link 2 (name)") leads to.
bool Parser::ReadHeader(std::uint64_t at, std::initializer_list<std::string_view> types,
                        const std::string& via, Block* b) {
  const unsigned char* p = bytes_.data() + at;
  if (p[0] != '#' || p[1] != '#') {
    return Fail(via + ": no block starts at " + Hex(at) +
                fmt::format(" (it holds {:02x} {:02x} {:02x} {:02x})", p[0], p[1], p[2], p[3]));
  }
  b->at = at;
  b->type.assign(reinterpret_cast<const char*>(p) + 2, 2);
  if (std::find(types.begin(), types.end(), b->type) == types.end()) {
    std::string expected;
    for (std::string_view t : types) expected += (expected.empty() ? "" : " or ") + std::string(t);
    return Fail(via + ": " + Hex(at) + " holds a " + b->type + " block, not a " + expected +
                " block");
  }
  b->length = U64(at + 8);
  b->links = U64(at + 16);
  if (b->links > (size_ - at - kHeaderSize) / 8) {
    return Fail(
        *b, fmt::format("its {} links run past the end of the file (size {})", b->links, size_));
  }
  if (b->length < kHeaderSize + 8 * b->links) {
    return Fail(*b, fmt::format("length {} is shorter than its header and {} links ({} bytes)",
                                b->length, b->links, kHeaderSize + 8 * b->links));
  }
  if (b->length > size_ - at) {
    return Fail(*b,
                fmt::format("length {} runs past the end of the file (size {})", b->length, size_));
  }
  return true;
}

// Link `index` of `from`: 0, or the offset of a whole block header inside the file.
bool Parser::Link(const Block& from, std::uint64_t index, const char* field, std::uint64_t* link) {
  if (index >= from.links) {
    return Fail(from, fmt::format("it has {} links, so no link {} ({})", from.links, index, field));
  }
  *link = U64(from.at + kHeaderSize + 8 * index);
  const std::string what = fmt::format("link {} ({})", index, field);
  if (*link == 0) return true;
  if (*link < kIdSize)
    return Fail(from, what + " points into the identification block (" + Hex(*link) + ")");
  if (*link >= size_)
    return Fail(from, what + fmt::format(" points past the end of the file (size {})", size_));
  if (*link > size_ - kHeaderSize) {
    return Fail(from, what + fmt::format(" points to {}, too near the end of the file (size {}) "
                                         "for a block header",
                                         Hex(*link), size_));
  }
  return true;
}

// The block link `index` of `from` leads to, of one of `types`; b->at = 0 when the link is 0.
bool Parser::Follow(const Block& from, std::uint64_t index, const char* field,
                    std::initializer_list<std::string_view> types, Block* b) {
  std::uint64_t link = 0;
  if (!Link(from, index, field, &link)) return false;
  *b = Block{};
  if (link == 0) return true;
  return ReadHeader(link, types, fmt::format("{}: link {} ({})", from.Name(), index, field), b);
}

// At least `links` links and a data section of at least `data_bytes` bytes.
bool Parser::Need(const Block& b, std::uint64_t links, std::uint64_t data_bytes) {
  if (b.links < links)
    return Fail(b,
                fmt::format("it has {} links; a {} block has at least {}", b.links, b.type, links));
  const std::uint64_t need = kHeaderSize + 8 * b.links + data_bytes;
  if (data_bytes > b.length || b.length < need) {
    return Fail(b, fmt::format("length {} is shorter than its {} links and {} bytes of fields need "
                               "({})",
                               b.length, b.links, data_bytes, need));
  }
  return true;
}

// A chain (DG, CG, CN, DL) or data block may be read once: meeting it again is a cycle (or a
// block shared where the format has none, which would read the same data twice).
bool Parser::Visit(const Block& from, const char* field, const Block& b) {
  if (visited_.insert(b.at).second) return true;
  return Fail(from, std::string(field) + " leads back to " + b.Name() +
                        ", which was read already (a cycle)");
}

// ---------------------------------------------------------------------------------------------
// Texts

// The display text of an MD block's XML: the <TX> element's content when there is one, else the
// text outside the tags; the five predefined entities decoded.
std::string MdText(std::string_view xml) {
  if (const std::size_t open = xml.find("<TX>"); open != std::string_view::npos) {
    const std::size_t close = xml.find("</TX>", open);
    xml = xml.substr(open + 4,
                     close == std::string_view::npos ? std::string_view::npos : close - open - 4);
  }
  std::string out;
  bool in_tag = false;
  for (std::size_t i = 0; i < xml.size(); ++i) {
    const char c = xml[i];
    if (c == '<')
      in_tag = true;
    else if (c == '>')
      in_tag = false;
    else if (in_tag)
      continue;
    else if (c != '&')
      out += c;
    else {
      static constexpr std::pair<std::string_view, char> kEntities[] = {
          {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
      bool done = false;
      for (const auto& [name, ch] : kEntities) {
        if (xml.substr(i, name.size()) == name) {
          out += ch;
          i += name.size() - 1;
          done = true;
          break;
        }
      }
      if (!done) out += c;
    }
  }
  const std::size_t b = out.find_first_not_of(" \t\r\n");
  const std::size_t e = out.find_last_not_of(" \t\r\n");
  return b == std::string::npos ? "" : out.substr(b, e - b + 1);
}

// The text of the TX or MD block link `index` leads to ("" for a 0 link). A TX's text ends at
// its first NUL (or the block's end).
bool Parser::Text(const Block& from, std::uint64_t index, const char* field, std::string* text) {
  Block b;
  if (!Follow(from, index, field, {"TX", "MD"}, &b)) return false;
  text->clear();
  if (b.at == 0) return true;
  const auto* p = reinterpret_cast<const char*>(bytes_.data() + b.data());
  const std::string_view raw(p, b.end() - b.data());
  const std::string_view s = raw.substr(0, raw.find('\0'));
  *text = b.type == "MD" ? MdText(s) : std::string(s);
  return true;
}

// ---------------------------------------------------------------------------------------------
// Conversions

double Conversion::Apply(double x, bool integer_raw) const {
  if (std::isnan(x)) return x;
  switch (type) {
    case 1:
      return p[0] + p[1] * x;
    case 2: {
      const double den = (p[3] * x + p[4]) * x + p[5];
      return den == 0 ? kNaN : ((p[0] * x + p[1]) * x + p[2]) / den;
    }
    case 4:
    case 5: {  // pairs (key, value), keys strictly increasing (checked)
      const std::size_t n = p.size() / 2;
      if (x <= p[0]) return p[1];
      if (x >= p[2 * (n - 1)]) return p[2 * n - 1];
      std::size_t lo = 0, hi = n - 1;  // key[lo] < x < key[hi]
      while (hi - lo > 1) {
        const std::size_t mid = (lo + hi) / 2;
        (p[2 * mid] <= x ? lo : hi) = mid;
      }
      const double k0 = p[2 * lo], k1 = p[2 * hi], v0 = p[2 * lo + 1], v1 = p[2 * hi + 1];
      if (type == 4) return v0 + (v1 - v0) * (x - k0) / (k1 - k0);
      return x - k0 <= k1 - x ? v0 : v1;  // the lower key at the midpoint
    }
    case 6: {  // triples (min, max, value), then the default
      for (std::size_t i = 0; i + 3 < p.size(); i += 3) {
        if (p[i] <= x && (integer_raw ? x <= p[i + 1] : x < p[i + 1])) return p[i + 2];
      }
      return p.back();
    }
    default:
      return x;
  }
}

// The CC of channel `cn` (link 4), or identity. A conversion this reader does not compute sets
// *skip to the reason instead of failing: the channel is then not numeric.
bool Parser::ReadConversion(const Block& cn, Conversion* c, std::string* skip) {
  Block b;
  if (!Follow(cn, 4, "conversion", {"CC"}, &b)) return false;
  *c = Conversion{};
  skip->clear();
  if (b.at == 0) return true;
  if (const auto it = conversions_.find(b.at); it != conversions_.end()) {
    std::tie(*c, *skip) = it->second;
    return true;
  }
  if (!Need(b, 4, 24)) return false;
  const std::uint64_t d = b.data();
  c->type = U8(d);
  const std::uint16_t refs = U16(d + 4);
  const std::uint16_t n = U16(d + 6);
  if (refs != b.links - 4)
    return Fail(b, fmt::format("reference count {} disagrees with its {} links (4 + references)",
                               refs, b.links));
  if (b.length < kHeaderSize + 8 * b.links + 24 + 8 * std::uint64_t{n})
    return Fail(b, fmt::format("length {} is too short for its {} values", b.length, n));
  if (c->type > 11) return Fail(b, fmt::format("unknown conversion type {}", c->type));
  if (c->type == 3) {
    *skip = "its conversion (" + b.Name() + ") is algebraic (type 3), which is not supported";
  } else if (c->type >= 7) {
    *skip = "its conversion (" + b.Name() + fmt::format(", type {}) produces text", c->type);
  } else {
    const bool ok = c->type == 0   ? true
                    : c->type == 1 ? n == 2
                    : c->type == 2 ? n == 6
                    : c->type == 6 ? n % 3 == 1
                                   : n >= 2 && n % 2 == 0;  // 4, 5
    if (!ok) return Fail(b, fmt::format("a type {} conversion cannot have {} values", c->type, n));
    c->p.resize(c->type == 0 ? 0 : n);
    for (std::size_t i = 0; i < c->p.size(); ++i) {
      c->p[i] = F64(d + 24 + 8 * i);
      if (!std::isfinite(c->p[i])) return Fail(b, fmt::format("value {} is not finite", i));
    }
    if (c->type == 2 && c->p[3] == 0 && c->p[4] == 0 && c->p[5] == 0)
      return Fail(b,
                  "the rational conversion's denominator is identically zero (p3 = p4 = p5 = 0)");
    if (c->type == 4 || c->type == 5) {
      for (std::size_t i = 2; i < c->p.size(); i += 2) {
        if (!(c->p[i] > c->p[i - 2]))
          return Fail(b, fmt::format("the table's keys do not increase strictly at key {}", i / 2));
      }
    }
  }
  conversions_[b.at] = {*c, *skip};
  return true;
}

// ---------------------------------------------------------------------------------------------
// Structure

bool Parser::ReadChannel(const Group& g, const Block& b, Channel* cn) {
  cn->block = b;
  if (!Need(b, 8, 72)) return false;
  const std::uint64_t d = b.data();
  cn->type = U8(d);
  cn->sync = U8(d + 1);
  cn->data_type = U8(d + 2);
  cn->bit_offset = U8(d + 3);
  cn->byte_offset = U32(d + 4);
  cn->bit_count = U32(d + 8);
  cn->flags = U32(d + 12);
  cn->inval_pos = U32(d + 16);
  const std::uint64_t expected_links = 8 + U16(d + 22) + ((cn->flags >> 12) & 1) * 3;
  if (b.links != expected_links) {
    return Fail(b, fmt::format("it has {} links, but its attachment count and flags give {}",
                               b.links, expected_links));
  }
  std::uint64_t name_link = 0;
  if (!Link(b, 2, "name", &name_link)) return false;
  if (name_link == 0) return Fail(b, "link 2 (name) is 0: a channel must have a name");
  if (!Text(b, 2, "name", &cn->name) || !Text(b, 6, "unit", &cn->unit) ||
      !Text(b, 7, "comment", &cn->comment)) {
    return false;
  }
  const std::string who = b.Name() + " ('" + cn->name + "')";
  if (cn->type > 7) return Fail(who + fmt::format(": unknown channel type {}", cn->type));
  if (cn->sync > 4) return Fail(who + fmt::format(": unknown sync type {}", cn->sync));
  if (cn->data_type > 17) return Fail(who + fmt::format(": unknown data type {}", cn->data_type));
  if (cn->bit_offset > 7)
    return Fail(who + fmt::format(": bit offset {} is more than 7", cn->bit_offset));
  if ((cn->flags & 2) && !(cn->flags & 1) && cn->inval_pos / 8 >= g.inval_bytes) {
    return Fail(who + fmt::format(": invalidation bit {} lies beyond the record's {} invalidation "
                                  "bytes",
                                  cn->inval_pos, g.inval_bytes));
  }
  std::uint64_t composition = 0;
  if (!Link(b, 1, "composition", &composition)) return false;
  static constexpr const char* kTypeSkips[] = {
      "", "it is a variable-length (VLSD) channel", "",
      "", "it is a synchronisation channel",        "it is a maximum-length (MLSD) channel",
      "", "it is a VLSC channel (MDF 4.3)"};
  cn->skip = kTypeSkips[cn->type];
  if (cn->skip.empty() && composition != 0)
    cn->skip = "it is a structure or an array (composition)";
  if (cn->skip.empty() && !CheckNumeric(g, cn)) return false;
  if (cn->skip.empty() && !ReadConversion(b, &cn->conversion, &cn->skip)) return false;
  return true;
}

// The data type and placement of a channel that would be read as numbers.
bool Parser::CheckNumeric(const Group& g, Channel* cn) {
  static constexpr const char* kTypeNames[] = {"",
                                               "",
                                               "",
                                               "",
                                               "",
                                               "",
                                               "an ISO-8859-1 string",
                                               "a UTF-8 string",
                                               "a UTF-16 LE string",
                                               "a UTF-16 BE string",
                                               "a byte array",
                                               "a MIME sample",
                                               "a MIME stream",
                                               "a CANopen date",
                                               "a CANopen time",
                                               "a complex number",
                                               "a complex number",
                                               "a string with a byte order mark"};
  const std::string who = cn->block.Name() + " ('" + cn->name + "')";
  if (cn->data_type >= 6) {
    cn->skip = std::string("its data type is ") + kTypeNames[cn->data_type] + ", not a number";
    return true;
  }
  if (cn->Virtual()) return true;  // no bytes in the record
  const std::uint32_t bits = cn->bit_count;
  if (cn->data_type <= 3 && (bits == 0 || bits + static_cast<std::uint32_t>(cn->bit_offset) > 64)) {
    return Fail(who + fmt::format(": an integer of {} bits at bit offset {} (1 to 64 bits, "
                                  "offset + count at most 64)",
                                  bits, cn->bit_offset));
  }
  if (cn->data_type >= 4) {
    const bool half = bits == 16 && version_ >= 420;
    if (cn->bit_offset != 0 || (bits != 32 && bits != 64 && !half)) {
      return Fail(who + fmt::format(": a float of {} bits at bit offset {} (32 or 64 bits, 16 from "
                                    "MDF 4.20, at bit offset 0)",
                                    bits, cn->bit_offset));
    }
  }
  const std::uint64_t end = std::uint64_t{cn->byte_offset} + (cn->bit_offset + bits + 7) / 8;
  if (end > g.data_bytes) {
    return Fail(who + fmt::format(": its bytes {} to {} lie beyond the record's {} data bytes",
                                  cn->byte_offset, end - 1, g.data_bytes));
  }
  return true;
}

// The channel groups of a DG, each with its channels.
bool Parser::ReadGroups(const Block& dg, int rec_id_size, std::vector<Group>* groups) {
  Block cg;
  if (!Follow(dg, 1, "first channel group", {"CG"}, &cg)) return false;
  const Block* from = &dg;
  const char* field = "link 1 (first channel group)";
  while (cg.at != 0) {
    if (!Visit(*from, field, cg) || !Need(cg, 6, 32)) return false;
    Group& g = groups->emplace_back();
    g.block = cg;
    const std::uint64_t d = cg.data();
    g.record_id = U64(d);
    g.cycles = U64(d + 8);
    g.flags = U16(d + 16);
    g.data_bytes = U32(d + 24);
    g.inval_bytes = U32(d + 28);
    if (!Text(cg, 2, "acquisition name", &g.name)) return false;
    if (rec_id_size < 8 && g.record_id >> (8 * rec_id_size) != 0) {
      return Fail(cg, fmt::format("record ID {} does not fit in the DG's {}-byte record IDs",
                                  g.record_id, rec_id_size));
    }
    for (std::size_t i = 0; i + 1 < groups->size(); ++i) {
      if ((*groups)[i].record_id == g.record_id) {
        return Fail(cg, fmt::format("record ID {} is also that of {}", g.record_id,
                                    (*groups)[i].block.Name()));
      }
    }
    if (!g.Vlsd()) {  // a VLSD group's records feed a channel of another group: no channels
      Block cn;
      if (!Follow(cg, 1, "first channel", {"CN"}, &cn)) return false;
      const Block* cn_from = &cg;
      const char* cn_field = "link 1 (first channel)";
      while (cn.at != 0) {
        if (!Visit(*cn_from, cn_field, cn)) return false;
        Channel& c = g.channels.emplace_back();
        if (!ReadChannel(g, cn, &c)) return false;
        if (c.type == 2 || c.type == 3) {
          if (g.master >= 0) {
            return Fail(cg, "it has two master channels, '" + g.channels[g.master].name +
                                "' and '" + c.name + "' (" + cn.Name() + ")");
          }
          if (!c.skip.empty())
            return Fail(cn, "master channel '" + c.name + "' is not numeric: " + c.skip);
          g.master = static_cast<int>(g.channels.size()) - 1;
        }
        cn_from = &c.block;
        cn_field = "link 0 (next channel)";
        if (!Follow(c.block, 0, "next channel", {"CN"}, &cn)) return false;
      }
    }
    from = &g.block;
    field = "link 0 (next channel group)";
    if (!Follow(g.block, 0, "next channel group", {"CG"}, &cg)) return false;
  }
  if (groups->size() > 1 && rec_id_size == 0) {
    return Fail(dg, fmt::format("it has {} channel groups but no record IDs (record ID size 0)",
                                groups->size()));
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Data

// Appends the original bytes of DZ block `dz` to *out.
bool Parser::Inflate(const Block& dz, std::vector<unsigned char>* out) {
  if (!Need(dz, 0, 24)) return false;
  const std::uint64_t d = dz.data();
  const std::string org(reinterpret_cast<const char*>(bytes_.data() + d), 2);
  const int zip = U8(d + 2);
  const std::uint32_t columns = U32(d + 4);
  const std::uint64_t org_length = U64(d + 8);
  const std::uint64_t data_length = U64(d + 16);
  if (org != "DT")
    return Fail(dz, "it holds a compressed '" + org + "' block where a DT block belongs");
  if (zip > 1) {
    return Fail(dz,
                fmt::format("zip type {} is not supported (0 deflate, 1 transposition + deflate; "
                            "2-5 are MDF 4.3's)",
                            zip));
  }
  if (zip == 1 && columns == 0) return Fail(dz, "a transposition with 0 columns (zip parameter 0)");
  if (data_length > dz.end() - d - 24) {
    return Fail(dz, fmt::format("its {} compressed bytes run past the block's end (length {})",
                                data_length, dz.length));
  }
  if (org_length > kMaxInflateRatio * data_length + 64) {
    return Fail(dz, fmt::format("its declared original size {} is more than deflate can produce "
                                "from {} bytes",
                                org_length, data_length));
  }
  const std::size_t base = out->size();
  out->resize(base + org_length);
  z_stream z{};
  if (inflateInit(&z) != Z_OK) return Fail(dz, "zlib could not be initialised");
  const unsigned char* in = bytes_.data() + d + 24;
  std::uint64_t in_left = data_length, out_left = org_length;
  unsigned char* next_out = out->data() + base;
  unsigned char spare = 0;  // one byte past the declared size, to tell "more" from "exact"
  // Each Z_OK made progress; with nothing left to read or write inflate says Z_BUF_ERROR.
  int rc = Z_OK;
  while (rc == Z_OK) {
    const uInt in_chunk = static_cast<uInt>(std::min<std::uint64_t>(in_left, UINT_MAX));
    const uInt out_chunk = static_cast<uInt>(std::min<std::uint64_t>(out_left, UINT_MAX));
    z.next_in = const_cast<unsigned char*>(in);
    z.avail_in = in_chunk;
    z.next_out = out_left > 0 ? next_out : &spare;
    z.avail_out = out_left > 0 ? out_chunk : 1;
    rc = inflate(&z, Z_NO_FLUSH);
    const uInt used_in = in_chunk - z.avail_in;
    in += used_in;
    in_left -= used_in;
    if (out_left == 0) {
      if (z.avail_out == 0) {
        inflateEnd(&z);
        return Fail(dz, fmt::format("it inflates to more than its declared {} bytes", org_length));
      }
    } else {
      const uInt made = out_chunk - z.avail_out;
      next_out += made;
      out_left -= made;
    }
  }
  const std::string zmsg = z.msg ? z.msg : "";
  inflateEnd(&z);
  if (rc != Z_STREAM_END) {
    return Fail(dz, "its data does not inflate (" +
                        (rc == Z_OK || rc == Z_BUF_ERROR
                             ? std::string("the zlib stream is cut short")
                             : "zlib: " + (zmsg.empty() ? std::to_string(rc) : zmsg)) +
                        ")");
  }
  if (out_left != 0) {
    return Fail(dz, fmt::format("it inflates to {} bytes, not its declared {}",
                                org_length - out_left, org_length));
  }
  if (zip ==
      1) {  // column c of the first rows * C bytes holds byte c of every row; the rest is as is
    const std::uint64_t rows = org_length / columns;
    const std::vector<unsigned char> t(
        out->begin() + static_cast<std::ptrdiff_t>(base),
        out->begin() + static_cast<std::ptrdiff_t>(base + rows * columns));
    unsigned char* o = out->data() + base;
    for (std::uint64_t c = 0; c < columns; ++c)
      for (std::uint64_t r = 0; r < rows; ++r) o[r * columns + c] = t[c * rows + r];
  }
  return true;
}

// Appends the payload of a DT or DZ block to *out.
bool Parser::AppendBlock(const Block& b, std::vector<unsigned char>* out) {
  if (b.type == "DZ") return Inflate(b, out);
  out->insert(out->end(), bytes_.begin() + static_cast<std::ptrdiff_t>(b.data()),
              bytes_.begin() + static_cast<std::ptrdiff_t>(b.end()));
  return true;
}

// The DG's data section as one stream: a DT's payload in place, else the inflated and
// concatenated payloads in *owned. Records may cross block boundaries, so the blocks are joined
// before records are cut.
bool Parser::ReadData(const Block& dg, std::vector<unsigned char>* owned,
                      std::span<const unsigned char>* stream) {
  Block b;
  if (!Follow(dg, 2, "data", {"DT", "DZ", "DL", "HL", "LD"}, &b)) return false;
  *stream = {};
  if (b.at == 0) return true;
  if (b.type == "LD")
    return Fail(b, "column-oriented storage (MDF 4.2 LD blocks) is not supported");
  if (!Visit(dg, "link 2 (data)", b)) return false;
  if (b.type == "DT") {
    *stream = bytes_.subspan(b.data(), b.end() - b.data());
    return true;
  }
  if (b.type == "DZ") {
    if (!Inflate(b, owned)) return false;
    *stream = *owned;
    return true;
  }
  Block dl = b;
  if (b.type == "HL") {
    if (!Need(b, 1, 8) || !Follow(b, 0, "first data list", {"DL"}, &dl)) return false;
    if (dl.at != 0 && !Visit(b, "link 0 (first data list)", dl)) return false;
  }
  Block prev;
  while (dl.at != 0) {
    if (!Need(dl, 1, 8)) return false;
    const std::uint64_t d = dl.data();
    const bool equal = (U8(d) & 1) != 0;
    const std::uint64_t n = dl.links - 1;
    const std::uint32_t count = U32(d + 4);
    if (count != n)
      return Fail(dl, fmt::format("its count {} disagrees with its {} data links", count, n));
    if (!Need(dl, 1, equal ? 16 : 8 + 8 * n)) return false;
    const std::uint64_t equal_length = equal ? U64(d + 8) : 0;
    for (std::uint64_t i = 0; i < n; ++i) {
      const std::string what = fmt::format("data block {}", i);
      Block block;
      if (!Follow(dl, 1 + i, what.c_str(), {"DT", "DZ"}, &block)) return false;
      if (block.at == 0) return Fail(dl, fmt::format("link {} ({}) is 0", 1 + i, what));
      if (!Visit(dl, fmt::format("link {} ({})", 1 + i, what).c_str(), block)) return false;
      const std::uint64_t start = owned->size();
      if (!equal && U64(d + 8 + 8 * i) != start) {
        return Fail(dl, fmt::format("offset {} is {}, but the blocks before it hold {} bytes", i,
                                    U64(d + 8 + 8 * i), start));
      }
      if (!AppendBlock(block, owned)) return false;
      const std::uint64_t got = owned->size() - start;
      // Every block but the chain's last holds exactly equal_length bytes.
      const bool last = i + 1 == n && U64(dl.at + kHeaderSize) == 0;
      if (equal && (last ? got > equal_length : got != equal_length)) {
        return Fail(block,
                    fmt::format("it holds {} bytes, but its DL block at {} gives equal lengths "
                                "of {}",
                                got, Hex(dl.at), equal_length));
      }
    }
    prev = dl;
    if (!Follow(prev, 0, "next data list", {"DL"}, &dl)) return false;
    if (dl.at != 0 && !Visit(prev, "link 0 (next data list)", dl)) return false;
  }
  *stream = *owned;
  return true;
}

// ---------------------------------------------------------------------------------------------
// Records

// Where each group's records lie in the stream: at a fixed stride when the DG is sorted, else by
// reading the record IDs one record after another.
bool Parser::SplitRecords(const Block& dg, int rec_id_size, std::span<const unsigned char> stream,
                          std::vector<Group>* groups) {
  const std::uint64_t size = stream.size();
  const auto id_at = [&](std::uint64_t pos) {
    std::uint64_t v = 0;
    for (int i = rec_id_size - 1; i >= 0; --i)
      v = (v << 8) | stream[pos + static_cast<std::uint64_t>(i)];
    return v;
  };
  if (groups->size() == 1 && !groups->front().Vlsd()) {
    Group& g = groups->front();
    const std::uint64_t s = rec_id_size + std::uint64_t{g.data_bytes} + g.inval_bytes;
    if (s == 0 && g.cycles > 0) {
      return Fail(g.block, fmt::format("its records are 0 bytes long (no record ID, data or "
                                       "invalidation bytes), but its cycle count is {}",
                                       g.cycles));
    }
    if (s > 0 && (g.cycles > size / s || g.cycles * s != size)) {
      return Fail(g.block,
                  fmt::format("its cycle count {} needs {} bytes of {}-byte records, but "
                              "the data of {} holds {}",
                              g.cycles,
                              g.cycles > size / s ? std::string("more than ") + std::to_string(size)
                                                  : std::to_string(g.cycles * s),
                              s, dg.Name(), size));
    }
    g.first = static_cast<std::uint64_t>(rec_id_size);
    g.stride = s;
    for (std::uint64_t k = 0; rec_id_size > 0 && k < g.cycles; ++k) {
      if (id_at(k * s) != g.record_id) {
        return Fail(g.block, fmt::format("record {} has record ID {}, not the group's {}", k,
                                         id_at(k * s), g.record_id));
      }
    }
    return true;
  }
  // Unsorted (or a lone VLSD group): record ID, then the payload its group gives the length of.
  std::map<std::uint64_t, std::size_t> by_id;
  for (std::size_t i = 0; i < groups->size(); ++i) by_id[(*groups)[i].record_id] = i;
  std::vector<std::uint64_t> met(groups->size(), 0);
  std::uint64_t pos = 0;
  while (pos < size) {
    if (size - pos < static_cast<std::uint64_t>(rec_id_size))
      return Fail(dg, fmt::format("its data ends inside a record ID at byte {}", pos));
    const std::uint64_t id = id_at(pos);
    const auto it = by_id.find(id);
    if (it == by_id.end()) {
      return Fail(dg, fmt::format("the record at byte {} of its data has record ID {}, which none "
                                  "of its channel groups has",
                                  pos, id));
    }
    Group& g = (*groups)[it->second];
    std::uint64_t payload = std::uint64_t{g.data_bytes} + g.inval_bytes;
    const std::uint64_t left = size - pos - rec_id_size;
    if (g.Vlsd()) {  // [u32 length][length bytes]
      if (left < 4) {
        return Fail(g.block, fmt::format("its VLSD record at byte {} of the data is cut short "
                                         "before its length",
                                         pos));
      }
      std::uint64_t len = 0;
      for (int i = 3; i >= 0; --i)
        len = (len << 8) | stream[pos + rec_id_size + static_cast<std::uint64_t>(i)];
      payload = 4 + len;
    }
    if (payload > left) {
      return Fail(g.block, fmt::format("its record at byte {} of the data needs {} bytes after the "
                                       "record ID; {} are left",
                                       pos, payload, left));
    }
    if (!g.Vlsd()) g.at.push_back(pos + rec_id_size);
    ++met[it->second];
    pos += rec_id_size + payload;
  }
  for (std::size_t i = 0; i < groups->size(); ++i) {
    if (met[i] != (*groups)[i].cycles) {
      return Fail((*groups)[i].block, fmt::format("its cycle count is {}, but the data of {} holds "
                                                  "{} of its records",
                                                  (*groups)[i].cycles, dg.Name(), met[i]));
    }
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Values

// IEEE 754 binary16 (sign 1, exponent 5 with bias 15, mantissa 10) to double.
double HalfToDouble(std::uint64_t h) {
  const int sign = (h >> 15) & 1, exponent = (h >> 10) & 0x1f;
  const double mantissa = static_cast<double>(h & 0x3ff);
  double v = 0;
  if (exponent == 0)
    v = std::ldexp(mantissa, -24);  // zero and subnormals
  else if (exponent == 31)
    v = mantissa == 0 ? std::numeric_limits<double>::infinity() : kNaN;
  else
    v = std::ldexp(1024 + mantissa, exponent - 25);
  return sign ? -v : v;
}

// The raw value of a numeric, non-virtual channel in the record at `rec`.
double RawValue(const Channel& cn, const unsigned char* rec) {
  const unsigned n = (static_cast<unsigned>(cn.bit_offset) + cn.bit_count + 7) / 8;
  const unsigned char* p = rec + cn.byte_offset;
  const bool big = cn.data_type % 2 == 1;
  std::uint64_t v = 0;
  for (unsigned i = 0; i < n; ++i) v = big ? (v << 8) | p[i] : v | std::uint64_t{p[i]} << (8 * i);
  if (cn.data_type >= 4) {  // floats: bit offset 0, 16, 32 or 64 bits (checked)
    if (cn.bit_count == 16) return HalfToDouble(v);
    if (cn.bit_count == 32) return std::bit_cast<float>(static_cast<std::uint32_t>(v));
    return std::bit_cast<double>(v);
  }
  v >>= cn.bit_offset;
  const unsigned bits = cn.bit_count;
  if (bits < 64) v &= (std::uint64_t{1} << bits) - 1;
  if (cn.data_type >= 2 && bits < 64) {  // sign-extend from bit `bits - 1`
    const std::uint64_t sign = std::uint64_t{1} << (bits - 1);
    return static_cast<double>(static_cast<std::int64_t>((v ^ sign) - sign));
  }
  return cn.data_type >= 2 ? static_cast<double>(static_cast<std::int64_t>(v))
                           : static_cast<double>(v);
}

// One physical value per record of `g`: NaN where invalid, CC(k) for a virtual channel.
bool Parser::Decode(const Group& g, const Channel& cn, std::span<const unsigned char> stream,
                    std::vector<double>* values) {
  values_ += g.cycles;
  if (values_ > kMaxMdf4Values) {
    return Fail(cn.block, fmt::format("the file decodes to more than {} values, more than this "
                                      "reader holds",
                                      kMaxMdf4Values));
  }
  values->resize(g.cycles);
  const bool integer = cn.data_type <= 3;
  for (std::uint64_t k = 0; k < g.cycles; ++k) {
    const unsigned char* rec = stream.data() + g.Record(k);
    bool valid = (cn.flags & 1) == 0;
    if (valid && (cn.flags & 2) != 0)
      valid = ((rec[g.data_bytes + cn.inval_pos / 8] >> (cn.inval_pos % 8)) & 1) == 0;
    const double raw = cn.Virtual() ? static_cast<double>(k) : RawValue(cn, rec);
    (*values)[k] = valid ? cn.conversion.Apply(raw, integer || cn.Virtual()) : kNaN;
  }
  return true;
}

// The groups of one DG, decoded into file_.
bool Parser::Emit(std::vector<Group>& groups, std::span<const unsigned char> stream) {
  for (Group& g : groups) {
    if (g.Vlsd()) continue;
    Mdf4Group out;
    out.name = g.name;
    out.number = static_cast<int>(file_.groups.size()) + 1;
    const int index = static_cast<int>(file_.groups.size());
    if (g.master >= 0) {
      const Channel& m = g.channels[g.master];
      out.has_master = true;
      out.master_name = m.name;
      out.virtual_master = m.type == 3;
      out.master_sync = m.sync;
      if (!Decode(g, m, stream, &out.time)) return false;
    }
    for (std::size_t c = 0; c < g.channels.size(); ++c) {
      const Channel& cn = g.channels[c];
      if (static_cast<int>(c) == g.master) continue;
      if (!cn.skip.empty()) {
        file_.skipped.push_back({cn.name, index, cn.skip});
        continue;
      }
      Mdf4Channel ch{cn.name, cn.unit, cn.comment, index, {}};
      if (!Decode(g, cn, stream, &ch.values)) return false;
      out.channels.push_back(static_cast<int>(file_.channels.size()));
      file_.channels.push_back(std::move(ch));
    }
    file_.groups.push_back(std::move(out));
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// File

Result<Mdf4File> Parser::Run() {
  const std::string id = "identification block at 0x0";
  if (size_ < kIdSize) {
    Fail(
        fmt::format("{}: the file holds {} bytes, fewer than an MDF identification block (64): "
                    "not an MDF file",
                    id, size_));
    return *error_;
  }
  const std::string_view magic(reinterpret_cast<const char*>(bytes_.data()), 8);
  if (magic == "UnFinMF ") {
    Fail(id +
         ": the file is an unfinalized MDF file ('UnFinMF '), whose cycle counts and block "
         "lengths cannot be trusted; finalize it with the program that wrote it");
  } else if (magic != "MDF     ") {
    Fail(id + ": not an MDF file (it does not start with 'MDF     ')");
  } else if (version_ = U16(28); version_ < 400 || version_ >= 500) {
    Fail(id + fmt::format(": MDF version {} is not supported: only MDF 4 (400 to 499) is read{}",
                          version_, version_ < 400 ? " (MDF 3 has another layout)" : ""));
  }
  if (error_) return *error_;
  file_.version = version_;
  if (size_ < kIdSize + kHeaderSize) {
    Fail(id + fmt::format(": the file ends (size {}) before the HD block at 0x40", size_));
    return *error_;
  }
  Block hd;
  if (!ReadHeader(kIdSize, {"HD"}, id + ": the HD block that must follow it", &hd) ||
      !Need(hd, 6, 32))
    return *error_;
  Block dg;
  if (!Follow(hd, 0, "first data group", {"DG"}, &dg)) return *error_;
  const Block* from = &hd;
  std::string field = "link 0 (first data group)";
  Block prev;
  while (dg.at != 0) {
    if (!Visit(*from, field.c_str(), dg) || !Need(dg, 4, 8)) return *error_;
    const int rec_id_size = U8(dg.data());
    if (rec_id_size != 0 && rec_id_size != 1 && rec_id_size != 2 && rec_id_size != 4 &&
        rec_id_size != 8) {
      Fail(dg, fmt::format("record ID size {} is not 0, 1, 2, 4 or 8", rec_id_size));
      return *error_;
    }
    std::vector<Group> groups;
    std::vector<unsigned char> owned;
    std::span<const unsigned char> stream;
    if (!ReadGroups(dg, rec_id_size, &groups)) return *error_;
    if (!groups.empty()) {
      if (!ReadData(dg, &owned, &stream) || !SplitRecords(dg, rec_id_size, stream, &groups) ||
          !Emit(groups, stream)) {
        return *error_;
      }
    }
    prev = dg;
    from = &prev;
    field = "link 0 (next data group)";
    if (!Follow(prev, 0, "next data group", {"DG"}, &dg)) return *error_;
  }
  return std::move(file_);
}

}  // namespace

Result<Mdf4File> ParseMdf4(std::span<const unsigned char> bytes, const std::string& source) {
  return Parser(bytes, source).Run();
}

Result<Mdf4File> ReadMdf4File(const std::string& path) {
  const auto file_error = [&path](std::string message) {
    Error e = InputError(std::move(message));
    e.file = path;
    return e;
  };
  std::uintmax_t size = 0;
  if (const std::string why = WhyNotReadable(path, kMaxFileBytes, &size); !why.empty())
    return file_error(why);
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr)
    return file_error("cannot open the file: " + std::generic_category().message(errno));
  std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
  const std::size_t got = std::fread(bytes.data(), 1, bytes.size(), f);
  const bool failed = std::ferror(f) != 0;
  const int error = errno;
  std::fclose(f);
  if (failed) return file_error("cannot read the file: " + std::generic_category().message(error));
  bytes.resize(got);
  return ParseMdf4(bytes, path);
}

bool LooksLikeMdf(std::span<const unsigned char> head) {
  if (head.size() < 8) return false;
  const std::string_view magic(reinterpret_cast<const char*>(head.data()), 8);
  return magic == "MDF     " || magic == "UnFinMF ";
}

int Mdf4File::Find(std::string_view name) const {
  // Matches in the groups `in` accepts; -1 none, -2 several.
  const auto find = [this](std::string_view n, const auto& in) {
    int found = -1;
    for (std::size_t i = 0; i < channels.size(); ++i) {
      if (channels[i].name != n || !in(channels[i].group)) continue;
      if (found != -1) return -2;
      found = static_cast<int>(i);
    }
    return found;
  };
  const int exact = find(name, [](int) { return true; });
  const std::size_t at = name.rfind('@');
  if (exact != -1 || at == std::string_view::npos) return exact;
  const std::string_view g = name.substr(at + 1);
  const bool number =
      !g.empty() && g.size() < 10 && g.find_first_not_of("0123456789") == std::string_view::npos;
  return find(name.substr(0, at), [&](int group) {
    const Mdf4Group& grp = groups[static_cast<std::size_t>(group)];
    return number ? std::to_string(grp.number) == g : grp.name == g;
  });
}

// ---------------------------------------------------------------------------------------------
// Dataset

namespace {

std::string GroupLabel(const Mdf4Group& g) {
  return "group " + std::to_string(g.number) + (g.name.empty() ? "" : " ('" + g.name + "')");
}

// The file's channel names as Mdf4ToDataset accepts them, for a message (at most 40).
std::string ChannelList(const Mdf4File& file) {
  std::string out;
  for (std::size_t i = 0; i < file.channels.size(); ++i) {
    if (i == 40) return out + ", ...";
    const Mdf4Channel& c = file.channels[i];
    out += (i ? ", " : "") + c.name;
    if (file.Find(c.name) != static_cast<int>(i))
      out += "@" + std::to_string(file.groups[c.group].number);
  }
  return out.empty() ? "none" : out;
}

// Why `name` names no channel that can be read: absent, ambiguous or skipped.
std::string WhyNot(const Mdf4File& file, const std::string& name, int found) {
  if (found == -2) {
    std::string where;
    for (const Mdf4Channel& c : file.channels) {
      if (c.name != name && c.name + "@" + std::to_string(file.groups[c.group].number) != name)
        continue;
      where +=
          (where.empty() ? "" : ", ") + name + "@" + std::to_string(file.groups[c.group].number);
    }
    return "channel '" + name + "' is in several groups: write " +
           (where.empty() ? name + "@G" : where) + " (G: the group's number)";
  }
  for (const Mdf4Skipped& s : file.skipped) {
    if (s.name == name || s.name + "@" + std::to_string(file.groups[s.group].number) == name)
      return "channel '" + name + "' in " + GroupLabel(file.groups[s.group]) +
             " is not read: " + s.reason;
  }
  return "channel '" + name + "' is not in the file; its channels are " + ChannelList(file);
}

// The master of `g` is finite and strictly increasing.
std::string CheckMaster(const Mdf4Group& g) {
  for (std::size_t k = 0; k < g.time.size(); ++k) {
    const std::string where = GroupLabel(g) + ": master '" + g.master_name + "'";
    if (!std::isfinite(g.time[k])) return where + fmt::format(" is not finite at record {}", k);
    if (k > 0 && !(g.time[k] > g.time[k - 1])) {
      return where + fmt::format(" at record {} ({}) is not after record {} ({})", k, g.time[k],
                                 k - 1, g.time[k - 1]);
    }
  }
  return "";
}

// Channel values at the rows' times (mdf4.h: Mdf4Format::interpolation). Both time vectors
// increase, so one pass suffices.
std::vector<double> Resample(std::span<const double> t, std::span<const double> v,
                             std::span<const double> rows, Mdf4Format::Interpolation how) {
  std::vector<double> out(rows.size(), kNaN);
  std::size_t j = 0;  // samples at or before the row
  for (std::size_t r = 0; r < rows.size(); ++r) {
    while (j < t.size() && t[j] <= rows[r]) ++j;
    if (j == 0) continue;
    const std::size_t i = j - 1;
    if (how == Mdf4Format::Interpolation::kHold || t[i] == rows[r])
      out[r] = v[i];
    else if (j < t.size())
      out[r] = v[i] + (v[j] - v[i]) * (rows[r] - t[i]) / (t[j] - t[i]);
  }
  return out;
}

}  // namespace

Result<std::shared_ptr<const Dataset>> Mdf4ToDataset(const Mdf4File& file,
                                                     const std::string& source,
                                                     const Mdf4Format& format) {
  const auto fail = [&source](std::string message) {
    Error e = InputError(std::move(message));
    e.file = source;
    return e;
  };
  // The channels and their column names.
  std::vector<std::pair<int, std::string>> chosen;
  if (format.channels.empty()) {
    std::map<std::string_view, int> count;
    for (const Mdf4Channel& c : file.channels) ++count[c.name];
    for (std::size_t i = 0; i < file.channels.size(); ++i) {
      const Mdf4Channel& c = file.channels[i];
      const Mdf4Group& g = file.groups[static_cast<std::size_t>(c.group)];
      if (!g.has_master) continue;
      const bool unique = count[c.name] == 1;
      chosen.emplace_back(static_cast<int>(i),
                          unique ? c.name : c.name + "@" + std::to_string(g.number));
    }
  }
  for (const std::string& name : format.channels) {
    const int i = file.Find(name);
    if (i < 0) return fail(WhyNot(file, name, i));
    const Mdf4Group& g = file.groups[static_cast<std::size_t>(file.channels[i].group)];
    if (!g.has_master) {
      return fail("channel '" + name + "' is in " + GroupLabel(g) +
                  ", which has no master channel: its samples have no times");
    }
    chosen.emplace_back(i, name);
  }
  // The time base.
  int base = -1;
  if (!format.time_base.empty()) {
    const std::string& b = format.time_base;
    for (std::size_t g = 0; g < file.groups.size() && base < 0; ++g) {
      if (std::to_string(file.groups[g].number) == b) base = static_cast<int>(g);
    }
    for (std::size_t g = 0; g < file.groups.size() && base < 0; ++g) {
      if (file.groups[g].name == b) base = static_cast<int>(g);
    }
    if (base < 0) {
      const int c = file.Find(b);
      if (c == -2) return fail("time base: " + WhyNot(file, b, c));
      if (c >= 0) base = file.channels[static_cast<std::size_t>(c)].group;
      for (std::size_t g = 0; g < file.groups.size() && base < 0; ++g) {
        if (file.groups[g].has_master && file.groups[g].master_name == b)
          base = static_cast<int>(g);
      }
    }
    if (base < 0) {
      return fail("time base '" + b + "' is neither a group (its number 1 to " +
                  std::to_string(file.groups.size()) + ", or its name) nor a channel");
    }
    if (!file.groups[static_cast<std::size_t>(base)].has_master)
      return fail("time base " + GroupLabel(file.groups[static_cast<std::size_t>(base)]) +
                  " has no master channel");
  } else {
    std::size_t most = 0;  // records of the base
    for (const auto& [c, name] : chosen) {
      const int g = file.channels[static_cast<std::size_t>(c)].group;
      const std::size_t n = file.groups[static_cast<std::size_t>(g)].time.size();
      if (base < 0 || n > most || (n == most && g < base)) {
        base = g;
        most = n;
      }
    }
  }
  // The masters used: one kind, each finite and strictly increasing.
  std::vector<int> used;
  if (base >= 0) used.push_back(base);
  for (const auto& [c, name] : chosen)
    used.push_back(file.channels[static_cast<std::size_t>(c)].group);
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  for (int g : used) {
    const Mdf4Group& group = file.groups[static_cast<std::size_t>(g)];
    if (group.master_sync != file.groups[static_cast<std::size_t>(used.front())].master_sync) {
      return fail(GroupLabel(group) + " and " +
                  GroupLabel(file.groups[static_cast<std::size_t>(used.front())]) +
                  " have masters of different kinds (sync types " +
                  std::to_string(group.master_sync) + " and " +
                  std::to_string(file.groups[static_cast<std::size_t>(used.front())].master_sync) +
                  "): they share no time base");
    }
    if (const std::string why = CheckMaster(group); !why.empty()) return fail(why);
  }

  auto d = std::make_shared<Dataset>();
  d->source = source;
  d->time_name = "t";
  std::vector<double> rows;
  if (format.sample_time > 0 && !used.empty()) {
    if (!std::isfinite(format.sample_time)) return fail("the sample time is not finite");
    double t0 = -std::numeric_limits<double>::infinity(),
           t1 = std::numeric_limits<double>::infinity();
    bool any_empty = false;  // a group without records: no common span
    for (int g : used) {
      const std::vector<double>& t = file.groups[static_cast<std::size_t>(g)].time;
      any_empty = any_empty || t.empty();
      if (t.empty()) continue;
      t0 = std::max(t0, t.front());
      t1 = std::min(t1, t.back());
    }
    if (!any_empty && t1 >= t0) {
      const double n = std::floor((t1 - t0) / format.sample_time * (1 + 1e-12)) + 1;
      if (n > kMaxGridRows) {
        return fail(fmt::format("a sample time of {} s makes {} rows from {} to {}, more than {}",
                                format.sample_time, n, t0, t1, kMaxGridRows));
      }
      for (std::size_t k = 0; k < static_cast<std::size_t>(n); ++k) {
        const double t = t0 + static_cast<double>(k) * format.sample_time;
        if (!rows.empty() && !(t > rows.back()))
          return fail(fmt::format("a sample time of {} s is too small to step from t = {}",
                                  format.sample_time, t0));
        rows.push_back(t);
      }
    }
  } else if (base >= 0) {
    rows = file.groups[static_cast<std::size_t>(base)].time;
  }
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (format.range && !((*format.range)[0] <= rows[k] && rows[k] <= (*format.range)[1])) continue;
    d->time.push_back(rows[k]);
    d->row_line.push_back(static_cast<int>(std::min<std::size_t>(k + 1, INT_MAX)));
  }
  for (std::size_t i = 0; i < chosen.size(); ++i) {
    const Mdf4Channel& c = file.channels[static_cast<std::size_t>(chosen[i].first)];
    Column col;
    col.name = chosen[i].second;
    col.field = static_cast<int>(i) + 1;
    col.values = Resample(file.groups[static_cast<std::size_t>(c.group)].time, c.values, d->time,
                          format.interpolation);
    for (std::size_t k = 0; k < col.values.size(); ++k) {
      if (!std::isnan(col.values[k])) continue;
      if (col.n_missing++ == 0) col.first_missing_line = d->row_line[k];
    }
    d->columns.push_back(std::move(col));
  }
  return std::shared_ptr<const Dataset>(std::move(d));
}

}  // namespace gb::data
