// drives[i].trinamic (docs/config.md "trinamic", decision 405): every key applied, every message,
// the rules between axes of one controller, and demo axes that the PACK defaults can drive.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "adapters/core/clock.h"
#include "adapters/trinamic/factory.h"
#include "adapters/trinamic/units.h"
#include "server/config/config.h"

namespace drivegw::config {
namespace {

using std::chrono::milliseconds;
using ::testing::HasSubstr;
using ::testing::Not;

constexpr char kSerialAxis[] = R"(
drives:
  - name: feeder-x
    family: trinamic
    trinamic:
      serial: {device: /dev/ttyUSB0}
      address: 1
      axis: 0
      microsteps_per_unit: 640
    axis: {min_mm: 0, max_mm: 200, max_velocity_mm_s: 40, max_acceleration_mm_s2: 190}
)";

// A second axis appended to kSerialAxis; `trinamic` is its trinamic mapping (flow style).
std::string TwoAxes(std::string_view trinamic) {
  return absl::StrCat(kSerialAxis, R"(  - name: feeder-y
    family: trinamic
    trinamic: )",
                      std::string(trinamic), R"(
    axis: {min_mm: 0, max_mm: 200, max_velocity_mm_s: 40, max_acceleration_mm_s2: 190}
)");
}

std::string With(std::string_view from, std::string_view to) {
  std::string text(kSerialAxis);
  EXPECT_NE(text.find(std::string(from)), std::string::npos) << from;
  return absl::StrReplaceAll(text, {{absl::string_view(from.data(), from.size()),
                                     absl::string_view(to.data(), to.size())}});
}

std::string Message(std::string_view yaml) {
  auto cfg = ParseConfig(yaml);
  EXPECT_FALSE(cfg.ok()) << "parsed unexpectedly:\n" << yaml;
  if (cfg.ok()) return "";
  EXPECT_EQ(cfg.status().code(), absl::StatusCode::kInvalidArgument);
  return std::string(cfg.status().message());
}

// ---- valid examples ----

TEST(TrinamicConfigTest, MinimalSerialAxis_Defaults) {
  auto cfg = ParseConfig(kSerialAxis);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  ASSERT_EQ(cfg->drives.size(), 1u);
  const DriveConfig& d = cfg->drives[0];
  EXPECT_EQ(d.family, "trinamic");
  ASSERT_TRUE(d.trinamic.has_value());
  const TrinamicConfig& t = *d.trinamic;
  ASSERT_TRUE(t.serial.has_value());
  EXPECT_FALSE(t.can.has_value());
  EXPECT_EQ(t.serial->device, "/dev/ttyUSB0");
  EXPECT_EQ(t.serial->baud, 19200);
  EXPECT_FALSE(t.serial->rs485);
  EXPECT_EQ(t.serial->turnaround, std::chrono::microseconds(6000));
  EXPECT_EQ(t.address, 1);
  EXPECT_EQ(t.axis, 0);
  EXPECT_EQ(t.axes, 6);
  EXPECT_DOUBLE_EQ(t.microsteps_per_unit, 640);
  EXPECT_EQ(t.response_address, 0xF0);
  EXPECT_EQ(t.poll_period, milliseconds(20));
  EXPECT_EQ(t.reply_timeout, milliseconds(100));
  EXPECT_EQ(t.offline_after_misses, 3);
  EXPECT_TRUE(t.parameters.empty());
  EXPECT_FALSE(d.can.has_value());
  EXPECT_FALSE(d.linudp.has_value());
}

