// The test writer of MDF 4.10 files (mdf4_writer.h). Blocks are written children first, so that
// every link is known when its block is written; only the HD at offset 64 is filled in last.
#include "tests/core/mdf4_writer.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <fstream>
#include <numeric>

#include <zlib.h>

namespace gb::data::mdf4_testing {
namespace {

// A byte buffer written little-endian.
struct Out {
  std::vector<unsigned char> b;
  // n bytes of v (n > 8: zeros after v's 8 bytes, for reserved fields).
  void U(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) b.push_back(i < 8 ? static_cast<unsigned char>(v >> (8 * i)) : 0);
  }
  void F(double v) { U(std::bit_cast<std::uint64_t>(v), 8); }
  void S(std::string_view s) { b.insert(b.end(), s.begin(), s.end()); }
};

class FileOut {
 public:
  FileOut() { out_.b.resize(64 + 104); }  // ID, then the HD filled in last
  // Writes a block at the next 8-byte boundary and returns its offset.
  std::uint64_t Block(std::string_view type, const std::vector<std::uint64_t>& links,
                      const std::vector<unsigned char>& data) {
    out_.b.resize((out_.b.size() + 7) / 8 * 8);
    const std::uint64_t at = out_.b.size();
    out_.S("##");
    out_.S(type);
    out_.U(0, 4);
    out_.U(24 + 8 * links.size() + data.size(), 8);
    out_.U(links.size(), 8);
    for (std::uint64_t l : links) out_.U(l, 8);
    out_.b.insert(out_.b.end(), data.begin(), data.end());
    return at;
  }
  std::uint64_t Text(std::string_view s, std::string_view type = "TX") {
    Out d;
    d.S(s);
    d.U(0, 1);
    d.b.resize((d.b.size() + 7) / 8 * 8);
    return Block(type, {}, d.b);
  }
  std::vector<unsigned char>& bytes() { return out_.b; }

 private:
  Out out_;
};

std::vector<unsigned char> Deflate(const std::vector<unsigned char>& in) {
  uLongf n = compressBound(static_cast<uLong>(in.size()));
  std::vector<unsigned char> out(n);
  const int rc = compress2(out.data(), &n, in.data(), static_cast<uLong>(in.size()), 9);
  assert(rc == Z_OK);
  (void)rc;
  out.resize(n);
  return out;
}

std::uint64_t Dz(FileOut& f, const std::vector<unsigned char>& data, std::uint32_t columns) {
  std::vector<unsigned char> in = data;
  if (columns > 0) {  // byte c of row r goes to c * rows + r; the last n mod C bytes stay
    const std::size_t rows = data.size() / columns;
    for (std::size_t r = 0; r < rows; ++r)
      for (std::size_t c = 0; c < columns; ++c) in[c * rows + r] = data[r * columns + c];
  }
  const std::vector<unsigned char> z = Deflate(in);
  Out d;
  d.S("DT");
  d.U(columns > 0 ? 1 : 0, 1);
  d.U(0, 1);
  d.U(columns, 4);
  d.U(data.size(), 8);
  d.U(z.size(), 8);
  d.b.insert(d.b.end(), z.begin(), z.end());
  return f.Block("DZ", {}, d.b);
}

// The bytes a channel takes in the record, from its byte offset.
int Bytes(const WChannel& c) { return (c.bit_offset + c.bit_count + 7) / 8; }
bool Virtual(const WChannel& c) { return c.cn_type == 3 || c.cn_type == 6; }

// Byte offsets resolved, record sizes computed.
struct Layout {
  std::vector<int> byte_offset;
  int data_bytes = 0, inval_bytes = 0;
};

Layout Lay(const WGroup& g) {
  Layout l;
  int cursor = 0;
  for (const WChannel& c : g.channels) {
    const int at = c.byte_offset >= 0 ? c.byte_offset : cursor;
    l.byte_offset.push_back(at);
    if (!Virtual(c)) cursor = std::max(cursor, at + Bytes(c));
    if (c.inval_bit >= 0) l.inval_bytes = std::max(l.inval_bytes, c.inval_bit / 8 + 1);
  }
  l.data_bytes = g.data_bytes >= 0 ? g.data_bytes : cursor;
  if (g.inval_bytes >= 0) l.inval_bytes = g.inval_bytes;
  return l;
}

// Record k of g without its record ID.
std::vector<unsigned char> Record(const WGroup& g, const Layout& l, std::size_t k) {
  std::vector<unsigned char> r(static_cast<std::size_t>(l.data_bytes + l.inval_bytes), 0);
  for (std::size_t i = 0; i < g.channels.size(); ++i) {
    const WChannel& c = g.channels[i];
    if (c.inval_bit >= 0 && k < c.invalid.size() && c.invalid[k])
      r[static_cast<std::size_t>(l.data_bytes + c.inval_bit / 8)] |=
          static_cast<unsigned char>(1 << (c.inval_bit % 8));
    if (Virtual(c) || k >= c.raw.size()) continue;
    const std::uint64_t mask =
        c.bit_count >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << c.bit_count) - 1;
    const std::uint64_t v = (c.raw[k] & mask) << c.bit_offset;
    const int n = Bytes(c);
    const bool big = c.data_type == kUintBe || c.data_type == kIntBe || c.data_type == kFloatBe;
    for (int j = 0; j < n; ++j) {
      const int shift = 8 * (big ? n - 1 - j : j);
      r[static_cast<std::size_t>(l.byte_offset[i] + j)] |= static_cast<unsigned char>(v >> shift);
    }
  }
  return r;
}

