// Tests for sim/trinamic/controller: every opcode's observable effect, ramp timing, reference
// search, stop conditions, interpolation, reset flag and both reply framings (trinamic-sixpack.md).
#include "sim/trinamic/controller.h"

#include <cmath>
#include <cstdlib>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::sim::trinamic {
namespace {

using drivegw::trinamic::DecodeCommand;
using drivegw::trinamic::Opcode;
using ::testing::ElementsAre;
using ::testing::ElementsAreArray;
namespace mt = drivegw::trinamic::motor_type;

constexpr uint8_t kRa = 0xF0;

Controller Make(ControllerOptions options = {}) {
  auto c = Controller::Create(options);
  EXPECT_TRUE(c.ok()) << c.status();
  return *std::move(c);
}

Command Cmd(Opcode op, std::initializer_list<int64_t> values, uint8_t address = 1) {
  auto c = drivegw::trinamic::MakeCommand(address, op, values);
  EXPECT_TRUE(c.ok()) << c.status();
  return *c;
}

// Sends raw wire bytes (the reference's byte sequences).
std::optional<std::vector<uint8_t>> Wire(Controller& c, std::vector<uint8_t> bytes) {
  auto cmd = DecodeCommand(bytes);
  EXPECT_TRUE(cmd.ok()) << cmd.status();
  return c.Handle(*cmd);
}

Duration Ticks(int n) { return kTick * n; }

// Runs until the motor is inactive; returns the number of 2 ms ticks.
int RunUntilIdle(Controller& c, int motor, int limit = 100000) {
  int n = 0;
  while (c.state(motor).action != Action::kInactive && n < limit) {
    c.Advance(kTick);
    ++n;
  }
  return n;
}

TEST(Controller, Create_BadOptions_InvalidArgument) {
  ControllerOptions o;
  o.axes = 5;
  EXPECT_FALSE(Controller::Create(o).ok());
  o.axes = 6;
  o.address = 0;
  EXPECT_FALSE(Controller::Create(o).ok());
  o.address = 1;
  o.amax_divisor = 32;
  EXPECT_FALSE(Controller::Create(o).ok());
}

TEST(Controller, QueryPosition_ReferenceExample_R8ByteExact) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kSetPosition, {2, -1234}));
  auto reply = Wire(c, {0x01, 0x20, 0x02, 0xF0, 0, 0, 0, 0, 0});  // §6.3
  ASSERT_TRUE(reply);
  EXPECT_THAT(*reply, ElementsAre(0x20, 0x02, 0x2E, 0xFB, 0xFF, 0xFF, 0x00, 0x00));
}

TEST(Controller, QueryPosition_R9Framing_PrefixedWithResponseAddress) {
  ControllerOptions o;
  o.framing = ReplyFraming::kR9;
  Controller c = Make(o);
  c.Handle(Cmd(Opcode::kSetPosition, {2, -1234}));
  auto reply = Wire(c, {0x01, 0x20, 0x02, 0xF0, 0, 0, 0, 0, 0});
  ASSERT_TRUE(reply);
  EXPECT_THAT(*reply, ElementsAre(0xF0, 0x20, 0x02, 0x2E, 0xFB, 0xFF, 0xFF, 0x00, 0x00));
}

TEST(Controller, UnitInformation_ResetFlagOnceThenZero) {
  Controller c = Make();
  auto first = Wire(c, {0x01, 0x43, 0xF0, 0, 0, 0, 0, 0, 0});  // §6.6
  ASSERT_TRUE(first);
  EXPECT_THAT(*first, ElementsAre(0x43, 0x94, 0x01, 0x1F, 0x34, 0x12, 0x00, 0x00));
  auto second = c.Handle(Cmd(Opcode::kUnitInformation, {kRa}));
  ASSERT_TRUE(second);
  EXPECT_EQ((*second)[2], 0);
}

TEST(Controller, HardwareReset_DefaultsBusyAndResetFlag) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kUnitInformation, {kRa}));
  c.Handle(Cmd(Opcode::kSetRamp, {0, 64, 300}));
  c.Handle(Cmd(Opcode::kSetPosition, {0, 77}));
  EXPECT_FALSE(Wire(c, {0x01, 0xCC, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_TRUE(c.busy());
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kUnitInformation, {kRa})));  // ~1 s busy (L900)
  c.Advance(std::chrono::milliseconds(1000));
  EXPECT_FALSE(c.busy());
  EXPECT_EQ(c.registers(0).amax, 128);
  EXPECT_EQ(c.registers(0).vmax, 511);
  EXPECT_EQ(c.state(0).position, 0);
  auto info = c.Handle(Cmd(Opcode::kUnitInformation, {kRa}));
  ASSERT_TRUE(info);
  EXPECT_EQ((*info)[2], 1);
}

// ---- Ramp generator (§5.3, §5.4) ----

