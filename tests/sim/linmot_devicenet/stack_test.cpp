// DnStack against a fake application: start-up and duplicate MAC check, Allocate/Release,
// explicit services, the 4 x EPR watchdog, poll and CoS/cyclic I/O, fragmentation, bus-off and
// fault injection (linmot-devicenet.md §5, §12.2-§12.4, §12.8, §13.2); time is passed in.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>

#include "absl/strings/str_format.h"
#include "adapters/linmot/devicenet/commands.h"
#include "sim/linmot_devicenet/dn_stack.h"
#include "tests/sim/linmot_devicenet/test_util.h"

namespace drivegw::sim::linmot_devicenet {
namespace {

using std::chrono::milliseconds;
using testing::Bytes;
using ::testing::ElementsAre;
using testing::F;
using ::testing::IsEmpty;
using testing::Text;

class FakeApp : public IoApplication {
 public:
  ConsumeOutcome Consume(IoConnection c, std::span<const uint8_t> m) override {
    consumed.emplace_back(c, std::vector<uint8_t>(m.begin(), m.end()));
    return outcome;
  }
  std::vector<uint8_t> Produce(IoConnection c) override {
    return c == IoConnection::kPoll ? poll_image : cos_image;
  }
  void SetIoConnected(bool connected) override { io_connected = connected; }
  void RaiseCodedError(uint16_t code) override { codes.push_back(code); }
  void ResetController() override { ++resets; }

  std::vector<std::pair<IoConnection, std::vector<uint8_t>>> consumed;
  ConsumeOutcome outcome = ConsumeOutcome::kRespond;
  std::vector<uint8_t> poll_image = Bytes("03.10.00.00.02.00.03.10");
  std::vector<uint8_t> cos_image = Bytes("03.10.00.00");
  bool io_connected = false;
  std::vector<uint16_t> codes;
  int resets = 0;
};

class StackTest : public ::testing::Test {
 protected:
  void Make(const DnSimOptions& options) {
    stack_ = std::make_unique<DnStack>(options, app_);
    now_ = TimePoint{} + std::chrono::hours(1);
  }
  static std::vector<std::string> Texts(const std::vector<OutFrame>& out) {
    std::vector<std::string> t;
    for (const OutFrame& f : out) t.push_back(Text(f.frame));
    return t;
  }
  std::vector<std::string> Start() { return Texts(stack_->Start(now_)); }
  std::vector<std::string> Send(std::string_view frame) {
    return Texts(stack_->HandleFrame(F(frame), now_));
  }
  std::vector<std::string> Advance(milliseconds d) {
    now_ += d;
    return Texts(stack_->Advance(now_));
  }
  void Online(const DnSimOptions& options = testing::F1Options()) {
    Make(options);
    Start();
    Advance(milliseconds(1000));
    Advance(milliseconds(1000));
    ASSERT_EQ(stack_->network(), NetworkState::kOnline);
  }
  // TC-01: explicit + poll allocated by master 0, poll EPR 100 ms.
  void StartStack(const DnSimOptions& options = testing::F1Options()) {
    Online(options);
    ASSERT_THAT(Send("42E#00.4B.03.01.03.00"), ElementsAre("42B#00.CB.00"));
    ASSERT_THAT(Send("42C#00.10.05.02.09.64.00"), ElementsAre("42B#00.90.64.00"));
  }