// When record k of g happened, to interleave an unsorted DG's records.
double When(const WGroup& g, std::size_t k) {
  for (const WChannel& c : g.channels) {
    if (c.cn_type == 2 && c.data_type == kFloatLe && c.bit_count == 64 && k < c.raw.size())
      return std::bit_cast<double>(c.raw[k]);
    if (c.cn_type == 3 && c.conversion.type == 1) return c.conversion.p[0] + c.conversion.p[1] * k;
  }
  return static_cast<double>(k);
}

std::uint64_t WriteChannel(FileOut& f, const WChannel& c, int byte_offset, std::uint64_t next,
                           Written* w) {
  const std::uint64_t name = f.Text(c.name);
  const std::uint64_t unit = c.unit.empty() ? 0 : f.Text(c.unit);
  std::uint64_t cc = 0;
  if (c.conversion.type >= 0) {
    Out d;
    d.U(c.conversion.type, 1);
    d.U(0, 1);
    d.U(0, 2);
    d.U(0, 2);
    d.U(c.conversion.p.size(), 2);
    d.F(0);
    d.F(0);
    for (double p : c.conversion.p) d.F(p);
    cc = f.Block("CC", {0, 0, 0, 0}, d.b);
    w->blocks.emplace("CC:" + c.name, cc);
  }
  Out d;
  d.U(c.cn_type, 1);
  d.U(c.sync, 1);
  d.U(c.data_type, 1);
  d.U(c.bit_offset, 1);
  d.U(static_cast<std::uint64_t>(byte_offset), 4);
  d.U(static_cast<std::uint64_t>(c.bit_count), 4);
  d.U(c.flags | (c.inval_bit >= 0 ? 2u : 0u), 4);
  d.U(c.inval_bit >= 0 ? static_cast<std::uint64_t>(c.inval_bit) : 0, 4);
  d.U(0, 1);
  d.U(0, 1);
  d.U(0, 2);
  for (int i = 0; i < 6; ++i) d.F(0);
  const std::uint64_t at = f.Block("CN", {next, 0, name, 0, cc, 0, unit, 0}, d.b);
  w->blocks.emplace("CN:" + c.name, at);
  w->blocks.emplace("TX:" + c.name, name);
  return at;
}

// The data blocks of one DG's stream; returns what the DG's data link points to.
std::uint64_t WriteData(FileOut& f, const WDataGroup& dg, const std::vector<unsigned char>& stream,
                        std::uint32_t record_size, int index, Written* w) {
  const std::string n = std::to_string(index);
  switch (dg.storage) {
    case Storage::kDt:
      return f.Block("DT", {}, stream);
    case Storage::kDz:
      return Dz(f, stream, 0);
    case Storage::kDzTransposed:
      return Dz(f, stream, record_size);
    default:
      break;
  }
  // Pieces cut at arbitrary bytes (not record boundaries): equal ones, else growing ones.
  const std::size_t k = static_cast<std::size_t>(dg.blocks);
  const bool equal = dg.storage == Storage::kDlEqual;
  const std::size_t piece = (stream.size() + k - 1) / k;
  std::vector<std::size_t> cuts = {0};
  for (std::size_t i = 1; i < k; ++i)
    cuts.push_back(equal ? std::min(stream.size(), i * piece) : stream.size() * i * i / (k * k));
  cuts.push_back(stream.size());
  std::vector<std::uint64_t> links = {0};
  for (std::size_t i = 0; i < k; ++i) {
    const std::vector<unsigned char> part(
        stream.begin() + static_cast<std::ptrdiff_t>(cuts[i]),
        stream.begin() + static_cast<std::ptrdiff_t>(cuts[i + 1]));
    const bool zipped = dg.storage == Storage::kHlDz;
    links.push_back(zipped ? Dz(f, part, 0) : f.Block("DT", {}, part));
    w->blocks[(zipped ? "DZ" : "DT") + n + "." + std::to_string(i)] = links.back();
  }
  Out d;
  d.U(equal ? 1 : 0, 1);
  d.U(0, 3);
  d.U(k, 4);
  if (equal)
    d.U(piece, 8);
  else
    for (std::size_t i = 0; i < k; ++i) d.U(cuts[i], 8);
  const std::uint64_t dl = f.Block("DL", links, d.b);
  w->blocks["DL" + n] = dl;
  if (dg.storage != Storage::kHlDz) return dl;
  Out h;
  h.U(0, 2);  // hl_flags: the DL has offsets, not equal lengths
  h.U(0, 1);  // the DZs' zip type: deflate
  h.U(0, 5);
  const std::uint64_t hl = f.Block("HL", {dl}, h.b);
  w->blocks["HL" + n] = hl;
  return hl;
}

}  // namespace

