// Predefined connection set (CiA 301 §7.3.3 Tables 71/72).
#include "adapters/canopen/cob_id.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace drivegw::canopen {
namespace {

using ::testing::HasSubstr;

TEST(CobIdTest, PeerToPeerIdentifiersAddTheNodeId) {
  struct Row {
    Function function;
    uint16_t id;
  };
  const Row rows[] = {
      {Function::kEmcy, 0x085},  {Function::kTpdo1, 0x185}, {Function::kRpdo1, 0x205},
      {Function::kTpdo2, 0x285}, {Function::kRpdo2, 0x305}, {Function::kTpdo3, 0x385},
      {Function::kRpdo3, 0x405}, {Function::kTpdo4, 0x485}, {Function::kRpdo4, 0x505},
      {Function::kSdoTx, 0x585}, {Function::kSdoRx, 0x605}, {Function::kNmtErrorControl, 0x705},
  };
  for (const Row& r : rows) {
    auto id = CobId(r.function, 5);
    ASSERT_TRUE(id.ok()) << FunctionName(r.function) << ": " << id.status();
    EXPECT_EQ(*id, r.id) << FunctionName(r.function);
    auto cls = ClassifyCobId(r.id);
    ASSERT_TRUE(cls.ok()) << cls.status();
    EXPECT_EQ(*cls, (CobIdClass{r.function, 5}));
  }
  EXPECT_EQ(*CobId(Function::kSdoRx, 127), 0x67F);
  EXPECT_EQ(*ClassifyCobId(0x77F), (CobIdClass{Function::kNmtErrorControl, 127}));
}

TEST(CobIdTest, BroadcastObjectsHaveFixedIdentifiers) {
  EXPECT_EQ(*CobId(Function::kNmt, 0), 0x000);
  EXPECT_EQ(*CobId(Function::kSync, 0), 0x080);
  EXPECT_EQ(*CobId(Function::kTime, 0), 0x100);
  EXPECT_EQ(*ClassifyCobId(0x000), (CobIdClass{Function::kNmt, 0}));
  EXPECT_EQ(*ClassifyCobId(0x080), (CobIdClass{Function::kSync, 0}));
  EXPECT_EQ(*ClassifyCobId(0x100), (CobIdClass{Function::kTime, 0}));
  auto bad = CobId(Function::kSync, 3);
  EXPECT_THAT(bad.status().message(), HasSubstr("sync.node_id: 3 must be 0"));
}

TEST(CobIdTest, NodeIdOutsideOneTo127IsRefusedNamingTheLimit) {
  EXPECT_TRUE(ValidateNodeId(1).ok());
  EXPECT_TRUE(ValidateNodeId(127).ok());
  EXPECT_EQ(ValidateNodeId(0).message(), "canopen node_id: 0 outside 1..127");
  EXPECT_EQ(ValidateNodeId(128).message(), "canopen node_id: 128 outside 1..127");
  EXPECT_EQ(CobId(Function::kEmcy, 128).status().message(),
            "canopen emcy.node_id: 128 outside 1..127");
  EXPECT_FALSE(CobId(Function::kSdoTx, 0).ok());
}

TEST(CobIdTest, IdentifiersOutsideThePredefinedSetAreNotFound) {
  for (uint32_t id :
       {0x001u, 0x101u, 0x17Fu, 0x180u, 0x580u, 0x680u, 0x6FFu, 0x700u, 0x780u, 0x7E5u, 0x7FFu}) {
    auto cls = ClassifyCobId(id);
    EXPECT_EQ(cls.status().code(), absl::StatusCode::kNotFound) << std::hex << id;
  }
  EXPECT_EQ(ClassifyCobId(0x680).status().message(),
            "canopen cob id 0x680: not in the CiA 301 predefined connection set");
  auto wide = ClassifyCobId(0x800);
  EXPECT_EQ(wide.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(wide.status().message(), HasSubstr("exceeds 0x7FF"));
}

TEST(CobIdTest, EveryElevenBitIdentifierClassifiesConsistently) {
  // Whatever classifies must map back to the same identifier.
  for (uint32_t id = 0; id <= 0x7FF; ++id) {
    auto cls = ClassifyCobId(id);
    if (!cls.ok()) continue;
    auto back = CobId(cls->function, cls->node);
    ASSERT_TRUE(back.ok()) << std::hex << id << ": " << back.status();
    EXPECT_EQ(*back, id);
  }
}

}  // namespace
}  // namespace drivegw::canopen
