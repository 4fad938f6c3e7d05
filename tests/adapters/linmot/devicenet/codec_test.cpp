// DeviceNet link codec tests: identifier math (§5.1, §5.2), the worked explicit frames of §5.3,
// §5.5, §11 and §13, fragmentation (§5.8), duplicate MAC ID check (§5.7), UCMM (§5.9).
#include "adapters/linmot/devicenet/codec.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "adapters/linmot/devicenet/codec_can.h"

namespace drivegw::linmot::devicenet {
namespace {

using ::testing::HasSubstr;
using Bytes = std::vector<uint8_t>;

Frame F(const char* text) {
  auto f = ParseFrame(text);
  EXPECT_TRUE(f.ok()) << text << ": " << f.status();
  return f.ok() ? *f : Frame{};
}

Bytes Payload(const char* text) {
  const Frame f = F(text);
  return Bytes(f.payload().begin(), f.payload().end());
}

uint16_t Id(MessageGroup g, uint8_t mac, uint8_t msg) {
  auto id = EncodeIdentifier(Identifier{g, mac, msg});
  EXPECT_TRUE(id.ok()) << id.status();
  return id.ok() ? *id : 0;
}

// ---- Frames ----------------------------------------------------------------------------------

TEST(Frame, ParseAndFormat_RoundTrip) {
  const Frame f = F("42D#02.00.11.10.00.14");
  EXPECT_EQ(f.id, 0x42D);
  EXPECT_EQ(f.payload().size(), 6u);
  EXPECT_EQ(FrameToString(f), "42D#02.00.11.10.00.14");
  EXPECT_EQ(FrameToString(F("42A#")), "42A#");
  EXPECT_EQ(F("42E#004B03010300"), F("42E#00.4B.03.01.03.00"));
}

TEST(Frame, Make_TooLong_NamesLimit) {
  const Bytes nine(9, 0);
  auto f = MakeFrame(0x42D, nine);
  ASSERT_FALSE(f.ok());
  EXPECT_EQ(f.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(f.status().message(), HasSubstr("9 data bytes exceed 8"));
  auto g = MakeFrame(0x800, {});
  ASSERT_FALSE(g.ok());
  EXPECT_THAT(g.status().message(), HasSubstr("0x800 exceeds 11 bits"));
}

TEST(Frame, Parse_Garbage_InvalidArgument) {
  EXPECT_FALSE(ParseFrame("42D").ok());
  EXPECT_FALSE(ParseFrame("XYZ#00").ok());
  EXPECT_FALSE(ParseFrame("42D#0").ok());
  EXPECT_FALSE(ParseFrame("42D#00.11.22.33.44.55.66.77.88").ok());
}

TEST(Frame, CanFrameConversion_RoundTrip) {
  const Frame f = F("3C5#03.10.00.00.02.00.03.10");
  const transport::CanFrame c = ToCanFrame(f);
  EXPECT_EQ(c.id, 0x3C5u);
  EXPECT_FALSE(c.extended);
  EXPECT_EQ(c.dlc, 8);
  auto back = FromCanFrame(c);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, f);
}

TEST(Frame, CanFrameConversion_NonDeviceNetFrames_Rejected) {
  transport::CanFrame ext;
  ext.id = 0x12345;
  ext.extended = true;
  EXPECT_THAT(FromCanFrame(ext).status().message(), HasSubstr("extended identifier"));
  transport::CanFrame rtr;
  rtr.id = 0x42D;
  rtr.rtr = true;
  EXPECT_THAT(FromCanFrame(rtr).status().message(), HasSubstr("remote frame"));
  transport::CanFrame err;
  err.error = true;
  EXPECT_FALSE(FromCanFrame(err).ok());
}

// ---- Identifiers (§5.1, §5.2) ------------------------------------------------------------------

TEST(Identifier, PredefinedSet_Mac5_MatchesTable) {
  auto ids = PredefinedSetIds(5);
  ASSERT_TRUE(ids.ok());
  EXPECT_EQ(ids->cos_response, 0x345);
  EXPECT_EQ(ids->poll_response, 0x3C5);
  EXPECT_EQ(ids->cos_acknowledge, 0x42A);
  EXPECT_EQ(ids->explicit_response, 0x42B);
  EXPECT_EQ(ids->explicit_request, 0x42C);
  EXPECT_EQ(ids->poll_command, 0x42D);
  EXPECT_EQ(ids->unconnected_request, 0x42E);
  EXPECT_EQ(ids->duplicate_mac_check, 0x42F);
}

TEST(Identifier, PredefinedSet_Mac63_MatchesTable) {
  auto ids = PredefinedSetIds(63);
  ASSERT_TRUE(ids.ok());
  EXPECT_EQ(ids->cos_response, 0x37F);
  EXPECT_EQ(ids->poll_response, 0x3FF);
  EXPECT_EQ(ids->cos_acknowledge, 0x5FA);
  EXPECT_EQ(ids->explicit_response, 0x5FB);
  EXPECT_EQ(ids->explicit_request, 0x5FC);
  EXPECT_EQ(ids->poll_command, 0x5FD);
  EXPECT_EQ(ids->unconnected_request, 0x5FE);
  EXPECT_EQ(ids->duplicate_mac_check, 0x5FF);
  // TC-09: MAC 63 polls on 0x5FD, answers on 0x3FF, checks on 0x5FF.
}

TEST(Identifier, Mac42FromHexSwitches_Tc08) {
  auto ids = PredefinedSetIds(0x2A);  // switches 2, A
  ASSERT_TRUE(ids.ok());
  EXPECT_EQ(ids->duplicate_mac_check, 0x557);
  EXPECT_EQ(ids->unconnected_request, 0x556);
  EXPECT_EQ(ids->explicit_response, 0x553);
  EXPECT_EQ(ids->poll_command, 0x555);
  EXPECT_EQ(ids->poll_response, 0x3EA);
}

TEST(Identifier, OtherMessagesOfTable_5_2) {
  EXPECT_EQ(Id(MessageGroup::kGroup1, 5, kG1MulticastPollResponse), 0x305);
  EXPECT_EQ(Id(MessageGroup::kGroup1, 63, kG1MulticastPollResponse), 0x33F);
  EXPECT_EQ(Id(MessageGroup::kGroup1, 5, kG1BitStrobeResponse), 0x385);
  EXPECT_EQ(Id(MessageGroup::kGroup1, 63, kG1BitStrobeResponse), 0x3BF);
  EXPECT_EQ(Id(MessageGroup::kGroup2, 0, kG2BitStrobeCommand), 0x400);
  EXPECT_EQ(Id(MessageGroup::kGroup2, 0, kG2MulticastPollCommand), 0x401);
  EXPECT_EQ(Id(MessageGroup::kGroup2, 0, kG2DuplicateMacCheck), 0x407);  // gateway's own check
  EXPECT_EQ(Id(MessageGroup::kGroup3, 0, kG3UcmmRequest), 0x780);
  EXPECT_EQ(Id(MessageGroup::kGroup3, 5, kG3UcmmResponse), 0x745);
  EXPECT_EQ(Id(MessageGroup::kGroup4, 0, 0x2C), 0x7EC);
  EXPECT_EQ(Id(MessageGroup::kGroup4, 0, 0x2D), 0x7ED);
  EXPECT_EQ(Id(MessageGroup::kGroup4, 0, 0x2E), 0x7EE);
  EXPECT_EQ(Id(MessageGroup::kGroup4, 0, 0x2F), 0x7EF);
}

TEST(Identifier, SocketCanFilters_5_12) {
  const uint8_t n = 5;
  EXPECT_EQ(Id(MessageGroup::kGroup1, n, kG1PollResponse), 0x3C0 | n);
  EXPECT_EQ(Id(MessageGroup::kGroup1, n, kG1ChangeOfState), 0x340 | n);
  EXPECT_EQ(Id(MessageGroup::kGroup2, n, kG2ExplicitResponse), 0x400 | (n << 3) | 3);
  EXPECT_EQ(Id(MessageGroup::kGroup2, n, kG2DuplicateMacCheck), 0x400 | (n << 3) | 7);
  EXPECT_EQ(Id(MessageGroup::kGroup3, n, kG3UcmmResponse), 0x740 | n);
}

TEST(Identifier, RoundTrip_EveryValidIdentifier) {
  int valid = 0;
  for (uint16_t id = 0; id <= 0x7FF; ++id) {
    auto d = DecodeIdentifier(id);
    if (id >= 0x7F0) {
      EXPECT_FALSE(d.ok()) << id;
      continue;
    }
    ASSERT_TRUE(d.ok()) << id << ": " << d.status();
    auto e = EncodeIdentifier(*d);
    ASSERT_TRUE(e.ok()) << e.status();
    EXPECT_EQ(*e, id);
    ++valid;
  }
  EXPECT_EQ(valid, 0x7F0);
}

TEST(Identifier, Decode_Groups) {
  auto g1 = DecodeIdentifier(0x3C5);
  ASSERT_TRUE(g1.ok());
  EXPECT_EQ(*g1, (Identifier{MessageGroup::kGroup1, 5, 0xF}));
  auto g2 = DecodeIdentifier(0x42E);
  ASSERT_TRUE(g2.ok());
  EXPECT_EQ(*g2, (Identifier{MessageGroup::kGroup2, 5, 6}));
  auto g3 = DecodeIdentifier(0x745);
  ASSERT_TRUE(g3.ok());
  EXPECT_EQ(*g3, (Identifier{MessageGroup::kGroup3, 5, 5}));
  auto g4 = DecodeIdentifier(0x7EF);
  ASSERT_TRUE(g4.ok());
  EXPECT_EQ(*g4, (Identifier{MessageGroup::kGroup4, 0, 0x2F}));
}

TEST(Identifier, Errors_NameFieldAndLimit) {
  auto mac = EncodeIdentifier(Identifier{MessageGroup::kGroup2, 64, 5});
  ASSERT_FALSE(mac.ok());
  EXPECT_EQ(mac.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(mac.status().message(), HasSubstr("identifier.mac_id: 64 exceeds 63"));
  EXPECT_THAT(EncodeIdentifier(Identifier{MessageGroup::kGroup1, 0, 16}).status().message(),
              HasSubstr("message_id: 16 exceeds group 1 limit 15"));
  EXPECT_THAT(EncodeIdentifier(Identifier{MessageGroup::kGroup2, 0, 8}).status().message(),
              HasSubstr("message_id: 8 exceeds group 2 limit 7"));
  EXPECT_THAT(EncodeIdentifier(Identifier{MessageGroup::kGroup3, 0, 7}).status().message(),
              HasSubstr("message_id: 7 exceeds group 3 limit 6"));
  EXPECT_THAT(EncodeIdentifier(Identifier{MessageGroup::kGroup4, 0, 0x30}).status().message(),
              HasSubstr("0x30 exceeds group 4 limit 0x2F"));
  EXPECT_THAT(EncodeIdentifier(Identifier{MessageGroup::kGroup4, 1, 0}).status().message(),
              HasSubstr("group 4 has no MAC field"));
  EXPECT_THAT(DecodeIdentifier(0x7F5).status().message(), HasSubstr("invalid range 0x7F0-0x7FF"));
  EXPECT_THAT(DecodeIdentifier(0x800).status().message(), HasSubstr("exceeds 11 bits"));
  EXPECT_THAT(PredefinedSetIds(64).status().message(), HasSubstr("slave_mac: 64 exceeds 63"));
}

// ---- Explicit messages (§5.3-§5.6, §11.2, §13.2) ------------------------------------------------

Frame ExplicitFrame(uint16_t id, const ExplicitRequest& r) {
  auto bytes = EncodeExplicitRequest(r);
  EXPECT_TRUE(bytes.ok()) << bytes.status();
  auto f = MakeFrame(id, bytes.ok() ? *bytes : Bytes{});
  EXPECT_TRUE(f.ok());
  return *f;
}

Frame ResponseFrame(uint16_t id, const ExplicitResponse& r) {
  auto bytes = EncodeExplicitResponse(r);
  EXPECT_TRUE(bytes.ok()) << bytes.status();
  auto f = MakeFrame(id, bytes.ok() ? *bytes : Bytes{});
  EXPECT_TRUE(f.ok());
  return *f;
}

void ExpectRequestRoundTrip(const char* text, const ExplicitRequest& expected) {
  auto decoded = DecodeExplicitRequest(Payload(text));
  ASSERT_TRUE(decoded.ok()) << text << ": " << decoded.status();
  EXPECT_EQ(*decoded, expected) << text;
}

TEST(Explicit, AllocateExplicitAndPoll_Tc01Bytes) {
  const ExplicitRequest r = AllocateRequest(0, false, kAllocExplicit | kAllocPolled);
  EXPECT_EQ(ExplicitFrame(0x42E, r), F("42E#00.4B.03.01.03.00"));
  ExpectRequestRoundTrip("42E#00.4B.03.01.03.00", r);
  auto params = DecodeAllocate(r);
  ASSERT_TRUE(params.ok());
  EXPECT_EQ(*params, (AllocateParams{0x03, 0}));
  EXPECT_EQ(ResponseFrame(0x42B, AllocateResponse({false, false, 0})), F("42B#00.CB.00"));
  auto resp = DecodeExplicitResponse(Payload("42B#00.CB.00"));
  ASSERT_TRUE(resp.ok());
  auto format = DecodeAllocateResponse(*resp);
  ASSERT_TRUE(format.ok());
  EXPECT_EQ(*format, BodyFormat::k8_8);
}

TEST(Explicit, ThirdPartyAllocateTrace_5_5) {
  const Bytes request = {0x0A, 0x4B, 0x03, 0x01, 0x01, 0x0A};
  auto bytes = EncodeExplicitRequest(AllocateRequest(0x0A, false, kAllocExplicit));
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(*bytes, request);
  auto resp = EncodeExplicitResponse(AllocateResponse({false, false, 0x0A}));
  ASSERT_TRUE(resp.ok());
  EXPECT_EQ(*resp, (Bytes{0x0A, 0xCB, 0x00}));
}

TEST(Explicit, AllocateWithCos_Tc05Bytes) {
  EXPECT_EQ(
      ExplicitFrame(0x42E,
                    AllocateRequest(0, false, kAllocExplicit | kAllocPolled | kAllocChangeOfState)),
      F("42E#00.4B.03.01.13.00"));
}

TEST(Explicit, SecondMasterRejected_Tc02Bytes) {
  const ExplicitRequest r = AllocateRequest(1, false, kAllocExplicit);
  EXPECT_EQ(ExplicitFrame(0x42E, r), F("42E#01.4B.03.01.01.01"));
  const ExplicitResponse err =
      ErrorResponseMessage({false, false, 1}, {kErrObjectStateConflict, kAddAllocationConflict});
  EXPECT_EQ(ResponseFrame(0x42B, err), F("42B#01.94.0C.01"));
  auto decoded = DecodeExplicitResponse(Payload("42B#01.94.0C.01"));
  ASSERT_TRUE(decoded.ok());
  EXPECT_TRUE(decoded->is_error());
  auto pair = DecodeErrorResponse(*decoded);
  ASSERT_TRUE(pair.ok());
  EXPECT_EQ(*pair, (ErrorResponse{0x0C, 0x01}));
  EXPECT_EQ(ErrorResponseText(*pair),
            "object state conflict (0x0C), additional allocation conflict (0x01)");
  // §11.8: the same pair for master 0.
  EXPECT_EQ(ResponseFrame(0x42B, ErrorResponseMessage({false, false, 0}, *pair)),
            F("42B#00.94.0C.01"));
  // After master 0's Release, master 1 gets the set.
  EXPECT_EQ(ExplicitFrame(0x42E, ReleaseRequest(0, false, 0x03)), F("42E#00.4C.03.01.03"));
  EXPECT_EQ(ResponseFrame(0x42B, ReleaseResponse({false, false, 0})), F("42B#00.CC"));
  EXPECT_EQ(ResponseFrame(0x42B, AllocateResponse({false, false, 1})), F("42B#01.CB.00"));
}

TEST(Explicit, ReleaseOnExplicitConnection_11_9) {
  const ExplicitRequest r = ReleaseRequest(0, false, kAllocExplicit | kAllocPolled);
  EXPECT_EQ(ExplicitFrame(0x42C, r), F("42C#00.4C.03.01.03"));
  ExpectRequestRoundTrip("42C#00.4C.03.01.03", r);
  auto choice = DecodeRelease(r);
  ASSERT_TRUE(choice.ok());
  EXPECT_EQ(*choice, 0x03);
  auto resp = DecodeExplicitResponse(Payload("42B#00.CC"));
  ASSERT_TRUE(resp.ok());
  EXPECT_EQ(resp->service, kServiceRelease);
  EXPECT_TRUE(resp->data.empty());
}

TEST(Explicit, GetAttributeSingle_5_3Examples) {
  const ExplicitRequest vendor =
      GetAttributeSingleRequest(0, false, kClassIdentity, 1, kAttrIdentityVendorId);
  EXPECT_EQ(ExplicitFrame(0x42C, vendor), F("42C#00.0E.01.01.01"));
  ExpectRequestRoundTrip("42C#00.0E.01.01.01", vendor);
  const ExplicitRequest produced =
      GetAttributeSingleRequest(0, false, kClassConnection, kInstancePoll, kAttrConnProducedSize);
  EXPECT_EQ(ExplicitFrame(0x42C, produced), F("42C#00.0E.05.02.07"));
  ExpectRequestRoundTrip("42C#00.0E.05.02.07", produced);
  // TC-03: F1 produced 8, consumed 6.
  EXPECT_EQ(ExplicitFrame(0x42C, GetAttributeSingleRequest(0, false, kClassConnection,
                                                           kInstancePoll, kAttrConnConsumedSize)),
            F("42C#00.0E.05.02.08"));
  const ExplicitResponse size8{{false, false, 0}, kServiceGetAttributeSingle, UintValue(8)};
  EXPECT_EQ(ResponseFrame(0x42B, size8), F("42B#00.8E.08.00"));
  auto decoded = DecodeExplicitResponse(Payload("42B#00.8E.06.00"));
  ASSERT_TRUE(decoded.ok());
  auto value = DecodeUintValue(decoded->data);
  ASSERT_TRUE(value.ok());
  EXPECT_EQ(*value, 6);
}

TEST(Explicit, SetExpectedPacketRate_Examples) {
  // §5.3 / TC-01: poll EPR 100 ms.
  EXPECT_EQ(ExplicitFrame(0x42C, SetExpectedPacketRateRequest(0, false, kInstancePoll, 100)),
            F("42C#00.10.05.02.09.64.00"));
  ExpectRequestRoundTrip("42C#00.10.05.02.09.64.00",
                         SetExpectedPacketRateRequest(0, false, kInstancePoll, 100));
  // §11.2 step 5: explicit EPR 2500 ms, and 0 (watchdog off).
  EXPECT_EQ(ExplicitFrame(0x42C, SetExpectedPacketRateRequest(0, false, kInstanceExplicit, 2500)),
            F("42C#00.10.05.01.09.C4.09"));
  EXPECT_EQ(ExplicitFrame(0x42C, SetExpectedPacketRateRequest(0, false, kInstanceExplicit, 0)),
            F("42C#00.10.05.01.09.00.00"));
  // TC-05: CoS heartbeat 1000 ms; §11.2 step 7: inhibit time attribute 17 (0x11).
  EXPECT_EQ(ExplicitFrame(0x42C, SetExpectedPacketRateRequest(0, false, kInstanceCosCyclic, 1000)),
            F("42C#00.10.05.04.09.E8.03"));
  EXPECT_EQ(ExplicitFrame(0x42C,
                          SetAttributeSingleRequest(0, false, kClassConnection, kInstanceCosCyclic,
                                                    kAttrConnProductionInhibitTime, UintValue(20))),
            F("42C#00.10.05.04.11.14.00"));
  // §5.6: third-party trace, 0x0E0A requested, 0x0E10 granted.
  EXPECT_EQ(ExplicitFrame(0x42C, SetExpectedPacketRateRequest(0, false, kInstancePoll, 0x0E0A)),
            F("42C#00.10.05.02.09.0A.0E"));
  auto granted = DecodeExplicitResponse(Payload("42B#00.90.10.0E"));
  ASSERT_TRUE(granted.ok());
  EXPECT_EQ(granted->service, kServiceSetAttributeSingle);
  auto v = DecodeUintValue(granted->data);
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(*v, 0x0E10);
}

TEST(Explicit, XidAndHeader_Bits) {
  EXPECT_EQ(EncodeExplicitHeader({false, true, 5}), 0x45);
  EXPECT_EQ(EncodeExplicitHeader({true, false, 63}), 0xBF);
  EXPECT_EQ(DecodeExplicitHeader(0x45), (ExplicitHeader{false, true, 5}));
  for (int b = 0; b < 256; ++b) {
    EXPECT_EQ(EncodeExplicitHeader(DecodeExplicitHeader(static_cast<uint8_t>(b))), b);
  }
  const ExplicitRequest r = GetAttributeSingleRequest(0, true, kClassConnection, 1, 1);
  EXPECT_EQ(ExplicitFrame(0x42C, r), F("42C#40.0E.05.01.01"));
}

TEST(Explicit, BodyFormats_WidenClassAndInstance) {
  ExplicitRequest r = GetAttributeSingleRequest(0, false, 0x0105, 0x0302, 7);
  EXPECT_FALSE(EncodeExplicitRequest(r, BodyFormat::k8_8).ok());
  auto b16 = EncodeExplicitRequest(r, BodyFormat::k16_16);
  ASSERT_TRUE(b16.ok());
  EXPECT_EQ(*b16, (Bytes{0x00, 0x0E, 0x05, 0x01, 0x02, 0x03, 0x07}));
  auto back = DecodeExplicitRequest(*b16, BodyFormat::k16_16);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, r);
  r.class_id = 5;
  auto b816 = EncodeExplicitRequest(r, BodyFormat::k8_16);
  ASSERT_TRUE(b816.ok());
  EXPECT_EQ(*b816, (Bytes{0x00, 0x0E, 0x05, 0x02, 0x03, 0x07}));
  r.class_id = 0x0105;
  r.instance_id = 2;
  auto b168 = EncodeExplicitRequest(r, BodyFormat::k16_8);
  ASSERT_TRUE(b168.ok());
  EXPECT_EQ(*b168, (Bytes{0x00, 0x0E, 0x05, 0x01, 0x02, 0x07}));
}

TEST(Explicit, EncodeErrors_NameField) {
  ExplicitRequest r = GetAttributeSingleRequest(0, false, 256, 1, 1);
  EXPECT_THAT(EncodeExplicitRequest(r).status().message(),
              HasSubstr("explicit_request.class_id: 256 exceeds 8-bit body format 8/8"));
  r = GetAttributeSingleRequest(64, false, 1, 1, 1);
  EXPECT_THAT(EncodeExplicitRequest(r).status().message(),
              HasSubstr("header.mac_id: 64 exceeds 63"));
  r = GetAttributeSingleRequest(0, false, 1, 1, 1);
  r.attribute_id.reset();
  EXPECT_THAT(EncodeExplicitRequest(r).status().message(), HasSubstr("attribute_id: absent"));
  r = AllocateRequest(0, false, 3);
  r.attribute_id = 1;
  EXPECT_THAT(EncodeExplicitRequest(r).status().message(), HasSubstr("takes none"));
  r = AllocateRequest(0, false, 3);
  r.header.fragmented = true;
  EXPECT_THAT(EncodeExplicitRequest(r).status().message(), HasSubstr("Fragmenter"));
  r = AllocateRequest(0, false, 3);
  r.service = 0x8B;
  EXPECT_THAT(EncodeExplicitRequest(r).status().message(), HasSubstr("exceeds 0x7F"));
  ExplicitResponse bad_error{{false, false, 0}, kServiceErrorResponse, {0x0C}};
  EXPECT_THAT(EncodeExplicitResponse(bad_error).status().message(),
              HasSubstr("an error response carries 2"));
}

TEST(Explicit, DecodeErrors_NameProblem) {
  EXPECT_THAT(DecodeExplicitRequest(Payload("42C#00")).status().message(),
              HasSubstr("1 bytes, header and service need 2"));
  EXPECT_THAT(
      DecodeExplicitRequest(Payload("42C#00.0E.05.02")).status().message(),
      HasSubstr("4 bytes, Get_Attribute_Single with class, instance and attribute needs 5"));
  EXPECT_THAT(DecodeExplicitRequest(Payload("42C#00.8E.05.02.07")).status().message(),
              HasSubstr("R/R bit set"));
  EXPECT_THAT(DecodeExplicitRequest(Payload("42C#80.0E.05.02.07")).status().message(),
              HasSubstr("fragmented"));
  EXPECT_THAT(DecodeExplicitResponse(Payload("42B#00.0E")).status().message(),
              HasSubstr("R/R bit clear"));
  EXPECT_THAT(DecodeExplicitResponse(Payload("42B#00.94.0C")).status().message(),
              HasSubstr("error response with 1 data bytes"));
  EXPECT_THAT(DecodeAllocate(GetAttributeSingleRequest(0, false, 3, 1, 1)).status().message(),
              HasSubstr("is not 0x4B"));
  ExplicitRequest wrong_class = AllocateRequest(0, false, 3);
  wrong_class.class_id = 5;
  EXPECT_THAT(DecodeAllocate(wrong_class).status().message(), HasSubstr("class 3, instance 1"));
  ExplicitRequest bad_mac = AllocateRequest(0, false, 3);
  bad_mac.data[1] = 64;
  EXPECT_THAT(DecodeAllocate(bad_mac).status().message(),
              HasSubstr("allocate.allocator_mac: 64 exceeds 63"));
  ExplicitRequest short_alloc = AllocateRequest(0, false, 3);
  short_alloc.data.pop_back();
  EXPECT_THAT(DecodeAllocate(short_alloc).status().message(), HasSubstr("needs 2"));
}

TEST(Explicit, ErrorResponseStatus_CarriesPair) {
  const absl::Status s = ErrorResponseStatus(kServiceAllocate, {0x0C, 0x01});
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(s.message(), HasSubstr("Allocate_Master/Slave_Connection_Set: error response "
                                     "object state conflict (0x0C), additional allocation "
                                     "conflict (0x01)"));
  auto pair = GetErrorResponse(s);
  ASSERT_TRUE(pair.has_value());
  EXPECT_EQ(*pair, (ErrorResponse{0x0C, 0x01}));
  EXPECT_FALSE(GetErrorResponse(absl::InternalError("x")).has_value());
}

TEST(Explicit, D14ErrorPairs_Frames) {
  // D-14: unsupported choice, already allocated, non-Allocate on msg 6.
  EXPECT_EQ(ResponseFrame(0x42B, ErrorResponseMessage({false, false, 0}, {kErrResourceUnavailable,
                                                                          kAddInvalidChoice})),
            F("42B#00.94.02.02"));
  EXPECT_EQ(
      ResponseFrame(0x42B, ErrorResponseMessage({false, false, 0},
                                                {kErrAlreadyInRequestedState, kAddInvalidChoice})),
      F("42B#00.94.0B.02"));
  EXPECT_EQ(
      ResponseFrame(0x42B, ErrorResponseMessage({false, false, 0}, {kErrServiceNotSupported,
                                                                    kAddInvalidGroup2OnlyRequest})),
      F("42B#00.94.08.03"));
  // §5.4: objects without attributes.
  EXPECT_EQ(ResponseFrame(0x42B, ErrorResponseMessage({false, false, 0},
                                                      {kErrAttributeNotSupported, kAddNone})),
            F("42B#00.94.14.FF"));
}

TEST(Explicit, Names) {
  EXPECT_STREQ(ServiceName(0x0E), "Get_Attribute_Single");
  EXPECT_STREQ(ServiceName(0x8E), "Get_Attribute_Single");
  EXPECT_STREQ(ServiceName(0x10), "Set_Attribute_Single");
  EXPECT_STREQ(ServiceName(0x4B), "Allocate_Master/Slave_Connection_Set");
  EXPECT_STREQ(ServiceName(0x4C), "Release_Master/Slave_Connection_Set");
  EXPECT_STREQ(ServiceName(0x14), "Error_Response");
  EXPECT_STREQ(ServiceName(0x33), "unknown service");
  const uint8_t generals[] = {0x02, 0x08, 0x09, 0x0B, 0x0C, 0x0E, 0x10,
                              0x11, 0x13, 0x14, 0x15, 0x16, 0x1F, 0x20};
  for (uint8_t g : generals) EXPECT_STRNE(GeneralErrorName(g), "unknown general error") << int(g);
  EXPECT_STREQ(GeneralErrorName(0x16), "object does not exist");
  EXPECT_STREQ(GeneralErrorName(0x99), "unknown general error");
  EXPECT_STREQ(AdditionalErrorName(0x01), "allocation conflict");
  EXPECT_STREQ(AdditionalErrorName(0xFF), "none");
}

TEST(Explicit, AllocationChoice_Validation) {
  EXPECT_TRUE(ValidateAllocationChoice(0x53).ok());
  EXPECT_THAT(ValidateAllocationChoice(0x33).message(),
              HasSubstr("sets both change_of_state and cyclic"));
  EXPECT_THAT(ValidateAllocationChoice(0x81).message(), HasSubstr("reserved bit 7"));
  EXPECT_EQ(AllocationChoiceText(0x43), "explicit|polled|ack_suppression");
  EXPECT_EQ(AllocationChoiceText(0), "none");
}

// ---- UCMM (§5.9) ------------------------------------------------------------------------------

TEST(Ucmm, OpenRequestAndResponse_RoundTrip) {
  const UcmmOpenRequest req{{false, false, 5}, BodyFormat::k8_8, 1, 4};
  auto bytes = EncodeUcmmOpenRequest(req);
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(*bytes, (Bytes{0x05, 0x4B, 0x00, 0x14}));
  auto back = DecodeUcmmOpenRequest(*bytes);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, req);
  const UcmmOpenResponse resp{{false, false, 0}, BodyFormat::k8_8, 3, 4, 0x0001};
  auto rb = EncodeUcmmOpenResponse(resp);
  ASSERT_TRUE(rb.ok());
  EXPECT_EQ(*rb, (Bytes{0x00, 0xCB, 0x00, 0x34, 0x01, 0x00}));
  auto rback = DecodeUcmmOpenResponse(*rb);
  ASSERT_TRUE(rback.ok());
  EXPECT_EQ(*rback, resp);
  EXPECT_THAT(EncodeUcmmOpenRequest({{false, false, 5}, BodyFormat::k8_8, 2, 4}).status().message(),
              HasSubstr("group_select: 2 is not 0, 1 or 3"));
}

// ---- Fragmentation (§5.8) ---------------------------------------------------------------------

Bytes Seq(size_t n, uint8_t first = 1) {
  Bytes b(n);
  for (size_t i = 0; i < n; ++i) b[i] = static_cast<uint8_t>(first + i);
  return b;
}

TEST(Fragmentation, TenBytePoll_ThirdPartyTrace) {
  auto frames = EncodePollCommand(5, Seq(10), 10);
  ASSERT_TRUE(frames.ok()) << frames.status();
  ASSERT_EQ(frames->size(), 2u);
  EXPECT_EQ((*frames)[0], F("42D#00.01.02.03.04.05.06.07"));
  EXPECT_EQ((*frames)[1], F("42D#81.08.09.0A"));
}

TEST(Fragmentation, SeedPatterns_ByteZeroAndDlc) {
  struct Case {
    size_t size;
    std::vector<std::pair<uint8_t, uint8_t>> pattern;  // byte 0, DLC
  };
  const Case cases[] = {
      {10, {{0x00, 8}, {0x81, 4}}},
      {22, {{0x00, 8}, {0x41, 8}, {0x42, 8}, {0x83, 2}}},
      {24, {{0x00, 8}, {0x41, 8}, {0x42, 8}, {0x83, 4}}},
  };
  for (const Case& c : cases) {
    auto fr = Fragmenter::ForIo(Seq(c.size));
    ASSERT_TRUE(fr.ok());
    ASSERT_EQ(fr->fragment_count(), c.pattern.size()) << c.size;
    for (size_t i = 0; i < c.pattern.size(); ++i) {
      EXPECT_EQ(fr->fragment(i)[0], c.pattern[i].first) << c.size << " #" << i;
      EXPECT_EQ(fr->fragment(i).size(), c.pattern[i].second) << c.size << " #" << i;
    }
  }
  for (size_t n = 0; n <= 8; ++n) {
    auto frames = EncodePollCommand(5, Seq(n), n);
    ASSERT_TRUE(frames.ok());
    ASSERT_EQ(frames->size(), 1u) << n;  // not fragmented
    EXPECT_EQ((*frames)[0].dlc, n);
  }
}

TEST(Fragmentation, Reassembler_Normal_RoundTripAllSizes) {
  for (size_t n = 9; n <= kMaxFragmentedMessage; ++n) {
    const Bytes msg = Seq(n, static_cast<uint8_t>(n));
    auto fr = Fragmenter::ForIo(msg);
    ASSERT_TRUE(fr.ok()) << n;
    Reassembler r;
    std::optional<Bytes> out;
    for (size_t i = 0; i < fr->fragment_count(); ++i) {
      auto step = r.FeedIo(fr->fragment(i));
      ASSERT_TRUE(step.ok()) << n << ": " << step.status();
      if (i + 1 < fr->fragment_count()) {
        EXPECT_FALSE(step->has_value());
      } else {
        out = **step;
      }
    }
    ASSERT_TRUE(out.has_value()) << n;
    EXPECT_EQ(*out, msg);
    EXPECT_TRUE(r.idle());
  }
}

TEST(Fragmentation, Fragmenter_TooSmallOrTooLarge) {
  EXPECT_THAT(Fragmenter::ForIo(Seq(8)).status().message(), HasSubstr("fit one frame"));
  EXPECT_THAT(Fragmenter::ForIo(Bytes(64 * 7 + 1)).status().message(), HasSubstr("more than 64"));
  EXPECT_TRUE(Fragmenter::ForIo(Bytes(64 * 7)).ok());
}

TEST(Fragmentation, OutOfOrder_ErrorNamesCounts_ThenReset) {
  auto fr = Fragmenter::ForIo(Seq(22));
  ASSERT_TRUE(fr.ok());
  Reassembler r;
  ASSERT_TRUE(r.FeedIo(fr->fragment(0)).ok());
  auto bad = r.FeedIo(fr->fragment(2));  // count 2 before 1
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.status().message(),
              HasSubstr("middle fragment count 2 out of order, expected count 1"));
  EXPECT_TRUE(r.idle());
  // The rest of the broken message is dropped too, then a whole message goes through.
  EXPECT_THAT(r.FeedIo(fr->fragment(3)).status().message(),
              HasSubstr("last fragment count 3 without a first fragment"));
  for (size_t i = 0; i < fr->fragment_count(); ++i) ASSERT_TRUE(r.FeedIo(fr->fragment(i)).ok());
}

