// family stober (docs/config.md "stober", decisions 407-409): node_id and canopen applied with
// their defaults, every message naming the key and the limit, the rules between CANopen drives
// and one protocol per CAN bus.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "adapters/stober/factory.h"
#include "server/config/config.h"

namespace drivegw::config {
namespace {

using std::chrono::milliseconds;
using ::testing::HasSubstr;
using ::testing::Not;

constexpr char kStoberAxis[] = R"(
drives:
  - name: s1
    family: stober
    can: {udp: {group: 239.74.163.2, port: 43114}}
    node_id: 3
    axis: {min_mm: -100, max_mm: 100, max_velocity_mm_s: 500, max_acceleration_mm_s2: 5000}
)";

std::string With(std::string_view from, std::string_view to) {
  std::string text(kStoberAxis);
  EXPECT_NE(text.find(std::string(from)), std::string::npos) << from;
  return absl::StrReplaceAll(text, {{absl::string_view(from.data(), from.size()),
                                     absl::string_view(to.data(), to.size())}});
}

// kStoberAxis plus one drive given in full (flow mappings, 4-space indented keys).
std::string PlusDrive(std::string_view name, std::string_view family, std::string_view keys) {
  return absl::StrCat(kStoberAxis, "  - name: ", std::string(name),
                      "\n    family: ", std::string(family), "\n", std::string(keys),
                      "    axis: {min_mm: 0, max_mm: 10, max_velocity_mm_s: 5, "
                      "max_acceleration_mm_s2: 50}\n");
}

std::string Message(std::string_view yaml) {
  auto cfg = ParseConfig(yaml);
  EXPECT_FALSE(cfg.ok()) << "parsed unexpectedly:\n" << yaml;
  if (cfg.ok()) return "";
  EXPECT_EQ(cfg.status().code(), absl::StatusCode::kInvalidArgument);
  return std::string(cfg.status().message());
}

// ---- valid ----

TEST(StoberConfigTest, FamilyIsKnown) {
  EXPECT_NE(std::find(std::begin(kKnownFamilies), std::end(kKnownFamilies), stober::kFamilyName),
            std::end(kKnownFamilies));
}

TEST(StoberConfigTest, MinimalAxis_NodeIdBusAndCanOpenDefaults) {
  auto cfg = ParseConfig(kStoberAxis);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  ASSERT_EQ(cfg->drives.size(), 1u);
  const DriveConfig& d = cfg->drives[0];
  EXPECT_EQ(d.family, "stober");
  EXPECT_EQ(d.node_id, std::optional<uint8_t>(3));
  ASSERT_TRUE(d.can.has_value());
  EXPECT_EQ(d.can->kind, CanBusConfig::Kind::kUdpMulticast);
  EXPECT_EQ(d.can->port, 43114);
  EXPECT_FALSE(d.mac_id.has_value());
  EXPECT_FALSE(d.linudp.has_value());
  EXPECT_FALSE(d.trinamic.has_value());
  // The defaults of drive_config.h: what the docs table lists.
  EXPECT_EQ(d.canopen.heartbeat, milliseconds(100));
  EXPECT_EQ(d.canopen.heartbeat_timeout, milliseconds(350));
  EXPECT_EQ(d.canopen.sync_period, milliseconds(2));
  EXPECT_EQ(d.canopen.sdo_timeout, milliseconds(1000));
  EXPECT_EQ(d.canopen.sdo_retries, 3);               // decision 1481
  EXPECT_EQ(d.canopen.rpdo_transmission_type, 255);  // event-driven (decision 1119)
  EXPECT_EQ(d.canopen.master_node_id, 127);          // the gateway's own node (decision 1483)
  EXPECT_EQ(d.axis.min_mm, -100);
}

TEST(StoberConfigTest, CanOpenKeys_Applied) {
  auto cfg = ParseConfig(With("node_id: 3", R"(node_id: 127
    canopen: {heartbeat_ms: 50, heartbeat_timeout_ms: 200, sync_period_ms: 4, sdo_timeout_ms: 300,
              sdo_retries: 0, master_node_id: 1})"));
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  const DriveConfig& d = cfg->drives[0];
  EXPECT_EQ(d.node_id, std::optional<uint8_t>(127));
  EXPECT_EQ(d.canopen.heartbeat, milliseconds(50));
  EXPECT_EQ(d.canopen.heartbeat_timeout, milliseconds(200));
  EXPECT_EQ(d.canopen.sync_period, milliseconds(4));
  EXPECT_EQ(d.canopen.sdo_timeout, milliseconds(300));
  EXPECT_EQ(d.canopen.sdo_retries, 0);
  // Node 127 is the default gateway node ID (decision 1483): free it by choosing another.
  EXPECT_EQ(d.canopen.master_node_id, 1);
  // "canopen:" alone keeps every default.
  auto empty = ParseConfig(With("node_id: 3", "node_id: 1\n    canopen:"));
  ASSERT_TRUE(empty.ok()) << empty.status();
  EXPECT_EQ(empty->drives[0].canopen.sync_period, milliseconds(2));
}

TEST(StoberConfigTest, SocketCan_Accepted) {
  auto cfg = ParseConfig(With("{udp: {group: 239.74.163.2, port: 43114}}",
                              "{socketcan: {interface: can1}, trace: /tmp/s1.log}"));
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->drives[0].can->kind, CanBusConfig::Kind::kSocketCan);
  EXPECT_EQ(cfg->drives[0].can->interface, "can1");
  EXPECT_EQ(cfg->drives[0].can->trace_file, "/tmp/s1.log");
}

TEST(StoberConfigTest, DocsExample_TwoNodesOnOneBus) {
  // docs/config.md "family: stober".
  auto cfg = ParseConfig(R"(
drives:
  - name: s1
    family: stober
    can: {udp: {group: 239.74.163.2, port: 43114}}   # socketcan: {interface: can1} on hardware
    node_id: 3
    canopen: {heartbeat_ms: 100, heartbeat_timeout_ms: 350, sync_period_ms: 2, sdo_timeout_ms: 1000}
    axis: {min_mm: -500, max_mm: 500, max_velocity_mm_s: 1000, max_acceleration_mm_s2: 10000}
  - name: s2
    family: stober
    can: {udp: {group: 239.74.163.2, port: 43114}}   # the same bus: another node ID
    node_id: 4
    axis: {kind: rotary, min_mm: 0, max_mm: 360, max_velocity_mm_s: 720, max_acceleration_mm_s2: 7200}
)");
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  ASSERT_EQ(cfg->drives.size(), 2u);
  EXPECT_EQ(cfg->drives[1].node_id, std::optional<uint8_t>(4));
  EXPECT_EQ(cfg->drives[1].axis.kind, AxisKind::kRotary);
}

// ---- node_id ----

TEST(StoberConfigTest, NodeId_RangeAndType) {
  EXPECT_THAT(Message(With("node_id: 3", "node_id: 128")),
              HasSubstr("drives[0].node_id: 128 exceeds 127 (line 6, column 14)"));
  EXPECT_THAT(Message(With("node_id: 3", "node_id: 0")),
              HasSubstr("drives[0].node_id: 0 is below 1"));
  EXPECT_THAT(Message(With("node_id: 3", "node_id: three")),
              HasSubstr("drives[0].node_id: 'three' is not an integer"));
  EXPECT_THAT(Message(With("node_id: 3", "node_id: 3.0")),
              HasSubstr("drives[0].node_id: '3.0' is not an integer"));
}

TEST(StoberConfigTest, RequiredKeys_NamedWithTheirLimits) {
  const std::string msg = Message(R"(
drives:
  - name: s1
    family: stober
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
)");
  EXPECT_THAT(msg, HasSubstr("drives[0].can: required for family stober (the CANopen bus)"));
  EXPECT_THAT(msg, HasSubstr("drives[0].node_id: required for family stober (1..127)"));
  EXPECT_THAT(Message(With("    axis: {min_mm: -100, max_mm: 100, max_velocity_mm_s: 500, "
                           "max_acceleration_mm_s2: 5000}\n",
                           "")),
              HasSubstr("drives[0].axis: required"));
}

TEST(StoberConfigTest, NodeIdOnOtherFamilies_Refused) {
  const std::string dn = R"(
drives:
  - name: d1
    family: linmot-devicenet
    can: {udp: {}}
    mac_id: 5
    node_id: 5
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
)";
  EXPECT_THAT(Message(dn), HasSubstr("drives[0].node_id: only for CANopen families (stober), not "
                                     "'linmot-devicenet' (a DeviceNet drive is addressed by "
                                     "mac_id) (line 7, column 14)"));
  const std::string linmot = R"(
drives:
  - name: x1
    family: linmot
    linudp: {host: 127.0.0.1}
    node_id: 1
    canopen: {heartbeat_ms: 10}
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
)";
  const std::string msg = Message(linmot);
  EXPECT_THAT(msg,
              HasSubstr("drives[0].node_id: only for CANopen families (stober), not 'linmot'"));
  EXPECT_THAT(msg,
              HasSubstr("drives[0].canopen: only for CANopen families (stober), not 'linmot'"));
}

