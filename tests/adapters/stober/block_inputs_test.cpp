// The wire binding of Command Mode I409 and End velocity I429 (stober-motion.md §2.5 L228-245,
// §3.2 L364-373; decisions 1172, 1175, 1209): SDO objects, not in the default RPDO layout, whose
// RPDOs are all full.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "adapters/stober/object_map.h"

namespace drivegw::stober {
namespace {

using ::testing::HasSubstr;
namespace co = drivegw::canopen;

TEST(BlockInputsTest, I409AndI429AreBoundAtTheirStoberAddresses) {
  // §7.2 [X]: 2000h + group I (8) × 200h + line.
  absl::StatusOr<ObjectBinding> mode = FindBinding(P("I409"));
  ASSERT_TRUE(mode.ok()) << mode.status();
  EXPECT_EQ(mode->address, (CanOpenAddress{0x3199, 0}));
  EXPECT_EQ(mode->type, WireType::kU8);
  EXPECT_FALSE(mode->read_only);
  absl::StatusOr<ObjectBinding> end = FindBinding(P("I429"));
  ASSERT_TRUE(end.ok()) << end.status();
  EXPECT_EQ(end->address, (CanOpenAddress{0x31AD, 0}));
  EXPECT_EQ(end->type, WireType::kU32);  // a speed >= 0 (decision 1161), 0.001 u/s
  EXPECT_DOUBLE_EQ(end->scale, kUserUnitScale);
  EXPECT_FALSE(end->read_only);
}

TEST(BlockInputsTest, EndVelocityRoundTripsAndNamesTheWireLimit) {
  absl::StatusOr<std::vector<uint8_t>> bytes = Encode(P("I429"), 80.125);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  EXPECT_EQ(*Decode(P("I429"), *bytes), 80.125);
  absl::StatusOr<std::vector<uint8_t>> negative = Encode(P("I429"), -1);
  ASSERT_FALSE(negative.ok());
  EXPECT_THAT(std::string(negative.status().message()), HasSubstr("I429"));
  absl::StatusOr<std::vector<uint8_t>> mode = Encode(P("I409"), 1);
  ASSERT_TRUE(mode.ok()) << mode.status();
  EXPECT_EQ(*mode, (std::vector<uint8_t>{1}));
}

// Decision 1209's premise: every RPDO of the default layout already carries 64 bits, and none
// maps I409 or I429, so they travel by SDO before the edge.
TEST(BlockInputsTest, DefaultRpdosAreFullAndDoNotCarryI409OrI429) {
  int rpdos = 0;
  for (const PdoLayout& layout : DefaultPdoLayout()) {
    if (layout.kind != co::PdoKind::kRpdo) continue;
    ++rpdos;
    int bits = 0;
    for (const PdoField& f : layout.fields) {
      bits += f.entry.bits;
      ASSERT_TRUE(f.param.has_value());
      EXPECT_NE(*f.param, P("I409")) << "RPDO" << layout.number;
      EXPECT_NE(*f.param, P("I429")) << "RPDO" << layout.number;
    }
    EXPECT_EQ(bits, 64) << "RPDO" << layout.number;
  }
  EXPECT_EQ(rpdos, 4);
}

}  // namespace
}  // namespace drivegw::stober
