// Several controllers on one serial line (RS-485 multi-drop, trinamic-sixpack.md §2.1/§2.2, L273,
// L275; decision 1471): the simulated PACKs answer several unit addresses on one real pty, the
// sessions share one SerialLine (one descriptor, one transaction at a time), a dead PACK on the
// line does not slow the live one, and the line refuses settings that cannot share it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "adapters/core/clock.h"
#include "adapters/trinamic/factory.h"
#include "adapters/trinamic/pack.h"
#include "adapters/trinamic/session.h"
#include "sim/trinamic/server.h"

namespace drivegw::trinamic {
namespace {

using namespace std::chrono_literals;
using ::testing::AllOf;
using ::testing::HasSubstr;

constexpr uint16_t kSerialOf[] = {0, 0x1111, 0x2222, 0x3333};  // by unit address

// Simulated PACKs with addresses 1..units on one pty (the CT-06 multi-drop line).
struct MultiDrop {
  explicit MultiDrop(int units, ReplyFraming framing = ReplyFraming::kR8) {
    static std::atomic<int> n{0};
    sim::trinamic::ServerOptions o;
    o.pty_path = (std::filesystem::temp_directory_path() /
                  ("dgw-trline-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
                     .string();
    o.trace_limit = 0;
    o.controller.address = 1;
    o.controller.serial_number = kSerialOf[1];
    o.controller.framing = framing;
    for (int a = 2; a <= units; ++a) {
      sim::trinamic::ControllerOptions more = o.controller;
      more.address = static_cast<uint8_t>(a);
      more.serial_number = kSerialOf[a];
      o.more_units.push_back(more);
    }
    auto s = sim::trinamic::TrinamicServer::Start(o, SteadyClock::Instance());
    EXPECT_TRUE(s.ok()) << s.status();
    if (s.ok()) server = *std::move(s);
    path = o.pty_path;
  }
  ~MultiDrop() {
    if (server) server->Stop();
  }
  std::unique_ptr<sim::trinamic::TrinamicServer> server;
  std::string path;  // the symlink, as a config names it
};

transport::SerialConfig Line(const std::string& path, int baud = 19200) {
  transport::SerialConfig c;
  c.device = path;
  c.baud = baud;
  return c;
}

SessionOptions Options(uint8_t address, uint8_t ra, const std::string& owner) {
  SessionOptions o;
  o.address = address;
  o.response_address = ra;
  o.owner = owner;
  o.probe_timeout = 100ms;
  o.break_duration = 1ms;
  return o;
}

// Descriptors of this process open on the terminal `path` names (symlink resolved).
int OpenDescriptorsOn(const std::string& path) {
  const auto target = std::filesystem::canonical(path);
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator("/proc/self/fd")) {
    std::error_code ec;
    if (std::filesystem::read_symlink(e.path(), ec) == target) ++n;
  }
  return n;
}

uint16_t SerialNumber(const Reply& r) { return static_cast<uint16_t>(r.values[3]); }

TEST(TrinamicSharedLineTest, TwoControllersOnePty_OneDescriptorAndEveryReplyFromItsOwnPack) {
  MultiDrop line(2);
  ASSERT_NE(line.server, nullptr);
  const int sim_fds = OpenDescriptorsOn(line.path);  // the simulator keeps the slave open too
  auto a = ControllerSession::OpenSerial(Line(line.path), Options(1, 0xF0, "drive 'a'"));
  auto b = ControllerSession::OpenSerial(Line(line.path), Options(2, 0xF1, "drive 'b'"));
  ASSERT_TRUE(a.ok()) << a.status();
  ASSERT_TRUE(b.ok()) << b.status();
  EXPECT_EQ(OpenDescriptorsOn(line.path), sim_fds + 1);  // opened (and termios set) once

  // Both hammer `$43` concurrently: each must only ever see its own PACK's serial number.
  auto run = [](ControllerSession& s, uint8_t address, std::atomic<int>& wrong,
                std::atomic<int>& failed) {
    const Command q =
        *MakeCommand(address, Opcode::kUnitInformation, {s.options().response_address});
    for (int i = 0; i < 150; ++i) {
      auto r = s.Transact(q, SessionClock::now() + 200ms);
      if (!r.ok() || !r->has_value()) {
        ++failed;
      } else if (SerialNumber(**r) != kSerialOf[address]) {
        ++wrong;
      }
    }
  };
  std::atomic<int> wrong{0}, failed{0};
  std::thread ta([&] { run(**a, 1, wrong, failed); });
  std::thread tb([&] { run(**b, 2, wrong, failed); });
  ta.join();
  tb.join();
  EXPECT_EQ(wrong.load(), 0);
  EXPECT_EQ(failed.load(), 0);
  for (auto* s : {&*a, &*b}) {
    const SessionCounters c = (*s)->counters();
    EXPECT_EQ(c.replies, 151u) << (*s)->name();  // the probe and 150 queries
    EXPECT_EQ(c.garbage, 0u) << (*s)->name();
    EXPECT_EQ(c.timeouts, 0u) << (*s)->name();
    EXPECT_EQ((*s)->health().state, HealthState::kUp) << (*s)->name();
  }
  a->reset();
  b->reset();
  EXPECT_EQ(OpenDescriptorsOn(line.path), sim_fds);  // closed with its last member
}

TEST(TrinamicSharedLineTest, Attach_RefusesOtherLineSettingsSameAddressAndRaClash_NamingBoth) {
  MultiDrop line(2);
  ASSERT_NE(line.server, nullptr);
  const int sim_fds = OpenDescriptorsOn(line.path);
  auto a = ControllerSession::OpenSerial(Line(line.path), Options(1, 0xF0, "drive 'a'"));
  ASSERT_TRUE(a.ok()) << a.status();

  auto baud = ControllerSession::OpenSerial(Line(line.path, 9600), Options(2, 0xF0, "drive 'b'"));
  EXPECT_EQ(baud.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(baud.status().message(),
              AllOf(HasSubstr(line.path), HasSubstr("drive 'b' (address 2) wants 9600 baud"),
                    HasSubstr("19200 baud for drive 'a' (address 1)")));

  transport::SerialConfig rs485 = Line(line.path);
  rs485.duplex = transport::SerialConfig::Duplex::kHalfRs485;
  auto duplex = ControllerSession::OpenSerial(rs485, Options(2, 0xF0, "drive 'b'"));
  EXPECT_THAT(duplex.status().message(),
              HasSubstr("drive 'b' (address 2) wants RS-485, the line is RS-232 for drive 'a'"));

  // The same line through its terminal path: one line, so the same address is refused.
  auto same =
      ControllerSession::OpenSerial(Line(line.server->slave_path()), Options(1, 0xF0, "drive 'c'"));
  EXPECT_EQ(same.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(same.status().message(),
              HasSubstr("drive 'c' (address 1) has the unit address of drive 'a' (address 1)"));

  auto ra = ControllerSession::OpenSerial(Line(line.path), Options(2, 1, "drive 'd'"));
  EXPECT_THAT(ra.status().message(),
              HasSubstr("drive 'd' (address 2) sends its replies to response address 1, the "
                        "unit address of drive 'a' (address 1)"));
  EXPECT_EQ(OpenDescriptorsOn(line.path), sim_fds + 1);

  // Refusals leave nothing behind: a valid second controller still joins.
  auto b = ControllerSession::OpenSerial(Line(line.path), Options(2, 0xF0, "drive 'b'"));
  ASSERT_TRUE(b.ok()) << b.status();
  EXPECT_TRUE((*b)->Probe().ok());
}

TEST(TrinamicSharedLineTest, ChangeBaud_RefusedWhileShared_NothingSent) {
  MultiDrop line(2);
  ASSERT_NE(line.server, nullptr);
  auto a = ControllerSession::OpenSerial(Line(line.path), Options(1, 0xF0, "drive 'a'"));
  auto b = ControllerSession::OpenSerial(Line(line.path), Options(2, 0xF0, "drive 'b'"));
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_TRUE((*a)->Probe().ok());
  const uint64_t before = (*a)->counters().requests;
  // `$40` divisor 22 = 57600 baud (§2.1): the PACK at address 2 would stay at 19200.
  const Command word = *MakeCommand(1, Opcode::kSetBaudRate, {22, 3});
  const absl::Status s = (*a)->ChangeBaud(word, SessionClock::now() + 200ms);
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(s.message(), HasSubstr("drive 'b' (address 2) share the line"));
  EXPECT_EQ((*a)->counters().requests, before);
  EXPECT_EQ((*a)->baud(), 19200);
  EXPECT_TRUE((*b)->Probe().ok());
}

// The gateway's path: one Pack (poll thread) per controller. Polls as fast as the line allows.
struct PollOnly : PackListener {
  void OnSample(const AxisSample&) noexcept override {}
  void OnLink(LinkState, const std::string&) noexcept override {}
  void OnControllerReset() noexcept override {}
  void OnDuplicateAddress(const std::string&) noexcept override {}
  std::vector<Command> ApplyCommands(bool) const override { return {}; }
  void AbsorbWord(const Command&) noexcept override {}
  absl::Status CheckShared(uint32_t, int64_t, int) const override { return absl::OkStatus(); }
};

TrinamicConfig PackConfig(const std::string& path, uint8_t address) {
  TrinamicConfig t;
  t.serial = SerialLineConfig{path, 19200, false, 6000us};
  t.address = address;
  // Its own response address per controller (decision 1471): R9 replies then name it.
  t.response_address = static_cast<uint8_t>(0xF0 + address - 1);
  t.axis = 0;
  t.microsteps_per_unit = 10;
  t.poll_period = 1ms;  // the line, not the period, limits the rate
  return t;             // reply_timeout 100 ms, back-off 100 ms .. 5 s (defaults)
}

// The controller at `address` with motor 0 polled by `axis` every 1 ms (nullptr on failure).
std::shared_ptr<Pack> Polled(const std::string& path, uint8_t address, const std::string& owner,
                             PollOnly& axis) {
  auto pack = Pack::Acquire(PackConfig(path, address), owner);
  EXPECT_TRUE(pack.ok()) << pack.status();
  if (!pack.ok()) return nullptr;
  const absl::Status s = (*pack)->Register(0, &axis, 1ms);
  EXPECT_TRUE(s.ok()) << s;
  return s.ok() ? *pack : nullptr;
}

// The gateway's path: two axis drives of two controllers on one device, built without the config
// file's cross-drive checks (which refuse this earlier, TrinamicConfigTest.OneSerialLine_*): the
// second Activate is refused naming both drives.
TEST(TrinamicSharedLineTest, DriveActivate_OtherBaudOnTheSameLine_RefusedNamingBothDrives) {
  MultiDrop line(2);
  ASSERT_NE(line.server, nullptr);
  auto drive = [&](const std::string& name, uint8_t address, int baud) {
    DriveConfig c;
    c.name = name;
    c.family = kFamilyName;
    c.axis.min_mm = 0;
    c.axis.max_mm = 100;
    c.axis.max_velocity_mm_s = 100;
    c.axis.max_acceleration_mm_s2 = 1000;
    c.trinamic = PackConfig(line.path, address);
    c.trinamic->serial->baud = baud;
    auto d = CreateTrinamicDrive(c, SteadyClock::Instance());
    EXPECT_TRUE(d.ok()) << d.status();
    return d.ok() ? *std::move(d) : nullptr;
  };
  std::unique_ptr<Drive> a = drive("feeder-x", 1, 19200);
  std::unique_ptr<Drive> b = drive("feeder-z", 2, 9600);
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->Activate().ok());
  const absl::Status s = b->Activate();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), AllOf(HasSubstr("drive 'feeder-z' (address 2) wants 9600 baud"),
                                 HasSubstr("19200 baud for drive 'feeder-x' (address 1)")));
  a->Deactivate();
}

// Decision 1432: one HealthModel per controller, so the axes of one controller must agree on
// health.up_after_ms (the factory folds it into TrinamicConfig::up_after, like the back-off).
TEST(TrinamicSharedLineTest, SameController_OtherUpAfter_RefusedNamingTheKey) {
  MultiDrop line(1);
  ASSERT_NE(line.server, nullptr);
  auto first = Pack::Acquire(PackConfig(line.path, 1), "drive 'a'");
  ASSERT_TRUE(first.ok()) << first.status();
  TrinamicConfig other = PackConfig(line.path, 1);
  other.up_after = 0ms;
  auto second = Pack::Acquire(other, "drive 'b'");
  ASSERT_EQ(second.status().code(), absl::StatusCode::kInvalidArgument) << second.status();
  EXPECT_THAT(second.status().message(),
              HasSubstr("trinamic.health.up_after_ms: 0 conflicts with 3000"));
  auto same = Pack::Acquire(PackConfig(line.path, 1), "drive 'c'");
  ASSERT_TRUE(same.ok()) << same.status();
  EXPECT_EQ(same->get(), first->get());
}

// Polls answered by `a` and by `b` during the same `window`, per second.
std::pair<double, double> PollsPerSecond(Pack& a, Pack& b, std::chrono::milliseconds window) {
  const uint64_t a0 = a.counters().polls, b0 = b.counters().polls;
  const auto t0 = SessionClock::now();
  std::this_thread::sleep_for(window);
  const double s = std::chrono::duration<double>(SessionClock::now() - t0).count();
  return {static_cast<double>(a.counters().polls - a0) / s,
          static_cast<double>(b.counters().polls - b0) / s};
}

std::string Describe(const SessionCounters& c) {
  return absl::StrCat("requests ", c.requests, " replies ", c.replies, " timeouts ", c.timeouts,
                      " garbage ", c.garbage, " duplicates ", c.duplicate_replies,
                      " wrong_address ", c.wrong_address, " unsolicited ", c.unsolicited);
}

// The live controller's poll rate is judged against a control: the same controller alone on a
// second line, measured in the same windows, so the load of a shared machine hits both alike.
TEST(TrinamicSharedLineTest, DeadNeighbour_DownAndProbedAtBackoff_LiveKeepsItsPollRate) {
  MultiDrop line(2), control_line(1);
  ASSERT_NE(line.server, nullptr);
  ASSERT_NE(control_line.server, nullptr);
  line.server->SetUnitSilent(1, true);  // the PACK at address 2 is dead
  PollOnly live_axis, control_axis, dead_axis;
  std::shared_ptr<Pack> live = Polled(line.path, 1, "drive 'live'", live_axis);
  std::shared_ptr<Pack> control = Polled(control_line.path, 1, "drive 'control'", control_axis);
  ASSERT_TRUE(live && control);
  std::this_thread::sleep_for(300ms);
  const auto [alone, control_alone] = PollsPerSecond(*live, *control, 3s);

  std::shared_ptr<Pack> dead = Polled(line.path, 2, "drive 'dead'", dead_axis);
  ASSERT_NE(dead, nullptr);
  // Its probes at 0, 0.2, 0.5, 1.0, 1.9, 3.6, 6.9 s (100 ms each, back-off doubling from 100 ms
  // after each failure): 3 of them (300 ms) fall into this 6 s window, ≈ 95 % of the line is left
  // for the live one (the steady state, 100 ms per 5 s, leaves 98 %).
  std::this_thread::sleep_for(1s);
  const auto [shared, control_shared] = PollsPerSecond(*live, *control, 6s);
  const double before = alone / control_alone;
  const double after = shared / control_shared;
  std::cout << "[ measured ] live controller polls/s: alone " << alone << " (control "
            << control_alone << "), with a dead neighbour " << shared << " (control "
            << control_shared << "): " << 100 * after / before << " % of alone\n";
  std::cout << "[ measured ] live: " << Describe(live->session_counters())
            << "; control: " << Describe(control->session_counters()) << "\n";
  EXPECT_GT(alone, 50);  // the line is the limit, not a stalled poll thread
  EXPECT_GE(after, 0.8 * before);
  const SessionCounters sc = live->session_counters();
  EXPECT_EQ(live->counters().poll_failures, 0u) << Describe(sc);
  EXPECT_EQ(sc.garbage, 0u) << Describe(sc);
  EXPECT_EQ(sc.timeouts, 0u) << Describe(sc);
  EXPECT_EQ(live->health().state, HealthState::kUp);
  dead->Unregister(0);
  live->Unregister(0);
  control->Unregister(0);
}

// In R9 framing with a response address per controller, the configuration decision 1471
// recommends: once the neighbour is back, a late reply of one is never taken for the other's.
TEST(TrinamicSharedLineTest, DeadNeighbour_IsDownAndProbedAtItsBackoffOnly) {
  MultiDrop line(2, ReplyFraming::kR9);
  ASSERT_NE(line.server, nullptr);
  line.server->SetUnitSilent(1, true);
  PollOnly live_axis, dead_axis;
  std::shared_ptr<Pack> live = Polled(line.path, 1, "drive 'live'", live_axis);
  std::shared_ptr<Pack> dead = Polled(line.path, 2, "drive 'dead'", dead_axis);
  ASSERT_TRUE(live && dead);
  std::this_thread::sleep_for(2500ms);
  EXPECT_EQ(dead->health().state, HealthState::kDown);
  EXPECT_EQ(live->health().state, HealthState::kUp);
  // Polled every 1 ms (≈ 2500 polls), yet probed only at its back-off: 0, 0.2, 0.5, 1.0, 1.9 s,
  // i.e. at most 5 (6 with slack); fewer on a loaded machine (3 seen beside a -j1 build), but it
  // is still being probed.
  const SessionCounters dc = dead->session_counters();
  EXPECT_GE(dc.probes, 2u);
  EXPECT_LE(dc.probes, 6u);
  // Nothing but probes went out for it (a probe in flight is counted before its word).
  EXPECT_LE(dc.requests, dc.probes);
  EXPECT_GE(dc.requests + 1, dc.probes);

  // It comes back: UP again after its next probe (up to 1.6 s away) and the hold before UP
  // (health.up_after_ms, 3 s by default, decision 1432); the live one never noticed.
  line.server->SetUnitSilent(1, false);
  const auto until = SessionClock::now() + 10s;
  while (dead->health().state != HealthState::kUp && SessionClock::now() < until) {
    std::this_thread::sleep_for(20ms);
  }
  EXPECT_EQ(dead->health().state, HealthState::kUp);
  EXPECT_EQ(live->counters().poll_failures, 0u) << Describe(live->session_counters());
  live->Unregister(0);
  dead->Unregister(0);
}

}  // namespace
}  // namespace drivegw::trinamic
