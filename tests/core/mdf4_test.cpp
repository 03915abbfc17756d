// Tests of core/data/mdf4.cpp: files written by the test writer (tests/core/mdf4_writer.h) read
// back to the numbers written, in every storage form; bit layouts and conversions against hand
// computations; the time base against closed forms; each malformed file refused with a message
// naming the file and the block. The fixture files in tests/data/mdf4/ are the writer's output,
// checked once with mdflib's mdfdump, an independent reader (tests/data/mdf4/README.md records
// what it printed); the tests here read them and check their values.
//
// Contents
//   Helpers
//   Values       the two-rate file against its CSV, storage forms, integers, floats, conversions,
//                virtual channels, invalidation bits
//   Time base    hold, linear, range, sample time, names
//   Files        fixtures, ReadMdf4File, LooksLikeMdf
//   Malformed    refusals
#include "core/data/mdf4.h"

#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "tests/core/mdf4_writer.h"

namespace gb::data::mdf4_test {
namespace {

using namespace gb::data::mdf4_testing;  // NOLINT: the writer's vocabulary

// ---------------------------------------------------------------------------------------------
// Helpers

constexpr int kFast = 50, kSlow = 5;

double FastTime(int k) { return k / 100.0; }
double SlowTime(int k) { return k / 10.0; }
std::int64_t SpeedRaw(int k) { return (k * 1237) % 65536; }
double Speed(int k) { return -10 + 0.5 * static_cast<double>(SpeedRaw(k)); }  // linear CC
float Temp(int k) { return 20.0f + 0.25f * static_cast<float>(k); }
double Pressure(int k) { return 1000 + 1.5 * k; }

// The 100 Hz group (float64 time, uint16 with a linear conversion, float32) and the 10 Hz group
// (a big-endian float64), with `fast` and `slow` records.
std::vector<WGroup> TwoRateGroups(int fast = kFast, int slow = kSlow) {
  WGroup f = Group("fast", static_cast<std::size_t>(fast), {});
  std::vector<double> t;
  std::vector<std::int64_t> speed;
  std::vector<float> temp;
  for (int k = 0; k < fast; ++k) {
    t.push_back(FastTime(k));
    speed.push_back(SpeedRaw(k));
    temp.push_back(Temp(k));
  }
  f.channels = {TimeMaster(t), Integer("speed", kUintLe, 16, 0, speed), Float32("temp", temp)};
  f.channels[1].unit = "km/h";
  f.channels[1].conversion = {1, {-10, 0.5}};
  f.channels[2].unit = "degC";
  WGroup s = Group("slow", static_cast<std::size_t>(slow), {});
  std::vector<double> ts, p;
  for (int k = 0; k < slow; ++k) {
    ts.push_back(SlowTime(k));
    p.push_back(Pressure(k));
  }
  s.channels = {TimeMaster(ts), Float64("pressure", p, /*big_endian=*/true)};
  s.channels[1].unit = "hPa";
  return {f, s};
}

WFile TwoRates(Storage storage, bool unsorted, int fast = kFast, int slow = kSlow) {
  const std::vector<WGroup> g = TwoRateGroups(fast, slow);
  WFile file;
  if (unsorted) {
    file.data_groups = {{g, 1, storage}};
  } else {
    file.data_groups = {{{g[0]}, -1, storage}, {{g[1]}, -1, storage}};
  }
  return file;
}

Mdf4File Read(const std::vector<unsigned char>& bytes) {
  Result<Mdf4File> r = ParseMdf4(bytes, "run.mf4");
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().ToString());
  return r.ok() ? std::move(r).value() : Mdf4File{};
}

Mdf4File Read(const WFile& file) { return Read(WriteMdf4(file).bytes); }

const std::vector<double>& Values(const Mdf4File& f, std::string_view name) {
  static const std::vector<double> kNone;
  const int i = f.Find(name);
  EXPECT_GE(i, 0) << name;
  return i >= 0 ? f.channels[static_cast<std::size_t>(i)].values : kNone;
}

std::shared_ptr<const Dataset> ToDataset(const Mdf4File& f, const Mdf4Format& format) {
  Result<std::shared_ptr<const Dataset>> r = Mdf4ToDataset(f, "run.mf4", format);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().ToString());
  return r.ok() ? *r : std::make_shared<const Dataset>();
}

const std::vector<double>& Column(const Dataset& d, std::string_view name) {
  static const std::vector<double> kNone;
  const int i = d.Find(name);
  EXPECT_GE(i, 0) << name;
  return i >= 0 ? d.columns[static_cast<std::size_t>(i)].values : kNone;
}

// Equal bit for bit, NaN equal to NaN.
void ExpectSame(const std::vector<double>& a, const std::vector<double>& b, std::string_view what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (std::size_t k = 0; k < a.size(); ++k) {
    if (std::isnan(a[k]))
      EXPECT_TRUE(std::isnan(b[k])) << what << " [" << k << "]";
    else
      EXPECT_EQ(a[k], b[k]) << what << " [" << k << "]";
  }
}

void ExpectSameFile(const Mdf4File& a, const Mdf4File& b) {
  ASSERT_EQ(a.groups.size(), b.groups.size());
  for (std::size_t g = 0; g < a.groups.size(); ++g) {
    EXPECT_EQ(a.groups[g].name, b.groups[g].name);
    ExpectSame(a.groups[g].time, b.groups[g].time, "time of " + a.groups[g].name);
  }
  ASSERT_EQ(a.channels.size(), b.channels.size());
  for (std::size_t c = 0; c < a.channels.size(); ++c) {
    EXPECT_EQ(a.channels[c].name, b.channels[c].name);
    EXPECT_EQ(a.channels[c].unit, b.channels[c].unit);
    ExpectSame(a.channels[c].values, b.channels[c].values, a.channels[c].name);
  }
}

// The message of a refused file; it must name the file and contain each of `parts`.
std::string Refused(const std::vector<unsigned char>& bytes,
                    std::initializer_list<std::string> parts) {
  Result<Mdf4File> r = ParseMdf4(bytes, "run.mf4");
  EXPECT_FALSE(r.ok()) << "expected a refusal";
  if (r.ok()) return "";
  const std::string m = r.error().ToString();
  EXPECT_EQ(m.rfind("run.mf4: ", 0), 0u) << m;
  for (const std::string& p : parts)
    EXPECT_NE(m.find(p), std::string::npos) << "'" << p << "' not in: " << m;
  return m;
}

std::string Block(std::uint64_t at, std::string_view type) {
  return fmt::format("{} block at {:#x}", type, at);
}

// A one-group file of `records` records holding `channels` after a float64 time master.
WFile OneGroup(std::vector<WChannel> channels, std::size_t records) {
  std::vector<double> t;
  for (std::size_t k = 0; k < records; ++k) t.push_back(static_cast<double>(k));
  channels.insert(channels.begin(), TimeMaster(t));
  WFile file;
  file.data_groups = {{{Group("g", records, channels)}}};
  return file;
}

// ---------------------------------------------------------------------------------------------
// Values

