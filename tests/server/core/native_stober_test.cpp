// DriveServiceCore::SendNativeCommand for the STOBER family: the motion-core command (I401 and
// its set values) and raw CANopen SDO reach the drive unchanged, the uploaded bytes come back as
// `reply`, and every refusal names the field and the limit (stober-motion.md §1.1, §3.2;
// decision 1103). Parameter ids are CANopen index << 8 | subindex.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
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

v1::SendNativeCommandRequest Mc(const std::string& drive, v1::StoberCommand command) {
  v1::SendNativeCommandRequest r;
  r.set_name(drive);
  r.mutable_stober()->set_command(command);
  return r;
}

v1::SendNativeCommandRequest Sdo(const std::string& drive, uint32_t index, uint32_t sub, bool write,
                                 std::string data) {
  v1::SendNativeCommandRequest r;
  r.set_name(drive);
  auto* s = r.mutable_canopen_sdo();
  s->set_index(index);
  s->set_sub_index(sub);
  s->set_write(write);
  s->set_data(std::move(data));
  return r;
}

class NativeStoberTest : public ::testing::Test {
 protected:
  NativeStoberTest()
      : st_(fleet_.Add("st1", "stober", false)),
        tmc_(fleet_.Add("tmc", "trinamic", true)),
        core_(fleet_.drives(), nullptr) {}

  absl::StatusOr<v1::NativeCommandResponse> Send(const v1::SendNativeCommandRequest& r) {
    return core_.SendNativeCommand(r, CallContext{});
  }

  FakeFleet fleet_;
  FakeDrive& st_;
  FakeDrive& tmc_;
  DriveServiceCore core_;
};

TEST_F(NativeStoberTest, MoveAbsolute_EveryValueReachesDrive_EnumValueIsI401) {
  v1::SendNativeCommandRequest r = Mc("drives/st1", v1::MC_MOVE_ABSOLUTE);
  auto* c = r.mutable_stober();
  c->set_position_mm(12.5);
  c->set_velocity_mm_s(100);
  c->set_acceleration_mm_s2(1000);
  c->set_deceleration_mm_s2(800);
  c->set_jerk_mm_s3(50000);
  c->set_direction(2);
  c->set_torque_percent(-30);
  c->set_motion_id(77);
  auto resp = Send(r);
  ASSERT_TRUE(resp.ok()) << resp.status();
  auto sent = st_.native();
  ASSERT_TRUE(sent.has_value());
  const auto* mc = std::get_if<StoberMcRequest>(&*sent);
  ASSERT_NE(mc, nullptr);
  EXPECT_EQ(mc->command, 1);
  EXPECT_EQ(mc->position_mm, 12.5);
  EXPECT_EQ(mc->velocity_mm_s, 100);
  EXPECT_EQ(mc->acceleration_mm_s2, 1000);
  EXPECT_EQ(mc->deceleration_mm_s2, 800);
  EXPECT_EQ(mc->jerk_mm_s3, 50000);
  EXPECT_EQ(mc->direction, 2);
  EXPECT_EQ(mc->torque_percent, -30);
  EXPECT_EQ(mc->motion_id, 77u);
  EXPECT_EQ(resp->name(), "drives/st1");
}

TEST_F(NativeStoberTest, EnumNumbering_FollowsTheReference) {
  // stober-motion.md §1.1: 0 DoNothing, 7 CyclicSpeed, 10 CyclicPosition, 11 Halt.
  EXPECT_EQ(v1::MC_DO_NOTHING, 0);
  EXPECT_EQ(v1::MC_MOVE_ADDITIVE, 3);
  EXPECT_EQ(v1::MC_HOME, 6);
  EXPECT_EQ(v1::MC_CYCLIC_SPEED, 7);
  EXPECT_EQ(v1::MC_TORQUE_CONTROL, 9);
  EXPECT_EQ(v1::MC_CYCLIC_POSITION, 10);
  EXPECT_EQ(v1::MC_HALT, 11);
  ASSERT_TRUE(Send(Mc("st1", v1::MC_HALT)).ok());
  EXPECT_EQ(std::get<StoberMcRequest>(*st_.native()).command, 11);
}

TEST_F(NativeStoberTest, CommandOutsideZeroToEleven_InvalidArgument) {
  for (int n : {12, 255, -1}) {
    auto resp = Send(Mc("st1", static_cast<v1::StoberCommand>(n)));
    EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument) << n;
    EXPECT_EQ(ViolationField(resp.status()), "stober.command");
    EXPECT_THAT(resp.status().message(),
                HasSubstr(absl::StrCat(n, " is not a motion-core command 0..11 (I401")));
  }
  EXPECT_EQ(st_.calls(), 0);
}

