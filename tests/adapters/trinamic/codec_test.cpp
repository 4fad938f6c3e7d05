// Trinamic codec tests: every worked example of trinamic-sixpack.md §6 byte-exact, round trips
// over the whole opcode table (min/max/mid), range errors per field, R8/R9 framing, CAN IDs.
#include "adapters/trinamic/codec.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace drivegw::trinamic {
namespace {

using ::testing::ElementsAreArray;
using ::testing::HasSubstr;

std::vector<uint8_t> Hex(const std::string& text) {
  std::vector<uint8_t> out;
  for (size_t i = 0; i + 1 < text.size() + 1; i += 3) {
    out.push_back(static_cast<uint8_t>(std::stoul(text.substr(i, 2), nullptr, 16)));
  }
  return out;
}

// Encodes the command and checks the wire bytes; then decodes them back.
void ExpectCommand(Opcode op, std::initializer_list<int64_t> values, const std::string& wire) {
  auto command = MakeCommand(1, op, values);
  ASSERT_TRUE(command.ok()) << command.status();
  auto bytes = EncodeCommand(*command);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  EXPECT_THAT(*bytes, ElementsAreArray(Hex(wire))) << wire;
  auto back = DecodeCommand(*bytes);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, *command);
}

TEST(TrinamicTable, HasAll39OpcodesOnce) {
  EXPECT_EQ(OpcodeTable().size(), 39u);
  std::set<uint8_t> seen;
  std::set<std::string> names;
  for (const OpcodeSpec& s : OpcodeTable()) {
    seen.insert(static_cast<uint8_t>(s.opcode));
    names.insert(s.name);
  }
  EXPECT_EQ(seen.size(), 39u);
  EXPECT_EQ(names.size(), 39u);
}

TEST(TrinamicTable, RepliesExactlyForQueries) {
  // §2.4: $20 $21 $28 $30 $43 $44 $45 $F2 $F4 $F5 $F6 $F7.
  const std::set<uint8_t> queries = {0x20, 0x21, 0x28, 0x30, 0x43, 0x44,
                                     0x45, 0xF2, 0xF4, 0xF5, 0xF6, 0xF7};
  for (const OpcodeSpec& s : OpcodeTable()) {
    EXPECT_EQ(s.has_reply, queries.count(static_cast<uint8_t>(s.opcode)) == 1) << s.name;
    EXPECT_EQ(s.has_reply, s.response_address_field >= 0) << s.name;
  }
}

TEST(TrinamicTable, FieldsFitAndDoNotOverlap) {
  for (const OpcodeSpec& s : OpcodeTable()) {
    for (auto fields : {s.Fields(), s.ReplyFields()}) {
      std::set<int> used;
      for (const FieldSpec& f : fields) {
        for (size_t b = 0; b < FieldWidth(f.type); ++b) {
          EXPECT_LT(f.param + b, kParamCount) << s.name << "." << f.name;
          EXPECT_TRUE(used.insert(static_cast<int>(f.param + b)).second) << s.name << "." << f.name;
        }
      }
    }
  }
}

// §6.1
TEST(TrinamicExamples, MotorParameters) {
  ExpectCommand(Opcode::kMotorParameters, {0, 400, 0xC8, 0x5A}, "01 15 00 90 01 00 00 C8 5A");
  ExpectCommand(Opcode::kMotorParameters, {0, 6400, 0xA0, 0x0A}, "01 15 00 00 19 00 00 A0 0A");
  EXPECT_EQ(0xC8, motor_type::kTestNull | motor_type::kStopNull | motor_type::kFilterSwitch);
  EXPECT_EQ(0x5A00, motor_type::kFastRef | motor_type::kDelayTestNull | motor_type::kStopSoft |
                        motor_type::kNullPositive);
}

// §6.2
TEST(TrinamicExamples, StartRamp) {
  ExpectCommand(Opcode::kStartRamp, {0, 10000}, "01 23 00 10 27 00 00 00 00");
  ExpectCommand(Opcode::kStartRamp, {5, -6400}, "01 23 05 00 E7 FF FF 00 00");
  ExpectCommand(Opcode::kStartRamp, {2, 100000}, "01 23 02 A0 86 01 00 00 00");
}