TEST(Fragmentation, MissingMiddle_Tc46_Discarded) {
  auto fr = Fragmenter::ForIo(Seq(22));
  ASSERT_TRUE(fr.ok());
  IoReceiver rx(22);
  ASSERT_TRUE(rx.Feed(fr->fragment(0)).ok());
  auto missing = rx.Feed(fr->fragment(2));  // 41 omitted
  ASSERT_FALSE(missing.ok());
  EXPECT_THAT(missing.status().message(), HasSubstr("expected count 1"));
  EXPECT_FALSE(rx.Feed(fr->fragment(3)).ok());
}

TEST(Fragmentation, Duplicate_ErrorNamesCount) {
  auto fr = Fragmenter::ForIo(Seq(22));
  ASSERT_TRUE(fr.ok());
  Reassembler r;
  ASSERT_TRUE(r.FeedIo(fr->fragment(0)).ok());
  ASSERT_TRUE(r.FeedIo(fr->fragment(1)).ok());
  auto dup = r.FeedIo(fr->fragment(1));
  ASSERT_FALSE(dup.ok());
  EXPECT_THAT(dup.status().message(), HasSubstr("duplicate middle fragment count 1"));
  EXPECT_TRUE(r.idle());
}

TEST(Fragmentation, NewFirstInterrupts_ReportedAndRestarted) {
  auto fr = Fragmenter::ForIo(Seq(22));
  ASSERT_TRUE(fr.ok());
  Reassembler r;
  ASSERT_TRUE(r.FeedIo(fr->fragment(0)).ok());
  ASSERT_TRUE(r.FeedIo(fr->fragment(1)).ok());
  auto restart = r.FeedIo(fr->fragment(0));
  ASSERT_FALSE(restart.ok());
  EXPECT_THAT(restart.status().message(),
              HasSubstr("missing fragments: message interrupted before count 2"));
  EXPECT_FALSE(r.idle());  // the new first fragment was kept
  ASSERT_TRUE(r.FeedIo(fr->fragment(1)).ok());
  ASSERT_TRUE(r.FeedIo(fr->fragment(2)).ok());
  auto done = r.FeedIo(fr->fragment(3));
  ASSERT_TRUE(done.ok());
  ASSERT_TRUE(done->has_value());
  EXPECT_EQ(**done, Seq(22));
}

