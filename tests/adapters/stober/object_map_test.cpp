// adapters/stober object map: addressing (§7.2 examples), every mapped object's type and
// round trip, range errors naming the parameter and limit, packed status, default PDO layout
// (decisions 1171-1175).
#include "adapters/stober/object_map.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "absl/strings/str_cat.h"

namespace drivegw::stober {
namespace {

namespace co = drivegw::canopen;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

TEST(ParamIdTest, ReferenceExamplesOfSection72) {
  // §7.2 [X]: I92 → 305Ch, I89 → 3059h, I401 → 3191h, J40 → 3228h.
  EXPECT_EQ(*ToCanOpen(P("I92")), (CanOpenAddress{0x305C, 0}));
  EXPECT_EQ(*ToCanOpen(P("I89")), (CanOpenAddress{0x3059, 0}));
  EXPECT_EQ(*ToCanOpen(P("I401")), (CanOpenAddress{0x3191, 0}));
  EXPECT_EQ(*ToCanOpen(P("J40")), (CanOpenAddress{0x3228, 0}));
  EXPECT_EQ(*ToCanOpen(P("A515")), (CanOpenAddress{0x6040, 0}));
  EXPECT_EQ(*ToCanOpen(P("A587[1]")), (CanOpenAddress{0x6099, 2}));
  EXPECT_EQ(*FromCanOpen({0x6041, 0}), P("A516"));
  EXPECT_EQ(*FromCanOpen({0x305C, 0}), P("I92"));
  EXPECT_FALSE(FromCanOpen({0x4000, 0}).ok());
  EXPECT_FALSE(ToCanOpen(P("I600")).ok());
  EXPECT_EQ(ToString(P("a587[1]")), "A587[1]");
  EXPECT_FALSE(ParseParamId("X1").ok());
}

TEST(ObjectMapTest, Cia402ObjectsHaveTheirStandardTypes) {
  struct Want {
    CanOpenAddress address;
    WireType type;
  };
  const Want wants[] = {
      {{0x6040, 0}, WireType::kU16}, {{0x6041, 0}, WireType::kU16}, {{0x6060, 0}, WireType::kI8},
      {{0x6061, 0}, WireType::kI8},  {{0x6064, 0}, WireType::kI32}, {{0x606C, 0}, WireType::kI32},
      {{0x6071, 0}, WireType::kI16}, {{0x607A, 0}, WireType::kI32}, {{0x607C, 0}, WireType::kI32},
      {{0x6081, 0}, WireType::kU32}, {{0x6083, 0}, WireType::kU32}, {{0x6084, 0}, WireType::kU32},
      {{0x6087, 0}, WireType::kU32}, {{0x6098, 0}, WireType::kI8},  {{0x6099, 1}, WireType::kU32},
      {{0x6099, 2}, WireType::kU32}, {{0x609A, 0}, WireType::kU32}, {{0x60A4, 1}, WireType::kU32},
      {{0x60B1, 0}, WireType::kI32}, {{0x60B2, 0}, WireType::kI16}, {{0x60C1, 1}, WireType::kI32},
      {{0x60F2, 0}, WireType::kU16}, {{0x60FF, 0}, WireType::kI32},
  };
  for (const Want& w : wants) {
    absl::StatusOr<ObjectBinding> b = FindBinding(w.address);
    ASSERT_TRUE(b.ok()) << b.status();
    EXPECT_EQ(b->type, w.type) << ToString(b->param);
  }
  EXPECT_EQ(FindBinding(CanOpenAddress{0x606C, 0})->param, P("I88"));
  EXPECT_TRUE(FindBinding(CanOpenAddress{0x6041, 0})->read_only);
}

TEST(ObjectMapTest, EveryObjectIsUniqueAddressedAndRoundTrips) {
  std::set<CanOpenAddress> seen;
  for (const ObjectBinding& b : ObjectMap()) {
    SCOPED_TRACE(ToString(b.param));
    EXPECT_TRUE(seen.insert(b.address).second);
    if (b.address.index != 0x606C) {
      EXPECT_EQ(*ToCanOpen(b.param), b.address);
      EXPECT_EQ(FindBinding(b.param)->address, b.address);
    }
    EXPECT_FALSE(b.name.empty());
    // Largest and smallest wire values and a mid value survive Encode/Decode exactly.
    for (int64_t raw : {WireTypeMin(b.type), WireTypeMax(b.type), int64_t{1}}) {
      if (b.boolean && raw > 1) continue;
      const double user = FromRaw(b, raw);
      absl::StatusOr<std::vector<uint8_t>> bytes = Encode(b, user);
      ASSERT_TRUE(bytes.ok()) << bytes.status();
      EXPECT_EQ(bytes->size(), WireTypeBits(b.type) / 8u);
      EXPECT_EQ(*ToRaw(b, *Decode(b, *bytes)), raw);
    }
  }
  EXPECT_GE(ObjectMap().size(), 100u);
}

TEST(ObjectMapTest, PositionScalingIsOneThousandthOfAUnit) {
  EXPECT_THAT(*Encode(P("I403"), 1.5), ElementsAre(0xDC, 0x05, 0x00, 0x00));  // 1500
  EXPECT_THAT(*Encode(P("I403"), -0.001), ElementsAre(0xFF, 0xFF, 0xFF, 0xFF));
  EXPECT_DOUBLE_EQ(*Decode(P("I403"), std::vector<uint8_t>{0xDC, 0x05, 0, 0}), 1.5);
  EXPECT_DOUBLE_EQ(*Decode(P("I403"), std::vector<uint8_t>{0xFF, 0xFF, 0xFF, 0x7F}), 2147483.647);
  // Torque percent in ‰ (6071h), times in µs, booleans and integers unscaled.
  EXPECT_THAT(*Encode(P("A558"), -12.3), ElementsAre(0x85, 0xFF));
  EXPECT_THAT(*Encode(P("A150"), 0.125), ElementsAre(125, 0, 0, 0));
  EXPECT_THAT(*Encode(P("I401"), 1), ElementsAre(1));
  EXPECT_THAT(*Encode(P("A541"), -1), ElementsAre(0xFF));
  EXPECT_THAT(*Encode(P("A515"), 0x1F), ElementsAre(0x1F, 0));
}

TEST(ObjectMapTest, RangeErrorsNameTheParameterAndTheLimit) {
  absl::StatusOr<std::vector<uint8_t>> e = Encode(P("I403"), 3e6);
  EXPECT_EQ(e.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(e.status().message(), HasSubstr("I403"));
  EXPECT_THAT(e.status().message(), HasSubstr("2147483.647"));
  e = Encode(P("I405"), -1);
  EXPECT_EQ(e.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(e.status().message(), HasSubstr("minimum 0.000"));
  e = Encode(P("I401"), 256);
  EXPECT_THAT(e.status().message(), HasSubstr("I401 (command)"));
  EXPECT_THAT(e.status().message(), HasSubstr("255"));
  EXPECT_EQ(Encode(P("I402"), 2).status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(Encode(P("I401"), 1.5).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Encode(P("I403"), std::nan("")).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Encode(P("J40"), 1).status().code(), absl::StatusCode::kNotFound);
  absl::StatusOr<double> d = Decode(P("I403"), std::vector<uint8_t>{1, 2});
  EXPECT_EQ(d.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(d.status().message(), HasSubstr("2 bytes"));
  EXPECT_EQ(Decode(P("I92"), std::vector<uint8_t>{2}).status().code(),
            absl::StatusCode::kOutOfRange);
}

TEST(ObjectMapTest, StatusFlagsCoverTheStatusSetWithoutOverlap) {
  uint32_t used = 0;
  std::set<ParamId> params;
  for (const StatusFlagBit& f : StatusFlagBits()) {
    EXPECT_EQ(used & f.bit, 0u) << ToString(f.param);
    used |= f.bit;
    params.insert(f.param);
    EXPECT_TRUE(FindBinding(f.param)->read_only) << ToString(f.param);
  }
  for (const char* id : {"I83", "I85", "I86", "I91", "I92", "I180", "I183"}) {
    EXPECT_TRUE(params.contains(P(id))) << id;  // §2.3 status set
  }
  MotionStatus s;
  s.flags = status_bit::kDone | (2u << status_bit::kCommandStateShift);
  EXPECT_TRUE(s.done());
  EXPECT_FALSE(s.error());
  EXPECT_EQ(s.command_state(), 2);
}

TEST(PdoLayoutTest, EveryPdoFitsEightBytesAndMapsItsObjects) {
  for (const PdoLayout& l : DefaultPdoLayout()) {
    SCOPED_TRACE(absl::StrCat(l.kind == co::PdoKind::kRpdo ? "rpdo" : "tpdo", l.number));
    const co::PdoMapping mapping = l.Mapping();
    EXPECT_TRUE(co::ValidateMapping(mapping).ok());
    EXPECT_LE(co::MappingBits(mapping), 64u);
    EXPECT_TRUE(co::ValidateCommParams(l.kind, l.comm).ok());
    for (const PdoField& f : l.fields) {
      EXPECT_EQ(f.entry.bits, WireTypeBits(f.type));
      if (!f.param) {
        EXPECT_EQ(f.entry.index, kStatusFlagsIndex);
        continue;
      }
      absl::StatusOr<ObjectBinding> b = FindBinding(CanOpenAddress{f.entry.index, f.entry.sub});
      ASSERT_TRUE(b.ok());
      EXPECT_EQ(b->param, *f.param);
      // RPDOs carry writable set values only.
      if (l.kind == co::PdoKind::kRpdo) {
        EXPECT_FALSE(b->read_only) << ToString(b->param);
      }
    }
  }
  EXPECT_EQ(FindDefaultPdo(co::PdoKind::kTpdo, 3), nullptr);
}

TEST(PdoLayoutTest, MoveAbsoluteWithUnchangedDynamicsIsOneFrameAndExecuteComesLast) {
  // Decision 1175: command, position and the Execute edge share RPDO1; Execute is the last entry
  // so that an object-by-object write applies the set values first (§2.1).
  const PdoLayout* rpdo1 = FindDefaultPdo(co::PdoKind::kRpdo, 1);
  ASSERT_NE(rpdo1, nullptr);
  ASSERT_EQ(rpdo1->fields.size(), 4u);
  EXPECT_EQ(rpdo1->fields[0].entry.index, 0x6040);
  EXPECT_EQ(*rpdo1->fields[1].param, P("I401"));
  EXPECT_EQ(*rpdo1->fields[2].param, P("I403"));
  EXPECT_EQ(*rpdo1->fields[3].param, P("I402"));
  EXPECT_EQ(co::MappingBits(rpdo1->Mapping()), 64u);
  const std::vector<double> values = {0x1F, 1, 1000.25, 1};
  absl::StatusOr<std::vector<uint8_t>> payload = PackLayout(*rpdo1, values);
  ASSERT_TRUE(payload.ok()) << payload.status();
  EXPECT_THAT(*payload, ElementsAre(0x1F, 0x00, 0x01, 0x3A, 0x43, 0x0F, 0x00, 0x01));
  EXPECT_THAT(*UnpackLayout(*rpdo1, *payload), ElementsAre(0x1F, 1, 1000.25, 1));
  EXPECT_THAT(PackLayout(*rpdo1, std::vector<double>{0x1F, 1, 5e6, 1}).status().message(),
              HasSubstr("I403"));
}

TEST(PdoLayoutTest, StatusAndActualTpdosDecode) {
  const PdoLayout* tpdo1 = FindDefaultPdo(co::PdoKind::kTpdo, 1);
  const std::vector<double> status = {0x1237, 3, 0, status_bit::kDone | status_bit::kInReference};
  absl::StatusOr<MotionStatus> s = DecodeStatusTpdo(*PackLayout(*tpdo1, status));
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_EQ(s->status_word, 0x1237);
  EXPECT_EQ(s->plc_state, 3);
  EXPECT_TRUE(s->done());
  const PdoLayout* tpdo2 = FindDefaultPdo(co::PdoKind::kTpdo, 2);
  absl::StatusOr<ActualValues> a =
      DecodeActualTpdo(*PackLayout(*tpdo2, std::vector<double>{-12.5, 400}));
  ASSERT_TRUE(a.ok());
  EXPECT_DOUBLE_EQ(a->position, -12.5);
  EXPECT_DOUBLE_EQ(a->velocity, 400);
  EXPECT_FALSE(DecodeStatusTpdo(std::vector<uint8_t>{1, 2, 3}).ok());
}

}  // namespace
}  // namespace drivegw::stober
