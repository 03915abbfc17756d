// The output guard (core/util/output_guard.h) and how WriteFileAtomic treats what is not a
// regular file (core/project/project.h).
#include "core/util/output_guard.h"

#include <filesystem>
#include <fstream>
#include <future>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/util/file.h"
#include "core/util/json.h"

namespace gb {
namespace {
namespace fs = std::filesystem;

class OutputGuard : public ::testing::Test {
 protected:
  void SetUp() override {
    static int counter = 0;
    dir_ = fs::temp_directory_path() /
           ("greybench-guard-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "sub");
    Write("model.json", "{\"model\": 1}\n");
    Write("data.csv", "t,y\n0,1\n");
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  void Write(const std::string& name, const std::string& text) const {
    std::ofstream(dir_ / name, std::ios::binary) << text;
  }
  std::string Read(const std::string& name) const {
    std::ifstream in(dir_ / name, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  // The guard's verdict on one output against the model and data files.
  Status Check(const std::string& out) const {
    return CheckOutputs(
        {{Path("model.json"), "the model file"}, {Path("data.csv"), "the data file"}},
        {{out, "--out"}});
  }

  fs::path dir_;
};

TEST_F(OutputGuard, AnOutputThatIsAnInputByAnyNameIsRefusedNamingBoth) {
  fs::create_symlink(Path("model.json"), Path("link.json"));
  fs::create_hard_link(Path("data.csv"), Path("hard.csv"));
  for (const std::string& alias : {Path("model.json"), Path("sub/../model.json"), Path("link.json"),
                                   Path("hard.csv"), (dir_ / "." / "data.csv").string()}) {
    const Status st = Check(alias);
    ASSERT_FALSE(st.ok()) << alias;
    EXPECT_NE(st.error().message.find("--out " + alias), std::string::npos) << st.error().message;
    EXPECT_NE(st.error().message.find("would destroy that input"), std::string::npos);
  }
  EXPECT_NE(Check(Path("link.json")).error().message.find("the model file"), std::string::npos);
  EXPECT_NE(Check(Path("hard.csv")).error().message.find("the data file"), std::string::npos);
}

TEST_F(OutputGuard, NewFilesOtherFilesAndStandardOutputPass) {
  EXPECT_TRUE(Check(Path("result.json")).ok());
  EXPECT_TRUE(Check(Path("sub/result.json")).ok());
  EXPECT_TRUE(Check("").ok());
  EXPECT_TRUE(Check("-").ok());
  EXPECT_TRUE(Check("/dev/null").ok());
}

TEST_F(OutputGuard, TwoOutputsOnOneFileAreRefusedUnlessItIsADevice) {
  // Neither exists yet: the same name, spelled two ways.
  const Status st =
      CheckOutputs({}, {{Path("out.csv"), "--out"}, {Path("sub/../out.csv"), "--states"}});
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("--states"), std::string::npos);
  EXPECT_NE(st.error().message.find("--out"), std::string::npos);
  EXPECT_TRUE(CheckOutputs({}, {{Path("a.csv"), "--out"}, {Path("b.csv"), "--states"}}).ok());
  EXPECT_TRUE(CheckOutputs({}, {{"/dev/null", "--out"}, {"/dev/null", "--states"}}).ok());
}

TEST_F(OutputGuard, WritingThroughASymlinkKeepsTheLinkAndReplacesItsTarget) {
  Write("target.json", "old\n");
  fs::create_symlink(Path("target.json"), Path("via.json"));
  ASSERT_TRUE(WriteFileAtomic(Path("via.json"), "new\n").ok());
  EXPECT_TRUE(fs::is_symlink(Path("via.json")));
  EXPECT_EQ(Read("target.json"), "new\n");
}

TEST_F(OutputGuard, AFifoIsWrittenThroughNeverReplacedByAFile) {
  ASSERT_EQ(::mkfifo(Path("pipe").c_str(), 0600), 0);
  // The reader drains the FIFO while the writer writes (opening a FIFO for writing waits for one).
  auto reader = std::async(std::launch::async, [&] { return Read("pipe"); });
  ASSERT_TRUE(CheckWritable(Path("pipe")).ok());
  ASSERT_TRUE(WriteFileAtomic(Path("pipe"), "through the pipe\n").ok());
  EXPECT_EQ(reader.get(), "through the pipe\n");
  struct stat st {};
  ASSERT_EQ(::lstat(Path("pipe").c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
}

TEST_F(OutputGuard, ADeviceIsWrittenThroughAndStaysADevice) {
  // A symlink to /dev/null: replacing it by rename would put a regular file where the link is
  // (and, run as root on /dev/null itself, where the device is).
  fs::create_symlink("/dev/null", Path("null"));
  ASSERT_TRUE(CheckWritable(Path("null")).ok());
  ASSERT_TRUE(WriteFileAtomic(Path("null"), "discarded\n").ok());
  EXPECT_TRUE(fs::is_symlink(Path("null")));
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  ASSERT_TRUE(WriteFileAtomic("/dev/null", "discarded\n").ok());
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
}

}  // namespace
}  // namespace gb
