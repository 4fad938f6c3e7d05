// ParseConfig/LoadConfigFile: defaults, demo mode, and the message of every validation error.
#include "server/config/config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"

namespace drivegw::config {
namespace {

using std::chrono::milliseconds;
using ::testing::HasSubstr;
using ::testing::Not;

// One valid drive; tests splice a broken line into a copy.
constexpr char kOneDrive[] = R"(
drives:
  - name: x1
    family: linmot
    linudp:
      host: 192.168.1.20
    axis:
      min_mm: 0
      max_mm: 150
      max_velocity_mm_s: 2000
      max_acceleration_mm_s2: 20000
)";

constexpr char kFull[] = R"(# Two LinMot drives on the machine network.
auth: {enabled: true}
listen:
  grpc: 0.0.0.0:50052
  http: "127.0.0.1:8081"
data_dir: /var/lib/drivegw
drives:
  - name: x1
    family: linmot
    linudp:
      host: 192.168.1.20
      port: 49360
      master_port: 41136
      bind_host: 192.168.1.2
      cycle_ms: 4
      reply_timeout_ms: 40
      lost_after_timeouts: 3
    axis:
      kind: linear
      min_mm: -5
      max_mm: 145.5
      max_velocity_mm_s: 1500
      max_acceleration_mm_s2: 15000
    timeouts:
      request_ms: 1500
      accept_ms: 80
      homing_ms: 20000
  - name: r_2
    family: linmot
    linudp: {host: drive-2.local, port: 49361}
    axis: {kind: rotary, min_mm: 0, max_mm: 360, max_velocity_mm_s: 720, max_acceleration_mm_s2: 7200}
)";

absl::Status ErrorOf(std::string_view yaml) {
  auto cfg = ParseConfig(yaml);
  EXPECT_FALSE(cfg.ok()) << "parsed unexpectedly:\n" << yaml;
  return cfg.ok() ? absl::OkStatus() : cfg.status();
}

// The error text as a std::string (gmock prints it readably; it outlives the Status).
std::string Message(std::string_view yaml) { return std::string(ErrorOf(yaml).message()); }

// kOneDrive with `from` replaced by `to` (which must occur).
std::string OneDriveWith(std::string_view from, std::string_view to) {
  std::string text(kOneDrive);
  EXPECT_NE(text.find(std::string(from)), std::string::npos) << from;
  return absl::StrReplaceAll(text, {{absl::string_view(from.data(), from.size()),
                                     absl::string_view(to.data(), to.size())}});
}

// ---- defaults and demo mode ----

TEST(ParseConfigTest, EmptyText_DemoWithAllDefaults) {
  auto cfg = ParseConfig("");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_TRUE(cfg->demo);
  EXPECT_TRUE(cfg->drives.empty());
  // Auth is off by default, so the default ports listen on loopback only (decision 015).
  EXPECT_FALSE(cfg->auth.enabled);
  EXPECT_EQ(cfg->listen.grpc, "127.0.0.1:50051");
  EXPECT_EQ(cfg->listen.http, "127.0.0.1:8080");
  EXPECT_EQ(cfg->data_dir, "./data");
}

TEST(ParseConfigTest, CommentsOnly_Demo) {
  auto cfg = ParseConfig("# nothing here\n\n# still nothing\n");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_TRUE(cfg->demo);
}

TEST(ParseConfigTest, OnlyListen_DemoWithListenAndDataDirApplied) {
  auto cfg = ParseConfig("listen:\n  http: 127.0.0.1:0\ndata_dir: /tmp/dgw\n");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_TRUE(cfg->demo);
  EXPECT_TRUE(cfg->drives.empty());
  EXPECT_EQ(cfg->listen.http, "127.0.0.1:0");
  EXPECT_EQ(cfg->listen.grpc, "127.0.0.1:50051");
  EXPECT_EQ(cfg->data_dir, "/tmp/dgw");
}

TEST(ParseConfigTest, EmptyListenSection_KeepsDefaults) {
  auto cfg = ParseConfig("listen:\n");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->listen.grpc, "127.0.0.1:50051");
}

TEST(ParseConfigTest, MinimalDrive_LinUdpAndTimeoutDefaults) {
  auto cfg = ParseConfig(kOneDrive);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_FALSE(cfg->demo);
  ASSERT_EQ(cfg->drives.size(), 1u);
  const DriveConfig& d = cfg->drives[0];
  EXPECT_EQ(d.name, "x1");
  EXPECT_EQ(d.family, "linmot");
  ASSERT_TRUE(d.linudp.has_value());
  EXPECT_EQ(d.linudp->host, "192.168.1.20");
  EXPECT_EQ(d.linudp->port, 49360);
  EXPECT_EQ(d.linudp->master_port, 41136);
  EXPECT_EQ(d.linudp->bind_host, "0.0.0.0");
  EXPECT_EQ(d.linudp->cycle, milliseconds(5));
  EXPECT_EQ(d.linudp->reply_timeout, milliseconds(50));
  EXPECT_EQ(d.linudp->lost_after_timeouts, 5);
  EXPECT_EQ(d.axis.kind, AxisKind::kLinear);
  EXPECT_EQ(d.timeouts.request, milliseconds(2000));
  EXPECT_EQ(d.timeouts.accept, milliseconds(100));
  EXPECT_EQ(d.timeouts.homing, milliseconds(30000));
  EXPECT_EQ(cfg->source_yaml, kOneDrive);
}

