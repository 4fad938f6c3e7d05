// DriveServiceCore::GetCommand name checks (docs/reliability.md gap 12): a name that is not
// "drives/{drive}/commands/{id}" with a decimal id that fits uint64 is InvalidArgument naming the
// field and the expected shape; an unknown drive or command is NotFound.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "server/core/drive_service.h"
#include "tests/server/core/fake_drive.h"

namespace drivegw::server {
namespace {

using test_support::FakeDrive;
using ::testing::HasSubstr;

struct Core {
  Core() {
    x1 = std::make_shared<FakeDrive>(FakeDrive::Config("x1", "linmot"), false);
    core = std::make_unique<DriveServiceCore>(std::vector<std::shared_ptr<Drive>>{x1}, nullptr);
  }
  absl::Status Get(const std::string& name) {
    v1::GetCommandRequest r;
    r.set_name(name);
    return core->GetCommand(r, {}).status();
  }
  std::shared_ptr<FakeDrive> x1;
  std::unique_ptr<DriveServiceCore> core;
};

TEST(GetCommandTest, MalformedNames_InvalidArgumentNamingFieldAndShape) {
  Core c;
  for (const std::string name :
       {"", "drives/x1", "drives/x1/commands", "drives/x1/commands/", "drives/x1/commands/abc",
        "drives/x1/commands/-1", "drives/x1/commands/1.5", "drives/x1/commands/1/extra",
        "drives/x1/command/1", "motors/x1/commands/1", "drives/x1/commands/18446744073709551616"}) {
    const absl::Status s = c.Get(name);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << name << ": " << s;
    EXPECT_THAT(std::string(s.message()),
                HasSubstr("name: '" + name + "' is not \"drives/{drive}/commands/{id}\""))
        << s;
  }
}

TEST(GetCommandTest, UnknownDriveOrCommand_NotFoundNamingIt) {
  Core c;
  const absl::Status drive = c.Get("drives/x9/commands/1");
  EXPECT_EQ(drive.code(), absl::StatusCode::kNotFound) << drive;
  EXPECT_THAT(std::string(drive.message()), HasSubstr("x9"));
  // The largest id is well formed; the fake drive keeps no commands.
  const absl::Status command = c.Get("drives/x1/commands/18446744073709551615");
  EXPECT_EQ(command.code(), absl::StatusCode::kNotFound) << command;
  EXPECT_THAT(
      std::string(command.message()),
      HasSubstr("name: drives/x1/commands/18446744073709551615 is unknown or no longer kept"));
}

}  // namespace
}  // namespace drivegw::server