TEST(TrinamicConfigTest, FullSerialExample_EveryKeyApplied) {
  constexpr char kYaml[] = R"(
drives:
  - name: table-z
    family: trinamic
    trinamic:
      serial:
        device: /dev/ttyUSB1
        baud: 115200
        rs485: true
        turnaround_ms: 4
      address: 3
      axis: 2
      axes: 4
      microsteps_per_unit: 3200.5
      response_address: 200
      poll_ms: 25
      reply_timeout_ms: 80
      offline_after_misses: 4
      parameters:
        "$14.vmax": 300
        $14.amax: 200
        "0x1200": 7
        "$15.motor_type_low": 0xA1
    axis: {kind: rotary, min_mm: 0, max_mm: 360, max_velocity_mm_s: 90, max_acceleration_mm_s2: 400}
)";
  auto cfg = ParseConfig(kYaml);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  const TrinamicConfig& t = *cfg->drives[0].trinamic;
  EXPECT_EQ(t.serial->device, "/dev/ttyUSB1");
  EXPECT_EQ(t.serial->baud, 115200);
  EXPECT_TRUE(t.serial->rs485);
  EXPECT_EQ(t.serial->turnaround, milliseconds(4));
  EXPECT_EQ(t.address, 3);
  EXPECT_EQ(t.axis, 2);
  EXPECT_EQ(t.axes, 4);
  EXPECT_DOUBLE_EQ(t.microsteps_per_unit, 3200.5);
  EXPECT_EQ(t.response_address, 200);
  EXPECT_EQ(t.poll_period, milliseconds(25));
  EXPECT_EQ(t.reply_timeout, milliseconds(80));
  EXPECT_EQ(t.offline_after_misses, 4);
  // Canonical catalogue names, in file order; "0x1200" is the id of $12 P0 = clkdiv.
  using P = std::pair<std::string, int64_t>;
  EXPECT_THAT(t.parameters,
              ::testing::ElementsAre(P{"$14.vmax", 300}, P{"$14.amax", 200}, P{"$12.clkdiv", 7},
                                     P{"$15.motor_type_low", 0xA1}));
}

TEST(TrinamicConfigTest, CanExample_SharedCanKeys) {
  auto cfg = ParseConfig(With("serial: {device: /dev/ttyUSB0}",
                              "can: {udp: {group: 239.1.2.3, port: 5000}, trace: /tmp/t.log}"));
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  const TrinamicConfig& t = *cfg->drives[0].trinamic;
  EXPECT_FALSE(t.serial.has_value());
  ASSERT_TRUE(t.can.has_value());
  EXPECT_EQ(t.can->kind, CanBusConfig::Kind::kUdpMulticast);
  EXPECT_EQ(t.can->group, "239.1.2.3");
  EXPECT_EQ(t.can->port, 5000);
  EXPECT_EQ(t.can->trace_file, "/tmp/t.log");
  EXPECT_FALSE(cfg->drives[0].can.has_value());  // the drive-level key stays unused

  auto sc =
      ParseConfig(With("serial: {device: /dev/ttyUSB0}", "can: {socketcan: {interface: can1}}"));
  ASSERT_TRUE(sc.ok()) << sc.status();
  EXPECT_EQ(sc->drives[0].trinamic->can->kind, CanBusConfig::Kind::kSocketCan);
  EXPECT_EQ(sc->drives[0].trinamic->can->interface, "can1");
}

TEST(TrinamicConfigTest, CanErrors_NamedUnderTrinamic) {
  EXPECT_THAT(Message(With("serial: {device: /dev/ttyUSB0}", "can: {udp: {group: 10.0.0.1}}")),
              HasSubstr("drives[0].trinamic.can.udp.group: '10.0.0.1' is not an IPv4 multicast "
                        "address (224.0.0.0/4)"));
  EXPECT_THAT(Message(With("serial: {device: /dev/ttyUSB0}", "can: {}")),
              HasSubstr("drives[0].trinamic.can: needs exactly one of socketcan, udp"));
  EXPECT_THAT(Message(With("serial: {device: /dev/ttyUSB0}", "can: {socketcan: {}}")),
              HasSubstr("drives[0].trinamic.can.socketcan.interface: required"));
}

