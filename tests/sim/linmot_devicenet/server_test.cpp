// LinMotDnServer over a real UDP multicast CAN bus with a scripted master on its own channel and
// a manual clock: start-up, the §13.2 connection cases, fragmentation, bus-off, bad frames,
// fault injection, frame recording and python-can as the master (linmot-devicenet.md §12, §13).
#include "sim/linmot_devicenet/server.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <optional>
#include <random>
#include <span>
#include <thread>

#include "absl/strings/str_cat.h"
#include "adapters/linmot/devicenet/codec_can.h"
#include "adapters/linmot/devicenet/commands.h"
#include "adapters/transport/udp_multicast_channel.h"
#include "sim/linmot_devicenet/device.h"
#include "sim/linmot_devicenet/dn_stack.h"
#include "tests/sim/linmot_devicenet/test_util.h"

namespace drivegw::sim::linmot_devicenet {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;
using testing::F;
using testing::Text;

// A test-specific group (not python-can's default) and a random port per test, so parallel
// ctest runs and demo simulators never share a bus with these tests.
constexpr char kGroup[] = "239.74.163.95";

uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 40000);
}

// Waits for a condition with a deadline (real time); never a fixed sleep.
template <typename Pred>
bool WaitFor(Pred pred, milliseconds timeout = milliseconds(5000)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(milliseconds(2));
  }
  return pred();
}

// The scripted master: its own channel on the bus.
class Master {
 public:
  explicit Master(uint16_t port) {
    auto ch = transport::UdpMulticastChannel::Open({.group = kGroup, .port = port});
    EXPECT_TRUE(ch.ok()) << ch.status();
    if (ch.ok()) channel_ = *std::move(ch);
  }
  bool ok() const { return channel_ != nullptr; }
  void Send(std::string_view frame) {
    ASSERT_TRUE(channel_->Send(dn::ToCanFrame(F(frame))).ok()) << frame;
  }
  void SendRaw(const transport::CanFrame& frame) { ASSERT_TRUE(channel_->Send(frame).ok()); }
  // The next frame on `id` within the timeout ("" if none); other frames are skipped.
  std::string Expect(uint16_t id, milliseconds timeout = milliseconds(3000)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (true) {
      const auto left = deadline - std::chrono::steady_clock::now();
      if (left <= std::chrono::nanoseconds(0)) return "";
      auto f = channel_->Receive(left);
      if (!f.ok() || !f->has_value()) continue;
      auto frame = dn::FromCanFrame(**f);
      if (frame.ok() && frame->id == id) return Text(*frame);
    }
  }
  // Sends and returns the first answer on `id`.
  std::string Transact(std::string_view frame, uint16_t id,
                       milliseconds timeout = milliseconds(3000)) {
    Send(frame);
    return Expect(id, timeout);
  }
  void Drain() {
    while (true) {
      auto f = channel_->Receive(milliseconds(0));
      if (!f.ok() || !f->has_value()) return;
    }
  }

 private:
  std::unique_ptr<transport::UdpMulticastChannel> channel_;
};

class ServerTest : public ::testing::Test {
 protected:
  void Start(DnSimOptions options = testing::F1Options()) {
    port_ = RandomPort();
    master_ = std::make_unique<Master>(port_);
    ASSERT_TRUE(master_->ok());
    options.can.kind = CanBusConfig::Kind::kUdpMulticast;
    options.can.group = kGroup;
    options.can.port = port_;
    if (!trace_.empty()) options.can.trace_file = trace_;
    auto s = LinMotDnServer::Start(options, clock_);
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = *std::move(s);
  }
  // The duplicate MAC check on the bus: a request now, one after 1 s, online after 2 s.
  void GoOnline() {
    ASSERT_EQ(master_->Expect(0x42F), "42F#00.00.00.05.00.4D.4C");
    clock_.Advance(seconds(1));
    ASSERT_EQ(master_->Expect(0x42F), "42F#00.00.00.05.00.4D.4C");
    clock_.Advance(seconds(1));
    ASSERT_TRUE(WaitFor([&] { return Network() == NetworkState::kOnline; }));
  }
  // TC-01 over the bus.
  void SetUpBus() {
    GoOnline();
    ASSERT_EQ(master_->Transact("42E#00.4B.03.01.03.00", 0x42B), "42B#00.CB.00");
    ASSERT_EQ(master_->Transact("42C#00.10.05.02.09.64.00", 0x42B), "42B#00.90.64.00");
    ASSERT_EQ(master_->Transact("42C#00.10.05.01.09.00.00", 0x42B), "42B#00.90.00.00");
  }
  NetworkState Network() { return server_->Snapshot().stack.network; }

