// libFuzzer target: the whole command line (gb::cli::Main, app/cli/main.cpp) in one process, with
// random combinations of every subcommand's options, hostile values and a fixed set of paths,
// outputs equal to inputs among them (issue 32).
//
// The input is text: words separated by white space. The first word chooses the subcommand, each
// later one a token of that subcommand's vocabulary: its options, the values of kValues, and the
// paths of kPaths (written @lin, @data, ...), which name files this target makes once, at start-up,
// in a private temporary directory:
//   @lin      a tiny linear model (the fuel film, tests/data/cli/fuel.json)
//   @nonlin   a tiny nonlinear model of the same inputs and outputs (for the EKF; two free
//             parameters, so that its fits take well under the -timeout under the sanitizers)
//   @data     40 rows the two models fit (tests/data/cli/fuel.csv), tagged as an operating point
//   @data2    the same rows at another operating point (sweep)
//   @result   a result file, `estimate @lin @data` at start-up
//   @project  a project naming @lin, @data and its diagram @diagram (assets/diagrams/fuel_film)
//   @missing  a path that does not exist;  @folder  a directory
//   @null     a null device: a node of our own in the directory where we may make one (as root),
//             else /dev/null
// A word outside the vocabulary stands for the token its hash picks, so every input is a command
// line and no fuzzed text ever becomes a path (a fuzzed --out could name any file).
// The seed corpus (tests/fuzz/corpus/cli/) holds command lines in this form, one a file; cli.dict
// lists the vocabulary.
//
// After every run, each of these must hold, or the target aborts (libFuzzer saves the input;
// with CLI_FUZZ_SURVEY=1 in the environment it prints each kind of failure once and goes on;
// CLI_FUZZ_ECHO=1 prints each command line before it runs):
//   - the exit status is 0, 1 or 2;
//   - every file of the set is byte for byte as before, except one the command line names as an
//     output (--out, --out-csv, --out-md, --states, --checkpoint) and does not also read; the null
//     device is still a character device;
//   - a run that succeeds (exit 0) names no file both as an input and as an output, nor as two
//     outputs (the null device aside);
//   - nothing is left in the directory but the set and the outputs named (no temporaries), nor in
//     the working directory, where a word of the vocabulary given as an output (--out 2) lands.
// Then the set is restored and the outputs removed, so that every run starts from the same files.
// A hang is libFuzzer's -timeout (scripts/fuzz.sh); stdout and stderr of the command go to
// /dev/null (stdout and stderr are swapped for a FILE* on /dev/null during the call, so libFuzzer's
// own messages and the sanitizers' reports still reach the log).
//
// Left out, because they run without end by design: `monitor -` (rows from standard input, which
// is /dev/null here anyway) and `dyno --live` (a live stream until it is stopped). For the same
// reason a `monitor --follow` without --idle is given `--idle 0.05` (without it, following a file
// never ends, as the help says), and command lines that ask for legitimately long work are not run
// (LegitimatelyLong: `monitor --idle` of more than 1 s, `bench --repeat` of more than 100, `sweep`
// of more than 3 data files, a fit each). The known hangs of issue 32 (--multistart 1000000000,
// monitor --idle 0, ...) are not hidden.
//
// Sections: 1. the vocabulary  2. the fixture  3. one command line (decode, run, check)
#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include "app/cli/cli.h"
#include "core/util/json.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

namespace fs = std::filesystem;

// ---- 1. the vocabulary -------------------------------------------------------------------------

struct Command {
  const char* name;
  std::vector<const char*> options;
};