// §6.3
TEST(TrinamicExamples, QueryPositionAndReplies) {
  ExpectCommand(Opcode::kQueryPosition, {2, 0xF0}, "01 20 02 F0 00 00 00 00 00");
  struct Case {
    const char* body;
    int64_t pos, action, stop;
  };
  for (const Case& c :
       {Case{"20 02 2E FB FF FF 00 00", -1234, 0, 0}, Case{"20 02 A0 86 01 00 05 00", 100000, 5, 0},
        Case{"20 02 00 00 00 00 16 01", 0, 22, 1}}) {
    auto reply = DecodeReply(Hex(c.body), ReplyFraming::kR8);
    ASSERT_TRUE(reply.ok()) << reply.status();
    EXPECT_EQ(reply->opcode, Opcode::kQueryPosition);
    EXPECT_EQ(*GetField(*reply, "motnr"), 2);
    EXPECT_EQ(*GetField(*reply, "posact"), c.pos);
    EXPECT_EQ(*GetField(*reply, "action"), c.action);
    EXPECT_EQ(*GetField(*reply, "stop_flag"), c.stop);
    EXPECT_THAT(*EncodeReply(*reply, ReplyFraming::kR8), ElementsAreArray(Hex(c.body)));
    // R9 prefixes RA (§6 intro, §2.4).
    reply->response_address = 0xF0;
    auto r9 = EncodeReply(*reply, ReplyFraming::kR9);
    ASSERT_TRUE(r9.ok());
    EXPECT_THAT(*r9, ElementsAreArray(Hex(std::string("F0 ") + c.body)));
    EXPECT_EQ(*DecodeReply(*r9, ReplyFraming::kR9), *reply);
  }
}

// §6.4
TEST(TrinamicExamples, Interpolation) {
  ExpectCommand(Opcode::kSetTarget, {0, 1000}, "01 26 00 E8 03 00 00 00 00");
  ExpectCommand(Opcode::kSetTarget, {1, 2000}, "01 26 01 D0 07 00 00 00 00");
  ExpectCommand(Opcode::kInterpolate, {0x03}, "01 50 03 00 00 00 00 00 00");
}

// §6.5 with m = 0 and m = 3 (pair base 2).
TEST(TrinamicExamples, DefaultConfigurationSequence) {
  for (int m : {0, 3}) {
    const std::string mm = m == 0 ? "00" : "03";
    ExpectCommand(Opcode::kPeakCurrent, {m & ~1, 128},
                  std::string("01 10 ") + (m == 0 ? "00" : "02") + " 80 00 00 00 00 00");
    ExpectCommand(Opcode::kCurrentControl, {m, 8, 2, 1, 0, 500},
                  "01 11 " + mm + " 08 02 01 00 F4 01");
    ExpectCommand(Opcode::kStartingVelocity, {m, 4, 5, 2}, "01 13 " + mm + " 04 00 05 00 02 00");
    ExpectCommand(Opcode::kSetRamp, {m, 128, 511}, "01 14 " + mm + " 80 00 FF 01 00 00");
    ExpectCommand(Opcode::kMotorParameters, {m, 6400, 0xA0, 0x0A},
                  "01 15 " + mm + " 00 19 00 00 A0 0A");
    ExpectCommand(Opcode::kReferenceParameters, {m, 100, 0x0FFF, 0},
                  "01 16 " + mm + " 64 00 FF 0F 00 00");
    ExpectCommand(Opcode::kNullOffset, {m, 0, 240}, "01 18 " + mm + " 00 00 00 00 F0 00");
    ExpectCommand(Opcode::kPiParameters, {m, 8, 129, 129, 1}, "01 19 " + mm + " 08 81 00 81 00 01");
  }
  ExpectCommand(Opcode::kVelocitySetting, {5}, "01 12 05 00 00 00 00 00 00");
  ExpectCommand(Opcode::kReadyOutput, {0x3F, 0x3F}, "01 33 3F 3F 00 00 00 00 00");
  ExpectCommand(Opcode::kWriteTable, {0, 0x0D, 0x25, 0x3E, 0x56}, "01 17 00 0D 25 3E 56 00 00");
  ExpectCommand(Opcode::kWriteTable, {4, 0x6D, 0x83, 0x98, 0xAB}, "01 17 04 6D 83 98 AB 00 00");
  ExpectCommand(Opcode::kWriteTable, {8, 0xBD, 0xCD, 0xDB, 0xE7}, "01 17 08 BD CD DB E7 00 00");
  ExpectCommand(Opcode::kWriteTable, {12, 0xF0, 0xF7, 0xFC, 0xFF}, "01 17 0C F0 F7 FC FF 00 00");
}