TEST(StoberConfigTest, KeysOfOtherFamilies_Refused) {
  EXPECT_THAT(Message(With("node_id: 3", "node_id: 3\n    mac_id: 3")),
              HasSubstr("drives[0].mac_id: not used by family stober (a CANopen drive is "
                        "addressed by node_id)"));
  EXPECT_THAT(Message(With("node_id: 3", "node_id: 3\n    linudp: {host: 127.0.0.1}")),
              HasSubstr("drives[0].linudp: not used by family stober"));
  EXPECT_THAT(Message(With("node_id: 3", "node_id: 3\n    trinamic: {serial: {device: /dev/x}}")),
              HasSubstr("drives[0].trinamic: only for family trinamic, not 'stober'"));
  EXPECT_THAT(Message(With("node_id: 3", "node_id: 3\n    nodeid: 4")),
              HasSubstr("drives[0].nodeid: unknown key (did you mean 'node_id'?)"));
}

// ---- canopen ----

TEST(StoberConfigTest, CanOpen_EveryKeyBounded) {
  auto with = [](std::string_view canopen) {
    return With("node_id: 3", absl::StrCat("node_id: 3\n    canopen: ", std::string(canopen)));
  };
  EXPECT_THAT(Message(with("{heartbeat_ms: 0}")),
              HasSubstr("drives[0].canopen.heartbeat_ms: 0 is below 1"));
  EXPECT_THAT(Message(with("{heartbeat_ms: 65536, heartbeat_timeout_ms: 65535}")),
              HasSubstr("drives[0].canopen.heartbeat_ms: 65536 exceeds 65535"));
  EXPECT_THAT(Message(with("{heartbeat_timeout_ms: 70000}")),
              HasSubstr("drives[0].canopen.heartbeat_timeout_ms: 70000 exceeds 65535"));
  EXPECT_THAT(Message(with("{sync_period_ms: 0}")),
              HasSubstr("drives[0].canopen.sync_period_ms: 0 is below 1"));
  EXPECT_THAT(Message(with("{sync_period_ms: 1001}")),
              HasSubstr("drives[0].canopen.sync_period_ms: 1001 exceeds 1000"));
  EXPECT_THAT(Message(with("{sdo_timeout_ms: 10001}")),
              HasSubstr("drives[0].canopen.sdo_timeout_ms: 10001 exceeds 10000"));
  EXPECT_THAT(Message(with("{sdo_timeout_ms: 1s}")),
              HasSubstr("drives[0].canopen.sdo_timeout_ms: '1s' is not an integer"));
  EXPECT_THAT(Message(with("{sdo_retries: 11}")),
              HasSubstr("drives[0].canopen.sdo_retries: 11 exceeds 10"));
  EXPECT_THAT(Message(with("{sdo_retries: -1}")),
              HasSubstr("drives[0].canopen.sdo_retries: -1 is below 0"));
  EXPECT_THAT(Message(with("{sdo_timout_ms: 100}")),
              HasSubstr("drives[0].canopen.sdo_timout_ms: unknown key (did you mean "
                        "'sdo_timeout_ms'?)"));
  EXPECT_THAT(Message(with("[100]")),
              HasSubstr("drives[0].canopen: expected a mapping, got a sequence"));
  EXPECT_TRUE(ParseConfig(with("{heartbeat_ms: 65534, heartbeat_timeout_ms: 65535, "
                               "sync_period_ms: 1000, sdo_timeout_ms: 1}"))
                  .ok());
}