TEST(Fragmentation, FirstWithNonZeroCount_AckInData_Empty) {
  Reassembler r;
  EXPECT_THAT(r.FeedIo(Bytes{0x05, 1, 2}).status().message(),
              HasSubstr("first fragment count 5, a first fragment has count 0"));
  EXPECT_THAT(r.FeedIo(Bytes{0xC1, 0x00}).status().message(),
              HasSubstr("ack fragment count 1 in the data stream"));
  EXPECT_THAT(r.FeedIo(Bytes{}).status().message(), HasSubstr("empty frame"));
  EXPECT_THAT(r.FeedIo(Bytes{0x81, 1}).status().message(),
              HasSubstr("last fragment count 1 without a first fragment"));
}

TEST(Fragmentation, Oversize_ErrorNamesLimitAndCount) {
  Reassembler r(16);
  auto fr = Fragmenter::ForIo(Seq(24));
  ASSERT_TRUE(fr.ok());
  ASSERT_TRUE(r.FeedIo(fr->fragment(0)).ok());
  ASSERT_TRUE(r.FeedIo(fr->fragment(1)).ok());
  auto big = r.FeedIo(fr->fragment(2));
  ASSERT_FALSE(big.ok());
  EXPECT_THAT(big.status().message(),
              HasSubstr("oversize: 21 bytes exceed 16 at fragment count 2"));
  EXPECT_TRUE(r.idle());
  // A connection of 22 bytes receiving a 24-byte message.
  IoReceiver rx(22);
  absl::Status last;
  for (size_t i = 0; i < fr->fragment_count(); ++i) last = rx.Feed(fr->fragment(i)).status();
  EXPECT_THAT(last.message(), HasSubstr("oversize"));
}