TEST(ControllerRamp, Defaults_VelocityIncrementTwoPerTickAndVmaxAfter506ms) {
  Controller c = Make();
  Wire(c, {0x01, 0x23, 0x02, 0xA0, 0x86, 0x01, 0x00, 0x00, 0x00});  // §6.2 motor 2 → 100 000
  EXPECT_EQ(c.state(2).action, Action::kRamp);
  c.Advance(kTick);
  EXPECT_EQ(c.vact(2), 7);  // vstart 5 + amax/64 = 2 (L545, L557)
  c.Advance(kTick);
  EXPECT_EQ(c.vact(2), 9);
  c.Advance(Ticks(250));
  EXPECT_EQ(c.vact(2), 509);
  c.Advance(kTick);  // tick 253: t_acc = 0.128 × 506 / 128 = 0.506 s
  EXPECT_EQ(c.vact(2), 511);
  // s_acc = 0.064 × K × (511² − 5²) / 128 ≈ 6640 µsteps (§5.3)
  EXPECT_NEAR(c.state(2).position, 6640, 6640 * 0.02);
}

TEST(ControllerRamp, LongMove_DurationWithinTwoPercentAndExactLandingWithoutOvershoot) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kStartRamp, {0, 100000}));
  int ticks = 0;
  int32_t max_pos = 0;
  while (c.state(0).action != Action::kInactive && ticks < 10000) {
    c.Advance(kTick);
    max_pos = std::max(max_pos, c.state(0).position);
    ++ticks;
  }
  EXPECT_EQ(c.state(0).position, 100000);
  EXPECT_EQ(max_pos, 100000);
  EXPECT_EQ(c.vact(0), 0);
  EXPECT_NEAR(ticks * 0.002, 4.35, 4.35 * 0.02);  // closed form §5.4
}

TEST(ControllerRamp, ShortMove_TrianglePeakAndDuration) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kStartRamp, {0, -1000}));
  int ticks = 0;
  int peak = 0;
  while (c.state(0).action != Action::kInactive && ticks < 1000) {
    c.Advance(kTick);
    peak = std::max(peak, std::abs(c.vact(0)));
    ++ticks;
  }
  EXPECT_EQ(c.state(0).position, -1000);
  EXPECT_NEAR(peak, 140, 10);                     // v_peak ≈ 140 (§5.4)
  EXPECT_NEAR(ticks * 0.002, 0.27, 0.27 * 0.08);  // t ≈ 0.27 s
}

TEST(ControllerRamp, Advance_KeepsRemainderBelowOneCycle) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kStartRamp, {0, 100000}));
  c.Advance(std::chrono::microseconds(1500));
  EXPECT_EQ(c.ticks(), 0);
  c.Advance(std::chrono::microseconds(1500));
  EXPECT_EQ(c.ticks(), 1);
  c.Advance(std::chrono::microseconds(1000));
  EXPECT_EQ(c.ticks(), 2);
}

TEST(ControllerRamp, AmaxDivisor16_FourTimesFaster) {
  ControllerOptions o;
  o.amax_divisor = 16;  // L363 reading (G-07)
  Controller c = Make(o);
  c.Handle(Cmd(Opcode::kStartRamp, {0, 100000}));
  c.Advance(kTick);
  EXPECT_EQ(c.vact(0), 13);  // 5 + 128/16
}

TEST(ControllerRamp, StartRamp_IgnoredWhileActive) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kStartRamp, {0, 100000}));
  c.Advance(Ticks(10));
  c.Handle(Cmd(Opcode::kStartRamp, {0, 5}));  // L691
  EXPECT_EQ(c.state(0).target, 100000);
}

TEST(ControllerRamp, SetTarget_OnTheFlyLengthensRampWithoutStartingStandingMotor) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kSetTarget, {1, 3000}));
  c.Advance(Ticks(5));
  EXPECT_EQ(c.state(1).action, Action::kInactive);  // mode unchanged (L722)
  EXPECT_EQ(c.state(1).position, 0);
  c.Handle(Cmd(Opcode::kStartRamp, {1, 3000}));
  c.Advance(Ticks(20));
  c.Handle(Cmd(Opcode::kSetTarget, {1, 20000}));
  RunUntilIdle(c, 1);
  EXPECT_EQ(c.state(1).position, 20000);
}

TEST(ControllerRamp, SetTarget_TooLate_OvershootsAndReturns) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kStartRamp, {0, 100000}));
  c.Advance(Ticks(300));
  const int32_t here = c.state(0).position;
  c.Handle(Cmd(Opcode::kSetTarget, {0, here + 10}));
  int32_t max_pos = here;
  for (int i = 0; i < 5000 && c.state(0).action != Action::kInactive; ++i) {
    c.Advance(kTick);
    max_pos = std::max(max_pos, c.state(0).position);
  }
  EXPECT_GT(max_pos, here + 10);  // L722
  EXPECT_EQ(c.state(0).position, here + 10);
}