TEST(StoberConfigTest, RpdoTransmissionType_SynchronousOrEventDriven) {
  auto with = [](std::string_view canopen) {
    return With("node_id: 3", absl::StrCat("node_id: 3\n    canopen: ", std::string(canopen)));
  };
  // CiA 301 §7.5.2.35: 0..240 synchronous (applied at the next SYNC), 254/255 event-driven.
  for (int type : {0, 1, 240, 254, 255}) {
    auto cfg = ParseConfig(with(absl::StrCat("{rpdo_transmission_type: ", type, "}")));
    ASSERT_TRUE(cfg.ok()) << type << ": " << cfg.status();
    EXPECT_EQ(cfg->drives[0].canopen.rpdo_transmission_type, type);
  }
  EXPECT_THAT(Message(with("{rpdo_transmission_type: 241}")),
              HasSubstr("drives[0].canopen.rpdo_transmission_type: 241 is reserved; an RPDO is "
                        "synchronous (0..240, applied at the next SYNC) or event-driven (254, "
                        "255)"));
  EXPECT_THAT(Message(with("{rpdo_transmission_type: 252}")),
              HasSubstr("drives[0].canopen.rpdo_transmission_type: 252 is for TPDOs only (RTR)"));
  EXPECT_THAT(Message(with("{rpdo_transmission_type: 256}")),
              HasSubstr("drives[0].canopen.rpdo_transmission_type: 256 exceeds 255"));
  EXPECT_THAT(Message(with("{rpdo_transmission_type: sync}")),
              HasSubstr("drives[0].canopen.rpdo_transmission_type: 'sync' is not an integer"));
  // Drives of one bus may differ: each node's RPDOs are its own; SYNC runs for the bus.
  auto two =
      ParseConfig(PlusDrive("s2", "stober",
                            "    can: {udp: {group: 239.74.163.2, port: 43114}}\n    node_id: 4\n"
                            "    canopen: {rpdo_transmission_type: 1}\n"));
  ASSERT_TRUE(two.ok()) << two.status();
  EXPECT_EQ(two->drives[0].canopen.rpdo_transmission_type, 255);
  EXPECT_EQ(two->drives[1].canopen.rpdo_transmission_type, 1);
}

