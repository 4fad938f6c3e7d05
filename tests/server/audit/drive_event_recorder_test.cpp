// DriveEventRecorder: drive-side events into the audit trail (issue 7) — the snapshot comparison
// on its own, and the recorder against the simulated LinMot drive over loopback UDP: online,
// homing done, a fault with the drive's own code and text, OFFLINE on link loss.
#include "server/core/drive_event_recorder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>

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