// §6.6 and CT-57
TEST(TrinamicExamples, FurtherSequences) {
  ExpectCommand(Opcode::kCurrentControl, {5, 8, 2, 1, 0, 500}, "01 11 05 08 02 01 00 F4 01");
  ExpectCommand(Opcode::kWriteTable, {0, 255, 255, 255, 255}, "01 17 00 FF FF FF FF 00 00");
  ExpectCommand(Opcode::kSetTarget, {0, 50000}, "01 26 00 50 C3 00 00 00 00");
  ExpectCommand(Opcode::kStartRamp, {0, 50000}, "01 23 00 50 C3 00 00 00 00");
  ExpectCommand(Opcode::kStartRotation, {1, 300}, "01 25 01 2C 01 00 00 00 00");
  ExpectCommand(Opcode::kStartRotation, {1, -300}, "01 25 01 D4 FE 00 00 00 00");
  ExpectCommand(Opcode::kStopMotors, {0x3F}, "01 2A 3F 00 00 00 00 00 00");
  ExpectCommand(Opcode::kStartRampParallel, {0x07}, "01 29 07 00 00 00 00 00 00");
  ExpectCommand(Opcode::kQueryActivities, {0xF0, 0x3F}, "01 28 F0 3F 00 00 00 00 00");
  ExpectCommand(Opcode::kReadInputs, {7, 0xF0}, "01 30 07 F0 00 00 00 00 00");
  ExpectCommand(Opcode::kAnalogStopLimits, {0, 100, 900}, "01 31 00 64 00 84 03 00 00");
  ExpectCommand(Opcode::kSetOutputs, {1, 1, 0, 1}, "01 32 01 01 00 01 00 00 00");
  ExpectCommand(Opcode::kSetBaudRate, {130, 3}, "01 40 82 00 03 00 00 00 00");
  ExpectCommand(Opcode::kSetBaudRate, {65, 10}, "01 40 41 00 0A 00 00 00 00");  // CT-07
  ExpectCommand(Opcode::kSetPacketTimeout, {50}, "01 41 32 00 00 00 00 00 00");
  ExpectCommand(Opcode::kUnitInformation, {0xF0}, "01 43 F0 00 00 00 00 00 00");
  ExpectCommand(Opcode::kHardwareReset, {0}, "01 CC 00 00 00 00 00 00 00");
  ExpectCommand(Opcode::kSetRamp, {0, 128, 300}, "01 14 00 80 00 2C 01 00 00");   // CT-57
  ExpectCommand(Opcode::kSetPosition, {2, -1234}, "01 27 02 2E FB FF FF 00 00");  // CT-12

  auto info = DecodeReply(Hex("43 94 01 1F 34 12 00 00"), ReplyFraming::kR8);
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(*GetField(*info, "firmware"), 148);
  EXPECT_EQ(*GetField(*info, "reset_flag"), 1);
  EXPECT_EQ(*GetField(*info, "temperature"), 31);
  EXPECT_EQ(*GetField(*info, "serial"), 0x1234);

  auto supply = DecodeReply(Hex("30 07 10 02 00 00 00 00"), ReplyFraming::kR8);
  ASSERT_TRUE(supply.ok());
  EXPECT_EQ(*GetField(*supply, "analog"), 528);  // 24 V × 22 (L779)
}

TEST(TrinamicReply, UndefinedBytesIgnoredAndSentAsZero) {
  // G-02: $28 P6 undefined.
  auto r = DecodeReply(Hex("28 05 00 0A 00 0F 14 AB"), ReplyFraming::kR8);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(*GetField(*r, "action5"), 20);
  EXPECT_THAT(*EncodeReply(*r, ReplyFraming::kR8),
              ElementsAreArray(Hex("28 05 00 0A 00 0F 14 00")));
}