  FakeApp app_;
  std::unique_ptr<DnStack> stack_;
  TimePoint now_{};
};

constexpr char kDupRequest[] = "42F#00.00.00.05.00.4D.4C";  // vendor 0, serial 0x4C4D0005

TEST_F(StackTest, Start_TwoDuplicateMacRequestsOneSecondApart_ThenOnline) {
  Make(testing::F1Options());
  EXPECT_THAT(Start(), ElementsAre(kDupRequest));
  EXPECT_EQ(stack_->network(), NetworkState::kDuplicateCheck);
  EXPECT_THAT(Advance(milliseconds(999)), IsEmpty());
  EXPECT_THAT(Advance(milliseconds(1)), ElementsAre(kDupRequest));
  EXPECT_THAT(Send("42E#00.4B.03.01.03.00"), IsEmpty()) << "not online before the check passed";
  EXPECT_THAT(Advance(milliseconds(1000)), IsEmpty());
  EXPECT_EQ(stack_->network(), NetworkState::kOnline);
  EXPECT_THAT(Send("42E#00.4B.03.01.03.00"), ElementsAre("42B#00.CB.00"));
}

// TC-07.
TEST_F(StackTest, Disabled_TransmitsNothingAndIgnoresAllocate_Tc07) {
  DnSimOptions o = testing::F1Options();
  o.dn_enable = false;
  Make(o);
  EXPECT_THAT(Start(), IsEmpty());
  EXPECT_THAT(Advance(milliseconds(5000)), IsEmpty());
  EXPECT_THAT(Send("42E#00.4B.03.01.03.00"), IsEmpty());
  EXPECT_EQ(stack_->network(), NetworkState::kDisabled);
}

// TC-08 and TC-09.
TEST_F(StackTest, MacIdFromSwitchesOrParameter_Tc08Tc09) {
  DnSimOptions o = testing::F1Options();
  o.mac_source = MacIdSource::kSwitches;
  o.mac_switches = 0x2A;
  Make(o);
  const auto start = Start();
  ASSERT_EQ(start.size(), 1u);
  EXPECT_EQ(start[0].substr(0, 4), "557#");
  Advance(milliseconds(1000));
  Advance(milliseconds(1000));
  EXPECT_THAT(Send("556#00.4B.03.01.03.00"), ElementsAre("553#00.CB.00"));
  Send("554#00.10.05.02.09.64.00");
  EXPECT_THAT(Send("555#00.00.00.00.00.00"), ElementsAre("3EA#03.10.00.00.02.00.03.10"));

  o.mac_source = MacIdSource::kParameter;
  o.mac_id = 63;
  o.mac_switches = 0x05;
  Make(o);
  EXPECT_EQ(Start()[0].substr(0, 4), "5FF#");
  Advance(milliseconds(2000));
  Advance(milliseconds(2000));
  EXPECT_THAT(Send("42E#00.4B.03.01.03.00"), IsEmpty());
  EXPECT_THAT(Send("5FE#00.4B.03.01.03.00"), ElementsAre("5FB#00.CB.00"));
}

// TC-10.
TEST_F(StackTest, DuplicateMacAnsweredDuringCheck_StaysOffline8101_Tc10) {
  Make(testing::F1Options());
  Start();
  EXPECT_THAT(Send("42F#80.00.00.99.00.00.00"), IsEmpty());
  EXPECT_EQ(stack_->network(), NetworkState::kCommunicationFaulted);
  EXPECT_THAT(app_.codes, ElementsAre(dn::kCodedMacIdInUse));
  EXPECT_THAT(Advance(milliseconds(5000)), IsEmpty());
  EXPECT_THAT(Send("42E#00.4B.03.01.03.00"), IsEmpty());
}

TEST_F(StackTest, InjectDuplicateMac_Faulted8101) {
  Online();
  EXPECT_THAT(Texts(stack_->InjectDuplicateMac(now_)), ElementsAre(kDupRequest));
  EXPECT_EQ(stack_->network(), NetworkState::kCommunicationFaulted);
  EXPECT_THAT(app_.codes, ElementsAre(dn::kCodedMacIdInUse));
}

TEST_F(StackTest, Online_AnswersDuplicateMacRequestForItsMac) {
  Online();
  EXPECT_THAT(Send("42F#00.01.00.02.00.00.00"), ElementsAre("42F#80.00.00.05.00.4D.4C"));
  EXPECT_THAT(Send("42F#80.01.00.02.00.00.00"), IsEmpty());
  EXPECT_THAT(Send("437#00.01.00.02.00.00.00"), IsEmpty()) << "MAC 6 is another node";
}

// TC-01.
TEST_F(StackTest, AllocationAndPollSetup_Tc01) {
  Online();
  EXPECT_THAT(Send("42E#00.4B.03.01.03.00"), ElementsAre("42B#00.CB.00"));
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), IsEmpty()) << "poll connection still configuring";
  EXPECT_FALSE(app_.io_connected);
  EXPECT_THAT(Send("42C#00.10.05.02.09.64.00"), ElementsAre("42B#00.90.64.00"));
  EXPECT_TRUE(app_.io_connected);
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), ElementsAre("3C5#03.10.00.00.02.00.03.10"));
  ASSERT_EQ(app_.consumed.size(), 1u);
  EXPECT_EQ(app_.consumed[0].second, Bytes("00.00.00.00.00.00"));
  const auto snap = stack_->Snapshot();
  EXPECT_EQ(snap.owner, 0);
  EXPECT_EQ(snap.allocation_choice, 0x03);
  EXPECT_EQ(snap.poll_connection.state, ConnectionState::kEstablished);
  EXPECT_EQ(snap.explicit_connection.expected_packet_rate_ms, 2500);
}

