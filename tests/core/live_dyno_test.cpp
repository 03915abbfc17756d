// The live dyno against the batch experiments (bit for bit without faults), against batch runs
// with the faulted values (noise-free, up to rounding), against an independent RK4 integration of
// the film under a ramp, and against itself (determinism).
#include "core/sim/live_dyno.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "core/design/prbs.h"

namespace gb::sim {
namespace {

using Kind = FuelFault::Kind;

// Noise-free agreement of two simulations that differ only in rounding.
constexpr double kRoundingTolerance = 1e-12;

FuelExperiment Fuel(const char* point, double duration) {
  FuelExperiment e;
  e.point = *FindFuelPoint(point);
  e.duration = duration;
  return e;
}

FuelExperiment NoiseFree(FuelExperiment e) {
  e.point.s11 = e.point.s12 = e.point.s2 = 0;
  return e;
}

FuelExperiment Unfiltered(FuelExperiment e) {
  e.recording.filter_hz = 0;
  return e;
}

int Samples(const FuelExperiment& e) {
  return static_cast<int>(std::ceil(e.duration / e.recording.sample_time - 1e-9));
}

// `n` samples of a live run; `faults` are injected before the sample of their index.
struct Scheduled {
  int before_sample;
  FuelFault fault;
};
std::vector<FuelSample> RunLive(const FuelExperiment& e, int n,
                                const std::vector<Scheduled>& faults = {}) {
  auto dyno = LiveFuelDyno::Create(e);
  EXPECT_TRUE(dyno.ok()) << dyno.error().ToString();
  std::vector<FuelSample> out;
  for (int k = 0; k < n; ++k) {
    for (const auto& f : faults)
      if (f.before_sample == k) {
        EXPECT_TRUE(dyno->Inject(f.fault).ok());
      }
    out.push_back(dyno->Next());
  }
  return out;
}

std::vector<FuelSample> RunBatch(const FuelExperiment& e) {
  auto rec = RunFuelExperiment(e);
  EXPECT_TRUE(rec.ok()) << rec.error().ToString();
  std::vector<FuelSample> out;
  for (std::size_t k = 0; k < rec->columns[0].size(); ++k)
    out.push_back({rec->columns[0][k], rec->columns[1][k], rec->columns[2][k]});
  return out;
}

bool SameBits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

TEST(LiveFuelDyno, WithoutFaultsGivesRunFuelExperimentsRecordBitForBit) {
  FuelExperiment seeded = Fuel("f3", 20);
  seeded.seed = 12345;
  seeded.prbs_order = 9;
  seeded.bit_period = 0.25;
  for (const FuelExperiment& e : {Fuel("f1", 60), seeded, Unfiltered(Fuel("f7", 20))}) {
    const auto batch = RunBatch(e);
    const auto live = RunLive(e, Samples(e));
    ASSERT_EQ(live.size(), batch.size());
    for (std::size_t k = 0; k < live.size(); ++k) {
      ASSERT_TRUE(SameBits(live[k].t, batch[k].t)) << e.point.name << " sample " << k;
      ASSERT_TRUE(SameBits(live[k].mfi, batch[k].mfi)) << e.point.name << " sample " << k;
      ASSERT_TRUE(SameBits(live[k].ilambda, batch[k].ilambda)) << e.point.name << " sample " << k;
    }
  }
}

TEST(LiveFuelDyno, RunsOnWithThePrbsRepeating) {
  // Unfiltered, the recorded input is the PRBS level: bit floor(t / T_prbs) of the maximal-length
  // sequence, which repeats after 2^6 - 1 = 63 bits (31.5 s = 2520 samples).
  const FuelExperiment e = Unfiltered(NoiseFree(Fuel("f2", 1)));
  const int period = 2520, per_bit = 40;
  const auto live = RunLive(e, 2 * period + 10);
  const auto bits = design::PrbsBits(e.prbs_order, 1, 63);
  const double bias = 1 / e.point.Kb;
  for (std::size_t k = 0; k < live.size(); ++k) {
    const double level = bits[(k / per_bit) % 63] ? 1 : -1;
    ASSERT_EQ(live[k].mfi, bias * (1 + e.amplitude * level)) << "sample " << k;
  }
}

TEST(LiveFuelDyno, StepInTauFFFromTheStartEqualsTheBatchRunWithTheNewValue) {
  // Without noise the film's steady state does not depend on τ_ff, so the live run faulted at
  // t = 0 and the batch run with τ_ff · 1.5 from the start see the same world.
  const FuelExperiment e = NoiseFree(Fuel("f1", 10));
  FuelExperiment faulted = e;
  faulted.point.tau_ff = e.point.tau_ff * 1.5;
  const auto batch = RunBatch(faulted);
  const auto nominal = RunBatch(e);
  const auto live = RunLive(e, Samples(e), {{0, {Kind::kTauFF, 1.5}}});
  double largest_effect = 0;
  for (std::size_t k = 0; k < live.size(); ++k) {
    EXPECT_EQ(live[k].mfi, batch[k].mfi);
    ASSERT_NEAR(live[k].ilambda, batch[k].ilambda, kRoundingTolerance) << "sample " << k;
    largest_effect = std::max(largest_effect, std::abs(live[k].ilambda - nominal[k].ilambda));
  }
  EXPECT_GT(largest_effect, 1e-3);
}

TEST(LiveFuelDyno, StepInXEqualsTheBatchRunWithTheNewValueOnceTheFilmHasSettled) {
  // The steady film depends on X ((1-X) u in the vapour, X u in the film): the two runs start
  // apart and agree once the difference has decayed (e^{-t/τ_ff}, below rounding after 10 s).
  const FuelExperiment e = NoiseFree(Fuel("f4", 15));
  FuelExperiment faulted = e;
  faulted.point.X = e.point.X * 2;
  const auto batch = RunBatch(faulted);
  const auto live = RunLive(e, Samples(e), {{0, {Kind::kX, 2}}});
  for (std::size_t k = 800; k < live.size(); ++k)
    ASSERT_NEAR(live[k].ilambda, batch[k].ilambda, 1e-10) << "sample " << k;
}

TEST(LiveFuelDyno, SensorGainScalesTheOutputAtOnce) {
  // The gain acts at the sensor: without noise or filter, 1/λ is the nominal one times the factor
  // from the fault's sample on, and the input is untouched.
  const FuelExperiment e = Unfiltered(NoiseFree(Fuel("f8", 5)));
  const auto nominal = RunLive(e, Samples(e));
  const auto live = RunLive(e, Samples(e), {{100, {Kind::kSensorGain, 0.9}}});
  for (std::size_t k = 0; k < live.size(); ++k) {
    EXPECT_EQ(live[k].mfi, nominal[k].mfi);
    const double expected = k < 100 ? nominal[k].ilambda : 0.9 * nominal[k].ilambda;
    ASSERT_NEAR(live[k].ilambda, expected, kRoundingTolerance) << "sample " << k;
  }
}

TEST(LiveFuelDyno, DelayChangeReReadsTheHistoryByTheRightNumberOfFineSteps) {
  // Without noise or filter the sample is the sensor's reading. After a delay change at sample 200
  // it is the reading of the batch run with the new delay (the film does not depend on it) - bit
  // for bit, lengthened by 3 fine steps, by 4 times, or shortened - and lengthening by 2 samples
  // (20 fine steps) shifts the nominal output by exactly 2 samples.
  const FuelExperiment e = Unfiltered(NoiseFree(Fuel("f1", 5)));
  const double h = e.recording.sample_time / e.recording.oversample;
  const auto nominal = RunBatch(e);
  for (double factor : {(e.point.delay_s + 3 * h) / e.point.delay_s, 4.0, 0.5}) {
    FuelExperiment changed = e;
    changed.point.delay_s = e.point.delay_s * factor;
    const auto batch = RunBatch(changed);
    const auto live = RunLive(e, Samples(e), {{200, {Kind::kSensorDelay, factor}}});
    for (std::size_t k = 0; k < live.size(); ++k)
      ASSERT_TRUE(SameBits(live[k].ilambda, (k < 200 ? nominal : batch)[k].ilambda))
          << "factor " << factor << ", sample " << k;
  }
  const double two_samples = (e.point.delay_s + 2 * e.recording.sample_time) / e.point.delay_s;
  const auto shifted = RunLive(e, Samples(e), {{200, {Kind::kSensorDelay, two_samples}}});
  for (std::size_t k = 200; k < shifted.size(); ++k)
    ASSERT_TRUE(SameBits(shifted[k].ilambda, nominal[k - 2].ilambda)) << "sample " << k;
}

TEST(LiveFuelDyno, RampMovesTheTruthLinearlyAndTheFilmFollowsTheOdeWithTheRampedTauFF) {
  // τ_ff ramps from 0.375 s to 0.75 s over 4 s from t = 1 s. The truth is linear in between; the
  // samples (no noise, no filter) are checked against RK4 on the film's ODE with τ_ff(t), fed the
  // recorded input (the held PRBS level) and read Δt = 5 samples later.
  const FuelExperiment e = Unfiltered(NoiseFree(Fuel("f1", 8)));
  const FuelOperatingPoint& p = e.point;
  auto dyno = LiveFuelDyno::Create(e);
  ASSERT_TRUE(dyno.ok());
  std::vector<FuelSample> live;
  for (int k = 0; k < Samples(e); ++k) {
    if (k == 80) {
      ASSERT_TRUE(dyno->Inject({Kind::kTauFF, 2, 4.0}).ok());
    }
    if (k == 80 + 160) {
      EXPECT_NEAR(dyno->Truth().tau_ff, 1.5 * p.tau_ff, 1e-15);
    }
    if (k >= 80 + 320) {
      EXPECT_EQ(dyno->Truth().tau_ff, 2 * p.tau_ff);
    }
    live.push_back(dyno->Next());
  }
  auto tau_ff = [&](double t) { return p.tau_ff * (1 + std::clamp((t - 1) / 4, 0.0, 1.0)); };
  const double bias = 1 / p.Kb;
  double mfv = (1 - p.X) * bias, mff = p.X * bias;
  std::vector<double> flow = {mfv + mff};
  const int substeps = 10;
  const double dt = e.recording.sample_time / substeps;
  for (std::size_t k = 0; k + 1 < live.size(); ++k) {
    const double u = live[k].mfi;
    auto f = [&](double t, double v, double ff, double* dv, double* dff) {
      *dv = (-v + (1 - p.X) * u) / p.tau_fv;
      *dff = (-ff + p.X * u) / tau_ff(t);
    };
    for (int j = 0; j < substeps; ++j) {
      const double t = live[k].t + j * dt;
      double a1, b1, a2, b2, a3, b3, a4, b4;
      f(t, mfv, mff, &a1, &b1);
      f(t + dt / 2, mfv + dt / 2 * a1, mff + dt / 2 * b1, &a2, &b2);
      f(t + dt / 2, mfv + dt / 2 * a2, mff + dt / 2 * b2, &a3, &b3);
      f(t + dt, mfv + dt * a3, mff + dt * b3, &a4, &b4);
      mfv += dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4);
      mff += dt / 6 * (b1 + 2 * b2 + 2 * b3 + b4);
    }
    flow.push_back(mfv + mff);
  }
  const auto nominal = RunLive(e, Samples(e));
  const int d = 5;  // Δt = 0.0625 s
  double largest_effect = 0;
  for (std::size_t k = d; k < live.size(); ++k) {
    ASSERT_NEAR(live[k].ilambda, p.Kb * flow[k - d], 1e-9) << "sample " << k;
    largest_effect = std::max(largest_effect, std::abs(live[k].ilambda - nominal[k].ilambda));
  }
  EXPECT_GT(largest_effect, 5e-3);
}

TEST(LiveFuelDyno, SameSeedAndFaultScheduleGiveTheSameSamples) {
  const FuelExperiment e = Fuel("f7", 10);
  const std::vector<Scheduled> schedule = {{100, {Kind::kTauFF, 1.3, 2}},
                                           {150, {Kind::kSensorDelay, 1.5}},
                                           {300, {Kind::kX, 0.8, 1}},
                                           {300, {Kind::kSensorGain, 1.1, 0.5}}};
  const auto a = RunLive(e, Samples(e), schedule);
  const auto b = RunLive(e, Samples(e), schedule);
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_TRUE(SameBits(a[k].mfi, b[k].mfi) && SameBits(a[k].ilambda, b[k].ilambda)) << k;
  }
  auto later = schedule;
  later[0].before_sample = 101;
  const auto c = RunLive(e, Samples(e), later);
  for (std::size_t k = 0; k <= 100; ++k) ASSERT_TRUE(SameBits(a[k].ilambda, c[k].ilambda)) << k;
  bool differs = false;
  for (std::size_t k = 101; k < a.size(); ++k) differs |= a[k].ilambda != c[k].ilambda;
  EXPECT_TRUE(differs);
}