TEST(Fragmentation, CountWrapsModulo64) {
  // A receiver with a larger limit sees counts 0..63, 0, 1... without complaint.
  Reassembler r(100 * 7);
  ASSERT_TRUE(r.FeedIo(Bytes{FragmentByte(FragmentType::kFirst, 0), 1}).ok());
  for (int i = 1; i < 70; ++i) {
    auto s = r.FeedIo(Bytes{FragmentByte(FragmentType::kMiddle, static_cast<uint8_t>(i)), 1});
    ASSERT_TRUE(s.ok()) << i << ": " << s.status();
  }
  EXPECT_EQ(r.next_count(), 70 % 64);
  auto done = r.FeedIo(Bytes{FragmentByte(FragmentType::kLast, 70 % 64), 1});
  ASSERT_TRUE(done.ok());
  ASSERT_TRUE(done->has_value());
  EXPECT_EQ((*done)->size(), 71u);
}

TEST(Fragmentation, IoReceiver_Unfragmented_LengthChecked_Tc04) {
  IoReceiver rx(6);
  EXPECT_FALSE(rx.fragmented());
  auto ok = rx.Feed(Payload("42D#00.00.00.00.00.00"));
  ASSERT_TRUE(ok.ok());
  ASSERT_TRUE(ok->has_value());
  auto bad = rx.Feed(Payload("42D#00.00.00.00"));
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.status().message(), HasSubstr("io message: 4 bytes, connection size 6"));
}