TEST(TrinamicReply, NegativeTemperature) {
  auto r = DecodeReply(Hex("43 94 00 F6 00 00 00 00"), ReplyFraming::kR8);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(*GetField(*r, "temperature"), -10);
}

TEST(TrinamicReply, RejectsSilentOpcodesAndWrongLength) {
  EXPECT_FALSE(DecodeReply(Hex("23 00 00 00 00 00 00 00"), ReplyFraming::kR8).ok());
  EXPECT_FALSE(DecodeReply(Hex("20 00 00 00 00 00 00"), ReplyFraming::kR8).ok());
  EXPECT_FALSE(DecodeReply(Hex("20 00 00 00 00 00 00 00"), ReplyFraming::kR9).ok());
  EXPECT_FALSE(DecodeReply(Hex("F0 20 00 00 00 00 00 00"), ReplyFraming::kR8).ok());
}

// §2.4: the first reply byte tells R8 from R9.
TEST(TrinamicFraming, DetectsR8AndR9) {
  EXPECT_EQ(*DetectReplyFraming(0x43, 0xF0), ReplyFraming::kR8);
  EXPECT_EQ(*DetectReplyFraming(0xF0, 0xF0), ReplyFraming::kR9);
  EXPECT_EQ(*DetectReplyFraming(0x20, 0xF0), ReplyFraming::kR8);
  EXPECT_FALSE(DetectReplyFraming(0x00, 0xF0).ok());  // stray reset byte (L228)
  EXPECT_FALSE(DetectReplyFraming(0x23, 0xF0).ok());  // no reply opcode
  EXPECT_EQ(ReplySize(ReplyFraming::kR8), 8u);
  EXPECT_EQ(ReplySize(ReplyFraming::kR9), 9u);
}

TEST(TrinamicFraming, ResponseAddressMustBeDistinguishable) {
  EXPECT_TRUE(ValidateResponseAddress(0xF0).ok());
  EXPECT_TRUE(ValidateResponseAddress(0x10).ok());  // $10 produces no reply
  for (uint8_t bad :
       {0x00, 0x20, 0x21, 0x28, 0x30, 0x43, 0x44, 0x45, 0xF2, 0xF4, 0xF5, 0xF6, 0xF7}) {
    EXPECT_FALSE(ValidateResponseAddress(bad).ok()) << int{bad};
    EXPECT_FALSE(DetectReplyFraming(0x43, bad).ok());
  }
}

TEST(TrinamicCan, IdentifierMath) {
  EXPECT_EQ(*CommandCanId(0x01), 0x008);
  EXPECT_EQ(*CommandCanId(0x10), 0x080);
  EXPECT_EQ(*CommandCanId(0xFF), 0x7F8);
  EXPECT_EQ(*TunnelTransmitCanId(0x01), 0x009);
  EXPECT_EQ(*ReplyCanId(0xF0), 0x780);
  EXPECT_EQ(*ReplyCanId(0x10), 0x080);
  EXPECT_EQ(*TunnelReceiveCanId(0x20), 0x100);  // CT-54
  EXPECT_FALSE(CommandCanId(0).ok());
  EXPECT_FALSE(ReplyCanId(0).ok());
}

// §6.6 last row and CT-49.
TEST(TrinamicCan, QueryPositionViaCan) {
  auto cmd = MakeCommand(1, Opcode::kQueryPosition, {2, 0xF0});
  ASSERT_TRUE(cmd.ok());
  auto frame = EncodeCommandCan(*cmd);
  ASSERT_TRUE(frame.ok());
  EXPECT_EQ(frame->id, 0x008);
  EXPECT_EQ(frame->dlc, 8);
  EXPECT_THAT(frame->data, ElementsAreArray(Hex("20 02 F0 00 00 00 00 00")));
  EXPECT_EQ(*DecodeCommandCan(*frame), *cmd);

  CanFrame reply_frame{0x780, 8, {}};
  const auto body = Hex("20 02 2E FB FF FF 00 00");
  std::copy(body.begin(), body.end(), reply_frame.data.begin());
  auto reply = DecodeReplyCan(reply_frame);
  ASSERT_TRUE(reply.ok()) << reply.status();
  EXPECT_EQ(reply->response_address, 0xF0);
  EXPECT_EQ(*GetField(*reply, "posact"), -1234);
  EXPECT_EQ(*EncodeReplyCan(*reply), reply_frame);
}

