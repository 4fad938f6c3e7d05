// DriveServiceCore::OpenWatch (issue 10, P5; decision 1341): the request checks WatchDrives always
// made, and a source that yields a drive's snapshot only when its content changed.
#include <gtest/gtest.h>

#include <chrono>
#include <limits>
#include <memory>
#include <vector>

#include "server/core/drive_service.h"
#include "tests/server/core/fake_drive.h"

namespace drivegw::server {
namespace {

using test_support::FakeDrive;

struct Core {
  Core() {
    x1 = std::make_shared<FakeDrive>(FakeDrive::Config("x1", "linmot"), false);
    x2 = std::make_shared<FakeDrive>(FakeDrive::Config("x2", "linmot"), false);
    core = std::make_unique<DriveServiceCore>(std::vector<std::shared_ptr<Drive>>{x1, x2}, nullptr);
  }
  std::shared_ptr<FakeDrive> x1, x2;
  std::unique_ptr<DriveServiceCore> core;
};

std::vector<std::string> Names(WatchSource& source) {
  std::vector<SharedDriveStatus> out;
  source.Next(out);
  std::vector<std::string> names;
  for (const auto& s : out) names.push_back(s->name());
  return names;
}

TEST(OpenWatchTest, OpenWatch_BadRate_IsRefused) {
  Core c;
  v1::WatchDrivesRequest r;
  r.set_max_rate_hz(-1);
  EXPECT_EQ(c.core->OpenWatch(r, {}).status().code(), absl::StatusCode::kInvalidArgument);
  r.set_max_rate_hz(1001);
  EXPECT_EQ(c.core->OpenWatch(r, {}).status().code(), absl::StatusCode::kOutOfRange);
}

// Gap 12 (docs/reliability.md): NaN and infinities are refused naming the field and the limit;
// the limit itself and 0 (the default rate) are accepted.
TEST(OpenWatchTest, OpenWatch_RateNanInfAndLimit_NamedOrAccepted) {
  Core c;
  v1::WatchDrivesRequest r;
  r.set_max_rate_hz(std::numeric_limits<double>::quiet_NaN());
  auto nan = c.core->OpenWatch(r, {});
  EXPECT_EQ(nan.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(nan.status().message().find("max_rate_hz"), std::string::npos) << nan.status();
  r.set_max_rate_hz(-std::numeric_limits<double>::infinity());
  auto neg = c.core->OpenWatch(r, {});
  EXPECT_EQ(neg.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(neg.status().message().find("must not be negative"), std::string::npos) << neg.status();
  r.set_max_rate_hz(std::numeric_limits<double>::infinity());
  auto inf = c.core->OpenWatch(r, {});
  EXPECT_EQ(inf.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_NE(inf.status().message().find("max_rate_hz: inf exceeds 1000"), std::string::npos)
      << inf.status();
  r.set_max_rate_hz(1000);
  EXPECT_TRUE(c.core->OpenWatch(r, {}).ok());
  r.set_max_rate_hz(0);
  EXPECT_TRUE(c.core->OpenWatch(r, {}).ok());
}

TEST(OpenWatchTest, OpenWatch_UnknownDrive_IsNotFound) {
  Core c;
  v1::WatchDrivesRequest r;
  r.add_names("drives/x9");
  auto w = c.core->OpenWatch(r, {});
  EXPECT_EQ(w.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(w.status().message().find("names[0]"), std::string::npos) << w.status();
}

TEST(OpenWatchTest, OpenWatch_Rate_SetsThePeriod) {
  Core c;
  v1::WatchDrivesRequest r;
  r.set_max_rate_hz(100);
  auto w = c.core->OpenWatch(r, {});
  ASSERT_TRUE(w.ok()) << w.status();
  EXPECT_EQ(w->period, std::chrono::milliseconds(10));
  r.set_max_rate_hz(0);  // default 20 Hz
  EXPECT_EQ(c.core->OpenWatch(r, {})->period, std::chrono::milliseconds(50));
}

TEST(OpenWatchTest, Next_ChangedSnapshotsOnly) {
  Core c;
  v1::WatchDrivesRequest r;  // no names: every drive
  auto w = c.core->OpenWatch(r, {});
  ASSERT_TRUE(w.ok()) << w.status();
  EXPECT_EQ(Names(*w->source), (std::vector<std::string>{"drives/x1", "drives/x2"}))
      << "the first snapshot of every drive";
  EXPECT_TRUE(Names(*w->source).empty()) << "nothing published";
  c.x2->SetState(DriveState::kEnabled);
  EXPECT_EQ(Names(*w->source), (std::vector<std::string>{"drives/x2"}));
  c.x2->SetState(DriveState::kEnabled);  // a new snapshot with the same content
  EXPECT_TRUE(Names(*w->source).empty());
}

TEST(OpenWatchTest, Shutdown_EndsOpenSourcesAndRefusesNewOnes) {
  Core c;
  v1::WatchDrivesRequest r;
  auto w = c.core->OpenWatch(r, {});
  ASSERT_TRUE(w.ok());
  EXPECT_FALSE(w->source->Ended());
  c.core->Shutdown();
  EXPECT_TRUE(w->source->Ended());
  EXPECT_EQ(c.core->OpenWatch(r, {}).status().code(), absl::StatusCode::kUnavailable);
}

}  // namespace
}  // namespace drivegw::server