TEST(LiveFuelDyno, RefusesFaultsOutOfRangeAndChangesNothing) {
  auto dyno = LiveFuelDyno::Create(Fuel("f1", 1));
  ASSERT_TRUE(dyno.ok());
  const FuelTruth before = dyno->Truth();
  auto refused = [&](FuelFault f, const char* says) {
    const Status st = dyno->Inject(f);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error().message.find(says), std::string::npos) << st.error().message;
  };
  refused({Kind::kX, 6}, "X would become 1.05");
  refused({Kind::kSensorDelay, 20}, "longer than the 1 s the delay line holds");
  refused({Kind::kTauFF, 0}, "the factor of tau_ff must be a finite number > 0");
  refused({Kind::kSensorGain, std::nan("")}, "the factor of gain");
  refused({Kind::kTauFF, 2, -1}, "the ramp must be a finite number of seconds >= 0");
  EXPECT_FALSE(dyno->ClearFaults(INFINITY).ok());
  const FuelTruth after = dyno->Truth();
  EXPECT_EQ(after.tau_ff, before.tau_ff);
  EXPECT_EQ(after.X, before.X);
  EXPECT_EQ(after.delay_s, before.delay_s);
  EXPECT_EQ(after.Kb, before.Kb);
  EXPECT_EQ(LiveFuelDyno::MaxSensorDelay(dyno->experiment().point), 1.0);
  EXPECT_TRUE(dyno->Inject({Kind::kX, 0}).ok());             // no film at all
  EXPECT_TRUE(dyno->Inject({Kind::kSensorDelay, 16}).ok());  // Δt = 1 s: the whole line
}

