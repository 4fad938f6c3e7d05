// STOBER contract cases that target the ADAPTER (stober-motion.md §10.10, CT-67..CT-71): the
// gateway's StoberDrive against the simulated axis on the UDP multicast CAN bus, checked on the
// wire by a sniffer channel (byte-exact where the case is about bytes). Decisions 1221-1229.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "tests/contract/stober/wire.h"

namespace drivegw::stober::wire {
namespace {

using ::testing::AnyOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

bool Running(CommandState s) { return s == CommandState::kBusy || s == CommandState::kActive; }

// Index (into `all`) of the first RPDO1 with Execute = 1 at or after `from`.
std::optional<size_t> NextEdge(const std::vector<Seen>& all, size_t from) {
  for (size_t i = from; i < all.size(); ++i) {
    if (all[i].frame.id == kRpdo1 && DecodeRpdo1(all[i].frame).execute) return i;
  }
  return std::nullopt;
}

// The RPDO1 from which Execute was 0 without interruption up to `edge`: the first of the run of
// Execute = 0 RPDO1 frames before it (nullopt when the frame before the edge had Execute = 1 or
// no RPDO1 precedes it). Enable's control words also carry I402 = 0 (decision 1175).
std::optional<size_t> LowSince(const std::vector<Seen>& all, size_t edge) {
  std::optional<size_t> low;
  for (size_t i = edge; i-- > 0;) {
    if (all[i].frame.id != kRpdo1) continue;
    if (DecodeRpdo1(all[i].frame).execute) break;
    low = i;
  }
  return low;
}

// ---------------------------------------------------------------- CT-67

// CT-67 (L113, G-05; decisions 1175, 1179, 1197): set values travel before or with the rising edge;
// Execute found high is lowered first and kept low ≥ one A150 cycle and ≥ one bus cycle.
TEST_F(WireTest, CT67_SetValuesBeforeTheEdgeExecuteLowFirst) {
  ss::AxisServerOptions o;
  o.axis.cycle_ms = 8;  // A150 = 8 ms: the low time is measurable against receive jitter
  before_drive_ = [](ss::AxisServer& s) {
    s.WithAxis([](ss::MotionCore& c) {
      c.SetReferenced(true);
      ASSERT_TRUE(c.Write(P("I402"), 1).ok());  // Execute high when the gateway arrives
    });
  };
  Start(o, 3000, -3000);
  ASSERT_EQ(Sim("I402"), 0) << "Execute found high at configuration must be lowered";
  const Duration a150 = 8ms;
  const Duration bus_cycle = std::chrono::milliseconds(2);  // canopen.sync_period default
  const Duration min_low = std::max(a150, bus_cycle);

  const size_t mark = sniffer_->size();
  const CommandInfo a = Move(MoveAbsolute{2000, 500, 0, 0});
  EXPECT_TRUE(Running(a.state)) << a.message;
  std::vector<Seen> all = sniffer_->Until(
      [&](const std::vector<Seen>& f) { return NextEdge(f, mark).has_value(); }, "edge of A");
  const std::optional<size_t> edge = NextEdge(all, mark);
  ASSERT_TRUE(edge.has_value());
  // RPDO1 = 6040h 001Fh (enable operation + bit 4 Execute) · I401 1 · I403 2000.000 · I402 1:
  // the set values are in the edge frame and Execute is its last byte (decision 1175).
  EXPECT_THAT(all[*edge].frame.payload(),
              ElementsAre(0x1F, 0x00, 0x01, 0x80, 0x84, 0x1E, 0x00, 0x01));
  // The dynamics changed (power-on values) → RPDO2 (I404 500.000 · I405 10000.000, 0 = axis
  // maximum, decision 1198) and RPDO3 (I406 10000.000 · I407 100000.000) go out before the edge.
  std::optional<size_t> r2, r3;
  for (size_t i = mark; i < *edge; ++i) {
    if (all[i].frame.id == kRpdo2) r2 = i;
    if (all[i].frame.id == kRpdo3) r3 = i;
  }
  ASSERT_TRUE(r2.has_value());
  ASSERT_TRUE(r3.has_value());
  EXPECT_THAT(all[*r2].frame.payload(),
              ElementsAre(0x20, 0xA1, 0x07, 0x00, 0x80, 0x96, 0x98, 0x00));
  EXPECT_THAT(all[*r3].frame.payload(),
              ElementsAre(0x80, 0x96, 0x98, 0x00, 0x00, 0xE1, 0xF5, 0x05));
  // Execute low before the edge, for at least one A150 cycle and one bus cycle.
  const std::optional<size_t> low = LowSince(all, *edge);
  ASSERT_TRUE(low.has_value());
  EXPECT_FALSE(DecodeRpdo1(all[*low].frame).execute);
  EXPECT_GE(all[*edge].at - all[*low].at, min_low);
  // The node took the edge: the status after it shows I89 3 (Discrete motion, §2.6).
  ASSERT_TRUE(sniffer_->WaitFor([&](const std::vector<Seen>& f) {
    for (size_t i = *edge; i < f.size(); ++i) {
      if (f[i].frame.id == kTpdo1 && DecodeTpdo1(f[i].frame).plc_state == 3) return true;
    }
    return false;
  }));

  // A second command while the first runs: Execute went low after the first edge was seen, and
  // stays low ≥ max(A150, bus cycle) before the second edge; new velocity → RPDO2 first.
  const size_t mark2 = sniffer_->size();
  const CommandInfo b = Move(MoveAbsolute{1000, 800, 0, 0});
  EXPECT_TRUE(Running(b.state)) << b.message;
  EXPECT_EQ(drive_->GetCommand(a.id)->state, CommandState::kAborted);
  all = sniffer_->Until([&](const std::vector<Seen>& f) { return NextEdge(f, mark2).has_value(); },
                        "edge of B");
  const std::optional<size_t> edge2 = NextEdge(all, mark2);
  ASSERT_TRUE(edge2.has_value());
  const std::optional<size_t> low2 = LowSince(all, *edge2);
  ASSERT_TRUE(low2.has_value());
  EXPECT_GT(*low2, *edge);
  EXPECT_FALSE(DecodeRpdo1(all[*low2].frame).execute);
  EXPECT_GE(all[*edge2].at - all[*low2].at, min_low);
  bool rpdo2_before = false;
  for (size_t i = mark2; i < *edge2; ++i) rpdo2_before |= all[i].frame.id == kRpdo2;
  EXPECT_TRUE(rpdo2_before);
  EXPECT_EQ(DecodeRpdo1(all[*edge2].frame).position, 1000);
  EXPECT_EQ(WaitFinal(Move(StopMotion{10000}).id).state, CommandState::kDone);
}

// ---------------------------------------------------------------- CT-68

// CT-68 (L391, L387): after a Done, a new command (here: the same, already reached position) is
// reported DONE only after I92 was seen 0 after its edge and then 1.
TEST_F(WireTest, CT68_NoStaleDoneOrError) {
  ss::AxisServerOptions o;
  o.axis.cycle_ms = 4;
  before_drive_ = [](ss::AxisServer& s) {
    s.WithAxis([](ss::MotionCore& c) { c.SetReferenced(true); });
  };
  Start(o);
  EXPECT_EQ(WaitFinal(Move(MoveAbsolute{20, 500, 5000, 5000}).id).state, CommandState::kDone);
  AtRest(20);
  for (int round = 0; round < 2; ++round) {
    SCOPED_TRACE(round);
    const size_t mark = sniffer_->size();
    const CommandInfo again = Move(MoveAbsolute{20, 500, 5000, 5000});
    ASSERT_NE(again.id, 0u);
    EXPECT_TRUE(Running(again.state)) << "stale I92 = 1 reported as Done at the start";
    EXPECT_EQ(WaitFinal(again.id).state, CommandState::kDone)
        << drive_->GetCommand(again.id)->message;
    // On the wire after the edge: I92 0 (the forced-0 cycle, §2.7) and then 1.
    auto zero_then_one = [&](const std::vector<Seen>& f) {
      const std::optional<size_t> edge = NextEdge(f, mark);
      if (!edge) return false;
      bool zero = false;
      for (size_t i = *edge; i < f.size(); ++i) {
        if (f[i].frame.id != kTpdo1) continue;
        const Tpdo1 t = DecodeTpdo1(f[i].frame);
        if (!t.done() && !t.error()) zero = true;
        if (zero && t.done()) return true;
      }
      return false;
    };
    EXPECT_TRUE(sniffer_->WaitFor(zero_then_one)) << "no TPDO1 I92 0 → 1 after the edge";
  }
  // Likewise Error: after that Done, a denied command (target beyond I50, L227) is ERROR only
  // after the wire showed I91 0 (with I92 0, the forced-0 cycle of CT-04) and then I91 1.
  ASSERT_TRUE(drive_->WriteParameter(ParameterRef{Id("I50"), false}, 10).ok());
  const size_t mark = sniffer_->size();
  const CommandInfo denied = Move(MoveAbsolute{50, 500, 5000, 5000});
  EXPECT_NE(denied.state, CommandState::kDone);
  const CommandInfo end = WaitFinal(denied.id);
  EXPECT_EQ(end.state, CommandState::kError) << end.message;
  EXPECT_THAT(end.message, HasSubstr("I50..I51"));
  auto clear_then_error = [&](const std::vector<Seen>& f) {
    const std::optional<size_t> edge = NextEdge(f, mark);
    if (!edge) return false;
    bool clear = false;
    for (size_t i = *edge; i < f.size(); ++i) {
      if (f[i].frame.id != kTpdo1) continue;
      const Tpdo1 t = DecodeTpdo1(f[i].frame);
      if (!t.done() && !t.error()) clear = true;
      if (clear && t.error()) return true;
    }
    return false;
  };
  EXPECT_TRUE(sniffer_->WaitFor(clear_then_error))
      << "no TPDO1 I91 0 → 1 after the edge" << Trace(sniffer_->frames(), mark);
}

// ---------------------------------------------------------------- CT-69

// CT-69 (L381, L385, L1059, G-02): B accepted while A runs → A ABORTED, B BUSY/ACTIVE; an MC_Stop
// instead → A ABORTED, the Stop running until I92 = 1, Execute dropped so that I89 leaves 6.
TEST_F(WireTest, CT69_CommandAbortedInferenceAndStopReleasesI89) {
  before_drive_ = [](ss::AxisServer& s) {
    s.WithAxis([](ss::MotionCore& c) { c.SetReferenced(true); });
  };
  Start();
  const CommandInfo a = Move(MoveAbsolute{150, 200, 2000, 2000});
  WaitUntil([](const DriveStatus& s) { return s.position_mm > 5; });
  const CommandInfo b = Move(MoveAbsolute{-30, 500, 5000, 5000});
  EXPECT_EQ(drive_->GetCommand(a.id)->state, CommandState::kAborted);
  EXPECT_THAT(b.state, AnyOf(CommandState::kBusy, CommandState::kActive));
  EXPECT_EQ(WaitFinal(b.id).state, CommandState::kDone);
  AtRest(-30);

  const CommandInfo a2 = Move(MoveAbsolute{150, 200, 2000, 2000});
  WaitUntil([](const DriveStatus& s) { return s.position_mm > -20; });
  const size_t mark = sniffer_->size();
  const CommandInfo stop = Move(StopMotion{1000});  // 200 mm/s at 1000 mm/s²: 200 ms of braking
  EXPECT_EQ(drive_->GetCommand(a2.id)->state, CommandState::kAborted);
  EXPECT_THAT(stop.state, AnyOf(CommandState::kBusy, CommandState::kActive));
  EXPECT_EQ(WaitFinal(stop.id).state, CommandState::kDone) << drive_->GetCommand(stop.id)->message;
  // The Stop's I92 = 1 on the bus after its edge.
  std::vector<Seen> all = sniffer_->Until(
      [&](const std::vector<Seen>& f) {
        const std::optional<size_t> e = NextEdge(f, mark);
        return e && Sniffer::Any(f, *e, kTpdo1, [](const transport::CanFrame& x) {
                 return DecodeTpdo1(x).done();
               });
      },
      "Stop edge and its I92 = 1");
  const std::optional<size_t> edge = NextEdge(all, mark);
  ASSERT_TRUE(edge.has_value());
  EXPECT_EQ(DecodeRpdo1(all[*edge].frame).command, 5);
  // Execute dropped after the edge (RPDO1 Execute = 0) and I89 leaves 6 (to 2, G-03).
  bool dropped = false;
  for (size_t i = *edge + 1; i < all.size(); ++i) {
    if (all[i].frame.id == kRpdo1) dropped |= !DecodeRpdo1(all[i].frame).execute;
  }
  EXPECT_TRUE(dropped);
  bool stopping_seen = false;
  for (size_t i = *edge; i < all.size(); ++i) {
    if (all[i].frame.id == kTpdo1) stopping_seen |= DecodeTpdo1(all[i].frame).plc_state == 6;
  }
  EXPECT_TRUE(stopping_seen) << "I89 = 6 (Stopping) never on the bus";
  EXPECT_TRUE(sniffer_->WaitFor([&](const std::vector<Seen>& f) {
    for (size_t i = f.size(); i-- > *edge;) {
      if (f[i].frame.id == kTpdo1) return DecodeTpdo1(f[i].frame).plc_state == 2;
    }
    return false;
  })) << "I89 stayed 6 after the Stop";
  auto i89 = drive_->ReadParameter(ParameterRef{Id("I89"), false});
  ASSERT_TRUE(i89.ok()) << i89.status();
  EXPECT_EQ(*i89, 2);
}

// ---------------------------------------------------------------- CT-70

// CT-70 (L1101, L1974; CT-45, CT-49): Stop / Halt with deceleration 0 at rest end DONE, not ERROR.
TEST_F(WireTest, CT70_StopAndHaltAtStandstillWithZeroDecelerationAreDone) {
  Start();
  // API Stop with 0 = the axis maximum (decision 1198).
  const CommandInfo api = Move(StopMotion{0});
  EXPECT_EQ(WaitFinal(api.id).state, CommandState::kDone) << drive_->GetCommand(api.id)->message;
  for (const uint8_t command : {uint8_t{5}, uint8_t{11}}) {
    SCOPED_TRACE(static_cast<int>(command));
    const size_t mark = sniffer_->size();
    StoberMcRequest req;
    req.command = command;
    req.deceleration_mm_s2 = 0;
    req.jerk_mm_s3 = 50000;
    const uint64_t id = Native(req);
    ASSERT_NE(id, 0u);
    const CommandInfo end = WaitFinal(id);
    EXPECT_EQ(end.state, CommandState::kDone) << end.message << Trace(sniffer_->frames(), mark);
    // I406 = 0 went out in RPDO3 before the edge: the node really saw deceleration 0; after the
    // edge I92 = 1 and never I91 = 1.
    const std::vector<Seen> all = sniffer_->Until(
        [&](const std::vector<Seen>& f) {
          const std::optional<size_t> e = NextEdge(f, mark);
          return e && Sniffer::Any(f, *e, kTpdo1, [](const transport::CanFrame& x) {
                   return DecodeTpdo1(x).done();
                 });
        },
        "edge and I92 = 1");
    const std::optional<size_t> edge = NextEdge(all, mark);
    ASSERT_TRUE(edge.has_value());
    double i406 = -1;
    for (size_t i = 0; i < *edge; ++i) {
      if (all[i].frame.id == kRpdo3) i406 = Unpack(co::PdoKind::kRpdo, 3, all[i].frame)[0];
    }
    EXPECT_EQ(i406, 0) << "the last RPDO3 before the edge must carry I406 = 0";
    bool error_after = false;
    for (size_t i = *edge; i < all.size(); ++i) {
      if (all[i].frame.id == kTpdo1) error_after |= DecodeTpdo1(all[i].frame).error();
    }
    EXPECT_FALSE(error_after);
    const DriveStatus st =
        WaitUntil([](const DriveStatus& s) { return s.state == DriveState::kEnabled; }, 1s);
    EXPECT_EQ(st.state, DriveState::kEnabled) << st.native.text;
  }
}

// ---------------------------------------------------------------- CT-71

// CT-71 (L832, L993, L1868, G-23) on the motion-core binding (decision 1221): the adapter has no
// CiA 402-only application; what it refuses itself never reaches the bus.
TEST_F(WireTest, CT71_LocallyRefusedCommandsProduceNoFrame) {
  Start();
  const size_t mark = SyncedMark();  // Enable's control words are recorded before it
  StoberMcRequest unknown;
  unknown.command = 12;
  auto r = drive_->SendNative(unknown);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("outside I401 0..11"));
  StoberMcRequest direction;
  direction.command = 1;
  direction.direction = 4;
  r = drive_->SendNative(direction);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("I411 0..3"));
  auto m = drive_->Move(MoveAbsolute{500, 100, 1000, 1000});
  EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(m.status().message()), HasSubstr("axis.min_mm..max_mm"));
  m = drive_->Move(MoveAbsolute{10, 5000, 1000, 1000});
  EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument);
  // A probe that does reach the node, after the refusals: everything sent to the node since the
  // mark must be this probe's SDO request (ordered on the bus after any earlier frame).
  ASSERT_TRUE(drive_->ReadParameter(ParameterRef{Id("I89"), false}).ok());
  ASSERT_TRUE(sniffer_->WaitFor([&](const std::vector<Seen>& f) {
    for (size_t i = mark; i < f.size(); ++i) {
      if (f[i].frame.id == kSdoRx) return true;
    }
    return false;
  }));
  std::vector<std::string> to_node;
  const std::vector<Seen> all = sniffer_->frames();
  for (size_t i = mark; i < all.size(); ++i) {
    if (ToNode(all[i].frame)) to_node.push_back(transport::FormatCanFrame(all[i].frame));
  }
  ASSERT_EQ(to_node.size(), 1u) << ::testing::PrintToString(to_node);
  EXPECT_THAT(to_node[0], HasSubstr(absl::StrCat(absl::Hex(kSdoRx, absl::kZeroPad3), "#40")));
}

}  // namespace
}  // namespace drivegw::stober::wire