TEST(ControllerRamp, SetRamp_VmaxLoweredDuringMotion) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kStartRamp, {0, 1000000}));
  c.Advance(Ticks(300));
  EXPECT_EQ(c.vact(0), 511);
  c.Handle(Cmd(Opcode::kSetRamp, {0, 128, 200}));  // L552: effective immediately
  c.Advance(Ticks(200));
  EXPECT_EQ(c.vact(0), 200);
  EXPECT_EQ(c.registers(0).amax, 128);
}

TEST(ControllerRamp, StopMotors_TargetIsActualPositionOvershootAndReturn) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kStartRamp, {0, 100000}));
  c.Advance(Ticks(300));
  const int32_t at_stop = c.state(0).position;
  Wire(c, {0x01, 0x2A, 0x3F, 0, 0, 0, 0, 0, 0});  // §6.6 stop all
  EXPECT_EQ(c.state(0).target, at_stop);
  int32_t max_pos = at_stop;
  for (int i = 0; i < 5000 && c.state(0).action != Action::kInactive; ++i) {
    c.Advance(kTick);
    max_pos = std::max(max_pos, c.state(0).position);
  }
  EXPECT_GT(max_pos, at_stop);  // overshoot (L767)
  EXPECT_EQ(c.state(0).position, at_stop);
}

TEST(ControllerRamp, StartRampParallel_StartsMaskedMotorsInSameTick) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kSetTarget, {0, 5000}));
  c.Handle(Cmd(Opcode::kSetTarget, {1, -5000}));
  c.Handle(Cmd(Opcode::kSetTarget, {2, 7000}));
  c.Handle(Cmd(Opcode::kStartRampParallel, {0x03}));
  EXPECT_EQ(c.state(0).action, Action::kRamp);
  EXPECT_EQ(c.state(1).action, Action::kRamp);
  EXPECT_EQ(c.state(2).action, Action::kInactive);
  c.Advance(kTick);
  EXPECT_EQ(c.vact(0), 7);
  EXPECT_EQ(c.vact(1), -7);
  RunUntilIdle(c, 0);
  EXPECT_EQ(c.state(1).action, Action::kInactive);  // symmetric moves end in the same tick
  EXPECT_EQ(c.state(1).position, -5000);
}

TEST(ControllerRamp, VelocitySetting_ChangesScaleOnlyWhileAllStopped) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kVelocitySetting, {2}));
  EXPECT_EQ(c.globals().clkdiv, 2);
  EXPECT_NEAR(c.K(0, false), 101.725, 0.001);  // §5.1 table
  c.Handle(Cmd(Opcode::kStartRamp, {3, 100000}));
  c.Handle(Cmd(Opcode::kVelocitySetting, {5}));  // L532
  EXPECT_EQ(c.globals().clkdiv, 2);
}

TEST(ControllerRamp, StartingVelocity_SetsVstartAndDivOnlyWhileStopped) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kStartingVelocity, {0, 6, 20, 1}));
  EXPECT_EQ(c.registers(0).vmin, 6);
  EXPECT_EQ(c.registers(0).div, 1);
  c.Handle(Cmd(Opcode::kStartRamp, {0, 100000}));
  c.Advance(kTick);
  EXPECT_EQ(c.vact(0), 22);                                // starts at vstart 20 (L545)
  c.Handle(Cmd(Opcode::kStartingVelocity, {0, 4, 5, 2}));  // L539
  EXPECT_EQ(c.registers(0).vstart, 20);
}

// ---- Rotation, PI (§5.5, §5.6) ----

TEST(ControllerRotation, StartRotation_AcceleratesToVelocityAndZeroStops) {
  Controller c = Make();
  Wire(c, {0x01, 0x25, 0x01, 0x2C, 0x01, 0, 0, 0, 0});  // §6.6 rotate +300
  EXPECT_EQ(c.state(1).action, Action::kRotation);
  c.Advance(Ticks(200));
  EXPECT_EQ(c.vact(1), 300);
  auto r = c.Handle(Cmd(Opcode::kQueryVelocity, {1, kRa}));
  ASSERT_TRUE(r);
  EXPECT_THAT(*r, ElementsAre(0x21, 0x01, 0x2C, 0x01, 15, 0, 0, 0));
  c.Handle(Cmd(Opcode::kStartRotation, {1, 0}));  // G-36
  RunUntilIdle(c, 1);
  EXPECT_EQ(c.vact(1), 0);
}

TEST(ControllerRotation, StartRampDuringRotation_OnlyStops) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kStartRotation, {0, -200}));
  c.Advance(Ticks(200));
  c.Handle(Cmd(Opcode::kStartRamp, {0, 50000}));  // L693
  RunUntilIdle(c, 0);
  EXPECT_EQ(c.state(0).action, Action::kInactive);
  EXPECT_LT(c.state(0).position, 0);
}

TEST(ControllerPi, ActivatePi_ConvergesToTargetWithAction10) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kPiParameters, {0, 4, 100, 50, 2}));
  EXPECT_EQ(c.registers(0).propdiv, 4);
  EXPECT_EQ(c.registers(0).intinpclip, 2);
  c.Handle(Cmd(Opcode::kActivatePi, {0, 3000}));
  c.Advance(std::chrono::seconds(3));
  EXPECT_EQ(c.state(0).action, Action::kPi);  // G-34: stays 10
  EXPECT_EQ(c.state(0).position, 3000);
}