TEST(Mdf4, TwoGroupsAt100And10HzImportToTheSameDataAsTheEquivalentCsv) {
  const Mdf4File f = Read(TwoRates(Storage::kDt, false));
  // The CSV at 10 Hz: each 100 Hz channel's last sample at or before the row's time, found by
  // search over the written times, printed to round-trip exactly.
  std::string csv = "t,speed,temp,pressure\n";
  for (int k = 0; k < kSlow; ++k) {
    int j = -1;
    for (int i = 0; i < kFast; ++i)
      if (FastTime(i) <= SlowTime(k)) j = i;
    ASSERT_GE(j, 0);
    csv += fmt::format("{:.17g},{:.17g},{:.17g},{:.17g}\n", SlowTime(k), Speed(j),
                       static_cast<double>(Temp(j)), Pressure(k));
  }
  Result<std::shared_ptr<const Dataset>> expected = ParseCsv(csv, "run.csv");
  ASSERT_TRUE(expected.ok()) << expected.error().ToString();
  Mdf4Format format;
  format.time_base = "slow";
  format.channels = {"speed", "temp", "pressure"};
  const std::shared_ptr<const Dataset> d = ToDataset(f, format);
  ExpectSame(d->time, (*expected)->time, "t");
  ASSERT_EQ(d->columns.size(), (*expected)->columns.size());
  for (std::size_t c = 0; c < d->columns.size(); ++c) {
    EXPECT_EQ(d->columns[c].name, (*expected)->columns[c].name);
    EXPECT_EQ(d->columns[c].field, static_cast<int>(c) + 1);
    ExpectSame(d->columns[c].values, (*expected)->columns[c].values, d->columns[c].name);
  }
  EXPECT_EQ(d->source, "run.mf4");
  EXPECT_EQ(d->time_name, "t");
  EXPECT_EQ(d->time_field, 0);
  EXPECT_EQ(d->header_line, 0);
  EXPECT_EQ(d->row_line, (std::vector<int>{1, 2, 3, 4, 5}));
}

TEST(Mdf4, ChannelsHoldTheWrittenPhysicalValuesNamesUnitsAndGroups) {
  const Mdf4File f = Read(TwoRates(Storage::kDt, false));
  EXPECT_EQ(f.version, 410);
  ASSERT_EQ(f.groups.size(), 2u);
  EXPECT_EQ(f.groups[0].name, "fast");
  EXPECT_EQ(f.groups[0].number, 1);
  EXPECT_EQ(f.groups[1].number, 2);
  EXPECT_EQ(f.groups[0].master_name, "t");
  EXPECT_EQ(f.groups[0].master_sync, 1);
  ASSERT_EQ(f.groups[0].time.size(), static_cast<std::size_t>(kFast));
  for (int k = 0; k < kFast; ++k) {
    EXPECT_EQ(f.groups[0].time[k], FastTime(k));
    EXPECT_EQ(Values(f, "speed")[k], Speed(k));
    EXPECT_EQ(Values(f, "temp")[k], static_cast<double>(Temp(k)));
  }
  for (int k = 0; k < kSlow; ++k) EXPECT_EQ(Values(f, "pressure")[k], Pressure(k));
  EXPECT_EQ(f.channels[static_cast<std::size_t>(f.Find("speed"))].unit, "km/h");
  EXPECT_EQ(f.channels[static_cast<std::size_t>(f.Find("pressure"))].group, 1);
  EXPECT_EQ(f.groups[1].channels, (std::vector<int>{f.Find("pressure")}));
}

TEST(Mdf4, SortedAndUnsortedFilesReadToIdenticalChannels) {
  const Mdf4File sorted = Read(TwoRates(Storage::kDt, false));
  const Mdf4File unsorted = Read(TwoRates(Storage::kDt, true));
  ExpectSameFile(sorted, unsorted);
  for (int rid : {2, 4, 8}) {
    WFile file = TwoRates(Storage::kDt, true);
    file.data_groups[0].rec_id_size = rid;
    ExpectSameFile(sorted, Read(file));
  }
}

TEST(Mdf4, DtDlDzTransposedDzAndHlStorageReadToIdenticalChannels) {
  for (bool unsorted : {false, true}) {
    const Mdf4File dt = Read(TwoRates(Storage::kDt, unsorted, 1000, 100));
    ASSERT_EQ(dt.channels.size(), 3u);
    for (Storage s :
         {Storage::kDl, Storage::kDlEqual, Storage::kDz, Storage::kDzTransposed, Storage::kHlDz}) {
      SCOPED_TRACE(fmt::format("storage {}, unsorted {}", static_cast<int>(s), unsorted));
      ExpectSameFile(dt, Read(TwoRates(s, unsorted, 1000, 100)));
    }
  }
}

TEST(Mdf4, TransposedDzWhoseLengthIsNoMultipleOfItsColumnsKeepsTheRemainderAsIs) {
  // Unsorted: the stream mixes 15-byte and 9-byte records while the columns are 15.
  const Written w = WriteMdf4(TwoRates(Storage::kDzTransposed, true, 7, 1));
  const std::uint64_t dz = w.At("DATA1");
  std::uint64_t n = 0;
  for (int i = 7; i >= 0; --i) n = (n << 8) | w.bytes[dz + 32 + static_cast<std::uint64_t>(i)];
  EXPECT_NE(n % 15, 0u);
  ExpectSameFile(Read(TwoRates(Storage::kDt, true, 7, 1)), Read(w.bytes));
}

TEST(Mdf4, IntegersAtBitOffsetsInBothByteOrdersReadToHandComputedValues) {
  // One record whose first two bytes are AB CD, read four ways at bit offset 4 over 12 bits:
  // big endian 0xABCD >> 4 = 0xABC, little endian 0xCDAB >> 4 = 0xCDA; signed, minus 4096.
  WChannel u_be = Integer("u_be", kUintBe, 12, 4, {});
  WChannel u_le = Integer("u_le", kUintLe, 12, 4, {});
  WChannel i_be = Integer("i_be", kIntBe, 12, 4, {});
  WChannel i_le = Integer("i_le", kIntLe, 12, 4, {});
  WChannel u3 = Integer("u3", kUintLe, 3, 5, {});  // bits 5-7 of byte 1 (0xCD = 110 01101): 6
  WChannel b1 = Integer("b1", kUintBe, 1, 7, {});  // bit 7 of byte 0 (0xAB): 1
  for (WChannel* c : {&u_be, &u_le, &i_be, &i_le, &u3, &b1}) c->byte_offset = 0;
  u3.byte_offset = 1;
  WFile file = OneGroup({u_be, u_le, i_be, i_le, u3, b1}, 1);
  file.data_groups[0].groups[0].channels[0].byte_offset = 2;  // the float64 master at bytes 2-9
  Written w = WriteMdf4(file);
  Put(w.bytes, w.At("DATA1") + 24, 0xCDAB, 2);  // record bytes 0, 1 = AB CD
  const Mdf4File f = Read(w.bytes);
  EXPECT_EQ(Values(f, "u_be")[0], 0xABC);
  EXPECT_EQ(Values(f, "u_le")[0], 0xCDA);
  EXPECT_EQ(Values(f, "i_be")[0], 0xABC - 4096);
  EXPECT_EQ(Values(f, "i_le")[0], 0xCDA - 4096);
  EXPECT_EQ(Values(f, "u3")[0], 6);
  EXPECT_EQ(Values(f, "b1")[0], 1);
  EXPECT_EQ(f.groups[0].time[0], 0);
}