// Every subcommand and every option of app/cli/main.cpp (--live of dyno left out: see above).
const std::vector<Command>& Commands() {
  static const std::vector<Command> kCommands = {
      {"loglik", {"--set", "--gradient"}},
      {"bench", {"--set", "--repeat"}},
      {"simulate", {"--inputs", "--set", "--seed", "--out"}},
      {"prbs",
       {"--order", "--period", "--ts", "--duration", "--low", "--high", "--name", "--seed",
        "--out"}},
      {"estimate",
       {"--set", "--out", "--start", "--steady-start", "--steady-window", "--threads",
        "--multistart", "--starts-on-bound", "--progress", "--checkpoint", "--score-differences",
        "--max-evaluations", "--algorithm", "--ftol", "--profile-intervals", "--profile-level"}},
      {"compare", {}},
      {"predict", {"--set", "--result", "--out", "--simulate-after", "--states"}},
      {"diagnose", {"--set", "--result", "--max-lag", "--lb-lags", "--out"}},
      {"export-model", {"--out"}},
      {"monitor",
       {"--reference", "--follow", "--set", "--forgetting", "--track", "--false-alarms", "--change",
        "--idle", "--every", "--out"}},
      {"dyno",
       {"--point", "--path", "--hold", "--ramp", "--sample-time", "--hold-speed",
        "--throttle-amplitude", "--duration", "--seed", "--order", "--bit-period", "--no-filter",
        "--oversample", "--lambda-sensor", "--constant-load", "--out", "--speed", "--fault",
        "--truth"}},
      {"linearise", {"--point", "--model", "--quantity", "--out"}},
      {"sweep", {"--set", "--out-csv", "--out-md", "--trend", "--delay-parameter", "--parallel"}},
      {"report", {"--model", "--data", "--dataset", "--format", "--out"}},
  };
  return kCommands;
}

// Values for any option or positional: numbers at and beyond the edges, the empty string (written
// ""), text that is no number, and the words some options take.
const std::vector<std::string>& Values() {
  static const std::vector<std::string> kValues = {
      "0", "-1", "1", "2", "1e308", "-1e308", "nan", "inf", "-inf", "\"\"", "1e9", "0.5",
      "1000000000", "x!y", "-", "--help",
      // --set, --point, --quantity, --track, --trend, --delay-parameter
      "tau_fv=0.1", "X=nan", "Kb=1e308", "s2=-1", "nope=1", "X=", "mfi=1", "mfi=1,ilambda=0.5",
      "mfv=0.2", "g=B_mfv_mfi", "q=A_mfv_mfv/0", "X", "tau_fv,X", "X:alpha_deg", "nope:tag",
      "tau_fv",
      // --algorithm, dyno's experiments, --point, --path, --lambda-sensor, --fault
      "bhhh", "slsqp", "lbfgs", "bobyqa", "auto", "trust-region", "fuel", "crankshaft",
      "square-wave", "engine", "f1", "f3", "n=2600,alpha=25", "f3,f1", "exact", "pade",
      "1:tau_ff*1.5",
      // report's --format
      "md", "html", "HTML", "pdf"};
  return kValues;
}

struct PathToken {
  const char* token;
  const char* file;  // in the fixture's directory
};
const std::vector<PathToken>& Paths() {
  static const std::vector<PathToken> kPaths = {
      {"@lin", "lin.json"},         {"@nonlin", "nonlin.json"},
      {"@data", "data.csv"},        {"@data2", "data2.csv"},
      {"@result", "result.json"},   {"@project", "project.json"},
      {"@diagram", "diagram.json"}, {"@missing", "missing.csv"},
      {"@folder", "folder"},        {"@null", "null"}};
  return kPaths;
}

// The options that name a file to write, and those that name a file to read. A path after any
// other option that takes a value (--name, --set, ...) is text to the command, not a file; a
// path anywhere else is a positional argument: a file to read.
const std::set<std::string>& OutputOptions() {
  static const std::set<std::string> kOut = {"--out", "--out-csv", "--out-md", "--states",
                                             "--checkpoint"};
  return kOut;
}
const std::set<std::string>& InputOptions() {
  static const std::set<std::string> kIn = {"--inputs",    "--start",  "--result",
                                            "--reference", "--follow", "--model"};
  return kIn;
}
const std::set<std::string>& Flags() {
  static const std::set<std::string> kFlags = {"--gradient",
                                               "--steady-start",
                                               "--progress",
                                               "--score-differences",
                                               "--profile-intervals",
                                               "--hold-speed",
                                               "--no-filter",
                                               "--constant-load",
                                               "--truth",
                                               "--help"};
  return kFlags;
}

