// DriveEventRecorder: drive-side events into the audit trail (issue 7) — the snapshot comparison
// on its own, and the recorder against the simulated LinMot drive over loopback UDP: online,
// homing done, a fault with the drive's own code and text, OFFLINE on link loss.
#include "server/core/drive_event_recorder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <thread>

#include "adapters/core/clock.h"
#include "adapters/linmot/linudp/factory.h"
#include "adapters/linmot/mc/error_codes.h"
#include "nlohmann/json.hpp"
#include "sim/linmot/server.h"
#include "tests/storage/audit_fixture.h"
#include "tests/support/linudp_bench.h"
#include "tests/support/wait_status.h"

namespace drivegw::server {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

constexpr auto kWait = 30s;  // generous: ctest -j3 on two cores

TEST(DriveEventsBetweenTest, EachKindOfChange) {
  DriveStatus off;  // OFFLINE
  DriveStatus ready;
  ready.state = DriveState::kReady;
  auto ev = DriveEventsBetween(off, ready);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].action, "drive.online");
  EXPECT_EQ(ev[0].before_json, R"({"state":"OFFLINE"})");
  EXPECT_EQ(ev[0].after_json, R"({"state":"READY"})");
  EXPECT_TRUE(DriveEventsBetween(ready, ready).empty());

  DriveStatus fault = ready;
  fault.state = DriveState::kFault;
  fault.fault = {0x0B, "Max Pos Error Exceeded", false};
  ev = DriveEventsBetween(ready, fault);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].action, "drive.fault");
  EXPECT_EQ(ev[0].message, "Max Pos Error Exceeded");
  const auto j = nlohmann::json::parse(ev[0].request_json);
  EXPECT_EQ(j["code"], 11);
  EXPECT_EQ(j["code_hex"], "0xb");
  EXPECT_EQ(DriveEventsBetween(fault, ready).at(0).action, "drive.fault_cleared");

  DriveStatus warned = ready;
  warned.warnings = {"Motor Hot"};
  ev = DriveEventsBetween(ready, warned);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].action, "drive.warning");
  EXPECT_EQ(nlohmann::json::parse(ev[0].request_json)["added"][0], "Motor Hot");
  EXPECT_EQ(DriveEventsBetween(warned, ready).at(0).action, "drive.warning_cleared");

  DriveStatus homed = ready;
  homed.homed = true;
  EXPECT_EQ(DriveEventsBetween(ready, homed).at(0).action, "drive.homed");

  // Losing the link while faulted: OFFLINE, and the fault as the drive last reported it stays.
  DriveStatus lost = fault;
  lost.state = DriveState::kOffline;
  ev = DriveEventsBetween(fault, lost);
  ASSERT_GE(ev.size(), 1u);
  EXPECT_EQ(ev[0].action, "drive.offline");
}

// Decision 1431: every change of the health state is an event, with state, since and reason.
TEST(DriveEventsBetweenTest, HealthChanges) {
  DriveStatus none;  // no health yet: counts as DEMOTED ("no reply yet")
  DriveStatus up;
  up.health = HealthInfo{HealthState::kUp, std::chrono::system_clock::time_point{}, 0, ""};
  auto ev = DriveEventsBetween(none, up);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].action, "drive.health");
  EXPECT_EQ(ev[0].before_json, R"({"health":"DEMOTED"})");
  EXPECT_EQ(ev[0].after_json, R"({"health":"UP"})");
  EXPECT_EQ(ev[0].message, "health UP");

  DriveStatus demoted = up;
  demoted.health->state = HealthState::kDemoted;
  demoted.health->consecutive_failures = 1;
  demoted.health->reason = "1 consecutive time-outs";
  ev = DriveEventsBetween(up, demoted);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].message, "health DEMOTED: 1 consecutive time-outs");

  DriveStatus demoted2 = demoted;  // the count moves, the state does not: no event
  demoted2.health->consecutive_failures = 2;
  EXPECT_TRUE(DriveEventsBetween(demoted, demoted2).empty());

  DriveStatus down = demoted2;
  down.health->state = HealthState::kDown;
  down.health->since = std::chrono::sys_days{std::chrono::year{2026} / 12 / 7};
  down.health->reason = "3 consecutive time-outs";
  ev = DriveEventsBetween(demoted2, down);
  ASSERT_EQ(ev.size(), 1u);
  const auto j = nlohmann::json::parse(ev[0].request_json);
  EXPECT_EQ(j["state"], "DOWN");
  EXPECT_EQ(j["since"], "2026-12-07T00:00:00Z");
  EXPECT_EQ(j["reason"], "3 consecutive time-outs");
  EXPECT_EQ(ev[0].after_json, R"({"health":"DOWN"})");
  EXPECT_TRUE(DriveEventsBetween(none, none).empty());
}