TEST(ParseConfigTest, FullExample_EveryKeyApplied) {
  auto cfg = ParseConfig(kFull);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_FALSE(cfg->demo);
  EXPECT_TRUE(cfg->auth.enabled);
  EXPECT_EQ(cfg->listen.grpc, "0.0.0.0:50052");
  EXPECT_EQ(cfg->listen.http, "127.0.0.1:8081");
  EXPECT_EQ(cfg->data_dir, "/var/lib/drivegw");
  ASSERT_EQ(cfg->drives.size(), 2u);
  const DriveConfig& a = cfg->drives[0];
  EXPECT_EQ(a.linudp->port, 49360);
  EXPECT_EQ(a.linudp->master_port, 41136);
  EXPECT_EQ(a.linudp->bind_host, "192.168.1.2");
  EXPECT_EQ(a.linudp->cycle, milliseconds(4));
  EXPECT_EQ(a.linudp->reply_timeout, milliseconds(40));
  EXPECT_EQ(a.linudp->lost_after_timeouts, 3);
  EXPECT_DOUBLE_EQ(a.axis.min_mm, -5);
  EXPECT_DOUBLE_EQ(a.axis.max_mm, 145.5);
  EXPECT_DOUBLE_EQ(a.axis.max_velocity_mm_s, 1500);
  EXPECT_DOUBLE_EQ(a.axis.max_acceleration_mm_s2, 15000);
  EXPECT_EQ(a.timeouts.request, milliseconds(1500));
  EXPECT_EQ(a.timeouts.accept, milliseconds(80));
  EXPECT_EQ(a.timeouts.homing, milliseconds(20000));
  const DriveConfig& b = cfg->drives[1];
  EXPECT_EQ(b.name, "r_2");
  EXPECT_EQ(b.linudp->host, "drive-2.local");
  EXPECT_EQ(b.linudp->port, 49361);
  EXPECT_EQ(b.axis.kind, AxisKind::kRotary);
  EXPECT_DOUBLE_EQ(b.axis.max_mm, 360);
}

TEST(ParseConfigTest, IPv6ListenAddress_Accepted) {
  auto cfg =
      ParseConfig("auth: {enabled: true}\nlisten:\n  grpc: \"[::]:50051\"\n  http: \"[::1]:0\"\n");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->listen.grpc, "[::]:50051");
}

TEST(ParseConfigTest, EmptyListenHost_MeansEveryInterface) {
  auto cfg = ParseConfig("auth: {enabled: true}\nlisten:\n  http: ':8081'\n");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->listen.http, ":8081");
}

// ---- the error messages from the brief ----

