// An experiment to design: the input signal by its shape, the record it would make, the input's
// spectrum against the model's bandwidth, and the standard errors the record would give
// (information.h), for one design or two side by side (the experiment-design view and
// `greybench-cli design`, user guide §4 and §6b).
//
// A design drives one input of the model; the model's other inputs are held at given levels.
// Shapes (level ± amplitude, sampled every sample_time for 0 <= t < duration):
//   PRBS     order n, bit period T (prbs.h): level - amplitude for a 0 bit, + for a 1 bit
//   square   period P: level - amplitude for the first half of each period, + for the second
//   step     at time T0: level - amplitude before, level + amplitude from T0 on (one step test)
// Text form (the CLI's --input, the project's "design"), keys in any order, each at most once:
//   prbs:order=6,bit=0.5,level=1.19,amplitude=0.12,ts=0.0125,duration=125[,seed=1]
//   square:period=4,level=..,amplitude=..,ts=..,duration=..
//   step:at=10,level=..,amplitude=..,ts=..,duration=..
// (level, amplitude, ts and duration have the defaults below; `seed` only for prbs.)
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "core/data/dataset.h"
#include "core/design/information.h"
#include "core/design/prbs.h"
#include "core/filter/kalman.h"
#include "core/model/linear_model.h"
#include "core/util/result.h"

namespace gb::design {

enum class InputShape { kPrbs, kSquare, kStep };

struct InputDesign {
  InputShape shape = InputShape::kPrbs;
  int order = 6;            // PRBS register length
  double bit_period = 0.5;  // PRBS bit period
  std::uint32_t seed = 1;   // PRBS register's first state
  double period = 4.0;      // square wave
  double step_time = 1.0;   // step
  double level = 0.0;       // the middle of the two levels
  double amplitude = 1.0;   // half the distance between them, > 0
  double sample_time = 0.0125;
  double duration = 125.0;
  // Checks every field (the limits of prbs.h; at most kMaxDesignSamples samples); *why names the
  // text form's key: "bit: the bit period 0.01 is shorter than the sample time 0.0125".
  bool IsValid(std::string* why) const;
  // "PRBS n = 6, bit 0.5, 1.19 ± 0.12, 10000 samples every 0.0125 over 125".
  std::string Describe() const;
};

// A design's record has at most this many samples (the expected information holds one joint
// moment per sample in time, not in memory, but its cost grows with the samples).
inline constexpr double kMaxDesignSamples = 2e6;

// The text form above. Errors (kInput) name the key and what is wrong ("prbs:...: 'order' must
// be a whole number from 2 to 24, not 'six'"), an unknown shape or key, a key given twice.
Result<InputDesign> ParseInputDesign(std::string_view text);
// The text form of `d` (ParseInputDesign's inverse; numbers to the last bit).
std::string FormatInputDesign(const InputDesign& d);
const char* ShapeName(InputShape shape);  // "prbs", "square", "step"

// The signal of a design. Errors (kInput): !IsValid.
Result<Signal> MakeInput(const InputDesign& d);

// The record a design makes for `model`: its times, the designed input in row `input` of U, the
// other inputs at `hold` (one value per model input; the designed one's is ignored), and every
// output observed (Y = 0: the values are not used by the expected information). Preconditions:
// 0 <= input < the model's inputs; hold has one value per input.
data::Series DesignSeries(const model::ModelSpec& spec, int input, const Signal& signal,
                          std::span<const double> hold);

// The one-sided power spectral density of u - mean(u) (units of u² per unit of frequency, the
// frequency in cycles per time unit), averaged over `bands` logarithmically spaced bands from
// 1/duration to the Nyquist frequency 1/(2 ts) (bands without a periodogram line are left out).
struct Spectrum {
  std::vector<double> frequency;  // the bands' geometric centres
  std::vector<double> power;
};
Spectrum InputSpectrum(const Signal& s, int bands = 48);

// |G(i 2π f)|², G(s) = C_o (sI - A)⁻¹ B_i + D_oi, at each frequency f (cycles per time unit).
std::vector<double> GainSquared(const model::StateSpace& ss, int input, int output,
                                std::span<const double> frequency);
// The −3 dB bandwidth from input i to output o: the lowest frequency where |G|² falls to half its
// value at zero frequency (the steady-state gain), searched from a thousandth of the slowest mode's
// corner frequency to a thousand times the fastest's; empty where a mode of A is not stable (no
// finite steady gain), where the gain at zero is zero, or where it never falls to half.
std::optional<double> Bandwidth(const model::StateSpace& ss, int input, int output);
// The time constants -1/Re(λ) of the stable real and complex modes of A, shortest first.
std::vector<double> TimeConstants(const Eigen::MatrixXd& A);

// A design evaluated: its signal, the expected information of the model's free parameters (in
// the order of ModelSpec::parameters) at the spec's values, and the input's spectrum.
struct DesignEvaluation {
  InputDesign design;
  Signal signal;
  std::vector<int> free;  // indices into the spec's parameters
  ExpectedInformation info;
  Spectrum spectrum;
};
// Errors: !design.IsValid (kInput, naming the key), the model's or the information's errors.
// `settings` as the filter's (FilterSettings::FromModel: hold, P0, each delay at its min).
Result<DesignEvaluation> EvaluateDesign(const model::LinearModel& model, const InputDesign& design,
                                        int input, std::span<const double> hold,
                                        const filter::FilterSettings& settings);

}  // namespace gb::design