// The recorder only wakes for snapshots whose event fields changed (EventFieldsDiffer, issue
// 10): every pair of snapshots that DriveEventsBetween reports an event for must count as such a
// change, or the event would be lost. Exhaustive over the fields' variants.
TEST(EventFieldsDifferTest, EveryEventIsAnEventFieldChange) {
  std::vector<DriveStatus> all;
  const std::vector<std::optional<HealthInfo>> healths = {
      std::nullopt, HealthInfo{HealthState::kUp, {}, 0, ""},
      HealthInfo{HealthState::kDemoted, {}, 1, "1 time-out"},
      HealthInfo{HealthState::kDown, {}, 3, "3 consecutive time-outs"}};
  const std::vector<Fault> faults = {{},
                                     {0x0B, "Max Pos Error Exceeded", false},
                                     {0x0B, "other text", false},
                                     {0x0B, "Max Pos Error Exceeded", true},
                                     {0x21, "X1 Pwr Voltage Too Low", false}};
  const std::vector<std::vector<std::string>> warnings = {{}, {"Motor Hot"}, {"Motor Hot", "X"}};
  for (int st = 0; st <= static_cast<int>(DriveState::kFault); ++st) {
    for (const auto& h : healths) {
      for (const auto& f : faults) {
        for (const auto& w : warnings) {
          for (bool homed : {false, true}) {
            DriveStatus s;
            s.state = static_cast<DriveState>(st);
            s.health = h;
            s.fault = f;
            s.warnings = w;
            s.homed = homed;
            all.push_back(s);
          }
        }
      }
    }
  }
  int events = 0;
  for (const DriveStatus& a : all) {
    for (const DriveStatus& b : all) {
      if (DriveEventsBetween(a, b).empty()) continue;
      ++events;
      ASSERT_TRUE(EventFieldsDiffer(a, b)) << ToString(a.state) << " -> " << ToString(b.state)
                                           << ": " << DriveEventsBetween(a, b).front().action;
    }
  }
  EXPECT_GT(events, 10000);
  // What a moving axis publishes every cycle is no event field.
  DriveStatus moving = all.front();
  moving.state = DriveState::kMoving;
  DriveStatus next = moving;
  next.position_mm = 12.5;
  next.demand_position_mm = 13;
  next.velocity_mm_s = 100;
  next.native.status_word ^= 0x1000;
  next.in_target = !moving.in_target;
  next.last_command = CommandInfo{};
  next.sequence = moving.sequence + 1;
  EXPECT_FALSE(EventFieldsDiffer(moving, next));
  next.state = DriveState::kEnabled;
  EXPECT_TRUE(EventFieldsDiffer(moving, next));
}