  ManualClock clock_{TimePoint{} + std::chrono::hours(1)};
  uint16_t port_ = 0;
  std::string trace_;
  std::unique_ptr<Master> master_;
  std::unique_ptr<LinMotDnServer> server_;
};

// TC-01.
TEST_F(ServerTest, StartUpAllocationAndPoll_Tc01) {
  Start();
  SetUpBus();
  EXPECT_EQ(master_->Transact("42D#00.00.00.00.00.00", 0x3C5), "3C5#01.10.02.00.00.00.00.00");
  EXPECT_EQ(master_->Transact("42D#02.00.02.00.00.00", 0x3C5), "3C5#03.10.02.00.02.00.03.10");
  const auto snap = server_->Snapshot();
  EXPECT_EQ(snap.stack.counters.polls_received, 2u);
  EXPECT_EQ(snap.stack.owner, 0);
  EXPECT_EQ(snap.device.state, ControllerState::kRun);
  EXPECT_EQ(server_->bus_name(), absl::StrCat("udp:", kGroup, ":", port_));
}

// TC-02.
TEST_F(ServerTest, SecondMasterRejectedThenAcceptedAfterRelease_Tc02) {
  Start();
  SetUpBus();
  EXPECT_EQ(master_->Transact("42E#01.4B.03.01.01.01", 0x42B), "42B#01.94.0C.01");
  EXPECT_THAT(master_->Transact("42D#00.00.00.00.00.00", 0x3C5), ::testing::StartsWith("3C5#"));
  EXPECT_EQ(master_->Transact("42E#00.4C.03.01.03", 0x42B), "42B#00.CC");
  EXPECT_EQ(master_->Transact("42E#01.4B.03.01.01.01", 0x42B), "42B#01.CB.00");
}

// TC-06.
TEST_F(ServerTest, ResetControllerNotAnsweredThenDuplicateCheck_Tc06) {
  Start();
  SetUpBus();
  master_->Send("42D#02.00.0F.00.00.00");
  EXPECT_EQ(master_->Expect(0x42F), "42F#00.00.00.05.00.4D.4C");
  clock_.Advance(seconds(1));
  EXPECT_EQ(master_->Expect(0x42F), "42F#00.00.00.05.00.4D.4C");
  clock_.Advance(seconds(1));
  ASSERT_TRUE(WaitFor([&] { return Network() == NetworkState::kOnline; }));
  EXPECT_EQ(master_->Transact("42D#00.00.00.00.00.00", 0x3C5, milliseconds(300)), "");
  EXPECT_EQ(server_->Snapshot().device.controller_resets, 1u);
  EXPECT_EQ(master_->Transact("42E#00.4B.03.01.03.00", 0x42B), "42B#00.CB.00");
}

// TC-07.
TEST_F(ServerTest, DeviceNetDisabled_TransmitsNothing_Tc07) {
  DnSimOptions o = testing::F1Options();
  o.dn_enable = false;
  Start(o);
  EXPECT_EQ(master_->Expect(0x42F, milliseconds(300)), "");
  clock_.Advance(seconds(3));
  EXPECT_EQ(master_->Transact("42E#00.4B.03.01.03.00", 0x42B, milliseconds(300)), "");
  EXPECT_EQ(server_->Snapshot().server.frames_sent, 0u);
}

