#include "core/model/linearise.h"

#include <cmath>
#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include "app/cli/cli.h"
#include "core/project/result_file.h"
#include "core/util/file.h"
#include "core/util/json.h"

namespace gb::cli {

namespace {

namespace fs = std::filesystem;

// The model a result names: --model, else its "model_file" (relative to the result file).
Result<std::string> ModelOf(const LineariseArgs& args) {
  if (!args.model.empty()) return args.model;
  auto j = ReadJsonFile(args.result);
  if (!j) return j.error();
  if (!j->is_object() || !j->contains("model_file") || !(*j)["model_file"].is_string()) {
    Error e = InputError(
        "the result file does not name its model file (results written before this greybench "
        "version do not): give it with --model");
    e.file = args.result;
    e.path = "model_file";
    return e;
  }
  const fs::path file = (*j)["model_file"].get<std::string>();
  if (file.is_absolute()) return file.string();
  return (fs::path(args.result).parent_path() / file).lexically_normal().string();
}

std::string Cell(double v, double se) {
  if (std::isnan(se)) return fmt::format("{:>12.5g}", v);
  return fmt::format("{:>12.5g} ({:.2g})", v, se);
}

void PrintMatrix(const char* name, const Eigen::MatrixXd& m, const Eigen::MatrixXd& se,
                 const std::vector<std::string>& rows, const std::vector<std::string>& cols) {
  std::printf("%s:\n%10s", name, "");
  for (const auto& c : cols) std::printf("  %21s", c.c_str());
  std::printf("\n");
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    std::printf("%10s", rows[static_cast<std::size_t>(i)].c_str());
    for (Eigen::Index j = 0; j < m.cols(); ++j)
      std::printf("  %21s", Cell(m(i, j), se(i, j)).c_str());
    std::printf("\n");
  }
}

Json MatrixJson(const Eigen::MatrixXd& m, const Eigen::MatrixXd& se) {
  Json rows = Json::array(), se_rows = Json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    Json r = Json::array(), s = Json::array();
    for (Eigen::Index j = 0; j < m.cols(); ++j) {
      r.push_back(m(i, j));
      s.push_back(std::isnan(se(i, j)) ? Json() : Json(se(i, j)));
    }
    rows.push_back(r);
    se_rows.push_back(s);
  }
  return {{"value", rows}, {"std_error", se_rows}};
}

}  // namespace

int RunLinearise(const LineariseArgs& args) {
  auto model_path = ModelOf(args);
  if (!model_path) return Fail(model_path.error());
  if (int s = GuardOutputs({{args.result, "the result file"}, {*model_path, "the model file"}},
                           {{args.out, "--out"}}))
    return s;
  auto spec = model::LoadModelFile(*model_path);
  if (!spec) return Fail(spec.error());
  auto reference = project::LoadReference(args.result, *spec);
  if (!reference) return Fail(reference.error());
  auto point = model::ParseOperatingPoint(args.point, *spec);
  if (!point) return Fail(point.error());
  model::LinearisationOptions options;
  for (const auto& q : args.quantities) {
    auto parsed = model::ParseQuantity(q);
    if (!parsed) return Fail(parsed.error());
    options.quantities.push_back(*parsed);
  }
  options.free = reference->free;
  options.covariance = reference->covariance;
  auto compiled = model::NonlinearModel::Compile(*spec);
  if (!compiled) return Fail(compiled.error());
  auto lin = model::Linearise(*compiled, reference->theta, *point, options);
  if (!lin) return Fail(lin.error());

  const auto& s = *spec;
  std::printf("Linearised %s at %s (from %s; standard errors by the delta method)\n",
              s.name.c_str(), args.point.c_str(), args.result.c_str());
  std::printf("Steady state:\n");
  for (std::size_t i = 0; i < s.states.size(); ++i)
    std::printf("  %-10s %s\n", s.states[i].c_str(),
                Cell(lin->x(static_cast<Eigen::Index>(i)), lin->se_x(static_cast<Eigen::Index>(i)))
                    .c_str());
  for (std::size_t j = 0; j < s.inputs.size(); ++j)
    std::printf("  %-10s %s\n", s.inputs[j].c_str(),
                Cell(lin->u(static_cast<Eigen::Index>(j)), lin->se_u(static_cast<Eigen::Index>(j)))
                    .c_str());
  for (std::size_t o = 0; o < s.outputs.size(); ++o)
    std::printf("  %-10s %12.5g\n", s.outputs[o].c_str(), lin->y(static_cast<Eigen::Index>(o)));
  PrintMatrix("A = df/dx", lin->A, lin->se_A, s.states, s.states);
  PrintMatrix("B = df/du", lin->B, lin->se_B, s.states, s.inputs);
  PrintMatrix("C = dh/dx", lin->C, lin->se_C, s.outputs, s.states);
  PrintMatrix("D = dh/du", lin->D, lin->se_D, s.outputs, s.inputs);
  if (!options.quantities.empty()) {
    std::printf("Quantities:\n");
    for (std::size_t k = 0; k < options.quantities.size(); ++k)
      std::printf("  %-10s %s   = %s\n", options.quantities[k].name.c_str(),
                  Cell(lin->quantities[k], lin->se_quantities[k]).c_str(),
                  options.quantities[k].text.c_str());
  }

  if (!args.out.empty()) {
    Json j;
    j["greybench_linearisation"] = 1;
    j["model"] = s.name;
    j["model_file"] = *model_path;
    j["result"] = args.result;
    j["point"] = args.point;
    Json steady = Json::object();
    for (std::size_t i = 0; i < s.states.size(); ++i) {
      const auto k = static_cast<Eigen::Index>(i);
      steady[s.states[i]] = {{"value", lin->x(k)},
                             {"std_error", std::isnan(lin->se_x(k)) ? Json() : Json(lin->se_x(k))}};
    }
    for (std::size_t i = 0; i < s.inputs.size(); ++i) {
      const auto k = static_cast<Eigen::Index>(i);
      steady[s.inputs[i]] = {{"value", lin->u(k)},
                             {"std_error", std::isnan(lin->se_u(k)) ? Json() : Json(lin->se_u(k))}};
    }
    for (std::size_t o = 0; o < s.outputs.size(); ++o)
      steady[s.outputs[o]] = {{"value", lin->y(static_cast<Eigen::Index>(o))}};
    j["steady_state"] = steady;
    j["states"] = s.states;
    j["inputs"] = s.inputs;
    j["outputs"] = s.outputs;
    j["A"] = MatrixJson(lin->A, lin->se_A);
    j["B"] = MatrixJson(lin->B, lin->se_B);
    j["C"] = MatrixJson(lin->C, lin->se_C);
    j["D"] = MatrixJson(lin->D, lin->se_D);
    Json q = Json::object();
    for (std::size_t k = 0; k < options.quantities.size(); ++k)
      q[options.quantities[k].name] = {
          {"expression", options.quantities[k].text},
          {"value", lin->quantities[k]},
          {"std_error", std::isnan(lin->se_quantities[k]) ? Json() : Json(lin->se_quantities[k])}};
    j["quantities"] = q;
    if (auto st = WriteFileAtomic(args.out, j.dump(1) + "\n"); !st) return Fail(st.error());
  }
  return 0;
}

}  // namespace gb::cli
