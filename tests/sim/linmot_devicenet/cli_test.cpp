// `drivegw-sim linmot-devicenet` flags: options from the command line, errors naming the flag.
#include "sim/linmot_devicenet/cli.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace drivegw::sim::linmot_devicenet {
namespace {

using ::testing::HasSubstr;

TEST(CliTest, ParseCliFlags_CanMacCount_Options) {
  auto f = ParseCliFlags({"--can", "udp:239.74.163.2:43113", "--mac", "5", "--count", "3",
                          "--motors=2", "--masters", "A", "--poll-modules", "ci,di,so,do1,do2"});
  ASSERT_TRUE(f.ok()) << f.status();
  EXPECT_EQ(f->sim.can.kind, CanBusConfig::Kind::kUdpMulticast);
  EXPECT_EQ(f->sim.can.port, 43113);
  EXPECT_EQ(f->count, 3);
  EXPECT_EQ(f->sim.motor_count, 2u);
  EXPECT_TRUE(f->sim.motors[0].master);
  EXPECT_FALSE(f->sim.motors[1].master);
  EXPECT_TRUE(f->sim.poll_modules.direct_out_2);
  EXPECT_FALSE(f->sim.poll_modules.addressed_in);
  const DnSimOptions third = DriveOptions(*f, 2);
  EXPECT_EQ(ResolvedMacId(third), 7);
  EXPECT_EQ(third.name, "linmot-dn-3");
}

TEST(CliTest, ParseCliFlags_SocketCanAndSwitches) {
  auto f = ParseCliFlags({"--can", "socketcan:vcan0", "--mac-switches", "2A", "--trace", "/tmp/x"});
  ASSERT_TRUE(f.ok()) << f.status();
  EXPECT_EQ(f->sim.can.kind, CanBusConfig::Kind::kSocketCan);
  EXPECT_EQ(f->sim.can.interface, "vcan0");
  EXPECT_EQ(f->sim.can.trace_file, "/tmp/x");
  EXPECT_EQ(ResolvedMacId(f->sim), 42);
}

TEST(CliTest, ParseCliFlags_Errors_NameTheFlag) {
  struct Case {
    std::vector<std::string> args;
    const char* message;
  };
  const Case cases[] = {
      {{"--mac", "64"}, "--mac: '64' is not an integer in [0, 63]"},
      {{"--mac"}, "--mac: missing value"},
      {{"--count", "4", "--mac", "62"}, "--count: 4 drives from MAC 62 exceed 63"},
      {{"--can", "tcp:1"}, "--can 'tcp:1'"},
      {{"--mac-switches", "4G"}, "--mac-switches: '4G' is not two hex digits"},
      {{"--mac-switches", "40"}, "--mac-switches: 0x40 exceeds 0x3F"},
      {{"--baud", "1000"}, "--baud: '1000' is not 125, 250 or 500"},
      {{"--io", "strobe"}, "--io: 'strobe' is not poll, cos or poll+cos"},
      {{"--poll-modules", "ci,xx"}, "--poll-modules: 'xx' is not one of"},
      {{"--masters", "C"}, "--masters: 'C' is not a motor of A..A"},
      {{"--stroke-max", "-50"}, "--stroke-max: -50 is not above stroke_min_mm -10"},
      {{"--tick-ms", "20"}, "--tick-ms: 20 is outside [0.25, 10]"},
      {{"--dn-enable", "maybe"}, "--dn-enable: 'maybe' is not on or off"},
      {{"--frob", "1"}, "unknown flag '--frob'"},
      {{"extra"}, "unexpected argument 'extra'"},
  };
  for (const Case& c : cases) {
    auto f = ParseCliFlags(c.args);
    ASSERT_FALSE(f.ok()) << c.args[0];
    EXPECT_EQ(f.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(f.status().message(), HasSubstr(c.message));
  }
}

TEST(CliTest, ParseCliFlags_Help) {
  auto f = ParseCliFlags({"--help"});
  ASSERT_TRUE(f.ok());
  EXPECT_TRUE(f->help);
  EXPECT_THAT(std::string(kCliUsage), HasSubstr("--can SPEC"));
}

}  // namespace
}  // namespace drivegw::sim::linmot_devicenet