// TC-08.
TEST_F(ServerTest, MacFromHexRotarySwitches_Tc08) {
  DnSimOptions o = testing::F1Options();
  o.mac_source = MacIdSource::kSwitches;
  o.mac_switches = 0x2A;
  Start(o);
  EXPECT_EQ(server_->mac_id(), 42);
  EXPECT_THAT(master_->Expect(0x557), ::testing::StartsWith("557#00."));
  clock_.Advance(seconds(1));
  EXPECT_THAT(master_->Expect(0x557), ::testing::StartsWith("557#00."));
  clock_.Advance(seconds(1));
  ASSERT_TRUE(WaitFor([&] { return Network() == NetworkState::kOnline; }));
  EXPECT_EQ(master_->Transact("556#00.4B.03.01.03.00", 0x553), "553#00.CB.00");
  EXPECT_EQ(master_->Transact("554#00.10.05.02.09.64.00", 0x553), "553#00.90.64.00");
  EXPECT_THAT(master_->Transact("555#00.00.00.00.00.00", 0x3EA), ::testing::StartsWith("3EA#"));
}

// TC-10: a second node with MAC 5 answers the check.
TEST_F(ServerTest, DuplicateMacAnswered_StaysOffline8101_Tc10) {
  Start();
  ASSERT_EQ(master_->Expect(0x42F), "42F#00.00.00.05.00.4D.4C");
  master_->Send("42F#80.00.00.11.22.33.44");
  ASSERT_TRUE(WaitFor([&] { return Network() == NetworkState::kCommunicationFaulted; }));
  clock_.Advance(seconds(5));
  EXPECT_EQ(master_->Transact("42E#00.4B.03.01.03.00", 0x42B, milliseconds(300)), "");
  EXPECT_EQ(server_->Snapshot().device.coded_error, dn::kCodedMacIdInUse);
}

// TC-11 (D-16 default: hold; the CAN controller reset keeps the latched 0x8148).
TEST_F(ServerTest, BusOffThenRecovery_CodedError8148Readable_Tc11) {
  Start();
  SetUpBus();
  server_->GoBusOff();
  EXPECT_EQ(master_->Transact("42D#00.00.00.00.00.00", 0x3C5, milliseconds(300)), "");
  master_->Drain();
  server_->RecoverBusOff();
  GoOnline();
  ASSERT_EQ(master_->Transact("42E#00.4B.03.01.03.00", 0x42B), "42B#00.CB.00");
  ASSERT_EQ(master_->Transact("42C#00.10.05.02.09.64.00", 0x42B), "42B#00.90.64.00");
  EXPECT_THAT(master_->Transact("42D#02.00.0A.00.00.00", 0x3C5),
              ::testing::EndsWith("0A.00.48.81"));
  EXPECT_EQ(server_->Snapshot().stack.bus_off_count, 1);
}

// TC-46 over the bus: fragments both ways; a missing middle fragment discards the poll.
TEST_F(ServerTest, Example1FragmentationBothWays_Tc46) {
  Start(testing::F3Options());
  SetUpBus();
  master_->Send("42D#00.00.00.18.20.00.00.00");
  master_->Send("42D#41.00.00.00.00.00.00.00");
  master_->Send("42D#42.00.00.00.00.00.00.00");
  master_->Send("42D#83.00");
  EXPECT_THAT(master_->Expect(0x3C5), ::testing::StartsWith("3C5#00."));
  EXPECT_THAT(master_->Expect(0x3C5), ::testing::StartsWith("3C5#41."));
  EXPECT_THAT(master_->Expect(0x3C5), ::testing::StartsWith("3C5#42."));
  EXPECT_THAT(master_->Expect(0x3C5), ::testing::StartsWith("3C5#83."));
  master_->Send("42D#00.00.00.18.20.00.00.00");
  master_->Send("42D#42.00.00.00.00.00.00.00");
  master_->Send("42D#83.00");
  EXPECT_EQ(master_->Expect(0x3C5, milliseconds(300)), "");
  EXPECT_GE(server_->Snapshot().stack.counters.fragment_errors, 1u);
}

