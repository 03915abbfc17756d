// NativeCode: C source from the expression graph, the system compiler, a cache folder, dlopen.
#include "core/expr/native.h"

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include <dlfcn.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/expr/internal.h"
#include "core/util/hash.h"

extern char** environ;  // NOLINT(readability-redundant-declaration): POSIX, for posix_spawnp

namespace gb::expr {
namespace {

namespace fs = std::filesystem;

// Part of every library's hash: a change of the generator's output format makes new names.
constexpr std::string_view kGeneratorVersion = "greybench-native-3";
constexpr int kMaxLogLines = 6;  // of the compiler's messages, in an error

// Helpers with Tape's arithmetic (internal.h): sign(±0) = ±0, min and max NaN-propagating,
// small integer powers as products (internal::Power).
constexpr std::string_view kPrelude = R"(#include <math.h>
static double gb_sign(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : x); }
static double gb_min(double a, double b) { return (a <= b || isnan(a)) ? a : b; }
static double gb_max(double a, double b) { return (a >= b || isnan(a)) ? a : b; }
static double gb_pow(double a, double b) {
  if (b == 2.0) return a * a;
  if (b == 3.0) return a * a * a;
  if (b == 4.0) { const double s = a * a; return s * s; }
  if (b == -1.0) return 1.0 / a;
  if (b == -2.0) return 1.0 / (a * a);
  return pow(a, b);
}
)";

std::string_view CName(Func f) {
  switch (f) {
    case Func::kExp:
      return "exp";
    case Func::kLog:
      return "log";
    case Func::kSqrt:  // the instruction, correctly rounded as the library's (no errno to set)
      return "__builtin_sqrt";
    case Func::kSin:
      return "sin";
    case Func::kCos:
      return "cos";
    case Func::kTan:
      return "tan";
    case Func::kTanh:
      return "tanh";
    case Func::kAbs:
      return "__builtin_fabs";
    case Func::kSign:
      return "gb_sign";
    case Func::kPow:
      return "gb_pow";
    case Func::kMin:
      return "gb_min";
    case Func::kMax:
      return "gb_max";
  }
  return "";
}

// The exact value as a C literal: hexadecimal floating point, in parentheses where negative.
std::string Literal(double v) {
  if (std::isnan(v)) return "(0.0 / 0.0)";
  if (std::isinf(v)) return v > 0 ? "(1.0 / 0.0)" : "(-1.0 / 0.0)";
  if (std::signbit(v)) return fmt::format("(-{:a})", -v);
  return fmt::format("{:a}", v);
}

// One program's function body: every distinct subexpression once, as `const double tN = ...;`
// in post-order (the operands before the operation, left to right, as Tape emits them).
class FunctionWriter {
 public:
  FunctionWriter(const std::function<int(const std::string&)>& slot_of, std::string* out)
      : slot_of_(slot_of), out_(out) {}

  // The operand that holds e's value: a literal, a slot or a temporary.
  Result<std::string> Operand(const Node& n) {
    switch (n.op) {
      case Op::kConst:
        return Literal(n.value);
      case Op::kVar: {
        const int slot = slot_of_(n.name);
        if (slot < 0) {
          Error e = InputError("unknown name '" + n.name + "'");
          e.expr_col = n.column;
          return e;
        }
        return fmt::format("s[{}]", slot);
      }
      default:
        break;
    }
    const int id = ids_.Of(n);
    if (id < static_cast<int>(temp_.size()) && temp_[id] >= 0) return fmt::format("t{}", temp_[id]);
    std::vector<std::string> args;
    for (const ExprPtr& a : n.args) {
      auto operand = Operand(*a);
      if (!operand) return operand.error();
      args.push_back(std::move(*operand));
    }
    std::string value;
    switch (n.op) {
      case Op::kNeg:
        value = "-" + args[0];
        break;
      case Op::kAdd:
        value = args[0] + " + " + args[1];
        break;
      case Op::kSub:
        value = args[0] + " - " + args[1];
        break;
      case Op::kMul:
        value = args[0] + " * " + args[1];
        break;
      case Op::kDiv:
        value = args[0] + " / " + args[1];
        break;
      case Op::kPow:
        value = "gb_pow(" + args[0] + ", " + args[1] + ")";
        break;
      case Op::kCall:
        value = fmt::format("{}({})", CName(n.func), fmt::join(args, ", "));
        break;
      default:
        break;
    }
    if (id >= static_cast<int>(temp_.size())) temp_.resize(static_cast<std::size_t>(id) + 1, -1);
    temp_[id] = n_temps_++;
    *out_ += fmt::format("  const double t{} = {};\n", temp_[id], value);
    return fmt::format("t{}", temp_[id]);
  }