TEST_F(NativeStoberTest, NonFiniteValue_NamesTheField) {
  struct Case {
    void (v1::StoberMotionCommand::*set)(double);
    const char* field;
  };
  const Case cases[] = {
      {&v1::StoberMotionCommand::set_position_mm, "stober.position_mm"},
      {&v1::StoberMotionCommand::set_velocity_mm_s, "stober.velocity_mm_s"},
      {&v1::StoberMotionCommand::set_acceleration_mm_s2, "stober.acceleration_mm_s2"},
      {&v1::StoberMotionCommand::set_deceleration_mm_s2, "stober.deceleration_mm_s2"},
      {&v1::StoberMotionCommand::set_jerk_mm_s3, "stober.jerk_mm_s3"},
      {&v1::StoberMotionCommand::set_torque_percent, "stober.torque_percent"},
  };
  for (const Case& c : cases) {
    for (double bad : {std::nan(""), std::numeric_limits<double>::infinity()}) {
      v1::SendNativeCommandRequest r = Mc("st1", v1::MC_MOVE_RELATIVE);
      (r.mutable_stober()->*c.set)(bad);
      auto resp = Send(r);
      EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument) << c.field;
      EXPECT_EQ(ViolationField(resp.status()), c.field);
      EXPECT_THAT(resp.status().message(), HasSubstr("is not a finite number"));
    }
  }
  EXPECT_EQ(st_.calls(), 0);
}

TEST_F(NativeStoberTest, DirectionAbove3_AndMotionIdAbove31Bit_Refused) {
  v1::SendNativeCommandRequest r = Mc("st1", v1::MC_MOVE_ABSOLUTE);
  r.mutable_stober()->set_direction(3);
  EXPECT_TRUE(Send(r).ok());
  r.mutable_stober()->set_direction(4);
  auto dir = Send(r);
  EXPECT_EQ(ViolationField(dir.status()), "stober.direction");
  EXPECT_THAT(dir.status().message(), HasSubstr("4 exceeds 3 (I411"));
  r.mutable_stober()->set_direction(0);
  r.mutable_stober()->set_motion_id(2147483647u);
  EXPECT_TRUE(Send(r).ok());
  r.mutable_stober()->set_motion_id(2147483648u);
  auto id = Send(r);
  EXPECT_EQ(ViolationField(id.status()), "stober.motion_id");
  EXPECT_THAT(id.status().message(), HasSubstr("exceeds 2147483647"));
}

// stober-motion.md §2.5, §3.2 L364-373; decisions 1161, 1162: Command Mode I409 and End
// velocity I429 reach the drive; out of range or on the wrong command they name field and limit.
TEST_F(NativeStoberTest, CommandModeAndEndVelocity_ReachDrive_RangesNamed) {
  v1::SendNativeCommandRequest r = Mc("st1", v1::MC_MOVE_ABSOLUTE);
  r.mutable_stober()->set_command_mode(1);
  r.mutable_stober()->set_end_velocity_mm_s(80);
  ASSERT_TRUE(Send(r).ok());
  const auto sent = st_.native();
  ASSERT_TRUE(sent.has_value());
  const auto* mc = std::get_if<StoberMcRequest>(&*sent);
  ASSERT_NE(mc, nullptr);
  EXPECT_EQ(mc->command_mode, 1);
  EXPECT_EQ(mc->end_velocity_mm_s, 80);
  r.mutable_stober()->set_command_mode(2);
  auto mode = Send(r);
  EXPECT_EQ(ViolationField(mode.status()), "stober.command_mode");
  EXPECT_THAT(mode.status().message(), HasSubstr("2 exceeds 1 (I409"));
  v1::SendNativeCommandRequest home = Mc("st1", v1::MC_HOME);
  home.mutable_stober()->set_command_mode(1);
  auto buffered_home = Send(home);
  EXPECT_EQ(ViolationField(buffered_home.status()), "stober.command_mode");
  EXPECT_THAT(buffered_home.status().message(), HasSubstr("applies to commands 1-5, 8, 11"));
  r.mutable_stober()->set_command_mode(0);
  r.mutable_stober()->set_end_velocity_mm_s(-1);
  auto negative = Send(r);
  EXPECT_EQ(ViolationField(negative.status()), "stober.end_velocity_mm_s");
  EXPECT_THAT(negative.status().message(), HasSubstr("outside 0..4294967.295"));
  v1::SendNativeCommandRequest velocity = Mc("st1", v1::MC_MOVE_VELOCITY);
  velocity.mutable_stober()->set_end_velocity_mm_s(5);
  auto wrong = Send(velocity);
  EXPECT_EQ(ViolationField(wrong.status()), "stober.end_velocity_mm_s");
  EXPECT_THAT(wrong.status().message(), HasSubstr("applies to MoveAbsolute/Relative/Additive"));
}

