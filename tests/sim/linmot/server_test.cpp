// LinMotServer over real loopback UDP with a test socket as master: status poll, A-01 port rule,
// A-04 malformed datagrams, physics on a ManualClock, link loss, reply delay, restart.
#include "sim/linmot/server.h"

#include <chrono>
#include <functional>
#include <thread>

#include "adapters/linmot/linudp/codec.h"
#include "adapters/linmot/mc/control_word.h"
#include "adapters/linmot/mc/motion_command.h"
#include "adapters/linmot/mc/state_var.h"
#include "gtest/gtest.h"
#include "sim/linmot/device.h"

namespace drivegw::sim::linmot {
namespace {

using std::chrono::milliseconds;
using transport::Endpoint;
using transport::UdpSocket;

constexpr auto kReplyTimeout = std::chrono::seconds(2);

// Waits (real time, bounded) until `condition` holds: the server thread runs concurrently.
bool WaitFor(const std::function<bool()>& condition) {
  const auto deadline = std::chrono::steady_clock::now() + kReplyTimeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(milliseconds(1));
  }
  return condition();
}

class ServerTest : public ::testing::Test {
 protected:
  void StartServer(SimOptions o) {
    o.bind = Endpoint{Endpoint::kLoopback, 0};
    o.boot_time = milliseconds(100);
    auto s = LinMotServer::Start(o, clock_);
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = std::move(*s);
    ASSERT_NE(server_->port(), 0);
  }
  UdpSocket Master() {
    auto s = UdpSocket::Bind(Endpoint{Endpoint::kLoopback, 0});
    EXPECT_TRUE(s.ok()) << s.status();
    return std::move(*s);
  }
  Endpoint Drive() const { return server_->endpoint(); }

  static void SendBytes(UdpSocket& m, const Endpoint& to, const std::vector<uint8_t>& b) {
    ASSERT_TRUE(m.SendTo(to, b).ok());
  }
  std::optional<linudp::Reply> Transact(UdpSocket& m, const linudp::Request& r) {
    SendBytes(m, Drive(), linudp::EncodeRequest(r));
    auto got = m.Receive(kReplyTimeout);
    if (!got.ok() || !got->has_value()) return std::nullopt;
    auto reply = linudp::DecodeReply((*got)->bytes);
    EXPECT_TRUE(reply.ok()) << reply.status();
    if (!reply.ok()) return std::nullopt;
    return *reply;
  }
  static linudp::Request Poll() {
    linudp::Request r;
    r.response_definition = linudp::kRespStandard;
    return r;
  }
  static linudp::Request Cw(uint16_t cw) {
    linudp::Request r = Poll();
    r.control_word = cw;
    return r;
  }