TEST(Mdf4, WrittenIntegersOfEveryWidthAndSignReadBack) {
  const std::vector<std::int64_t> s = {0, 1, -1, -64, 63, -5, 42};
  const std::vector<std::int64_t> big = {0, INT64_MAX, INT64_MIN, -1, 1LL << 53, 7, -(1LL << 40)};
  WFile file = OneGroup({Integer("i7be", kIntBe, 7, 3, s), Integer("i7le", kIntLe, 7, 5, s),
                         Integer("u33", kUintLe, 33, 7, {0, 1, 8589934591, 4294967296, 5, 6, 7}),
                         Integer("i64", kIntLe, 64, 0, big), Integer("i64be", kIntBe, 64, 0, big),
                         Integer("u64", kUintLe, 64, 0, {-1, 0, 1, 2, 3, 4, 5}),
                         Integer("i8", kIntLe, 8, 0, {-128, 127, 0, -1, 1, 2, 3})},
                        7);
  const Mdf4File f = Read(file);
  for (std::size_t k = 0; k < 7; ++k) {
    EXPECT_EQ(Values(f, "i7be")[k], static_cast<double>(s[k]));
    EXPECT_EQ(Values(f, "i7le")[k], static_cast<double>(s[k]));
    EXPECT_EQ(Values(f, "i64")[k], static_cast<double>(big[k]));
    EXPECT_EQ(Values(f, "i64be")[k], static_cast<double>(big[k]));
  }
  EXPECT_EQ(Values(f, "u33")[2], 8589934591.0);
  EXPECT_EQ(Values(f, "u33")[3], 4294967296.0);
  EXPECT_EQ(Values(f, "u64")[0], 18446744073709551615.0);
  EXPECT_EQ(Values(f, "i8")[0], -128);
  EXPECT_EQ(Values(f, "i8")[1], 127);
}

TEST(Mdf4, Float32AndFloat64InBothByteOrdersReadExactly) {
  const std::vector<float> f32 = {0.1f, -3.5f, 1e30f, -0.0f};
  const std::vector<double> f64 = {0.1, -3.5, 1e300, 5e-324};
  const Mdf4File f = Read(OneGroup({Float32("le32", f32), Float32("be32", f32, true),
                                    Float64("le64", f64), Float64("be64", f64, true)},
                                   4));
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(Values(f, "le32")[k], static_cast<double>(f32[k]));
    EXPECT_EQ(Values(f, "be32")[k], static_cast<double>(f32[k]));
    EXPECT_EQ(Values(f, "le64")[k], f64[k]);
    EXPECT_EQ(Values(f, "be64")[k], f64[k]);
  }
}

TEST(Mdf4, HalfFloatsOfMdf420ReadToTheirValues) {
  // binary16: 0x3c00 = 1, 0xc000 = -2, 0x3555 = 0.333251953125, 0x0001 = 2^-24, 0x7c00 = inf.
  WFile file =
      OneGroup({Integer("h", kFloatLe, 16, 0, {0x3c00, 0xc000, 0x3555, 0x0001, 0x7c00})}, 5);
  file.version = 420;
  const Mdf4File f = Read(file);
  EXPECT_EQ(Values(f, "h"),
            (std::vector<double>{1, -2, 0.333251953125, std::ldexp(1.0, -24), INFINITY}));
}

TEST(Mdf4, LinearRationalAndTableConversionsGiveHandComputedValues) {
  const std::vector<std::int64_t> raw = {0, 1, 2, 3, 5, 6, 25, -1};
  WChannel linear = Integer("linear", kIntLe, 16, 0, raw);
  linear.conversion = {1, {2.5, 0.25}};  // 2.5 + 0.25 x
  WChannel rational = Integer("rational", kIntLe, 16, 0, raw);
  rational.conversion = {2, {1, 0, 0, 0, 1, 1}};  // x^2 / (x + 1): NaN at x = -1
  WChannel pole = Integer("pole", kIntLe, 16, 0, raw);
  pole.conversion = {2, {0, 0, 1, 0, 1, -2}};  // 1 / (x - 2): NaN at x = 2
  WChannel interp = Integer("interp", kIntLe, 16, 0, raw);
  interp.conversion = {4, {0, 0, 10, 100, 20, 50}};
  WChannel nearest = Integer("nearest", kIntLe, 16, 0, raw);
  nearest.conversion = {5, {0, 0, 10, 100, 20, 50}};
  WChannel ranges = Integer("ranges", kIntLe, 16, 0, raw);
  ranges.conversion = {6, {0, 2, 7, 3, 5, 8, -9}};  // [0,2] -> 7, [3,5] -> 8, else -9
  const Mdf4File f = Read(OneGroup({linear, rational, pole, interp, nearest, ranges}, raw.size()));
  EXPECT_EQ(Values(f, "linear"), (std::vector<double>{2.5, 2.75, 3, 3.25, 3.75, 4, 8.75, 2.25}));
  const std::vector<double>& r = Values(f, "rational");
  EXPECT_EQ(r[0], 0);
  EXPECT_EQ(r[1], 0.5);
  EXPECT_EQ(r[2], 4.0 / 3);
  EXPECT_EQ(r[3], 9.0 / 4);
  EXPECT_EQ(r[6], 625.0 / 26);
  EXPECT_TRUE(std::isnan(r[7]));
  const std::vector<double>& p = Values(f, "pole");
  EXPECT_EQ(p[0], -0.5);
  EXPECT_TRUE(std::isnan(p[2]));
  EXPECT_EQ(p[3], 1);
  EXPECT_EQ(Values(f, "interp"), (std::vector<double>{0, 10, 20, 30, 50, 60, 50, 0}));
  EXPECT_EQ(Values(f, "nearest"), (std::vector<double>{0, 0, 0, 0, 0, 100, 50, 0}));
  EXPECT_EQ(Values(f, "ranges"), (std::vector<double>{7, 7, 7, 8, 8, -9, -9, -9}));
}

TEST(Mdf4, AVirtualMasterIsItsPeriodTimesTheRecordIndexAndVirtualDataItsConversion) {
  WChannel data;
  data.name = "ramp";
  data.cn_type = 6;
  data.data_type = kUintLe;
  data.bit_count = 0;
  data.conversion = {1, {1, 3}};
  WGroup g =
      Group("virtual", 5,
            {VirtualMaster(0.02, "time"), data, Integer("x", kUintLe, 8, 0, {9, 8, 7, 6, 5})});
  WFile file;
  file.data_groups = {{{g}}};
  const Mdf4File f = Read(file);
  ASSERT_EQ(f.groups.size(), 1u);
  EXPECT_TRUE(f.groups[0].virtual_master);
  EXPECT_EQ(f.groups[0].master_name, "time");
  for (int k = 0; k < 5; ++k) EXPECT_EQ(f.groups[0].time[k], 0 + 0.02 * k);
  EXPECT_EQ(Values(f, "ramp"), (std::vector<double>{1, 4, 7, 10, 13}));
  EXPECT_EQ(Values(f, "x"), (std::vector<double>{9, 8, 7, 6, 5}));
}