 private:
  const std::function<int(const std::string&)>& slot_of_;
  std::string* out_;
  internal::StructuralIds ids_;
  std::vector<int> temp_;  // per id: its temporary, -1 none yet
  int n_temps_ = 0;
};

std::string Compiler() {
  for (const char* name : {"GREYBENCH_CC", "CC"}) {
    const char* v = std::getenv(name);  // NOLINT(concurrency-mt-unsafe): read, never set here
    if (v && *v) return v;
  }
  return "cc";
}

std::vector<std::string> CompilerFlags() {
  return {"-O2",
          "-fPIC",
          "-shared",
          "-ffp-contract=off",
          "-fno-fast-math",
          "-fno-builtin",
          "-fno-math-errno",
          "-std=c99",
          "-w"};
}

// The cache folder (created, mode 0700), or an error.
Result<fs::path> CacheFolder() {
  const auto env = [](const char* name) -> std::string {
    const char* v = std::getenv(name);  // NOLINT(concurrency-mt-unsafe): read, never set here
    return v ? v : "";
  };
  fs::path dir;
  if (const std::string v = env("GREYBENCH_NATIVE_CACHE"); !v.empty()) {
    dir = v;
  } else if (const std::string xdg = env("XDG_CACHE_HOME"); !xdg.empty()) {
    dir = fs::path(xdg) / "greybench" / "native";
  } else if (const std::string home = env("HOME"); !home.empty()) {
    dir = fs::path(home) / ".cache" / "greybench" / "native";
  } else {
    dir = fs::temp_directory_path() / fmt::format("greybench-native-{}", getuid());
  }
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    return NumericalError(fmt::format("native code: cannot create the cache folder {}: {}",
                                      dir.string(), ec ? ec.message() : "not a folder"));
  }
  fs::permissions(dir, fs::perms::owner_all, fs::perm_options::replace, ec);
  return dir;
}

// The first lines of the compiler's messages.
std::string FirstLines(const fs::path& log) {
  std::ifstream in(log);
  std::string line, text;
  for (int i = 0; i < kMaxLogLines && std::getline(in, line); ++i) text += "\n  " + line;
  return text;
}

}  // namespace

Status RunCCompiler(const fs::path& source, const fs::path& output,
                    std::span<const std::string> flags, const fs::path& log,
                    const std::string& what, bool* ran) {
  *ran = false;
  std::vector<std::string> args{Compiler()};
  args.insert(args.end(), flags.begin(), flags.end());
  args.insert(args.end(), {"-o", output.string(), source.string(), "-lm"});
  std::vector<char*> argv;
  argv.reserve(args.size() + 1);
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    return NumericalError(fmt::format("cannot run the C compiler '{}': {}", args[0],
                                      std::error_code(spawned, std::generic_category()).message()));
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return NumericalError("lost the C compiler's process");
  }
  *ran = true;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    return NumericalError(
        fmt::format("the C compiler '{}' failed on {}:{}", args[0], what, FirstLines(log)));
  }
  return Ok();
}

bool NativeCode::Enabled() {
  const char* v = std::getenv("GREYBENCH_NATIVE");  // NOLINT(concurrency-mt-unsafe): read only
  return !(v && (std::string_view(v) == "0" || std::string_view(v) == "off"));
}