// TC-02.
TEST_F(StackTest, SecondMaster_RejectedUntilRelease_Tc02) {
  StartStack();
  EXPECT_THAT(Send("42E#01.4B.03.01.01.01"), ElementsAre("42B#01.94.0C.01"));
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), ElementsAre("3C5#03.10.00.00.02.00.03.10"));
  EXPECT_THAT(Send("42C#01.0E.01.01.01"), IsEmpty()) << "explicit requests of a non-owner";
  EXPECT_EQ(stack_->counters().second_master_dropped, 1u);
  EXPECT_THAT(Send("42E#00.4C.03.01.03"), ElementsAre("42B#00.CC"));
  EXPECT_FALSE(app_.io_connected);
  EXPECT_THAT(Send("42E#01.4B.03.01.01.01"), ElementsAre("42B#01.CB.00"));
  EXPECT_EQ(stack_->owner(), 1);
}

// D-14 error codes.
TEST_F(StackTest, AllocateErrors_D14) {
  Online();
  EXPECT_THAT(Send("42E#00.4B.03.01.04.00"), ElementsAre("42B#00.94.02.02")) << "bit-strobe";
  EXPECT_THAT(Send("42E#00.4B.03.01.08.00"), ElementsAre("42B#00.94.02.02")) << "multicast poll";
  EXPECT_THAT(Send("42E#00.4B.03.01.11.00"), ElementsAre("42B#00.94.02.02")) << "CoS not set up";
  EXPECT_THAT(Send("42E#00.4B.03.01.00.00"), ElementsAre("42B#00.94.02.02")) << "empty choice";
  EXPECT_THAT(Send("42E#00.0E.03.01.01"), ElementsAre("42B#00.94.08.03")) << "Get on msg 6";
  EXPECT_THAT(Send("42E#00.4B.05.01.03.00"), ElementsAre("42B#00.94.16.FF")) << "wrong class";
  EXPECT_THAT(Send("42E#00.4B.03.01.03.00"), ElementsAre("42B#00.CB.00"));
  EXPECT_THAT(Send("42E#00.4B.03.01.02.00"), ElementsAre("42B#00.94.0B.02")) << "already";
  EXPECT_THAT(Send("42E#00.4C.03.01.10"), ElementsAre("42B#00.94.0B.02")) << "not allocated";
}

TEST_F(StackTest, ExplicitRequest_XidEchoed) {
  StartStack();
  EXPECT_THAT(Send("42C#40.0E.05.02.01"), ElementsAre("42B#40.8E.03"));
}

// TC-03 (D-13: connection attributes readable).
TEST_F(StackTest, GetAttributeSingle_ConnectionIdentityAndUnsupportedObjects_Tc03) {
  StartStack();
  EXPECT_THAT(Send("42C#00.0E.05.02.07"), ElementsAre("42B#00.8E.08.00"));
  EXPECT_THAT(Send("42C#00.0E.05.02.08"), ElementsAre("42B#00.8E.06.00"));
  EXPECT_THAT(Send("42C#00.0E.05.02.01"), ElementsAre("42B#00.8E.03"));
  EXPECT_THAT(Send("42C#00.0E.05.02.04"), ElementsAre("42B#00.8E.C5.03"));
  EXPECT_THAT(Send("42C#00.0E.05.04.01"), ElementsAre("42B#00.94.16.FF")) << "CoS not allocated";
  EXPECT_THAT(Send("42C#00.0E.01.01.01"), ElementsAre("42B#00.8E.00.00"));
  EXPECT_THAT(Send("42C#00.0E.01.01.02"), ElementsAre("42B#00.8E.00.00"));
  EXPECT_THAT(Send("42C#00.0E.01.01.04"), ElementsAre("42B#00.8E.01.03"));
  EXPECT_THAT(Send("42C#00.0E.03.01.01"), ElementsAre("42B#00.8E.05"));
  EXPECT_THAT(Send("42C#00.0E.03.01.05"), ElementsAre("42B#00.8E.03.00"));
  EXPECT_THAT(Send("42C#00.0E.03.01.08"), ElementsAre("42B#00.8E.05"));
  EXPECT_THAT(Send("42C#00.0E.03.01.0A"), ElementsAre("42B#00.94.14.FF"));
  EXPECT_THAT(Send("42C#00.0E.02.01.01"), ElementsAre("42B#00.94.14.FF")) << "message router";
  EXPECT_THAT(Send("42C#00.0E.04.64.03"), ElementsAre("42B#00.94.14.FF")) << "assembly";
  EXPECT_THAT(Send("42C#00.0E.64.01.01"), ElementsAre("42B#00.94.16.FF")) << "application";
  EXPECT_THAT(Send("42C#00.10.01.01.01.00.00"), ElementsAre("42B#00.94.0E.FF"));
  EXPECT_THAT(Send("42C#00.4D.01.01"), ElementsAre("42B#00.94.08.FF"));
}