WChannel TimeMaster(const std::vector<double>& seconds, std::string name) {
  WChannel c = Float64(std::move(name), seconds);
  c.cn_type = 2;
  c.sync = 1;
  c.unit = "s";
  return c;
}

WChannel VirtualMaster(double period, std::string name) {
  WChannel c;
  c.name = std::move(name);
  c.unit = "s";
  c.cn_type = 3;
  c.sync = 1;
  c.data_type = kUintLe;
  c.bit_count = 0;
  c.conversion = {1, {0, period}};
  return c;
}

WChannel Float64(std::string name, const std::vector<double>& values, bool big_endian) {
  WChannel c;
  c.name = std::move(name);
  c.data_type = big_endian ? kFloatBe : kFloatLe;
  for (double v : values) c.raw.push_back(std::bit_cast<std::uint64_t>(v));
  return c;
}

WChannel Float32(std::string name, const std::vector<float>& values, bool big_endian) {
  WChannel c;
  c.name = std::move(name);
  c.data_type = big_endian ? kFloatBe : kFloatLe;
  c.bit_count = 32;
  for (float v : values) c.raw.push_back(std::bit_cast<std::uint32_t>(v));
  return c;
}

WChannel Integer(std::string name, int data_type, int bit_count, int bit_offset,
                 const std::vector<std::int64_t>& values) {
  WChannel c;
  c.name = std::move(name);
  c.data_type = data_type;
  c.bit_count = bit_count;
  c.bit_offset = bit_offset;
  for (std::int64_t v : values) c.raw.push_back(static_cast<std::uint64_t>(v));
  return c;
}