TEST(LiveFuelDyno, RefusesFaultsThatTakeTauFFOrTheGainBeyondAHundredTimesNominal) {
  // τ_ff × 1e-320 overflowed the film's discretisation and K_b × 1e308 the sensor: NaN and inf
  // rows. Within 1/100..100 times the nominal value a fault is taken, also as several.
  auto dyno = LiveFuelDyno::Create(Fuel("f1", 1));
  ASSERT_TRUE(dyno.ok());
  const FuelOperatingPoint p = dyno->experiment().point;
  auto refused = [&](FuelFault f, const char* says) {
    const Status st = dyno->Inject(f);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error().message.find(says), std::string::npos) << st.error().message;
  };
  refused({Kind::kTauFF, 1e-320}, "a fault may take it to 0.01..100 times that");
  refused({Kind::kSensorGain, 1e308}, "gain would become 8.421e+307");
  refused({Kind::kSensorGain, 0.0099}, "0.0099 times its nominal value 0.8421");
  ASSERT_TRUE(dyno->Inject({Kind::kTauFF, 10}).ok());
  refused({Kind::kTauFF, 11}, "tau_ff would become 41.25 (3.75 x 11), 110 times");
  ASSERT_TRUE(dyno->Inject({Kind::kTauFF, 10}).ok());  // 100 times: the limit
  EXPECT_DOUBLE_EQ(dyno->Truth().tau_ff, 100 * p.tau_ff);
  ASSERT_TRUE(dyno->Inject({Kind::kSensorGain, 0.01}).ok());
  for (int k = 0; k < 160; ++k) {
    const FuelSample s = dyno->Next();
    ASSERT_TRUE(std::isfinite(s.mfi) && std::isfinite(s.ilambda)) << k;
  }
  auto shaft = LiveCrankshaftDyno::Create(CrankshaftExperiment{});
  ASSERT_TRUE(shaft.ok());
  const Status st = shaft->Inject({CrankshaftFault::Kind::kTauF, 1e-320});
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("tau_f would become"), std::string::npos) << st.error().message;
  EXPECT_FALSE(shaft->Inject({CrankshaftFault::Kind::kJe, 101}).ok());
  EXPECT_TRUE(shaft->Inject({CrankshaftFault::Kind::kJe, 100}).ok());
}