// STYLE §6 / issue 3: bad frames are counted and dropped; the server survives.
TEST_F(ServerTest, MalformedFramesCountedServerSurvives) {
  Start();
  SetUpBus();
  transport::CanFrame extended = dn::ToCanFrame(F("42D#00.00.00.00.00.00"));
  extended.extended = true;
  master_->SendRaw(extended);
  master_->SendRaw(transport::MakeCanRtrFrame(0x42C, 4));
  master_->Send("7F5#01.02");
  master_->Send("42C#00.0E");
  EXPECT_EQ(master_->Expect(0x42B), "42B#00.94.13.FF");
  ASSERT_TRUE(WaitFor([&] {
    const auto s = server_->Snapshot();
    return s.server.malformed >= 2 && s.stack.counters.malformed >= 2;
  }));
  EXPECT_THAT(master_->Transact("42D#00.00.00.00.00.00", 0x3C5), ::testing::StartsWith("3C5#"));
}

// §5.6: 4 x EPR on the injected clock.
TEST_F(ServerTest, PollWatchdogOnTheInjectedClock) {
  Start();
  SetUpBus();
  EXPECT_THAT(master_->Transact("42D#00.00.00.00.00.00", 0x3C5), ::testing::StartsWith("3C5#"));
  clock_.Advance(milliseconds(400));
  ASSERT_TRUE(WaitFor([&] {
    return server_->Snapshot().stack.poll_connection.state == ConnectionState::kTimedOut;
  }));
  EXPECT_FALSE(server_->Snapshot().device.io_connected);
  EXPECT_EQ(master_->Transact("42D#00.00.00.00.00.00", 0x3C5, milliseconds(300)), "");
  EXPECT_EQ(master_->Transact("42C#00.0E.05.02.01", 0x42B), "42B#00.8E.04");
}

TEST_F(ServerTest, MotionOnTheInjectedClock_SetPointReached) {
  Start();
  SetUpBus();
  master_->Transact("42D#00.00.00.00.00.00", 0x3C5);
  master_->Transact("42D#02.00.11.10.00.14", 0x3C5);
  for (int i = 0; i < 20; ++i) {
    clock_.Advance(milliseconds(90));
    master_->Transact("42D#02.00.11.10.00.14", 0x3C5);  // keeps the 400 ms watchdog fed
  }
  EXPECT_EQ(master_->Transact("42D#02.00.18.10.00.00", 0x3C5), "3C5#03.10.02.00.18.10.00.14");
  EXPECT_NEAR(server_->Snapshot().device.motors[0].actual_mm, 100.0, 1e-6);
}

TEST_F(ServerTest, FaultInjection_DropDelayAndCodedError) {
  Start();
  SetUpBus();
  server_->DropNextPolls(1);
  EXPECT_EQ(master_->Transact("42D#00.00.00.00.00.00", 0x3C5, milliseconds(300)), "");
  EXPECT_THAT(master_->Transact("42D#00.00.00.00.00.00", 0x3C5), ::testing::StartsWith("3C5#"));
  server_->SetResponseDelay(milliseconds(50));
  EXPECT_EQ(master_->Transact("42D#00.00.00.00.00.00", 0x3C5, milliseconds(200)), "")
      << "due only on the injected clock";
  clock_.Advance(milliseconds(50));
  EXPECT_THAT(master_->Expect(0x3C5), ::testing::StartsWith("3C5#"));
  server_->SetResponseDelay(Duration{0});
  EXPECT_FALSE(server_->RaiseCodedError(0x1234).ok());
  ASSERT_TRUE(server_->RaiseCodedError(dn::kCodedCanCrcError).ok());
  EXPECT_THAT(master_->Transact("42D#00.00.0A.00.00.00", 0x3C5),
              ::testing::EndsWith("0A.00.45.81"));
  server_->WithDevice(
      [](LinMotDnDevice& d) { d.SetMotorErrorCause(Motor::kA, dn::kMotorTooHotSensor); });
  // Decision 954: the coded-error register and the error-state latch are separate registers;
  // each keeps its own first cause (D-23).
  EXPECT_THAT(master_->Transact("42D#00.00.08.10.00.00", 0x3C5),
              ::testing::EndsWith("08.10.02.00"));
  EXPECT_THAT(master_->Transact("42D#00.00.08.00.00.00", 0x3C5),
              ::testing::EndsWith("08.00.80.10"));
}

