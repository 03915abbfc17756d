// Fault schedules of the live fuel dyno: the written form parsed part by part, the errors naming
// the argument and the part at fault, the schedule's order and its replay on the operating point,
// and the faults applied at the first sample at or after their time (checked against the dyno's
// own Inject at that sample).
#include "core/sim/fault_schedule.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gb::sim {
namespace {

using Kind = FuelFault::Kind;

TimedFuelFault Parsed(const std::string& text) {
  auto f = ParseFuelFault(text, "--fault");
  EXPECT_TRUE(f.ok()) << f.error().ToString();
  return f.ok() ? *f : TimedFuelFault{};
}

std::string Refusal(const std::string& text) {
  auto f = ParseFuelFault(text, "--live-fault");
  return f.ok() ? "" : f.error().message;
}

TEST(FuelFaultSchedule, ParsesStepsRampsAndClears) {
  const TimedFuelFault step = Parsed("60:tau_ff*1.5");
  EXPECT_EQ(step.text, "60:tau_ff*1.5");
  EXPECT_EQ(step.at_s, 60);
  EXPECT_FALSE(step.clear);
  EXPECT_EQ(step.fault.kind, Kind::kTauFF);
  EXPECT_EQ(step.fault.factor, 1.5);
  EXPECT_EQ(step.fault.ramp_s, 0);

  const TimedFuelFault ramp = Parsed("12.5:gain*0.9/30");
  EXPECT_EQ(ramp.at_s, 12.5);
  EXPECT_EQ(ramp.fault.kind, Kind::kSensorGain);
  EXPECT_EQ(ramp.fault.factor, 0.9);
  EXPECT_EQ(ramp.fault.ramp_s, 30);

  EXPECT_EQ(Parsed("1:X*2").fault.kind, Kind::kX);
  EXPECT_EQ(Parsed("1:delay*2").fault.kind, Kind::kSensorDelay);

  const TimedFuelFault clear = Parsed("90:clear/5");
  EXPECT_TRUE(clear.clear);
  EXPECT_EQ(clear.at_s, 90);
  EXPECT_EQ(clear.fault.ramp_s, 5);
}

TEST(FuelFaultSchedule, RefusalsNameTheArgumentAndThePartAtFault) {
  EXPECT_EQ(Refusal("60"), std::string("--live-fault '60': ") + kFuelFaultForm);
  EXPECT_EQ(Refusal("-1:X*2"),
            "--live-fault '-1:X*2': the time '-1' is not a number of seconds >= 0");
  EXPECT_EQ(
      Refusal("5:tauff*2"),
      "--live-fault '5:tauff*2': unknown parameter 'tauff' (tau_ff, X, delay, gain, or clear)");
  EXPECT_EQ(Refusal("5:tau_ff"), "--live-fault '5:tau_ff': no factor: expected tau_ff*FACTOR");
  EXPECT_EQ(Refusal("5:tau_ff*abc"),
            "--live-fault '5:tau_ff*abc': the factor 'abc' is not a number");
  EXPECT_EQ(Refusal("5:tau_ff*2/x"),
            "--live-fault '5:tau_ff*2/x': the ramp 'x' is not a number of seconds >= 0");
  EXPECT_EQ(Refusal("5:tau_ff*inf"),
            "--live-fault '5:tau_ff*inf': the factor 'inf' is not a number");
}

TEST(FuelFaultSchedule, SortsByTimeKeepingTheGivenOrderAtEqualTimes) {
  const FuelOperatingPoint p = *FindFuelPoint("f1");
  auto s = ScheduleFuelFaults({Parsed("9:X*2"), Parsed("5:tau_ff*2"), Parsed("5:clear")}, p, "--f");
  ASSERT_TRUE(s.ok()) << s.error().ToString();
  ASSERT_EQ(s->size(), 3u);
  EXPECT_EQ((*s)[0].text, "5:tau_ff*2");
  EXPECT_EQ((*s)[1].text, "5:clear");
  EXPECT_EQ((*s)[2].text, "9:X*2");
}

TEST(FuelFaultSchedule, RefusesWhatTheDynoWouldRefuseNamingThatFault) {
  // X at f1 is 0.175: doubled twice it passes 1 only at the third doubling.
  const FuelOperatingPoint p = *FindFuelPoint("f1");
  ASSERT_LT(4 * p.X, 1.0);
  ASSERT_GT(8 * p.X, 1.0);
  auto s = ScheduleFuelFaults({Parsed("3:X*2"), Parsed("1:X*2"), Parsed("2:X*2")}, p, "--fault");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().message.rfind("--fault '3:X*2': ", 0), 0u) << s.error().message;
  auto zero = ScheduleFuelFaults({Parsed("1:tau_ff*0")}, p, "--fault");
  ASSERT_FALSE(zero.ok());
  EXPECT_EQ(zero.error().message.rfind("--fault '1:tau_ff*0': ", 0), 0u);
}

TEST(FuelFaultSchedule, AppliesEachFaultAtTheFirstSampleAtOrAfterItsTime) {
  FuelExperiment e;
  e.point = *FindFuelPoint("f1");
  const double ts = e.recording.sample_time;
  auto s = ScheduleFuelFaults({Parsed("0.1:tau_ff*1.5"), Parsed("0.1001:gain*0.9")}, e.point, "-");
  ASSERT_TRUE(s.ok());
  auto dyno = LiveFuelDyno::Create(e);
  ASSERT_TRUE(dyno.ok());
  std::size_t next = 0;
  // 0.1 s is sample 8 exactly; 0.1001 s is first reached by sample 9.
  for (int k = 0; k < 12; ++k) {
    ASSERT_TRUE(ApplyDueFuelFaults(*s, &next, &*dyno, "-").ok());
    const FuelTruth truth = dyno->Truth();
    EXPECT_NEAR(dyno->Time(), k * ts, 1e-12);
    EXPECT_EQ(truth.tau_ff, k >= 8 ? 1.5 * e.point.tau_ff : e.point.tau_ff) << "sample " << k;
    EXPECT_NEAR(truth.Kb, k >= 9 ? 0.9 * e.point.Kb : e.point.Kb, 1e-15) << "sample " << k;
    EXPECT_EQ(next, k >= 9 ? 2u : k >= 8 ? 1u : 0u);
    dyno->Next();
  }
}

}  // namespace
}  // namespace gb::sim