// ---- 2. the fixture ----------------------------------------------------------------------------

struct Fixture {
  fs::path dir;
  std::map<std::string, std::string> files;  // file name -> its bytes
  std::string null_device;                   // what @null names
  bool own_null = false;                     // a device node of our own (made as root)
  std::FILE* devnull = nullptr;              // where the commands' stdout and stderr go
  fs::path cwd;  // the working directory (libFuzzer's paths are relative to it)
  // The words of the vocabulary that name no file in it at start-up: a command given one as an
  // output (--out 2) writes a file of that name there.
  std::vector<std::string> relative_names;
};

Fixture& TheFixture() {
  static Fixture fixture;  // set once by LLVMFuzzerInitialize
  return fixture;
}

void RemoveFixture() {
  std::error_code ec;
  fs::remove_all(TheFixture().dir, ec);
}

std::string ReadBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void WriteBytes(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  FUZZ_CHECK(out.good());
}

std::string Resolve(const std::string& file) {
  const Fixture& f = TheFixture();
  if (file == "null") return f.null_device;
  return (f.dir / file).string();
}

// Runs gb::cli::Main on `args` (without the program name) with stdout and stderr discarded.
int RunCli(const std::vector<std::string>& args) {
  std::vector<std::string> argv_storage = {"greybench-cli"};
  argv_storage.insert(argv_storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_storage) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::FILE* const out = stdout;
  std::FILE* const err = stderr;
  std::fflush(out);
  std::fflush(err);
  stdout = TheFixture().devnull;
  stderr = TheFixture().devnull;
  const int rc = gb::cli::Main(static_cast<int>(argv.size()) - 1, argv.data());
  std::fflush(TheFixture().devnull);
  stdout = out;
  stderr = err;
  return rc;
}

const char* kNonlinearModel = R"json({
  "greybench_model": 1,
  "name": "Fuel film with a saturating wall film (cli_fuzz)",
  "states": ["mfv", "mff"],
  "inputs": ["mfi"],
  "outputs": ["ilambda"],
  "parameters": {
    "tau_fv": {"value": 0.075, "fixed": true},
    "tau_ff": {"value": 0.375, "lower": 0.01, "upper": 5.0},
    "X": {"value": 0.175, "fixed": true},
    "Kb": {"value": 0.8421, "fixed": true},
    "s11": {"value": 1.098e-3, "fixed": true},
    "s12": {"value": 3.91e-4, "fixed": true},
    "s2": {"value": 1.257e-4, "lower": 0}
  },
  "drift": {"mfv": "(-mfv + (1 - X)*mfi)/tau_fv", "mff": "(-tanh(mff) + X*mfi)/tau_ff"},
  "diffusion": {"mfv": "sqrt(s11)", "mff": "sqrt(s12)"},
  "observation": {"ilambda": "Kb*(mfv + mff)"},
  "measurement_variance": {"ilambda": "s2"},
  "initial_state": {"mfv": "0", "mff": "0"}
}
)json";

const char* kProject = R"json({
  "greybench_project": 1,
  "name": "cli_fuzz",
  "model": "lin.json",
  "datasets": ["data.csv"],
  "diagram": "diagram.json"
}
)json";