TEST_F(ServerTest, TwoDrivesOnOneBus) {
  Start();
  DnSimOptions o = testing::F1Options();
  o.name = "second";
  o.mac_id = 6;
  o.can = server_->options().can;
  auto second = LinMotDnServer::Start(o, clock_);
  ASSERT_TRUE(second.ok()) << second.status();
  // Each drive's check advances only when its thread has seen the clock move.
  ASSERT_TRUE(WaitFor(
      [&] { return (*second)->Snapshot().stack.counters.duplicate_mac_requests_sent == 1; }));
  clock_.Advance(seconds(1));
  ASSERT_TRUE(WaitFor([&] {
    return server_->Snapshot().stack.counters.duplicate_mac_requests_sent == 2 &&
           (*second)->Snapshot().stack.counters.duplicate_mac_requests_sent == 2;
  }));
  clock_.Advance(seconds(1));
  ASSERT_TRUE(WaitFor([&] {
    return Network() == NetworkState::kOnline &&
           (*second)->Snapshot().stack.network == NetworkState::kOnline;
  }));
  EXPECT_EQ(master_->Transact("42E#00.4B.03.01.03.00", 0x42B), "42B#00.CB.00");
  EXPECT_EQ(master_->Transact("436#00.4B.03.01.03.00", 0x433), "433#00.CB.00");
  EXPECT_EQ(master_->Transact("434#00.10.05.02.09.64.00", 0x433), "433#00.90.64.00");
  EXPECT_THAT(master_->Transact("435#00.00.00.00.00.00", 0x3C6), ::testing::StartsWith("3C6#"));
  EXPECT_GT(server_->Snapshot().stack.counters.not_for_us, 0u);
}

TEST_F(ServerTest, FramesRecordedAndCandumpTraceWritten) {
  trace_ =
      absl::StrCat(::testing::TempDir(), "/dnsim_trace_", ::getpid(), "_", RandomPort(), ".log");
  Start();
  SetUpBus();
  master_->Transact("42D#00.00.00.00.00.00", 0x3C5);
  const auto frames = server_->Frames();
  ASSERT_GE(frames.size(), 8u);
  EXPECT_TRUE(frames.front().transmitted);
  EXPECT_EQ(Text(frames.front().frame), "42F#00.00.00.05.00.4D.4C");
  EXPECT_FALSE(frames[frames.size() - 2].transmitted);
  EXPECT_EQ(Text(frames.back().frame), "3C5#01.10.02.00.00.00.00.00");
  std::ifstream in(trace_);
  std::string line;
  int lines = 0;
  bool saw_poll = false;
  while (std::getline(in, line)) {
    ++lines;
    saw_poll = saw_poll || line.find("42D#000000000000") != std::string::npos;
  }
  EXPECT_GE(lines, 8);
  EXPECT_TRUE(saw_poll);
  std::remove(trace_.c_str());
  server_->ClearFrames();
  EXPECT_TRUE(server_->Frames().empty());
}

TEST_F(ServerTest, StartWithInjectedChannel_AndInvalidOptions) {
  DnSimOptions bad = testing::F1Options();
  bad.motor_count = 0;
  auto s = LinMotDnServer::Start(bad, clock_);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  port_ = RandomPort();
  Master master(port_);
  auto channel = transport::UdpMulticastChannel::Open({.group = kGroup, .port = port_});
  ASSERT_TRUE(channel.ok());
  auto server = LinMotDnServer::Start(testing::F1Options(), clock_, *std::move(channel));
  ASSERT_TRUE(server.ok()) << server.status();
  EXPECT_EQ(master.Expect(0x42F), "42F#00.00.00.05.00.4D.4C");
  (*server)->Stop();
  (*server)->Stop();  // idempotent
}

// An injected channel whose controller reports bus-off: the drive goes bus-off itself (§5.10).
class FakeChannel : public transport::CanChannel {
 public:
  absl::Status Send(const transport::CanFrame&) override {
    ++sent;
    return absl::OkStatus();
  }
  absl::StatusOr<std::optional<transport::CanFrame>> Receive(
      std::chrono::nanoseconds timeout) override {
    std::unique_lock lock(mu_);
    cv_.wait_for(lock, timeout, [&] { return woken_; });
    woken_ = false;
    return std::optional<transport::CanFrame>();
  }
  void Wake() override {
    std::lock_guard lock(mu_);
    woken_ = true;
    cv_.notify_all();
  }
  absl::Status SetFilters(std::span<const transport::CanFilter>) override {
    return absl::OkStatus();
  }
  transport::CanBusState state() const override { return state_.load(); }
  transport::CanCounters counters() const override { return {}; }
  std::string name() const override { return "fake0"; }

