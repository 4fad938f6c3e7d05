// PDO mapping, packing and the configuration sequence (CiA 301 §7.2.2, §7.5.2.35-38).
#include "adapters/canopen/pdo.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace drivegw::canopen {
namespace {

using ::testing::HasSubstr;

// CiA 402 controlword 6040h (u16), modes of operation 6060h (i8), target position 607Ah (i32).
const PdoMapping kRpdo = {{0x6040, 0, 16}, {0x6060, 0, 8}, {0x607A, 0, 32}};

TEST(PdoTest, PacksTypedValuesLittleEndianInMappingOrder) {
  const std::vector<PdoValue> values = {
      {PdoType::kU16, 0x000F}, {PdoType::kI8, 1}, {PdoType::kI32, -2}};
  auto payload = PackPdo(kRpdo, values);
  ASSERT_TRUE(payload.ok()) << payload.status();
  EXPECT_EQ(*payload, (std::vector<uint8_t>{0x0F, 0x00, 0x01, 0xFE, 0xFF, 0xFF, 0xFF}));
  const std::vector<PdoType> types = {PdoType::kU16, PdoType::kI8, PdoType::kI32};
  auto back = UnpackPdo(kRpdo, types, *payload);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, values);
}

TEST(PdoTest, EveryTypeRoundTripsItsExtremes) {
  const PdoType types[] = {PdoType::kU8,  PdoType::kI8,  PdoType::kU16,
                           PdoType::kI16, PdoType::kU32, PdoType::kI32};
  for (PdoType t : types) {
    const uint8_t bits = PdoTypeBits(t);
    const bool is_signed = t == PdoType::kI8 || t == PdoType::kI16 || t == PdoType::kI32;
    const int64_t min = is_signed ? -(int64_t{1} << (bits - 1)) : 0;
    const int64_t max = is_signed ? (int64_t{1} << (bits - 1)) - 1 : (int64_t{1} << bits) - 1;
    const PdoMapping m = {{0x2000, 1, bits}, {0x2000, 2, bits}};
    const std::vector<PdoValue> v = {{t, min}, {t, max}};
    auto packed = PackPdo(m, v);
    ASSERT_TRUE(packed.ok()) << PdoTypeName(t) << ": " << packed.status();
    EXPECT_EQ(packed->size(), 2u * bits / 8);
    const std::vector<PdoType> ts = {t, t};
    EXPECT_EQ(*UnpackPdo(m, ts, *packed), v) << PdoTypeName(t);
    const std::vector<PdoValue> over = {{t, min}, {t, max + 1}};
    EXPECT_THAT(PackPdo(m, over).status().message(), HasSubstr("outside"));
  }
}

TEST(PdoTest, ErrorsNameTheEntryAndTheLimit) {
  const std::vector<PdoValue> too_big = {
      {PdoType::kU16, 70000}, {PdoType::kI8, 0}, {PdoType::kI32, 0}};
  EXPECT_EQ(PackPdo(kRpdo, too_big).status().message(),
            "canopen pdo mapping[0] 6040h:00: u16 value 70000 outside 0..65535");
  const std::vector<PdoValue> wrong_type = {
      {PdoType::kI32, 0}, {PdoType::kI8, 0}, {PdoType::kI32, 0}};
  EXPECT_EQ(PackPdo(kRpdo, wrong_type).status().message(),
            "canopen pdo mapping[0] 6040h:00: i32 needs 32 bits, entry maps 16");
  const PdoMapping wide = {{0x607A, 0, 32}, {0x60FF, 0, 32}, {0x6040, 0, 16}};
  EXPECT_EQ(ValidateMapping(wide).message(), "canopen pdo mapping: 80 bits exceed 64");
  const PdoMapping zero = {{0x6040, 0, 16}, {0x6060, 0, 0}};
  EXPECT_EQ(ValidateMapping(zero).message(), "canopen pdo mapping[1].bits: 0 outside 1..64");
  const std::vector<uint8_t> short_payload = {0x0F, 0x00, 0x01};
  EXPECT_EQ(UnpackPdoRaw(kRpdo, short_payload).status().message(),
            "canopen pdo payload: 3 bytes, mapping needs 7");
  const std::vector<uint64_t> raw = {0x10000, 0, 0};
  EXPECT_EQ(PackPdoRaw(kRpdo, raw).status().message(),
            "canopen pdo mapping[0] 6040h:00: value 0x10000 exceeds 16 bits");
}

TEST(PdoTest, BitFieldsPackLsbFirstAndLongerPayloadsAreAccepted) {
  const PdoMapping bits = {{0x2001, 1, 1}, {0x2001, 2, 3}, {0x2001, 3, 12}};
  const std::vector<uint64_t> v = {1, 5, 0xABC};
  auto packed = PackPdoRaw(bits, v);
  ASSERT_TRUE(packed.ok());
  // 1 | 5 << 1 | 0xABC << 4 = 0xABCB
  EXPECT_EQ(*packed, (std::vector<uint8_t>{0xCB, 0xAB}));
  const std::vector<uint8_t> longer = {0xCB, 0xAB, 0xEE, 0xEE};
  EXPECT_EQ(*UnpackPdoRaw(bits, longer), v);
  const PdoMapping full = {{0x2002, 0, 64}};
  const std::vector<uint64_t> all = {~uint64_t{0}};
  EXPECT_EQ(*UnpackPdoRaw(full, *PackPdoRaw(full, all)), all);
}