TEST(StoberConfigTest, HeartbeatTimeout_MustExceedHeartbeat) {
  auto with = [](std::string_view canopen) {
    return With("node_id: 3", absl::StrCat("node_id: 3\n    canopen: ", std::string(canopen)));
  };
  EXPECT_THAT(Message(with("{heartbeat_ms: 200, heartbeat_timeout_ms: 200}")),
              HasSubstr("drives[0].canopen.heartbeat_timeout_ms: 200 must be greater than "
                        "heartbeat_ms 200 (line 7"));
  // Only the producer time given: the default consumer time is named as such.
  EXPECT_THAT(Message(with("{heartbeat_ms: 500}")),
              HasSubstr("drives[0].canopen.heartbeat_timeout_ms: 350 (the default) must be "
                        "greater than heartbeat_ms 500"));
  EXPECT_TRUE(ParseConfig(with("{heartbeat_ms: 200, heartbeat_timeout_ms: 201}")).ok());
  EXPECT_TRUE(ParseConfig(with("{heartbeat_timeout_ms: 101}")).ok());
}

// ---- axis limits on the wire (decision 1172) ----

TEST(StoberConfigTest, AxisLimits_MustFitTheWireTypes) {
  EXPECT_THAT(Message(With("max_mm: 100,", "max_mm: 3000000,")),
              HasSubstr("drives[0].axis.max_mm: 3000000 is beyond the STOBER wire range "
                        "±2147483.647 (INTEGER32 in 0.001 units, decision 1172)"));
  EXPECT_THAT(Message(With("min_mm: -100,", "min_mm: -2147484,")),
              HasSubstr("drives[0].axis.min_mm: -2147484 is beyond"));
  EXPECT_THAT(Message(With("max_velocity_mm_s: 500", "max_velocity_mm_s: 2147484")),
              HasSubstr("drives[0].axis.max_velocity_mm_s: 2147484 is beyond the STOBER "
                        "wire range ±2147483.647"));
  EXPECT_THAT(Message(With("max_acceleration_mm_s2: 5000", "max_acceleration_mm_s2: 4294968")),
              HasSubstr("drives[0].axis.max_acceleration_mm_s2: 4294968 is beyond the "
                        "STOBER wire range 4294967.295 (UNSIGNED32"));
  EXPECT_TRUE(
      ParseConfig(With("min_mm: -100, max_mm: 100,", "min_mm: -2147483.647, max_mm: 2147483.647,"))
          .ok());
}