// TC-03: the computed sizes of F1, F2, F3.
TEST_F(StackTest, ComputedSizesFollowTheModuleSelection_Tc03) {
  const std::pair<DnSimOptions, std::pair<int, int>> cases[] = {{testing::F1Options(), {6, 8}},
                                                                {testing::F2Options(), {10, 8}},
                                                                {testing::F3Options(), {22, 24}}};
  for (const auto& [options, sizes] : cases) {
    Make(options);
    const auto snap = stack_->Snapshot();
    EXPECT_EQ(snap.poll_consumed_size, sizes.first);
    EXPECT_EQ(snap.poll_produced_size, sizes.second);
  }
}

TEST_F(StackTest, ConnectionAttributesNotReadable_ErrorResponse_D13) {
  DnSimOptions o = testing::F1Options();
  o.connection_attributes_readable = false;
  o.identity_readable = false;
  StartStack(o);
  EXPECT_THAT(Send("42C#00.0E.05.02.07"), ElementsAre("42B#00.94.08.FF"));
  EXPECT_THAT(Send("42C#00.0E.01.01.01"), ElementsAre("42B#00.94.08.FF"));
}

// §5.6 life cycle 5: the third-party trace granted 0x0E10 for 0x0E0A.
TEST_F(StackTest, SetExpectedPacketRate_RoundedUpToResolution_D13) {
  StartStack();
  EXPECT_THAT(Send("42C#00.10.05.02.09.0A.0E"), ElementsAre("42B#00.90.10.0E"));
  EXPECT_THAT(Send("42C#00.10.05.01.09.C4.09"), ElementsAre("42B#00.90.C4.09"));
  EXPECT_THAT(Send("42C#00.10.05.02.09.64"), ElementsAre("42B#00.94.13.FF"));
}

TEST_F(StackTest, PollWatchdog_TimesOutAfterFourEpr_ReestablishedByNewEpr) {
  StartStack();
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), ::testing::SizeIs(1));
  Advance(milliseconds(399));
  EXPECT_EQ(stack_->Snapshot().poll_connection.state, ConnectionState::kEstablished);
  Advance(milliseconds(1));
  EXPECT_EQ(stack_->Snapshot().poll_connection.state, ConnectionState::kTimedOut);
  EXPECT_FALSE(app_.io_connected);
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), IsEmpty());
  EXPECT_THAT(Send("42C#00.0E.05.02.01"), ElementsAre("42B#00.8E.04"));
  EXPECT_THAT(Send("42C#00.10.05.02.09.64.00"), ElementsAre("42B#00.90.64.00"));
  EXPECT_TRUE(app_.io_connected);
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), ::testing::SizeIs(1));
  EXPECT_EQ(stack_->counters().watchdog_timeouts, 1u);
}

TEST_F(StackTest, PollWatchdog_ResetServiceReestablishes) {
  StartStack();
  Advance(milliseconds(500));
  EXPECT_THAT(Send("42C#00.05.05.02"), ElementsAre("42B#00.85"));
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), ::testing::SizeIs(1));
}

TEST_F(StackTest, PollWatchdog_AutoDeleteAction_ReleasesThePollConnection) {
  StartStack();
  EXPECT_THAT(Send("42C#00.10.05.02.0C.01"), ElementsAre("42B#00.90"));
  Advance(milliseconds(400));
  EXPECT_EQ(stack_->allocation_choice(), dn::kAllocExplicit);
  EXPECT_THAT(Send("42E#00.4B.03.01.02.00"), ElementsAre("42B#00.CB.00"));
}