TEST(PdoTest, MappingEntryWord) {
  EXPECT_EQ(EncodeMappingEntry({0x607A, 0x00, 32}), 0x607A0020u);
  EXPECT_EQ(DecodeMappingEntry(0x60410010), (PdoMappingEntry{0x6041, 0, 16}));
}

TEST(PdoTest, DefaultCobIdsAndIndices) {
  EXPECT_EQ(*DefaultPdoCobId(PdoKind::kTpdo, 1, 5), 0x185);
  EXPECT_EQ(*DefaultPdoCobId(PdoKind::kRpdo, 1, 5), 0x205);
  EXPECT_EQ(*DefaultPdoCobId(PdoKind::kTpdo, 4, 5), 0x485);
  EXPECT_EQ(*DefaultPdoCobId(PdoKind::kRpdo, 4, 127), 0x57F);
  EXPECT_FALSE(DefaultPdoCobId(PdoKind::kRpdo, 5, 1).ok());
  EXPECT_EQ(PdoCommIndex(PdoKind::kRpdo, 1), 0x1400);
  EXPECT_EQ(PdoMappingIndex(PdoKind::kRpdo, 2), 0x1601);
  EXPECT_EQ(PdoCommIndex(PdoKind::kTpdo, 3), 0x1802);
  EXPECT_EQ(PdoMappingIndex(PdoKind::kTpdo, 4), 0x1A03);
}

TEST(PdoTest, TransmissionTypeLimits) {
  PdoCommParams c;
  for (int t : {0, 1, 240, 254, 255}) {
    c.transmission_type = static_cast<uint8_t>(t);
    EXPECT_TRUE(ValidateCommParams(PdoKind::kRpdo, c).ok()) << t;
    EXPECT_TRUE(ValidateCommParams(PdoKind::kTpdo, c).ok()) << t;
  }
  c.transmission_type = 241;
  EXPECT_EQ(ValidateCommParams(PdoKind::kTpdo, c).message(),
            "canopen tpdo.transmission_type: 241 is reserved (241..251)");
  c.transmission_type = 252;
  EXPECT_TRUE(ValidateCommParams(PdoKind::kTpdo, c).ok());
  EXPECT_EQ(ValidateCommParams(PdoKind::kRpdo, c).message(),
            "canopen rpdo.transmission_type: 252 is TPDO-only (RTR)");
}

TEST(PdoTest, TpdoMappingWritesFollowTheCia301Order) {
  PdoCommParams comm;
  comm.transmission_type = 1;
  comm.inhibit_time_100us = 10;
  comm.event_timer_ms = 100;
  const PdoMapping mapping = {{0x6041, 0, 16}, {0x6064, 0, 32}};
  auto writes = MappingWrites(PdoKind::kTpdo, 1, 5, comm, mapping);
  ASSERT_TRUE(writes.ok()) << writes.status();
  const std::vector<SdoWrite> expected = {
      {0x1800, 1, {0x85, 0x01, 0x00, 0xC0}},  // invalid (bit 31) + no RTR (bit 30)
      {0x1A00, 0, {0x00}},                    // mapping count 0
      {0x1A00, 1, {0x10, 0x00, 0x41, 0x60}},  // 6041h:00, 16 bits
      {0x1A00, 2, {0x20, 0x00, 0x64, 0x60}},  // 6064h:00, 32 bits
      {0x1A00, 0, {0x02}},                    // mapping count 2
      {0x1800, 2, {0x01}},                    // transmission type: every SYNC
      {0x1800, 3, {0x0A, 0x00}},              // inhibit time 1 ms
      {0x1800, 5, {0x64, 0x00}},              // event timer 100 ms
      {0x1800, 1, {0x85, 0x01, 0x00, 0x40}},  // valid
  };
  EXPECT_EQ(*writes, expected);
}

TEST(PdoTest, RpdoMappingWritesSkipTheInhibitTimeAndCanStayInvalid) {
  PdoCommParams comm;
  comm.cob_id = 0x210;
  comm.transmission_type = 255;
  comm.valid = false;
  const PdoMapping mapping = {{0x6040, 0, 16}};
  auto writes = MappingWrites(PdoKind::kRpdo, 2, 5, comm, mapping);
  ASSERT_TRUE(writes.ok()) << writes.status();
  const std::vector<SdoWrite> expected = {
      {0x1401, 1, {0x10, 0x02, 0x00, 0x80}},
      {0x1601, 0, {0x00}},
      {0x1601, 1, {0x10, 0x00, 0x40, 0x60}},
      {0x1601, 0, {0x01}},
      {0x1401, 2, {0xFF}},
      {0x1401, 5, {0x00, 0x00}},
      {0x1401, 1, {0x10, 0x02, 0x00, 0x80}},
  };
  EXPECT_EQ(*writes, expected);
  EXPECT_FALSE(MappingWrites(PdoKind::kRpdo, 0, 5, comm, mapping).ok());
  EXPECT_FALSE(MappingWrites(PdoKind::kRpdo, 1, 0, comm, mapping).ok());
  comm.cob_id = 0;
  EXPECT_THAT(MappingWrites(PdoKind::kRpdo, 5, 5, comm, mapping).status().message(),
              HasSubstr("rpdo5.cob_id: 0 (predefined) needs PDO 1..4"));
}

}  // namespace
}  // namespace drivegw::canopen