TEST(Mdf4, InvalidationBitsMakeTheirSamplesNaN) {
  WChannel a = Integer("a", kUintLe, 8, 0, {1, 2, 3, 4});
  a.inval_bit = 3;
  a.invalid = {false, true, false, true};
  WChannel b = Float64("b", {1.5, 2.5, 3.5, 4.5});
  b.inval_bit = 9;  // second invalidation byte
  b.invalid = {true, false, false, false};
  WChannel never = Integer("never", kUintLe, 8, 0, {1, 2, 3, 4});
  never.flags = 1;  // all values invalid
  const Mdf4File f = Read(OneGroup({a, b, never}, 4));
  ExpectSame(Values(f, "a"), {1, NAN, 3, NAN}, "a");
  ExpectSame(Values(f, "b"), {NAN, 2.5, 3.5, 4.5}, "b");
  ExpectSame(Values(f, "never"), {NAN, NAN, NAN, NAN}, "never");
}

// ---------------------------------------------------------------------------------------------
// Time base

// Group 1 at t = k/4 (k = 0..12) with q = k; group 2 at t = 0.5, 1.5, 2.5 with s = 0, 10, 40.
Mdf4File Quarters() {
  std::vector<double> t, q;
  for (int k = 0; k <= 12; ++k) {
    t.push_back(k * 0.25);
    q.push_back(k);
  }
  WFile file;
  file.data_groups = {
      {{Group("quarters", 13, {TimeMaster(t), Float64("q", q)})}},
      {{Group("sparse", 3, {TimeMaster({0.5, 1.5, 2.5}), Float64("s", {0, 10, 40})})}}};
  return Read(file);
}

TEST(Mdf4, HoldTakesTheLastSampleAtOrBeforeEachRowAndIsMissingBeforeTheFirst) {
  Mdf4Format format;
  format.channels = {"s", "q"};
  const std::shared_ptr<const Dataset> d = ToDataset(Quarters(), format);  // base: the larger group
  ASSERT_EQ(d->rows(), 13u);
  ExpectSame(Column(*d, "s"), {NAN, NAN, 0, 0, 0, 0, 10, 10, 10, 10, 40, 40, 40}, "s");
  EXPECT_EQ(d->columns[0].n_missing, 2);
  EXPECT_EQ(d->columns[0].first_missing_line, 1);
  EXPECT_EQ(Column(*d, "q")[7], 7);
}

TEST(Mdf4, LinearInterpolatesBetweenNeighboursAndIsMissingOutsideTheSamples) {
  Mdf4Format format;
  format.channels = {"s"};
  format.time_base = "1";
  format.interpolation = Mdf4Format::Interpolation::kLinear;
  const std::shared_ptr<const Dataset> d = ToDataset(Quarters(), format);
  // Between 0.5 and 1.5: 10 (t - 0.5); between 1.5 and 2.5: 10 + 30 (t - 1.5).
  ExpectSame(Column(*d, "s"), {NAN, NAN, 0, 2.5, 5, 7.5, 10, 17.5, 25, 32.5, 40, NAN, NAN}, "s");
}

TEST(Mdf4, TheSparseGroupAsTimeBaseTakesTheDenseChannelsSamplesAtItsTimes) {
  Mdf4Format format;
  format.time_base = "s";  // a channel: its group
  const std::shared_ptr<const Dataset> d = ToDataset(Quarters(), format);
  EXPECT_EQ(d->time, (std::vector<double>{0.5, 1.5, 2.5}));
  EXPECT_EQ(Column(*d, "q"), (std::vector<double>{2, 6, 10}));
  EXPECT_EQ(d->columns.size(), 2u);  // every channel when none is named
}

TEST(Mdf4, ARangeKeepsTheRowsInsideItAndTheirRecordIndices) {
  Mdf4Format format;
  format.channels = {"q"};
  format.range = std::array<double, 2>{0.5, 1.5};
  const std::shared_ptr<const Dataset> d = ToDataset(Quarters(), format);
  EXPECT_EQ(d->time, (std::vector<double>{0.5, 0.75, 1, 1.25, 1.5}));
  EXPECT_EQ(d->row_line, (std::vector<int>{3, 4, 5, 6, 7}));
  EXPECT_EQ(Column(*d, "q"), (std::vector<double>{2, 3, 4, 5, 6}));
}

TEST(Mdf4, ASampleTimePutsTheRowsOnAGridOverTheChannelsCommonSpan) {
  Mdf4Format format;
  format.channels = {"q", "s"};
  format.sample_time = 0.5;
  const std::shared_ptr<const Dataset> d = ToDataset(Quarters(), format);
  EXPECT_EQ(d->time, (std::vector<double>{0.5, 1, 1.5, 2, 2.5}));
  EXPECT_EQ(Column(*d, "q"), (std::vector<double>{2, 4, 6, 8, 10}));
  EXPECT_EQ(Column(*d, "s"), (std::vector<double>{0, 0, 10, 10, 40}));
}

TEST(Mdf4, ANameInSeveralGroupsIsFoundAsNameAtGroupNumberOrGroupName) {
  WFile file;
  file.data_groups = {{{Group("a", 2, {TimeMaster({0, 1}), Float64("x", {1, 2})})}},
                      {{Group("b", 2, {TimeMaster({0, 2}), Float64("x", {3, 4})})}}};
  const Mdf4File f = Read(file);
  EXPECT_EQ(f.Find("x"), -2);
  EXPECT_EQ(f.Find("x@1"), 0);
  EXPECT_EQ(f.Find("x@b"), 1);
  EXPECT_EQ(f.Find("x@3"), -1);
  EXPECT_EQ(f.Find("y"), -1);
  const std::shared_ptr<const Dataset> d = ToDataset(f, {});
  ASSERT_EQ(d->columns.size(), 2u);
  EXPECT_EQ(d->columns[0].name, "x@1");
  EXPECT_EQ(d->columns[1].name, "x@2");
  EXPECT_EQ(d->time, (std::vector<double>{0, 1}));  // a tie: the lower group number
  EXPECT_EQ(d->columns[1].values, (std::vector<double>{3, 3}));
  Mdf4Format ambiguous;
  ambiguous.channels = {"x"};
  const Result<std::shared_ptr<const Dataset>> r = Mdf4ToDataset(f, "run.mf4", ambiguous);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().ToString(),
            "run.mf4: channel 'x' is in several groups: write x@1, x@2 (G: the group's number)");
}

TEST(Mdf4, AnAbsentChannelIsRefusedWithTheFilesChannels) {
  Mdf4Format format;
  format.channels = {"speed", "rpm"};
  const Result<std::shared_ptr<const Dataset>> r =
      Mdf4ToDataset(Read(TwoRates(Storage::kDt, false)), "run.mf4", format);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().ToString(),
            "run.mf4: channel 'rpm' is not in the file; its channels are speed, temp, pressure");
}

