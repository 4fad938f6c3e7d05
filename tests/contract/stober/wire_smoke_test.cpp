// Wire-level AXIS smoke: a handful of AXIS contract cases (stober-motion.md §10, already proven
// on the pure motion core in tests/sim/stober) replayed through the StoberDrive and the CANopen
// bus, to show the binding (object_map.h, decision 1175) carries their semantics.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/contract/stober/wire.h"

namespace drivegw::stober::wire {
namespace {

using ::testing::HasSubstr;

StoberMcRequest Mc(uint8_t command, double position, double velocity, int direction = 0) {
  StoberMcRequest r;
  r.command = command;
  r.position_mm = position;
  r.velocity_mm_s = velocity;
  r.acceleration_mm_s2 = 5000;
  r.deceleration_mm_s2 = 5000;
  r.jerk_mm_s3 = 50000;
  r.direction = direction;
  return r;
}

void Referenced(ss::AxisServer& s) {
  s.WithAxis([](ss::MotionCore& c) { c.SetReferenced(true); });
}

// CT-01 (L113): the rising edge starts; Execute held at 1 does not restart when I403 changes.
TEST_F(WireTest, CT01_Wire_RisingEdgeStartsLevelDoesNotRestart) {
  before_drive_ = Referenced;
  Start();
  const size_t mark = sniffer_->size();
  const uint64_t id = Native(Mc(1, 50, 500));
  EXPECT_EQ(WaitFinal(id).state, CommandState::kDone);
  AtRest(50);
  // The edge frame: I401 1 · I403 50.000 · Execute 1.
  sniffer_->Until(
      [&](const std::vector<Seen>& f) {
        return Sniffer::Any(f, mark, kRpdo1, [](const transport::CanFrame& x) {
          const Rpdo1 r = DecodeRpdo1(x);
          return r.execute && r.command == 1 && r.position == 50;
        });
      },
      "RPDO1 edge I401 1 I403 50");
  // SDO writes of I403 / I402 (the motion core's own inputs, §2.1) on the same node.
  SdoWrite("I403", 80);
  SdoWrite("I402", 1);  // 0 → 1: an edge, the axis moves to 80
  AtRest(80);
  EXPECT_NEAR(Sim("I80"), 80, 1e-6);
  SdoWrite("I403", 20);  // Execute stays 1: no new edge
  // 10 A150 cycles with the level held (the node samples Execute each cycle, decision 1179).
  std::this_thread::sleep_for(10 * std::chrono::duration<double, std::milli>(kCycleMs));
  EXPECT_NEAR(Sim("I80"), 80, 1e-6);
  EXPECT_EQ(Sim("I92"), 1);
  SdoWrite("I402", 0);
  // Low for ≥ one A150 cycle: three, as the adapter's own edges (decision 1197: 2 × A150).
  std::this_thread::sleep_for(3 * std::chrono::duration<double, std::milli>(kCycleMs));
  SdoWrite("I402", 1);
  AtRest(20);
  EXPECT_NEAR(Sim("I80"), 20, 1e-6);
  SdoWrite("I402", 0);  // leave Execute low for the adapter's next edge
}

// CT-05 (L227): a target outside I50/I51 is denied; the API names the rule, the wire shows
// I91 = 1 with the I90 cause and I89 7; the axis does not move.
TEST_F(WireTest, CT05_Wire_SoftwareLimitDenialNamesTheRule) {
  before_drive_ = Referenced;
  Start();
  ASSERT_TRUE(drive_->WriteParameter(ParameterRef{Id("I50"), false}, 100).ok());
  const size_t mark = sniffer_->size();
  const CommandInfo end = WaitFinal(Move(MoveAbsolute{150, 200, 2000, 2000}).id);
  EXPECT_EQ(end.state, CommandState::kError);
  EXPECT_THAT(end.message, HasSubstr("software limits I50..I51"));
  sniffer_->Until(
      [&](const std::vector<Seen>& f) {
        return Sniffer::Any(f, mark, kTpdo1, [](const transport::CanFrame& x) {
          const Tpdo1 t = DecodeTpdo1(x);
          return t.error() && t.cause != 0 && t.plc_state == 7;
        });
      },
      "TPDO1 I91 1, I90 cause, I89 7");
  EXPECT_NEAR(Sim("I80"), 0, 1e-9);
  auto ack = drive_->AcknowledgeFault();
  ASSERT_TRUE(ack.ok()) << ack.status();
  EXPECT_EQ(ack->state, CommandState::kDone);
}

// CT-23 Table 11 row 2 (L741-762, scaled 1:10): MoveAbsolute 100, MC_Stop during travel, then
// MoveAdditive 20 ends at 120 — the base is the last set position, MC_Stop leaves it valid.
TEST_F(WireTest, CT23_Wire_MoveAdditiveBaseAfterStopIsTheLastSetPosition) {
  before_drive_ = Referenced;
  Start();
  const CommandInfo abs = Move(MoveAbsolute{100, 200, 2000, 2000});
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 20; });
  EXPECT_EQ(WaitFinal(Move(StopMotion{5000}).id).state, CommandState::kDone);
  EXPECT_EQ(drive_->GetCommand(abs.id)->state, CommandState::kAborted);
  const DriveStatus stopped =
      WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kEnabled; });
  EXPECT_LT(stopped.position_mm, 90);
  const size_t mark = sniffer_->size();
  const uint64_t add = Native(Mc(3, 20, 300));
  EXPECT_EQ(WaitFinal(add).state, CommandState::kDone) << drive_->GetCommand(add)->message;
  EXPECT_NEAR(AtRest(120).position_mm, 120, 1e-6);
  sniffer_->Until(  // I403 is the distance, not the target
      [&](const std::vector<Seen>& f) {
        return Sniffer::Any(f, mark, kRpdo1, [](const transport::CanFrame& x) {
          const Rpdo1 r = DecodeRpdo1(x);
          return r.execute && r.command == 3 && r.position == 20;
        });
      },
      "RPDO1 edge I401 3 I403 20");
}

