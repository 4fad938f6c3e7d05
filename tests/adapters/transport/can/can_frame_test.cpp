// CanFrame validation and text, CanFilter matching and limits, --can specs, and the SocketCAN
// state/back-off logic that needs no CAN kernel.
#include "adapters/transport/can_frame.h"

#include <linux/can/error.h>

#include <array>
#include <chrono>
#include <vector>

#include "adapters/transport/can_channel.h"
#include "adapters/transport/socketcan_channel.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::transport {
namespace {

using ::testing::HasSubstr;

TEST(CanFrame, MakeCanFrame_CopiesBytesAndSetsDlc) {
  const std::array<uint8_t, 3> bytes{0x01, 0x02, 0x03};
  const CanFrame f = MakeCanFrame(0x123, bytes);
  EXPECT_EQ(f.id, 0x123u);
  EXPECT_FALSE(f.extended);
  EXPECT_EQ(f.dlc, 3);
  EXPECT_THAT(std::vector<uint8_t>(f.payload().begin(), f.payload().end()),
              ::testing::ElementsAre(1, 2, 3));
}

TEST(CanFrame, MakeCanFrame_MoreThanEightBytes_KeepsEight) {
  const std::array<uint8_t, 10> bytes{};
  EXPECT_EQ(MakeCanFrame(0x1, bytes).dlc, 8);
}

TEST(CanFrame, Rtr_HasNoPayload) {
  const CanFrame f = MakeCanRtrFrame(0x7FF, 4);
  EXPECT_TRUE(f.rtr);
  EXPECT_EQ(f.dlc, 4);
  EXPECT_TRUE(f.payload().empty());
  EXPECT_TRUE(ValidateCanFrame(f).ok());
}

TEST(CanFrame, Validate_IdLimitsPerFormat) {
  EXPECT_TRUE(ValidateCanFrame(MakeCanFrame(0x7FF, {})).ok());
  EXPECT_TRUE(ValidateCanFrame(MakeCanFrame(0x1FFFFFFF, {}, true)).ok());
  const absl::Status base = ValidateCanFrame(MakeCanFrame(0x800, {}));
  EXPECT_EQ(base.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(base.message(), "can frame.id: 0x800 exceeds 0x7FF (11-bit base format)");
  const absl::Status ext = ValidateCanFrame(MakeCanFrame(0x20000000, {}, true));
  EXPECT_EQ(ext.message(), "can frame.id: 0x20000000 exceeds 0x1FFFFFFF (29-bit extended format)");
}

TEST(CanFrame, Validate_DlcAboveEight_NamesFieldAndLimit) {
  CanFrame f;
  f.dlc = 9;
  EXPECT_EQ(ValidateCanFrame(f).message(), "can frame.dlc: 9 exceeds 8 (classic CAN)");
}

TEST(CanFrame, Validate_ErrorFrame_CannotBeSent) {
  CanFrame f;
  f.error = true;
  EXPECT_THAT(std::string(ValidateCanFrame(f).message()), HasSubstr("can frame.error"));
}

TEST(CanFrame, Format_CandumpBodies) {
  const std::array<uint8_t, 5> bytes{0x00, 0x4B, 0x03, 0x01, 0x03};
  EXPECT_EQ(FormatCanFrame(MakeCanFrame(0x42E, bytes)), "42E#004B030103");
  EXPECT_EQ(FormatCanFrame(MakeCanFrame(0x5, {})), "005#");
  EXPECT_EQ(FormatCanFrame(MakeCanFrame(0x1ABCDEF0, bytes, true)), "1ABCDEF0#004B030103");
  EXPECT_EQ(FormatCanFrame(MakeCanFrame(0x5, {}, true)), "00000005#");
  EXPECT_EQ(FormatCanFrame(MakeCanRtrFrame(0x123, 0)), "123#R");
  EXPECT_EQ(FormatCanFrame(MakeCanRtrFrame(0x123, 3)), "123#R3");
  CanFrame err;
  err.error = true;
  err.id = CAN_ERR_BUSOFF;
  err.dlc = 8;
  EXPECT_EQ(FormatCanFrame(err), "20000040#0000000000000000");
}

TEST(CanFilter, Matches_IdMaskAndFormat) {
  const CanFilter group2{0x400, 0x600, false};  // DeviceNet group 2 (ids 10xxxxxxxxx)
  EXPECT_TRUE(group2.Matches(MakeCanFrame(0x41C, {})));
  EXPECT_FALSE(group2.Matches(MakeCanFrame(0x21C, {})));
  EXPECT_FALSE(group2.Matches(MakeCanFrame(0x41C, {}, true)));  // other format
  const CanFilter any_ext{0, 0, true};
  EXPECT_TRUE(any_ext.Matches(MakeCanFrame(0x1234567, {}, true)));
  EXPECT_FALSE(any_ext.Matches(MakeCanFrame(0x123, {})));
}

TEST(CanFilter, Validate_LimitsNameIndexAndField) {
  const std::vector<CanFilter> ok{{0x7FF, 0x7FF, false}, {0x1FFFFFFF, 0x1FFFFFFF, true}};
  EXPECT_TRUE(ValidateCanFilters(ok).ok());
  const std::vector<CanFilter> bad_mask{{0x1, 0x7FF, false}, {0x1, 0xFFFF, false}};
  EXPECT_EQ(ValidateCanFilters(bad_mask).message(),
            "can filters[1].mask: 0xFFFF exceeds 0x7FF (11-bit base format)");
  const std::vector<CanFilter> bad_id{{0x20000000, 0, true}};
  EXPECT_EQ(ValidateCanFilters(bad_id).message(),
            "can filters[0].id: 0x20000000 exceeds 0x1FFFFFFF (29-bit extended format)");
  const std::vector<CanFilter> too_many(kMaxCanFilters + 1);
  EXPECT_EQ(ValidateCanFilters(too_many).message(),
            "can filters: 513 filters exceed 512 (CAN_RAW_FILTER_MAX)");
}

TEST(CanBusState, Names) {
  EXPECT_STREQ(CanBusStateName(CanBusState::kActive), "active");
  EXPECT_STREQ(CanBusStateName(CanBusState::kWarning), "warning");
  EXPECT_STREQ(CanBusStateName(CanBusState::kPassive), "passive");
  EXPECT_STREQ(CanBusStateName(CanBusState::kBusOff), "bus-off");
  EXPECT_STREQ(CanBusStateName(CanBusState::kDown), "down");
}

TEST(ParseCanSpec, Socketcan_TakesInterface) {
  auto c = ParseCanSpec("socketcan:vcan0");
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->kind, CanBusConfig::Kind::kSocketCan);
  EXPECT_EQ(c->interface, "vcan0");
  EXPECT_EQ(CanSpecString(*c), "socketcan:vcan0");
}

TEST(ParseCanSpec, Udp_GroupAndPort) {
  auto c = ParseCanSpec("udp:239.1.2.3:5000");
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->kind, CanBusConfig::Kind::kUdpMulticast);
  EXPECT_EQ(c->group, "239.1.2.3");
  EXPECT_EQ(c->port, 5000);
  EXPECT_EQ(CanSpecString(*c), "udp:239.1.2.3:5000");
}

