// The ZIP writer (core/util/zip.h), read back by readers that share no code with it: Info-ZIP's
// `unzip` and Python's `zipfile` (each test that needs one is skipped when it is missing).
#include "core/util/zip.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/util/file.h"

namespace gb {
namespace {
namespace fs = std::filesystem;

// A folder of its own under the test's temporary folder, removed with all it holds.
class ZipTestDir {
 public:
  ZipTestDir() {
    path_ = fs::path(::testing::TempDir()) /
            ("greybench-zip-" + std::to_string(::getpid()) + "-" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~ZipTestDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string Path(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

// The shell's exit status of `command` and what it printed on stdout.
struct ZipToolOutput {
  int status = -1;
  std::string out;
};

ZipToolOutput ZipRunTool(const std::string& command) {
  ZipToolOutput r;
  std::FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return r;
  char buf[1 << 14];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) r.out.append(buf, n);
  const int raw = ::pclose(pipe);
  r.status = raw != -1 && WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return r;
}

bool ZipHaveUnzip() { return std::system("command -v unzip >/dev/null 2>&1") == 0; }

bool ZipHavePython() { return std::system("python3 -c 'import zipfile' >/dev/null 2>&1") == 0; }

// A path or a name inside single quotes for the shell.
std::string ZipQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string ZipReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string ZipHex(const std::string& bytes) {
  static const char* digits = "0123456789abcdef";
  std::string hex;
  hex.reserve(2 * bytes.size());
  for (unsigned char c : bytes) {
    hex += digits[c >> 4];
    hex += digits[c & 15];
  }
  return hex;
}

// What an FMU holds and more: text that deflates well, every byte value, nothing at all, bytes
// that do not deflate (and so must be stored), and a name in folders.
std::vector<ZipEntry> ZipSampleEntries() {
  std::vector<ZipEntry> entries;
  std::string xml = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiModelDescription";
  for (int i = 0; i < 200; ++i) xml += "\n  <ScalarVariable name=\"x" + std::to_string(i) + "\"/>";
  xml += "\n</fmiModelDescription>\n";
  entries.push_back({"modelDescription.xml", xml});
  std::string every_byte;
  for (int r = 0; r < 64; ++r)
    for (int b = 0; b < 256; ++b) every_byte += static_cast<char>(b);
  entries.push_back({"every_byte.bin", every_byte});
  entries.push_back({"empty.txt", ""});
  std::mt19937 rng(20240601);
  std::string noise(8192, '\0');
  for (char& c : noise) c = static_cast<char>(rng() & 0xFF);
  entries.push_back({"noise.bin", noise});
  entries.push_back({"binaries/linux64/x.so",
                     "\x7f"
                     "ELF\x02\x01\x01" +
                         every_byte.substr(0, 600)});
  return entries;
}

TEST(Zip, UnzipReadsBackEveryEntryBitForBit) {
  if (!ZipHaveUnzip()) GTEST_SKIP() << "unzip is not installed";
  ZipTestDir dir;
  const std::string archive = dir.Path("model.fmu");
  const std::vector<ZipEntry> entries = ZipSampleEntries();
  const Status st = WriteZipFile(archive, entries);
  ASSERT_TRUE(st.ok()) << st.error().ToString();
  const ZipToolOutput test = ZipRunTool("unzip -t " + ZipQuote(archive) + " 2>&1");
  EXPECT_EQ(test.status, 0) << test.out;
  EXPECT_NE(test.out.find("No errors detected"), std::string::npos) << test.out;
  for (const ZipEntry& e : entries) {
    const ZipToolOutput back = ZipRunTool("unzip -p " + ZipQuote(archive) + " " + ZipQuote(e.name));
    EXPECT_EQ(back.status, 0) << e.name;
    EXPECT_TRUE(back.out == e.bytes) << e.name << ": " << back.out.size() << " bytes read back, "
                                     << e.bytes.size() << " written";
  }
}

TEST(Zip, PythonReadsBackEveryEntryWithItsMethodModeTimeAndUtf8Name) {
  if (!ZipHavePython()) GTEST_SKIP() << "python3 with zipfile is not installed";
  ZipTestDir dir;
  const std::string archive = dir.Path("model.fmu");
  std::vector<ZipEntry> entries = ZipSampleEntries();
  entries.push_back({"r\xc3\xa9sum\xc3\xa9/\xce\xb8.txt", "theta"});  // "résumé/θ.txt"
  const Status st = WriteZipFile(archive, entries);
  ASSERT_TRUE(st.ok()) << st.error().ToString();
  // One line an entry: name, method, mode, flags, time, system, contents in hex; then testzip's.
  const std::string script = dir.Path("read.py");
  std::ofstream(script)
      << "import sys, zipfile\n"
         "with zipfile.ZipFile(sys.argv[1]) as z:\n"
         "    for i in z.infolist():\n"
         "        print(i.filename, i.compress_type, oct(i.external_attr >> 16),\n"
         "              hex(i.flag_bits), '%d-%d-%d-%d-%d-%d' % i.date_time,\n"
         "              i.create_system, i.create_version, i.extract_version,\n"
         "              z.read(i).hex() or '-', sep='\\t')\n"
         "    print('testzip', z.testzip())\n";
  const ZipToolOutput r =
      ZipRunTool("python3 " + ZipQuote(script) + " " + ZipQuote(archive) + " 2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  std::istringstream lines(r.out);
  std::string line;
  for (const ZipEntry& e : entries) {
    ASSERT_TRUE(std::getline(lines, line)) << "no line for " << e.name;
    std::istringstream fields(line);
    std::vector<std::string> f;
    for (std::string field; std::getline(fields, field, '\t');) f.push_back(field);
    ASSERT_EQ(f.size(), 9u) << line;
    EXPECT_EQ(f[0], e.name);
    const bool must_store = e.name == "noise.bin" || e.name == "empty.txt";
    const bool must_deflate = e.name == "modelDescription.xml" || e.name == "every_byte.bin";
    if (must_store) {
      EXPECT_EQ(f[1], "0") << e.name << " is stored";
    }
    if (must_deflate) {
      EXPECT_EQ(f[1], "8") << e.name << " is deflated";
    }
    EXPECT_EQ(f[2], "0o100644") << e.name;
    EXPECT_EQ(f[3], "0x800") << e.name;
    EXPECT_EQ(f[4], "1980-1-1-0-0-0") << e.name;
    EXPECT_EQ(f[5], "3") << e.name;
    EXPECT_EQ(f[6], "20") << e.name;
    EXPECT_EQ(f[7], "20") << e.name;
    EXPECT_TRUE(f[8] == (e.bytes.empty() ? "-" : ZipHex(e.bytes))) << e.name;
  }
  ASSERT_TRUE(std::getline(lines, line));
  EXPECT_EQ(line, "testzip None");
  EXPECT_FALSE(std::getline(lines, line)) << "an entry too many: " << line;
}

TEST(Zip, TheSameEntriesGiveTheSameBytesTwiceAndTheFileHoldsThem) {
  ZipTestDir dir;
  const std::vector<ZipEntry> entries = ZipSampleEntries();
  const Result<std::string> first = ZipArchive(entries);
  const Result<std::string> second = ZipArchive(entries);
  ASSERT_TRUE(first.ok()) << first.error().ToString();
  ASSERT_TRUE(second.ok()) << second.error().ToString();
  EXPECT_TRUE(*first == *second);
  EXPECT_EQ(first->substr(0, 4), std::string("PK\x03\x04"));
  const std::string archive = dir.Path("a.zip");
  ASSERT_TRUE(WriteZipFile(archive, entries).ok());
  EXPECT_TRUE(ZipReadFile(archive) == *first);
  ASSERT_TRUE(WriteZipFile(archive, entries).ok());  // replaced by the same bytes
  EXPECT_TRUE(ZipReadFile(archive) == *first);
}

TEST(Zip, AnArchiveOfNoEntriesIsTheEndRecordAlone) {
  const Result<std::string> empty = ZipArchive({});
  ASSERT_TRUE(empty.ok());
  EXPECT_EQ(*empty, std::string("PK\x05\x06", 4) + std::string(18, '\0'));
}

TEST(Zip, EachBadNameIsRefusedWithAnErrorNamingTheEntry) {
  struct Case {
    std::vector<ZipEntry> entries;
    std::string expected;  // in the message
  };
  const std::vector<Case> cases = {
      {{{"a.txt", "a"}, {"", "b"}}, "zip entry number 2: its name is empty"},
      {{{"/etc/passwd", "x"}}, "zip entry \"/etc/passwd\": its name starts with '/'"},
      {{{"binaries/../../x.so", "x"}},
       "zip entry \"binaries/../../x.so\": its name contains \"..\""},
      {{{"a.txt", "a"}, {"b.txt", "b"}, {"a.txt", "c"}},
       "zip entry \"a.txt\": the name is also that of entry number 1"},
      {{{std::string(65536, 'n'), "x"}}, "its name has 65536 bytes"},
  };
  ZipTestDir dir;
  const std::string archive = dir.Path("bad.zip");
  for (const Case& c : cases) {
    const Result<std::string> bytes = ZipArchive(c.entries);
    ASSERT_FALSE(bytes.ok()) << c.expected;
    EXPECT_EQ(bytes.error().kind, ErrorKind::kInput);
    EXPECT_NE(bytes.error().message.find(c.expected), std::string::npos) << bytes.error().message;
    const Status st = WriteZipFile(archive, c.entries);
    ASSERT_FALSE(st.ok()) << c.expected;
    EXPECT_EQ(st.error().file, archive);
    EXPECT_NE(st.error().ToString().find(c.expected), std::string::npos) << st.error().ToString();
    EXPECT_FALSE(fs::exists(archive)) << c.expected;
  }
  // The longest name there can be is fine.
  const std::vector<ZipEntry> longest = {{std::string(65535, 'n'), "x"}};
  EXPECT_TRUE(ZipArchive(longest).ok());
}

TEST(Zip, AnArchiveHoldsAtMost65534EntriesWithoutZip64) {
  std::vector<ZipEntry> entries(65534);
  for (std::size_t i = 0; i < entries.size(); ++i) entries[i].name = "f" + std::to_string(i);
  const Result<std::string> most = ZipArchive(entries);
  ASSERT_TRUE(most.ok()) << most.error().ToString();
  // The end record counts them all (twice) in its 16-bit fields.
  const std::string end = most->substr(most->size() - 22);
  EXPECT_EQ(end.substr(8, 4), std::string("\xfe\xff\xfe\xff"));
  entries.push_back({"one-too-many", ""});
  const Result<std::string> over = ZipArchive(entries);
  ASSERT_FALSE(over.ok());
  EXPECT_NE(over.error().message.find("at most 65534 entries, not 65535"), std::string::npos)
      << over.error().message;
}

TEST(Zip, WritingIntoAFolderThatDoesNotExistGivesAnErrorNamingTheFile) {
  ZipTestDir dir;
  const std::string archive = dir.Path("no-such-folder/model.fmu");
  const Status st = WriteZipFile(archive, ZipSampleEntries());
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().file, archive);
  EXPECT_EQ(st.error().ToString().rfind(archive + ": ", 0), 0u) << st.error().ToString();
  EXPECT_NE(st.error().message.find("No such file or directory"), std::string::npos)
      << st.error().message;
  EXPECT_FALSE(fs::exists(dir.Path("no-such-folder")));
}

}  // namespace
}  // namespace gb