TEST(Mdf4, AMasterThatDoesNotIncreaseIsRefusedNamingGroupAndRecord) {
  WFile file;
  file.data_groups = {
      {{Group("fast", 4, {TimeMaster({0, 0.1, 0.1, 0.3}), Float64("x", {1, 2, 3, 4})})}}};
  const Mdf4File f = Read(file);  // the file itself is fine
  const Result<std::shared_ptr<const Dataset>> r = Mdf4ToDataset(f, "run.mf4", {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().ToString(),
            "run.mf4: group 1 ('fast'): master 't' at record 2 (0.1) is not after record 1 (0.1)");
}

TEST(Mdf4, AStringChannelIsSkippedAndRefusedOnlyWhenAskedFor) {
  WChannel text = Integer("label", kUtf8, 32, 0, {0x41424344, 0x45464748});
  const Mdf4File f = Read(OneGroup({text, Float64("x", {1, 2})}, 2));
  EXPECT_EQ(f.Find("label"), -1);
  ASSERT_EQ(f.skipped.size(), 1u);
  EXPECT_EQ(ToDataset(f, {})->columns.size(), 1u);
  Mdf4Format format;
  format.channels = {"label"};
  const Result<std::shared_ptr<const Dataset>> r = Mdf4ToDataset(f, "run.mf4", format);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().ToString(),
            "run.mf4: channel 'label' in group 1 ('g') is not read: its data type is a UTF-8 "
            "string, not a number");
}

// ---------------------------------------------------------------------------------------------
// Files

std::vector<unsigned char> Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The fixtures as the writer makes them (tests/data/mdf4/README.md).
std::vector<std::pair<std::string, Written>> Fixtures() {
  WFile big_endian = OneGroup({Integer("u12_be", kUintBe, 12, 3, {0, 1, 2748, 4095}),
                               Integer("i7_be", kIntBe, 7, 5, {-64, -1, 0, 63}),
                               Integer("i24_be", kIntBe, 24, 0, {-8388608, -2, 8388607, 12345}),
                               Float64("f64_be", {0.5, -1.25, 1e10, 3}, true)},
                              4);
  return {{"two_rates.mf4", WriteMdf4(TwoRates(Storage::kDt, false))},
          {"unsorted.mf4", WriteMdf4(TwoRates(Storage::kDt, true))},
          {"dz_transposed.mf4", WriteMdf4(TwoRates(Storage::kDzTransposed, true))},
          {"big_endian.mf4", WriteMdf4(big_endian)}};
}

const std::string kFixtures = std::string(GREYBENCH_TEST_DATA_DIR) + "/mdf4/";

TEST(Mdf4, TheFixtureFilesAreWhatTheWriterWrites) {
  // GREYBENCH_WRITE_MDF4_FIXTURES=1 writes them anew (then check them with mdfdump again).
  for (const auto& [name, written] : Fixtures()) {
    if (std::getenv("GREYBENCH_WRITE_MDF4_FIXTURES")) WriteBytes(kFixtures + name, written.bytes);
    EXPECT_EQ(Slurp(kFixtures + name), written.bytes) << name;
  }
}

TEST(Mdf4, TheFixtureFilesReadToTheirWrittenValues) {
  for (const char* name : {"two_rates.mf4", "unsorted.mf4", "dz_transposed.mf4"}) {
    const Result<Mdf4File> f = ReadMdf4File(kFixtures + name);
    ASSERT_TRUE(f.ok()) << f.error().ToString();
    ASSERT_EQ(f->groups.size(), 2u) << name;
    for (int k = 0; k < kFast; ++k) {
      EXPECT_EQ(f->groups[0].time[k], FastTime(k));
      EXPECT_EQ(Values(*f, "speed")[k], Speed(k));
      EXPECT_EQ(Values(*f, "temp")[k], static_cast<double>(Temp(k)));
    }
    for (int k = 0; k < kSlow; ++k) EXPECT_EQ(Values(*f, "pressure")[k], Pressure(k));
  }
  const Result<Mdf4File> f = ReadMdf4File(kFixtures + "big_endian.mf4");
  ASSERT_TRUE(f.ok()) << f.error().ToString();
  EXPECT_EQ(Values(*f, "u12_be"), (std::vector<double>{0, 1, 2748, 4095}));
  EXPECT_EQ(Values(*f, "i7_be"), (std::vector<double>{-64, -1, 0, 63}));
  EXPECT_EQ(Values(*f, "i24_be"), (std::vector<double>{-8388608, -2, 8388607, 12345}));
  EXPECT_EQ(Values(*f, "f64_be"), (std::vector<double>{0.5, -1.25, 1e10, 3}));
}

TEST(Mdf4, AFileThatCannotBeReadIsRefusedNamingIt) {
  const std::string missing = kFixtures + "no_such.mf4";
  const Result<Mdf4File> r = ReadMdf4File(missing);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().file, missing);
  const Result<Mdf4File> folder = ReadMdf4File(kFixtures);
  ASSERT_FALSE(folder.ok());
  EXPECT_NE(folder.error().ToString().find("it is a folder"), std::string::npos);
  const Result<Mdf4File> device = ReadMdf4File("/dev/zero");
  ASSERT_FALSE(device.ok());
  EXPECT_NE(device.error().ToString().find("not a regular file"), std::string::npos);
}

TEST(Mdf4, LooksLikeMdfKnowsBothMagics) {
  const auto bytes = [](std::string_view s) {
    return std::vector<unsigned char>(s.begin(), s.end());
  };
  EXPECT_TRUE(LooksLikeMdf(bytes("MDF     4.10")));
  EXPECT_TRUE(LooksLikeMdf(bytes("UnFinMF 4.10")));
  EXPECT_FALSE(LooksLikeMdf(bytes("t,x\n0,1")));
  EXPECT_FALSE(LooksLikeMdf(bytes("MDF")));
}

// ---------------------------------------------------------------------------------------------
// Malformed

// Field offsets (from the block's start) of blocks the writer writes with their usual links.
constexpr std::uint64_t kLength = 8, kCnNext = 24, kCnName = 40, kCnConversion = 56, kCnType = 88,
                        kCnDataType = 90, kCnByteOffset = 92, kCnBitCount = 96, kCgFirstCn = 32,
                        kCgRecordId = 72, kCgCycles = 80, kCgDataBytes = 96, kDgNext = 24,
                        kDgRecIdSize = 56, kDzZipType = 26, kDzParameter = 28, kDzOrgLength = 32,
                        kDzData = 48, kCcValues = 80;

struct Case {
  Written w = WriteMdf4(TwoRates(Storage::kDt, false));
  std::vector<unsigned char>& b = w.bytes;
  std::uint64_t at(const std::string& label) const { return w.At(label); }
};

TEST(Mdf4Malformed, ATruncatedIdentificationBlockIsNotAnMdfFile) {
  Case c;
  c.b.resize(40);
  Refused(c.b, {"identification block at 0x0", "holds 40 bytes", "not an MDF file"});
}

TEST(Mdf4Malformed, AWrongMagicIsNotAnMdfFile) {
  Case c;
  c.b[0] = 'X';
  Refused(c.b, {"identification block at 0x0: not an MDF file"});
}

TEST(Mdf4Malformed, AnUnfinalizedFileIsRefused) {
  Case c;
  std::copy_n("UnFinMF ", 8, c.b.begin());
  Refused(c.b, {"identification block at 0x0", "unfinalized"});
}