TEST_F(StackTest, EprZero_WatchdogOff) {
  StartStack();
  Send("42C#00.10.05.02.09.00.00");
  Send("42C#00.10.05.01.09.00.00");
  Advance(milliseconds(60'000));
  EXPECT_EQ(stack_->Snapshot().poll_connection.state, ConnectionState::kEstablished);
  EXPECT_EQ(stack_->Snapshot().explicit_connection.state, ConnectionState::kEstablished);
}

TEST_F(StackTest, ExplicitWatchdog_DeletesExplicit_OwnershipKeptWhilePollLives_D13) {
  StartStack();
  for (int i = 0; i < 100; ++i) {
    Advance(milliseconds(100));
    Send("42D#00.00.00.00.00.00");  // keeps the poll connection alive
  }
  EXPECT_EQ(stack_->allocation_choice(), dn::kAllocPolled);
  EXPECT_THAT(Send("42C#00.0E.05.02.01"), IsEmpty());
  EXPECT_THAT(Send("42E#01.4B.03.01.01.01"), ElementsAre("42B#01.94.0C.01"));
  EXPECT_THAT(Send("42E#00.4B.03.01.01.00"), ElementsAre("42B#00.CB.00"));
}

TEST_F(StackTest, ExplicitWatchdog_OwnershipEndsWithExplicit_D13Alternative) {
  DnSimOptions o = testing::F1Options();
  o.ownership_ends_with_explicit = true;
  StartStack(o);
  Advance(milliseconds(10'000));
  EXPECT_EQ(stack_->owner(), std::nullopt);
  EXPECT_THAT(Send("42E#01.4B.03.01.03.01"), ElementsAre("42B#01.CB.00"));
}

// TC-04 (D-24).
TEST_F(StackTest, PollOfWrongSize_NoAnswerCounted_Tc04) {
  StartStack();
  EXPECT_THAT(Send("42D#00.00.00.00"), IsEmpty());
  EXPECT_EQ(stack_->counters().polls_wrong_size, 1u);
  EXPECT_TRUE(app_.consumed.empty());
}

// TC-46.
TEST_F(StackTest, Example1_FragmentedBothWays_MissingMiddleDiscarded_Tc46) {
  StartStack(testing::F3Options());
  app_.poll_image.assign(24, 0);
  for (size_t i = 0; i < 24; ++i) app_.poll_image[i] = static_cast<uint8_t>(0xA0 + i);
  EXPECT_THAT(Send("42D#00.02.00.18.20.00.00.01"), IsEmpty());
  EXPECT_THAT(Send("42D#41.02.03.04.05.06.07.08"), IsEmpty());
  EXPECT_THAT(Send("42D#42.09.0A.0B.0C.0D.0E.0F"), IsEmpty());
  EXPECT_THAT(Send("42D#83.10"),
              ElementsAre("3C5#00.A0.A1.A2.A3.A4.A5.A6", "3C5#41.A7.A8.A9.AA.AB.AC.AD",
                          "3C5#42.AE.AF.B0.B1.B2.B3.B4", "3C5#83.B5.B6.B7"));
  ASSERT_EQ(app_.consumed.size(), 1u);
  EXPECT_EQ(app_.consumed[0].second.size(), 22u);
  EXPECT_EQ(app_.consumed[0].second[21], 0x10);
  EXPECT_THAT(Send("42D#00.02.00.18.20.00.00.01"), IsEmpty());
  EXPECT_THAT(Send("42D#42.09.0A.0B.0C.0D.0E.0F"), IsEmpty());
  EXPECT_THAT(Send("42D#83.10"), IsEmpty());
  EXPECT_EQ(app_.consumed.size(), 1u);
  EXPECT_GE(stack_->counters().fragment_errors, 1u);
}

// TC-44: 10 bytes in two fragments, 8 bytes back unfragmented.
TEST_F(StackTest, Example2_FragmentedPollUnfragmentedResponse_Tc44) {
  StartStack(testing::F2Options());
  EXPECT_THAT(Send("42D#00.02.00.11.00.00.14.11"), IsEmpty());
  EXPECT_THAT(Send("42D#81.00.00.EC"), ElementsAre("3C5#03.10.00.00.02.00.03.10"));
  ASSERT_EQ(app_.consumed.size(), 1u);
  EXPECT_EQ(app_.consumed[0].second, Bytes("02.00.11.00.00.14.11.00.00.EC"));
}

TEST_F(StackTest, Faults_DropDelayCorruptLength) {
  StartStack();
  stack_->faults().drop_next_polls = 2;
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), IsEmpty());
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), IsEmpty());
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), ::testing::SizeIs(1));
  EXPECT_EQ(stack_->counters().polls_dropped_injected, 2u);
  EXPECT_EQ(app_.consumed.size(), 1u) << "a dropped poll is not executed";

  stack_->faults().response_delay = milliseconds(7);
  auto out = stack_->HandleFrame(F("42D#00.00.00.00.00.00"), now_);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].due, now_ + milliseconds(7));
  stack_->faults().response_delay = {};

  stack_->faults().response_length_delta = 1;  // 9 bytes: fragmented
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"),
              ElementsAre("3C5#00.03.10.00.00.02.00.03", "3C5#81.10.00"));
  stack_->faults().corrupt_fragments = true;
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), ElementsAre("3C5#00.03.10.00.00.02.00.03"));
  stack_->faults() = StackFaults{};
  stack_->faults().drop_polls = true;
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), IsEmpty());
}

