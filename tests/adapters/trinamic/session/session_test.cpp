// ControllerSession over a real pty with a scripted controller thread, and over the UDP CAN bus.
#include "adapters/trinamic/session.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "adapters/transport/can_frame.h"
#include "adapters/transport/pty.h"

namespace drivegw::trinamic {
namespace {

using std::chrono::milliseconds;
using ::testing::HasSubstr;

constexpr uint8_t kRa = 0xF0;

Deadline In(milliseconds ms) { return SessionClock::now() + ms; }

// Replies the controller sends for one received command (empty: silent).
using Script = std::function<std::vector<uint8_t>(const Command&)>;

std::vector<uint8_t> ReplyBytes(const Reply& reply, ReplyFraming framing) {
  auto bytes = EncodeReply(reply, framing);
  EXPECT_TRUE(bytes.ok()) << bytes.status();
  return bytes.ok() ? *bytes : std::vector<uint8_t>{};
}

// The master side of a pty: reads 9-byte words, records them, answers per script (§2.3/§2.4).
class ScriptedController {
 public:
  explicit ScriptedController(ReplyFraming framing) : framing_(framing) {
    auto pty = transport::PseudoTerminal::Open();
    EXPECT_TRUE(pty.ok()) << pty.status();
    pty_.emplace(std::move(*pty));
    script_ = [this](const Command& c) { return Default(c); };
    thread_ = std::thread([this] { Run(); });
  }
  ~ScriptedController() {
    stop_ = true;
    thread_.join();
  }
  std::string path() const { return pty_->slave_path(); }
  ReplyFraming framing() const { return framing_; }

  void SetScript(Script s) {
    std::lock_guard<std::mutex> l(mu_);
    script_ = std::move(s);
  }
  std::vector<uint8_t> Received() {
    std::lock_guard<std::mutex> l(mu_);
    return received_;
  }
  size_t Words() {
    std::lock_guard<std::mutex> l(mu_);
    return received_.size() / kCommandSize;
  }
  // The default controller: $43 firmware 148, no reset; $20 posact = motnr × 1000.
  std::vector<uint8_t> Default(const Command& c) {
    Reply r;
    r.response_address = kRa;
    r.opcode = c.opcode;
    if (c.opcode == Opcode::kUnitInformation) {
      r.values = {148, 0, 25, 4711, 0, 0, 0};
    } else if (c.opcode == Opcode::kQueryPosition) {
      r.values = {c.values[0], c.values[0] * 1000, 0, 0, 0, 0, 0};
    } else {
      return {};
    }
    return ReplyBytes(r, framing_);
  }

 private:
  void Run() {
    while (!stop_) {
      auto word = pty_->ReadExactly(kCommandSize, milliseconds(20));
      if (!word.ok()) continue;  // idle
      auto cmd = DecodeCommand(*word);
      Script script;
      {
        std::lock_guard<std::mutex> l(mu_);
        received_.insert(received_.end(), word->begin(), word->end());
        script = script_;
      }
      if (!cmd.ok()) continue;
      auto out = script(*cmd);
      if (!out.empty()) (void)pty_->Write(out);
    }
  }

