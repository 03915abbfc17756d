// LLVM's ORC JIT against the system compiler and dlopen, on the C that greybench generates for a
// model (core/expr/native.h keeps it beside its library: ~/.cache/greybench/native/gb-HASH.c).
// A measurement for docs/benchmarks.md (issue 37), never part of the build: LLVM is not one of
// greybench's dependencies. Build and run (Debian: llvm-15-dev, clang-15):
//
//   g++ -std=c++17 -O2 bench/orc/orc_vs_dlopen.cpp -o /tmp/orc_vs_dlopen \
//       $(llvm-config-15 --cxxflags --ldflags --libs orcjit native irreader passes) -ldl
//   /tmp/orc_vs_dlopen gb-HASH.c gb-HASH.so SLOTS
//
// SLOTS: the number of slots the functions read (the model's states, inputs, parameters and t).
// The C is turned into LLVM IR by clang-15 -O0 (standing in for IR built from the expression
// graph in the process), then timed: parsing the IR, LLVM's O2 pipeline and ORC's code
// generation (what a JIT adds to a fit's start), and each function's evaluation time against the
// same function from the gcc-built library (dlopen), on the same slots.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include <dlfcn.h>

#include "llvm/ExecutionEngine/Orc/LLJIT.h"
#include "llvm/IR/LLVMContext.h"
#include "llvm/IR/Module.h"
#include "llvm/IRReader/IRReader.h"
#include "llvm/Passes/PassBuilder.h"
#include "llvm/Support/SourceMgr.h"
#include "llvm/Support/TargetSelect.h"

using Function = void (*)(const double*, double*);

static double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// Median ns per call of f over `reps` calls, 7 rounds.
static double NsPerCall(Function f, const std::vector<double>& slots, std::vector<double>& out,
                        int reps) {
  std::vector<double> rounds;
  for (int r = 0; r < 7; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < reps; ++i) f(slots.data(), out.data());
    rounds.push_back(Seconds(t0) * 1e9 / reps);
  }
  std::sort(rounds.begin(), rounds.end());
  return rounds[3];
}

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s gb-HASH.c gb-HASH.so SLOTS\n", argv[0]);
    return 2;
  }
  const std::string c_file = argv[1], so_file = argv[2];
  const int n_slots = std::atoi(argv[3]);
  const std::string ll_file = "/tmp/orc_vs_dlopen.ll";
  auto t0 = std::chrono::steady_clock::now();
  const std::string cmd =
      "clang-15 -O0 -Xclang -disable-O0-optnone -ffp-contract=off "
      "-fno-builtin -S -emit-llvm -o " +
      ll_file + " " + c_file;
  if (std::system(cmd.c_str()) != 0) return 1;
  const double clang_s = Seconds(t0);

  llvm::InitializeNativeTarget();
  llvm::InitializeNativeTargetAsmPrinter();
  t0 = std::chrono::steady_clock::now();
  auto context = std::make_unique<llvm::LLVMContext>();
  llvm::SMDiagnostic error;
  std::unique_ptr<llvm::Module> module = llvm::parseIRFile(ll_file, error, *context);
  if (!module) {
    error.print(argv[0], llvm::errs());
    return 1;
  }
  const double parse_s = Seconds(t0);
  t0 = std::chrono::steady_clock::now();
  {
    llvm::LoopAnalysisManager lam;
    llvm::FunctionAnalysisManager fam;
    llvm::CGSCCAnalysisManager cgam;
    llvm::ModuleAnalysisManager mam;
    llvm::PassBuilder pb;
    pb.registerModuleAnalyses(mam);
    pb.registerCGSCCAnalyses(cgam);
    pb.registerFunctionAnalyses(fam);
    pb.registerLoopAnalyses(lam);
    pb.crossRegisterProxies(lam, fam, cgam, mam);
    pb.buildPerModuleDefaultPipeline(llvm::OptimizationLevel::O2).run(*module, mam);
  }
  const double optimise_s = Seconds(t0);
  std::vector<std::string> names;
  for (const llvm::Function& f : *module)
    if (!f.isDeclaration() && f.getName().startswith("gb_program_"))
      names.push_back(f.getName().str());
  t0 = std::chrono::steady_clock::now();
  auto jit = llvm::orc::LLJITBuilder().create();
  if (!jit) {
    llvm::errs() << jit.takeError() << "\n";
    return 1;
  }
  auto& dylib = (*jit)->getMainJITDylib();
  dylib.addGenerator(llvm::cantFail(llvm::orc::DynamicLibrarySearchGenerator::GetForCurrentProcess(
      (*jit)->getDataLayout().getGlobalPrefix())));
  if (auto e =
          (*jit)->addIRModule(llvm::orc::ThreadSafeModule(std::move(module), std::move(context)))) {
    llvm::errs() << std::move(e) << "\n";
    return 1;
  }
  std::vector<Function> jitted;
  for (const std::string& name : names) {
    auto symbol = (*jit)->lookup(name);  // code generation happens here, on first lookup
    if (!symbol) {
      llvm::errs() << symbol.takeError() << "\n";
      return 1;
    }
    jitted.push_back(symbol->toPtr<Function>());
  }
  const double codegen_s = Seconds(t0);

  t0 = std::chrono::steady_clock::now();
  void* handle = dlopen(so_file.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    std::fprintf(stderr, "%s\n", dlerror());
    return 1;
  }
  const double dlopen_s = Seconds(t0);
  std::printf(
      "functions %zu; clang -O0 to IR %.3f s (stand-in for IR from the graph); "
      "ORC: parse %.3f s, O2 %.3f s, codegen %.3f s, total %.3f s; dlopen %.4f s\n",
      names.size(), clang_s, parse_s, optimise_s, codegen_s, parse_s + optimise_s + codegen_s,
      dlopen_s);

  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> around(0.5, 2.0);
  std::vector<double> slots(static_cast<std::size_t>(n_slots));
  for (double& s : slots) s = around(rng);
  std::vector<double> out(1 << 20, 0.0);
  for (std::size_t k = 0; k < names.size(); ++k) {
    auto gcc = reinterpret_cast<Function>(dlsym(handle, names[k].c_str()));
    const double a = NsPerCall(gcc, slots, out, 20000);
    const double b = NsPerCall(jitted[k], slots, out, 20000);
    std::printf("%s: gcc -O2 + dlopen %.1f ns, ORC (LLVM O2) %.1f ns, ratio %.2f\n",
                names[k].c_str(), a, b, b / a);
  }
  return 0;
}
