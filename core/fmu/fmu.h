// The fitted model as an FMI 2.0 FMU (issue 38): the model's deterministic part at the
// estimates,
//
//   dx/dt = f(x, u, θ̂, t),   y = h(x, u, θ̂, t),   x(t0) = x̂0
//
// for Model Exchange (the importer integrates: states, derivatives, outputs) and Co-Simulation
// (fmi2DoStep integrates with Dormand-Prince 5(4) under the model file's "ekf" tolerances, the
// inputs held over each communication step, or ramped where the importer gives their first
// derivatives: fmi2SetRealInputDerivatives). The estimates are tunable parameters
// (causality="parameter") with their units and descriptions; the states start at x̂0.
//
// The FMU is a zip (core/util/zip.h) of
//   modelDescription.xml          the variables in value-reference order: states, their
//                                 derivatives der(x), inputs, outputs, parameters; the
//                                 ModelStructure's dependencies from the symbolic Jacobians
//                                 (an output or a derivative depends on a state or an input
//                                 where its derivative with respect to it is not zero)
//   binaries/linux64/ID.so        the model's C (core/expr/native.h's generator) and greybench's
//                                 FMI runtime (core/fmu/runtime.c: the standard's state
//                                 machine, illegal call sequences refused with a logged message),
//                                 built by the system's C compiler
//   sources/ID.c                  the same C, with the FMI 2.0 headers (sources/fmi2*.h, their
//                                 BSD 2-Clause licence in sources/LICENSE.txt), to build elsewhere
// With FmuOptions::virtual_sensor, a Co-Simulation FMU of the model's filter instead
// (core/fmu/sensor.c, appended to the runtime): inputs u, the measurements and their validity,
// outputs the filtered and predicted states and their sd, the one-step predictions and their sd,
// the innovations.
// The exporting machine needs a C compiler (cc, $GREYBENCH_CC or $CC), as native code does.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "core/model/nonlinear_model.h"
#include "core/util/result.h"

namespace gb::fmu {

enum class Interface { kModelExchange, kCoSimulation, kBoth };

struct FmuOptions {
  Interface interface = Interface::kBoth;
  // The FMU's modelIdentifier (a C identifier: letters, digits, '_', not starting with a digit);
  // empty: from the model's name.
  std::string identifier;
  // The states' start values; empty: the model's initial state at θ.
  std::vector<double> initial_state;
  // The error control of the Co-Simulation's integration (and the filter's); 0: the model
  // file's "ekf" tolerances.
  double rtol = 0.0, atol = 0.0;

  // The virtual sensor (core/fmu/sensor.c says what it computes): a Co-Simulation FMU of the
  // model's extended Kalman filter instead of its deterministic part. `interface` is ignored.
  bool virtual_sensor = false;
  std::vector<int> delays;  // per output, in samples (the fit's)
  // P0 as the filter starts: kCtsm, the covariance equation integrated from P = 0 at x0 over the
  // first interval; kStationary, the solution of J P + P J' + diag σ² = 0 at x0 and the first
  // sample's inputs; kExplicit, `initial_covariance` (n x n, row-major).
  model::InitialCovariance initial_covariance_kind = model::InitialCovariance::kCtsm;
  std::vector<double> initial_covariance;
};

struct FmuSources {
  std::string identifier;
  std::string guid;
  std::string model_description;  // modelDescription.xml
  std::string source;             // the C, without the FMI headers
};

// modelDescription.xml and the C source of `model` at the parameter values θ (all of the
// model's parameters, in its order). Errors: a name two variables share (a state and an output,
// say), an identifier that is not a C identifier, a start value that is not finite.
Result<FmuSources> MakeFmuSources(const model::NonlinearModel& model, std::span<const double> theta,
                                  const FmuOptions& options);

// Builds the binary and writes the FMU to `path` (atomically). Errors: MakeFmuSources', the
// compiler's (its first lines), the file's.
Status ExportFmu(const model::NonlinearModel& model, std::span<const double> theta,
                 const FmuOptions& options, const std::string& path);

// The options of a virtual sensor of `model` at θ with the fit's output delays (samples; -1: the
// model's smallest): its delays; P0 as the model starts its filter (explicit variances taken
// at θ); and for a linear model, which greybench filters with the exact discretisation, the
// moment equations at rtol 1e-10, atol 1e-12. Errors (kInput): the iterated EKF, a delay or
// variance out of range.
Result<FmuOptions> VirtualSensorOptions(const model::NonlinearModel& model,
                                        std::span<const double> theta, std::span<const int> delays);

// "Model Exchange", "Co-Simulation", "Model Exchange and Co-Simulation".
const char* InterfaceName(Interface interface);

// The FMU's outputs are h at the same instant: a delay the fit estimated (samples per output,
// -1 or 0 for none) is left to the importer. The sentence that says so ("the fit delays ilambda
// by 5 samples; the FMU's outputs are not delayed (add the delay after the output in the
// importer)"), or "" when no output is delayed.
std::string DelayNote(const model::ModelSpec& spec, std::span<const int> delays);

// A C identifier from a name: every other character as '_', a leading digit prefixed by '_';
// "model" for an empty name.
std::string IdentifierOf(const std::string& name);

}  // namespace gb::fmu