TEST(Fragmentation, EncodeIoMessage_WrongSize) {
  EXPECT_THAT(EncodePollCommand(5, Seq(4), 6).status().message(),
              HasSubstr("4 bytes, connection size 6"));
}

TEST(Fragmentation, ExplicitFragments_WithAcks) {
  // A Set_Attribute_Single carrying 6 bytes of data: 1 + 1 + 3 + 6 = 11 bytes > 8.
  const ExplicitRequest req =
      SetAttributeSingleRequest(0, true, kClassConnection, 2, 16, Bytes{1, 2, 3, 4, 5, 6});
  auto msg = EncodeExplicitRequest(req);
  ASSERT_TRUE(msg.ok());
  ASSERT_EQ(msg->size(), 11u);
  auto fr = Fragmenter::ForExplicit(*msg);
  ASSERT_TRUE(fr.ok()) << fr.status();
  ASSERT_EQ(fr->fragment_count(), 2u);
  EXPECT_EQ(fr->fragment(0), (Bytes{0xC0, 0x00, 0x10, 0x05, 0x02, 0x10, 0x01, 0x02}));
  EXPECT_EQ(fr->fragment(1), (Bytes{0xC0, 0x81, 0x03, 0x04, 0x05, 0x06}));

  Reassembler rx;
  auto first = fr->Next();
  ASSERT_TRUE(first.ok());
  EXPECT_THAT(fr->Next().status().message(), HasSubstr("not acknowledged yet"));
  ASSERT_TRUE(rx.FeedExplicit(*first).ok());
  auto ack0 = EncodeFragmentAck({{true, true, 5}, 0, kAckSuccess});
  ASSERT_TRUE(ack0.ok());
  EXPECT_EQ(*ack0, (Bytes{0xC5, 0xC0, 0x00}));
  EXPECT_TRUE(IsFragmentAck(*ack0));
  ASSERT_TRUE(fr->AcceptAck(*ack0).ok());
  auto second = fr->Next();
  ASSERT_TRUE(second.ok());
  auto done = rx.FeedExplicit(*second);
  ASSERT_TRUE(done.ok()) << done.status();
  ASSERT_TRUE(done->has_value());
  EXPECT_EQ(**done, *msg);
  auto decoded = DecodeExplicitRequest(**done);
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(*decoded, req);
  EXPECT_THAT(fr->AcceptAck(Bytes{0xC5, 0xC0, 0x00}).message(),
              HasSubstr("ack count 0, expected 1"));
  ASSERT_TRUE(fr->AcceptAck(Bytes{0xC5, 0xC1, 0x00}).ok());
  EXPECT_TRUE(fr->done());
}

