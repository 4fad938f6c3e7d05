// LinMot DeviceNet command table tests: the 102 commands of §8.4, round trips over the whole
// table, the worked command/response frames of §8.4 and §13 (TC-11 ... TC-45), toggle rule
// (D-4), coded errors (§8.6).
#include "adapters/linmot/devicenet/commands.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "adapters/linmot/devicenet/codec.h"

namespace drivegw::linmot::devicenet {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using Bytes = std::vector<uint8_t>;

// F1: Control In + Addressed In / Status Out + Addressed Out, motor A (§13.1).
const IoLayout kF1 = DefaultLayoutP();

// The Addressed In slot of an F1 poll command frame "42D#CW.CW.ID.ID.VAL.VAL".
CommandSlot AddressedOf(const char* text) {
  auto f = ParseFrame(text);
  EXPECT_TRUE(f.ok()) << text;
  auto img = DecodeConsumed(kF1, f->payload());
  EXPECT_TRUE(img.ok()) << text << ": " << img.status();
  return img.ok() ? *img->addressed : CommandSlot{};
}

// Checks bytes 4..7 of an F1 poll response against "ID.ID.VAL.VAL" (the §13 "…" notation).
void ExpectAddressedOut(CommandSlot slot, const std::string& tail) {
  ProducedImage img = EmptyProduced(kF1);
  img.addressed = slot;
  auto bytes = EncodeProduced(kF1, img);
  ASSERT_TRUE(bytes.ok());
  auto frame = MakeFrame(0x3C5, *bytes);
  ASSERT_TRUE(frame.ok());
  const std::string s = FrameToString(*frame);
  EXPECT_EQ(s.substr(s.size() - tail.size()), tail) << s;
}

// Drive side of one poll: decode the addressed command and answer with `value`.
CommandSlot Answer(const char* poll, int32_t value = 0) {
  auto cmd = DecodeCommand(AddressedOf(poll), Module::kAddressed);
  EXPECT_TRUE(cmd.ok()) << poll << ": " << cmd.status();
  if (!cmd.ok()) return {};
  auto resp = EncodeResponse(*cmd, value);
  EXPECT_TRUE(resp.ok()) << poll << ": " << resp.status();
  return resp.ok() ? *resp : CommandSlot{};
}

Command Cmd(CommandId id, std::optional<Motor> motor, int32_t value = 0, bool t = false) {
  return Command{Raw(id), motor, t, value};
}

CommandSlot Encode(const Command& c, Module m = Module::kAddressed) {
  auto s = EncodeCommand(c, m);
  EXPECT_TRUE(s.ok()) << s.status();
  return s.ok() ? *s : CommandSlot{};
}

// ---- The table ----------------------------------------------------------------------------

TEST(Table, Has102Commands_AscendingUniqueKeys) {
  const auto all = AllCommands();
  ASSERT_EQ(all.size(), 102u);
  std::set<std::string> keys;
  for (size_t i = 0; i < all.size(); ++i) {
    if (i > 0) {
      EXPECT_LT(all[i - 1].id, all[i].id);
    }
    EXPECT_TRUE(keys.insert(all[i].key()).second) << all[i].key();
    EXPECT_EQ(FindCommand(all[i].id), &all[i]);
    EXPECT_LE(all[i].id, 0x7F);
  }
  EXPECT_EQ(all.front().id, 0x00);
  EXPECT_EQ(all.back().id, 0x77);
}

TEST(Table, UnassignedIds_8_7_NotFound) {
  const uint8_t unassigned[] = {0x01, 0x0E, 0x16, 0x17, 0x1A, 0x1B, 0x1C, 0x1D, 0x1E,
                                0x1F, 0x2E, 0x2F, 0x54, 0x55, 0x5E, 0x5F, 0x69, 0x6C,
                                0x78, 0x79, 0x7A, 0x7B, 0x7C, 0x7D, 0x7E, 0x7F};
  for (uint8_t id : unassigned) EXPECT_EQ(FindCommand(id), nullptr) << int(id);
  EXPECT_EQ(102 + std::size(unassigned), 128u);
}

TEST(Table, Keys_ReadAsManualWords) {
  EXPECT_EQ(FindCommand(CommandId::kSetPositionSetpoint)->key(), "set_position_setpoint");
  EXPECT_EQ(FindCommand(CommandId::kGetInPositionMinus)->key(), "get_in_position_minus");
  EXPECT_EQ(FindCommand(CommandId::kSetInPositionPlus)->key(), "set_in_position_plus");
  EXPECT_EQ(FindCommand(CommandId::kGetZeroPosition)->key(), "get_0_position");
  EXPECT_EQ(FindCommand(CommandId::kSet10VPosition)->key(), "set_10_v_position");
  EXPECT_EQ(FindCommand(CommandId::kGetControllerFfFriction)->key(), "get_controller_ff_friction");
}

TEST(Table, OverviewColumns_GetsAddressedOnly_OthersBoth) {
  for (const CommandSpec& s : AllCommands()) {
    EXPECT_TRUE(s.addressed) << s.key();
    EXPECT_EQ(s.direct, s.kind != CommandKind::kGet) << s.key();
    if (s.kind == CommandKind::kGet) {
      EXPECT_EQ(s.response_kind, ResponseKind::kValue) << s.key();
      EXPECT_EQ(s.request.type, ValueType::kDontCare) << s.key();
    }
  }
}

TEST(Table, RuleSets_D4_11_4) {
  std::vector<uint8_t> toggle, armed, one_shot, serial, undocumented, encoder;
  for (const CommandSpec& s : AllCommands()) {
    if (s.toggle) toggle.push_back(s.id);
    if (s.trigger_armed) armed.push_back(s.id);
    if (s.one_shot) one_shot.push_back(s.id);
    if (s.serial_mode) serial.push_back(s.id);
    if (!s.documented) undocumented.push_back(s.id);
    if (s.requirement != Requirement::kNone) encoder.push_back(s.id);
  }
  EXPECT_THAT(toggle, ElementsAre(0x13, 0x15, 0x19, 0x20, 0x22));
  EXPECT_THAT(armed, ElementsAre(0x12, 0x14, 0x21, 0x23));
  EXPECT_THAT(one_shot, ElementsAre(0x07, 0x09, 0x0B, 0x0F, 0x13, 0x14, 0x15, 0x19, 0x20, 0x21,
                                    0x22, 0x23, 0x6E, 0x6F));
  EXPECT_THAT(serial, ElementsAre(0x11, 0x12, 0x13, 0x14, 0x20, 0x21, 0x22, 0x23));
  EXPECT_THAT(undocumented, ElementsAre(0x68, 0x6D, 0x74, 0x75, 0x76, 0x77));
  EXPECT_THAT(encoder,
              ElementsAre(0x60, 0x61, 0x62, 0x63, 0x64, 0x65, 0x66, 0x67, 0x68, 0x6A, 0x6B));
  EXPECT_EQ(FindCommand(CommandId::kResetController)->response_kind, ResponseKind::kNoResponse);
  EXPECT_EQ(FindCommand(CommandId::kSetControllerIo)->response_kind, ResponseKind::kActualIo);
  EXPECT_EQ(FindCommand(CommandId::kSetExtendedIo)->response_kind, ResponseKind::kActualIo);
  EXPECT_EQ(FindCommand(CommandId::kNoCommand)->response_kind, ResponseKind::kDontCare);
}

TEST(Table, MotorSelect_8_4) {
  std::vector<uint8_t> system, optional;
  for (const CommandSpec& s : AllCommands()) {
    if (s.motor_select == MotorSelect::kSystem) system.push_back(s.id);
    if (s.motor_select == MotorSelect::kOptional) optional.push_back(s.id);
  }
  EXPECT_THAT(system, ElementsAre(0x00, 0x02, 0x03, 0x04, 0x05, 0x07, 0x0A, 0x0B, 0x0C, 0x0D, 0x0F,
                                  0x60, 0x61, 0x64, 0x65, 0x66, 0x67));
  EXPECT_THAT(optional, ElementsAre(0x06, 0x08, 0x09));
}

TEST(Table, Ranges_8_4) {
  auto range = [](CommandId id) {
    const ValueSpec& v = FindCommand(id)->kind == CommandKind::kGet ? FindCommand(id)->response
                                                                    : FindCommand(id)->request;
    return std::pair<int32_t, int32_t>{v.min, v.max};
  };
  EXPECT_EQ(range(CommandId::kSetPositionSetpoint), (std::pair{-32256, 32256}));
  EXPECT_EQ(range(CommandId::kGetActualPosition), (std::pair{-32768, 32767}));  // D-17
  EXPECT_EQ(range(CommandId::kStartCurve), (std::pair{0, 63}));
  EXPECT_EQ(range(CommandId::kSetCurveAmplitude), (std::pair{0, 4096}));
  EXPECT_EQ(range(CommandId::kSetControllerP), (std::pair{0, 32640}));
  EXPECT_EQ(range(CommandId::kSetControllerFfFriction), (std::pair{0, 255}));
  EXPECT_EQ(range(CommandId::kSetInPositionPlus), (std::pair{2, 511}));
  EXPECT_EQ(range(CommandId::kSetFollowingErrorMinus), (std::pair{4, 511}));
  EXPECT_EQ(range(CommandId::kSetFilterMaxSpeed), (std::pair{6, 24576}));
  EXPECT_EQ(range(CommandId::kSetFilterMaxAcceleration), (std::pair{1, 1536}));  // D-17
  EXPECT_EQ(range(CommandId::kSetCamLength), (std::pair{16, 32767}));
  EXPECT_EQ(range(CommandId::kSetCamDelay), (std::pair{0, 32767}));
  EXPECT_EQ(range(CommandId::kSetDirectOut1Variable), (std::pair{0, 7}));
}

TEST(Table, ErrorCodes_PerCommand) {
  EXPECT_THAT(FindCommand(CommandId::kSetPositionSetpoint)->ErrorCodes(),
              ElementsAre(0x8110, 0x8111, 0x8112, 0x8118));
  EXPECT_THAT(FindCommand(CommandId::kStartCurve)->ErrorCodes(),
              ElementsAre(0x8110, 0x8111, 0x8112, 0x8118, 0x8130, 0x8131, 0x8132));
  EXPECT_THAT(FindCommand(CommandId::kGetEncoder1Position)->ErrorCodes(),
              ElementsAre(0x8120, 0x8121));
  EXPECT_THAT(FindCommand(CommandId::kSetExtendedIo)->ErrorCodes(), ElementsAre(0x8120));
  EXPECT_TRUE(FindCommand(CommandId::kGetStatusLowWord)->ErrorCodes().empty());
  EXPECT_THAT(FindCommand(CommandId::kGetDirectOut1Address)->ErrorCodes(),
              ElementsAre(0x8108, 0x8110, 0x8111));
  for (const CommandSpec& s : AllCommands()) {
    for (uint16_t code : s.ErrorCodes()) EXPECT_NE(FindCodedError(code), nullptr) << s.key();
  }
}

// ---- Round trips over the whole table -----------------------------------------------------------

std::vector<int32_t> SampleValues(const ValueSpec& v) {
  switch (v.type) {
    case ValueType::kDontCare:
      return {0};
    case ValueType::kBits:
      return {0, 0x0001, 0x8000, 0xFFFF, 0xA55A};
    default:
      return {v.min, v.max, v.min + (v.max - v.min) / 2};
  }
}

std::vector<std::optional<Motor>> MotorsFor(const CommandSpec& s) {
  switch (s.motor_select) {
    case MotorSelect::kSystem:
      return {std::nullopt};
    case MotorSelect::kRequired:
      return {Motor::kA, Motor::kB, Motor::kC, Motor::kD};
    case MotorSelect::kOptional:
    case MotorSelect::kUndefined:
      return {std::nullopt, Motor::kA, Motor::kD};
  }
  return {};
}

TEST(RoundTrip, EveryCommand_AddressedAndDirect) {
  int checked = 0;
  for (const CommandSpec& s : AllCommands()) {
    for (Module module : {Module::kAddressed, Module::kDirect}) {
      if (module == Module::kDirect && !s.direct) continue;
      const auto motors = module == Module::kDirect
                              ? std::vector<std::optional<Motor>>{std::nullopt}
                              : MotorsFor(s);
      for (const auto& motor : motors) {
        for (bool t : {false, true}) {
          for (int32_t value : SampleValues(s.request)) {
            const Command c{s.id, motor, t, value};
            auto slot = EncodeCommand(c, module, /*strict=*/s.documented);
            ASSERT_TRUE(slot.ok()) << s.key() << ": " << slot.status();
            auto d = DecodeCommand(*slot, module);
            ASSERT_TRUE(d.ok()) << s.key() << ": " << d.status();
            EXPECT_EQ(d->spec, &s);
            EXPECT_EQ(d->word.id, s.id);
            EXPECT_EQ(d->word.toggle, t);
            EXPECT_EQ(d->motor, module == Module::kAddressed ? motor : std::nullopt) << s.key();
            if (s.request.type != ValueType::kDontCare) {
              EXPECT_EQ(d->value, value) << s.key();
            }
            if (s.response_kind == ResponseKind::kNoResponse) {
              EXPECT_EQ(EncodeResponse(*d).status().code(), absl::StatusCode::kFailedPrecondition);
              ++checked;
              continue;
            }
            for (int32_t rv : SampleValues(s.response)) {
              auto resp = EncodeResponse(*d, rv);
              ASSERT_TRUE(resp.ok()) << s.key() << ": " << resp.status();
              EXPECT_TRUE(ResponseMatches(*slot, *resp)) << s.key();
              auto back = DecodeResponse(*resp);
              ASSERT_TRUE(back.ok()) << back.status();
              EXPECT_EQ(back->spec, &s);
              EXPECT_EQ(back->echo, d->word);
              switch (s.response_kind) {
                case ResponseKind::kEcho:
                  EXPECT_EQ(back->raw_value, slot->value) << s.key();
                  if (s.request.type != ValueType::kDontCare) {
                    EXPECT_EQ(back->value, value);
                  }
                  break;
                case ResponseKind::kValue:
                case ResponseKind::kActualIo:
                  EXPECT_EQ(back->value, rv) << s.key();
                  break;
                default:
                  break;
              }
              ++checked;
            }
          }
        }
      }
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST(RoundTrip, EveryRawSlot_DecodeEncodeStable) {
  // Every command word with a few values: what decodes answers with the same echo.
  for (uint32_t word = 0; word <= 0xFFFF; word += 7) {
    for (uint16_t value : {uint16_t{0}, uint16_t{0x8000}, uint16_t{0x1234}}) {
      const CommandSlot slot{static_cast<uint16_t>(word), value};
      for (Module m : {Module::kAddressed, Module::kDirect}) {
        auto d = DecodeCommand(slot, m);
        if (!d.ok()) {
          EXPECT_TRUE(GetCodedError(d.status()).has_value()) << d.status();
          continue;
        }
        EXPECT_EQ(d->word.raw(), slot.word);
        if (d->spec->response_kind == ResponseKind::kNoResponse) continue;
        auto r = EncodeResponse(*d, 0);
        ASSERT_TRUE(r.ok()) << r.status();
        EXPECT_EQ(r->word, slot.word);
      }
    }
  }
}

// ---- Command words (§8.4 examples) ------------------------------------------------------------

TEST(CommandWord, Section8_4_Examples) {
  const CommandSlot set = Encode(Cmd(CommandId::kSetPositionSetpoint, Motor::kA, 5120));
  EXPECT_EQ(set.word, 0x1011);
  const CommandSlot start = Encode(Cmd(CommandId::kStartCurve, Motor::kA, 3, true));
  EXPECT_EQ(start.word, 0x10A0);
  EXPECT_EQ(Encode(Cmd(CommandId::kGetActualPosition, Motor::kB)).word, 0x2018);
  EXPECT_EQ(Encode(Cmd(CommandId::kGetActualPosition, Motor::kC)).word, 0x4018);
  EXPECT_EQ(Encode(Cmd(CommandId::kGetActualPosition, Motor::kD)).word, 0x8018);
  ConsumedImage img = EmptyConsumed(kF1);
  img.addressed = set;
  auto bytes = EncodeConsumed(kF1, img);
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ((*bytes)[2], 0x11);  // little-endian bytes "11 10"
  EXPECT_EQ((*bytes)[3], 0x10);
  img.addressed = start;
  bytes = EncodeConsumed(kF1, img);
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ((*bytes)[2], 0xA0);  // "A0 10"
  EXPECT_EQ((*bytes)[3], 0x10);
}

TEST(CommandWord, RawRoundTrip_AllWords) {
  for (uint32_t w = 0; w <= 0xFFFF; ++w) {
    EXPECT_EQ(CommandWord::FromRaw(static_cast<uint16_t>(w)).raw(), w);
  }
}

// ---- Worked frames of §13 ------------------------------------------------------------------

TEST(WorkedFrames, StatusAndControl_Tc12ToTc16) {
  // Gateway encodes exactly the poll of each case.
  ConsumedImage img = EmptyConsumed(kF1);
  img.control = ControlWord{ControlWord::kRunRequest};
  img.addressed = Encode(Cmd(CommandId::kGetStatusLowWord, std::nullopt));
  auto bytes = EncodeConsumed(kF1, img);
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(FrameToString(*MakeFrame(0x42D, *bytes)), "42D#02.00.02.00.00.00");
  ExpectAddressedOut(Answer("42D#02.00.02.00.00.00", 0x1003), "02.00.03.10");  // TC-12
  ExpectAddressedOut(Answer("42D#02.00.03.00.00.00", 0x000A), "03.00.0A.00");  // TC-13
  ExpectAddressedOut(Answer("42D#02.00.04.00.00.00", 0x0002), "04.00.02.00");  // TC-14
  const CommandSlot set_cw = Encode(Cmd(CommandId::kSetControlWord, std::nullopt, 0x0002));
  EXPECT_EQ(set_cw, (CommandSlot{0x0005, 0x0002}));                      // TC-15
  EXPECT_EQ(AddressedOf("42D#04.00.00.00.00.00"), (CommandSlot{0, 0}));  // TC-16
}

TEST(WorkedFrames, Motion_Tc18ToTc27) {
  // TC-18
  EXPECT_EQ(Encode(Cmd(CommandId::kSetPositionSetpoint, Motor::kA, 5120)),
            AddressedOf("42D#02.00.11.10.00.14"));
  ExpectAddressedOut(Answer("42D#02.00.11.10.00.14"), "11.10.00.14");
  ExpectAddressedOut(Answer("42D#02.00.10.10.00.00", 5120), "10.10.00.14");
  // TC-19: -256 = -5 mm.
  ExpectAddressedOut(Answer("42D#02.00.18.10.00.00", -256), "18.10.00.FF");
  auto pos = DecodeResponse(CommandSlot{0x1018, 0xFF00});
  ASSERT_TRUE(pos.ok());
  EXPECT_EQ(pos->value, -256);
  // TC-20
  EXPECT_EQ(Encode(Cmd(CommandId::kSetPositionSetpointWaitingForTrigger, Motor::kA, 5120)),
            AddressedOf("42D#02.00.12.10.00.14"));
  ExpectAddressedOut(Answer("42D#02.00.12.10.00.14"), "12.10.00.14");
  auto cw = DecodeConsumed(kF1, ParseFrame("42D#02.01.10.10.00.00")->payload());
  ASSERT_TRUE(cw.ok());
  EXPECT_TRUE(cw->control->trigger(Motor::kA));
  // TC-21: T = 1, +256.
  EXPECT_EQ(Encode(Cmd(CommandId::kIncrementPositionSetpoint, Motor::kA, 256, true)),
            AddressedOf("42D#02.00.93.10.00.01"));
  // TC-22 / TC-23 / TC-24 / TC-25
  EXPECT_EQ(Encode(Cmd(CommandId::kStartCurve, Motor::kA, 3, true)),
            AddressedOf("42D#02.00.A0.10.03.00"));
  ExpectAddressedOut(Answer("42D#02.00.A0.10.03.00"), "A0.10.03.00");
  EXPECT_EQ(Encode(Cmd(CommandId::kStartCurve, Motor::kA, 3, false)),
            AddressedOf("42D#02.00.20.10.03.00"));
  EXPECT_EQ(Encode(Cmd(CommandId::kStartCurveIncremental, Motor::kA, 4, true)),
            AddressedOf("42D#02.00.A2.10.04.00"));
  EXPECT_EQ(Encode(Cmd(CommandId::kStartCurveWaitingForTrigger, Motor::kA, 3)),
            AddressedOf("42D#02.00.21.10.03.00"));
  // TC-26 / TC-27
  EXPECT_EQ(Encode(Cmd(CommandId::kMoveHomePosition, Motor::kA, 0, true)),
            AddressedOf("42D#02.00.95.10.00.00"));
  EXPECT_EQ(Encode(Cmd(CommandId::kSetActualPosition, Motor::kA, 2560, false)),
            AddressedOf("42D#02.00.19.10.00.0A"));
  ExpectAddressedOut(Answer("42D#02.00.18.10.00.00", 2560), "18.10.00.0A");
}

TEST(WorkedFrames, CodedErrors_Tc11Tc28ToTc33Tc42) {
  ExpectAddressedOut(Answer("42D#02.00.0A.00.00.00", kCodedCanBusOff), "0A.00.48.81");  // TC-11
  ExpectAddressedOut(Answer("42D#02.00.08.00.00.00", kSystemErrorCodedError), "08.00.80.00");
  ExpectAddressedOut(Answer("42D#02.00.0A.00.00.00", kCodedDriveNotSerial), "0A.00.12.81");
  ExpectAddressedOut(Answer("42D#02.00.0A.00.00.00", kCodedCurveMissing), "0A.00.30.81");
  ExpectAddressedOut(Answer("42D#02.00.0A.00.00.00", kCodedUnknownCommand), "0A.00.08.81");
  ExpectAddressedOut(Answer("42D#02.00.0A.00.00.00", kCodedDriveNotSpecified), "0A.00.10.81");
  ExpectAddressedOut(Answer("42D#02.00.0A.00.00.00", kCodedDriveNotMaster), "0A.00.11.81");
  ExpectAddressedOut(Answer("42D#02.00.0A.00.00.00", kCodedRangeError), "0A.00.18.81");
  ExpectAddressedOut(Answer("42D#02.00.0A.00.00.00", kCodedEncoderNotExists), "0A.00.20.81");
  auto coded = DecodeResponse(CommandSlot{0x000A, 0x8112});
  ASSERT_TRUE(coded.ok());
  EXPECT_EQ(CodedErrorText(static_cast<uint16_t>(coded->value)),
            "Drive not in serial mode (0x8112)");

  // TC-29: undefined curve 10 sent with T = 1.
  EXPECT_EQ(Encode(Cmd(CommandId::kStartCurve, Motor::kA, 10, true)),
            AddressedOf("42D#02.00.A0.10.0A.00"));
  // TC-30: unknown command 0x01 -> 0x8108.
  auto unknown = DecodeCommand(AddressedOf("42D#02.00.01.00.00.00"), Module::kAddressed);
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(unknown.status().message(), HasSubstr("command 0x01: not in the command table"));
  EXPECT_EQ(GetCodedError(unknown.status()), kCodedUnknownCommand);
  // TC-31: motor command without a select bit -> 0x8110.
  auto unspecified = DecodeCommand(AddressedOf("42D#02.00.18.00.00.00"), Module::kAddressed);
  ASSERT_FALSE(unspecified.ok());
  EXPECT_THAT(unspecified.status().message(),
              HasSubstr("get_actual_position: no motor select bit"));
  EXPECT_EQ(GetCodedError(unspecified.status()), kCodedDriveNotSpecified);
  // TC-32: motor B selected; the simulator raises 0x8111 when B is a slave axis.
  auto slave = DecodeCommand(AddressedOf("42D#02.00.11.20.00.14"), Module::kAddressed);
  ASSERT_TRUE(slave.ok());
  EXPECT_EQ(slave->motor, Motor::kB);
  EXPECT_EQ(slave->value, 5120);
  // TC-33: In Position + = 1 < 2 -> 0x8118; sent non-strict on purpose.
  auto range = EncodeCommand(Cmd(CommandId::kSetInPositionPlus, Motor::kA, 1), Module::kAddressed);
  ASSERT_FALSE(range.ok());
  EXPECT_EQ(range.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(range.status().message(),
              HasSubstr("set_in_position_plus.in_position_plus: 1 below minimum 2"));
  auto forced = EncodeCommand(Cmd(CommandId::kSetInPositionPlus, Motor::kA, 1), Module::kAddressed,
                              /*strict=*/false);
  ASSERT_TRUE(forced.ok());
  EXPECT_EQ(*forced, AddressedOf("42D#02.00.4B.10.01.00"));
  auto d = DecodeCommand(*forced, Module::kAddressed);
  ASSERT_TRUE(d.ok());
  const absl::Status rs = CheckRange(*d->spec, d->value);
  EXPECT_EQ(rs.code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(GetCodedError(rs), kCodedRangeError);
  ExpectAddressedOut(Answer("42D#02.00.4A.10.00.00", 10), "4A.10.0A.00");
  // TC-42: encoder command without module.
  EXPECT_EQ(Encode(Cmd(CommandId::kGetEncoder1Position, std::nullopt)),
            AddressedOf("42D#02.00.60.00.00.00"));
}

TEST(WorkedFrames, WarnErrorStates_Tc34ToTc38) {
  ExpectAddressedOut(Answer("42D#02.00.06.00.00.00", 0x1000), "06.00.00.10");
  ExpectAddressedOut(Answer("42D#02.00.06.10.00.00", 0x0001), "06.10.01.00");
  ExpectAddressedOut(Answer("42D#02.00.08.00.00.00", 0x1000), "08.00.00.10");
  ExpectAddressedOut(Answer("42D#02.00.08.10.00.00", 0x0004), "08.10.04.00");
  auto sys = DecodeCommand(AddressedOf("42D#02.00.06.00.00.00"), Module::kAddressed);
  ASSERT_TRUE(sys.ok());
  EXPECT_FALSE(sys->motor.has_value());  // system warn state
  auto mot = DecodeCommand(AddressedOf("42D#02.00.08.10.00.00"), Module::kAddressed);
  ASSERT_TRUE(mot.ok());
  EXPECT_EQ(mot->motor, Motor::kA);                                    // motor error state
  ExpectAddressedOut(Answer("42D#02.00.09.00.00.00"), "09.00.00.00");  // TC-37
  ExpectAddressedOut(Answer("42D#02.00.0B.00.00.00"), "0B.00.00.00");  // TC-38
  EXPECT_EQ(Encode(Cmd(CommandId::kResetErrorState, std::nullopt)), (CommandSlot{0x0009, 0}));
  EXPECT_EQ(Encode(Cmd(CommandId::kResetCodedError, std::nullopt)), (CommandSlot{0x000B, 0}));
}

TEST(WorkedFrames, Io_Tc39ToTc41) {
  ExpectAddressedOut(Answer("42D#02.00.0C.00.00.00", 0x0501), "0C.00.01.05");
  EXPECT_EQ(Encode(Cmd(CommandId::kSetControllerIo, std::nullopt, 0x8000)),
            AddressedOf("42D#02.00.0D.00.00.80"));
  ExpectAddressedOut(Answer("42D#02.00.0D.00.00.80", 0x8000), "0D.00.00.80");
  ExpectAddressedOut(Answer("42D#02.00.0D.00.00.80", 0x0000), "0D.00.00.00");  // output busy
  EXPECT_EQ(Encode(Cmd(CommandId::kSetExtendedIo, std::nullopt, 0xA500)),
            AddressedOf("42D#02.00.65.00.00.A5"));
  ExpectAddressedOut(Answer("42D#02.00.65.00.00.A5", 0xA53C), "65.00.3C.A5");
  auto ext = DecodeResponse(CommandSlot{0x0064, 0x003C});
  ASSERT_TRUE(ext.ok());
  EXPECT_EQ(ext->value & 0xFF, 0x3C);
}

TEST(WorkedFrames, DirectOutVariables_Tc43) {
  ExpectAddressedOut(Answer("42D#02.00.70.10.00.00", 0), "70.10.00.00");
  EXPECT_EQ(Encode(Cmd(CommandId::kSetDirectOut1Variable, Motor::kA, 4)),
            AddressedOf("42D#02.00.71.10.04.00"));
  ExpectAddressedOut(Answer("42D#02.00.71.10.04.00"), "71.10.04.00");
  ExpectAddressedOut(Answer("42D#02.00.70.10.00.00", 4), "70.10.04.00");
}

TEST(WorkedFrames, ResetController_Tc06_NoResponse) {
  EXPECT_EQ(Encode(Cmd(CommandId::kResetController, std::nullopt)),
            AddressedOf("42D#02.00.0F.00.00.00"));
  auto d = DecodeCommand(AddressedOf("42D#02.00.0F.00.00.00"), Module::kAddressed);
  ASSERT_TRUE(d.ok());
  auto r = EncodeResponse(*d);
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.status().message(), HasSubstr("never answers"));
}

TEST(WorkedFrames, DirectSlots_Tc44Tc45) {
  const CommandSlot a =
      Encode(Cmd(CommandId::kSetPositionSetpoint, std::nullopt, 5120), Module::kDirect);
  EXPECT_EQ(a, (CommandSlot{0x0011, 0x1400}));
  const CommandSlot c =
      Encode(Cmd(CommandId::kSetPositionSetpoint, std::nullopt, -5120), Module::kDirect);
  EXPECT_EQ(c, (CommandSlot{0x0011, 0xEC00}));
  EXPECT_EQ(Encode(Cmd(CommandId::kSetDirectOut1Variable, std::nullopt, 4), Module::kDirect),
            (CommandSlot{0x0071, 0x0004}));
  auto d = DecodeCommand(CommandSlot{0x0011, 0xEC00}, Module::kDirect);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->value, -5120);
  EXPECT_FALSE(d->motor.has_value());
}

// ---- Strict encoding errors -----------------------------------------------------------------

TEST(Encode, StrictErrors_NameCommand) {
  EXPECT_EQ(
      EncodeCommand(Command{0x01, std::nullopt, false, 0}, Module::kAddressed).status().code(),
      absl::StatusCode::kNotFound);
  EXPECT_THAT(
      EncodeCommand(Cmd(CommandId::kSetPositionSetpoint, std::nullopt, 0), Module::kAddressed)
          .status()
          .message(),
      HasSubstr("set_position_setpoint: needs exactly one motor (A-D)"));
  EXPECT_THAT(EncodeCommand(Cmd(CommandId::kGetCodedError, Motor::kB), Module::kAddressed)
                  .status()
                  .message(),
              HasSubstr("get_coded_error: system command, motor B given"));
  EXPECT_THAT(EncodeCommand(Cmd(CommandId::kGetActualPosition, std::nullopt), Module::kDirect)
                  .status()
                  .message(),
              HasSubstr("get_actual_position: not allowed in a Direct slot"));
  EXPECT_THAT(
      EncodeCommand(Cmd(CommandId::kSetPositionSetpoint, Motor::kA, 0), Module::kDirect, false)
          .status()
          .message(),
      HasSubstr("given for a Direct slot"));
  EXPECT_THAT(EncodeCommand(Cmd(CommandId::kStartCamAtCounts, Motor::kA, 0), Module::kAddressed)
                  .status()
                  .message(),
              HasSubstr("undocumented in the seed, never sent (D-19)"));
  EXPECT_THAT(
      EncodeCommand(Cmd(CommandId::kSetPositionSetpoint, Motor::kA, 32257), Module::kAddressed)
          .status()
          .message(),
      HasSubstr("set_position_setpoint.position_setpoint: 32257 exceeds maximum 32256"));
  auto wide = EncodeCommand(Cmd(CommandId::kSetPositionSetpoint, Motor::kA, 40000),
                            Module::kAddressed, false);
  EXPECT_EQ(wide.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(wide.status().message(), HasSubstr("40000 outside Int16"));
  // Non-strict writes what the tests need (TC-31).
  auto tc31 =
      EncodeCommand(Cmd(CommandId::kGetActualPosition, std::nullopt), Module::kAddressed, false);
  ASSERT_TRUE(tc31.ok());
  EXPECT_EQ(*tc31, AddressedOf("42D#02.00.18.00.00.00"));
}

TEST(Decode, TwoMotorSelectBits_D6) {
  auto d = DecodeCommand(CommandSlot{0x3018, 0}, Module::kAddressed);
  ASSERT_FALSE(d.ok());
  EXPECT_THAT(d.status().message(), HasSubstr("2 motor select bits 0x3, at most one (D-6)"));
  EXPECT_EQ(GetCodedError(d.status()), kCodedDriveNotSpecified);
  auto opt = DecodeCommand(CommandSlot{0x3006, 0}, Module::kAddressed);
  EXPECT_FALSE(opt.ok());
  // Direct slots ignore bits 15..8 (reserved).
  auto direct = DecodeCommand(CommandSlot{0x3011, 5}, Module::kDirect);
  ASSERT_TRUE(direct.ok());
  EXPECT_FALSE(direct->motor.has_value());
}

TEST(Decode, ResponseOutsideType_OutOfRange) {
  auto d = DecodeCommand(CommandSlot{0x1018, 0}, Module::kAddressed);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(EncodeResponse(*d, 40000).status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_FALSE(DecodeResponse(CommandSlot{0x0001, 0}).ok());
}

// ---- Toggle (D-4) ---------------------------------------------------------------------------

TEST(Toggle, NextToggleAndHandshake_Tc21Tc22Tc23) {
  StatusHighWord sh{0x0000};
  const CommandSpec& start = *FindCommand(CommandId::kStartCurve);
  // Gateway: next T-command inverts the motor's Command Toggle.
  EXPECT_TRUE(NextToggle(sh, Motor::kA));
  EXPECT_TRUE(ToggleFor(start, sh, Motor::kA));
  EXPECT_FALSE(ToggleFor(*FindCommand(CommandId::kSetPositionSetpoint), sh, Motor::kA));
  // Drive: executes once, then the bit follows T.
  EXPECT_TRUE(IsNewToggleCommand(true, sh, Motor::kA));
  sh = sh.With(StatusHighWord::Bit(Motor::kA, StatusHighWord::kCommandToggle), true);
  EXPECT_EQ(sh.raw, 0x0008);                              // TC-22: SH bit 3 = 1
  EXPECT_FALSE(IsNewToggleCommand(true, sh, Motor::kA));  // repeated frame does nothing
  EXPECT_TRUE(ToggleAccepted(true, sh, Motor::kA));
  // TC-23: T = 0 is new now.
  EXPECT_FALSE(NextToggle(sh, Motor::kA));
  EXPECT_TRUE(IsNewToggleCommand(false, sh, Motor::kA));
  // Other motors are independent.
  EXPECT_TRUE(NextToggle(sh, Motor::kB));
  EXPECT_TRUE(IsNewToggleCommand(true, StatusHighWord{0x0008}, Motor::kD));
}

// ---- Coded errors (§8.6) ----------------------------------------------------------------------

TEST(CodedErrors, Table_8_6) {
  const auto all = AllCodedErrors();
  ASSERT_EQ(all.size(), 20u);
  for (size_t i = 1; i < all.size(); ++i) EXPECT_LT(all[i - 1].code, all[i].code);
  EXPECT_EQ(all.front().code, 0x8100);
  EXPECT_EQ(all.back().code, 0x8148);
  EXPECT_EQ(FindCodedError(0x8146), nullptr);
  EXPECT_EQ(CodedErrorText(0x8101), "DeviceNet MACID already in use (0x8101)");
  EXPECT_EQ(CodedErrorText(0x8143), "CAN acknowledge error (0x8143)");
  EXPECT_EQ(CodedErrorText(0), "no coded error (0x0000)");
  EXPECT_EQ(CodedErrorText(0x1234), "LinMot coded error 0x1234");
}

TEST(CodedErrors, StatusPayload_RoundTrip) {
  absl::Status s = absl::FailedPreconditionError("drive x: command failed");
  AttachCodedError(s, 0x8132);
  EXPECT_EQ(GetCodedError(s), 0x8132);
  EXPECT_FALSE(GetCodedError(absl::OkStatus()).has_value());
}

}  // namespace
}  // namespace drivegw::linmot::devicenet