TEST(ParseConfigTest, PortAbove65535_NamesPathAndLimit) {
  std::string yaml = absl::StrCat(kOneDrive, R"(
  - name: x2
    family: linmot
    linudp: {host: 10.0.0.2}
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
  - name: x3
    family: linmot
    linudp:
      host: 10.0.0.3
      port: 70000
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
)");
  EXPECT_EQ(ErrorOf(yaml).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(Message(yaml), HasSubstr("drives[2].linudp.port: 70000 exceeds 65535"));
  EXPECT_THAT(Message(yaml), HasSubstr("(line 21, column 13)"));
}

TEST(ParseConfigTest, MaxBelowMin_NamesBothValues) {
  absl::Status s =
      ErrorOf(OneDriveWith("min_mm: 0\n      max_mm: 150", "min_mm: 20\n      max_mm: 10"));
  EXPECT_THAT(s.message(), HasSubstr("drives[0].axis.max_mm: 10 must be greater than min_mm 20"));
}

TEST(ParseConfigTest, MaxEqualMin_Rejected) {
  absl::Status s = ErrorOf(OneDriveWith("max_mm: 150", "max_mm: 0"));
  EXPECT_THAT(s.message(), HasSubstr("drives[0].axis.max_mm: 0 must be greater than min_mm 0"));
}

TEST(ParseConfigTest, DuplicateName_PointsAtFirst) {
  std::string yaml = absl::StrCat(kOneDrive, R"(
  - name: x1
    family: linmot
    linudp: {host: 10.0.0.2}
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
)");
  EXPECT_THAT(ErrorOf(yaml).message(),
              HasSubstr("drives[1].name: 'x1' is a duplicate of drives[0].name"));
}

TEST(ParseConfigTest, UnknownFamily_ListsKnownOnes) {
  EXPECT_THAT(ErrorOf(OneDriveWith("family: linmot", "family: foo")).message(),
              HasSubstr("drives[0].family: 'foo' is not one of [linmot, linmot-devicenet, "
                        "trinamic, stober]"));
}

TEST(ParseConfigTest, FamilyList_IsAParameter) {
  constexpr std::string_view kMore[] = {"linmot", "acme"};
  std::string yaml = OneDriveWith("family: linmot", "family: acme");
  EXPECT_TRUE(ParseConfig(yaml, kMore).ok());
  EXPECT_THAT(ParseConfig(OneDriveWith("family: linmot", "family: foo"), kMore).status().message(),
              HasSubstr("'foo' is not one of [linmot, acme]"));
}

TEST(ParseConfigTest, UnknownKey_NamesFullPathAndSuggests) {
  absl::Status s = ErrorOf(OneDriveWith("host: 192.168.1.20", "host: 192.168.1.20\n      prot: 1"));
  EXPECT_THAT(s.message(), HasSubstr("drives[0].linudp.prot: unknown key"));
  EXPECT_THAT(s.message(), HasSubstr("did you mean 'port'?"));
}

TEST(ParseConfigTest, UnknownTopLevelKey_Rejected) {
  EXPECT_THAT(ErrorOf("listen: {}\nlisten_http: 1\n").message(),
              HasSubstr("listen_http: unknown key"));
  EXPECT_THAT(ErrorOf("listen:\n  https: 0.0.0.0:1\n").message(),
              HasSubstr("listen.https: unknown key (did you mean 'http'?)"));
}

TEST(ParseConfigTest, ListenNotHostPort_Rejected) {
  EXPECT_THAT(ErrorOf("listen:\n  http: abc\n").message(),
              HasSubstr("listen.http: 'abc' is not a host:port"));
  EXPECT_THAT(ErrorOf("listen:\n  grpc: 0.0.0.0:99999\n").message(),
              HasSubstr("listen.grpc: '0.0.0.0:99999' is not a host:port"));
  EXPECT_THAT(ErrorOf("listen:\n  grpc: 'host:'\n").message(),
              HasSubstr("listen.grpc: 'host:' is not a host:port"));
  EXPECT_THAT(ErrorOf("listen:\n  grpc: 'a b:80'\n").message(),
              HasSubstr("listen.grpc: 'a b:80' is not a host:port"));
  EXPECT_THAT(ErrorOf("listen:\n  grpc: [1, 2]\n").message(),
              HasSubstr("listen.grpc: expected a string, got a sequence"));
}

// ---- per-key validation ----

TEST(ParseConfigTest, NameRules_Enforced) {
  for (const char* bad : {"X1", "x 1", "'x.1'", "''", "abcdefghijabcdefghijabcdefghijabc"}) {
    absl::Status s = ErrorOf(OneDriveWith("name: x1", absl::StrCat("name: ", bad)));
    EXPECT_THAT(s.message(), HasSubstr("must match [a-z0-9_-]{1,32}")) << bad;
    EXPECT_THAT(s.message(), HasSubstr("drives[0].name: ")) << bad;
  }
  EXPECT_TRUE(ParseConfig(OneDriveWith("name: x1", "name: abcdefghijabcdefghijabcdefghijab")).ok());
  EXPECT_TRUE(ParseConfig(OneDriveWith("name: x1", "name: a-b_9")).ok());
}

TEST(ParseConfigTest, RequiredKeys_Named) {
  EXPECT_THAT(ErrorOf(OneDriveWith("  - name: x1\n", "  -\n")).message(),
              HasSubstr("drives[0].name: required"));
  EXPECT_THAT(ErrorOf(OneDriveWith("    family: linmot\n", "")).message(),
              HasSubstr("drives[0].family: required"));
  EXPECT_THAT(ErrorOf(OneDriveWith("      host: 192.168.1.20\n", "      port: 1\n")).message(),
              HasSubstr("drives[0].linudp.host: required"));
  EXPECT_THAT(ErrorOf(OneDriveWith("    linudp:\n      host: 192.168.1.20\n", "")).message(),
              HasSubstr("drives[0].linudp: required for family linmot"));
  EXPECT_THAT(ErrorOf(OneDriveWith("      max_velocity_mm_s: 2000\n", "")).message(),
              HasSubstr("drives[0].axis.max_velocity_mm_s: required"));
  EXPECT_THAT(ErrorOf(OneDriveWith("      min_mm: 0\n", "")).message(),
              HasSubstr("drives[0].axis.min_mm: required"));
}

TEST(ParseConfigTest, AxisMissing_Required) {
  std::string yaml(kOneDrive);
  yaml = yaml.substr(0, yaml.find("    axis:"));
  EXPECT_THAT(ErrorOf(yaml).message(), HasSubstr("drives[0].axis: required"));
}

TEST(ParseConfigTest, AxisValues_Checked) {
  EXPECT_THAT(ErrorOf(OneDriveWith("max_velocity_mm_s: 2000", "max_velocity_mm_s: 0")).message(),
              HasSubstr("drives[0].axis.max_velocity_mm_s: 0 must be greater than 0"));
  EXPECT_THAT(ErrorOf(OneDriveWith("max_acceleration_mm_s2: 20000", "max_acceleration_mm_s2: -1"))
                  .message(),
              HasSubstr("drives[0].axis.max_acceleration_mm_s2: -1 must be greater than 0"));
  EXPECT_THAT(ErrorOf(OneDriveWith("max_mm: 150", "max_mm: .inf")).message(),
              HasSubstr("drives[0].axis.max_mm: '.inf' is not a finite number"));
  EXPECT_THAT(ErrorOf(OneDriveWith("max_mm: 150", "max_mm: nan")).message(),
              HasSubstr("drives[0].axis.max_mm: 'nan' is not a finite number"));
  EXPECT_THAT(ErrorOf(OneDriveWith("max_mm: 150", "max_mm: ten")).message(),
              HasSubstr("drives[0].axis.max_mm: 'ten' is not a finite number"));
  EXPECT_THAT(ErrorOf(OneDriveWith("min_mm: 0", "kind: circular\n      min_mm: 0")).message(),
              HasSubstr("drives[0].axis.kind: 'circular' is not one of [linear, rotary]"));
}

TEST(ParseConfigTest, LinUdpRanges_Checked) {
  const std::string host = "host: 192.168.1.20";
  auto with = [&](const std::string& line) {
    return Message(OneDriveWith(host, absl::StrCat(host, "\n      ", line)));
  };
  EXPECT_THAT(with("port: 0"), HasSubstr("drives[0].linudp.port: 0 is below 1"));
  EXPECT_THAT(with("port: abc"), HasSubstr("drives[0].linudp.port: 'abc' is not an integer"));
  EXPECT_THAT(with("port: 49360.5"),
              HasSubstr("drives[0].linudp.port: '49360.5' is not an integer"));
  EXPECT_THAT(with("master_port: 65536"),
              HasSubstr("drives[0].linudp.master_port: 65536 exceeds 65535"));
  EXPECT_THAT(with("cycle_ms: 0"), HasSubstr("drives[0].linudp.cycle_ms: 0 is below 1"));
  EXPECT_THAT(with("cycle_ms: 1001"), HasSubstr("drives[0].linudp.cycle_ms: 1001 exceeds 1000"));
  EXPECT_THAT(with("reply_timeout_ms: 0"),
              HasSubstr("drives[0].linudp.reply_timeout_ms: 0 is below 1"));
  EXPECT_THAT(with("lost_after_timeouts: 0"),
              HasSubstr("drives[0].linudp.lost_after_timeouts: 0 is below 1"));
  EXPECT_THAT(with("bind_host: 'a b'"),
              HasSubstr("drives[0].linudp.bind_host: 'a b' is not a host name or IPv4 address"));
  // Boundaries are accepted.
  EXPECT_TRUE(ParseConfig(OneDriveWith(host, host + "\n      cycle_ms: 1000\n      port: 65535\n"
                                                    "      master_port: 0"))
                  .ok());
}

// Decision 1311: real-time scheduling of the LinUDP I/O thread.
TEST(ParseConfigTest, LinUdpIoScheduling_AppliedAndChecked) {
  const std::string host = "host: 192.168.1.20";
  auto cfg =
      ParseConfig(OneDriveWith(host, host + "\n      io_priority: 50\n      io_cpus: [1, 3]"));
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->drives[0].linudp->io_priority, 50);
  EXPECT_EQ(cfg->drives[0].linudp->io_cpus, (std::vector<int>{1, 3}));
  auto defaults = ParseConfig(kOneDrive);
  ASSERT_TRUE(defaults.ok());
  EXPECT_EQ(defaults->drives[0].linudp->io_priority, 0);
  EXPECT_TRUE(defaults->drives[0].linudp->io_cpus.empty());
  auto with = [&](const std::string& line) {
    return Message(OneDriveWith(host, absl::StrCat(host, "\n      ", line)));
  };
  EXPECT_THAT(with("io_priority: 100"), HasSubstr("drives[0].linudp.io_priority: 100 exceeds 99"));
  EXPECT_THAT(with("io_priority: -1"), HasSubstr("drives[0].linudp.io_priority: -1 is below 0"));
  EXPECT_THAT(with("io_cpus: 1"), HasSubstr("drives[0].linudp.io_cpus: expected a sequence"));
  EXPECT_THAT(with("io_cpus: [0, x]"),
              HasSubstr("drives[0].linudp.io_cpus[1]: 'x' is not an integer"));
  EXPECT_THAT(with("io_cpus: [2, 2]"),
              HasSubstr("drives[0].linudp.io_cpus[1]: CPU 2 is given twice"));
  EXPECT_THAT(with("io_cpus: [1024]"),
              HasSubstr("drives[0].linudp.io_cpus[0]: 1024 is outside 0..1023"));
}

