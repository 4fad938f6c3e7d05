// The family-neutral DriveConfig checks the LinMot factories share (adapters/core/
// drive_config_check.h): each time-out in the order request, accept, homing, then the axis range,
// with the texts the factories answered before the check moved to core.
#include "adapters/core/drive_config_check.h"

#include <gtest/gtest.h>

namespace drivegw {
namespace {

using std::chrono::milliseconds;

TEST(DriveConfigCheckTest, DefaultsPass) {
  EXPECT_TRUE(CheckTimeoutsAndAxis({}, "drive 'x'").ok());
}

TEST(DriveConfigCheckTest, TimeoutNotPositive_NamedInOrder) {
  DriveConfig c;
  c.timeouts.accept = milliseconds(0);
  c.timeouts.homing = milliseconds(-5);
  absl::Status s = CheckTimeoutsAndAxis(c, "drive 'x'");
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(), "drive 'x'.timeouts.accept: 0 ms must be positive");
  c.timeouts.accept = milliseconds(100);
  EXPECT_EQ(CheckTimeoutsAndAxis(c, "drive 'x'").message(),
            "drive 'x'.timeouts.homing: -5 ms must be positive");
  c.timeouts.request = milliseconds(0);
  EXPECT_EQ(CheckTimeoutsAndAxis(c, "drive 'y'").message(),
            "drive 'y'.timeouts.request: 0 ms must be positive");
}

TEST(DriveConfigCheckTest, EmptyAxisRange_Refused) {
  DriveConfig c;
  c.axis.min_mm = 50;
  c.axis.max_mm = 50;
  const absl::Status s = CheckTimeoutsAndAxis(c, "drive 'x'");
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(), "drive 'x'.axis.min_mm: 50 must be below axis.max_mm 50");
  c.timeouts.request = milliseconds(0);  // time-outs are named first
  EXPECT_EQ(CheckTimeoutsAndAxis(c, "drive 'x'").message(),
            "drive 'x'.timeouts.request: 0 ms must be positive");
}

}  // namespace
}  // namespace drivegw
