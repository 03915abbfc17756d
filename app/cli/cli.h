// greybench-cli commands (CONTRACT section 4). Each Run* returns the process exit status:
// 0 success, 1 numerical failure or non-convergence, 2 bad input.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/model/model.h"
#include "core/util/result.h"

namespace gb::cli {

// Prints `greybench-cli: error: <where>: <what>` to stderr; returns 2 (input) or 1 (numerical).
int Fail(const Error& e);

// Reads the model file and applies every `NAME=VALUE` of --set.
Result<model::ModelSpec> LoadModelWithOverrides(const std::string& path,
                                                const std::vector<std::string>& sets);

struct LoglikArgs {
  std::string model;
  std::vector<std::string> data;
  std::vector<std::string> sets;
};
int RunLoglik(const LoglikArgs& args);

struct BenchArgs {
  std::string model;
  std::vector<std::string> data;
  std::vector<std::string> sets;
  int repeat = 21;
};
int RunBench(const BenchArgs& args);

struct SimulateArgs {
  std::string model;
  std::string inputs;
  std::vector<std::string> sets;
  std::uint64_t seed = 1;
  std::string out;
};
int RunSimulate(const SimulateArgs& args);

struct PrbsArgs {
  int order = 6;
  double period = 0.5;
  double ts = 0.0125;
  double duration = 0;
  double low = -1;
  double high = 1;
  std::uint32_t seed = 1;
  std::string name = "u";
  std::string out;
};
int RunPrbs(const PrbsArgs& args);

struct EstimateArgs {
  std::string model;
  std::vector<std::string> data;
  std::vector<std::string> sets;
  std::string out;
  int threads = 0;
  int multistart = 0;
  int max_evaluations = 20000;
  std::string algorithm = "auto";
  double ftol = 1e-12;
};
int RunEstimate(const EstimateArgs& args);

struct CompareArgs {
  std::string a;
  std::string b;
};
int RunCompare(const CompareArgs& args);

struct DynoArgs {
  std::string experiment;  // fuel, crankshaft, square-wave
  std::string point = "f1";
  double duration = 0;     // 0: the experiment's default
  std::uint64_t seed = 1;
  int order = 0;           // 0: default
  double bit_period = 0;   // 0: default
  bool no_filter = false;
  bool constant_load = false;
  std::string out;
};
int RunDyno(const DynoArgs& args);

}  // namespace gb::cli
