// EMCY frames and error code names (CiA 301 §7.2.7.3.1, Table 21; CiA 402 8611h).
#include "adapters/canopen/emcy.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace drivegw::canopen {
namespace {

using transport::FormatCanFrame;
using transport::MakeCanFrame;

transport::CanFrame Frame(uint32_t id, std::initializer_list<uint8_t> bytes) {
  const std::vector<uint8_t> v(bytes);
  return MakeCanFrame(id, v);
}

TEST(EmcyTest, DecodesFollowingErrorFromAStoberStyleFrame) {
  auto emcy = DecodeEmcy(Frame(0x085, {0x11, 0x86, 0x21, 0x01, 0x02, 0x03, 0x04, 0x05}));
  ASSERT_TRUE(emcy.ok()) << emcy.status();
  EXPECT_EQ(emcy->node, 5);
  EXPECT_EQ(emcy->error_code, emcy_code::kFollowingError);
  EXPECT_EQ(emcy->error_register, error_register::kGeneric | error_register::kDeviceProfile);
  EXPECT_EQ(emcy->manufacturer, (std::array<uint8_t, 5>{1, 2, 3, 4, 5}));
  EXPECT_EQ(EmcyCodeName(emcy->error_code), "EMCY 0x8611 following error");
  auto again = EncodeEmcy(*emcy);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(FormatCanFrame(*again), "085#1186210102030405");
}

TEST(EmcyTest, ErrorResetAndShortFrames) {
  auto reset = DecodeEmcy(Frame(0x0FF, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0}));
  ASSERT_TRUE(reset.ok());
  EXPECT_EQ(reset->node, 127);
  EXPECT_EQ(ClassOfEmcyCode(reset->error_code), EmcyClass::kNoError);
  EXPECT_EQ(EmcyCodeName(0), "EMCY 0x0000 error reset or no error");
  // Decision 1106: down to 3 bytes accepted, the missing manufacturer bytes read 0.
  auto short_frame = DecodeEmcy(Frame(0x081, {0x30, 0x81, 0x11}));
  ASSERT_TRUE(short_frame.ok());
  EXPECT_EQ(short_frame->error_code, emcy_code::kLifeGuardHeartbeat);
  EXPECT_EQ(short_frame->manufacturer, (std::array<uint8_t, 5>{}));
  EXPECT_EQ(DecodeEmcy(Frame(0x081, {0x30, 0x81})).status().message(),
            "canopen emcy.dlc: 2 bytes, need 8 (at least 3)");
  EXPECT_FALSE(DecodeEmcy(Frame(0x080, {0, 0, 0, 0, 0, 0, 0, 0})).ok());  // that is SYNC
  EXPECT_FALSE(DecodeEmcy(Frame(0x100, {0, 0, 0, 0, 0, 0, 0, 0})).ok());
  EXPECT_FALSE(EncodeEmcy(Emcy{.node = 0}).ok());
}

TEST(EmcyTest, ClassesAndNames) {
  struct Row {
    uint16_t code;
    EmcyClass cls;
    const char* name;
  };
  const Row rows[] = {
      {0x1000, EmcyClass::kGeneric, "EMCY 0x1000 generic error"},
      {0x2310, EmcyClass::kCurrent, "EMCY 0x2310 continuous over current"},
      {0x2345, EmcyClass::kCurrent, "EMCY 0x2345 current (class 2xxxh)"},
      {0x3210, EmcyClass::kVoltage, "EMCY 0x3210 DC link over-voltage"},
      {0x4200, EmcyClass::kTemperature, "EMCY 0x4200 device temperature"},
      {0x5000, EmcyClass::kHardware, "EMCY 0x5000 device hardware"},
      {0x6100, EmcyClass::kSoftware, "EMCY 0x6100 internal software"},
      {0x7000, EmcyClass::kAdditionalModules, "EMCY 0x7000 additional modules"},
      {0x8110, EmcyClass::kMonitoring, "EMCY 0x8110 CAN overrun (objects lost)"},
      {0x8120, EmcyClass::kMonitoring, "EMCY 0x8120 CAN in error passive mode"},
      {0x8130, EmcyClass::kMonitoring, "EMCY 0x8130 life guard error or heartbeat error"},
      {0x8140, EmcyClass::kMonitoring, "EMCY 0x8140 recovered from bus off"},
      {0x8611, EmcyClass::kMonitoring, "EMCY 0x8611 following error"},
      {0x9000, EmcyClass::kExternal, "EMCY 0x9000 external error, generic error"},
      {0xF000, EmcyClass::kAdditionalFunctions, "EMCY 0xF000 additional functions, generic error"},
      {0xFF00, EmcyClass::kDeviceSpecific, "EMCY 0xFF00 device specific, generic error"},
      {0xFF42, EmcyClass::kDeviceSpecific, "EMCY 0xFF42 device specific (class FFxxh)"},
      {0x1100, EmcyClass::kReserved, "EMCY 0x1100 reserved (class 1xxxh)"},
      {0xA000, EmcyClass::kReserved, "EMCY 0xA000 reserved (class Axxxh)"},
  };
  for (const Row& r : rows) {
    EXPECT_EQ(ClassOfEmcyCode(r.code), r.cls) << std::hex << r.code;
    EXPECT_EQ(EmcyCodeName(r.code), r.name);
  }
}

}  // namespace
}  // namespace drivegw::canopen
