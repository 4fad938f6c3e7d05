// NMT commands, heartbeat / boot-up byte (CiA 301 §7.2.8.3) and SYNC (§7.2.5).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "adapters/canopen/nmt.h"
#include "adapters/canopen/sync.h"
#include "adapters/transport/can_frame.h"

namespace drivegw::canopen {
namespace {

using transport::CanFrame;
using transport::FormatCanFrame;
using transport::MakeCanFrame;

CanFrame Frame(uint32_t id, std::initializer_list<uint8_t> bytes) {
  const std::vector<uint8_t> v(bytes);
  return MakeCanFrame(id, v);
}

TEST(NmtTest, CommandsEncodeByteExact) {
  struct Row {
    NmtCommand command;
    uint8_t node;
    const char* wire;
  };
  const Row rows[] = {
      {NmtCommand::kStart, 5, "000#0105"},
      {NmtCommand::kStop, 5, "000#0205"},
      {NmtCommand::kEnterPreOperational, 127, "000#807F"},
      {NmtCommand::kResetNode, 0, "000#8100"},
      {NmtCommand::kResetCommunication, 1, "000#8201"},
  };
  for (const Row& r : rows) {
    auto frame = EncodeNmt({r.command, r.node});
    ASSERT_TRUE(frame.ok()) << frame.status();
    EXPECT_EQ(FormatCanFrame(*frame), r.wire);
    auto back = DecodeNmt(*frame);
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_EQ(*back, (NmtMessage{r.command, r.node}));
  }
}

TEST(NmtTest, BadCommandsAreRefusedNamingTheField) {
  EXPECT_EQ(EncodeNmt({NmtCommand::kStart, 128}).status().message(),
            "canopen nmt.node_id: 128 exceeds 127 (0 = all nodes)");
  EXPECT_THAT(DecodeNmt(Frame(0x000, {0x03, 0x01})).status().message(),
              ::testing::HasSubstr("nmt.command: 0x03 is no NMT command specifier"));
  EXPECT_THAT(DecodeNmt(Frame(0x000, {0x01})).status().message(),
              ::testing::HasSubstr("nmt.dlc: 1 bytes, need 2"));
  EXPECT_FALSE(DecodeNmt(Frame(0x001, {0x01, 0x01})).ok());
  EXPECT_FALSE(DecodeNmt(Frame(0x000, {0x01, 0x80})).ok());
}

TEST(NmtTest, HeartbeatAndBootUpDecode) {
  struct Row {
    uint8_t byte;
    NmtState state;
  };
  const Row rows[] = {{0x00, NmtState::kBootUp},
                      {0x04, NmtState::kStopped},
                      {0x05, NmtState::kOperational},
                      {0x7F, NmtState::kPreOperational},
                      // Bit 7 is the node-guarding toggle; heartbeat decoding ignores it.
                      {0x85, NmtState::kOperational},
                      {0xFF, NmtState::kPreOperational},
                      {0x84, NmtState::kStopped}};
  for (const Row& r : rows) {
    auto hb = DecodeErrorControl(Frame(0x70A, {r.byte}));
    ASSERT_TRUE(hb.ok()) << hb.status();
    EXPECT_EQ(hb->node, 10);
    EXPECT_EQ(hb->state, r.state) << int(r.byte);
  }
  EXPECT_THAT(DecodeErrorControl(Frame(0x70A, {0x03})).status().message(),
              ::testing::HasSubstr("heartbeat.state: 0x03 is no NMT state"));
  EXPECT_FALSE(DecodeErrorControl(Frame(0x700, {0x05})).ok());
  EXPECT_FALSE(DecodeErrorControl(Frame(0x780, {0x05})).ok());
  EXPECT_FALSE(DecodeErrorControl(Frame(0x70A, {0x05, 0x00})).ok());
  EXPECT_FALSE(DecodeErrorControl(Frame(0x70A, {})).ok());
}

TEST(NmtTest, HeartbeatEncodesAndNodeGuardRequestIsRtr) {
  EXPECT_EQ(FormatCanFrame(*EncodeErrorControl({3, NmtState::kBootUp, false})), "703#00");
  EXPECT_EQ(FormatCanFrame(*EncodeErrorControl({3, NmtState::kPreOperational, false})), "703#7F");
  EXPECT_EQ(FormatCanFrame(*EncodeErrorControl({3, NmtState::kOperational, true})), "703#85");
  EXPECT_FALSE(EncodeErrorControl({3, NmtState::kBootUp, true}).ok());
  EXPECT_FALSE(EncodeErrorControl({0, NmtState::kOperational, false}).ok());
  EXPECT_EQ(FormatCanFrame(*NodeGuardRequest(3)), "703#R1");
}

TEST(NmtTest, SlaveStateAfterCommands) {
  EXPECT_EQ(NmtStateAfter(NmtState::kPreOperational, NmtCommand::kStart), NmtState::kOperational);
  EXPECT_EQ(NmtStateAfter(NmtState::kOperational, NmtCommand::kStop), NmtState::kStopped);
  EXPECT_EQ(NmtStateAfter(NmtState::kStopped, NmtCommand::kEnterPreOperational),
            NmtState::kPreOperational);
  EXPECT_EQ(NmtStateAfter(NmtState::kOperational, NmtCommand::kResetNode),
            NmtState::kPreOperational);
  EXPECT_EQ(NmtStateAfter(NmtState::kStopped, NmtCommand::kResetCommunication),
            NmtState::kPreOperational);
  EXPECT_EQ(NmtStateName(NmtState::kPreOperational), "pre_operational");
  EXPECT_EQ(NmtCommandName(NmtCommand::kResetCommunication), "reset_communication");
}

TEST(SyncTest, EncodeDecodeWithAndWithoutCounter) {
  EXPECT_EQ(FormatCanFrame(*EncodeSync({})), "080#");
  EXPECT_EQ(FormatCanFrame(*EncodeSync({7})), "080#07");
  EXPECT_EQ(*DecodeSync(Frame(0x080, {})), Sync{});
  EXPECT_EQ(*DecodeSync(Frame(0x080, {240})), Sync{240});
  EXPECT_EQ(EncodeSync({0}).status().message(), "canopen sync.counter: 0 outside 1..240");
  EXPECT_FALSE(DecodeSync(Frame(0x080, {241})).ok());
  EXPECT_FALSE(DecodeSync(Frame(0x080, {1, 2})).ok());
  EXPECT_FALSE(DecodeSync(Frame(0x081, {})).ok());
  EXPECT_EQ(FormatCanFrame(*EncodeSync({}, 0x090)), "090#");
}

TEST(SyncTest, CounterWrapsAtTheOverflowValue) {
  EXPECT_EQ(NextSyncCounter(0, 10), 1);
  EXPECT_EQ(NextSyncCounter(1, 10), 2);
  EXPECT_EQ(NextSyncCounter(9, 10), 10);
  EXPECT_EQ(NextSyncCounter(10, 10), 1);
  EXPECT_EQ(NextSyncCounter(240, 240), 1);
}

}  // namespace
}  // namespace drivegw::canopen