// ---- between drives ----

TEST(StoberConfigTest, SameNodeIdOnOneBus_NamesBoth_OtherBusFine) {
  const std::string same = PlusDrive("s2", "stober",
                                     "    can: {udp: {group: 239.74.163.2, port: 43114}}\n"
                                     "    node_id: 3\n");
  EXPECT_THAT(Message(same), HasSubstr("drives[1].node_id: 3 is also the node ID of drives[0] on "
                                       "udp:239.74.163.2:43114 (line 11, column 14)"));
  EXPECT_TRUE(ParseConfig(PlusDrive("s2", "stober",
                                    "    can: {udp: {group: 239.74.163.2, port: 43115}}\n"
                                    "    node_id: 3\n"))
                  .ok());
  EXPECT_TRUE(ParseConfig(PlusDrive("s2", "stober",
                                    "    can: {udp: {group: 239.74.163.2, port: 43114}}\n"
                                    "    node_id: 4\n"))
                  .ok());
}

TEST(StoberConfigTest, SyncPeriodDiffersOnOneBus_Refused) {
  const std::string keys =
      "    can: {udp: {group: 239.74.163.2, port: 43114}}\n    node_id: 4\n"
      "    canopen: {sync_period_ms: 4}\n";
  EXPECT_THAT(Message(PlusDrive("s2", "stober", keys)),
              HasSubstr("drives[1].canopen.sync_period_ms: 4 differs from drives[0] (2) on the "
                        "same bus udp:239.74.163.2:43114; the bus's CANopen master has one SYNC "
                        "producer (decision 1116)"));
  // Other timing is per node.
  EXPECT_TRUE(ParseConfig(PlusDrive("s2", "stober",
                                    "    can: {udp: {group: 239.74.163.2, port: 43114}}\n"
                                    "    node_id: 4\n    canopen: {heartbeat_ms: 20, "
                                    "heartbeat_timeout_ms: 80, sdo_timeout_ms: 50}\n"))
                  .ok());
}