Result<std::string> NativeCode::Source(std::span<const Program> programs,
                                       const std::function<int(const std::string&)>& slot_of) {
  std::string source(kPrelude);
  for (std::size_t p = 0; p < programs.size(); ++p) {
    const Program& program = programs[p];
    assert((program.positions.empty() || program.positions.size() == program.exprs.size()) &&
           "NativeCode: one position per expression");
    source +=
        fmt::format("\nvoid gb_program_{}(const double* restrict s, double* restrict o) {{\n", p);
    FunctionWriter writer(slot_of, &source);
    for (std::size_t i = 0; i < program.exprs.size(); ++i) {
      auto operand = writer.Operand(*program.exprs[i]);
      if (!operand) return operand.error();
      const std::size_t at = program.positions.empty() ? i : program.positions[i];
      source += fmt::format("  o[{}] = {};\n", at, *operand);
    }
    source += "}\n";
  }
  return source;
}

Result<std::shared_ptr<const NativeCode>> NativeCode::Compile(
    std::span<const Program> programs, const std::function<int(const std::string&)>& slot_of) {
  auto source = Source(programs, slot_of);
  if (!source) return source.error();
  auto dir = CacheFolder();
  if (!dir) return dir.error();
  std::string key = std::string(kGeneratorVersion) + "\n" + Compiler();
  for (const std::string& f : CompilerFlags()) key += " " + f;
  key += "\n" + *source;
  const fs::path library = *dir / fmt::format("gb-{:016x}.so", Fnv1a(key));

  std::shared_ptr<NativeCode> code(new NativeCode());
  std::error_code ec;
  if (fs::exists(library, ec)) {
    code->cached_ = true;
  } else {
    // A name of this process's own for the source, the log and the library being written.
    static std::atomic<int> counter{0};
    const std::string own = fmt::format("{}.{}.{}", library.stem().string(), getpid(), counter++);
    const fs::path c_file = *dir / (own + ".c");
    const fs::path log = *dir / (own + ".log");
    const fs::path partial = *dir / (own + ".so.part");
    {
      std::ofstream out(c_file, std::ios::binary);
      out << *source;
      if (!out.flush()) return NumericalError("native code: cannot write " + c_file.string());
    }
    // Where a compiler that ran failed, its source stays for a reader (and a bug report) as
    // gb-HASH.failed.c; where it works, the source stays beside its library as gb-HASH.c.
    fs::path failed = library;
    failed.replace_extension(".failed.c");
    bool ran = false;
    Status built =
        RunCCompiler(c_file, partial, CompilerFlags(), log,
                     fmt::format("the model's generated C (kept as {})", failed.string()), &ran);
    if (!built) built = NumericalError("native code: " + built.error().message);
    fs::remove(log, ec);
    fs::remove(failed, ec);
    if (!built) {
      if (ran) fs::rename(c_file, failed, ec);
      if (!ran || ec) fs::remove(c_file, ec);
      fs::remove(partial, ec);
      return built.error();
    }
    fs::path kept = library;
    fs::rename(c_file, kept.replace_extension(".c"), ec);
    if (ec) fs::remove(c_file, ec);
    fs::rename(partial, library, ec);  // atomic: another process may have put the same one there
    if (ec) {
      fs::remove(partial, ec);
      if (!fs::exists(library))
        return NumericalError("native code: cannot move the library into " + dir->string());
    }
  }
  code->handle_ = dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!code->handle_) {
    const char* why = dlerror();  // NOLINT(concurrency-mt-unsafe): the message of this call
    return NumericalError(fmt::format("native code: cannot load {}: {}", library.string(),
                                      why ? why : "unknown error"));
  }
  for (std::size_t p = 0; p < programs.size(); ++p) {
    void* symbol = dlsym(code->handle_, fmt::format("gb_program_{}", p).c_str());
    if (!symbol)
      return NumericalError(
          fmt::format("native code: {} has no gb_program_{}", library.string(), p));
    code->functions_.push_back(reinterpret_cast<Function>(symbol));
  }
  return std::shared_ptr<const NativeCode>(std::move(code));
}

NativeCode::~NativeCode() {
  if (handle_) dlclose(handle_);
}

}  // namespace gb::expr