TEST(Mdf4Malformed, Mdf3IsRefusedByVersion) {
  Case c;
  Put(c.b, 28, 330, 2);
  Refused(c.b, {"identification block at 0x0", "MDF version 330", "MDF 3"});
}

TEST(Mdf4Malformed, AFileCutInsideTheHeaderBlockIsRefused) {
  Case c;
  c.b.resize(64 + 30);
  Refused(c.b, {Block(64, "HD") + ": its 6 links run past the end of the file (size 94)"});
}

TEST(Mdf4Malformed, ALinkToATruncatedBlockHeaderIsRefused) {
  Case c;
  Put(c.b, c.at("CN:speed") + kCnName, c.b.size() - 16, 8);
  Refused(c.b, {Block(c.at("CN:speed"), "CN"), "link 2 (name)", "too near the end of the file"});
}

TEST(Mdf4Malformed, ALinkPastTheEndOfTheFileIsRefused) {
  Case c;
  Put(c.b, c.at("CN:speed") + kCnName, c.b.size() + 100, 8);
  Refused(c.b, {Block(c.at("CN:speed"), "CN") +
                ": link 2 (name) points past the end of the file (size " +
                std::to_string(c.b.size()) + ")"});
}

TEST(Mdf4Malformed, ALinkIntoTheIdentificationBlockIsRefused) {
  Case c;
  Put(c.b, c.at("CG1.1") + kCgFirstCn, 16, 8);
  Refused(c.b, {Block(c.at("CG1.1"), "CG") +
                ": link 1 (first channel) points into the identification block"});
}

TEST(Mdf4Malformed, ALinkToWhereNoBlockStartsIsRefused) {
  Case c;
  Put(c.b, c.at("CN:speed") + kCnNext, c.at("CN:speed") + 8, 8);
  Refused(c.b, {Block(c.at("CN:speed"), "CN") + ": link 0 (next channel): no block starts at"});
}

TEST(Mdf4Malformed, ACycleInAChannelChainIsRefused) {
  Case c;
  Put(c.b, c.at("CN:temp") + kCnNext, c.at("CN:t"), 8);  // temp is the last channel of group 1
  Refused(c.b, {Block(c.at("CN:temp"), "CN"),
                "link 0 (next channel) leads back to " + Block(c.at("CN:t"), "CN"), "a cycle"});
}

TEST(Mdf4Malformed, ACycleInTheDataGroupChainIsRefused) {
  Case c;
  Put(c.b, c.at("DG2") + kDgNext, c.at("DG1"), 8);
  Refused(c.b, {Block(c.at("DG2"), "DG"), "leads back to " + Block(c.at("DG1"), "DG")});
}

TEST(Mdf4Malformed, ABlockOfAnotherTypeWhereAChannelBelongsIsRefused) {
  Case c;
  Put(c.b, c.at("CG1.1") + kCgFirstCn, c.at("TX:speed"), 8);
  Refused(c.b, {Block(c.at("CG1.1"), "CG"), "holds a TX block, not a CN block"});
}

TEST(Mdf4Malformed, ABlockOfAnotherTypeWhereAConversionBelongsIsRefused) {
  Case c;
  Put(c.b, c.at("CN:temp") + kCnConversion, c.at("TX:temp"), 8);
  Refused(c.b, {Block(c.at("CN:temp"), "CN") + ": link 4 (conversion)",
                "holds a TX block, not a CC block"});
}

TEST(Mdf4Malformed, AConversionWhereANameBelongsIsRefused) {
  Case c;
  Put(c.b, c.at("CN:temp") + kCnName, c.at("CC:speed"), 8);
  Refused(c.b, {Block(c.at("CN:temp"), "CN") + ": link 2 (name)",
                "holds a CC block, not a TX or MD block"});
}

TEST(Mdf4Malformed, ABlockShorterThanItsLinksIsRefused) {
  Case c;
  Put(c.b, c.at("CN:speed") + kLength, 24 + 8 * 8 - 8, 8);
  Refused(c.b, {Block(c.at("CN:speed"), "CN"),
                "length 80 is shorter than its header and 8 links (88 bytes)"});
}

TEST(Mdf4Malformed, ABlockShorterThanItsFieldsIsRefused) {
  Case c;
  Put(c.b, c.at("CN:speed") + kLength, 24 + 8 * 8 + 8, 8);
  Refused(c.b, {Block(c.at("CN:speed"), "CN"),
                "length 96 is shorter than its 8 links and 72 bytes of fields"});
}

TEST(Mdf4Malformed, ACycleCountLargerThanTheDataIsRefused) {
  Case c;
  Put(c.b, c.at("CG1.1") + kCgCycles, kFast + 1, 8);
  Refused(c.b,
          {Block(c.at("CG1.1"), "CG"), "cycle count 51", Block(c.at("DG1"), "DG") + " holds 700"});
}

TEST(Mdf4Malformed, AHugeCycleCountIsRefusedBeforeAnythingIsAllocated) {
  Case c;
  Put(c.b, c.at("CG1.1") + kCgCycles, ~std::uint64_t{0} / 2, 8);
  Refused(c.b, {Block(c.at("CG1.1"), "CG"), "needs more than 700 bytes"});
}

TEST(Mdf4Malformed, RecordsOfZeroBytesAreRefused) {
  WFile file;
  file.data_groups = {{{Group("virtual", 5, {VirtualMaster(0.1)})}}};
  const Written w = WriteMdf4(file);
  Refused(w.bytes, {Block(w.At("CG1.1"), "CG"), "records are 0 bytes long", "cycle count is 5"});
}

TEST(Mdf4Malformed, AChannelBeyondItsRecordIsRefused) {
  Case c;
  Put(c.b, c.at("CN:temp") + kCnByteOffset, 12, 4);  // 4 bytes at 12 in a 14-byte record
  Refused(c.b, {Block(c.at("CN:temp"), "CN") +
                " ('temp'): its bytes 12 to 15 lie beyond the record's 14 data bytes"});
}

TEST(Mdf4Malformed, AnIntegerOfMoreThan64BitsIsRefused) {
  Case c;
  Put(c.b, c.at("CN:speed") + kCnBitCount, 65, 4);
  Refused(c.b, {Block(c.at("CN:speed"), "CN") + " ('speed'): an integer of 65 bits"});
}

TEST(Mdf4Malformed, AHalfFloatBeforeMdf420IsRefused) {
  Case c;
  Put(c.b, c.at("CN:temp") + kCnBitCount, 16, 4);
  Refused(c.b, {Block(c.at("CN:temp"), "CN") + " ('temp'): a float of 16 bits"});
}

TEST(Mdf4Malformed, UnknownChannelAndDataTypesAreRefused) {
  Case c;
  Put(c.b, c.at("CN:speed") + kCnType, 9, 1);
  Refused(c.b, {Block(c.at("CN:speed"), "CN") + " ('speed'): unknown channel type 9"});
  Case d;
  Put(d.b, d.at("CN:speed") + kCnDataType, 40, 1);
  Refused(d.b, {Block(d.at("CN:speed"), "CN") + " ('speed'): unknown data type 40"});
}