// ---- Position limits: rotary wrap (L695-698, L713) ----

TEST(ControllerLimits, RotaryNullLeft_PositionsWrapInZeroToPoslimit) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kMotorParameters, {0, 6400, mt::kRotaryAxis | mt::kNullLeft, 0}));
  c.Handle(Cmd(Opcode::kStartRotation, {0, 511}));
  bool wrapped = false;
  int32_t last = 0;
  for (int i = 0; i < 1000; ++i) {
    c.Advance(kTick);
    const int32_t p = c.state(0).position;
    EXPECT_GE(p, 0);
    EXPECT_LT(p, 6400);
    if (p < last) wrapped = true;
    last = p;
  }
  EXPECT_TRUE(wrapped);
}

TEST(ControllerLimits, RotaryNullRight_PositionsInMinusPoslimitToZero) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kMotorParameters, {0, 6400, mt::kRotaryAxis, 0}));
  c.Handle(Cmd(Opcode::kStartRotation, {0, -511}));
  for (int i = 0; i < 1000; ++i) {
    c.Advance(kTick);
    EXPECT_LE(c.state(0).position, 0);
    EXPECT_GT(c.state(0).position, -6400);
  }
}

// ---- Interpolation (§5.5, §6.4) ----

TEST(ControllerInterpolation, ReferenceExample_AllAxesArriveTogetherOnTheLine) {
  Controller c = Make();
  Wire(c, {0x01, 0x26, 0x00, 0xE8, 0x03, 0, 0, 0, 0});
  Wire(c, {0x01, 0x26, 0x01, 0xD0, 0x07, 0, 0, 0, 0});
  Wire(c, {0x01, 0x50, 0x03, 0, 0, 0, 0, 0, 0});
  int ticks = 0;
  while ((c.state(0).action != Action::kInactive || c.state(1).action != Action::kInactive) &&
         ticks < 5000) {
    EXPECT_EQ(c.state(0).action, c.state(1).action);
    EXPECT_NEAR(c.state(0).position * 2, c.state(1).position, 2);
    c.Advance(kTick);
    ++ticks;
  }
  EXPECT_EQ(c.state(0).position, 1000);
  EXPECT_EQ(c.state(1).position, 2000);
}

TEST(ControllerInterpolation, SlaveLimitReducesMasterVelocity) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kSetRamp, {0, 128, 100}));  // slave vmax 100
  c.Handle(Cmd(Opcode::kSetTarget, {0, 50000}));
  c.Handle(Cmd(Opcode::kSetTarget, {1, 100000}));
  c.Handle(Cmd(Opcode::kInterpolate, {0x03}));
  int peak = 0;
  while (c.state(1).action != Action::kInactive) {
    c.Advance(kTick);
    peak = std::max(peak, c.vact(1));
  }
  EXPECT_EQ(peak, 200);  // master ≤ 100 × 100000/50000
  EXPECT_EQ(c.state(0).position, 50000);
  EXPECT_EQ(c.state(0).action, Action::kInactive);
}

TEST(ControllerInterpolation, MovingMaskedMotor_Ignored) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kStartRotation, {0, 100}));
  c.Handle(Cmd(Opcode::kSetTarget, {1, 1000}));
  c.Handle(Cmd(Opcode::kInterpolate, {0x03}));
  EXPECT_EQ(c.state(1).action, Action::kInactive);
}

TEST(ControllerInterpolation, StopMaster_ReleasesSlavesWhereTheyAre) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kSetTarget, {0, 10000}));
  c.Handle(Cmd(Opcode::kSetTarget, {1, 20000}));
  c.Handle(Cmd(Opcode::kInterpolate, {0x03}));
  c.Advance(Ticks(100));
  c.Handle(Cmd(Opcode::kStopMotors, {0x02}));  // motor 1 is the master
  EXPECT_EQ(c.state(0).action, Action::kInactive);
  const int32_t slave = c.state(0).position;
  RunUntilIdle(c, 1);
  EXPECT_EQ(c.state(0).position, slave);
  EXPECT_EQ(c.state(0).action, Action::kInactive);
}

// ---- Reference search (§5.7) ----

Controller RefController(uint16_t motor_type, int32_t nulloffset, bool stop_after) {
  ControllerOptions o;
  o.world[0].switch_low = 10000;
  o.world[0].switch_high = 10500;
  Controller c = Make(o);
  c.Handle(Cmd(Opcode::kMotorParameters, {0, 20000, motor_type & 0xFF, motor_type >> 8}));
  c.Handle(Cmd(Opcode::kNullOffset, {0, nulloffset, 240}));
  c.Handle(Cmd(Opcode::kReferenceParameters, {0, 100, 0x0001, stop_after ? 1 : 0}));
  return c;
}