void MakeFixture() {
  Fixture& f = TheFixture();
  char pattern[] = "/tmp/greybench-cli-fuzz-XXXXXX";
  FUZZ_CHECK(mkdtemp(pattern) != nullptr);
  f.dir = pattern;
  std::atexit(RemoveFixture);
  const fs::path source = GREYBENCH_SOURCE_DIR;
  const std::string rows = ReadBytes(source / "tests/data/cli/fuel.csv");
  WriteBytes(f.dir / "lin.json", ReadBytes(source / "tests/data/cli/fuel.json"));
  WriteBytes(f.dir / "nonlin.json", kNonlinearModel);
  WriteBytes(f.dir / "data.csv",
             "# greybench: {\"operating_point\": {\"name\": \"p1\", \"n_rpm\": 2000, "
             "\"alpha_deg\": 20}}\n" +
                 rows);
  WriteBytes(f.dir / "data2.csv",
             "# greybench: {\"operating_point\": {\"name\": \"p2\", \"n_rpm\": 3000, "
             "\"alpha_deg\": 30}}\n" +
                 rows);
  WriteBytes(f.dir / "diagram.json", ReadBytes(source / "assets/diagrams/fuel_film.json"));
  WriteBytes(f.dir / "project.json", kProject);
  fs::create_directory(f.dir / "folder");
  // A null device of our own when we may make one: written by rename, /dev/null itself would be
  // replaced by a regular file (issue 32), for every process on the machine. Otherwise rename
  // over /dev/null fails for want of permission, and /dev/null is safe to name.
  f.null_device = "/dev/null";
  if (mknod((f.dir / "null").c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0) {
    f.null_device = (f.dir / "null").string();
    f.own_null = true;
  }
  f.devnull = std::fopen("/dev/null", "w");
  FUZZ_CHECK(f.devnull != nullptr);
  f.cwd = fs::current_path();
  std::error_code ec;
  std::set<std::string> words(Values().begin(), Values().end());
  for (const auto& c : Commands()) words.insert(c.options.begin(), c.options.end());
  for (const auto& w : words)
    if (!w.empty() && w.find('/') == std::string::npos && w != "\"\"" &&
        !fs::exists(fs::symlink_status(f.cwd / w, ec)))
      f.relative_names.push_back(w);
  const int rc = RunCli(
      {"estimate", Resolve("lin.json"), Resolve("data.csv"), "--out", Resolve("result.json")});
  FUZZ_CHECK(rc == 0);
  for (const char* name : {"lin.json", "nonlin.json", "data.csv", "data2.csv", "diagram.json",
                           "project.json", "result.json"})
    f.files[name] = ReadBytes(f.dir / name);
}

bool IsCharDevice(const std::string& path) {
  struct stat st {};
  return lstat(path.c_str(), &st) == 0 && S_ISCHR(st.st_mode);
}

// ---- 3. one command line -----------------------------------------------------------------------

struct CommandLine {
  std::vector<std::string> args;        // as given to Main
  std::set<std::string> inputs;         // fixture files named in input positions
  std::set<std::string> outputs;        // file names given to an output option
  std::vector<std::string> output_seq;  // in order, repeats kept
  int positionals = 0;                  // words that are neither options nor their values
};

std::size_t Hash(std::string_view word) { return std::hash<std::string_view>{}(word); }

CommandLine Decode(const std::uint8_t* data, std::size_t size) {
  constexpr std::size_t kMaxTokens = 24;
  std::vector<std::string> words;
  std::string word;
  for (std::size_t i = 0; i <= size; ++i) {
    const char c = i < size ? static_cast<char>(data[i]) : ' ';
    if (c == ' ' || c == '\n' || c == '\t' || c == '\r') {
      if (!word.empty()) words.push_back(word);
      word.clear();
      if (words.size() > kMaxTokens) break;
    } else {
      word += c;
    }
  }
  CommandLine cl;
  const auto& commands = Commands();
  if (words.empty()) words.push_back("");
  const Command* command = nullptr;
  for (const auto& c : commands)
    if (words[0] == c.name) command = &c;
  if (!command) command = &commands[Hash(words[0]) % commands.size()];
  cl.args.push_back(command->name);

  std::vector<std::string> vocabulary;
  for (const char* o : command->options) vocabulary.push_back(o);
  for (const auto& v : Values()) vocabulary.push_back(v);
  for (const auto& p : Paths()) vocabulary.push_back(p.token);

  std::string previous;
  for (std::size_t i = 1; i < words.size() && i <= kMaxTokens; ++i) {
    std::string token = words[i];
    if (std::find(vocabulary.begin(), vocabulary.end(), token) == vocabulary.end())
      token = vocabulary[Hash(token) % vocabulary.size()];
    std::string arg = token == "\"\"" ? "" : token;
    const bool after_value_option = previous.rfind("--", 0) == 0 && !Flags().count(previous);
    if (!after_value_option && token.rfind("--", 0) != 0) ++cl.positionals;
    for (const auto& p : Paths()) {
      if (token != p.token) continue;
      arg = Resolve(p.file);
      if (OutputOptions().count(previous)) {
        cl.outputs.insert(p.file);
        cl.output_seq.push_back(p.file);
      } else if (!after_value_option || InputOptions().count(previous)) {
        cl.inputs.insert(p.file);
      }
    }
    // Any other word after an output option names a file in the working directory ("-" is
    // stdout only for monitor and dyno --live; a command may take "--out" for a file name).
    if (OutputOptions().count(previous) && token[0] != '@') {
      cl.outputs.insert(arg);
      cl.output_seq.push_back(arg);
    }
    cl.args.push_back(arg);
    // A word taken as an option's value is not an option itself, even when it reads like one
    // (`--out --states --states F` writes the file "--states" and F: not one output twice).
    previous = after_value_option ? std::string() : token;
  }
  // A project is read with its diagram (export-model).
  if (cl.inputs.count("project.json")) cl.inputs.insert("diagram.json");
  return cl;
}

std::string ValueOf(const CommandLine& cl, const std::string& option) {
  for (std::size_t i = 0; i + 1 < cl.args.size(); ++i)
    if (cl.args[i] == option) return cl.args[i + 1];
  return "";
}

bool Has(const CommandLine& cl, const std::string& arg) {
  return std::find(cl.args.begin(), cl.args.end(), arg) != cl.args.end();
}

// A number the option's text reads as (strtod's reading; "" and text: none).
bool Number(const std::string& text, double* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return end && *end == '\0';
}

// Command lines that are long or endless by design (see the head of the file).
bool LegitimatelyLong(CommandLine* cl) {
  const std::string command = cl->args[0];
  double v = 0;
  if (command == "monitor") {
    if (Has(*cl, "-")) return true;  // rows from standard input
    if (Has(*cl, "--follow") && !Has(*cl, "--idle")) {
      cl->args.push_back("--idle");
      cl->args.push_back("0.05");
    }
    if (Number(ValueOf(*cl, "--idle"), &v) && v > 1) return true;
  }
  if (command == "bench" && Number(ValueOf(*cl, "--repeat"), &v) && v > 100) return true;
  // A fit per data file, each slow under the sanitizers: more than 3 files outlast -timeout
  // (docs/benchmarks.md, "Timings behind the code's limits").
  if (command == "sweep" && cl->positionals > 4) return true;
  return false;
}

void Report(const CommandLine& cl, const std::string& what) {
  std::string text;  // with the paths written as their tokens (@lin, ...)
  for (const auto& a : cl.args) {
    std::string word = a.empty() ? "''" : a;
    for (const auto& p : Paths())
      if (a == Resolve(p.file)) word = p.token;
    text += " " + word;
  }
  std::fprintf(stderr, "cli_fuzz: %s\n  command line: greybench-cli%s\n", what.c_str(),
               text.c_str());
}

// Checks the properties of the head of the file after a run, and restores the fixture.
void CheckAndRestore(const CommandLine& cl, int rc) {
  Fixture& f = TheFixture();
  std::vector<std::string> problems;
  if (rc != 0 && rc != 1 && rc != 2) problems.push_back("exit status " + std::to_string(rc));

  for (const auto& [name, bytes] : f.files) {
    const fs::path p = f.dir / name;
    std::error_code ec;
    const bool regular = fs::is_regular_file(fs::symlink_status(p, ec));
    if (regular && ReadBytes(p) == bytes) continue;
    const bool asked = cl.outputs.count(name) > 0;
    if (!asked)
      problems.push_back(name + (regular ? " changed" : " is gone or no longer a file") +
                         ", though the command line names it as no output");
    else if (cl.inputs.count(name))
      problems.push_back(name + " is both an input and an output, and was " +
                         (regular ? "overwritten" : "replaced"));
    fs::remove_all(p, ec);
    WriteBytes(p, bytes);
  }
  if (f.own_null && !IsCharDevice(f.null_device)) {
    problems.push_back("the null device was replaced by something else");
    std::error_code ec;
    fs::remove_all(f.null_device, ec);
    FUZZ_CHECK(mknod(f.null_device.c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0);
  }
  if (!f.own_null) FUZZ_CHECK(IsCharDevice("/dev/null"));

  // (--help prints the help and runs nothing.)
  if (rc == 0 && !Has(cl, "--help")) {
    for (const std::string& out : cl.outputs) {
      if (out == "null" || out == "folder") continue;
      if (cl.inputs.count(out)) problems.push_back("exit 0 with " + out + " as input and output");
      if (std::count(cl.output_seq.begin(), cl.output_seq.end(), out) > 1)
        problems.push_back("exit 0 with " + out + " as two outputs");
    }
  }

  // Anything new in the directory must be an output the command line names; outputs are removed.
  std::vector<fs::path> extra;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(f.dir, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    const fs::path rel = it->path().lexically_relative(f.dir);
    const std::string name = rel.string();
    if (f.files.count(name) || name == "folder" || (f.own_null && name == "null")) continue;
    if (!cl.outputs.count(name) && !cl.outputs.count(it->path().string()))
      problems.push_back(name + " is left behind, though no option names it");
    extra.push_back(it->path());
  }
  for (const auto& name : f.relative_names) {
    if (!fs::exists(fs::symlink_status(f.cwd / name, ec))) continue;
    if (!cl.outputs.count(name))
      problems.push_back("./" + name + " is left behind, though no option names it");
    extra.push_back(f.cwd / name);
  }
  for (const auto& p : extra) fs::remove_all(p, ec);

  if (problems.empty()) return;
  // CLI_FUZZ_SURVEY=1: each kind of failed property is printed once and the run goes on (a survey
  // of what the command line gets wrong; crashes, hangs and sanitizer reports still stop it).
  if (std::getenv("CLI_FUZZ_SURVEY")) {
    static std::set<std::string> seen;
    for (const auto& p : problems)
      if (seen.insert(cl.args[0] + ": " + p).second) Report(cl, p);
    return;
  }
  std::string all;
  for (const auto& p : problems) all += (all.empty() ? "" : "; ") + p;
  Report(cl, all);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // Nothing a command reads from standard input may wait for a terminal.
  const int null_fd = open("/dev/null", O_RDONLY);
  FUZZ_CHECK(null_fd >= 0 && dup2(null_fd, 0) == 0);
  close(null_fd);
  MakeFixture();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  CommandLine cl = Decode(data, size);
  if (LegitimatelyLong(&cl)) return 0;
  // A relative output that names a file already in the working directory (not ours) is not run.
  for (const std::string& out : cl.outputs) {
    std::error_code ec;
    if (!out.empty() && out.find('/') == std::string::npos &&
        fs::exists(fs::symlink_status(TheFixture().cwd / out, ec)))
      return 0;
  }
  // CLI_FUZZ_ECHO=1: each command line is printed before it runs (to read what a hang ran).
  if (std::getenv("CLI_FUZZ_ECHO")) Report(cl, "running");
  const int rc = RunCli(cl.args);
  CheckAndRestore(cl, rc);
  return 0;
}