// One I/O thread serves every drive of a master socket: their scheduling must agree.
TEST(ParseConfigTest, LinUdpIoScheduling_SharedMasterSocketMustAgree) {
  const std::string two = R"(
drives:
  - name: x1
    family: linmot
    linudp: {host: 10.0.0.1, io_priority: 40}
    axis: {min_mm: 0, max_mm: 150, max_velocity_mm_s: 2000, max_acceleration_mm_s2: 20000}
  - name: x2
    family: linmot
    linudp: {host: 10.0.0.2, io_priority: PRIO}
    axis: {min_mm: 0, max_mm: 150, max_velocity_mm_s: 2000, max_acceleration_mm_s2: 20000}
)";
  EXPECT_TRUE(ParseConfig(absl::StrReplaceAll(two, {{"PRIO", "40"}})).ok());
  EXPECT_THAT(Message(absl::StrReplaceAll(two, {{"PRIO", "0"}})),
              HasSubstr("drives[1].linudp: io_priority/io_cpus differ from drives[0], which "
                        "shares master socket 0.0.0.0:41136"));
  // Another master port is another socket and thread.
  EXPECT_TRUE(ParseConfig(absl::StrReplaceAll(two, {{"PRIO", "0, master_port: 41137"}})).ok());
}

TEST(ParseConfigTest, Timeouts_Checked) {
  const std::string tail = "max_acceleration_mm_s2: 20000";
  auto with = [&](const std::string& block) {
    return Message(OneDriveWith(tail, absl::StrCat(tail, "\n    timeouts:\n      ", block)));
  };
  EXPECT_THAT(with("request_ms: 0"), HasSubstr("drives[0].timeouts.request_ms: 0 is below 1"));
  EXPECT_THAT(with("accept_ms: 60001"),
              HasSubstr("drives[0].timeouts.accept_ms: 60001 exceeds 60000"));
  EXPECT_THAT(with("homing_ms: -5"), HasSubstr("drives[0].timeouts.homing_ms: -5 is below 1"));
  EXPECT_THAT(with("homing: 5"), HasSubstr("drives[0].timeouts.homing: unknown key"));
}