// TC-05.
TEST_F(StackTest, PolledPlusCos_MasterDataViaPollDriveDataOnBoth_Tc05) {
  DnSimOptions o = testing::F1Options();
  o.io_cos = true;
  Online(o);
  EXPECT_THAT(Send("42E#00.4B.03.01.13.00"), ElementsAre("42B#00.CB.00"));
  Send("42C#00.10.05.02.09.64.00");
  EXPECT_THAT(Send("42C#00.10.05.04.09.E8.03"), ElementsAre("42B#00.90.E8.03"));
  EXPECT_THAT(Advance(milliseconds(1)), ElementsAre("345#03.10.00.00"));  // first production
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), ElementsAre("3C5#03.10.00.00.02.00.03.10"));
  EXPECT_EQ(app_.consumed.back().first, IoConnection::kPoll);
  EXPECT_THAT(Send("42A#"), IsEmpty());
  EXPECT_EQ(stack_->counters().cos_acks_received, 1u);
  app_.cos_image = Bytes("01.10.00.00");  // RUN State changed
  EXPECT_THAT(Advance(milliseconds(10)), ElementsAre("345#01.10.00.00"));
  EXPECT_THAT(Advance(milliseconds(500)), IsEmpty());
  EXPECT_THAT(Advance(milliseconds(500)), ElementsAre("345#01.10.00.00")) << "heartbeat";
  // Production inhibit time 100 ms.
  EXPECT_THAT(Send("42C#00.10.05.04.11.64.00"), ElementsAre("42B#00.90"));
  app_.cos_image = Bytes("03.10.00.00");
  EXPECT_THAT(Advance(milliseconds(50)), IsEmpty());
  EXPECT_THAT(Advance(milliseconds(50)), ElementsAre("345#03.10.00.00"));
}

TEST_F(StackTest, Cyclic_ProducedEveryEpr) {
  DnSimOptions o = testing::F1Options();
  o.io_cos = true;
  Online(o);
  EXPECT_THAT(Send("42E#00.4B.03.01.23.00"), ElementsAre("42B#00.CB.00"));
  Send("42C#00.10.05.04.09.64.00");
  EXPECT_THAT(Advance(milliseconds(1)), ElementsAre("345#03.10.00.00"));
  EXPECT_THAT(Advance(milliseconds(50)), IsEmpty());
  EXPECT_THAT(Advance(milliseconds(50)), ElementsAre("345#03.10.00.00"));
  EXPECT_THAT(Send("42E#00.4B.03.01.10.00"), ElementsAre("42B#00.94.02.02")) << "CoS + cyclic";
}

TEST_F(StackTest, CosOnly_MasterDataAcknowledgedUnlessSuppressed) {
  DnSimOptions o = testing::F1Options();
  o.io_polled = false;
  o.io_cos = true;
  o.cos_modules = dn::DefaultLayoutP().modules;
  Online(o);
  EXPECT_THAT(Send("42E#00.4B.03.01.11.00"), ElementsAre("42B#00.CB.00"));
  Send("42C#00.10.05.04.09.E8.03");
  EXPECT_TRUE(app_.io_connected);
  Advance(milliseconds(1));
  EXPECT_THAT(Send("42D#02.00.00.00.00.00"), ElementsAre("3C5#"));
  EXPECT_EQ(app_.consumed.back().first, IoConnection::kCos);

  Online(o);
  EXPECT_THAT(Send("42E#00.4B.03.01.51.00"), ElementsAre("42B#00.CB.00"));
  Send("42C#00.10.05.04.09.E8.03");
  Advance(milliseconds(1));
  EXPECT_THAT(Send("42D#02.00.00.00.00.00"), IsEmpty()) << "acknowledge suppression";
}