  std::atomic<transport::CanBusState> state_{transport::CanBusState::kActive};
  std::atomic<int> sent{0};

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  bool woken_ = false;
};

TEST_F(ServerTest, ChannelReportsBusOff_DriveGoesBusOff8148) {
  auto fake = std::make_unique<FakeChannel>();
  FakeChannel* channel = fake.get();
  auto server = LinMotDnServer::Start(testing::F1Options(), clock_, std::move(fake));
  ASSERT_TRUE(server.ok()) << server.status();
  EXPECT_EQ((*server)->bus_name(), "fake0");
  EXPECT_EQ(channel->sent.load(), 1) << "the first duplicate MAC request";
  channel->state_ = transport::CanBusState::kBusOff;
  ASSERT_TRUE(
      WaitFor([&] { return (*server)->Snapshot().stack.network == NetworkState::kBusOff; }));
  EXPECT_EQ((*server)->Snapshot().device.coded_error, dn::kCodedCanBusOff);
  clock_.Advance(seconds(5));
  (*server)->Snapshot();
  EXPECT_EQ(channel->sent.load(), 1) << "nothing transmitted while bus-off";
  (*server)->Stop();
}

// ---- python-can as the master (Debian python3-can, run by /usr/bin/python3) ----

constexpr char kPython[] = "/usr/bin/python3";  // the python3 on PATH may lack apt modules

bool PythonCanInstalled() {
  return std::system(absl::StrCat(kPython, " -c 'import can' >/dev/null 2>&1").c_str()) == 0;
}

constexpr char kPythonMaster[] = R"py(
import sys, can
group, port = sys.argv[1], int(sys.argv[2])
bus = can.Bus(interface="udp_multicast", channel=group, port=port)
def transact(arb, data, want):
    bus.send(can.Message(arbitration_id=arb, is_extended_id=False, data=bytes(data)))
    while True:
        m = bus.recv(timeout=5)
        if m is None:
            return "timeout"
        if m.arbitration_id == want:
            return "%03X#%s" % (m.arbitration_id, m.data.hex().upper())
print(transact(0x42E, [0x00, 0x4B, 0x03, 0x01, 0x03, 0x00], 0x42B), flush=True)
print(transact(0x42C, [0x00, 0x10, 0x05, 0x02, 0x09, 0x64, 0x00], 0x42B), flush=True)
print(transact(0x42D, [0x02, 0x00, 0x02, 0x00, 0x00, 0x00], 0x3C5), flush=True)
bus.shutdown()
)py";

TEST_F(ServerTest, PythonCanMaster_AllocatesAndPolls) {
  if (!PythonCanInstalled()) GTEST_SKIP() << "python-can is missing: apt-get install python3-can";
  Start();
  GoOnline();
  const std::string script =
      absl::StrCat(::testing::TempDir(), "/dnsim_master_", ::getpid(), "_", port_, ".py");
  std::ofstream(script) << kPythonMaster;
  FILE* pipe = ::popen(
      absl::StrCat("timeout 30 ", kPython, " ", script, " ", kGroup, " ", port_, " 2>&1").c_str(),
      "r");
  ASSERT_NE(pipe, nullptr);
  std::vector<std::string> lines;
  char buf[512];
  while (std::fgets(buf, sizeof(buf), pipe)) {
    std::string l(buf);
    if (!l.empty() && l.back() == '\n') l.pop_back();
    lines.push_back(l);
  }
  const int status = ::pclose(pipe);
  std::remove(script.c_str());
  EXPECT_EQ(WIFEXITED(status) ? WEXITSTATUS(status) : -1, 0);
  EXPECT_THAT(lines, ::testing::ElementsAre("42B#00CB00", "42B#00906400",
                                            "3C5#031002000200"
                                            "0310"));
}

}  // namespace
}  // namespace drivegw::sim::linmot_devicenet
