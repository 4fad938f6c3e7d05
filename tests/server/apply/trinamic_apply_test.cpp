// ParameterApplier against the real Trinamic axis drive (factory) and the simulated SIXpack on a
// pty (sim/trinamic), real time: a set applied lands in the PACK's registers; a stopped-only
// parameter (`$13`, L539, CT-56) refused while the motor turns makes the applier restore the
// `$14` values it had already written, checked through the simulator's registers.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/trinamic/factory.h"
#include "server/core/parameter_apply.h"
#include "sim/trinamic/server.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "storage/parameter_set_repo.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::server {
namespace {

using namespace std::chrono_literals;
using sim::trinamic::Controller;
using sim::trinamic::ServerOptions;
using sim::trinamic::TrinamicServer;
using storage::ParameterSet;
using ::testing::HasSubstr;

std::string TempLink() {
  static std::atomic<int> n{0};
  return (std::filesystem::temp_directory_path() /
          ("dgw-apply-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
      .string();
}

// 1 mm = 1 microstep; limits fit the PACK defaults (as tests/adapters/trinamic/drive).
DriveConfig Config(const std::string& pty) {
  DriveConfig c;
  c.name = "feeder-x";
  c.family = trinamic::kFamilyName;
  c.axis.min_mm = -20000;
  c.axis.max_mm = 20000;
  c.axis.max_velocity_mm_s = 26000;
  c.axis.max_acceleration_mm_s2 = 120000;
  c.timeouts.request = 2000ms;
  c.timeouts.accept = 100ms;
  c.timeouts.homing = 8000ms;
  TrinamicConfig t;
  t.address = 1;
  t.axis = 0;
  t.axes = 6;
  t.microsteps_per_unit = 1;
  t.poll_period = 5ms;
  t.reply_timeout = 60ms;
  t.offline_after_misses = 2;
  t.serial = SerialLineConfig{pty, 19200, false, 6000us};
  c.trinamic = t;
  return c;
}

DriveStatus WaitStatus(Drive& d, const std::function<bool(const DriveStatus&)>& pred) {
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  DriveStatus s = d.GetStatus();
  while (!pred(s) && std::chrono::steady_clock::now() < deadline) {
    s = d.WaitForStatus(s.sequence, deadline);
  }
  return s;
}

class TrinamicApplyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ServerOptions options;
    options.pty_path = TempLink();
    auto s = TrinamicServer::Start(options, SteadyClock::Instance());
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = *std::move(s);
    auto d = trinamic::CreateTrinamicDrive(Config(server_->slave_path()), SteadyClock::Instance());
    ASSERT_TRUE(d.ok()) << d.status();
    drive_ = *std::move(d);
    ASSERT_TRUE(drive_->Activate().ok());
    ASSERT_NE(
        WaitStatus(*drive_, [](const DriveStatus& s) { return s.state != DriveState::kOffline; })
            .state,
        DriveState::kOffline);

    auto db = storage::Db::Open(dir_.File("gw.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(*std::move(db));
    ASSERT_TRUE(storage::Migrate(*db_).ok());
    repo_ = std::make_unique<storage::ParameterSetRepo>(*db_);
    catalogues_.push_back(trinamic::TrinamicParameterCatalogue());
    applier_ = std::make_unique<ParameterApplier>(*repo_, catalogues_);
  }
  void TearDown() override {
    applier_.reset();
    if (drive_) drive_->Deactivate();
    if (server_) server_->Stop();
  }

  // `$14.vmax` 450, `$14.amax` 200 (anytime, L552), then `$13.vstart` 7 (stopped only, L539).
  ApplyRequest Request() {
    ParameterSet set;
    set.name = "feeder-tuning";
    set.family = "trinamic";
    set.version = 1;
    set.values = {{"$14.vmax", 0x1403, 450}, {"$14.amax", 0x1401, 200}, {"$13.vstart", 0, 7}};
    ApplyRequest r;
    r.set = set;
    r.drives = {drive_.get()};
    r.principal = "test";
    return r;
  }
  // The PACK's registers once `done` holds for them, or as they are after 3 s: the words go out
  // without a reply (L325), so the simulator may still be reading them when the apply returns.
  sim::trinamic::MotorRegisters Registers(
      const std::function<bool(const sim::trinamic::MotorRegisters&)>& done) {
    sim::trinamic::MotorRegisters regs;
    const auto deadline = std::chrono::steady_clock::now() + 3s;
    for (;;) {
      server_->WithController([&](Controller& c) { regs = c.registers(0); });
      if (done(regs) || std::chrono::steady_clock::now() > deadline) return regs;
      std::this_thread::sleep_for(1ms);  // pacing of the poll, not a timing assertion
    }
  }

  storage::testing::TempDir dir_;
  std::unique_ptr<TrinamicServer> server_;
  std::unique_ptr<Drive> drive_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::ParameterSetRepo> repo_;
  CatalogueList catalogues_;
  std::unique_ptr<ParameterApplier> applier_;
};

TEST_F(TrinamicApplyTest, SetLandsInThePackRegisters) {
  ApplyRequest request = Request();
  // Ids as the catalogue resolves them (the set may carry 0 = "resolve by name").
  auto op = applier_->Run(request);
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "SUCCEEDED");
  ASSERT_EQ(op->drives.size(), 1u);
  EXPECT_EQ(op->drives[0].state, "APPLIED");
  ASSERT_EQ(op->drives[0].pre_image.size(), 3u);
  EXPECT_EQ(op->drives[0].pre_image[0].value, 511);  // §5.12 defaults
  EXPECT_EQ(op->drives[0].pre_image[1].value, 128);
  EXPECT_EQ(op->drives[0].pre_image[2].value, 5);
  const auto regs = Registers([](const auto& r) { return r.vstart == 7; });
  EXPECT_EQ(regs.vmax, 450);
  EXPECT_EQ(regs.amax, 200);
  EXPECT_EQ(regs.vstart, 7);
}

TEST_F(TrinamicApplyTest, StoppedOnlyParameterRefusedWhileMovingRollsBackTheEarlierWrites) {
  auto enable = drive_->Enable();
  ASSERT_TRUE(enable.ok()) << enable.status();
  auto move = drive_->Move(MoveVelocity{2000, 20000, 0});
  ASSERT_TRUE(move.ok()) << move.status();
  ASSERT_EQ(WaitStatus(*drive_, [](const DriveStatus& s) { return s.state == DriveState::kMoving; })
                .state,
            DriveState::kMoving);

  server_->ClearWords();
  // `$14` is the move's own profile (the drive rewrites it per move), so this set touches
  // `$19.propdiv` and `$18.testnullrange` (anytime, L636, L634) and then `$13.vstart`.
  ApplyRequest request = Request();
  request.set.values = {
      {"$19.propdiv", 0, 12}, {"$18.testnullrange", 0, 200}, {"$13.vstart", 0, 7}};
  auto op = applier_->Run(request);
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->state, "FAILED");
  const auto& r = op->drives[0];
  EXPECT_EQ(r.state, "ROLLED_BACK") << r.error;
  EXPECT_EQ(r.failed_parameter, "$13.vstart");
  EXPECT_THAT(r.error, HasSubstr("stands still"));
  // Both went out and were restored to the pre-image in the PACK, newest first; `$13` never.
  int pi_words = 0;
  int null_words = 0;
  int start_words = 0;
  const auto restored = [&] {
    pi_words = null_words = start_words = 0;
    for (const auto& w : server_->words()) {
      if (w.size() != 9) continue;
      pi_words += w[1] == 0x19;
      null_words += w[1] == 0x18;
      start_words += w[1] == 0x13;
    }
    return pi_words == 2 && null_words == 2;
  };
  const auto regs = Registers([&](const auto&) { return restored(); });
  EXPECT_EQ(pi_words, 2);
  EXPECT_EQ(null_words, 2);
  EXPECT_EQ(start_words, 0);
  EXPECT_EQ(regs.propdiv, 8);  // §5.12 defaults
  EXPECT_EQ(regs.testnullrange, 240);
  EXPECT_EQ(regs.vstart, 5);

  auto stored = repo_->GetOperation(op->id);
  ASSERT_TRUE(stored.ok()) << stored.status();
  EXPECT_EQ(stored->drives[0].state, "ROLLED_BACK");
  EXPECT_EQ(stored->drives[0].failed_parameter, "$13.vstart");
  ASSERT_TRUE(drive_->Move(StopMotion{100000}).ok());
}

}  // namespace
}  // namespace drivegw::server