TEST(Fragmentation, ExplicitAck_ThirdPartyTrace) {
  auto ack = DecodeFragmentAck(Payload("42B#80.C1.00"));
  ASSERT_TRUE(ack.ok());
  EXPECT_EQ(*ack, (FragmentAck{{true, false, 0}, 1, kAckSuccess}));
  auto bytes = EncodeFragmentAck(*ack);
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(*bytes, Payload("42B#80.C1.00"));
  EXPECT_FALSE(DecodeFragmentAck(Payload("42B#00.C1.00")).ok());
  EXPECT_FALSE(DecodeFragmentAck(Payload("42B#80.41.00")).ok());
}

TEST(Fragmentation, ExplicitAck_FailureStatus) {
  const Bytes msg = Seq(12);
  auto fr = Fragmenter::ForExplicit(msg);
  ASSERT_TRUE(fr.ok());
  ASSERT_TRUE(fr->Next().ok());
  EXPECT_THAT(fr->AcceptAck(Bytes{0x80, 0xC0, kAckTooMuchData}).message(),
              HasSubstr("too much data"));
}

TEST(Fragmentation, ExplicitHeaderChange_Rejected) {
  Reassembler rx;
  ASSERT_TRUE(rx.FeedExplicit(Bytes{0x80, 0x00, 1, 2, 3, 4, 5, 6}).ok());
  auto bad = rx.FeedExplicit(Bytes{0xC0, 0x81, 7});
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.status().message(), HasSubstr("differs from the first fragment's"));
  EXPECT_THAT(rx.FeedExplicit(Bytes{0x00, 0x00, 1}).status().message(),
              HasSubstr("Frag bit clear"));
}

