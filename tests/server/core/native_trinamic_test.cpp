// DriveServiceCore::SendNativeCommand and parameter ids for the Trinamic family: the instruction
// reaches the drive as on the wire, the reply body comes back as bytes, and every refusal names
// the field and the limit (trinamic-sixpack.md §2.3, §3.5, §4.1).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <variant>

#include "absl/strings/str_cat.h"
#include "server/core/drive_service.h"
#include "tests/server/core/core_test_support.h"

namespace drivegw::server {
namespace {

using test_support::FakeDrive;
using test_support::FakeFleet;
using test_support::ViolationField;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

v1::SendNativeCommandRequest Instruction(const std::string& drive, uint32_t opcode,
                                         std::string params) {
  v1::SendNativeCommandRequest r;
  r.set_name(drive);
  r.mutable_trinamic()->set_opcode(opcode);
  r.mutable_trinamic()->set_params(std::move(params));
  return r;
}

v1::SendNativeCommandRequest Tunnel(const std::string& drive, std::string data) {
  v1::SendNativeCommandRequest r;
  r.set_name(drive);
  r.mutable_trinamic_tunnel()->set_data(std::move(data));
  return r;
}

DriveConfig TrinamicOn(std::string name, bool can) {
  DriveConfig c = FakeDrive::Config(std::move(name), "trinamic");
  TrinamicConfig t;
  if (can) {
    t.can = CanBusConfig{};
  } else {
    t.serial = SerialLineConfig{"/dev/ttyS0"};
  }
  c.trinamic = t;
  return c;
}

class NativeTrinamicTest : public ::testing::Test {
 protected:
  NativeTrinamicTest()
      : serial_(fleet_.AddConfig(TrinamicOn("tmc-serial", false), true)),
        can_(fleet_.AddConfig(TrinamicOn("tmc-can", true), true)),
        lin_(fleet_.Add("lin1", "linmot", false)),
        core_(fleet_.drives(), nullptr) {}

  absl::StatusOr<v1::NativeCommandResponse> Send(const v1::SendNativeCommandRequest& r) {
    return core_.SendNativeCommand(r, CallContext{});
  }

  FakeFleet fleet_;
  FakeDrive& serial_;
  FakeDrive& can_;
  FakeDrive& lin_;
  DriveServiceCore core_;
};

// $20 query position of motor 2 (§4.2 $20): P0 = motnr, P1 = RA.
const std::string kQuery20("\x02\xF0\x00\x00\x00\x00\x00", 7);

TEST_F(NativeTrinamicTest, Query_ReachesDriveAsOnTheWire_ReplyBodyReturnedAsBytes) {
  NativeReply reply;
  reply.data = {0x20, 0x02, 0x2E, 0xFB, 0xFF, 0xFF, 0x00, 0x00};  // §6.3: motor 2 at -1234
  serial_.SetNativeReply(reply);
  auto resp = Send(Instruction("drives/tmc-serial", 0x20, kQuery20));
  ASSERT_TRUE(resp.ok()) << resp.status();
  auto sent = serial_.native();
  ASSERT_TRUE(sent.has_value());
  const auto* req = std::get_if<TrinamicRequest>(&*sent);
  ASSERT_NE(req, nullptr);
  EXPECT_EQ(req->opcode, 0x20);
  EXPECT_THAT(req->params, ElementsAre(0x02, 0xF0, 0, 0, 0, 0, 0));
  EXPECT_EQ(resp->name(), "drives/tmc-serial");
  EXPECT_EQ(resp->reply(), std::string("\x20\x02\x2E\xFB\xFF\xFF\x00\x00", 8));
  EXPECT_FALSE(resp->has_command());
}

TEST_F(NativeTrinamicTest, SilentInstruction_EmptyReply) {
  // $23 start ramp of motor 0 to 1000 (§6.2 style): no reply body (§2.4).
  auto resp = Send(Instruction("tmc-serial", 0x23, std::string("\x00\xE8\x03\x00\x00\x00\x00", 7)));
  ASSERT_TRUE(resp.ok()) << resp.status();
  EXPECT_TRUE(resp->reply().empty());
}

TEST_F(NativeTrinamicTest, OpcodeAbove255_InvalidArgument) {
  auto resp = Send(Instruction("tmc-serial", 256, kQuery20));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "trinamic.opcode");
  EXPECT_THAT(resp.status().message(), HasSubstr("256 exceeds 255"));
  EXPECT_EQ(serial_.calls(), 0);
}

TEST_F(NativeTrinamicTest, ServiceOpcodes_RefusedNamingTheRange) {
  for (uint32_t op : {0xF2u, 0xF4u, 0xF7u}) {
    auto resp = Send(Instruction("tmc-serial", op, kQuery20));
    EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument) << op;
    EXPECT_EQ(ViolationField(resp.status()), "trinamic.opcode");
    EXPECT_THAT(resp.status().message(), HasSubstr("service function ($F2..$F7)"));
  }
  EXPECT_THAT(std::string(Send(Instruction("tmc-serial", 0xF4, kQuery20)).status().message()),
              HasSubstr("($F4)"));
  EXPECT_EQ(serial_.calls(), 0);
  // Neighbours of the range are ordinary opcodes as far as the core is concerned.
  EXPECT_TRUE(Send(Instruction("tmc-serial", 0xF1, kQuery20)).ok());
  EXPECT_TRUE(Send(Instruction("tmc-serial", 0xF8, kQuery20)).ok());
}