TEST(LiveFuelDyno, FaultsCompoundAndClearBackToTheNominalValues) {
  auto dyno = LiveFuelDyno::Create(Fuel("f2", 1));
  ASSERT_TRUE(dyno.ok());
  const FuelOperatingPoint p = dyno->experiment().point;
  ASSERT_TRUE(dyno->Inject({Kind::kTauFF, 2}).ok());
  ASSERT_TRUE(dyno->Inject({Kind::kTauFF, 1.5}).ok());
  ASSERT_TRUE(dyno->Inject({Kind::kSensorGain, 0.8, 1}).ok());
  EXPECT_DOUBLE_EQ(dyno->Truth().tau_ff, 3 * p.tau_ff);
  for (int k = 0; k < 40; ++k) dyno->Next();  // 0.5 s: half-way along the gain's ramp
  EXPECT_NEAR(dyno->Truth().Kb, 0.9 * p.Kb, 1e-12);
  // A new fault on a ramping parameter starts where the ramp has got to.
  ASSERT_TRUE(dyno->Inject({Kind::kSensorGain, 0.5}).ok());
  EXPECT_NEAR(dyno->Truth().Kb, 0.45 * p.Kb, 1e-12);
  ASSERT_TRUE(dyno->ClearFaults(2).ok());
  for (int k = 0; k < 80; ++k) dyno->Next();  // 1 s: half-way back
  EXPECT_NEAR(dyno->Truth().tau_ff, 2 * p.tau_ff, 1e-12);
  EXPECT_NEAR(dyno->Truth().Kb, 0.725 * p.Kb, 1e-12);
  for (int k = 0; k < 80; ++k) dyno->Next();
  const FuelTruth cleared = dyno->Truth();
  EXPECT_EQ(cleared.tau_ff, p.tau_ff);
  EXPECT_EQ(cleared.X, p.X);
  EXPECT_EQ(cleared.delay_s, p.delay_s);
  EXPECT_EQ(cleared.Kb, p.Kb);
  EXPECT_EQ(dyno->SampleIndex(), 200);
  EXPECT_EQ(dyno->Time(), 2.5);
}