TEST(TrinamicCan, RejectsTunnelIdsAndShortFrames) {
  CanFrame f{0x009, 8, {0x20, 0x02, 0xF0}};
  EXPECT_FALSE(DecodeCommandCan(f).ok());  // tunnel, not a command
  f.id = 0x000;
  EXPECT_FALSE(DecodeCommandCan(f).ok());
  f.id = 0x008;
  f.dlc = 3;
  EXPECT_FALSE(DecodeCommandCan(f).ok());  // G-27: DLC 8 only
  f.dlc = 8;
  EXPECT_TRUE(DecodeCommandCan(f).ok());
  // CT-54 request: $44 with RA F0, tunnel address 20, packets of 4.
  CanFrame t{0x008, 8, {0x44, 0xF0, 0x20, 0x04}};
  auto tunnel = DecodeCommandCan(t);
  ASSERT_TRUE(tunnel.ok()) << tunnel.status();
  EXPECT_EQ(*GetField(*tunnel, "packet_size"), 4);
}

// Round trip of every opcode with all fields at min, max and mid.
TEST(TrinamicRoundTrip, WholeTableMinMaxMid) {
  int checked = 0;
  for (const OpcodeSpec& s : OpcodeTable()) {
    for (int which = 0; which < 3; ++which) {
      Command c{0xFF, s.opcode, {}};
      for (size_t i = 0; i < s.field_count; ++i) {
        const FieldSpec& f = s.fields[i];
        int64_t v = which == 0 ? f.min : which == 1 ? f.max : f.min + (f.max - f.min) / 2;
        v -= v % f.multiple_of;
        c.values[i] = v;
      }
      auto wire = EncodeCommand(c);
      ASSERT_TRUE(wire.ok()) << s.name << " " << wire.status();
      ASSERT_EQ(wire->size(), kCommandSize);
      EXPECT_EQ((*wire)[1], static_cast<uint8_t>(s.opcode));
      EXPECT_EQ(*DecodeCommand(*wire), c) << s.name;
      EXPECT_EQ(*DecodeCommandCan(*EncodeCommandCan(c)), c) << s.name;
      ++checked;
      if (!s.has_reply) continue;
      Reply r{0xF0, s.opcode, {}};
      for (size_t i = 0; i < s.reply_field_count; ++i) {
        const FieldSpec& f = s.reply_fields[i];
        r.values[i] = which == 0 ? f.min : which == 1 ? f.max : f.min + (f.max - f.min) / 2;
      }
      for (ReplyFraming framing : {ReplyFraming::kR8, ReplyFraming::kR9}) {
        auto bytes = EncodeReply(r, framing);
        ASSERT_TRUE(bytes.ok()) << s.name;
        auto back = DecodeReply(*bytes, framing);
        ASSERT_TRUE(back.ok()) << s.name;
        Reply expected = r;
        if (framing == ReplyFraming::kR8) expected.response_address = 0;
        EXPECT_EQ(*back, expected) << s.name;
      }
      EXPECT_EQ(*DecodeReplyCan(*EncodeReplyCan(r)), r) << s.name;
    }
  }
  EXPECT_EQ(checked, 39 * 3);
}

// Every field with a range narrower than its type: one above max and one below min are refused
// by encode and decode, naming opcode, field and limit.
TEST(TrinamicRange, EveryFieldBothEnds) {
  int checked = 0;
  for (const OpcodeSpec& s : OpcodeTable()) {
    for (size_t i = 0; i < s.field_count; ++i) {
      const FieldSpec& f = s.fields[i];
      Command c{1, s.opcode, {}};
      for (size_t j = 0; j < s.field_count; ++j) c.values[j] = s.fields[j].min;
      const std::string where = std::string(s.name) + "." + f.name + ": ";
      c.values[i] = f.max + 1;
      auto over = EncodeCommand(c);
      ASSERT_FALSE(over.ok()) << where;
      EXPECT_EQ(over.status().code(), absl::StatusCode::kInvalidArgument);
      EXPECT_THAT(
          std::string(over.status().message()),
          HasSubstr(where + std::to_string(f.max + 1) + " exceeds " + std::to_string(f.max)));
      c.values[i] = f.min - 1;
      auto under = EncodeCommand(c);
      ASSERT_FALSE(under.ok()) << where;
      EXPECT_THAT(std::string(under.status().message()),
                  HasSubstr(where + std::to_string(f.min - 1) + " below " + std::to_string(f.min)));
      ++checked;
    }
  }
  EXPECT_GT(checked, 90);
}