// ---- CAN bus and DeviceNet MAC ID (docs/config.md "can") ----

constexpr char kDeviceNetDrive[] = R"(
drives:
  - name: dn1
    family: linmot-devicenet
    can:
      socketcan: {interface: can0}
    mac_id: 5
    axis: {min_mm: 0, max_mm: 150, max_velocity_mm_s: 2000, max_acceleration_mm_s2: 20000}
)";

std::string DeviceNetWith(std::string_view from, std::string_view to) {
  std::string text(kDeviceNetDrive);
  EXPECT_NE(text.find(std::string(from)), std::string::npos) << from;
  return absl::StrReplaceAll(text, {{absl::string_view(from.data(), from.size()),
                                     absl::string_view(to.data(), to.size())}});
}

TEST(ParseConfigTest, CanSocketcan_InterfaceAndMacId) {
  auto cfg = ParseConfig(kDeviceNetDrive);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  const DriveConfig& d = cfg->drives[0];
  ASSERT_TRUE(d.can.has_value());
  EXPECT_EQ(d.can->kind, CanBusConfig::Kind::kSocketCan);
  EXPECT_EQ(d.can->interface, "can0");
  EXPECT_EQ(d.can->trace_file, "");
  EXPECT_EQ(d.mac_id, std::optional<uint8_t>(5));
  EXPECT_FALSE(d.linudp.has_value());
}

TEST(ParseConfigTest, CanUdp_GroupPortTrace) {
  auto cfg = ParseConfig(
      DeviceNetWith("socketcan: {interface: can0}",
                    "udp: {group: 239.1.2.3, port: 5000}\n      trace: /var/log/drivegw/can.log"));
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  const CanBusConfig& can = *cfg->drives[0].can;
  EXPECT_EQ(can.kind, CanBusConfig::Kind::kUdpMulticast);
  EXPECT_EQ(can.group, "239.1.2.3");
  EXPECT_EQ(can.port, 5000);
  EXPECT_EQ(can.trace_file, "/var/log/drivegw/can.log");
}

TEST(ParseConfigTest, CanUdp_EmptyTakesPythonCanDefaults) {
  for (const char* udp : {"udp:", "udp: {}"}) {
    auto cfg = ParseConfig(DeviceNetWith("socketcan: {interface: can0}", udp));
    ASSERT_TRUE(cfg.ok()) << udp << ": " << cfg.status();
    EXPECT_EQ(cfg->drives[0].can->group, "239.74.163.2");
    EXPECT_EQ(cfg->drives[0].can->port, 43113);
  }
}

TEST(ParseConfigTest, CanUdpGroup_MustBeMulticast) {
  EXPECT_THAT(Message(DeviceNetWith("socketcan: {interface: can0}", "udp: {group: 10.0.0.1}")),
              HasSubstr("drives[0].can.udp.group: '10.0.0.1' is not an IPv4 multicast address "
                        "(224.0.0.0/4) (line 6, column 20)"));
  EXPECT_THAT(Message(DeviceNetWith("socketcan: {interface: can0}", "udp: {group: bus.local}")),
              HasSubstr("drives[0].can.udp.group: 'bus.local' is not an IPv4 multicast address"));
  EXPECT_TRUE(
      ParseConfig(DeviceNetWith("socketcan: {interface: can0}", "udp: {group: 224.0.0.1}")).ok());
  EXPECT_FALSE(
      ParseConfig(DeviceNetWith("socketcan: {interface: can0}", "udp: {group: 240.0.0.1}")).ok());
}

TEST(ParseConfigTest, CanUdpPort_Range) {
  EXPECT_THAT(Message(DeviceNetWith("socketcan: {interface: can0}", "udp: {port: 0}")),
              HasSubstr("drives[0].can.udp.port: 0 is below 1"));
  EXPECT_THAT(Message(DeviceNetWith("socketcan: {interface: can0}", "udp: {port: 65536}")),
              HasSubstr("drives[0].can.udp.port: 65536 exceeds 65535"));
}