// TC-11 at stack level (D-16 default: hold until the CAN controller is reset).
TEST_F(StackTest, BusOff_SilentUntilRecovered_Tc11) {
  StartStack();
  stack_->GoBusOff(now_);
  EXPECT_THAT(app_.codes, ElementsAre(dn::kCodedCanBusOff));
  EXPECT_FALSE(app_.io_connected);
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), IsEmpty());
  EXPECT_THAT(Send("42F#00.01.00.02.00.00.00"), IsEmpty());
  EXPECT_THAT(Advance(milliseconds(60'000)), IsEmpty());
  EXPECT_THAT(Texts(stack_->RecoverBusOff(now_)), ElementsAre(kDupRequest));
  Advance(milliseconds(1000));
  Advance(milliseconds(1000));
  EXPECT_EQ(stack_->network(), NetworkState::kOnline);
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), IsEmpty()) << "connections are gone";
  EXPECT_THAT(Send("42C#00.0E.03.01.04"), IsEmpty());
  Send("42E#00.4B.03.01.03.00");
  EXPECT_THAT(Send("42C#00.0E.03.01.04"), ElementsAre("42B#00.8E.01"));
}

TEST_F(StackTest, BusOff_AutoRecoverAfterConfiguredTime_D16Option) {
  DnSimOptions o = testing::F1Options();
  o.bus_off_recovery = BusOffRecovery::kAutoRecover;
  o.bus_off_recover_after = milliseconds(500);
  StartStack(o);
  stack_->GoBusOff(now_);
  EXPECT_THAT(Advance(milliseconds(499)), IsEmpty());
  EXPECT_THAT(Advance(milliseconds(1)), ElementsAre(kDupRequest));
}

TEST_F(StackTest, LonelyNode_KeepsRetransmitting8143) {
  Make(testing::F1Options());
  stack_->faults().lonely_node = true;
  Start();
  Advance(milliseconds(1000));
  for (int i = 0; i < 3; ++i) EXPECT_THAT(Advance(milliseconds(1000)), ElementsAre(kDupRequest));
  EXPECT_EQ(stack_->network(), NetworkState::kDuplicateCheck);
  EXPECT_THAT(app_.codes, ElementsAre(dn::kCodedCanAckError));
  stack_->faults().lonely_node = false;
  Advance(milliseconds(1000));
  EXPECT_EQ(stack_->network(), NetworkState::kOnline);
}

// TC-06.
TEST_F(StackTest, ResetController_NoResponseThenDuplicateCheck_Tc06) {
  StartStack();
  app_.outcome = ConsumeOutcome::kResetController;
  EXPECT_THAT(Send("42D#02.00.0F.00.00.00"), ElementsAre(kDupRequest));
  EXPECT_EQ(stack_->network(), NetworkState::kDuplicateCheck);
  EXPECT_EQ(stack_->allocation_choice(), 0);
  EXPECT_THAT(Advance(milliseconds(1000)), ElementsAre(kDupRequest));
  Advance(milliseconds(1000));
  app_.outcome = ConsumeOutcome::kRespond;
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), IsEmpty());
  EXPECT_EQ(stack_->counters().network_restarts, 1u);
}

TEST_F(StackTest, IdentityReset_RespondsThenRestarts) {
  StartStack();
  EXPECT_THAT(Send("42C#00.05.01.01"), ElementsAre("42B#00.85", kDupRequest));
  EXPECT_EQ(app_.resets, 1);
}

TEST_F(StackTest, ReleaseOverExplicitConnection) {
  StartStack();
  EXPECT_THAT(Send("42C#00.4C.03.01.02"), ElementsAre("42B#00.CC"));
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), IsEmpty());
  EXPECT_THAT(Send("42C#00.4C.03.01.01"), ElementsAre("42B#00.CC"));
  EXPECT_EQ(stack_->owner(), std::nullopt);
}