TEST(Mdf4Malformed, TwoMastersInOneGroupAreRefused) {
  Case c;
  Put(c.b, c.at("CN:temp") + kCnType, 2, 1);
  Refused(c.b, {Block(c.at("CG1.1"), "CG"), "two master channels, 't' and 'temp'"});
}

TEST(Mdf4Malformed, ARecordIdSizeOfThreeIsRefused) {
  Case c;
  Put(c.b, c.at("DG1") + kDgRecIdSize, 3, 1);
  Refused(c.b, {Block(c.at("DG1"), "DG") + ": record ID size 3"});
}

TEST(Mdf4Malformed, DuplicateRecordIdsInOneDataGroupAreRefused) {
  Written w = WriteMdf4(TwoRates(Storage::kDt, true));
  Put(w.bytes, w.At("CG1.2") + kCgRecordId, 1, 8);
  Refused(w.bytes, {Block(w.At("CG1.2"), "CG") + ": record ID 1 is also that of " +
                    Block(w.At("CG1.1"), "CG")});
}

TEST(Mdf4Malformed, AnUnknownRecordIdInAnUnsortedGroupIsRefused) {
  Written w = WriteMdf4(TwoRates(Storage::kDt, true));
  const std::uint64_t data = w.At("DATA1") + 24;
  Put(w.bytes, data + 15, 9, 1);  // the second record (the first is the 15-byte fast one at t = 0)
  Refused(w.bytes,
          {Block(w.At("DG1"), "DG") + ": the record at byte 15 of its data has record ID 9"});
}

TEST(Mdf4Malformed, AVlsdLengthPastTheEndOfTheDataIsRefused) {
  std::vector<WGroup> groups = TwoRateGroups(3, 1);
  WGroup vlsd;
  vlsd.vlsd_items = {"abc", "defgh"};
  groups.push_back(vlsd);
  WFile file;
  file.data_groups = {{groups}};
  Written w = WriteMdf4(file);
  ASSERT_EQ(Read(w.bytes).groups.size(), 2u);                 // the VLSD group is read past
  Put(w.bytes, w.At("DATA1") + 24 + 1 + 4 + 3 + 1, 1000, 4);  // the second item's length
  Refused(w.bytes,
          {Block(w.At("CG1.3"), "CG") + ": its record at byte 8 of the data needs 1004 bytes"});
}

TEST(Mdf4Malformed, ADzThatDoesNotInflateIsRefused) {
  Written w = WriteMdf4(TwoRates(Storage::kDz, false));
  w.bytes[w.At("DATA1") + kDzData + 4] ^= 0xff;
  w.bytes[w.At("DATA1") + kDzData + 5] ^= 0xff;
  Refused(w.bytes, {Block(w.At("DATA1"), "DZ") + ": its data does not inflate"});
  Written bad_header = WriteMdf4(TwoRates(Storage::kDz, false));
  bad_header.bytes[bad_header.At("DATA1") + kDzData] = 0;
  Refused(bad_header.bytes,
          {Block(bad_header.At("DATA1"), "DZ") + ": its data does not inflate (zlib: "});
}

TEST(Mdf4Malformed, ADzWhoseInflatedSizeDiffersFromTheDeclaredOneIsRefused) {
  Written more = WriteMdf4(TwoRates(Storage::kDz, false));
  Put(more.bytes, more.At("DATA1") + kDzOrgLength, 700 + 1, 8);
  Refused(more.bytes,
          {Block(more.At("DATA1"), "DZ") + ": it inflates to 700 bytes, not its declared 701"});
  Written less = WriteMdf4(TwoRates(Storage::kDz, false));
  Put(less.bytes, less.At("DATA1") + kDzOrgLength, 700 - 1, 8);
  Refused(less.bytes,
          {Block(less.At("DATA1"), "DZ") + ": it inflates to more than its declared 699 bytes"});
  Written huge = WriteMdf4(TwoRates(Storage::kDz, false));
  Put(huge.bytes, huge.At("DATA1") + kDzOrgLength, std::uint64_t{1} << 60, 8);
  Refused(huge.bytes, {Block(huge.At("DATA1"), "DZ") + ": its declared original size",
                       "more than deflate can produce"});
}

TEST(Mdf4Malformed, ADzOfAnUnknownZipTypeOrATranspositionWithoutColumnsIsRefused) {
  Written w = WriteMdf4(TwoRates(Storage::kDz, false));
  Put(w.bytes, w.At("DATA1") + kDzZipType, 2, 1);
  Refused(w.bytes, {Block(w.At("DATA1"), "DZ") + ": zip type 2 is not supported"});
  Written t = WriteMdf4(TwoRates(Storage::kDzTransposed, false));
  Put(t.bytes, t.At("DATA1") + kDzParameter, 0, 4);
  Refused(t.bytes, {Block(t.At("DATA1"), "DZ") + ": a transposition with 0 columns"});
}

TEST(Mdf4Malformed, ADlWithACountLargerThanItsLinksIsRefused) {
  Written w = WriteMdf4(TwoRates(Storage::kDl, false));
  const std::uint64_t dl = w.At("DL1");
  Put(w.bytes, dl + 24 + 8 * 4 + 4, 5, 4);  // 1 + 3 links, then flags and the count
  Refused(w.bytes, {Block(dl, "DL") + ": its count 5 disagrees with its 3 data links"});
}

TEST(Mdf4Malformed, ADlWhoseOffsetsDisagreeWithItsBlocksIsRefused) {
  Written w = WriteMdf4(TwoRates(Storage::kDl, false));
  const std::uint64_t dl = w.At("DL1");
  Put(w.bytes, dl + 24 + 8 * 4 + 8 + 8, 1, 8);  // offset 1
  Refused(w.bytes, {Block(dl, "DL") + ": offset 1 is 1, but the blocks before it hold 77 bytes"});
}

TEST(Mdf4Malformed, ADataBlockListedTwiceIsRefused) {
  Written w = WriteMdf4(TwoRates(Storage::kDl, false));
  const std::uint64_t dl = w.At("DL1");
  Put(w.bytes, dl + 24 + 16, w.At("DT1.0"), 8);
  Refused(w.bytes, {Block(dl, "DL") + ": link 2 (data block 1) leads back to " +
                    Block(w.At("DT1.0"), "DT")});
}

TEST(Mdf4Malformed, ARationalConversionWithAZeroDenominatorIsRefused) {
  WChannel x = Integer("x", kUintLe, 8, 0, {1, 2});
  x.conversion = {2, {1, 0, 0, 0, 0, 0}};
  const Written w = WriteMdf4(OneGroup({x}, 2));
  Refused(w.bytes, {Block(w.At("CC:x"), "CC") +
                    ": the rational conversion's denominator is identically zero"});
}