  ManualClock clock_;
  std::unique_ptr<LinMotServer> server_;
};

TEST_F(ServerTest, StatusPoll_AnsweredOnLoopback) {
  SimOptions o;
  o.master_port = 0;  // answer any source port
  StartServer(o);
  UdpSocket m = Master();
  const auto reply = Transact(m, Poll());
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(reply->response_definition, linudp::kRespStandard);
  EXPECT_EQ(reply->state_var, 0x0000);  // power-up: state 0
  EXPECT_EQ(reply->actual_position, 100'000);
  EXPECT_EQ(server_->counters().replies_sent, 1u);
}

TEST_F(ServerTest, WrongSourcePort_DroppedAndCounted_A01) {
  UdpSocket master = Master();
  UdpSocket other = Master();
  SimOptions o;
  o.master_port = master.local_port();
  StartServer(o);
  SendBytes(other, Drive(), linudp::EncodeRequest(Poll()));
  ASSERT_TRUE(WaitFor([&] { return server_->counters().dropped_wrong_port == 1; }));
  auto nothing = other.Receive(milliseconds(20));
  ASSERT_TRUE(nothing.ok());
  EXPECT_FALSE(nothing->has_value());
  // From the master port: answered, to the master port.
  EXPECT_TRUE(Transact(master, Poll()).has_value());
}

TEST_F(ServerTest, MalformedDatagrams_CountedServerKeepsAnswering_A04) {
  SimOptions o;
  o.master_port = 0;
  StartServer(o);
  UdpSocket m = Master();
  SendBytes(m, Drive(), {0x01, 0x02, 0x03});                                // < 8 bytes
  SendBytes(m, Drive(), {0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00});  // CW flagged, absent
  ASSERT_TRUE(WaitFor([&] { return server_->counters().malformed == 2; }));
  const auto reply = Transact(m, Poll());
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(server_->counters().replies_sent, 1u);
}

TEST_F(ServerTest, PhysicsFollowsManualClock_SwitchOnAndMove) {
  SimOptions o;
  o.master_port = 0;
  StartServer(o);
  UdpSocket m = Master();
  ASSERT_TRUE(Transact(m, Cw(mc::kSwitchedOff)).has_value());
  auto r = Transact(m, Cw(mc::kOperational));
  EXPECT_EQ(mc::StateVar::FromRaw(*r->state_var).main_state, 5);
  clock_.Advance(milliseconds(300));  // HW tests (no real waiting)
  r = Transact(m, Cw(mc::kOperational));
  EXPECT_EQ(mc::StateVar::FromRaw(*r->state_var).main_state, 8);
  linudp::Request move = Poll();
  move.motion_command =
      *mc::EncodeMotionCommand(mc::VaiGoToPos(500'000, 1'000'000, 1'000'000, 1'000'000), 1);
  r = Transact(m, move);
  EXPECT_EQ(mc::StateVar::FromRaw(*r->state_var).count_echo(), 1);
  EXPECT_TRUE(mc::StateVar::FromRaw(*r->state_var).motion_active());
  clock_.Advance(milliseconds(500));
  r = Transact(m, Poll());
  EXPECT_EQ(r->demand_position, 500'000);
  EXPECT_FALSE(mc::StateVar::FromRaw(*r->state_var).motion_active());
  EXPECT_EQ(server_->Snapshot().device.demand_position, 500'000);
}

TEST_F(ServerTest, StopAnswering_LinkLossThenRecovery) {
  SimOptions o;
  o.master_port = 0;
  StartServer(o);
  UdpSocket m = Master();
  server_->SetAnswering(false);
  SendBytes(m, Drive(), linudp::EncodeRequest(Poll()));
  ASSERT_TRUE(WaitFor([&] { return server_->counters().dropped_not_answering == 1; }));
  auto nothing = m.Receive(milliseconds(20));
  EXPECT_FALSE(nothing->has_value());
  server_->SetAnswering(true);
  EXPECT_TRUE(Transact(m, Poll()).has_value());
}

TEST_F(ServerTest, ReplyDelay_MeasuredOnInjectedClock) {
  SimOptions o;
  o.master_port = 0;
  StartServer(o);
  UdpSocket m = Master();
  server_->SetReplyDelay(milliseconds(10));
  SendBytes(m, Drive(), linudp::EncodeRequest(Poll()));
  ASSERT_TRUE(WaitFor([&] { return server_->counters().replies_delayed == 1; }));
  auto early = m.Receive(milliseconds(20));
  EXPECT_FALSE(early->has_value());  // the manual clock has not moved
  clock_.Advance(milliseconds(10));
  auto late = m.Receive(kReplyTimeout);
  ASSERT_TRUE(late.ok() && late->has_value());
  EXPECT_TRUE(linudp::DecodeReply((*late)->bytes).ok());
}

TEST_F(ServerTest, ImpairmentDropAll_NoReplies) {
  SimOptions o;
  o.master_port = 0;
  StartServer(o);
  UdpSocket m = Master();
  ASSERT_TRUE(server_->SetImpairment({.drop_probability = 1.0, .seed = 7}).ok());
  SendBytes(m, Drive(), linudp::EncodeRequest(Poll()));
  ASSERT_TRUE(WaitFor([&] { return server_->counters().replies_dropped == 1; }));
  EXPECT_TRUE(absl::IsInvalidArgument(server_->SetImpairment({.drop_probability = 2.0})));
}

TEST_F(ServerTest, ManualPadding_64ByteReplies_A06) {
  SimOptions o;
  o.master_port = 0;
  o.min_reply_payload = linudp::kManualReplyPayload;
  StartServer(o);
  UdpSocket m = Master();
  linudp::Request r;
  r.response_definition = linudp::kRespStatusWord;
  SendBytes(m, Drive(), linudp::EncodeRequest(r));
  auto got = m.Receive(kReplyTimeout);
  ASSERT_TRUE(got.ok() && got->has_value());
  EXPECT_EQ((*got)->bytes.size(), 64u);
}

TEST_F(ServerTest, RestartOverRtc_SilentForBootTime_A11) {
  SimOptions o;
  o.master_port = 0;
  StartServer(o);
  UdpSocket m = Master();
  linudp::Request nop = Poll();
  nop.response_definition |= linudp::kRespRtc;
  nop.rtc = linudp::RtcRequest{1, 0x00, 0, 0, 0};
  ASSERT_TRUE(Transact(m, nop).has_value());
  linudp::Request restart = nop;
  restart.rtc = linudp::RtcRequest{0, 0x30, 0, 0, 0};
  SendBytes(m, Drive(), linudp::EncodeRequest(restart));
  ASSERT_TRUE(WaitFor([&] { return server_->counters().dropped_not_answering == 1; }));
  EXPECT_TRUE(server_->Snapshot().device.booting);
  clock_.Advance(milliseconds(100));
  const auto reply = Transact(m, restart);
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(reply->rtc->count, 0);
  EXPECT_EQ(reply->rtc->status, 0);
  EXPECT_EQ(server_->Snapshot().device.boots, 1u);
}

TEST_F(ServerTest, RaiseErrorHook_ShowsInReply) {
  SimOptions o;
  o.master_port = 0;
  StartServer(o);
  UdpSocket m = Master();
  ASSERT_TRUE(server_->RaiseError(0x0003).ok());
  const auto reply = Transact(m, Poll());
  EXPECT_EQ(reply->error_code, 0x0003);
  EXPECT_EQ(*reply->state_var, 0x0403);
  EXPECT_TRUE(absl::IsInvalidArgument(server_->RaiseError(0x00FE)));
}

TEST_F(ServerTest, FixIpFilter_OtherSendersIgnored_A15) {
  SimOptions o;
  o.master_port = 0;
  o.master_filter = MasterFilter::kSingleMasterFixIp;
  o.master_ip = 0x7F000002;  // 127.0.0.2: our master at 127.0.0.1 is filtered
  StartServer(o);
  UdpSocket m = Master();
  SendBytes(m, Drive(), linudp::EncodeRequest(Poll()));
  ASSERT_TRUE(WaitFor([&] { return server_->counters().dropped_filtered == 1; }));
  EXPECT_EQ(server_->counters().replies_sent, 0u);
}

TEST_F(ServerTest, SingleMasterFilter_LatchesFirstIp_A15) {
  SimOptions o;
  o.master_port = 0;
  o.master_filter = MasterFilter::kSingleMaster;
  StartServer(o);
  UdpSocket first = Master();  // 127.0.0.1
  auto second = UdpSocket::Bind(Endpoint{0x7F000002, 0});
  ASSERT_TRUE(second.ok()) << second.status();
  ASSERT_TRUE(Transact(first, Poll()).has_value());
  SendBytes(*second, Drive(), linudp::EncodeRequest(Poll()));
  ASSERT_TRUE(WaitFor([&] { return server_->counters().dropped_filtered == 1; }));
  EXPECT_TRUE(Transact(first, Poll()).has_value());
}

TEST_F(ServerTest, StopIsIdempotent) {
  SimOptions o;
  o.master_port = 0;
  StartServer(o);
  server_->Stop();
  server_->Stop();
  SUCCEED();
}

}  // namespace
}  // namespace drivegw::sim::linmot