// D-11: UCMM Open/Close on group 3 allocates the explicit connection.
TEST_F(StackTest, UcmmOpenAndClose_D11) {
  Online();
  dn::UcmmOpenRequest open;
  open.header = dn::ExplicitHeader{false, false, 5};
  open.group_select = 1;
  auto bytes = dn::EncodeUcmmOpenRequest(open).value();
  auto out = Texts(stack_->HandleFrame(dn::MakeFrame(0x780, bytes).value(), now_));
  ASSERT_EQ(out.size(), 1u);
  auto response = dn::DecodeUcmmOpenResponse(testing::F(out[0]).payload());
  ASSERT_TRUE(response.ok()) << out[0];
  EXPECT_EQ(testing::F(out[0]).id, 0x745);
  EXPECT_EQ(response->connection_instance, 1);
  EXPECT_EQ(stack_->owner(), 0);
  EXPECT_THAT(Send("42C#00.0E.03.01.01"), ElementsAre("42B#00.8E.05"));
  EXPECT_THAT(Send("781#05.4B.00.14"), ElementsAre("745#01.94.0C.01")) << "second master";
  EXPECT_THAT(Send("780#05.4C.01.00"), ElementsAre("745#00.CC"));
  EXPECT_EQ(stack_->owner(), std::nullopt);
  EXPECT_THAT(Send("780#06.4B.00.14"), IsEmpty()) << "another server's MAC";
}

TEST_F(StackTest, FragmentedExplicitResponse_SentFragmentByFragmentAfterAcks) {
  StartStack();
  const auto first = Send("42C#00.0E.01.01.07");  // product name: 16 bytes
  ASSERT_EQ(first.size(), 1u);
  dn::Reassembler r;
  auto fed = r.FeedExplicit(F(first[0]).payload());
  ASSERT_TRUE(fed.ok());
  std::vector<uint8_t> message;
  std::string last = first[0];
  for (int i = 0; i < 5 && !message.size(); ++i) {
    const uint8_t count = dn::FragmentCountOf(F(last).payload()[1]);
    const auto next = Send(absl::StrFormat("42C#80.%02X.00", 0xC0 | count));
    if (next.empty()) break;
    last = next[0];
    auto more = r.FeedExplicit(F(last).payload());
    ASSERT_TRUE(more.ok()) << more.status();
    if (more->has_value()) message = **more;
  }
  auto response = dn::DecodeExplicitResponse(message);
  ASSERT_TRUE(response.ok()) << response.status();
  ASSERT_FALSE(response->data.empty());
  EXPECT_EQ(std::string(response->data.begin() + 1, response->data.end()), "LinMot DN sim");
}

TEST_F(StackTest, FragmentedExplicitRequest_AckedAndAnswered) {
  StartStack();
  auto fragmenter = dn::Fragmenter::ForExplicit(Bytes("00.10.05.02.09.64.00.00.00.00")).value();
  auto f1 = fragmenter.Next().value();
  EXPECT_THAT(Texts(stack_->HandleFrame(dn::MakeFrame(0x42C, f1).value(), now_)),
              ElementsAre("42B#80.C0.00"));
  ASSERT_TRUE(fragmenter.AcceptAck(Bytes("80.C0.00")).ok());
  auto f2 = fragmenter.Next().value();
  EXPECT_THAT(Texts(stack_->HandleFrame(dn::MakeFrame(0x42C, f2).value(), now_)),
              ElementsAre("42B#80.C1.00", "42B#00.94.15.FF"));
}

TEST_F(StackTest, Malformed_CountedAndDropped) {
  StartStack();
  EXPECT_THAT(Send("7F5#00"), IsEmpty());
  EXPECT_THAT(Send("42C#00.0E.05"), ElementsAre("42B#00.94.13.FF"));
  EXPECT_THAT(Send("42F#00.01"), IsEmpty());
  EXPECT_THAT(Send("42C#00.8E.05.02.01"), IsEmpty()) << "a response on the request id";
  EXPECT_GE(stack_->counters().malformed, 4u);
  EXPECT_THAT(Send("42D#00.00.00.00.00.00"), ::testing::SizeIs(1)) << "the stack survives";
}

TEST_F(StackTest, NextDeadline_DuplicateCheckThenWatchdog) {
  Make(testing::F1Options());
  Start();
  EXPECT_EQ(stack_->NextDeadline(), now_ + milliseconds(1000));
  Advance(milliseconds(1000));
  Advance(milliseconds(1000));
  Send("42E#00.4B.03.01.03.00");
  EXPECT_EQ(stack_->NextDeadline(), now_ + milliseconds(10'000));
  Send("42C#00.10.05.02.09.64.00");
  EXPECT_EQ(stack_->NextDeadline(), now_ + milliseconds(400));
}

}  // namespace
}  // namespace drivegw::sim::linmot_devicenet