// The two examples of docs/config.md "drives[i].trinamic", verbatim: the file loader accepts
// them and so does the family factory (its cross-field parameter rules included).
constexpr char kDocsSerial[] = R"(
drives:
  - name: feeder-x
    family: trinamic
    trinamic:
      serial: {device: /dev/ttyUSB0, baud: 19200}      # rs485: true, turnaround_ms: 6 on RS-485
      address: 1
      axis: 0
      microsteps_per_unit: 640          # 3200 microsteps/rev on a 5 mm lead screw
      parameters:
        "$13.vstart": 8                 # 8 x 64 = 512 >= the amax below (L556)
        "$14.amax": 400
        "$14.vmax": 300
    axis: {min_mm: 0, max_mm: 200, max_velocity_mm_s: 20, max_acceleration_mm_s2: 240}
  - name: feeder-y
    family: trinamic
    trinamic: {serial: {device: /dev/ttyUSB0}, address: 1, axis: 1, microsteps_per_unit: 640}
    axis: {min_mm: 0, max_mm: 200, max_velocity_mm_s: 40, max_acceleration_mm_s2: 190}
)";
constexpr char kDocsCan[] = R"(
drives:
  - name: lift
    family: trinamic
    trinamic:
      can: {udp: {group: 239.74.163.2, port: 43113}}
      address: 2                        # commands on ID 0x010
      response_address: 241             # replies on ID 0x788; one per controller on a bus (1053)
      axis: 3
      axes: 4                           # a QUADpack
      microsteps_per_unit: 8.888889     # 3200 microsteps per 360° = per degree
    axis: {kind: rotary, min_mm: 0, max_mm: 360, max_velocity_mm_s: 90, max_acceleration_mm_s2: 360}
)";

TEST(TrinamicConfigTest, DocsExamples_AcceptedByConfigAndFactory) {
  for (const char* yaml : {kDocsSerial, kDocsCan}) {
    auto cfg = ParseConfig(yaml);
    ASSERT_TRUE(cfg.ok()) << cfg.status() << "\n" << yaml;
    for (const DriveConfig& d : cfg->drives) {
      auto drive = trinamic::CreateTrinamicDrive(d, SteadyClock::Instance());
      EXPECT_TRUE(drive.ok()) << d.name << ": " << drive.status();
    }
  }
  auto cfg = ParseConfig(kDocsSerial);
  ASSERT_TRUE(cfg.ok());
  using P = std::pair<std::string, int64_t>;
  EXPECT_THAT(cfg->drives[0].trinamic->parameters,
              ::testing::ElementsAre(P{"$13.vstart", 8}, P{"$14.amax", 400}, P{"$14.vmax", 300}));
}