TEST(EventBudgetTest, CapsEachWindowAndReportsTheSuppressedCountWhenItEnds) {
  const auto t0 = std::chrono::steady_clock::time_point{} + 1h;
  EventBudget budget(3, 60s, t0);
  EXPECT_EQ(budget.Roll(t0), 0);
  int taken = 0;
  for (int i = 0; i < 10; ++i) taken += budget.Take() ? 1 : 0;
  EXPECT_EQ(taken, 3);
  EXPECT_EQ(budget.Roll(t0 + 59s), 0);  // same window
  EXPECT_FALSE(budget.Take());
  EXPECT_EQ(budget.Roll(t0 + 60s), 8);  // 7 + 1 suppressed, reported once
  EXPECT_TRUE(budget.Take());
  EXPECT_EQ(budget.Roll(t0 + 200s), 0);
}

class DriveEventRecorderTest : public storage::testing::AuditDbTest {
 protected:
  void SetUp() override {
    AuditDbTest::SetUp();
    sim::linmot::SimOptions o = test_support::LinUdpSimOptions();
    auto server = sim::linmot::LinMotServer::Start(o, SteadyClock::Instance());
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    DriveConfig c = test_support::LinUdpDriveConfig(server_->port());
    auto drive = linmot::linudp::CreateLinMotUdpDrive(c, SteadyClock::Instance());
    ASSERT_TRUE(drive.ok()) << drive.status();
    drive_ = std::shared_ptr<Drive>(std::move(*drive));
    ASSERT_TRUE(drive_->Activate().ok());
    recorder_ = std::make_unique<DriveEventRecorder>(std::vector{drive_}, log_.get());
  }
  void TearDown() override {
    if (recorder_) recorder_->Stop();
    if (drive_) drive_->Deactivate();
  }

  // The newest entry with `action` once it exists (waits on the log's append signal).
  std::optional<storage::AuditRecord> WaitForAction(const std::string& action) {
    const auto deadline = std::chrono::steady_clock::now() + kWait;
    while (true) {
      const int64_t last = log_->LastId().value_or(0);
      storage::AuditQuery q;
      q.action = action;
      auto rows = log_->Query(q);
      if (rows.ok() && !rows->empty()) return rows->front();
      if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
      log_->WaitForAppend(last, std::min(deadline, std::chrono::steady_clock::now() + 200ms));
    }
  }

  // An entry with `action` and `after_json` once it exists.
  std::optional<storage::AuditRecord> WaitForRecord(const std::string& action,
                                                    const std::string& after_json) {
    const auto deadline = std::chrono::steady_clock::now() + kWait;
    while (true) {
      const int64_t last = log_->LastId().value_or(0);
      storage::AuditQuery q;
      q.action = action;
      auto rows = log_->Query(q);
      if (rows.ok()) {
        for (const auto& r : *rows) {
          if (r.after_json == after_json) return r;
        }
      }
      if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
      log_->WaitForAppend(last, std::min(deadline, std::chrono::steady_clock::now() + 200ms));
    }
  }

  std::unique_ptr<sim::linmot::LinMotServer> server_;
  std::shared_ptr<Drive> drive_;
  std::unique_ptr<DriveEventRecorder> recorder_;
};

