// Parameter ids, CANopen addressing (stober-motion.md §0.2, §7.2) and catalogue refusals.
#include "sim/stober/parameters.h"

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "sim/stober/motion_core.h"

namespace drivegw::sim::stober {
namespace {

using ::testing::HasSubstr;

TEST(StoberParams, ParseAndPrint) {
  absl::StatusOr<ParamId> id = ParseParamId("I92");
  ASSERT_TRUE(id.ok());
  EXPECT_EQ(*id, (ParamId{'I', 92, 0}));
  EXPECT_EQ(ToString(*id), "I92");
  EXPECT_EQ(*ParseParamId("a515"), (ParamId{'A', 515, 0}));
  EXPECT_EQ(*ParseParamId("A587[1]"), (ParamId{'A', 587, 1}));
  EXPECT_EQ(ToString(ParamId{'A', 587, 1}), "A587[1]");
  EXPECT_EQ(ToString(*ParseParamId("I401")), "I401");
  for (const char* bad : {"", "I", "X10", "I92[", "I92[300]", "I92x", "Iab", "I92[]"}) {
    EXPECT_FALSE(ParseParamId(bad).ok()) << bad;
  }
  EXPECT_THAT(std::string(ParseParamId("X10").status().message()), HasSubstr("group"));
}

TEST(StoberParams, CanOpenIndexOfGroupParameters) {
  // §7.2 examples: I92 → 305Ch, I89 → 3059h, I401 → 3191h, J40 → 3228h.
  EXPECT_EQ(*ToCanOpen(P("I92")), (CanOpenAddress{0x305C, 0}));
  EXPECT_EQ(*ToCanOpen(P("I89")), (CanOpenAddress{0x3059, 0}));
  EXPECT_EQ(*ToCanOpen(P("I401")), (CanOpenAddress{0x3191, 0}));
  EXPECT_EQ(*ToCanOpen(P("J40")), (CanOpenAddress{0x3228, 0}));
  EXPECT_EQ(*ToCanOpen(P("A150")), (CanOpenAddress{0x2096, 0}));
  EXPECT_EQ(*ToCanOpen(P("M511")), (CanOpenAddress{0x39FF, 0}));
  EXPECT_FALSE(ToCanOpen(P("M550")).ok());  // line > 511 of a group other than A
  EXPECT_THAT(std::string(ToCanOpen(P("M550")).status().message()), HasSubstr("M550"));
}

TEST(StoberParams, CiA402ObjectsForGroupALinesAbove511) {
  EXPECT_EQ(*ToCanOpen(P("A515")), (CanOpenAddress{0x6040, 0}));
  EXPECT_EQ(*ToCanOpen(P("A516")), (CanOpenAddress{0x6041, 0}));
  EXPECT_EQ(*ToCanOpen(P("A541")), (CanOpenAddress{0x6060, 0}));
  EXPECT_EQ(*ToCanOpen(P("A567")), (CanOpenAddress{0x607A, 0}));
  EXPECT_EQ(*ToCanOpen(P("A587[1]")), (CanOpenAddress{0x6099, 2}));
  EXPECT_EQ(*FromCanOpen({0x6099, 1}), P("A587[0]"));
  EXPECT_EQ(*FromCanOpen({0x6040, 0}), P("A515"));
  EXPECT_FALSE(ToCanOpen(P("A999")).ok());
  EXPECT_FALSE(FromCanOpen({0x1000, 0}).ok());
}

TEST(StoberParams, EveryCatalogueEntryRoundTripsThroughCanOpen) {
  for (const ParamInfo& info : Catalogue()) {
    absl::StatusOr<CanOpenAddress> address = ToCanOpen(info.id);
    ASSERT_TRUE(address.ok()) << ToString(info.id) << ": " << address.status();
    absl::StatusOr<ParamId> back = FromCanOpen(*address);
    ASSERT_TRUE(back.ok()) << ToString(info.id);
    EXPECT_EQ(*back, info.id) << ToString(info.id);
    EXPECT_LE(info.min, info.default_value) << ToString(info.id);
    EXPECT_GE(info.max, info.default_value) << ToString(info.id);
    EXPECT_FALSE(info.default_source.empty()) << ToString(info.id);
  }
}

TEST(StoberParams, WriteRefusalsNameParameterAndLimit) {
  MotionCore core;
  absl::Status s = core.Write(P("I10"), -1);
  EXPECT_EQ(s.code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(std::string(s.message()), HasSubstr("I10"));
  EXPECT_THAT(std::string(s.message()), HasSubstr("minimum 0"));
  s = core.Write(P("I401"), 12);
  EXPECT_EQ(s.code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(std::string(s.message()), HasSubstr("maximum 11"));
  s = core.Write(P("I401"), 1.5);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  s = core.Write(P("I89"), 2);
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(s.message()), HasSubstr("I89"));
  s = core.Write(P("J40"), 1);
  EXPECT_EQ(s.code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(core.Read(P("J40")).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(core.Write(P("I429"), -10).code(), absl::StatusCode::kOutOfRange);  // a magnitude
  EXPECT_EQ(core.Write(P("I409"), 2).code(), absl::StatusCode::kOutOfRange);    // 0 / 1 (1162)
  EXPECT_TRUE(core.Write(P("I10"), 1500).ok());
  EXPECT_EQ(*core.Read(P("I10")), 1500);
}

}  // namespace
}  // namespace drivegw::sim::stober