TEST_F(NativeTrinamicTest, ParamsNotSevenBytes_InvalidArgumentNamingTheCount) {
  for (size_t n : {0u, 6u, 8u}) {
    auto resp = Send(Instruction("tmc-serial", 0x20, std::string(n, '\0')));
    EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument) << n;
    EXPECT_EQ(ViolationField(resp.status()), "trinamic.params");
    EXPECT_THAT(resp.status().message(),
                HasSubstr(absl::StrCat(n, " bytes; exactly 7 are required")));
  }
  EXPECT_EQ(serial_.calls(), 0);
}

TEST_F(NativeTrinamicTest, Tunnel_OnCan_ReachesDrive) {
  auto resp = Send(Tunnel("tmc-can", "AT\r"));
  ASSERT_TRUE(resp.ok()) << resp.status();
  auto sent = can_.native();
  ASSERT_TRUE(sent.has_value());
  const auto* t = std::get_if<TrinamicTunnelRequest>(&*sent);
  ASSERT_NE(t, nullptr);
  EXPECT_THAT(t->data, ElementsAre('A', 'T', '\r'));
}

TEST_F(NativeTrinamicTest, Tunnel_EightBytes_Accepted_NineRefused) {
  EXPECT_TRUE(Send(Tunnel("tmc-can", std::string(8, 'x'))).ok());
  auto resp = Send(Tunnel("tmc-can", std::string(9, 'x')));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "trinamic_tunnel.data");
  EXPECT_THAT(resp.status().message(), HasSubstr("9 bytes exceed 8"));
}

TEST_F(NativeTrinamicTest, Tunnel_Empty_InvalidArgument) {
  auto resp = Send(Tunnel("tmc-can", ""));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "trinamic_tunnel.data");
  EXPECT_THAT(resp.status().message(), HasSubstr("is empty; 1..8 bytes"));
}

TEST_F(NativeTrinamicTest, Tunnel_OnSerialDrive_FailedPrecondition) {
  auto resp = Send(Tunnel("tmc-serial", "AT"));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(ViolationField(resp.status()), "trinamic_tunnel");
  EXPECT_THAT(resp.status().message(), HasSubstr("needs a drive on a CAN bus"));
  EXPECT_EQ(serial_.calls(), 0);
}

TEST_F(NativeTrinamicTest, TrinamicCommandToLinMotDrive_RefusedByFamily) {
  auto resp = Send(Instruction("lin1", 0x20, kQuery20));
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "trinamic");
  EXPECT_THAT(resp.status().message(), HasSubstr("is a trinamic command; drive family is linmot"));
  auto tunnel = Send(Tunnel("lin1", "AT"));
  EXPECT_EQ(ViolationField(tunnel.status()), "trinamic_tunnel");
  EXPECT_EQ(lin_.calls(), 0);
}

TEST_F(NativeTrinamicTest, LinMotCommandToTrinamicDrive_RefusedByFamily) {
  v1::SendNativeCommandRequest r;
  r.set_name("tmc-serial");
  r.mutable_linmot_rtc()->set_command_id(1);
  auto resp = Send(r);
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(resp.status()), "linmot_rtc");
  EXPECT_THAT(resp.status().message(), HasSubstr("drive family is trinamic"));
}

TEST_F(NativeTrinamicTest, NoCommand_ListsTheTrinamicFields) {
  v1::SendNativeCommandRequest r;
  r.set_name("tmc-serial");
  auto resp = Send(r);
  EXPECT_EQ(ViolationField(resp.status()), "command");
  EXPECT_THAT(resp.status().message(), HasSubstr("trinamic, trinamic_tunnel"));
}

TEST_F(NativeTrinamicTest, ParameterId_OpcodeAndPIndex_ReachesDrive) {
  v1::ReadParameterRequest r;
  r.set_name("tmc-serial");
  r.set_parameter_id(0x1403);  // $14.vmax
  auto p = core_.ReadParameter(r, {});
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(serial_.parameter_id(), 0x1403u);
  EXPECT_EQ(p->value(), 42);
}

TEST_F(NativeTrinamicTest, ParameterId_PIndexAbove6_InvalidArgument) {
  v1::WriteParameterRequest r;
  r.set_name("tmc-serial");
  r.set_parameter_id(0x1407);
  auto p = core_.WriteParameter(r, {});
  EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(p.status()), "write_parameter.parameter_id");
  EXPECT_THAT(p.status().message(), HasSubstr("P-index 7 exceeds 6"));
  EXPECT_FALSE(serial_.parameter_id().has_value());
}

TEST_F(NativeTrinamicTest, ParameterId_Above16Bit_InvalidArgument) {
  v1::ReadParameterRequest r;
  r.set_name("tmc-serial");
  r.set_parameter_id(0x11403);
  auto p = core_.ReadParameter(r, {});
  EXPECT_EQ(ViolationField(p.status()), "read_parameter.parameter_id");
  EXPECT_THAT(p.status().message(), HasSubstr("exceeds 65535"));
}

}  // namespace
}  // namespace drivegw::server