TEST(TrinamicRange, MessagesNameFieldAndLimit) {
  Command c = *MakeCommand(1, Opcode::kSetRamp, {0, 128, 511});
  EXPECT_EQ(SetField(c, "amax", 32768).message(), "set_ramp.amax: 32768 exceeds 32767");
  EXPECT_EQ(SetField(c, "vmax", 512).message(), "set_ramp.vmax: 512 exceeds 511");
  EXPECT_EQ(SetField(c, "amax", 0).message(), "set_ramp.amax: 0 below 1");
  EXPECT_EQ(SetField(c, "motnr", 6).message(), "set_ramp.motnr: 6 exceeds 5");
  EXPECT_EQ(SetField(c, "nope", 1).code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(MakeCommand(1, Opcode::kVelocitySetting, {32}).status().message(),
            "velocity_setting.clkdiv: 32 exceeds 31");
  EXPECT_EQ(MakeCommand(1, Opcode::kStartingVelocity, {0, 0, 5, 4}).status().message(),
            "starting_velocity.div: 4 exceeds 3");
  EXPECT_EQ(MakeCommand(1, Opcode::kWriteTable, {5, 0, 0, 0, 0}).status().message(),
            "write_table.index: 5 is not a multiple of 4");
  EXPECT_EQ(MakeCommand(1, Opcode::kStartRotation, {0, -512}).status().message(),
            "start_rotation.velocity: -512 below -511");
  EXPECT_EQ(MakeCommand(1, Opcode::kSetBaudRate, {65, 1001}).status().message(),
            "set_baud_rate.switchover: 1001 exceeds 1000");
  EXPECT_EQ(MakeCommand(1, Opcode::kSetPacketTimeout, {1}).status().message(),
            "set_packet_timeout.timeout: 1 below 2");
  EXPECT_EQ(MakeCommand(1, Opcode::kMotorParameters, {0, 0x8000000, 0, 0}).status().message(),
            "motor_parameters.poslimit: 134217728 exceeds 134217727");
  EXPECT_EQ(MakeCommand(0, Opcode::kStartRamp, {0, 0}).status().message(),
            "start_ramp.address: 0 below 1");
  EXPECT_FALSE(MakeCommand(1, Opcode::kStartRamp, {0}).ok());  // wrong value count
  auto target = GetField(*MakeCommand(1, Opcode::kStartRamp, {0, INT32_MIN}), "target");
  EXPECT_EQ(*target, INT32_MIN);
}

TEST(TrinamicDecode, LengthOpcodeRangeAndPadding) {
  EXPECT_FALSE(DecodeCommand(Hex("01 27 00 88 13 00 00 00")).ok());  // CT-03: 8 bytes
  EXPECT_FALSE(DecodeCommand(Hex("01 99 00 00 00 00 00 00 00")).ok());
  auto bad_motor = DecodeCommand(Hex("01 23 06 00 00 00 00 00 00"));
  ASSERT_FALSE(bad_motor.ok());
  EXPECT_EQ(bad_motor.status().message(), "start_ramp.motnr: 6 exceeds 5");
  // Decision 1012: non-zero unused bytes are ignored; re-encoding pads with 00.
  auto padded = DecodeCommand(Hex("01 22 03 FF FF FF FF FF FF"));
  ASSERT_TRUE(padded.ok());
  EXPECT_THAT(*EncodeCommand(*padded), ElementsAreArray(Hex("01 22 03 00 00 00 00 00 00")));
}

}  // namespace
}  // namespace drivegw::trinamic
