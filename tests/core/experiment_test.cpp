// Input designs (core/design/experiment.h): the text form, the signals, the spectrum and the
// bandwidth against closed forms.
#include "core/design/experiment.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "filter_fixtures.h"

namespace gb::design {
namespace {

TEST(ParseInputDesign, ReadsEveryShapeAndFormatsBackToTheBit) {
  for (const char* text :
       {"prbs:order=7,bit=0.3,level=1.25,amplitude=0.1,ts=0.01,duration=20,seed=9",
        "square:period=4,level=-2,amplitude=0.5,ts=0.1,duration=40",
        "step:at=3.5,level=0,amplitude=1,ts=0.05,duration=10"}) {
    auto d = ParseInputDesign(text);
    ASSERT_TRUE(d.ok()) << text << ": " << d.error().ToString();
    auto again = ParseInputDesign(FormatInputDesign(*d));
    ASSERT_TRUE(again.ok()) << FormatInputDesign(*d);
    EXPECT_EQ(FormatInputDesign(*again), FormatInputDesign(*d));
  }
  auto d = ParseInputDesign("prbs:bit=0.1,level=0.1,amplitude=0.3");
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->order, 6);  // the defaults stay
  EXPECT_EQ(d->bit_period, 0.1);
  EXPECT_EQ(d->level, 0.1);
}

TEST(ParseInputDesign, NamesTheKeyAndWhatIsWrong) {
  struct Bad {
    const char* text;
    const char* says;
  };
  for (const Bad& b : {Bad{"sine:period=1", "unknown shape 'sine'"},
                       Bad{"prbs:order=six", "'order' must be a finite number, not 'six'"},
                       Bad{"prbs:order=6.5", "'order' must be a whole number"},
                       Bad{"prbs:order=30", "'order' must be a whole number from 2 to 24"},
                       Bad{"prbs:bit=0.01,ts=0.0125", "bit: the bit period 0.01 is shorter"},
                       Bad{"prbs:period=2", "unknown key 'period' for prbs"},
                       Bad{"square:period=1,period=2", "'period' is given twice"},
                       Bad{"step:at=20,duration=10", "at: the step at 20 is not within"},
                       Bad{"prbs:amplitude=0", "amplitude: must be positive"},
                       Bad{"prbs:amplitude=nan", "'amplitude' must be a finite number"},
                       Bad{"prbs:level", "'level' is not KEY=VALUE"},
                       Bad{"prbs:ts=1e-9,duration=1000", "more than 2000000 samples"}}) {
    auto d = ParseInputDesign(b.text);
    ASSERT_FALSE(d.ok()) << b.text;
    EXPECT_NE(d.error().message.find(b.says), std::string::npos)
        << b.text << ": " << d.error().message;
    EXPECT_NE(d.error().message.find(b.text), std::string::npos) << d.error().message;
  }
}

TEST(MakeInput, GivesTheLevelsOfEachShape) {
  InputDesign step;
  step.shape = InputShape::kStep;
  step.step_time = 1.0;
  step.level = 2.0;
  step.amplitude = 0.5;
  step.sample_time = 0.25;
  step.duration = 2.0;
  auto s = MakeInput(step);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->u, (std::vector<double>{1.5, 1.5, 1.5, 1.5, 2.5, 2.5, 2.5, 2.5}));
  InputDesign prbs;
  prbs.level = 1.0;
  prbs.amplitude = 0.1;
  prbs.duration = 10.0;
  auto p = MakeInput(prbs);
  ASSERT_TRUE(p.ok());
  for (double v : p->u) EXPECT_TRUE(v == 0.9 || v == 1.1) << v;
}

TEST(InputSpectrum, PutsASquareWavesPowerAtItsOddHarmonics) {
  // A ±1 square wave of period 2 s has variance 1; its fundamental at 0.5 Hz carries 8/π² of it.
  InputDesign d;
  d.shape = InputShape::kSquare;
  d.period = 2.0;
  d.level = 0.0;
  d.amplitude = 1.0;
  d.sample_time = 0.01;
  d.duration = 200.0;
  auto s = MakeInput(d);
  ASSERT_TRUE(s.ok());
  const Spectrum spec = InputSpectrum(*s, 200);
  ASSERT_FALSE(spec.frequency.empty());
  // The band holding 0.5 Hz is the highest of all.
  std::size_t best = 0;
  for (std::size_t b = 0; b < spec.power.size(); ++b)
    if (spec.power[b] > spec.power[best]) best = b;
  const double ratio = std::exp(std::log(spec.frequency.back() / spec.frequency.front()) / 199);
  EXPECT_LT(std::abs(std::log(spec.frequency[best] / 0.5)), std::log(ratio));
}

TEST(Bandwidth, IsTheCornerOfAFirstOrderLag) {
  // dx = (-x + K u)/τ dt: |G|² = K² / (1 + (2π f τ)²) halves at f = 1 / (2π τ).
  auto lm = filter::fixtures::CompileModel(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {"tau": 0.4, "K": 3.0},
    "drift": {"x": "(-x + K*u)/tau"}, "diffusion": {"x": "0.1"},
    "observation": {"y": "x"}, "measurement_variance": {"y": "0.01"}
  })json");
  auto ss = lm.Evaluate(std::vector<double>{0.4, 3.0});
  ASSERT_TRUE(ss.ok());
  const auto bw = Bandwidth(*ss, 0, 0);
  ASSERT_TRUE(bw.has_value());
  EXPECT_NEAR(*bw, 1.0 / (2 * std::numbers::pi * 0.4), 1e-12);
  EXPECT_NEAR(GainSquared(*ss, 0, 0, std::vector<double>{0.0})[0], 9.0, 1e-12);
  EXPECT_EQ(TimeConstants(ss->A), std::vector<double>{0.4});
}

TEST(Bandwidth, IsAbsentForAnIntegrator) {
  auto lm = filter::fixtures::CompileModel(R"json({
    "greybench_model": 1, "states": ["x"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {"k": 2.0},
    "drift": {"x": "k*u"}, "diffusion": {"x": "0.1"},
    "observation": {"y": "x"}, "measurement_variance": {"y": "0.01"}
  })json");
  auto ss = lm.Evaluate(std::vector<double>{2.0});
  ASSERT_TRUE(ss.ok());
  EXPECT_FALSE(Bandwidth(*ss, 0, 0).has_value());
  EXPECT_TRUE(TimeConstants(ss->A).empty());
}

}  // namespace
}  // namespace gb::design