TEST(ParseConfigTest, Can_ExactlyOneBus) {
  EXPECT_THAT(Message(DeviceNetWith("socketcan: {interface: can0}",
                                    "socketcan: {interface: can0}\n      udp: {}")),
              HasSubstr("drives[0].can: has both socketcan and udp; a drive is on one bus"));
  EXPECT_THAT(Message(DeviceNetWith("socketcan: {interface: can0}", "trace: x.log")),
              HasSubstr("drives[0].can: needs exactly one of socketcan, udp"));
  EXPECT_THAT(Message(DeviceNetWith("can:\n      socketcan: {interface: can0}", "can:")),
              HasSubstr("drives[0].can: needs exactly one of socketcan, udp"));
  EXPECT_THAT(Message(DeviceNetWith("socketcan: {interface: can0}", "sockcan: {}")),
              HasSubstr("drives[0].can.sockcan: unknown key (did you mean 'socketcan'?)"));
}

TEST(ParseConfigTest, CanSocketcanInterface_RequiredAndValid) {
  EXPECT_THAT(Message(DeviceNetWith("socketcan: {interface: can0}", "socketcan:")),
              HasSubstr("drives[0].can.socketcan.interface: required"));
  EXPECT_THAT(Message(DeviceNetWith("socketcan: {interface: can0}", "socketcan: {}")),
              HasSubstr("drives[0].can.socketcan.interface: required"));
  EXPECT_THAT(Message(DeviceNetWith("interface: can0", "interface: a-very-long-ifname0")),
              HasSubstr("drives[0].can.socketcan.interface: 'a-very-long-ifname0' is not a network "
                        "interface name (1..15 characters, no '/', ':' or spaces)"));
  EXPECT_THAT(Message(DeviceNetWith("interface: can0", "interface: 'can/0'")),
              HasSubstr("is not a network interface name"));
}

TEST(ParseConfigTest, CanTrace_NotEmpty) {
  EXPECT_THAT(Message(DeviceNetWith("socketcan: {interface: can0}",
                                    "socketcan: {interface: can0}\n      trace: ''")),
              HasSubstr("drives[0].can.trace: must not be empty (omit the key to trace nothing)"));
}

TEST(ParseConfigTest, DeviceNet_RequiresCanAndMacId) {
  const std::string yaml = R"(
drives:
  - name: dn1
    family: linmot-devicenet
    axis: {min_mm: 0, max_mm: 150, max_velocity_mm_s: 2000, max_acceleration_mm_s2: 20000}
)";
  EXPECT_THAT(Message(yaml), HasSubstr("drives[0].can: required for family linmot-devicenet"));
  EXPECT_THAT(Message(yaml),
              HasSubstr("drives[0].mac_id: required for family linmot-devicenet (0..63)"));
}

TEST(ParseConfigTest, MacId_Range) {
  EXPECT_THAT(Message(DeviceNetWith("mac_id: 5", "mac_id: 64")),
              HasSubstr("drives[0].mac_id: 64 exceeds 63"));
  EXPECT_THAT(Message(DeviceNetWith("mac_id: 5", "mac_id: -1")),
              HasSubstr("drives[0].mac_id: -1 is below 0"));
  EXPECT_THAT(Message(DeviceNetWith("mac_id: 5", "mac_id: five")),
              HasSubstr("drives[0].mac_id: 'five' is not an integer"));
  auto zero = ParseConfig(DeviceNetWith("mac_id: 5", "mac_id: 0"));
  ASSERT_TRUE(zero.ok()) << zero.status();
  EXPECT_EQ(zero->drives[0].mac_id, std::optional<uint8_t>(0));
}

TEST(ParseConfigTest, SameMacIdOnOneBus_Rejected_OtherBusFine) {
  const std::string two = R"(
drives:
  - name: dn1
    family: linmot-devicenet
    can: {udp: {}}
    mac_id: 7
    axis: {min_mm: 0, max_mm: 150, max_velocity_mm_s: 2000, max_acceleration_mm_s2: 20000}
  - name: dn2
    family: linmot-devicenet
    can: {udp: {port: BUSPORT}}
    mac_id: 7
    axis: {min_mm: 0, max_mm: 150, max_velocity_mm_s: 2000, max_acceleration_mm_s2: 20000}
)";
  EXPECT_THAT(Message(absl::StrReplaceAll(two, {{"BUSPORT", "43113"}})),
              HasSubstr("drives[1].mac_id: 7 is also the MAC ID of drives[0] on "
                        "udp:239.74.163.2:43113"));
  EXPECT_TRUE(ParseConfig(absl::StrReplaceAll(two, {{"BUSPORT", "43114"}})).ok());
}

TEST(ParseConfigTest, LinMot_UnaffectedByCanKeys) {
  auto cfg = ParseConfig(kOneDrive);
  ASSERT_TRUE(cfg.ok());
  EXPECT_FALSE(cfg->drives[0].can.has_value());
  EXPECT_FALSE(cfg->drives[0].mac_id.has_value());
}

TEST(ParseConfigTest, SameDriveAddressTwice_Rejected) {
  std::string yaml = absl::StrCat(kOneDrive, R"(
  - name: x2
    family: linmot
    linudp: {host: 192.168.1.20, port: 49360}
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
)");
  EXPECT_THAT(ErrorOf(yaml).message(),
              HasSubstr("drives[1].linudp: 192.168.1.20:49360 is also the address of drives[0]"));
}