  ReplyFraming framing_;
  std::optional<transport::PseudoTerminal> pty_;
  std::mutex mu_;
  Script script_;
  std::vector<uint8_t> received_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

struct RecordingObserver : SessionObserver {
  void OnLinkChange(LinkState s, const std::string& reason) noexcept override {
    std::lock_guard<std::mutex> l(mu);
    states.push_back(s);
    last_reason = reason;
  }
  void OnControllerReset(uint8_t address) noexcept override {
    std::lock_guard<std::mutex> l(mu);
    resets.push_back(address);
  }
  void OnSessionEvent(SessionEvent e, const std::string& detail) noexcept override {
    std::lock_guard<std::mutex> l(mu);
    events.push_back(e);
    last_event = detail;
  }
  std::mutex mu;
  std::vector<LinkState> states;
  std::vector<uint8_t> resets;
  std::vector<SessionEvent> events;
  std::string last_reason, last_event;
};

SessionOptions FastOptions() {
  SessionOptions o;
  o.address = 1;
  o.offline_after_misses = 2;
  o.probe_timeout = milliseconds(300);
  o.retry_min = milliseconds(20);
  o.retry_max = milliseconds(40);
  o.break_duration = milliseconds(1);
  return o;
}

std::shared_ptr<ControllerSession> OpenSession(const ScriptedController& ctl,
                                               const SessionOptions& o = FastOptions()) {
  transport::SerialConfig config;
  config.device = ctl.path();
  config.baud = 19200;
  auto s = ControllerSession::OpenSerial(config, o);
  EXPECT_TRUE(s.ok()) << s.status();
  return s.ok() ? *s : nullptr;
}

Command QueryPosition(uint8_t motnr) {
  auto c = MakeCommand(1, Opcode::kQueryPosition, {motnr, kRa});
  EXPECT_TRUE(c.ok()) << c.status();
  return *c;
}

class FramingTest : public ::testing::TestWithParam<ReplyFraming> {};

TEST_P(FramingTest, Transact_Query_DetectsFramingAndReturnsReply) {
  ScriptedController ctl(GetParam());
  auto session = OpenSession(ctl);
  ASSERT_NE(session, nullptr);
  EXPECT_EQ(session->link_state(), LinkState::kUnknown);
  auto r = session->Transact(QueryPosition(3), In(milliseconds(500)));
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_TRUE(r->has_value());
  EXPECT_EQ((*r)->opcode, Opcode::kQueryPosition);
  EXPECT_EQ((*r)->values[0], 3);
  EXPECT_EQ((*r)->values[1], 3000);
  EXPECT_EQ(session->link_state(), LinkState::kOnline);
  EXPECT_EQ(session->framing(), GetParam());
  // The probe went first: A 43 RA 00.. (§2.4 G-01), then the query.
  auto bytes = ctl.Received();
  ASSERT_EQ(bytes.size(), 2 * kCommandSize);
  EXPECT_EQ(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 9),
            (std::vector<uint8_t>{1, 0x43, kRa, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(session->counters().replies, 2u);
}

TEST_P(FramingTest, Transact_SilentCommand_ReturnsNulloptWithoutWaiting) {
  ScriptedController ctl(GetParam());
  auto session = OpenSession(ctl);
  ASSERT_NE(session, nullptr);
  auto cmd = MakeCommand(1, Opcode::kSetTarget, {2, 12345});
  ASSERT_TRUE(cmd.ok());
  auto r = session->Transact(*cmd, In(milliseconds(500)));
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_FALSE(r->has_value());
}

INSTANTIATE_TEST_SUITE_P(Both, FramingTest,
                         ::testing::Values(ReplyFraming::kR8, ReplyFraming::kR9));

TEST(SessionTest, Transact_NoReply_DeadlineExceededNamesAddressAndOpcode) {
  ScriptedController ctl(ReplyFraming::kR8);
  auto o = FastOptions();
  o.offline_after_misses = 5;
  auto session = OpenSession(ctl, o);
  ASSERT_NE(session, nullptr);
  ASSERT_TRUE(session->Probe().ok());
  ctl.SetScript([](const Command&) { return std::vector<uint8_t>{}; });
  auto r = session->Transact(QueryPosition(0), In(milliseconds(60)));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("address 1"));
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("query_position"));
  EXPECT_EQ(session->counters().timeouts, 1u);
  EXPECT_EQ(session->link_state(), LinkState::kOnline);
}

TEST(SessionTest, Transact_Garbage_ResyncsAndNextSucceeds) {
  ScriptedController ctl(ReplyFraming::kR8);
  auto session = OpenSession(ctl);
  ASSERT_NE(session, nullptr);
  RecordingObserver obs;
  session->AddObserver(&obs);
  ASSERT_TRUE(session->Probe().ok());
  std::atomic<int> calls{0};
  ctl.SetScript([&](const Command& c) {
    if (calls++ == 0) return std::vector<uint8_t>{0x55, 0xAA, 0x13, 0x37, 0x01, 0x02, 0x03, 0x04};
    return ctl.Default(c);
  });
  auto bad = session->Transact(QueryPosition(1), In(milliseconds(300)));
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(bad.status().message()), HasSubstr("garbage"));
  auto good = session->Transact(QueryPosition(2), In(milliseconds(500)));
  ASSERT_TRUE(good.ok()) << good.status();
  EXPECT_EQ((*good)->values[1], 2000);
  auto c = session->counters();
  EXPECT_EQ(c.garbage, 1u);
  EXPECT_GE(c.resyncs, 1u);
  std::lock_guard<std::mutex> l(obs.mu);
  ASSERT_FALSE(obs.events.empty());
  EXPECT_EQ(obs.events[0], SessionEvent::kGarbage);
}

TEST(SessionTest, Transact_MissesGoOfflineThenRecoverAfterBackoff) {
  ScriptedController ctl(ReplyFraming::kR9);
  auto session = OpenSession(ctl);
  ASSERT_NE(session, nullptr);
  RecordingObserver obs;
  session->AddObserver(&obs);
  ASSERT_TRUE(session->Probe().ok());
  ctl.SetScript([](const Command&) { return std::vector<uint8_t>{}; });
  for (int i = 0; i < 2; ++i) {
    auto r = session->Transact(QueryPosition(0), In(milliseconds(40)));
    EXPECT_EQ(r.status().code(), absl::StatusCode::kDeadlineExceeded);
  }
  EXPECT_EQ(session->link_state(), LinkState::kOffline);
  auto fast = session->Transact(QueryPosition(0), In(milliseconds(40)));
  EXPECT_EQ(fast.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(fast.status().message()), HasSubstr("OFFLINE"));

  ctl.SetScript([&](const Command& c) { return ctl.Default(c); });
  const Deadline give_up = In(milliseconds(3000));
  absl::StatusOr<std::optional<Reply>> r = absl::UnknownError("");
  while (SessionClock::now() < give_up) {
    r = session->Transact(QueryPosition(4), In(milliseconds(300)));
    if (r.ok()) break;
    std::this_thread::sleep_for(milliseconds(5));  // polling pace of a drive, not a timing wait
  }
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ((*r)->values[1], 4000);
  EXPECT_EQ(session->link_state(), LinkState::kOnline);
  EXPECT_EQ(session->counters().offline_events, 1u);
  std::lock_guard<std::mutex> l(obs.mu);
  ASSERT_GE(obs.states.size(), 3u);
  EXPECT_EQ(obs.states[0], LinkState::kOnline);
  EXPECT_EQ(obs.states[1], LinkState::kOffline);
  EXPECT_EQ(obs.states.back(), LinkState::kOnline);
}

TEST(SessionTest, Probe_ResetFlagAndStrayZero_NotifiesObserver) {
  ScriptedController ctl(ReplyFraming::kR8);
  std::atomic<bool> reset{true};
  ctl.SetScript([&](const Command& c) {
    auto out = ctl.Default(c);
    if (c.opcode == Opcode::kUnitInformation && reset.exchange(false)) {
      Reply r;
      r.opcode = Opcode::kUnitInformation;
      r.values = {148, 1, 25, 4711, 0, 0, 0};
      out = ReplyBytes(r, ReplyFraming::kR8);
      out.insert(out.begin(), 0x00);  // the 0-byte after a hardware reset (L228)
    }
    return out;
  });
  auto session = OpenSession(ctl);
  ASSERT_NE(session, nullptr);
  RecordingObserver obs;
  session->AddObserver(&obs);
  ASSERT_TRUE(session->Probe().ok());
  EXPECT_EQ(session->framing(), ReplyFraming::kR8);
  auto again =
      session->Transact(*MakeCommand(1, Opcode::kUnitInformation, {kRa}), In(milliseconds(300)));
  ASSERT_TRUE(again.ok()) << again.status();
  auto c = session->counters();
  EXPECT_EQ(c.resets_seen, 1u);
  EXPECT_EQ(c.stray_zeros, 1u);
  std::lock_guard<std::mutex> l(obs.mu);
  EXPECT_EQ(obs.resets, std::vector<uint8_t>{1});
}

TEST(SessionTest, Transact_ConcurrentCallers_NeverInterleave) {
  ScriptedController ctl(ReplyFraming::kR9);
  auto o = FastOptions();
  o.command_gap = std::chrono::microseconds(100);
  o.duplicate_window = std::chrono::microseconds(100);
  auto session = OpenSession(ctl, o);
  ASSERT_NE(session, nullptr);
  constexpr int kThreads = 4, kEach = 15;
  std::atomic<int> ok{0}, mismatched{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kEach; ++i) {
        auto r = session->Transact(QueryPosition(static_cast<uint8_t>(t)), In(milliseconds(1000)));
        if (!r.ok() || !r->has_value()) continue;
        ++ok;
        if ((*r)->values[0] != t || (*r)->values[1] != t * 1000) ++mismatched;
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(ok.load(), kThreads * kEach);
  EXPECT_EQ(mismatched.load(), 0);
  auto bytes = ctl.Received();
  ASSERT_EQ(bytes.size() % kCommandSize, 0u);
  size_t queries = 0;
  for (size_t i = 0; i < bytes.size(); i += kCommandSize) {
    auto cmd = DecodeCommand(std::span<const uint8_t>(bytes).subspan(i, kCommandSize));
    ASSERT_TRUE(cmd.ok()) << "word " << i / kCommandSize << ": " << cmd.status();
    EXPECT_EQ(cmd->address, 1);
    if (cmd->opcode == Opcode::kQueryPosition) ++queries;
  }
  EXPECT_EQ(queries, static_cast<size_t>(kThreads * kEach));
}

TEST(SessionTest, Transact_TwoAnswers_ReportsDuplicateAddress) {
  ScriptedController ctl(ReplyFraming::kR8);
  auto session = OpenSession(ctl);
  ASSERT_NE(session, nullptr);
  RecordingObserver obs;
  session->AddObserver(&obs);
  ASSERT_TRUE(session->Probe().ok());
  ctl.SetScript([&](const Command& c) {
    auto out = ctl.Default(c);
    if (c.opcode == Opcode::kQueryPosition) {
      auto twice = out;
      twice.insert(twice.end(), out.begin(), out.end());
      return twice;
    }
    return out;
  });
  auto r = session->Transact(QueryPosition(1), In(milliseconds(300)));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(r.status().message()), HasSubstr("same address"));
  EXPECT_EQ(session->counters().duplicate_replies, 1u);
  std::lock_guard<std::mutex> l(obs.mu);
  ASSERT_EQ(obs.events.size(), 1u);
  EXPECT_EQ(obs.events[0], SessionEvent::kDuplicateAddress);
}

TEST(SessionTest, Transact_BytesAfterReply_ReplyStandsGarbageCounted) {
  ScriptedController ctl(ReplyFraming::kR9);
  auto session = OpenSession(ctl);
  ASSERT_NE(session, nullptr);
  ASSERT_TRUE(session->Probe().ok());
  ctl.SetScript([&](const Command& c) {
    auto out = ctl.Default(c);
    out.push_back(0x77);  // line noise, not a second reply
    return out;
  });
  auto r = session->Transact(QueryPosition(5), In(milliseconds(300)));
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ((*r)->values[1], 5000);
  EXPECT_EQ(session->counters().garbage, 1u);
  EXPECT_EQ(session->counters().duplicate_replies, 0u);
}

TEST(SessionTest, Transact_HardwareReset_OfflineUntilBootThenResetReported) {
  ScriptedController ctl(ReplyFraming::kR8);
  auto o = FastOptions();
  o.reset_boot_time = milliseconds(30);
  auto session = OpenSession(ctl, o);
  ASSERT_NE(session, nullptr);
  RecordingObserver obs;
  session->AddObserver(&obs);
  ASSERT_TRUE(session->Probe().ok());
  std::atomic<bool> was_reset{false};
  ctl.SetScript([&](const Command& c) {
    if (c.opcode == Opcode::kHardwareReset) {
      was_reset = true;
      return std::vector<uint8_t>{};
    }
    auto out = ctl.Default(c);
    if (c.opcode == Opcode::kUnitInformation && was_reset.exchange(false)) {
      Reply r;
      r.opcode = Opcode::kUnitInformation;
      r.values = {148, 1, 25, 4711, 0, 0, 0};
      out = ReplyBytes(r, ReplyFraming::kR8);
      out.insert(out.begin(), 0x00);  // L902
    }
    return out;
  });
  Command reset;
  reset.address = 1;
  reset.opcode = Opcode::kHardwareReset;
  auto sent = session->Transact(reset, In(milliseconds(100)));
  ASSERT_TRUE(sent.ok()) << sent.status();
  EXPECT_EQ(session->link_state(), LinkState::kOffline);
  const Deadline give_up = In(milliseconds(3000));
  absl::StatusOr<std::optional<Reply>> r = absl::UnknownError("");
  while (SessionClock::now() < give_up) {
    r = session->Transact(QueryPosition(1), In(milliseconds(300)));
    if (r.ok()) break;
    std::this_thread::sleep_for(milliseconds(5));  // polling pace of a drive
  }
  ASSERT_TRUE(r.ok()) << r.status();
  std::lock_guard<std::mutex> l(obs.mu);
  EXPECT_EQ(obs.resets, std::vector<uint8_t>{1});
}

TEST(SessionTest, Transact_Rs485HalfDuplex_TurnaroundRespected) {
  ScriptedController ctl(ReplyFraming::kR9);
  transport::SerialConfig config;
  config.device = ctl.path();
  config.baud = 19200;
  config.duplex = transport::SerialConfig::Duplex::kHalfRs485;
  config.turnaround = std::chrono::microseconds(2000);
  auto session = ControllerSession::OpenSerial(config, FastOptions());
  ASSERT_TRUE(session.ok()) << session.status();
  const auto start = SessionClock::now();
  for (int i = 0; i < 3; ++i) {
    auto r = (*session)->Transact(QueryPosition(1), In(milliseconds(500)));
    ASSERT_TRUE(r.ok()) << r.status();
  }
  // 4 words (probe + 3), each Write returns no earlier than the turnaround after its last byte.
  EXPECT_GE(SessionClock::now() - start, std::chrono::microseconds(4 * 2000));
}

TEST(SessionTest, Transact_OtherAddress_InvalidArgument) {
  ScriptedController ctl(ReplyFraming::kR8);
  auto session = OpenSession(ctl);
  ASSERT_NE(session, nullptr);
  auto cmd = MakeCommand(2, Opcode::kQueryPosition, {0, kRa});
  ASSERT_TRUE(cmd.ok());
  EXPECT_EQ(session->Transact(*cmd, In(milliseconds(100))).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// Decision 1471: on a line shared with the controller at address 2 (RA $F1), an R9 reply that
// starts with $F1 is that controller's late reply: counted and dropped, ours still taken.
TEST(TrinamicSharedLineTest, ReplyWithNeighboursRa_CountedDroppedOwnReplyTaken) {
  ScriptedController ctl(ReplyFraming::kR9);
  ctl.SetScript([&](const Command& c) {
    std::vector<uint8_t> out;
    if (c.opcode == Opcode::kQueryPosition) {
      Reply late;  // the neighbour's `$20` reply, arriving after its time-out
      late.response_address = 0xF1;
      late.opcode = Opcode::kQueryPosition;
      late.values = {0, 999, 0, 0, 0, 0, 0};
      out = ReplyBytes(late, ReplyFraming::kR9);
    }
    const std::vector<uint8_t> own = ctl.Default(c);
    out.insert(out.end(), own.begin(), own.end());
    return out;
  });
  auto a = OpenSession(ctl);
  SessionOptions bo = FastOptions();
  bo.address = 2;
  bo.response_address = 0xF1;
  transport::SerialConfig config;
  config.device = ctl.path();
  config.baud = 19200;
  auto b = ControllerSession::OpenSerial(config, bo);  // on the line, idle
  ASSERT_NE(a, nullptr);
  ASSERT_TRUE(b.ok()) << b.status();
  auto r = a->Transact(QueryPosition(3), In(milliseconds(300)));
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_TRUE(r->has_value());
  EXPECT_EQ((*r)->values[1], 3000);  // ours (motnr × 1000), not the neighbour's 999
  const SessionCounters c = a->counters();
  EXPECT_EQ(c.wrong_address, 1u);
  EXPECT_EQ(c.garbage, 0u);
  EXPECT_EQ(a->health().state, HealthState::kUp);
}

uint16_t UniquePort() {
  static std::atomic<int> next{0};
  return static_cast<uint16_t>(20000 + (::getpid() * 16 + 7 + next++) % 40000);
}

TEST(SessionCanTest, Transact_OverUdpBus_CommandAndReplyIds) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = "239.74.163.77";
  bus.port = UniquePort();
  auto peer = transport::OpenCanChannel(bus);
  ASSERT_TRUE(peer.ok()) << peer.status();
  std::atomic<bool> stop{false};
  std::atomic<int> commands{0};
  std::atomic<uint32_t> last_id{0};
  std::thread controller([&] {
    while (!stop) {
      auto f = (*peer)->Receive(milliseconds(20));
      if (!f.ok() || !f->has_value()) continue;
      last_id = (**f).id;
      CanFrame tf;
      tf.id = static_cast<uint16_t>((**f).id);
      tf.dlc = (**f).dlc;
      tf.data = (**f).data;
      auto cmd = DecodeCommandCan(tf);
      if (!cmd.ok()) continue;
      ++commands;
      Reply r;
      r.response_address = kRa;
      r.opcode = cmd->opcode;
      if (cmd->opcode == Opcode::kUnitInformation) {
        r.values = {148, 0, 25, 1, 0, 0, 0};
      } else if (cmd->opcode == Opcode::kQueryPosition) {
        r.values = {cmd->values[0], -77, 0, 0, 0, 0, 0};
      } else {
        continue;
      }
      auto out = EncodeReplyCan(r);
      if (out.ok()) (void)(*peer)->Send(transport::MakeCanFrame(out->id, out->data));
    }
  });
  auto o = FastOptions();
  o.address = 5;
  auto session = ControllerSession::OpenCan(bus, o);
  ASSERT_TRUE(session.ok()) << session.status();
  auto cmd = MakeCommand(5, Opcode::kQueryPosition, {2, kRa});
  ASSERT_TRUE(cmd.ok());
  auto r = (*session)->Transact(*cmd, In(milliseconds(500)));
  stop = true;
  controller.join();
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_TRUE(r->has_value());
  EXPECT_EQ((*r)->values[0], 2);
  EXPECT_EQ((*r)->values[1], -77);
  EXPECT_EQ(last_id.load(), 5u << 3);  // command ID = A × 8 (§3.1)
  EXPECT_EQ(commands.load(), 2);       // $43 probe + query
  EXPECT_EQ((*session)->link_state(), LinkState::kOnline);
}

TEST(SessionTest, SendTunnel_SerialLink_FailedPrecondition) {
  ScriptedController ctl(ReplyFraming::kR8);
  auto session = OpenSession(ctl);
  ASSERT_NE(session, nullptr);
  const absl::Status s = session->SendTunnel({0x41, 0x42});
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(s.message()), ::testing::HasSubstr("tunnel needs CAN"));
}

// §3.5 (L307-317): the bytes leave as one frame on ID (A << 3) + 1 with DLC = their count.
TEST(SessionCanTest, SendTunnel_OneFrameOnTunnelId_DlcIsLength) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = "239.74.163.77";
  bus.port = UniquePort();
  auto peer = transport::OpenCanChannel(bus);
  ASSERT_TRUE(peer.ok()) << peer.status();
  auto o = FastOptions();
  o.address = 5;
  auto session = ControllerSession::OpenCan(bus, o);
  ASSERT_TRUE(session.ok()) << session.status();
  EXPECT_EQ((*session)->SendTunnel({}).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ((*session)->SendTunnel(std::vector<uint8_t>(9, 0x30)).code(),
            absl::StatusCode::kInvalidArgument);
  ASSERT_TRUE((*session)->SendTunnel({0x41, 0x42, 0x43}).ok());
  std::optional<transport::CanFrame> got;
  const auto deadline = SessionClock::now() + milliseconds(1000);
  while (!got && SessionClock::now() < deadline) {
    auto f = (*peer)->Receive(milliseconds(50));
    if (f.ok() && f->has_value()) got = **f;
  }
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->id, (5u << 3) + 1);
  EXPECT_EQ(got->dlc, 3);
  EXPECT_EQ(got->data[0], 0x41);
  EXPECT_EQ(got->data[2], 0x43);
}

}  // namespace
}  // namespace drivegw::trinamic
