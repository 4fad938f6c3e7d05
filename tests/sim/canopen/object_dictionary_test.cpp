// Tests for sim/canopen/object_dictionary: typed entries, integer encoding, access rules, hooks
// and their abort codes, resets to defaults and the PDO mapping check.
#include "sim/canopen/object_dictionary.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

namespace drivegw::sim::canopen {
namespace {

namespace co = drivegw::canopen;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using Bytes = std::vector<uint8_t>;

TEST(ObjectDictionary, IntegerEncodingPerType) {
  EXPECT_THAT(*EncodeInteger(DataType::kI16, -2), ElementsAre(0xFE, 0xFF));
  EXPECT_EQ(*DecodeInteger(DataType::kI16, Bytes{0xFE, 0xFF}), -2);
  EXPECT_EQ(*DecodeInteger(DataType::kU16, Bytes{0xFE, 0xFF}), 0xFFFE);
  EXPECT_EQ(*DecodeInteger(DataType::kI8, Bytes{0x80}), -128);
  EXPECT_EQ(*DecodeInteger(DataType::kU64, Bytes(8, 0xFF)), -1);  // the u64 bit pattern
  EXPECT_THAT(std::string(EncodeInteger(DataType::kU16, 70000).status().message()),
              HasSubstr("u16 value 70000 outside 0..65535"));
  EXPECT_FALSE(EncodeInteger(DataType::kI8, 128).ok());
  EXPECT_FALSE(DecodeInteger(DataType::kU32, Bytes{1, 2}).ok());
  EXPECT_FALSE(EncodeInteger(DataType::kString, 1).ok());
}

TEST(ObjectDictionary, AddRefusesDuplicatesAndBadDefaults) {
  ObjectDictionary od;
  ASSERT_TRUE(od.Add(Integer(0x2000, 0, "a", DataType::kU8)).ok());
  EXPECT_EQ(od.Add(Integer(0x2000, 0, "a", DataType::kU8)).code(),
            absl::StatusCode::kAlreadyExists);
  EXPECT_THAT(
      std::string(od.Add(Integer(0x2001, 0, "b", DataType::kU8, Access::kRw, 300)).message()),
      HasSubstr("2001h:00 b.default"));
  EXPECT_FALSE(od.Add(Integer(0x2002, 0, "c", DataType::kU8, Access::kRw, 5).Range(10, 20)).ok());
  EXPECT_FALSE(od.Add(Integer(0x2003, 0, "d", DataType::kU8).Range(20, 10)).ok());
  auto s = String(0x2004, 0, "e", "x");
  s.min = 1;
  EXPECT_FALSE(od.Add(s).ok());
  EXPECT_TRUE(od.Contains(0x2000));
  EXPECT_FALSE(od.Contains(0x2001));
}

TEST(ObjectDictionary, HooksOnTheBusPathOnly) {
  ObjectDictionary od;
  ASSERT_TRUE(od.Add(Integer(0x2000, 0, "v", DataType::kI32)).ok());
  int reads = 0;
  ASSERT_TRUE(od.OnReadInt(0x2000, 0, [&]() -> absl::StatusOr<int64_t> {
                  ++reads;
                  return -7;
                }).ok());
  std::vector<int64_t> written;
  ASSERT_TRUE(od.OnWriteInt(0x2000, 0, [&](int64_t v) {
                  written.push_back(v);
                  return v == 13 ? absl::FailedPreconditionError("13 is unlucky")
                                 : absl::OkStatus();
                }).ok());
  EXPECT_EQ(*od.GetInt(0x2000, 0), 0);  // model side: stored value, no hook
  EXPECT_THAT(*od.Read(0x2000, 0), ElementsAre(0xF9, 0xFF, 0xFF, 0xFF));
  EXPECT_EQ(reads, 1);
  EXPECT_EQ(*od.GetInt(0x2000, 0), -7);  // the served value is stored
  EXPECT_TRUE(od.Write(0x2000, 0, Bytes{5, 0, 0, 0}).ok());
  absl::Status refused = od.Write(0x2000, 0, Bytes{13, 0, 0, 0});
  EXPECT_EQ(co::AbortCodeForStatus(refused), co::SdoAbortCode::kDeviceState);
  EXPECT_EQ(*od.GetInt(0x2000, 0), 5);
  EXPECT_THAT(written, ElementsAre(5, 13));
  ASSERT_TRUE(od.SetInt(0x2000, 0, 42).ok());  // no hook
  EXPECT_THAT(written, ElementsAre(5, 13));
  EXPECT_EQ(od.OnReadInt(0x3000, 0, nullptr).code(), absl::StatusCode::kNotFound);
  ASSERT_TRUE(od.Add(String(0x2001, 0, "s", "x")).ok());
  EXPECT_EQ(od.OnWriteInt(0x2001, 0, nullptr).code(), absl::StatusCode::kInvalidArgument);
}

TEST(ObjectDictionary, ObserversAfterSuccessfulBusWrites) {
  ObjectDictionary od;
  ASSERT_TRUE(od.Add(Integer(0x2000, 0, "v", DataType::kU8).Range(0, 10)).ok());
  std::vector<uint16_t> seen;
  od.AddWriteObserver([&](uint16_t index, uint8_t) { seen.push_back(index); });
  EXPECT_TRUE(od.Write(0x2000, 0, Bytes{3}).ok());
  EXPECT_FALSE(od.Write(0x2000, 0, Bytes{11}).ok());
  EXPECT_THAT(seen, ElementsAre(0x2000));
}

TEST(ObjectDictionary, ResetToDefaultsByRangeKeepsConst) {
  ObjectDictionary od;
  ASSERT_TRUE(od.Add(Integer(0x1017, 0, "hb", DataType::kU16)).ok());
  ASSERT_TRUE(od.Add(Integer(0x2000, 0, "a", DataType::kU16, Access::kRw, 7)).ok());
  ASSERT_TRUE(od.Add(String(0x2001, 0, "s", "abc", Access::kRw)).ok());
  ASSERT_TRUE(od.SetInt(0x1017, 0, 100).ok());
  ASSERT_TRUE(od.SetInt(0x2000, 0, 9).ok());
  ASSERT_TRUE(od.SetString(0x2001, 0, "zz").ok());
  od.ResetToDefaults(0x2000, 0x9FFF);
  EXPECT_EQ(*od.GetInt(0x1017, 0), 100);
  EXPECT_EQ(*od.GetInt(0x2000, 0), 7);
  EXPECT_EQ(*od.GetString(0x2001, 0), "abc");
  ASSERT_TRUE(od.SetDefaultInt(0x2000, 0, 11).ok());
  ASSERT_TRUE(od.SetInt(0x2000, 0, 1).ok());
  od.ResetToDefaults(0x2000, 0x2000);
  EXPECT_EQ(*od.GetInt(0x2000, 0), 11);
}

TEST(ObjectDictionary, CheckMappable) {
  ObjectDictionary od;
  ASSERT_TRUE(od.Add(Integer(0x6040, 0, "cw", DataType::kU16).Mappable()).ok());
  ASSERT_TRUE(od.Add(Integer(0x6041, 0, "sw", DataType::kU16, Access::kRo).Mappable()).ok());
  ASSERT_TRUE(od.Add(Integer(0x2000, 0, "x", DataType::kU16)).ok());
  using K = co::PdoKind;
  EXPECT_TRUE(od.CheckMappable(K::kRpdo, {0x6040, 0, 16}).ok());
  EXPECT_TRUE(od.CheckMappable(K::kTpdo, {0x6041, 0, 16}).ok());
  EXPECT_TRUE(od.CheckMappable(K::kRpdo, {0x0005, 0, 8}).ok());
  EXPECT_EQ(co::AbortCodeOf(od.CheckMappable(K::kRpdo, {0x0005, 0, 16})),
            co::SdoAbortCode::kNotMappable);
  EXPECT_EQ(co::AbortCodeOf(od.CheckMappable(K::kRpdo, {0x6041, 0, 16})),
            co::SdoAbortCode::kNotMappable);
  EXPECT_EQ(co::AbortCodeOf(od.CheckMappable(K::kTpdo, {0x2000, 0, 16})),
            co::SdoAbortCode::kNotMappable);
  EXPECT_EQ(co::AbortCodeOf(od.CheckMappable(K::kTpdo, {0x6040, 0, 8})),
            co::SdoAbortCode::kNotMappable);
  EXPECT_EQ(co::AbortCodeOf(od.CheckMappable(K::kTpdo, {0x6040, 1, 16})),
            co::SdoAbortCode::kNoObject);
  EXPECT_EQ(co::AbortCodeOf(od.CheckMappable(K::kTpdo, {0x7000, 0, 16})),
            co::SdoAbortCode::kNoObject);
}

}  // namespace
}  // namespace drivegw::sim::canopen