TEST(ParseCanSpec, Udp_DefaultsArePythonCans) {
  auto bare = ParseCanSpec("udp");
  ASSERT_TRUE(bare.ok());
  EXPECT_EQ(CanSpecString(*bare), "udp:239.74.163.2:43113");
  auto group_only = ParseCanSpec("udp:224.0.0.200");
  ASSERT_TRUE(group_only.ok());
  EXPECT_EQ(CanSpecString(*group_only), "udp:224.0.0.200:43113");
}

TEST(ParseCanSpec, Errors_NameTheSpecAndWhat) {
  EXPECT_EQ(ParseCanSpec("udp:10.0.0.1:5000").status().message(),
            "--can 'udp:10.0.0.1:5000': group '10.0.0.1' is not an IPv4 multicast address "
            "(224.0.0.0/4)");
  EXPECT_EQ(ParseCanSpec("udp:239.1.2.3:70000").status().message(),
            "--can 'udp:239.1.2.3:70000': port '70000' is not 1..65535");
  EXPECT_EQ(ParseCanSpec("udp:239.1.2.3:0").status().message(),
            "--can 'udp:239.1.2.3:0': port '0' is not 1..65535");
  EXPECT_EQ(ParseCanSpec("udp:239.1.2.3:").status().message(),
            "--can 'udp:239.1.2.3:': port '' is not 1..65535");
  EXPECT_EQ(ParseCanSpec("socketcan:").status().message(),
            "--can 'socketcan:': socketcan needs an interface: socketcan:IFACE");
  EXPECT_EQ(ParseCanSpec("socketcan:averyveryverylongname").status().message(),
            "--can 'socketcan:averyveryverylongname': interface name exceeds 15 characters "
            "(IFNAMSIZ)");
  EXPECT_EQ(ParseCanSpec("can0").status().message(),
            "--can 'can0': expected socketcan:IFACE or udp:GROUP:PORT[@BITRATE]");
  EXPECT_EQ(ParseCanSpec("").status().code(), absl::StatusCode::kInvalidArgument);
}