TEST(ParseConfigTest, DrivesEmptyOrWrongType_Rejected) {
  EXPECT_THAT(ErrorOf("drives: []\n").message(),
              HasSubstr("drives: must list at least one drive (omit the key for demo mode)"));
  EXPECT_THAT(ErrorOf("drives:\n").message(), HasSubstr("drives: must list at least one drive"));
  EXPECT_THAT(ErrorOf("drives: x1\n").message(),
              HasSubstr("drives: expected a sequence, got a scalar"));
  EXPECT_THAT(ErrorOf("drives: [x1]\n").message(),
              HasSubstr("drives[0]: expected a mapping, got a scalar"));
}

TEST(ParseConfigTest, DuplicateKey_Rejected) {
  EXPECT_THAT(ErrorOf("data_dir: a\ndata_dir: b\n").message(),
              HasSubstr("data_dir: duplicate key"));
}

TEST(ParseConfigTest, RootNotAMapping_Rejected) {
  EXPECT_THAT(ErrorOf("- a\n- b\n").message(),
              HasSubstr("(root): expected a mapping, got a sequence"));
  EXPECT_THAT(ErrorOf("just text").message(),
              HasSubstr("(root): expected a mapping, got a scalar"));
}

TEST(ParseConfigTest, EmptyDataDir_Rejected) {
  EXPECT_THAT(ErrorOf("data_dir: ''\n").message(), HasSubstr("data_dir: must not be empty"));
}

TEST(ParseConfigTest, SeveralErrors_AllReported) {
  absl::Status s = ErrorOf("listen:\n  http: abc\ndata_dir: ''\nbogus: 1\n");
  EXPECT_THAT(s.message(), HasSubstr("listen.http: 'abc' is not a host:port"));
  EXPECT_THAT(s.message(), HasSubstr("data_dir: must not be empty"));
  EXPECT_THAT(s.message(), HasSubstr("bogus: unknown key"));
}

// ---- YAML syntax: exceptions become InvalidArgument with line/column ----

TEST(ParseConfigTest, SyntaxError_InvalidArgumentWithLineAndColumn) {
  absl::Status s = ErrorOf("listen:\n  http: [unclosed\n");
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("config: YAML error at line"));
  EXPECT_THAT(s.message(), HasSubstr("column"));

  s = ErrorOf("a: b\n c: d\n  - e\n");
  EXPECT_THAT(s.message(), HasSubstr("config: YAML error at line"));
}

TEST(ParseConfigTest, MultipleDocuments_Rejected) {
  EXPECT_THAT(
      ErrorOf("data_dir: a\n---\ndata_dir: b\n").message(),
      HasSubstr("config: more than one YAML document (the second starts at line 2, column 1)"));
}

TEST(ParseConfigTest, StrayFlowToken_SyntaxErrorNotDemoOrHang) {
  // yaml-cpp 0.7 alone loops forever on LoadAll(",") and returns null from Load(",").
  EXPECT_EQ(Message(","), "config: YAML error at line 1, column 1: unexpected ','");
  EXPECT_THAT(Message("data_dir: /x\n,\n"), HasSubstr("config: YAML error at line 2, column 1"));
  EXPECT_THAT(Message("- a\n]"), HasSubstr("config: YAML error at line 2"));
}

TEST(ParseConfigTest, DeepNesting_RejectedNotCrashed) {
  std::string deep(100000, '[');
  EXPECT_EQ(ErrorOf(deep).code(), absl::StatusCode::kInvalidArgument);
}

TEST(ParseConfigTest, SelfReferencingAlias_DoesNotLoop) {
  // yaml-cpp builds a cyclic node for this; the schema walk is bounded, so it just fails.
  absl::Status s = ErrorOf("drives: &a [*a]\n");
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
}

TEST(ParseConfigTest, TooLarge_RejectedBeforeParsing) {
  std::string big(kMaxConfigBytes + 1, '#');
  EXPECT_THAT(ErrorOf(big).message(), HasSubstr("exceeds 1048576"));
}

// ---- files ----

class LoadConfigFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern = "/tmp/dgw_config_XXXXXX";
    ASSERT_NE(mkdtemp(pattern.data()), nullptr);
    dir_ = pattern;
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  std::string Write(const std::string& name, std::string_view text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  std::filesystem::path dir_;
};

TEST_F(LoadConfigFileTest, Missing_NotFoundNamingPath) {
  const std::string path = (dir_ / "nope.yaml").string();
  auto cfg = LoadConfigFile(path);
  EXPECT_EQ(cfg.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(cfg.status().message(), HasSubstr(path));
}

TEST_F(LoadConfigFileTest, Valid_ParsesAndKeepsSource) {
  auto cfg = LoadConfigFile(Write("gw.yaml", kFull));
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->drives.size(), 2u);
  EXPECT_EQ(cfg->source_yaml, kFull);
}