TEST(Fragmentation, IoFragmenter_NoAcks) {
  auto fr = Fragmenter::ForIo(Seq(10));
  ASSERT_TRUE(fr.ok());
  ASSERT_TRUE(fr->Next().ok());
  ASSERT_TRUE(fr->Next().ok());  // back-to-back
  EXPECT_TRUE(fr->done());
  EXPECT_THAT(fr->Next().status().message(), HasSubstr("all 2 fragments sent"));
  EXPECT_FALSE(fr->AcceptAck(Bytes{0x80, 0xC0, 0}).ok());
}

// ---- Duplicate MAC ID check (§5.7) --------------------------------------------------------------

TEST(DuplicateMac, Request_Frame) {
  const DuplicateMacCheck m{false, 0, 0x1234, 0xA1B2C3D4};
  auto f = DuplicateMacCheckFrame(0, m);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(*f, F("407#00.34.12.D4.C3.B2.A1"));  // §11.2 step 1 layout
  auto d = DecodeDuplicateMacCheck(f->payload());
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(*d, m);
}

TEST(DuplicateMac, DriveRequestAndResponse_Tc06Tc10) {
  auto req = DuplicateMacCheckFrame(5, DuplicateMacCheck{false, 0, 0, 0});
  ASSERT_TRUE(req.ok());
  EXPECT_EQ(req->id, 0x42F);
  EXPECT_EQ(req->dlc, 7);
  EXPECT_EQ(req->data[0], 0x00);
  auto resp = DecodeDuplicateMacCheck(Payload("42F#80.01.00.02.00.00.00"));
  ASSERT_TRUE(resp.ok());
  EXPECT_TRUE(resp->response);
  EXPECT_EQ(resp->vendor_id, 1);
  EXPECT_EQ(resp->serial_number, 2u);
}

