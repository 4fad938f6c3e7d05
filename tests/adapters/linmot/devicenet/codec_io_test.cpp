// LinMot DeviceNet I/O module tests: sizes and byte maps of the seed examples (§7.7), the F1/F2/
// F3 fixtures of §13.1, words and bit names (§7.1, §7.4, §8.5), byte order (D-1).
#include "adapters/linmot/devicenet/codec_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "adapters/linmot/devicenet/codec.h"

namespace drivegw::linmot::devicenet {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using Bytes = std::vector<uint8_t>;

IoLayout F1() { return DefaultLayoutP(); }
IoLayout F1Prime() {
  IoLayout l = DefaultLayoutP();
  l.modules.control_in = false;
  return l;
}

Bytes Concat(const std::vector<Frame>& frames, bool fragmented) {
  Bytes out;
  for (const Frame& f : frames) {
    auto p = f.payload();
    out.insert(out.end(), p.begin() + (fragmented ? 1 : 0), p.end());
  }
  return out;
}

TEST(Layout, Sizes_Fixtures) {
  EXPECT_EQ(ConsumedSize(F1()), 6u);  // default EDS setup (line 322), D-3 candidate P
  EXPECT_EQ(ProducedSize(F1()), 8u);
  EXPECT_EQ(ConsumedSize(F1Prime()), 4u);
  EXPECT_EQ(ProducedSize(F1Prime()), 8u);
  EXPECT_EQ(ConsumedSize(Example2Layout()), 10u);
  EXPECT_EQ(ProducedSize(Example2Layout()), 8u);
  EXPECT_EQ(ConsumedSize(Example1Layout()), 22u);
  EXPECT_EQ(ProducedSize(Example1Layout()), 24u);
  // §7.8 candidate Q: Control In + Direct In / Status Out + DO1 + DO2, one master.
  IoLayout q;
  q.modules = ModuleSet{true, false, true, true, false, true, true};
  q.master_drives = 0x1;
  EXPECT_EQ(ConsumedSize(q), 6u);
  EXPECT_EQ(ProducedSize(q), 8u);
  EXPECT_EQ(ConsumedModulesText(F1()), "control_in+addressed_in");
  EXPECT_EQ(ProducedModulesText(Example1Layout()),
            "status_out+addressed_out+direct_out_1+direct_out_2");
  EXPECT_THAT(MasterDrives(Example2Layout()), ElementsAre(Motor::kA, Motor::kC));
}

TEST(Layout, Example1_ConsumedByteMap) {
  // Lines 492-521: CW, addressed ID/value, Direct ID/value A, B, C, D.
  ConsumedImage img;
  img.control = ControlWord{0x0102};
  img.addressed = CommandSlot{0x1011, 0x1400};
  img.direct = {{0x0011, 0xA1A1}, {0x0011, 0xB1B1}, {0x0011, 0xC1C1}, {0x0011, 0xD1D1}};
  auto bytes = EncodeConsumed(Example1Layout(), img);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  EXPECT_EQ(*bytes, (Bytes{0x02, 0x01, 0x11, 0x10, 0x00, 0x14, 0x11, 0x00, 0xA1, 0xA1, 0x11,
                           0x00, 0xB1, 0xB1, 0x11, 0x00, 0xC1, 0xC1, 0x11, 0x00, 0xD1, 0xD1}));
  auto back = DecodeConsumed(Example1Layout(), *bytes);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, img);
}

TEST(Layout, Example1_ProducedByteMap_InterleavedPerMotor) {
  ProducedImage img;
  img.status_low = StatusLowWord{0x1003};
  img.status_high = StatusHighWord{0x0008};
  img.addressed = CommandSlot{0x1011, 0x1400};
  img.direct = {{0xA001, 0xA002}, {0xB001, 0xB002}, {0xC001, 0xC002}, {0xD001, 0xD002}};
  auto bytes = EncodeProduced(Example1Layout(), img);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  ASSERT_EQ(bytes->size(), 24u);
  EXPECT_EQ((*bytes)[8], 0x01);  // DO1 A
  EXPECT_EQ((*bytes)[9], 0xA0);
  EXPECT_EQ((*bytes)[10], 0x02);  // DO2 A
  EXPECT_EQ((*bytes)[12], 0x01);  // DO1 B
  EXPECT_EQ((*bytes)[13], 0xB0);
  EXPECT_EQ((*bytes)[22], 0x02);  // DO2 D
  EXPECT_EQ((*bytes)[23], 0xD0);
  auto back = DecodeProduced(Example1Layout(), *bytes);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, img);
}