// CT-28 (L265-271): endless axis at 10, MoveAbsolute 350 with I411 = 1 (only positive) travels
// +340; I411 goes out in RPDO4 before the edge, TPDO2's 606Ch never shows a negative velocity.
TEST_F(WireTest, CT28_Wire_EndlessMoveAbsoluteOnlyPositive) {
  ss::AxisServerOptions o;
  o.axis.endless = true;
  o.axis.revolution = 360;
  before_drive_ = Referenced;
  Start(o);
  EXPECT_EQ(WaitFinal(Native(Mc(1, 10, 900))).state, CommandState::kDone);
  AtRest(10);
  const size_t mark = sniffer_->size();
  const uint64_t id = Native(Mc(1, 350, 900, 1));
  EXPECT_EQ(WaitFinal(id).state, CommandState::kDone) << drive_->GetCommand(id)->message;
  EXPECT_NEAR(AtRest(350).position_mm, 350, 1e-6);
  // The whole travel is recorded once TPDO2 shows the axis at rest at 350.
  sniffer_->Until(
      [&](const std::vector<Seen>& f) {
        return Sniffer::Any(f, mark, kTpdo2, [](const transport::CanFrame& x) {
          const std::vector<double> v = DecodeTpdo2(x);
          return v.size() == 2 && std::abs(v[0] - 350) < 1e-6 && v[1] == 0;
        });
      },
      "TPDO2 at rest at 350");
  const std::vector<Seen> rpdo4 = sniffer_->With(kRpdo4, mark);
  ASSERT_FALSE(rpdo4.empty());
  EXPECT_EQ(Unpack(co::PdoKind::kRpdo, 4, rpdo4.back().frame)[1], 1);  // I411
  double lowest = 0, highest = 0;
  for (const Seen& s : sniffer_->With(kTpdo2, mark)) {
    const std::vector<double> v = DecodeTpdo2(s.frame);
    ASSERT_EQ(v.size(), 2u);
    lowest = std::min(lowest, v[1]);
    highest = std::max(highest, v[1]);
  }
  EXPECT_GE(lowest, 0) << "the axis moved negative (shortest path) despite I411 = 1";
  EXPECT_GT(highest, 100);
}

// CT-47 / CT-42 (L1918, L1926, L1039, L1043): MC_Halt shows I89 3 and lets a new command start
// before standstill; MC_Stop shows I89 6 (Stopping).
TEST_F(WireTest, CT47_Wire_HaltLetsANewCommandInStopHoldsStopping) {
  before_drive_ = Referenced;
  Start();
  const CommandInfo far = Move(MoveAbsolute{150, 200, 2000, 2000});
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 5; });
  size_t mark = sniffer_->size();
  StoberMcRequest halt;
  halt.command = 11;
  halt.deceleration_mm_s2 = 500;  // 200 mm/s → 0 in 400 ms: time to start a new command
  halt.jerk_mm_s3 = 5000;
  const uint64_t h = Native(halt);
  EXPECT_EQ(drive_->GetCommand(far.id)->state, CommandState::kAborted);
  ASSERT_TRUE(sniffer_->WaitFor([&](const std::vector<Seen>& f) {
    for (size_t i = mark; i < f.size(); ++i) {
      if (f[i].frame.id == kTpdo1 && DecodeTpdo1(f[i].frame).plc_state == 3) return true;
    }
    return false;
  })) << "I89 = 3 (Halt) never on the bus";
  EXPECT_GT(std::abs(drive_->GetStatus().velocity_mm_s), 1) << "standstill already";
  const CommandInfo next = Move(MoveAbsolute{-30, 500, 5000, 5000});
  EXPECT_EQ(drive_->GetCommand(h)->state, CommandState::kAborted);
  EXPECT_EQ(WaitFinal(next.id).state, CommandState::kDone) << drive_->GetCommand(next.id)->message;
  AtRest(-30);

  Move(MoveAbsolute{150, 200, 2000, 2000});
  WaitUntil([](const DriveStatus& s) { return s.position_mm > -20; });
  mark = sniffer_->size();
  const CommandInfo stop = Move(StopMotion{1000});
  ASSERT_TRUE(sniffer_->WaitFor([&](const std::vector<Seen>& f) {
    for (size_t i = mark; i < f.size(); ++i) {
      if (f[i].frame.id == kTpdo1 && DecodeTpdo1(f[i].frame).plc_state == 6) return true;
    }
    return false;
  })) << "I89 = 6 (Stopping) never on the bus";
  EXPECT_EQ(WaitFinal(stop.id).state, CommandState::kDone);
}

}  // namespace
}  // namespace drivegw::stober::wire