TEST(DuplicateMac, Errors) {
  EXPECT_THAT(DecodeDuplicateMacCheck(Bytes(6)).status().message(), HasSubstr("6 bytes, needs 7"));
  EXPECT_THAT(EncodeDuplicateMacCheck({false, 128, 0, 0}).status().message(),
              HasSubstr("port: 128 exceeds 127"));
  EXPECT_FALSE(DuplicateMacCheckFrame(64, {}).ok());
}

// ---- I/O frames ------------------------------------------------------------------------------

TEST(IoFrames, CosAndAcks_Tc05) {
  auto cos = EncodeChangeOfState(5, Bytes{0x03, 0x10, 0x00, 0x00}, 4);
  ASSERT_TRUE(cos.ok());
  ASSERT_EQ(cos->size(), 1u);
  EXPECT_EQ((*cos)[0], F("345#03.10.00.00"));
  auto ack = CosAcknowledgeFrame(5);
  ASSERT_TRUE(ack.ok());
  EXPECT_EQ(*ack, F("42A#"));
  auto slave_ack = SlaveCosAcknowledgeFrame(5);
  ASSERT_TRUE(slave_ack.ok());
  EXPECT_EQ(*slave_ack, F("3C5#"));
}

TEST(IoFrames, PollResponse24Bytes_Tc46) {
  auto frames = EncodePollResponse(5, Seq(24), 24);
  ASSERT_TRUE(frames.ok());
  ASSERT_EQ(frames->size(), 4u);
  EXPECT_EQ(FrameToString((*frames)[0]), "3C5#00.01.02.03.04.05.06.07");
  EXPECT_EQ(FrameToString((*frames)[1]), "3C5#41.08.09.0A.0B.0C.0D.0E");
  EXPECT_EQ(FrameToString((*frames)[2]), "3C5#42.0F.10.11.12.13.14.15");
  EXPECT_EQ(FrameToString((*frames)[3]), "3C5#83.16.17.18");
}

}  // namespace
}  // namespace drivegw::linmot::devicenet