std::vector<int> Phases(Controller& c, int motor, int limit) {
  std::vector<int> seen;
  for (int i = 0; i < limit; ++i) {
    const int a = static_cast<int>(c.state(motor).action);
    if (seen.empty() || seen.back() != a) seen.push_back(a);
    if (a == 0) break;
    c.Advance(kTick);
  }
  return seen;
}

TEST(ControllerReference, FastRef_PhasesAndFinalPositionWithNullOffset) {
  Controller c = RefController(mt::kFastRef, 100, true);
  Wire(c, {0x01, 0x22, 0x00, 0, 0, 0, 0, 0, 0});
  EXPECT_THAT(Phases(c, 0, 200000), ElementsAre(20, 21, 22, 23, 25, 26, 0));
  EXPECT_EQ(c.state(0).position, 0);
  EXPECT_EQ(c.state(0).rotor, 10000 + 100);  // edge + nulloffset in search direction (G-12)
}

TEST(ControllerReference, NullCenter_ZeroAtCentreOfSwitch) {
  Controller c = RefController(mt::kNullCenter, 0, true);
  EXPECT_THAT(Phases(c, 0, 1), ElementsAre(0));
  c.Handle(Cmd(Opcode::kStartReferenceSearch, {0}));
  EXPECT_THAT(Phases(c, 0, 400000), ElementsAre(20, 23, 24, 25, 26, 0));
  EXPECT_EQ(c.state(0).rotor, (10000 + 10501) / 2);
  EXPECT_EQ(c.state(0).position, 0);
}

TEST(ControllerReference, NullLeft_SearchesDescendingAndResumesPreviousPosition) {
  ControllerOptions o;
  o.world[0].switch_low = -3000;
  o.world[0].switch_high = -2000;
  Controller c = Make(o);
  c.Handle(Cmd(Opcode::kMotorParameters,
               {0, 20000, mt::kNullLeft, (mt::kFastRef | mt::kStopNoRef) >> 8}));
  c.Handle(Cmd(Opcode::kReferenceParameters, {0, 100, 0x0001, 0}));
  c.Handle(Cmd(Opcode::kSetPosition, {0, 700}));
  c.Handle(Cmd(Opcode::kStartReferenceSearch, {0}));
  EXPECT_THAT(Phases(c, 0, 400000), ElementsAre(20, 21, 22, 23, 25, 26, 0));
  EXPECT_EQ(c.state(0).position, 700);  // back to the numeric position held before (L680)
  EXPECT_EQ(c.state(0).rotor, -2000 + 700);
}

TEST(ControllerReference, AutoNullCmdBit_StartsSearchAndIsNotStored) {
  Controller c = RefController(mt::kFastRef, 0, true);
  c.Handle(Cmd(Opcode::kMotorParameters, {0, 20000, mt::kAutoNullCmd, mt::kFastRef >> 8}));
  EXPECT_EQ(c.state(0).action, Action::kRefStop);
  EXPECT_EQ(c.registers(0).motor_type & mt::kAutoNullCmd, 0);
  EXPECT_EQ(c.registers(0).poslimit, 20000);
}

TEST(ControllerReference, StuckInactiveSwitch_RetriesForever) {
  Controller c = RefController(mt::kFastRef, 0, true);
  c.SetStuckSwitch(0, false);
  c.Handle(Cmd(Opcode::kStartReferenceSearch, {0}));
  std::vector<int> phases = Phases(c, 0, 20000);
  EXPECT_GE(std::count(phases.begin(), phases.end(), 20), 2);  // 125 % → repeat (L680)
  EXPECT_NE(c.state(0).action, Action::kInactive);
}

TEST(ControllerReference, MechRef_Drives5Of4PoslimitThenZero) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kMotorParameters, {0, 4000, 0, mt::kMechRef >> 8}));
  c.Handle(Cmd(Opcode::kStartReferenceSearch, {0}));
  std::vector<int> phases = Phases(c, 0, 100000);
  EXPECT_THAT(phases, ElementsAre(20, 30, 0));
  EXPECT_EQ(c.state(0).rotor, 5000);
  EXPECT_EQ(c.state(0).position, 0);
}

TEST(ControllerReference, FilterSwitch_DebounceDelaysSwitchRecognition) {
  ControllerOptions o;
  o.world[0].switch_low = 0;
  o.world[0].switch_high = 10;
  Controller c = Make(o);
  c.Handle(Cmd(Opcode::kMotorParameters, {0, 6400, mt::kFilterSwitch, 0}));
  c.Handle(Cmd(Opcode::kReferenceParameters, {0, 100, 0x000F, 1}));  // 4 samples
  c.LoseSteps(0, 100);                                               // rotor leaves the switch
  c.Advance(Ticks(3));
  EXPECT_TRUE(c.state(0).switch_filtered);
  c.Advance(kTick);
  EXPECT_FALSE(c.state(0).switch_filtered);
  EXPECT_EQ(c.registers(0).debounce_mask, 0x000F);
  EXPECT_TRUE(c.registers(0).stop_after_search);
}