TEST(TrinamicConfigTest, LoadConfigFile_ValidAndInvalidTrinamicFiles) {
  std::string dir_template = "/tmp/dgw_trinamic_config_XXXXXX";
  ASSERT_NE(mkdtemp(dir_template.data()), nullptr);
  const std::filesystem::path dir = dir_template;
  const std::string good = (dir / "good.yaml").string();
  const std::string bad = (dir / "bad.yaml").string();
  std::ofstream(good, std::ios::binary) << kDocsSerial;
  std::ofstream(bad, std::ios::binary) << With("axis: 0", "axis: 7");
  auto cfg = LoadConfigFile(good);
  ASSERT_TRUE(cfg.ok()) << cfg.status();
  EXPECT_EQ(cfg->drives.size(), 2u);
  EXPECT_EQ(cfg->source_yaml, kDocsSerial);
  auto err = LoadConfigFile(bad);
  EXPECT_EQ(err.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(err.status().message(),
              HasSubstr(bad + ": drives[0].trinamic.axis: 7 exceeds 5 (a SIXpack has motors "
                              "0..5) (line 8, column 13)"));
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

// Bit flips, deletions and duplications of the docs examples: ParseConfig answers every one
// with a config or InvalidArgument (never a crash, throw or other code), the trinamic checks
// included (config_fuzz's random bytes rarely form a trinamic section).
TEST(TrinamicConfigTest, MutatedExamples_ConfigOrInvalidArgument) {
  std::mt19937 rng(405);
  int parsed = 0;
  for (const char* base : {kDocsSerial, kDocsCan}) {
    for (int i = 0; i < 1500; ++i) {
      std::string text(base);
      const int edits = 1 + static_cast<int>(rng() % 3);
      for (int e = 0; e < edits && !text.empty(); ++e) {
        const size_t at = rng() % text.size();
        switch (rng() % 4) {
          case 0:
            text[at] = static_cast<char>(text[at] ^ (1 << (rng() % 7)));
            break;
          case 1:
            text.erase(at, 1 + rng() % 8);
            break;
          case 2:
            text.insert(at, text.substr(rng() % text.size(), 1 + rng() % 24));
            break;
          default:
            text[at] = "0123456789:{},-[] x$"[rng() % 20];
        }
      }
      auto cfg = ParseConfig(text);
      if (cfg.ok()) {
        ++parsed;
      } else {
        EXPECT_EQ(cfg.status().code(), absl::StatusCode::kInvalidArgument) << text;
      }
    }
  }
  EXPECT_GT(parsed, 0);  // some mutations keep a valid file (comments, values)
}

// ---- messages of the trinamic mapping ----

TEST(TrinamicConfigTest, TrinamicSection_RequiredForFamilyOnlyThere) {
  const std::string none = absl::StrReplaceAll(
      kSerialAxis, {{"    trinamic:\n      serial: {device: /dev/ttyUSB0}\n      address: 1\n"
                     "      axis: 0\n      microsteps_per_unit: 640\n",
                     ""}});
  EXPECT_THAT(Message(none), HasSubstr("drives[0].trinamic: required for family trinamic"));
  const std::string linmot = absl::StrCat(kSerialAxis, R"(  - name: x1
    family: linmot
    linudp: {host: 10.0.0.2}
    trinamic: {serial: {device: /dev/ttyUSB0}, microsteps_per_unit: 1}
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
)");
  EXPECT_THAT(Message(linmot),
              HasSubstr("drives[1].trinamic: only for family trinamic, not 'linmot'"));
}

TEST(TrinamicConfigTest, DriveLevelTransportKeys_Refused) {
  EXPECT_THAT(Message(With("    axis: {", "    can: {udp: {}}\n    axis: {")),
              HasSubstr("drives[0].can: not used by family trinamic (its bus goes under "
                        "trinamic.can)"));
  EXPECT_THAT(Message(With("    axis: {", "    mac_id: 3\n    axis: {")),
              HasSubstr("drives[0].mac_id: not used by family trinamic"));
  EXPECT_THAT(Message(With("    axis: {", "    linudp: {host: 10.0.0.1}\n    axis: {")),
              HasSubstr("drives[0].linudp: not used by family trinamic"));
}

TEST(TrinamicConfigTest, SerialAndCan_ExactlyOne) {
  EXPECT_THAT(Message(With("serial: {device: /dev/ttyUSB0}",
                           "serial: {device: /dev/ttyUSB0}\n      can: {udp: {}}")),
              HasSubstr("drives[0].trinamic: has both serial and can; a controller is driven "
                        "over one of them (G-28)"));
  EXPECT_THAT(Message(With("      serial: {device: /dev/ttyUSB0}\n", "")),
              HasSubstr("drives[0].trinamic: needs exactly one of serial, can"));
  EXPECT_THAT(Message(absl::StrReplaceAll(
                  kSerialAxis, {{"    trinamic:\n      serial: {device: /dev/ttyUSB0}\n      "
                                 "address: 1\n      axis: 0\n      microsteps_per_unit: 640\n",
                                 "    trinamic:\n"}})),
              HasSubstr("drives[0].trinamic: needs exactly one of serial, can"));
  EXPECT_THAT(Message(With("    trinamic:\n      serial", "    trinamic: 5\n    x:\n      serial")),
              HasSubstr("drives[0].trinamic: expected a mapping, got a scalar"));
}

TEST(TrinamicConfigTest, UnknownKey_NamesPathAndSuggests) {
  EXPECT_THAT(Message(With("address: 1", "adress: 1")),
              HasSubstr("drives[0].trinamic.adress: unknown key (did you mean 'address'?)"));
  EXPECT_THAT(Message(With("{device: /dev/ttyUSB0}", "{device: /dev/ttyUSB0, bauds: 9600}")),
              HasSubstr("drives[0].trinamic.serial.bauds: unknown key (did you mean 'baud'?)"));
}

TEST(TrinamicConfigTest, Serial_DeviceBaudRs485Turnaround) {
  EXPECT_THAT(Message(With("{device: /dev/ttyUSB0}", "{baud: 9600}")),
              HasSubstr("drives[0].trinamic.serial.device: required"));
  EXPECT_THAT(Message(With("{device: /dev/ttyUSB0}", "{device: ''}")),
              HasSubstr("drives[0].trinamic.serial.device: must not be empty"));
  EXPECT_THAT(Message(With("{device: /dev/ttyUSB0}", "{device: /dev/ttyUSB0, baud: 12345}")),
              HasSubstr("drives[0].trinamic.serial.baud: 12345 is not a supported rate (1200, "));
  EXPECT_THAT(Message(With("{device: /dev/ttyUSB0}", "{device: /dev/ttyUSB0, baud: fast}")),
              HasSubstr("drives[0].trinamic.serial.baud: 'fast' is not an integer"));
  EXPECT_THAT(Message(With("{device: /dev/ttyUSB0}", "{device: /dev/ttyUSB0, rs485: yes}")),
              HasSubstr("drives[0].trinamic.serial.rs485: 'yes' is not true or false"));
  EXPECT_THAT(Message(With("{device: /dev/ttyUSB0}", "{device: /dev/ttyUSB0, turnaround_ms: 1}")),
              HasSubstr("drives[0].trinamic.serial.turnaround_ms: 1 is below 2"));
  EXPECT_THAT(
      Message(With("{device: /dev/ttyUSB0}", "{device: /dev/ttyUSB0, turnaround_ms: 2001}")),
      HasSubstr("drives[0].trinamic.serial.turnaround_ms: 2001 exceeds 2000"));
  EXPECT_TRUE(
      ParseConfig(With("{device: /dev/ttyUSB0}", "{device: /dev/ttyUSB0, baud: 9600}")).ok());
}

TEST(TrinamicConfigTest, Address_1To255WithPosition) {
  EXPECT_THAT(Message(With("address: 1", "address: 0")),
              HasSubstr("drives[0].trinamic.address: 0 is below 1 (line 7, column 16)"));
  EXPECT_THAT(Message(With("address: 1", "address: 256")),
              HasSubstr("drives[0].trinamic.address: 256 exceeds 255"));
  EXPECT_TRUE(ParseConfig(With("address: 1", "address: 255")).ok());
}

TEST(TrinamicConfigTest, AxisAndAxes_MotorsOfTheVariant) {
  EXPECT_THAT(Message(With("axis: 0", "axis: 7")),
              HasSubstr("drives[0].trinamic.axis: 7 exceeds 5 (a SIXpack has motors 0..5)"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 4\n      axes: 4")),
              HasSubstr("drives[0].trinamic.axis: 4 exceeds 3 (a QUADpack has motors 0..3)"));
  EXPECT_THAT(Message(With("axis: 0", "axis: -1")),
              HasSubstr("drives[0].trinamic.axis: -1 is below 0"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      axes: 5")),
              HasSubstr("drives[0].trinamic.axes: 5 is not 6 (SIXpack) or 4 (QUADpack)"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      axes: 8")),
              HasSubstr("drives[0].trinamic.axes: 8 exceeds 6"));
  EXPECT_TRUE(ParseConfig(With("axis: 0", "axis: 5")).ok());
  EXPECT_TRUE(ParseConfig(With("axis: 0", "axis: 3\n      axes: 4")).ok());
}

TEST(TrinamicConfigTest, MicrostepsPerUnit_RequiredPositiveInt32Range) {
  EXPECT_THAT(Message(With("      microsteps_per_unit: 640\n", "")),
              HasSubstr("drives[0].trinamic.microsteps_per_unit: required"));
  EXPECT_THAT(Message(With("microsteps_per_unit: 640", "microsteps_per_unit: 0")),
              HasSubstr("drives[0].trinamic.microsteps_per_unit: 0 must be greater than 0"));
  EXPECT_THAT(Message(With("microsteps_per_unit: 640", "microsteps_per_unit: -3")),
              HasSubstr("drives[0].trinamic.microsteps_per_unit: -3 must be greater than 0"));
  EXPECT_THAT(Message(With("microsteps_per_unit: 640", "microsteps_per_unit: .nan")),
              HasSubstr("drives[0].trinamic.microsteps_per_unit: '.nan' is not a finite number"));
  // 200 mm x 2e7 = 4e9 microsteps: beyond the PACK's int32 position (§5.2).
  EXPECT_THAT(Message(With("microsteps_per_unit: 640", "microsteps_per_unit: 20000000")),
              HasSubstr("drives[0].trinamic.microsteps_per_unit: 2e+07 puts axis.max_mm 200 at "
                        "4e+09 microsteps, beyond the int32 position range (2147483647)"));
  EXPECT_TRUE(ParseConfig(With("microsteps_per_unit: 640", "microsteps_per_unit: 10000000")).ok());
}

TEST(TrinamicConfigTest, ResponseAddress_RangeAndNotOwnAddress) {
  EXPECT_THAT(Message(With("address: 1", "address: 1\n      response_address: 0")),
              HasSubstr("drives[0].trinamic.response_address: 0 is below 1"));
  EXPECT_THAT(Message(With("address: 1", "address: 1\n      response_address: 300")),
              HasSubstr("drives[0].trinamic.response_address: 300 exceeds 255"));
  // 0x20 is the `$20` reply opcode: R8 and R9 replies would look alike (decision 1011).
  EXPECT_THAT(Message(With("address: 1", "address: 1\n      response_address: 32")),
              HasSubstr("drives[0].trinamic.response_address: 0x20 equals a reply opcode"));
  EXPECT_THAT(Message(With("address: 1", "address: 7\n      response_address: 7")),
              HasSubstr("drives[0].trinamic.response_address: 7 equals address; replies must go "
                        "to another address (CT-50)"));
}

TEST(TrinamicConfigTest, ResponseAddress_NotAnotherControllersAddress) {
  const std::string yaml =
      TwoAxes("{serial: {device: /dev/ttyUSB0}, address: 240, axis: 0, microsteps_per_unit: 640}");
  EXPECT_THAT(Message(yaml),
              HasSubstr("drives[0].trinamic.response_address: 240 is the address of drives[1]'s "
                        "controller on serial:/dev/ttyUSB0; replies must go to an address no "
                        "controller uses (CT-50)"));
  // Another line: no conflict.
  EXPECT_TRUE(ParseConfig(TwoAxes("{serial: {device: /dev/ttyUSB1}, address: 240, axis: 0, "
                                  "microsteps_per_unit: 640}"))
                  .ok());
}

TEST(TrinamicConfigTest, Timing_Ranges) {
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      poll_ms: 0")),
              HasSubstr("drives[0].trinamic.poll_ms: 0 is below 1"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      poll_ms: 1001")),
              HasSubstr("drives[0].trinamic.poll_ms: 1001 exceeds 1000"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      reply_timeout_ms: 10001")),
              HasSubstr("drives[0].trinamic.reply_timeout_ms: 10001 exceeds 10000"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      offline_after_misses: 0")),
              HasSubstr("drives[0].trinamic.offline_after_misses: 0 is below 1"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      offline_after_misses: 1001")),
              HasSubstr("drives[0].trinamic.offline_after_misses: 1001 exceeds 1000"));
}

// ---- parameters ----

TEST(TrinamicConfigTest, Parameters_NamesMustExist) {
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      parameters: {\"$14.vmux\": 300}")),
              HasSubstr("drives[0].trinamic.parameters.$14.vmux: unknown parameter (did you "
                        "mean '$14.vmax'?)"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      parameters: {speed: 300}")),
              HasSubstr("drives[0].trinamic.parameters.speed: unknown parameter (names are "
                        "\"$<opcode>.<field>\", e.g. \"$14.vmax\")"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      parameters: {\"$23.vmax\": 1}")),
              HasSubstr("drives[0].trinamic.parameters.$23.vmax: unknown parameter"));
}

TEST(TrinamicConfigTest, Parameters_ValuesInFieldRange) {
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      parameters: {\"$14.vmax\": 600}")),
              HasSubstr("drives[0].trinamic.parameters.$14.vmax: 600 exceeds 511"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      parameters: {\"$14.amax\": 0}")),
              HasSubstr("drives[0].trinamic.parameters.$14.amax: 0 is below 1"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      parameters: {\"$12.clkdiv\": 2.5}")),
              HasSubstr("drives[0].trinamic.parameters.$12.clkdiv: '2.5' is not an integer"));
  EXPECT_THAT(Message(With("axis: 0", "axis: 0\n      parameters: [\"$14.vmax\"]")),
              HasSubstr("drives[0].trinamic.parameters: expected a mapping of parameter name to "
                        "value ({\"$14.vmax\": 300}), got a sequence"));
}

TEST(TrinamicConfigTest, Parameters_SameParameterTwice) {
  EXPECT_THAT(
      Message(With("axis: 0", "axis: 0\n      parameters: {\"$14.vmax\": 300, \"0x1403\": 200}")),
      HasSubstr("drives[0].trinamic.parameters.0x1403: is the same parameter as "
                "drives[0].trinamic.parameters.$14.vmax"));
  EXPECT_THAT(
      Message(With("axis: 0", "axis: 0\n      parameters: {\"$14.vmax\": 300, \"$14.VMAX\": 2}")),
      HasSubstr("is the same parameter as drives[0].trinamic.parameters.$14.vmax"));
}

// ---- axes of one controller ----

TEST(TrinamicConfigTest, SameMotorTwice_NamesBothDrives) {
  EXPECT_THAT(
      Message(TwoAxes("{serial: {device: /dev/ttyUSB0}, axis: 0, microsteps_per_unit: 640}")),
      HasSubstr("drives[1].trinamic.axis: 0 is also the axis of drives[0] (address 1 on "
                "serial:/dev/ttyUSB0)"));
  EXPECT_THAT(
      Message(absl::StrCat(With("serial: {device: /dev/ttyUSB0}", "can: {udp: {}}"), R"(  - name: b
    family: trinamic
    trinamic: {can: {udp: {port: 43113}}, address: 1, axis: 0, microsteps_per_unit: 1}
    axis: {min_mm: 0, max_mm: 1, max_velocity_mm_s: 1, max_acceleration_mm_s2: 1}
)")),
      HasSubstr("drives[1].trinamic.axis: 0 is also the axis of drives[0] (address 1 on "
                "udp:239.74.163.2:43113)"));
  // Another motor, another address or another line: fine.
  for (const char* ok :
       {"{serial: {device: /dev/ttyUSB0}, axis: 1, microsteps_per_unit: 640}",
        "{serial: {device: /dev/ttyUSB0}, address: 2, axis: 0, microsteps_per_unit: 640}",
        "{serial: {device: /dev/ttyUSB1}, axis: 0, microsteps_per_unit: 640}",
        "{can: {udp: {}}, axis: 0, microsteps_per_unit: 640}"}) {
    auto cfg = ParseConfig(TwoAxes(ok));
    EXPECT_TRUE(cfg.ok()) << ok << ": " << cfg.status();
  }
}

TEST(TrinamicConfigTest, OneController_AgreesOnVariantSessionAndControllerParameters) {
  EXPECT_THAT(Message(TwoAxes("{serial: {device: /dev/ttyUSB0}, axis: 1, axes: 4, "
                              "microsteps_per_unit: 640}")),
              HasSubstr("drives[1].trinamic.axes: 4 differs from drives[0] (6) on the same "
                        "controller (address 1 on serial:/dev/ttyUSB0)"));
  EXPECT_THAT(Message(TwoAxes("{serial: {device: /dev/ttyUSB0}, axis: 1, response_address: 200, "
                              "microsteps_per_unit: 640}")),
              HasSubstr("drives[1].trinamic.response_address: 200 differs from drives[0] (240)"));
  EXPECT_THAT(Message(TwoAxes("{serial: {device: /dev/ttyUSB0}, axis: 1, offline_after_misses: 9, "
                              "microsteps_per_unit: 640}")),
              HasSubstr("drives[1].trinamic.offline_after_misses: 9 differs from drives[0] (3)"));
  // $12 clkdiv is one value per PACK; $14 vmax is per motor.
  const std::string first =
      With("axis: 0", "axis: 0\n      parameters: {\"$12.clkdiv\": 5, \"$14.vmax\": 500}");
  auto two = [&](std::string_view params) {
    return absl::StrCat(first, R"(  - name: feeder-y
    family: trinamic
    trinamic: {serial: {device: /dev/ttyUSB0}, axis: 1, microsteps_per_unit: 640, parameters: )",
                        std::string(params), R"(}
    axis: {min_mm: 0, max_mm: 200, max_velocity_mm_s: 40, max_acceleration_mm_s2: 190}
)");
  };
  EXPECT_THAT(Message(two("{\"$12.clkdiv\": 7}")),
              HasSubstr("drives[1].trinamic.parameters.$12.clkdiv: 7 differs from drives[0] (5): "
                        "a controller-wide parameter (address 1 on serial:/dev/ttyUSB0)"));
  auto fine = ParseConfig(two("{\"$12.clkdiv\": 5, \"$14.vmax\": 300}"));
  EXPECT_TRUE(fine.ok()) << fine.status();
}

TEST(TrinamicConfigTest, OneSerialLine_OneLineSetting) {
  const std::string yaml = TwoAxes(
      "{serial: {device: /dev/ttyUSB0, baud: 9600, rs485: true, turnaround_ms: 10}, address: 2, "
      "axis: 0, microsteps_per_unit: 640}");
  const std::string m = Message(yaml);
  EXPECT_THAT(m, HasSubstr("drives[1].trinamic.serial.baud: 9600 differs from drives[0] (19200) "
                           "on the same line /dev/ttyUSB0"));
  EXPECT_THAT(m, HasSubstr("drives[1].trinamic.serial.rs485: true differs from drives[0] (false)"));
  EXPECT_THAT(m,
              HasSubstr("drives[1].trinamic.serial.turnaround_ms: 10 differs from drives[0] (6)"));
  EXPECT_THAT(m, Not(HasSubstr("is also the axis")));
}

// ---- demo axes ----

TEST(TrinamicDemoDrivesTest, TwoFeederAxesReachableWithPackDefaults) {
  const auto drives = DemoTrinamicDrives("/tmp/data/trinamic-demo.pty");
  ASSERT_EQ(drives.size(), 2u);
  EXPECT_EQ(drives[0].name, "feeder-x");
  EXPECT_EQ(drives[1].name, "feeder-y");
  for (size_t i = 0; i < drives.size(); ++i) {
    const DriveConfig& d = drives[i];
    EXPECT_EQ(d.family, "trinamic");
    ASSERT_TRUE(d.trinamic.has_value());
    const TrinamicConfig& t = *d.trinamic;
    ASSERT_TRUE(t.serial.has_value());
    EXPECT_EQ(t.serial->device, "/tmp/data/trinamic-demo.pty");
    EXPECT_EQ(t.serial->baud, 19200);
    EXPECT_EQ(t.address, 1);
    EXPECT_EQ(t.axis, i);
    EXPECT_EQ(t.axes, 6);
    EXPECT_DOUBLE_EQ(t.microsteps_per_unit, 640);
    // Reset defaults (§5.12): clkdiv 5, div 2, vstart 5 -> vmax <= 511, amax <= 5 x 64 (L556).
    const trinamic::VelocityScale defaults;
    auto vmax = trinamic::MmPerSecondToVelocity(d.axis.max_velocity_mm_s, defaults, 640);
    ASSERT_TRUE(vmax.ok()) << vmax.status();
    EXPECT_LE(*vmax, 511);
    auto amax = trinamic::MmPerSecond2ToAmax(d.axis.max_acceleration_mm_s2, defaults, 640);
    ASSERT_TRUE(amax.ok()) << amax.status();
    EXPECT_LE(*amax, 5 * 64);
    auto end = trinamic::MmToMicrosteps(d.axis.max_mm, 640);
    ASSERT_TRUE(end.ok()) << end.status();
    EXPECT_EQ(*end, 128000);
    auto drive = trinamic::CreateTrinamicDrive(d, SteadyClock::Instance());
    EXPECT_TRUE(drive.ok()) << d.name << ": " << drive.status();
  }
}

}  // namespace
}  // namespace drivegw::config