TEST(Layout, Example2_Tc44_FramesAndImage) {
  // CW 0x0002; slot A: 0x0011 / 5120; slot C: 0x0011 / -5120 (lines 523-540).
  ConsumedImage img;
  img.control = ControlWord{0x0002};
  img.direct = {{0x0011, 0x1400}, {0x0011, static_cast<uint16_t>(-5120)}};
  auto bytes = EncodeConsumed(Example2Layout(), img);
  ASSERT_TRUE(bytes.ok());
  auto frames = EncodePollCommand(5, *bytes, ConsumedSize(Example2Layout()));
  ASSERT_TRUE(frames.ok());
  ASSERT_EQ(frames->size(), 2u);
  EXPECT_EQ(FrameToString((*frames)[0]), "42D#00.02.00.11.00.00.14.11");
  EXPECT_EQ(FrameToString((*frames)[1]), "42D#81.00.00.EC");
  // Drive side: reassemble and decode.
  IoReceiver rx(10);
  ASSERT_TRUE(rx.Feed((*frames)[0].payload()).ok());
  auto msg = rx.Feed((*frames)[1].payload());
  ASSERT_TRUE(msg.ok());
  ASSERT_TRUE(msg->has_value());
  auto decoded = DecodeConsumed(Example2Layout(), **msg);
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(*decoded, img);
  // Produced: 8 bytes, unfragmented; DO1 A = 5120, DO1 C = -5120 after settling.
  ProducedImage out;
  out.status_low = StatusLowWord{0x1003};
  out.status_high = StatusHighWord{0};
  out.direct = {{0x1400, std::nullopt}, {static_cast<uint16_t>(-5120), std::nullopt}};
  auto pb = EncodeProduced(Example2Layout(), out);
  ASSERT_TRUE(pb.ok());
  auto resp = EncodePollResponse(5, *pb, 8);
  ASSERT_TRUE(resp.ok());
  ASSERT_EQ(resp->size(), 1u);
  EXPECT_EQ(FrameToString((*resp)[0]), "3C5#03.10.00.00.00.14.00.EC");
}

TEST(Layout, Example2_Tc45_DirectSlotSetsVariable) {
  auto frames = std::vector<Frame>{*ParseFrame("42D#00.02.00.11.00.00.14.71"),
                                   *ParseFrame("42D#81.00.04.00")};
  IoReceiver rx(10);
  ASSERT_TRUE(rx.Feed(frames[0].payload()).ok());
  auto msg = rx.Feed(frames[1].payload());
  ASSERT_TRUE(msg.ok() && msg->has_value());
  auto img = DecodeConsumed(Example2Layout(), **msg);
  ASSERT_TRUE(img.ok());
  ASSERT_EQ(img->direct.size(), 2u);
  EXPECT_EQ(img->direct[1], (CommandSlot{0x0071, 4}));  // slot C: Set DO1 Variable = Actual Speed
  EXPECT_STREQ(DirectOutVariableName(img->direct[1].value), "Actual Speed");
}

TEST(Layout, Example1_Tc46_BothDirectionsFragmented) {
  ConsumedImage in = EmptyConsumed(Example1Layout());
  in.control = ControlWord{0x0002};
  in.addressed = CommandSlot{0x1018, 0};
  auto cb = EncodeConsumed(Example1Layout(), in);
  ASSERT_TRUE(cb.ok());
  auto cmd = EncodePollCommand(5, *cb, 22);
  ASSERT_TRUE(cmd.ok());
  ASSERT_EQ(cmd->size(), 4u);
  EXPECT_EQ((*cmd)[0].payload()[0], 0x00);
  EXPECT_EQ((*cmd)[1].payload()[0], 0x41);
  EXPECT_EQ((*cmd)[2].payload()[0], 0x42);
  EXPECT_EQ((*cmd)[3].payload()[0], 0x83);
  EXPECT_EQ((*cmd)[3].dlc, 2);
  EXPECT_EQ(Concat(*cmd, true), *cb);

  ProducedImage out = EmptyProduced(Example1Layout());
  out.addressed = CommandSlot{in.addressed->word, 0xFF00};  // echo + actual position
  auto pb = EncodeProduced(Example1Layout(), out);
  ASSERT_TRUE(pb.ok());
  EXPECT_EQ((*pb)[4], (*cb)[2]);  // echo at offsets 4-5 = consumed offsets 2-3
  EXPECT_EQ((*pb)[5], (*cb)[3]);
  auto resp = EncodePollResponse(5, *pb, 24);
  ASSERT_TRUE(resp.ok());
  ASSERT_EQ(resp->size(), 4u);
  EXPECT_EQ((*resp)[3].dlc, 4);
  IoReceiver rx(24);
  std::optional<Bytes> got;
  for (const Frame& f : *resp) {
    auto m = rx.Feed(f.payload());
    ASSERT_TRUE(m.ok()) << m.status();
    if (m->has_value()) got = **m;
  }
  ASSERT_TRUE(got.has_value());
  auto decoded = DecodeProduced(Example1Layout(), *got);
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(*decoded, out);
}