TEST(Mdf4Malformed, AConversionWithTheWrongValueCountOrUnorderedKeysIsRefused) {
  WChannel x = Integer("x", kUintLe, 8, 0, {1, 2});
  x.conversion = {1, {1, 2, 3}};
  const Written w = WriteMdf4(OneGroup({x}, 2));
  Refused(w.bytes, {Block(w.At("CC:x"), "CC") + ": a type 1 conversion cannot have 3 values"});
  x.conversion = {4, {0, 1, 5, 2, 5, 3}};
  const Written keys = WriteMdf4(OneGroup({x}, 2));
  Refused(keys.bytes,
          {Block(keys.At("CC:x"), "CC") + ": the table's keys do not increase strictly at key 2"});
  x.conversion = {1, {0, INFINITY}};
  const Written inf = WriteMdf4(OneGroup({x}, 2));
  Refused(inf.bytes, {Block(inf.At("CC:x"), "CC") + ": value 1 is not finite"});
  Written bad = WriteMdf4(TwoRates(Storage::kDt, false));
  Put(bad.bytes, bad.At("CC:speed") + kCcValues - 24, 99, 1);
  Refused(bad.bytes, {Block(bad.At("CC:speed"), "CC") + ": unknown conversion type 99"});
}

TEST(Mdf4Malformed, AChannelWithoutANameIsRefused) {
  Case c;
  Put(c.b, c.at("CN:speed") + kCnName, 0, 8);
  Refused(c.b, {Block(c.at("CN:speed"), "CN") + ": link 2 (name) is 0"});
}

TEST(Mdf4Malformed, SeveralGroupsWithoutRecordIdsAreRefused) {
  Written w = WriteMdf4(TwoRates(Storage::kDt, true));
  Put(w.bytes, w.At("DG1") + kDgRecIdSize, 0, 1);
  Refused(w.bytes, {Block(w.At("CG1.1"), "CG") +
                    ": record ID 1 does not fit in the DG's 0-byte record IDs"});
  Put(w.bytes, w.At("CG1.1") + kCgRecordId, 0, 8);
  Put(w.bytes, w.At("CG1.2") + kCgRecordId, 0, 8);
  Refused(w.bytes, {Block(w.At("CG1.2"), "CG") + ": record ID 0 is also that of " +
                    Block(w.At("CG1.1"), "CG")});
}

TEST(Mdf4Malformed, AGroupWhoseDataIsLongerThanItsCycleCountIsRefused) {
  Case c;
  Put(c.b, c.at("CG1.1") + kCgDataBytes, 13, 4);
  Put(c.b, c.at("CN:temp") + kCnByteOffset, 2, 4);
  Refused(c.b, {Block(c.at("CG1.1"), "CG"), "needs 650 bytes of 13-byte records", "holds 700"});
}

TEST(Mdf4Malformed, AFileWithoutItsHeaderBlockIsRefused) {
  Case c;
  c.b[64] = 'X';
  Refused(c.b, {"identification block at 0x0: the HD block that must follow it: no block starts "
                "at 0x40 (it holds 58 23 48 44)"});
}

TEST(Mdf4Malformed, AnInvalidationBitBeyondTheInvalidationBytesIsRefused) {
  WChannel x = Integer("x", kUintLe, 8, 0, {1, 2});
  x.inval_bit = 3;
  x.invalid = {false, false};
  Written w = WriteMdf4(OneGroup({x}, 2));
  Put(w.bytes, w.At("CN:x") + 104, 8, 4);  // bit 8 of one invalidation byte
  Refused(w.bytes, {Block(w.At("CN:x"), "CN") + " ('x'): invalidation bit 8 lies beyond the "
                                                "record's 1 invalidation bytes"});
}

TEST(Mdf4Malformed, AnEqualLengthDlWhoseBlockHasAnotherLengthIsRefused) {
  Written w = WriteMdf4(TwoRates(Storage::kDlEqual, false));
  const std::uint64_t dl = w.At("DL1");
  Put(w.bytes, dl + 24 + 8 * 4 + 8, 200, 8);  // the equal length: 234 written
  Refused(w.bytes, {Block(w.At("DT1.0"), "DT") + ": it holds 234 bytes, but its DL block at " +
                    fmt::format("{:#x}", dl) + " gives equal lengths of 200"});
}

TEST(Mdf4Malformed, ADzOfAnotherBlockTypeWhereDataBelongsIsRefused) {
  Written w = WriteMdf4(TwoRates(Storage::kDz, false));
  w.bytes[w.At("DATA1") + 24] = 'S';
  w.bytes[w.At("DATA1") + 25] = 'D';
  Refused(w.bytes, {Block(w.At("DATA1"), "DZ") +
                    ": it holds a compressed 'SD' block where a DT block belongs"});
}

TEST(Mdf4Malformed, ColumnOrientedStorageIsRefusedByName) {
  Written w = WriteMdf4(TwoRates(Storage::kDt, false));
  w.bytes[w.At("DATA1") + 2] = 'L';
  w.bytes[w.At("DATA1") + 3] = 'D';
  Refused(w.bytes, {Block(w.At("DATA1"), "LD") + ": column-oriented storage"});
}

TEST(Mdf4, ARowBetweenAValidAndAnInvalidSampleIsMissingWhenInterpolated) {
  WChannel x = Float64("x", {0, 10, 20});
  x.inval_bit = 0;
  x.invalid = {false, true, false};
  WFile file;
  file.data_groups = {{{Group("a", 3, {TimeMaster({0, 1, 2}), x})}},
                      {{Group("b", 5, {TimeMaster({0, 0.5, 1, 1.5, 2}), Float64("y", {})})}}};
  file.data_groups[1].groups[0].channels[1].raw.assign(5, 0);
  Mdf4Format format;
  format.channels = {"x"};
  format.time_base = "b";
  format.interpolation = Mdf4Format::Interpolation::kLinear;
  ExpectSame(Column(*ToDataset(Read(file), format), "x"), {0, NAN, NAN, NAN, 20}, "x");
}

TEST(Mdf4, AnUnknownTimeBaseAndAGroupWithoutMasterAreRefused) {
  const Mdf4File f = Read(TwoRates(Storage::kDt, false));
  Mdf4Format format;
  format.time_base = "medium";
  Result<std::shared_ptr<const Dataset>> r = Mdf4ToDataset(f, "run.mf4", format);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().ToString(),
            "run.mf4: time base 'medium' is neither a group (its number 1 to 2, or its name) nor a "
            "channel");
  WFile file;
  file.data_groups = {{{Group("nomaster", 2, {Float64("x", {1, 2})})}}};
  const Mdf4File g = Read(file);
  EXPECT_FALSE(g.groups[0].has_master);
  EXPECT_TRUE(ToDataset(g, {})->columns.empty());
  format = {};
  format.channels = {"x"};
  r = Mdf4ToDataset(g, "run.mf4", format);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().ToString(),
            "run.mf4: channel 'x' is in group 1 ('nomaster'), which has no master channel: its "
            "samples have no times");
}

TEST(Mdf4, GroupsOfDifferentMasterKindsAreRefusedTogether) {
  WFile file;
  WChannel angle = TimeMaster({0, 1});
  angle.sync = 2;
  file.data_groups = {{{Group("time", 2, {TimeMaster({0, 1}), Float64("x", {1, 2})})}},
                      {{Group("angle", 2, {angle, Float64("y", {1, 2})})}}};
  const Result<std::shared_ptr<const Dataset>> r = Mdf4ToDataset(Read(file), "run.mf4", {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().ToString().find("have masters of different kinds"), std::string::npos);
}

}  // namespace
}  // namespace gb::data::mdf4_test