CanFrame ErrorFrame(uint32_t cls, uint8_t d1 = 0) {
  CanFrame f;
  f.error = true;
  f.extended = true;
  f.id = cls;
  f.dlc = 8;
  f.data[1] = d1;
  return f;
}

TEST(NextCanBusState, ControllerClasses) {
  EXPECT_EQ(
      NextCanBusState(CanBusState::kActive, ErrorFrame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING)),
      CanBusState::kWarning);
  EXPECT_EQ(
      NextCanBusState(CanBusState::kWarning, ErrorFrame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_PASSIVE)),
      CanBusState::kPassive);
  EXPECT_EQ(NextCanBusState(CanBusState::kPassive, ErrorFrame(CAN_ERR_CRTL, CAN_ERR_CRTL_ACTIVE)),
            CanBusState::kActive);
  EXPECT_EQ(NextCanBusState(CanBusState::kPassive, ErrorFrame(CAN_ERR_BUSOFF)),
            CanBusState::kBusOff);
  EXPECT_EQ(NextCanBusState(CanBusState::kBusOff, ErrorFrame(CAN_ERR_RESTARTED)),
            CanBusState::kActive);
}

TEST(NextCanBusState, BusOff_EndsOnlyByRestart) {
  EXPECT_EQ(
      NextCanBusState(CanBusState::kBusOff, ErrorFrame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING)),
      CanBusState::kBusOff);
  EXPECT_EQ(NextCanBusState(CanBusState::kBusOff, ErrorFrame(CAN_ERR_CRTL, CAN_ERR_CRTL_ACTIVE)),
            CanBusState::kBusOff);
}

TEST(NextCanBusState, DataFramesAndOtherClasses_KeepState) {
  EXPECT_EQ(NextCanBusState(CanBusState::kWarning, MakeCanFrame(0x1, {})), CanBusState::kWarning);
  EXPECT_EQ(NextCanBusState(CanBusState::kActive, ErrorFrame(CAN_ERR_TX_TIMEOUT)),
            CanBusState::kActive);
  EXPECT_EQ(
      NextCanBusState(CanBusState::kActive, ErrorFrame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_OVERFLOW)),
      CanBusState::kActive);
}

TEST(CanBackoff, DoublesToCeilingAndResets) {
  using std::chrono::milliseconds;
  CanBackoff b(milliseconds(100), milliseconds(700));
  EXPECT_EQ(b.Next(), milliseconds(100));
  EXPECT_EQ(b.Next(), milliseconds(200));
  EXPECT_EQ(b.Next(), milliseconds(400));
  EXPECT_EQ(b.Next(), milliseconds(700));
  EXPECT_EQ(b.Next(), milliseconds(700));
  b.Reset();
  EXPECT_EQ(b.Next(), milliseconds(100));
}

TEST(CanBackoff, ZeroInitial_NeverZero) {
  CanBackoff b(std::chrono::milliseconds(0), std::chrono::milliseconds(0));
  EXPECT_GT(b.Next().count(), 0);
}

}  // namespace
}  // namespace drivegw::transport