TEST(Layout, F1_Tc12_GetStatusLowWord_Bytes) {
  ConsumedImage in;
  in.control = ControlWord{0x0002};
  in.addressed = CommandSlot{0x0002, 0};
  auto cb = EncodeConsumed(F1(), in);
  ASSERT_TRUE(cb.ok());
  auto cmd = EncodePollCommand(5, *cb, 6);
  ASSERT_TRUE(cmd.ok());
  EXPECT_EQ(FrameToString((*cmd)[0]), "42D#02.00.02.00.00.00");
  ProducedImage out;
  out.status_low = StatusLowWord{0x1003};
  out.status_high = StatusHighWord{0x0000};
  out.addressed = CommandSlot{0x0002, 0x1003};
  auto pb = EncodeProduced(F1(), out);
  ASSERT_TRUE(pb.ok());
  auto resp = EncodePollResponse(5, *pb, 8);
  ASSERT_TRUE(resp.ok());
  EXPECT_EQ(FrameToString((*resp)[0]), "3C5#03.10.00.00.02.00.03.10");
}

TEST(Layout, F1Prime_Tc15_SetControlWordWithoutControlIn) {
  auto f = ParseFrame("42D#05.00.02.00");
  ASSERT_TRUE(f.ok());
  auto img = DecodeConsumed(F1Prime(), f->payload());
  ASSERT_TRUE(img.ok());
  EXPECT_FALSE(img->control.has_value());
  EXPECT_EQ(img->addressed, (CommandSlot{0x0005, 0x0002}));
}

TEST(Layout, Tc01_FirstPoll_ZeroImage) {
  auto cb = EncodeConsumed(F1(), EmptyConsumed(F1()));
  ASSERT_TRUE(cb.ok());
  auto cmd = EncodePollCommand(5, *cb, 6);
  ASSERT_TRUE(cmd.ok());
  EXPECT_EQ(FrameToString((*cmd)[0]), "42D#00.00.00.00.00.00");
  auto pb = EncodeProduced(F1(), EmptyProduced(F1()));
  ASSERT_TRUE(pb.ok());
  auto resp = EncodePollResponse(5, *pb, 8);
  ASSERT_TRUE(resp.ok());
  EXPECT_EQ((*resp)[0].dlc, 8);
}

TEST(Layout, ByteOrder_BigEndianSwitch_D1) {
  IoLayout l = F1();
  l.byte_order = ByteOrder::kBigEndian;
  ConsumedImage in;
  in.control = ControlWord{0x0002};
  in.addressed = CommandSlot{0x1011, 0x1400};
  auto cb = EncodeConsumed(l, in);
  ASSERT_TRUE(cb.ok());
  EXPECT_EQ(*cb, (Bytes{0x00, 0x02, 0x10, 0x11, 0x14, 0x00}));
  auto back = DecodeConsumed(l, *cb);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, in);
}