Written WriteMdf4(const WFile& file) {
  Written w;
  FileOut f;
  std::vector<std::uint64_t> dgs;
  for (std::size_t d = 0; d < file.data_groups.size(); ++d) {
    const WDataGroup& dg = file.data_groups[d];
    const std::string dn = std::to_string(d + 1);
    const bool unsorted = dg.groups.size() > 1;
    const int rid = dg.rec_id_size >= 0 ? dg.rec_id_size : unsorted ? 1 : 0;
    // The CGs from the last, so that each knows its next.
    std::vector<Layout> layouts;
    for (const WGroup& g : dg.groups) layouts.push_back(Lay(g));
    std::uint64_t next_cg = 0;
    for (std::size_t i = dg.groups.size(); i-- > 0;) {
      const WGroup& g = dg.groups[i];
      std::uint64_t next_cn = 0;
      for (std::size_t c = g.channels.size(); c-- > 0;)
        next_cn = WriteChannel(f, g.channels[c], layouts[i].byte_offset[c], next_cn, &w);
      const std::uint64_t name = g.name.empty() ? 0 : f.Text(g.name);
      const bool vlsd = !g.vlsd_items.empty();
      std::uint64_t vlsd_bytes = 0;
      for (const std::string& s : g.vlsd_items) vlsd_bytes += 4 + s.size();
      Out o;
      o.U(g.record_id != 0 || !unsorted ? g.record_id : i + 1, 8);
      o.U(vlsd ? g.vlsd_items.size() : g.records, 8);
      o.U(vlsd ? 1 : 0, 2);
      o.U(0, 2);
      o.U(0, 4);
      o.U(vlsd ? vlsd_bytes & 0xffffffff : static_cast<std::uint64_t>(layouts[i].data_bytes), 4);
      o.U(vlsd ? vlsd_bytes >> 32 : static_cast<std::uint64_t>(layouts[i].inval_bytes), 4);
      next_cg = f.Block("CG", {next_cg, next_cn, name, 0, 0, 0}, o.b);
      w.blocks["CG" + dn + "." + std::to_string(i + 1)] = next_cg;
    }
    // The records: a sorted DG's in order; an unsorted one's VLSD items first, then the others
    // by time (a stable merge: ties in group order).
    struct Ref {
      double t;
      std::size_t g, k;
    };
    std::vector<Ref> order;
    for (std::size_t i = 0; i < dg.groups.size(); ++i) {
      const WGroup& g = dg.groups[i];
      const std::size_t n = g.vlsd_items.empty() ? g.records : g.vlsd_items.size();
      for (std::size_t k = 0; k < n; ++k)
        order.push_back({g.vlsd_items.empty() ? When(g, k) : -INFINITY, i, k});
    }
    std::stable_sort(order.begin(), order.end(),
                     [](const Ref& a, const Ref& b) { return a.t < b.t; });
    std::vector<unsigned char> stream;
    for (const Ref& r : order) {
      const WGroup& g = dg.groups[r.g];
      Out o;
      o.U(g.record_id != 0 || !unsorted ? g.record_id : r.g + 1, rid);
      if (!g.vlsd_items.empty()) {
        o.U(g.vlsd_items[r.k].size(), 4);
        o.S(g.vlsd_items[r.k]);
      } else {
        const std::vector<unsigned char> rec = Record(g, layouts[r.g], r.k);
        o.b.insert(o.b.end(), rec.begin(), rec.end());
      }
      stream.insert(stream.end(), o.b.begin(), o.b.end());
    }
    const std::uint32_t record_size =
        dg.groups.empty()
            ? 1
            : static_cast<std::uint32_t>(rid + layouts[0].data_bytes + layouts[0].inval_bytes);
    const std::uint64_t data =
        stream.empty() && dg.groups.empty()
            ? 0
            : WriteData(f, dg, stream, std::max<std::uint32_t>(record_size, 1),
                        static_cast<int>(d + 1), &w);
    w.blocks["DATA" + dn] = data;
    Out o;
    o.U(static_cast<std::uint64_t>(rid), 1);
    o.U(0, 7);
    dgs.push_back(f.Block("DG", {0, next_cg, data, 0}, o.b));
    w.blocks["DG" + dn] = dgs.back();
  }
  // The DG chain: each DG's next link (the blocks are already written).
  std::vector<unsigned char>& b = f.bytes();
  for (std::size_t d = 0; d + 1 < dgs.size(); ++d) Put(b, dgs[d] + 24, dgs[d + 1], 8);
  const std::uint64_t fh_comment = f.Text(
      "<FHcomment><TX>written by greybench's tests</TX><tool_id>greybench</tool_id>"
      "<tool_vendor>greybench</tool_vendor><tool_version>0</tool_version></FHcomment>",
      "MD");
  Out fh;
  fh.U(0, 8);
  fh.U(0, 8);
  const std::uint64_t fh_at = f.Block("FH", {0, fh_comment}, fh.b);
  // ID and HD.
  Out id;
  id.S("MDF     ");
  id.S(file.version == 400 ? "4.00    " : file.version == 420 ? "4.20    " : "4.10    ");
  id.S("greybnch");
  id.U(0, 4);
  id.U(static_cast<std::uint64_t>(file.version), 2);
  id.U(0, 34);
  Out hd;
  hd.S("##HD");
  hd.U(0, 4);
  hd.U(104, 8);
  hd.U(6, 8);
  hd.U(dgs.empty() ? 0 : dgs.front(), 8);
  hd.U(fh_at, 8);
  hd.U(0, 8 * 4);
  hd.U(0, 32);
  b.resize((b.size() + 7) / 8 * 8);
  std::copy(id.b.begin(), id.b.end(), b.begin());
  std::copy(hd.b.begin(), hd.b.end(), b.begin() + 64);
  w.blocks["HD"] = 64;
  w.bytes = std::move(b);
  return w;
}

void WriteBytes(const std::string& path, const std::vector<unsigned char>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
}

void Put(std::vector<unsigned char>& bytes, std::uint64_t at, std::uint64_t value, int size) {
  for (int i = 0; i < size; ++i)
    bytes.at(at + static_cast<std::uint64_t>(i)) = static_cast<unsigned char>(value >> (8 * i));
}

}  // namespace gb::data::mdf4_testing