// ---- Stop conditions (§5.8) ----

TEST(ControllerStop, AnalogMaxRight_AbruptStopFlagLostSteps) {
  Controller c = Make();
  Wire(c, {0x01, 0x31, 0x00, 0x64, 0x00, 0x84, 0x03, 0, 0});  // §6.6 limits 100 / 900
  EXPECT_EQ(c.registers(0).stop_max_right, 900);
  c.Handle(Cmd(Opcode::kMotorParameters, {0, 6400, 0, mt::kStopNoRef >> 8}));
  c.Handle(Cmd(Opcode::kStartRamp, {0, 100000}));
  c.Advance(Ticks(300));
  c.world(0).analog = 950;
  c.Advance(kTick);
  EXPECT_EQ(c.state(0).action, Action::kInactive);
  EXPECT_EQ(c.vact(0), 0);
  EXPECT_LT(c.state(0).rotor, c.state(0).position);  // lost steps on an abrupt stop
  auto r = c.Handle(Cmd(Opcode::kQueryPosition, {0, kRa}));
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)[7], 1);
  r = c.Handle(Cmd(Opcode::kQueryPosition, {0, kRa}));
  EXPECT_EQ((*r)[7], 0);  // cleared after read (L663)
}

TEST(ControllerStop, AnalogMinLeftWithStopSoft_DeceleratesGradually) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kAnalogStopLimits, {0, 100, 1023}));
  c.Handle(Cmd(Opcode::kMotorParameters, {0, 6400, 0, (mt::kStopNoRef | mt::kStopSoft) >> 8}));
  c.Handle(Cmd(Opcode::kStartRamp, {0, -100000}));
  c.Advance(Ticks(300));
  c.world(0).analog = 50;
  c.Advance(kTick);
  EXPECT_LT(c.vact(0), -400);
  EXPECT_TRUE(c.state(0).stop_flag);
  RunUntilIdle(c, 0);
  EXPECT_EQ(c.state(0).rotor, c.state(0).position);
}

TEST(ControllerStop, StopWithoutStopNoRef_StartsReferenceSearch) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kAnalogStopLimits, {0, 0, 900}));
  c.world(0).analog = 1000;
  c.Handle(Cmd(Opcode::kStartRamp, {0, 100000}));
  c.Advance(Ticks(2));
  EXPECT_GE(static_cast<int>(c.state(0).action), 20);  // AutoNullCmd (L582, L598)
}

TEST(ControllerStop, StopNull_SwitchActiveOutsideRangeStops) {
  ControllerOptions o;
  o.world[0].switch_low = 5000;
  o.world[0].switch_high = 6000;
  Controller c = Make(o);
  c.Handle(Cmd(Opcode::kMotorParameters, {0, 20000, mt::kStopNull, mt::kStopNoRef >> 8}));
  c.Handle(Cmd(Opcode::kStartRamp, {0, 100000}));
  RunUntilIdle(c, 0);
  EXPECT_TRUE(c.state(0).stop_flag);
  EXPECT_NEAR(c.state(0).position, 5000, 600);
}

// ---- Queries and registers (§4.2) ----

TEST(ControllerQuery, QueryActivities_ImmediateAndDelayed) {
  Controller c = Make();
  auto r = Wire(c, {0x01, 0x28, 0xF0, 0x3F, 0, 0, 0, 0, 0});
  ASSERT_TRUE(r);
  EXPECT_THAT(*r, ElementsAre(0x28, 0, 0, 0, 0, 0, 0, 0));
  c.Handle(Cmd(Opcode::kStartRamp, {3, 2000}));
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kQueryActivities, {kRa, 0x08})));  // delayed (L740)
  auto now = c.Handle(Cmd(Opcode::kQueryActivities, {kRa, 0x01}));
  ASSERT_TRUE(now);
  EXPECT_EQ((*now)[4], 5);
  EXPECT_FALSE(c.TakeDelayedReply());  // replaced by the later query (decision 1036)
  c.Handle(Cmd(Opcode::kQueryActivities, {kRa, 0x08}));
  EXPECT_FALSE(c.TakeDelayedReply());
  RunUntilIdle(c, 3);
  auto late = c.TakeDelayedReply();
  ASSERT_TRUE(late);
  EXPECT_THAT(*late, ElementsAre(0x28, 0, 0, 0, 0, 0, 0, 0));
  EXPECT_FALSE(c.TakeDelayedReply());
}

