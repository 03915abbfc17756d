#include "core/sim/response.h"

namespace gb::sim {

Result<Simulation> DeterministicResponse(const model::StateSpace& ss, const data::Series& series,
                                         const filter::FilterSettings& settings) {
  SimulateOptions options;
  options.process_noise = false;
  options.measurement_noise = false;
  options.random_initial_state = false;
  return Simulate(ss, series, settings, options);
}

Result<Simulation> SamplePath(const model::StateSpace& ss, const data::Series& series,
                              const filter::FilterSettings& settings, std::uint64_t seed) {
  SimulateOptions options;
  options.seed = seed;
  return Simulate(ss, series, settings, options);
}

}  // namespace gb::sim