TEST_F(NativeStoberTest, SdoUpload_ReachesDrive_BytesReturnedAsReply) {
  NativeReply reply;
  reply.data = {0x01, 0x00, 0x00, 0x00};
  st_.SetNativeReply(reply);
  auto resp = Send(Sdo("st1", 0x305C, 0, false, ""));  // I92 Done (stober-motion.md §7.2)
  ASSERT_TRUE(resp.ok()) << resp.status();
  const auto sent = st_.native();
  ASSERT_TRUE(sent.has_value());
  const auto sdo = std::get<CanOpenSdoRequest>(*sent);
  EXPECT_EQ(sdo.index, 0x305C);
  EXPECT_EQ(sdo.sub_index, 0);
  EXPECT_FALSE(sdo.write);
  EXPECT_TRUE(sdo.data.empty());
  EXPECT_EQ(resp->reply(), std::string("\x01\x00\x00\x00", 4));
}

TEST_F(NativeStoberTest, SdoDownload_DataReachesDrive_64KiBAccepted) {
  ASSERT_TRUE(Send(Sdo("st1", 0x6060, 0, true, "\x08")).ok());
  const auto sent = st_.native();
  ASSERT_TRUE(sent.has_value());
  const auto sdo = std::get<CanOpenSdoRequest>(*sent);
  EXPECT_EQ(sdo.index, 0x6060);
  EXPECT_TRUE(sdo.write);
  EXPECT_THAT(sdo.data, ElementsAre(0x08));
  EXPECT_TRUE(Send(Sdo("st1", 0x2000, 255, true, std::string(65536, 'x'))).ok());
}

TEST_F(NativeStoberTest, SdoDataRules_NameTheFieldAndTheLimit) {
  auto empty = Send(Sdo("st1", 0x6060, 0, true, ""));
  EXPECT_EQ(empty.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(empty.status()), "canopen_sdo.data");
  EXPECT_THAT(empty.status().message(), HasSubstr("is empty; a download (write) carries 1..65536"));
  auto big = Send(Sdo("st1", 0x6060, 0, true, std::string(65537, 'x')));
  EXPECT_EQ(ViolationField(big.status()), "canopen_sdo.data");
  EXPECT_THAT(big.status().message(), HasSubstr("65537 bytes exceed 65536"));
  auto upload_with_data = Send(Sdo("st1", 0x6060, 0, false, "ab"));
  EXPECT_EQ(ViolationField(upload_with_data.status()), "canopen_sdo.data");
  EXPECT_THAT(upload_with_data.status().message(), HasSubstr("2 bytes given for an upload"));
  auto index = Send(Sdo("st1", 0x10000, 0, false, ""));
  EXPECT_EQ(ViolationField(index.status()), "canopen_sdo.index");
  EXPECT_THAT(index.status().message(), HasSubstr("65536 exceeds 65535"));
  auto sub = Send(Sdo("st1", 0x1000, 256, false, ""));
  EXPECT_EQ(ViolationField(sub.status()), "canopen_sdo.sub_index");
  EXPECT_THAT(sub.status().message(), HasSubstr("256 exceeds 255"));
  EXPECT_EQ(st_.calls(), 0);
}

TEST_F(NativeStoberTest, WrongFamily_RefusedNamingTheOneofField) {
  auto mc = Send(Mc("tmc", v1::MC_STOP));
  EXPECT_EQ(mc.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(mc.status()), "stober");
  EXPECT_THAT(mc.status().message(), HasSubstr("is a stober command; drive family is trinamic"));
  auto sdo = Send(Sdo("tmc", 0x1000, 0, false, ""));
  EXPECT_EQ(ViolationField(sdo.status()), "canopen_sdo");
  EXPECT_EQ(tmc_.calls(), 0);
  v1::SendNativeCommandRequest tr;
  tr.set_name("st1");
  tr.mutable_trinamic()->set_opcode(0x20);
  EXPECT_EQ(ViolationField(Send(tr).status()), "trinamic");
}

TEST_F(NativeStoberTest, NoCommand_ListsTheStoberFields) {
  v1::SendNativeCommandRequest r;
  r.set_name("st1");
  auto resp = Send(r);
  EXPECT_EQ(ViolationField(resp.status()), "command");
  EXPECT_THAT(resp.status().message(), HasSubstr("stober, canopen_sdo"));
}

TEST_F(NativeStoberTest, ParameterId_IndexShift8Subindex_24Bit) {
  v1::ReadParameterRequest r;
  r.set_name("st1");
  r.set_parameter_id(0x305C00);  // I92 → 305Ch, subindex 0
  ASSERT_TRUE(core_.ReadParameter(r, {}).ok());
  EXPECT_EQ(st_.parameter_id(), 0x305C00u);
  r.set_parameter_id(0x1000000);
  auto too_big = core_.ReadParameter(r, {});
  EXPECT_EQ(too_big.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ViolationField(too_big.status()), "read_parameter.parameter_id");
  EXPECT_THAT(too_big.status().message(), HasSubstr("exceeds 16777215"));
}

}  // namespace
}  // namespace drivegw::server