// Decision 1483: the gateway's own node ID (its heartbeat 700h + ID) is one per bus and no
// drive's; the refusals name the other drive.
TEST(StoberConfigTest, MasterNodeId_RangeAndCollisionsNamingBoth) {
  const std::string bus = "    can: {udp: {group: 239.74.163.2, port: 43114}}\n";
  EXPECT_THAT(Message(PlusDrive("s2", "stober",
                                bus + "    node_id: 4\n    canopen: {master_node_id: 3}\n")),
              HasSubstr("drives[1].canopen.master_node_id: 3 is the node_id of drives[0] on "
                        "udp:239.74.163.2:43114; the gateway's own node ID must differ"));
  EXPECT_THAT(Message(PlusDrive("s2", "stober",
                                bus + "    node_id: 127\n    canopen: {master_node_id: 126}\n")),
              HasSubstr("drives[1].node_id: 127 is the gateway's own node ID "
                        "(canopen.master_node_id of drives[0]) on udp:239.74.163.2:43114"));
  EXPECT_THAT(Message(PlusDrive("s2", "stober",
                                bus + "    node_id: 4\n    canopen: {master_node_id: 100}\n")),
              HasSubstr("drives[1].canopen.master_node_id: 100 differs from drives[0] (127) on the "
                        "same bus udp:239.74.163.2:43114"));
  const std::string other = "    can: {udp: {group: 239.74.163.2, port: 43115}}\n";
  EXPECT_THAT(Message(PlusDrive("s2", "stober",
                                other + "    node_id: 5\n    canopen: {master_node_id: 5}\n")),
              HasSubstr("drives[1].canopen.master_node_id: 5 is also this drive's node_id"));
  EXPECT_THAT(Message(PlusDrive("s2", "stober",
                                other + "    node_id: 5\n    canopen: {master_node_id: 128}\n")),
              HasSubstr("drives[1].canopen.master_node_id"));
  // Another bus has a master of its own; 0 turns it off there.
  EXPECT_TRUE(ParseConfig(PlusDrive("s2", "stober",
                                    other + "    node_id: 127\n    canopen: {master_node_id: 0}\n"))
                  .ok());
  EXPECT_TRUE(ParseConfig(PlusDrive("s2", "stober", bus + "    node_id: 4\n")).ok());
}

// ---- one protocol per bus (decision 407) ----

TEST(StoberConfigTest, DeviceNetOnTheSameBus_RefusedNamingBoth) {
  // MAC ID 3 = node ID 3 does not matter: any DeviceNet drive on a CANopen bus is refused.
  const std::string msg = Message(PlusDrive("d1", "linmot-devicenet",
                                            "    can: {udp: {group: 239.74.163.2, port: 43114}}\n"
                                            "    mac_id: 3\n"));
  EXPECT_THAT(
      msg, HasSubstr("drives[1].can: udp:239.74.163.2:43114 carries CANopen of drives[0] "
                     "(stober); DeviceNet (linmot-devicenet) cannot share a bus with it, "
                     "their 11-bit CAN identifiers overlap (decision 407) (line 10, column 10)"));
  // The same drive on a bus of its own is fine, whatever its MAC ID.
  EXPECT_TRUE(ParseConfig(PlusDrive("d1", "linmot-devicenet",
                                    "    can: {udp: {group: 239.74.163.2, port: 43113}}\n"
                                    "    mac_id: 3\n"))
                  .ok());
}

TEST(StoberConfigTest, TrinamicCanOnTheSameBus_Refused) {
  const std::string msg = Message(PlusDrive(
      "lift", "trinamic",
      "    trinamic: {can: {udp: {group: 239.74.163.2, port: 43114}}, microsteps_per_unit: 10}\n"));
  EXPECT_THAT(msg, HasSubstr("drives[1].trinamic.can: udp:239.74.163.2:43114 carries CANopen of "
                             "drives[0] (stober); the Trinamic CAN protocol (trinamic) cannot "
                             "share a bus with it"));
  EXPECT_TRUE(ParseConfig(PlusDrive("lift", "trinamic",
                                    "    trinamic: {can: {udp: {group: 239.74.163.2, port: "
                                    "43113}}, microsteps_per_unit: 10}\n"))
                  .ok());
}