TEST(FuelFaults, ReplaysAScheduleWithoutTheSimulation) {
  const FuelOperatingPoint p = *FindFuelPoint("f3");
  FuelFaults faults(p, LiveFuelDyno::MaxSensorDelay(p));
  ASSERT_TRUE(faults.Inject({Kind::kX, 4, 10}, 60).ok());
  EXPECT_EQ(faults.At(59).X, p.X);
  EXPECT_NEAR(faults.At(65).X, 2.5 * p.X, 1e-15);
  EXPECT_EQ(faults.At(70).X, 4 * p.X);
  EXPECT_FALSE(faults.Inject({Kind::kX, 4}, 80).ok());  // 16 X = 1.168
}

// ---- crankshaft --------------------------------------------------------------------------------

std::vector<CrankshaftSample> RunLive(const CrankshaftExperiment& e, int n,
                                      const CrankshaftFault* fault_at_start = nullptr) {
  auto dyno = LiveCrankshaftDyno::Create(e);
  EXPECT_TRUE(dyno.ok()) << dyno.error().ToString();
  if (fault_at_start) {
    EXPECT_TRUE(dyno->Inject(*fault_at_start).ok());
  }
  std::vector<CrankshaftSample> out;
  for (int k = 0; k < n; ++k) out.push_back(dyno->Next());
  return out;
}