TEST(ControllerQuery, ReadInputs_SupplyVoltageAndReferenceBits) {
  ControllerOptions o;
  o.world[1].switch_low = -10;
  o.world[1].switch_high = 10;
  o.world[2].analog = 0x3FF;
  Controller c = Make(o);
  auto r = Wire(c, {0x01, 0x30, 0x07, 0xF0, 0, 0, 0, 0, 0});  // §6.6: 24 V
  ASSERT_TRUE(r);
  EXPECT_THAT(*r, ElementsAre(0x30, 0x07, 0x10, 0x02, 0x00, 0x02, 0x00, 0x00));
  r = c.Handle(Cmd(Opcode::kReadInputs, {1, kRa}));
  EXPECT_EQ((*r)[4], 1);
  r = c.Handle(Cmd(Opcode::kReadInputs, {2, kRa}));
  EXPECT_EQ((*r)[2], 0xFF);
  EXPECT_EQ((*r)[3], 0x03);
  c.Handle(Cmd(Opcode::kSetOutputs, {1, 0, 1, 1}));  // TTLIO1 output, high
  EXPECT_THAT(c.globals().outputs, ElementsAre(1, 0, 1, 1));
  r = c.Handle(Cmd(Opcode::kReadInputs, {2, kRa}));
  EXPECT_EQ((*r)[6], 1);
}

TEST(ControllerQuery, PeakCurrent_PairsOnlyFromEvenMotor) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kPeakCurrent, {2, 200}));
  EXPECT_EQ(c.registers(2).peak_current, 200);
  EXPECT_EQ(c.registers(3).peak_current, 200);
  c.Handle(Cmd(Opcode::kPeakCurrent, {3, 10}));  // L507
  EXPECT_EQ(c.registers(3).peak_current, 200);
}

TEST(ControllerQuery, CurrentControlTableNullOffsetReadyBaudTimeoutStored) {
  Controller c = Make();
  Wire(c, {0x01, 0x11, 0x05, 0x08, 0x02, 0x01, 0x00, 0xF4, 0x01});
  EXPECT_THAT(c.registers(5).current_index, ElementsAre(8, 2, 1, 0));
  EXPECT_EQ(c.registers(5).t0, 500);
  Wire(c, {0x01, 0x17, 0x04, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0});
  EXPECT_EQ(c.globals().table[4], 0xFF);
  EXPECT_EQ(c.globals().table[8], 189);
  Wire(c, {0x01, 0x18, 0x01, 0x9C, 0xFF, 0xFF, 0xFF, 0x10, 0x00});
  EXPECT_EQ(c.registers(1).nulloffset, -100);
  EXPECT_EQ(c.registers(1).testnullrange, 16);
  Wire(c, {0x01, 0x33, 0x01, 0x02, 0, 0, 0, 0, 0});
  EXPECT_EQ(c.globals().ready_active_mask, 1);
  EXPECT_EQ(c.globals().ready_reference_mask, 2);
  Wire(c, {0x01, 0x40, 0x82, 0x00, 0x03, 0x00, 0, 0, 0});
  EXPECT_EQ(c.globals().baud_divisor, 130);
  EXPECT_EQ(c.globals().switchover, 3);
  Wire(c, {0x01, 0x41, 0x32, 0x00, 0, 0, 0, 0, 0});
  EXPECT_EQ(c.globals().packet_timeout, 50);
}

TEST(ControllerQuery, ChangeAddress_TakesEffectImmediately) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kChangeAddress, {7}));
  EXPECT_EQ(c.address(), 7);
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kUnitInformation, {kRa}, 1)));
  EXPECT_TRUE(c.Handle(Cmd(Opcode::kUnitInformation, {kRa}, 7)));
}

TEST(ControllerQuery, TunnelPowerDownAndServiceFunctions) {
  ControllerOptions o;
  o.firmware = 149;  // `$45` exists in firmware 1.46 and since 1.49 (L873)
  Controller c = Make(o);
  auto r = c.Handle(Cmd(Opcode::kRs232Tunnel, {kRa, 0x20, 8}));
  ASSERT_TRUE(r);
  EXPECT_THAT(*r, ElementsAre(0x44, 0, 0, 0, 0, 0, 0, 0));
  EXPECT_EQ(c.globals().tunnel_address, 0x20);
  r = c.Handle(Cmd(Opcode::kPowerDown, {kRa, 0x04}));
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)[1], 0);
  EXPECT_TRUE(c.globals().power_down_enabled);
  r = c.Handle(Cmd(Opcode::kFlashChecksum, {kRa}));
  ASSERT_TRUE(r);
  EXPECT_THAT(*r, ElementsAre(0xF4, 0xEF, 0xBE, 0, 0, 0, 0, 0));
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kFlashEnable, {kRa, 0x12345678})));  // G-22
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kEepromRead, {kRa, 1, 2, 3})));
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kFlashRead, {kRa})));
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kFlashProgram, {1, 2, 3, 4, 5, 6, 7})));
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kEepromWrite, {kRa, 1, 2, 3})));
}

TEST(ControllerQuery, SilentCommands_NoReply) {
  Controller c = Make();
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kSetRamp, {0, 128, 511})));
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kStartRamp, {0, 10})));
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kSetPosition, {1, 10})));
  EXPECT_EQ(c.state(1).position, 10);
}