TEST(Layout, Errors_NameModuleAndSizes) {
  ConsumedImage in = EmptyConsumed(F1());
  in.addressed.reset();
  EXPECT_THAT(EncodeConsumed(F1(), in).status().message(),
              HasSubstr("consumed.addressed_in: selected but absent"));
  in = EmptyConsumed(F1());
  in.direct.push_back({});
  EXPECT_THAT(EncodeConsumed(F1(), in).status().message(),
              HasSubstr("consumed.direct_in: 1 slots, layout has 0 (module not selected)"));
  ConsumedImage e2 = EmptyConsumed(Example2Layout());
  e2.direct.pop_back();
  EXPECT_THAT(EncodeConsumed(Example2Layout(), e2).status().message(),
              HasSubstr("1 slots, layout has 2 master drives"));
  EXPECT_THAT(DecodeConsumed(F1(), Bytes(4)).status().message(),
              HasSubstr("consumed: 4 bytes, layout control_in+addressed_in needs 6"));
  EXPECT_THAT(DecodeProduced(F1(), Bytes(6)).status().message(),
              HasSubstr("produced: 6 bytes, layout status_out+addressed_out needs 8"));
  ProducedImage out = EmptyProduced(F1());
  out.status_high.reset();
  EXPECT_THAT(EncodeProduced(F1(), out).status().message(), HasSubstr("come together"));
  ProducedImage e1 = EmptyProduced(Example1Layout());
  e1.direct[2].out_2.reset();
  EXPECT_THAT(EncodeProduced(Example1Layout(), e1).status().message(),
              HasSubstr("produced.direct_out[2].out_2: selected but absent"));
  IoLayout bad = F1();
  bad.master_drives = 0x10;
  EXPECT_THAT(ValidateLayout(bad).message(), HasSubstr("master_drives: 0x10 exceeds 0xF"));
  EXPECT_FALSE(EncodeConsumed(bad, EmptyConsumed(F1())).ok());
}

TEST(Words, StatusLowHigh_Tc12Tc13) {
  const StatusLowWord sl{0x1003};
  EXPECT_TRUE(sl.init_done());
  EXPECT_TRUE(sl.run_state());
  EXPECT_TRUE(sl.in_position(Motor::kA));
  EXPECT_FALSE(sl.in_position(Motor::kB));
  EXPECT_FALSE(sl.error_pending());
  EXPECT_THAT(SetBitNames(WordKind::kStatusLow, sl.raw),
              ElementsAre("INIT Done", "RUN State", "In Position A"));
  const StatusHighWord sh{0x000A};
  EXPECT_TRUE(sh.position_range(Motor::kA));
  EXPECT_TRUE(sh.command_toggle(Motor::kA));
  EXPECT_FALSE(sh.command_toggle(Motor::kB));
  EXPECT_EQ(StatusHighWord::Bit(Motor::kD, StatusHighWord::kCommandToggle), 0x8000);
  EXPECT_STREQ(WordBitName(WordKind::kStatusHigh, 7), "Motor B Command Toggle");
  EXPECT_EQ(sl.With(StatusLowWord::kErrorPending, true).raw, 0x1043);
}

TEST(Words, ControlWord_Bits) {
  const ControlWord cw{0x0102};
  EXPECT_TRUE(cw.run_request());
  EXPECT_TRUE(cw.trigger(Motor::kA));
  EXPECT_FALSE(cw.trigger(Motor::kB));
  EXPECT_FALSE(ControlWord{0x0004}.run_request());
  EXPECT_TRUE(ControlWord{0x0004}.stop_request());
  EXPECT_TRUE(ControlWord{0x0008}.init_request());
  EXPECT_TRUE(ControlWord{0x0010}.freeze_request());
  EXPECT_TRUE(ControlWord{0x2000}.freeze_motor(Motor::kB));
  EXPECT_THAT(SetBitNames(WordKind::kControl, 0x0102),
              ElementsAre("RUN Request", "Trig In Motor A"));
}

TEST(Words, StateWords_BitNames_8_5) {
  // TC-34 / TC-35: system word bit 12 = motor A; motor word bits.
  EXPECT_THAT(SetBitNames(WordKind::kSystemWarnState, 0x1000), ElementsAre("Warn Motor A"));
  EXPECT_THAT(SetBitNames(WordKind::kMotorWarnState, 0x0001), ElementsAre("Motor Too Hot Calc"));
  EXPECT_THAT(SetBitNames(WordKind::kSystemErrorState, 0x0080), ElementsAre("Coded error"));
  EXPECT_THAT(SetBitNames(WordKind::kMotorErrorState, 0x0004), ElementsAre("Following Error"));
  EXPECT_THAT(SetBitNames(WordKind::kControllerIo, 0x0501),
              ElementsAre("Run request", "Dig In 5", "Warn out"));  // TC-39
  EXPECT_THAT(SetBitNames(WordKind::kExtendedIo, 0xA53C).size(), 8u);
  EXPECT_STREQ(WordBitName(WordKind::kControllerIo, 15), "Dig out 6");
  EXPECT_STREQ(WordBitName(WordKind::kControl, 16), "Unknown Bit");
  EXPECT_EQ(kControllerIoOutputMask, 0xFC00);
  EXPECT_STREQ(DirectOutVariableName(0), "Actual Pos");
  EXPECT_STREQ(DirectOutVariableName(8), "unknown");
}

}  // namespace
}  // namespace drivegw::linmot::devicenet