TEST(LiveCrankshaftDyno, WithoutFaultsGivesRunCrankshaftExperimentsRecordBitForBit) {
  CrankshaftExperiment constant_load;
  constant_load.perturb_load = false;
  constant_load.seed = 3;
  for (CrankshaftExperiment e : {CrankshaftExperiment{}, constant_load}) {
    e.duration = 150;
    auto rec = RunCrankshaftExperiment(e);
    ASSERT_TRUE(rec.ok());
    const auto live = RunLive(e, static_cast<int>(rec->columns[0].size()));
    for (std::size_t k = 0; k < live.size(); ++k) {
      const double values[] = {live[k].t, live[k].theta, live[k].Tl, live[k].N, live[k].Pman};
      for (int c = 0; c < 5; ++c)
        ASSERT_TRUE(SameBits(values[c], rec->columns[c][k])) << "column " << c << ", sample " << k;
    }
  }
}

TEST(LiveCrankshaftDyno, StepInTauFOrJeFromTheStartEqualsTheBatchRunWithTheNewValue) {
  // Without noise the shaft rests at zero deviation until t = 0 in both runs.
  CrankshaftExperiment e;
  e.point.s1 = e.point.s21 = e.point.s22 = 0;
  e.duration = 60;
  for (const CrankshaftFault& fault :
       {CrankshaftFault{CrankshaftFault::Kind::kTauF, 0.5}, {CrankshaftFault::Kind::kJe, 1.4}}) {
    CrankshaftExperiment faulted = e;
    (fault.kind == CrankshaftFault::Kind::kTauF ? faulted.point.tau_f : faulted.point.Je) *=
        fault.factor;
    auto batch = RunCrankshaftExperiment(faulted);
    auto nominal = RunCrankshaftExperiment(e);
    ASSERT_TRUE(batch.ok() && nominal.ok());
    const auto live = RunLive(e, static_cast<int>(batch->columns[0].size()), &fault);
    double largest_effect = 0;
    for (std::size_t k = 0; k < live.size(); ++k) {
      ASSERT_NEAR(live[k].N, batch->columns[3][k], 1e-9) << "sample " << k;
      ASSERT_NEAR(live[k].Pman, batch->columns[4][k], 1e-12) << "sample " << k;
      largest_effect = std::max(largest_effect, std::abs(live[k].N - nominal->columns[3][k]));
    }
    EXPECT_GT(largest_effect, 1.0);  // rpm
  }
}

TEST(LiveCrankshaftDyno, RampsAndClearsTheTruth) {
  auto dyno = LiveCrankshaftDyno::Create(CrankshaftExperiment{});
  ASSERT_TRUE(dyno.ok());
  const CrankshaftPoint p = dyno->experiment().point;
  ASSERT_TRUE(dyno->Inject({CrankshaftFault::Kind::kJe, 3, 10}).ok());
  EXPECT_FALSE(dyno->Inject({CrankshaftFault::Kind::kTauF, -1}).ok());
  for (int k = 0; k < 80; ++k) dyno->Next();  // 5 s at 16 Hz
  EXPECT_NEAR(dyno->Truth().Je, 2 * p.Je, 1e-12);
  EXPECT_EQ(dyno->Truth().tau_f, p.tau_f);
  ASSERT_TRUE(dyno->ClearFaults().ok());
  EXPECT_EQ(dyno->Truth().Je, p.Je);
}

}  // namespace
}  // namespace gb::sim