TEST(StoberConfigTest, DeviceNetAndTrinamicOnOneBus_AlsoRefused) {
  const std::string yaml = R"(
drives:
  - name: d1
    family: linmot-devicenet
    can: {socketcan: {interface: can0}}
    mac_id: 5
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
  - name: d2
    family: linmot-devicenet
    can: {socketcan: {interface: can0}}
    mac_id: 6
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
  - name: lift
    family: trinamic
    trinamic: {can: {socketcan: {interface: can0}}, microsteps_per_unit: 10}
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
)";
  const std::string msg = Message(yaml);
  EXPECT_THAT(msg, HasSubstr("drives[2].trinamic.can: socketcan:can0 carries DeviceNet of "
                             "drives[0] (linmot-devicenet)"));
  // Two DeviceNet drives on one bus are one protocol.
  EXPECT_THAT(msg, Not(HasSubstr("drives[1].can")));
}

// ---- demo ----

TEST(StoberConfigTest, DemoDrive_NodeThreeOnTheGivenBus_FlinLimits) {
  CanBusConfig bus;
  bus.port = 43200;
  const DriveConfig d = DemoStoberDrive(bus);
  EXPECT_EQ(d.name, "s1");
  EXPECT_EQ(d.family, stober::kFamilyName);
  EXPECT_EQ(d.node_id, std::optional<uint8_t>(3));
  ASSERT_TRUE(d.can.has_value());
  EXPECT_EQ(d.can->port, 43200);
  // F-LIN (stober-motion.md §10.1): I50/I51 ±10000 u, I10 1000 u/s, I11 10000 u/s², 1 u = 1 mm.
  EXPECT_EQ(d.axis.min_mm, -10000);
  EXPECT_EQ(d.axis.max_mm, 10000);
  EXPECT_EQ(d.axis.max_velocity_mm_s, 1000);
  EXPECT_EQ(d.axis.max_acceleration_mm_s2, 10000);
}

}  // namespace
}  // namespace drivegw::config

// ---- one bit rate per bus (decision 805) ----

namespace drivegw::config {
namespace {

TEST(CanBitrateConfigTest, BitrateParsedIntoTheBus) {
  auto cfg = ParseConfig(With("port: 43114}", "port: 43114, bitrate: 500000}"));
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  ASSERT_TRUE(cfg->drives[0].can.has_value());
  EXPECT_EQ(cfg->drives[0].can->bitrate, 500000u);
}

TEST(CanBitrateConfigTest, UnsupportedBitrate_NamesKeyAndValue) {
  const std::string msg = Message(With("port: 43114}", "port: 43114, bitrate: 100000}"));
  EXPECT_THAT(msg, HasSubstr("drives[0].can.udp.bitrate: 100000"));
}

TEST(CanBitrateConfigTest, TwoRatesOnOneBus_RefusedNamingBoth) {
  const std::string msg =
      Message(PlusDrive("s2", "stober",
                        "    can: {udp: {group: 239.74.163.2, port: 43114, bitrate: 250000}}\n"
                        "    node_id: 4\n"));
  EXPECT_THAT(msg, HasSubstr("drives[1].can.udp.bitrate: 250000 bit/s differs from no bitrate "
                             "(unpaced) of drives[0] on udp:239.74.163.2:43114; a bus has one "
                             "bit rate (decision 805)"));
  // The same rate on both drives of the bus is fine.
  const std::string both = absl::StrReplaceAll(
      PlusDrive("s2", "stober",
                "    can: {udp: {group: 239.74.163.2, port: 43114, bitrate: 250000}}\n"
                "    node_id: 4\n"),
      {{"port: 43114}}\n    node_id: 3", "port: 43114, bitrate: 250000}}\n    node_id: 3"}});
  auto cfg = ParseConfig(both);
  EXPECT_TRUE(cfg.ok()) << cfg.status() << "\n" << both;
}

}  // namespace
}  // namespace drivegw::config