TEST(ControllerQuery, QuadPack_Motor4Ignored) {
  ControllerOptions o;
  o.axes = 4;
  Controller c = Make(o);
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kQueryPosition, {4, kRa})));  // G-17
  c.Handle(Cmd(Opcode::kStartRamp, {4, 1000}));
  EXPECT_EQ(c.state(4).action, Action::kInactive);
  EXPECT_TRUE(c.Handle(Cmd(Opcode::kQueryPosition, {3, kRa})));
}

TEST(ControllerQuery, OtherAddressOrInvalidValues_Ignored) {
  Controller c = Make();
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kUnitInformation, {kRa}, 2)));
  Command bad = Cmd(Opcode::kSetRamp, {0, 128, 511});
  bad.values[2] = 600;  // vmax > 511 (L561)
  c.Handle(bad);
  EXPECT_EQ(c.registers(0).vmax, 511);
}

TEST(ControllerQuery, ReferenceParametersIgnoredWhileMoving) {
  Controller c = Make();
  c.Handle(Cmd(Opcode::kStartRamp, {0, 100000}));
  c.Handle(Cmd(Opcode::kReferenceParameters, {0, 50, 0x0001, 1}));  // L609
  EXPECT_EQ(c.registers(0).vrefmax, 100);
}

TEST(ControllerPowerDown, Firmware148_NoPowerDownCommand) {
  Controller c = Make();  // firmware 148: `$45` exists only in 1.46 and since 1.49 (L873)
  EXPECT_FALSE(c.Handle(Cmd(Opcode::kPowerDown, {kRa, 0x04})));
  EXPECT_FALSE(c.globals().power_down_enabled);
}

TEST(ControllerPowerDown, UndervoltageSavesPositionsWhichSurviveReset) {
  ControllerOptions o;
  o.firmware = 149;
  Controller c = Make(o);
  c.Handle(Cmd(Opcode::kSetPosition, {2, 1234}));
  c.Handle(Cmd(Opcode::kPowerDown, {kRa, 0x04}));
  c.SetSupplyVolts(12.9);  // below 13 V (L877)
  c.Advance(kTick);
  EXPECT_TRUE(c.motors_disabled());
  EXPECT_TRUE(c.eeprom().valid);
  c.Reset();  // power cycle: counters 0, EEPROM kept (decision 1043)
  c.SetSupplyVolts(24.0);
  EXPECT_EQ(c.state(2).position, 0);
  auto r = c.Handle(Cmd(Opcode::kPowerDown, {kRa, 0x01}));  // bit 0: load positions (L881)
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)[1] & 0x03, 0x03);
  EXPECT_EQ(c.state(2).position, 1234);
  r = c.Handle(Cmd(Opcode::kPowerDown, {kRa, 0x02}));  // bit 1: invalidate
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)[1] & 0x02, 0x00);
}

TEST(ControllerPowerDown, NotEnabled_StateTrackedMotorsKeepRunning) {
  ControllerOptions o;
  o.firmware = 146;
  Controller c = Make(o);
  c.Handle(Cmd(Opcode::kStartRotation, {0, 100}));
  c.SetSupplyVolts(12.0);
  c.Advance(Ticks(10));
  EXPECT_TRUE(c.globals().power_down_state);  // always tracked (G-23)
  EXPECT_FALSE(c.motors_disabled());
  EXPECT_EQ(c.state(0).action, Action::kRotation);
}

TEST(ControllerIntrospection, QuadPackPeakCurrentWithDipAndDisplay) {
  ControllerOptions o;
  o.axes = 4;
  o.quad_dip_percent = {100, 66, 33, 0, 100, 100};
  Controller c = Make(o);
  EXPECT_DOUBLE_EQ(c.PeakCurrentMa(0), 750.0);  // 1.5 A × 128/256 (L512)
  EXPECT_NEAR(c.PeakCurrentMa(1), 495.0, 1e-9);
  EXPECT_DOUBLE_EQ(c.PeakCurrentMa(3), 0.0);
  EXPECT_EQ(c.DisplayDigit(), 0);
  c.Handle(Cmd(Opcode::kStartRamp, {0, 1000}));
  c.Handle(Cmd(Opcode::kStartRotation, {1, 50}));
  c.Advance(kTick);
  EXPECT_EQ(c.DisplayDigit(), 2);  // active motors (L66)
  EXPECT_FALSE(c.DisplayPoint());
  c.Handle(Cmd(Opcode::kStartReferenceSearch, {2}));
  EXPECT_TRUE(c.DisplayPoint());
}

TEST(ControllerIntrospection, ReadyOutputOffShowsTtlout1Level) {
  Controller c = Make();
  EXPECT_TRUE(c.Ttlout1High());  // reset state high (G-20)
  c.Handle(Cmd(Opcode::kSetOutputs, {0, 1, 0, 0}));
  c.Handle(Cmd(Opcode::kStartRamp, {0, 1000}));
  EXPECT_FALSE(c.Ttlout1High());  // P0 = 0, ready function off: the programmed level
}

}  // namespace
}  // namespace drivegw::sim::trinamic