// A moving axis publishes its position every cycle; a waiter for event changes (the recorder's
// wait) wakes for the state changes of the move, not for each of those snapshots (issue 10).
TEST_F(DriveEventRecorderTest, EventWaiterSleepsThroughAMovesPositionSnapshots) {
  ASSERT_TRUE(WaitForAction("drive.online").has_value());
  auto en = drive_->Enable();
  ASSERT_TRUE(en.ok()) << en.status();
  auto home = drive_->Home();
  ASSERT_TRUE(home.ok()) << home.status();
  ASSERT_EQ(test_support::WaitCommandFinal(*drive_, home->id, kWait).state, CommandState::kDone);

  std::atomic<bool> done{false};
  std::atomic<int> event_wakes{0};
  std::atomic<int> status_wakes{0};
  auto count = [&](bool events, std::atomic<int>& wakes) {
    DriveStatus last = drive_->GetStatus();
    while (!done.load()) {
      const auto deadline = std::chrono::steady_clock::now() + 20ms;
      DriveStatus s = events ? drive_->WaitForEventStatus(last.sequence, deadline)
                             : drive_->WaitForStatus(last.sequence, deadline);
      // Woken (not the slice's end, after which the newest snapshot comes back anyway).
      if (s.sequence != last.sequence && std::chrono::steady_clock::now() < deadline) ++wakes;
      last = std::move(s);
    }
  };
  std::thread event_waiter(count, true, std::ref(event_wakes));
  std::thread status_waiter(count, false, std::ref(status_wakes));
  // 0 -> 100 mm at 200 mm/s: ≈ 0.5 s of motion, a new position every 2 ms cycle.
  auto move = drive_->Move(MoveAbsolute{100, 200, 2000, 2000});
  ASSERT_TRUE(move.ok()) << move.status();
  EXPECT_EQ(test_support::WaitCommandFinal(*drive_, move->id, kWait).state, CommandState::kDone);
  done = true;
  event_waiter.join();
  status_waiter.join();
  EXPECT_GT(status_wakes.load(), 20);  // positions published while moving
  EXPECT_GE(event_wakes.load(), 1);    // at least MOVING and back
  EXPECT_LE(event_wakes.load(), 6) << "status wakes: " << status_wakes.load();
}

TEST_F(DriveEventRecorderTest, OnlineHomedFaultOffline_RecordedAsTheDrive) {
  auto online = WaitForAction("drive.online");
  ASSERT_TRUE(online.has_value());
  EXPECT_EQ(online->principal, "drive:x1");
  EXPECT_EQ(online->drive, "x1");
  EXPECT_THAT(online->source_address, HasSubstr("127.0.0.1"));
  EXPECT_EQ(online->before_json, R"({"state":"OFFLINE"})");

  auto en = drive_->Enable();
  ASSERT_TRUE(en.ok()) << en.status();
  auto home = drive_->Home();
  ASSERT_TRUE(home.ok()) << home.status();
  EXPECT_EQ(test_support::WaitCommandFinal(*drive_, home->id, kWait).state, CommandState::kDone);
  auto homed = WaitForAction("drive.homed");
  ASSERT_TRUE(homed.has_value());
  EXPECT_EQ(homed->after_json, R"({"homed":true})");

  ASSERT_TRUE(server_->RaiseError(linmot::mc::kPwrVoltageTooLow).ok());
  auto fault = WaitForAction("drive.fault");
  ASSERT_TRUE(fault.has_value());
  EXPECT_EQ(fault->principal, "drive:x1");
  EXPECT_THAT(fault->result_message, HasSubstr("X1 Pwr Voltage Too Low"));
  const auto j = nlohmann::json::parse(fault->request_json);
  EXPECT_EQ(j["code"], linmot::mc::kPwrVoltageTooLow);
  EXPECT_THAT(j["text"].get<std::string>(), HasSubstr("X1 Pwr Voltage Too Low"));
  EXPECT_EQ(fault->after_json, R"({"state":"FAULT"})");

  server_->SetAnswering(false);
  auto offline = WaitForAction("drive.offline");
  ASSERT_TRUE(offline.has_value());
  EXPECT_EQ(offline->after_json, R"({"state":"OFFLINE"})");
  // Decision 1431: the link's health went DEMOTED and then DOWN, each an event of the drive.
  auto down = WaitForRecord("drive.health", R"({"health":"DOWN"})");
  ASSERT_TRUE(down.has_value());
  EXPECT_EQ(down->principal, "drive:x1");
  EXPECT_THAT(down->result_message, HasSubstr("3 consecutive time-outs"));
  EXPECT_TRUE(WaitForRecord("drive.health", R"({"health":"DEMOTED"})").has_value());
  EXPECT_TRUE(WaitForRecord("drive.health", R"({"health":"UP"})").has_value());

  recorder_->Stop();
  const storage::AuditVerifyReport v = VerifyOrDie();
  EXPECT_TRUE(v.ok);
}

}  // namespace
}  // namespace drivegw::server