TEST_F(LoadConfigFileTest, Invalid_MessageStartsWithPath) {
  const std::string path = Write("bad.yaml", "listen:\n  http: abc\n");
  auto cfg = LoadConfigFile(path);
  EXPECT_EQ(cfg.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(cfg.status().message(), HasSubstr(path + ": listen.http: 'abc' is not a host:port"));
}

TEST_F(LoadConfigFileTest, Directory_Rejected) {
  auto cfg = LoadConfigFile(dir_.string());
  EXPECT_EQ(cfg.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(cfg.status().message(), HasSubstr("is a directory"));
}

// ---- demo drives ----

TEST(DemoDrivesTest, TwoLinMotDrivesOnConsecutiveLoopbackPorts) {
  auto drives = DemoDrives(50000);
  ASSERT_EQ(drives.size(), 2u);
  EXPECT_EQ(drives[0].name, "x1");
  EXPECT_EQ(drives[1].name, "x2");
  for (size_t i = 0; i < drives.size(); ++i) {
    const DriveConfig& d = drives[i];
    EXPECT_EQ(d.family, "linmot");
    ASSERT_TRUE(d.linudp.has_value());
    EXPECT_EQ(d.linudp->host, "127.0.0.1");
    EXPECT_EQ(d.linudp->port, 50000 + i);
    EXPECT_EQ(d.axis.kind, AxisKind::kLinear);
    EXPECT_DOUBLE_EQ(d.axis.min_mm, 0);
    EXPECT_DOUBLE_EQ(d.axis.max_mm, 150);
    EXPECT_DOUBLE_EQ(d.axis.max_velocity_mm_s, 2000);
    EXPECT_DOUBLE_EQ(d.axis.max_acceleration_mm_s2, 20000);
  }
  EXPECT_EQ(DemoDrives()[0].linudp->port, 49360);
}

}  // namespace
}  // namespace drivegw::config

namespace drivegw::config {
namespace {

// ---- drives[i].health (decision 1431) ----

constexpr char kAxisLine[] = "    axis:\n";

TEST(ParseConfigTest, Health_AbsentKeysStayUnset_GivenOnesApplied) {
  auto cfg = ParseConfig(kOneDrive);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_FALSE(cfg->drives[0].health.down_after_failures.has_value());
  EXPECT_FALSE(cfg->drives[0].health.backoff_min.has_value());
  EXPECT_FALSE(cfg->drives[0].health.up_after.has_value());
  cfg = ParseConfig(OneDriveWith(kAxisLine,
                                 "    health: {down_after_failures: 4, backoff_min_ms: 0, "
                                 "backoff_max_ms: 800, up_after_ms: 2500}\n    axis:\n"));
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  const HealthOverrides& h = cfg->drives[0].health;
  EXPECT_EQ(h.down_after_failures, 4);
  EXPECT_EQ(h.backoff_min, std::chrono::milliseconds(0));
  EXPECT_EQ(h.backoff_max, std::chrono::milliseconds(800));
  EXPECT_EQ(h.up_after, std::chrono::milliseconds(2500));
  // 0 is valid: UP at the next success (decision 1432).
  cfg = ParseConfig(OneDriveWith(kAxisLine, "    health: {up_after_ms: 0}\n    axis:\n"));
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->drives[0].health.up_after, std::chrono::milliseconds(0));
}

TEST(ParseConfigTest, Health_LimitsNameTheKey) {
  EXPECT_THAT(Message(OneDriveWith(kAxisLine, "    health: {down_after_failures: 0}\n    axis:\n")),
              HasSubstr("drives[0].health.down_after_failures: 0 is below 1"));
  EXPECT_THAT(
      Message(OneDriveWith(kAxisLine, "    health: {down_after_failures: 1001}\n    axis:\n")),
      HasSubstr("drives[0].health.down_after_failures: 1001 exceeds 1000"));
  EXPECT_THAT(Message(OneDriveWith(kAxisLine, "    health: {backoff_max_ms: 600001}\n    axis:\n")),
              HasSubstr("drives[0].health.backoff_max_ms: 600001 exceeds 600000"));
  EXPECT_THAT(Message(OneDriveWith(kAxisLine, "    health: {backoff_min_ms: -1}\n    axis:\n")),
              HasSubstr("drives[0].health.backoff_min_ms: -1 is below 0"));
  EXPECT_THAT(
      Message(OneDriveWith(kAxisLine,
                           "    health: {backoff_min_ms: 900, backoff_max_ms: 800}\n    axis:\n")),
      HasSubstr("drives[0].health.backoff_min_ms: 900 must not exceed backoff_max_ms 800"));
  EXPECT_THAT(Message(OneDriveWith(kAxisLine, "    health: {up_after_ms: 600001}\n    axis:\n")),
              HasSubstr("drives[0].health.up_after_ms: 600001 exceeds 600000"));
  EXPECT_THAT(Message(OneDriveWith(kAxisLine, "    health: {up_after_ms: -5}\n    axis:\n")),
              HasSubstr("drives[0].health.up_after_ms: -5 is below 0"));
  EXPECT_THAT(Message(OneDriveWith(kAxisLine, "    health: {retries: 3}\n    axis:\n")),
              HasSubstr("drives[0].health.retries"));
}

TEST(ParseConfigTest, Health_CountGivenTwice_Refused) {
  std::string yaml = OneDriveWith("      host: 192.168.1.20\n",
                                  "      host: 192.168.1.20\n      lost_after_timeouts: 4\n");
  yaml =
      absl::StrReplaceAll(yaml, {{kAxisLine, "    health: {down_after_failures: 4}\n    axis:\n"}});
  EXPECT_THAT(Message(yaml), HasSubstr("drives[0].health.down_after_failures: also given as "
                                       "drives[0].linudp.lost_after_timeouts"));
}

}  // namespace
}  // namespace drivegw::config
