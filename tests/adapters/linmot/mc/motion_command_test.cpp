// Tests of the MC command table and codec (linmot-mc.md §4, §5; linmot-linudp.md §3.4).
#include "adapters/linmot/mc/motion_command.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

namespace drivegw::linmot::mc {
namespace {

using ::testing::ElementsAreArray;
using ::testing::HasSubstr;

std::vector<uint8_t> Bytes(std::initializer_list<int> b) {
  std::vector<uint8_t> out;
  for (int v : b) out.push_back(static_cast<uint8_t>(v));
  out.resize(kMcBlockSize, 0);
  return out;
}

// ----- Header and count -----

TEST(Header, Raw_PacksMasterSubCount) {
  EXPECT_EQ((Header{0x01, 0x0, 0x3}).raw(), 0x0103);  // §0.3 example
  EXPECT_EQ((Header{0x3C, 0x2, 0xF}).raw(), 0x3C2F);
  EXPECT_EQ(Header::FromRaw(0x0C5A), (Header{0x0C, 0x5, 0xA}));
  for (uint32_t raw = 0; raw <= 0xFFFF; ++raw) {
    ASSERT_EQ(Header::FromRaw(static_cast<uint16_t>(raw)).raw(), raw);
  }
}

TEST(NextCount, Ring_OneToFifteenNeverZero) {
  EXPECT_EQ(NextCount(0), 1);
  EXPECT_EQ(NextCount(1), 2);
  EXPECT_EQ(NextCount(14), 15);
  EXPECT_EQ(NextCount(15), 1);
  uint8_t c = 0;
  std::set<uint8_t> seen;
  for (int i = 0; i < 45; ++i) {
    c = NextCount(c);
    EXPECT_NE(c, 0);
    EXPECT_LE(c, 15);
    seen.insert(c);
  }
  EXPECT_EQ(seen.size(), 15u);
  EXPECT_EQ(NextCount(0x35), 6);  // whole state var low byte passed: only the nibble counts
}

// ----- Table -----

TEST(AllCommands, Table_SortedUniqueAndFindable) {
  std::set<uint16_t> ids;
  for (const CommandSpec& c : AllCommands()) {
    const uint16_t id = static_cast<uint16_t>(c.master_id << 4 | c.sub_id);
    EXPECT_TRUE(ids.insert(id).second) << c.name;
    EXPECT_EQ(FindCommand(c.master_id, c.sub_id), &c);
    EXPECT_LE(c.sub_id, 15);
    EXPECT_LE(c.master_id, 0x3C);
    EXPECT_LE(c.size(), kMcBlockSize);
    EXPECT_FALSE(c.key().empty());
  }
  // §5.1-5.18: every listed ID (header-cell misprints resolved per errata 7).
  EXPECT_EQ(AllCommands().size(), 283u);
}

TEST(AllCommands, CatalogueIds_AllPresent) {
  // The complete ID list of linmot-mc.md §5, as printed there.
  const char* kIds[] = {
      "000", "001", "002", "003", "005", "008", "009", "00A", "00F", "010", "011", "012", "013",
      "014", "015", "016", "017", "018", "019", "01A", "01B", "01C", "01D", "01E", "01F", "020",
      "021", "022", "023", "024", "027", "028", "02A", "02B", "02C", "02D", "02E", "02F", "030",
      "031", "032", "033", "034", "035", "03A", "03F", "040", "041", "042", "043", "044", "045",
      "046", "047", "04A", "04C", "04E", "04F", "050", "051", "052", "054", "055", "056", "060",
      "061", "063", "064", "069", "06A", "06B", "06C", "06D", "06E", "070", "071", "072", "07E",
      "07F", "090", "091", "092", "093", "094", "095", "096", "097", "098", "09A", "09B", "09C",
      "09D", "09E", "09F", "0A0", "0A1", "0A2", "0A3", "0A4", "0A7", "0A8", "0AA", "0AB", "0AC",
      "0AD", "0B0", "0B1", "0B2", "0B3", "0B4", "0B8", "0BA", "0BB", "0BC", "0BD", "0C0", "0C1",
      "0C2", "0C3", "0C4", "0C5", "0C6", "0C7", "0C8", "0CA", "0CB", "0CC", "0CD", "0CE", "0CF",
      "0D0", "0D1", "0D2", "0D4", "0D5", "0D6", "0D7", "0D8", "0D9", "0DC", "0DD", "0DE", "0DF",
      "0E0", "0E1", "0E4", "0E6", "0E8", "0E9", "0EA", "0EB", "0EC", "0ED", "0F0", "0F1", "0F2",
      "0F4", "0F6", "0F8", "0F9", "0FA", "0FB", "0FC", "0FD", "100", "101", "102", "104", "110",
      "111", "112", "113", "114", "115", "116", "117", "118", "120", "121", "122", "123", "124",
      "125", "126", "127", "128", "200", "201", "202", "208", "209", "210", "211", "212", "213",
      "214", "218", "219", "220", "221", "222", "223", "224", "225", "226", "227", "228", "229",
      "22A", "22B", "22E", "22F", "240", "241", "242", "243", "248", "249", "24C", "24D", "24E",
      "250", "251", "252", "253", "256", "257", "258", "259", "25A", "25B", "25C", "25D", "25E",
      "25F", "260", "262", "263", "264", "265", "266", "300", "301", "304", "305", "310", "311",
      "380", "381", "382", "383", "384", "385", "386", "387", "388", "389", "38A", "38B", "390",
      "398", "399", "39F", "3A0", "3A1", "3A2", "3A4", "3A6", "3AA", "3AB", "3AC", "3AD", "3B0",
      "3B1", "3B2", "3B4", "3BA", "3BB", "3BC", "3BD", "3C0", "3C1", "3C2"};
  for (const char* id : kIds) {
    const unsigned v = std::stoul(id, nullptr, 16);
    EXPECT_NE(FindCommand(static_cast<uint8_t>(v >> 4), static_cast<uint8_t>(v & 0xF)), nullptr)
        << id;
  }
  EXPECT_EQ(std::size(kIds), AllCommands().size());
}

TEST(FindCommand, UndefinedIds_Null) {
  // §5.19 examples.
  EXPECT_EQ(FindCommand(0x00, 0x4), nullptr);
  EXPECT_EQ(FindCommand(0x02, 0x5), nullptr);
  EXPECT_EQ(FindCommand(0x02, 0x6), nullptr);
  EXPECT_EQ(FindCommand(0x08, 0x0), nullptr);
  EXPECT_EQ(FindCommand(0x0B, 0x5), nullptr);
  EXPECT_EQ(FindCommand(0x13, 0x0), nullptr);
  EXPECT_EQ(FindCommand(0x23, 0x0), nullptr);
  EXPECT_EQ(FindCommand(0x3D, 0x0), nullptr);
  EXPECT_EQ(FindCommand(0xFF, 0xF), nullptr);
}

TEST(CommandSpec, VaiGoToPos_LayoutAndKey) {
  const CommandSpec* c = FindCommand(kVaiGoToPos.master, kVaiGoToPos.sub);
  ASSERT_NE(c, nullptr);
  EXPECT_STREQ(c->name, "VAI Go To Pos");
  EXPECT_EQ(c->key(), "vai_go_to_pos");
  ASSERT_EQ(c->params.size(), 4u);
  EXPECT_STREQ(c->params[0].name, "target_position");
  EXPECT_EQ(c->params[0].type, ParamType::kSInt32);
  EXPECT_EQ(c->params[1].offset, 6);
  EXPECT_EQ(c->params[3].type, ParamType::kUInt32);
  EXPECT_EQ(c->size(), 18u);
  EXPECT_EQ(c->ParamIndex("deceleration"), 3u);
  EXPECT_EQ(c->ParamIndex("jerk"), std::nullopt);
  EXPECT_EQ(FindCommand(0x0C, 0x0)->key(), "vai_dec_acc_go_to_pos");
}

TEST(CommandSpec, LongestLayouts_EndAtOffset22) {
  // §4.1: 38Ax and 3A0x end at offset 21.
  EXPECT_EQ(FindCommand(0x38, 0xA)->size(), 22u);
  EXPECT_EQ(FindCommand(0x3A, 0x0)->size(), 22u);
  size_t longest = 0;
  for (const CommandSpec& c : AllCommands()) longest = std::max(longest, c.size());
  EXPECT_EQ(longest, 22u);
}

TEST(CommandSpec, DecisionLayouts_D13D15D19) {
  // D-13: U!-typed positions are SInt32 (e.g. 016, 0C2, 3AB).
  EXPECT_EQ(FindCommand(0x01, 0x6)->params[0].type, ParamType::kSInt32);
  EXPECT_EQ(FindCommand(0x0C, 0x2)->params[0].type, ParamType::kSInt32);
  EXPECT_EQ(FindCommand(0x3A, 0xB)->params[0].type, ParamType::kSInt32);
  // D-15: 0AC is SInt16 scaled.
  EXPECT_EQ(FindCommand(0x0A, 0xC)->params[0].type, ParamType::kSInt16);
  // D-19: 3C0 has the VA layout with deceleration at 14.
  EXPECT_EQ(FindCommand(0x3C, 0x0)->params.size(), 4u);
  EXPECT_EQ(FindCommand(0x3C, 0x0)->params[3].offset, 14);
  // errata 27: 02D carries an increment.
  EXPECT_STREQ(FindCommand(0x02, 0xD)->params[0].name, "position_increment");
}

TEST(CommandSpec, Availability_FromOverview) {
  const CommandSpec* vaji = FindCommand(0x3A, 0x0);
  EXPECT_FALSE(vaji->AvailableOn(Product::kC1100));
  EXPECT_TRUE(vaji->AvailableOn(Product::kC1250));
  EXPECT_FALSE(vaji->AvailableOn(Product::kE1200));
  EXPECT_TRUE(vaji->AvailableOn(Product::kE1400));
  const CommandSpec* force = FindCommand(0x38, 0x0);
  EXPECT_FALSE(force->AvailableOn(Product::kE1400));
  EXPECT_TRUE(force->AvailableOn(Product::kE1400, /*force_control_key=*/true));
  EXPECT_FALSE(FindCommand(0x38, 0xA)->AvailableOn(Product::kE1400, true));
  EXPECT_TRUE(FindCommand(0x38, 0xA)->AvailableOn(Product::kC1250, true));
  EXPECT_TRUE(FindCommand(0x3C, 0x2)->AvailableOn(Product::kC1250));
  EXPECT_FALSE(FindCommand(0x3C, 0x2)->AvailableOn(Product::kE1400));
  EXPECT_TRUE(FindCommand(0x30, 0x0)->AvailableOn(Product::kE1200));
  EXPECT_FALSE(FindCommand(0x30, 0x0)->AvailableOn(Product::kE1400));
  EXPECT_TRUE(FindCommand(0x0F, 0x2)->AvailableOn(Product::kC1100));
  EXPECT_FALSE(FindCommand(0x0F, 0x2)->AvailableOn(Product::kC1250));
  EXPECT_FALSE(FindCommand(0x03, 0xA)->AvailableOn(Product::kC1100));
  EXPECT_TRUE(FindCommand(0x03, 0xA)->AvailableOn(Product::kC1250));
  EXPECT_FALSE(FindCommand(0x39, 0x8)->AvailableOn(Product::kE1200));
  for (const CommandSpec& c : AllCommands()) {
    if (c.master_id <= 0x02) {
      for (size_t p = 0; p < kProductCount; ++p) {
        EXPECT_TRUE(c.AvailableOn(static_cast<Product>(p))) << c.name;
      }
    }
  }
  EXPECT_STREQ(ProductName(Product::kE1400), "E1400");
}

TEST(CommandSpec, UndocumentedLayouts_HeaderOnlyAndFlagged) {
  for (auto [m, s] : {std::pair{0x06, 0x4}, {0x07, 0x2}, {0x21, 0x8}, {0x21, 0x9}}) {
    const CommandSpec* c = FindCommand(static_cast<uint8_t>(m), static_cast<uint8_t>(s));
    ASSERT_NE(c, nullptr);
    EXPECT_FALSE(c->layout_documented);
    EXPECT_TRUE(c->params.empty());
  }
  int undocumented = 0;
  for (const CommandSpec& c : AllCommands()) undocumented += c.layout_documented ? 0 : 1;
  EXPECT_EQ(undocumented, 4);
}

// ----- Encoding examples -----

TEST(EncodeMotionCommand, McExample42_ByteForByte) {
  // linmot-mc.md §4.2: 010xh count 1, 100 mm, 0.5 m/s, 2 m/s², 1 m/s².
  auto block = EncodeMotionCommand(VaiGoToPos(1'000'000, 500'000, 200'000, 100'000), 1);
  ASSERT_TRUE(block.ok()) << block.status();
  EXPECT_THAT(*block,
              ElementsAreArray(Bytes({0x01, 0x01, 0x40, 0x42, 0x0F, 0x00, 0x20, 0xA1, 0x07, 0x00,
                                      0x40, 0x0D, 0x03, 0x00, 0xA0, 0x86, 0x01, 0x00})));
}

TEST(EncodeMotionCommand, LinUdpExample34_ByteForByte) {
  // linmot-linudp.md §3.4: 10 mm, 1 m/s, 10 m/s², count 0.
  auto block = EncodeMotionCommand(VaiGoToPos(100'000, 1'000'000, 1'000'000, 1'000'000), 0);
  ASSERT_TRUE(block.ok()) << block.status();
  EXPECT_THAT(*block,
              ElementsAreArray(Bytes({0x00, 0x01, 0xA0, 0x86, 0x01, 0x00, 0x40, 0x42, 0x0F, 0x00,
                                      0x40, 0x42, 0x0F, 0x00, 0x40, 0x42, 0x0F, 0x00})));
}

TEST(EncodeMotionCommand, LinUdpWorkedTelegram3_Count1) {
  // linmot-linudp.md §9 item 3: the MC block of the 40-byte request.
  auto block = EncodeMotionCommand(VaiGoToPos(100'000, 1'000'000, 1'000'000, 1'000'000), 1);
  ASSERT_TRUE(block.ok());
  EXPECT_EQ((*block)[0], 0x01);
  EXPECT_EQ((*block)[1], 0x01);
}

TEST(EncodeMotionCommand, NegativePositionAndSInt16_TwosComplementLe) {
  auto block = EncodeMotionCommand(PredefVaiGoToPos(-2), 2);
  ASSERT_TRUE(block.ok());
  EXPECT_THAT(*block, ElementsAreArray(Bytes({0x02, 0x02, 0xFE, 0xFF, 0xFF, 0xFF})));
  auto b16 = EncodeMotionCommand(McCommand{0x0A, 0x0, {-32768}}, 3);
  ASSERT_TRUE(b16.ok());
  EXPECT_THAT(*b16, ElementsAreArray(Bytes({0x03, 0x0A, 0x00, 0x80})));
}

TEST(EncodeMotionCommand, WriteLiveParameter_UpidThenValue) {
  // 002x: UPID 14BEh, value 500000 (LMC-18).
  auto block = EncodeMotionCommand(WriteLiveParameter(0x14BE, 500'000), 4);
  ASSERT_TRUE(block.ok());
  EXPECT_THAT(*block, ElementsAreArray(Bytes({0x24, 0x00, 0xBE, 0x14, 0x20, 0xA1, 0x07, 0x00})));
}

TEST(EncodeMotionCommand, HeaderOnly_RestZero) {
  auto block = EncodeMotionCommand(NoOperation(), 1);
  ASSERT_TRUE(block.ok());
  EXPECT_THAT(*block, ElementsAreArray(Bytes({0x01, 0x00})));
  auto reset = EncodeMotionCommand(Reset(), 0);  // §4.3 rule 4: 00F0h
  ASSERT_TRUE(reset.ok());
  EXPECT_THAT(*reset, ElementsAreArray(Bytes({0xF0, 0x00})));
}

// ----- Encoding errors -----

TEST(EncodeMotionCommand, CountAbove15_InvalidArgument) {
  auto r = EncodeMotionCommand(NoOperation(), 16);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("count: 16"));
}

TEST(EncodeMotionCommand, UnknownId_NotFoundNamingId) {
  auto r = EncodeMotionCommand(McCommand{0x00, 0x4, {}}, 1);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(r.status().message(), HasSubstr("0x004"));
  auto r2 = EncodeMotionCommand(McCommand{0x3D, 0x1, {}}, 1);
  EXPECT_THAT(r2.status().message(), HasSubstr("0x3D1"));
}

TEST(EncodeMotionCommand, SubIdAbove15_InvalidArgument) {
  auto r = EncodeMotionCommand(McCommand{0x01, 0x10, {}}, 1);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(EncodeMotionCommand, WrongValueCount_InvalidArgument) {
  auto r = EncodeMotionCommand(McCommand{0x01, 0x0, {1, 2, 3}}, 1);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("3 values given"));
  EXPECT_THAT(r.status().message(), HasSubstr("takes 4"));
  auto r2 = EncodeMotionCommand(McCommand{0x00, 0x0, {0}}, 1);
  EXPECT_EQ(r2.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(EncodeMotionCommand, UInt32AboveMax_OutOfRangeNamingFieldAndLimit) {
  auto r = EncodeMotionCommand(McCommand{0x01, 0x0, {0, 4294967296LL, 0, 0}}, 1);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(r.status().message(),
            "vai_go_to_pos.maximal_velocity: 4294967296 exceeds UInt32 max 4294967295");
}

TEST(EncodeMotionCommand, UInt32Negative_OutOfRange) {
  auto r = EncodeMotionCommand(McCommand{0x01, 0x7, {-1}}, 1);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(r.status().message(), "vai_stop.deceleration: -1 is below UInt32 min 0");
}

TEST(EncodeMotionCommand, SInt32OutOfRange_OutOfRange) {
  auto hi = EncodeMotionCommand(McCommand{0x02, 0x0, {2147483648LL}}, 1);
  EXPECT_EQ(hi.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(hi.status().message(),
            "predef_vai_go_to_pos.target_position: 2147483648 exceeds SInt32 max 2147483647");
  auto lo = EncodeMotionCommand(McCommand{0x02, 0x0, {-2147483649LL}}, 1);
  EXPECT_EQ(lo.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(lo.status().message(), HasSubstr("below SInt32 min -2147483648"));
}

TEST(EncodeMotionCommand, SInt16OutOfRange_OutOfRange) {
  auto hi = EncodeMotionCommand(McCommand{0x0A, 0x0, {32768}}, 1);
  EXPECT_EQ(hi.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_THAT(hi.status().message(), HasSubstr("exceeds SInt16 max 32767"));
  auto lo = EncodeMotionCommand(McCommand{0x0A, 0x0, {-32769}}, 1);
  EXPECT_THAT(lo.status().message(), HasSubstr("below SInt16 min -32768"));
}

TEST(EncodeMotionCommand, UInt16OutOfRange_OutOfRange) {
  auto hi = EncodeMotionCommand(McCommand{0x00, 0x1, {65536}}, 1);
  EXPECT_EQ(hi.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_EQ(hi.status().message(),
            "write_interface_control_word.interface_control_word: 65536 exceeds UInt16 max 65535");
  auto lo = EncodeMotionCommand(McCommand{0x00, 0x1, {-1}}, 1);
  EXPECT_THAT(lo.status().message(), HasSubstr("below UInt16 min 0"));
}

// ----- Round trip of every command -----

std::vector<int64_t> Fill(const CommandSpec& c, int which) {
  std::vector<int64_t> v;
  for (const ParamSpec& p : c.params) {
    const int64_t lo = ParamTypeMin(p.type);
    const int64_t hi = ParamTypeMax(p.type);
    switch (which) {
      case 0:
        v.push_back(lo);
        break;
      case 1:
        v.push_back(hi);
        break;
      case 2:
        v.push_back(lo + (hi - lo) / 2);
        break;
      default:
        v.push_back((hi - lo) / 3 + lo + static_cast<int64_t>(v.size()) * 257);
        break;
    }
  }
  return v;
}

TEST(MotionCommandCodec, EveryCommandMinMaxMid_RoundTrips) {
  for (const CommandSpec& c : AllCommands()) {
    for (int which = 0; which < 4; ++which) {
      const McCommand cmd{c.master_id, c.sub_id, Fill(c, which)};
      const uint8_t count = static_cast<uint8_t>((which * 5 + c.sub_id) & 0x0F);
      auto block = EncodeMotionCommand(cmd, count);
      ASSERT_TRUE(block.ok()) << c.name << ": " << block.status();
      // Unused bytes stay zero (D-02).
      for (size_t i = c.size(); i < kMcBlockSize; ++i) ASSERT_EQ((*block)[i], 0) << c.name;
      auto decoded = DecodeMotionCommand(*block);
      ASSERT_TRUE(decoded.ok()) << c.name << ": " << decoded.status();
      EXPECT_EQ(decoded->spec, &c);
      EXPECT_EQ(decoded->header, (Header{c.master_id, c.sub_id, count}));
      EXPECT_EQ(decoded->command, cmd) << c.name << " case " << which;
      // Exactly the command's bytes are enough to decode (short blocks, §4.1 / A-04 note).
      auto short_decoded = DecodeMotionCommand(std::span<const uint8_t>(block->data(), c.size()));
      ASSERT_TRUE(short_decoded.ok()) << c.name;
      EXPECT_EQ(short_decoded->command, cmd);
    }
  }
}

TEST(ParameterBytes, VaiGoToPos_BytesFromOffset2) {
  auto bytes = ParameterBytes(VaiGoToPos(100'000, 1'000'000, 1'000'000, 1'000'000));
  ASSERT_TRUE(bytes.ok());
  EXPECT_THAT(*bytes, ElementsAreArray({0xA0, 0x86, 0x01, 0x00, 0x40, 0x42, 0x0F, 0x00, 0x40, 0x42,
                                        0x0F, 0x00, 0x40, 0x42, 0x0F, 0x00}));
  auto none = ParameterBytes(NoOperation());
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  EXPECT_FALSE(ParameterBytes(McCommand{0x01, 0x7, {-1}}).ok());
}

// ----- Decoding -----

TEST(DecodeMotionCommand, McExample42_Values) {
  auto d = DecodeMotionCommand(Bytes({0x01, 0x01, 0x40, 0x42, 0x0F, 0x00, 0x20, 0xA1, 0x07, 0x00,
                                      0x40, 0x0D, 0x03, 0x00, 0xA0, 0x86, 0x01, 0x00}));
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_EQ(d->header, (Header{0x01, 0x0, 1}));
  EXPECT_STREQ(d->spec->name, "VAI Go To Pos");
  EXPECT_EQ(d->command, VaiGoToPos(1'000'000, 500'000, 200'000, 100'000));
  auto va = AsVa(d->command);
  ASSERT_TRUE(va.ok());
  EXPECT_EQ(va->position, 1'000'000);
  EXPECT_EQ(va->maximal_velocity, 500'000u);
  EXPECT_EQ(va->acceleration, 200'000u);
  EXPECT_EQ(va->deceleration, 100'000u);
}

TEST(DecodeMotionCommand, UInt32HighBit_DecodesUnsigned) {
  // VAI Stop (017x) count 1, deceleration FFFF'FFFFh.
  auto d = DecodeMotionCommand(Bytes({0x71, 0x01, 0xFF, 0xFF, 0xFF, 0xFF}));
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->command.values, (std::vector<int64_t>{4294967295LL}));
}

TEST(DecodeMotionCommand, TooShortForHeader_InvalidArgument) {
  const uint8_t one[] = {0x01};
  EXPECT_EQ(DecodeMotionCommand(one).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(DecodeMotionCommand({}).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(DecodeMotionCommand, ShortBlockMissingParams_InvalidArgumentNamingBytes) {
  const uint8_t block[] = {0x01, 0x01, 0x40, 0x42, 0x0F, 0x00, 0x20, 0xA1, 0x07, 0x00};
  auto d = DecodeMotionCommand(block);
  EXPECT_EQ(d.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(d.status().message(),
            "vai_go_to_pos: block of 10 bytes, the command needs 18 (bytes 10..17 missing)");
}

TEST(DecodeMotionCommand, HeaderOnlyTwoBytes_Ok) {
  const uint8_t block[] = {0x05, 0x00};
  auto d = DecodeMotionCommand(block);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->command, NoOperation());
  EXPECT_EQ(d->header.count, 5);
}

TEST(DecodeMotionCommand, TrailingBytes_Ignored) {
  auto block = Bytes({0x02, 0x00});
  block[20] = 0xAA;  // garbage after a header-only command (D-02: the drive ignores it)
  auto d = DecodeMotionCommand(block);
  ASSERT_TRUE(d.ok());
  EXPECT_TRUE(d->command.values.empty());
}

TEST(DecodeMotionCommand, UnknownId_NotFoundWithHeaderPayload) {
  const uint8_t block[] = {0x47, 0x00};  // 004x count 7: undefined (§5.19)
  auto d = DecodeMotionCommand(block);
  EXPECT_EQ(d.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(d.status().message(), HasSubstr("0x004"));
  EXPECT_THAT(d.status().message(), HasSubstr("0x0047"));
  const auto h = UnknownCommandHeader(d.status());
  ASSERT_TRUE(h.has_value());
  EXPECT_EQ(*h, (Header{0x00, 0x4, 7}));
  EXPECT_EQ(UnknownCommandHeader(absl::NotFoundError("other")), std::nullopt);
  EXPECT_EQ(UnknownCommandHeader(absl::OkStatus()), std::nullopt);
}

TEST(DecodeMotionCommand, EveryUndefinedHeader_NotFound) {
  int unknown = 0;
  for (uint32_t raw = 0; raw <= 0xFFFF; raw += 16) {  // count 0; IDs only
    const uint8_t block[2] = {static_cast<uint8_t>(raw), static_cast<uint8_t>(raw >> 8)};
    const bool known = FindCommand(static_cast<uint8_t>(raw >> 8),
                                   static_cast<uint8_t>((raw >> 4) & 0xF)) != nullptr;
    auto d = DecodeMotionCommand(block);
    if (known) {
      EXPECT_TRUE(d.ok() || d.status().code() == absl::StatusCode::kInvalidArgument);
    } else {
      ++unknown;
      EXPECT_EQ(d.status().code(), absl::StatusCode::kNotFound);
    }
  }
  EXPECT_EQ(unknown, 4096 - static_cast<int>(AllCommands().size()));
}

// ----- Builders -----

TEST(Builders, Ids_MatchNamedConstants) {
  EXPECT_EQ(NoOperation().id(), kNoOperation);
  EXPECT_EQ(Reset().id(), kReset);
  EXPECT_EQ(ClearEventEvaluation().id(), kClearEventEvaluation);
  EXPECT_EQ(WriteInterfaceControlWord(0x3F).id(), kWriteInterfaceControlWord);
  EXPECT_EQ(WriteLiveParameter(1, 2).id(), kWriteLiveParameter);
  EXPECT_EQ(MasterHoming(0).id(), kMasterHoming);
  EXPECT_EQ(VaiGoToPos(0, 0, 0, 0).id(), kVaiGoToPos);
  EXPECT_EQ(VaiIncrementDemPos(0, 0, 0, 0).id(), kVaiIncrementDemPos);
  EXPECT_EQ(VaiIncrementTargetPos(0, 0, 0, 0).id(), kVaiIncrementTargetPos);
  EXPECT_EQ(VaiIncrementActPos(0, 0, 0, 0).id(), kVaiIncrementActPos);
  EXPECT_EQ(VaiGoToPosAfterActualCommand(0, 0, 0, 0).id(), kVaiGoToPosAfterActualCommand);
  EXPECT_EQ(VaiStop(0).id(), kVaiStop);
  EXPECT_EQ(PredefVaiGoToPos(0).id(), kPredefVaiGoToPos);
  EXPECT_EQ(PredefVaiIncrementDemPos(0).id(), kPredefVaiIncrementDemPos);
  EXPECT_EQ(PredefVaiStop().id(), kPredefVaiStop);
  EXPECT_EQ(PredefVaiInfinitePositive().id(), kPredefVaiInfinitePositive);
  EXPECT_EQ(PredefVaiInfiniteNegative().id(), kPredefVaiInfiniteNegative);
  EXPECT_EQ(VaiDecAccInfinitePositive(1, 2).id(), kVaiDecAccInfinitePositive);
  EXPECT_EQ(VaiDecAccInfiniteNegative(1, 2).id(), kVaiDecAccInfiniteNegative);
}

TEST(Builders, EveryBuilder_Encodes) {
  const McCommand all[] = {NoOperation(),
                           Reset(),
                           ClearEventEvaluation(),
                           WriteInterfaceControlWord(0xFFFF),
                           WriteLiveParameter(0xFFFF, -2147483647 - 1),
                           MasterHoming(-1),
                           VaiGoToPos(-1, 0xFFFFFFFFu, 0xFFFFFFFFu, 0xFFFFFFFFu),
                           VaiIncrementDemPos(1, 2, 3, 4),
                           VaiIncrementTargetPos(1, 2, 3, 4),
                           VaiIncrementActPos(0, 2, 3, 4),
                           VaiGoToPosAfterActualCommand(1, 2, 3, 4),
                           VaiStop(0xFFFFFFFFu),
                           PredefVaiGoToPos(5),
                           PredefVaiIncrementDemPos(-5),
                           PredefVaiStop(),
                           PredefVaiInfinitePositive(),
                           PredefVaiInfiniteNegative(),
                           VaiDecAccInfinitePositive(1, 2),
                           VaiDecAccInfiniteNegative(1, 2)};
  for (const McCommand& c : all) {
    auto b = EncodeMotionCommand(c, 1);
    ASSERT_TRUE(b.ok()) << b.status();
    auto d = DecodeMotionCommand(*b);
    ASSERT_TRUE(d.ok());
    EXPECT_EQ(d->command, c);
  }
}

TEST(NamedIds, AllResolveInTable) {
  for (CommandId id : {kNoOperation,
                       kWriteInterfaceControlWord,
                       kWriteLiveParameter,
                       kWriteX4IntfOutputsWithMask,
                       kSelectPositionControllerSet,
                       kClearEventEvaluation,
                       kMasterHoming,
                       kResetIPositionController,
                       kReset,
                       kVaiGoToPos,
                       kVaiIncrementDemPos,
                       kVaiIncrementTargetPos,
                       kVaiGoToPosFromActPosAndActVel,
                       kVaiGoToPosFromActPosDemVel0,
                       kVaiIncrementActPos,
                       kVaiIncrementActPosDemVel0,
                       kVaiStop,
                       kVaiGoToPosAfterActualCommand,
                       kVaiGoToAnalogPos,
                       kVaiGoToPosOnRisingTrigger,
                       kVaiIncrementTargetPosOnRisingTrigger,
                       kVaiGoToPosOnFallingTrigger,
                       kVaiIncrementTargetPosOnFallingTrigger,
                       kVaiChangeMotionParamsOnPositiveTransition,
                       kVaiChangeMotionParamsOnNegativeTransition,
                       kPredefVaiGoToPos,
                       kPredefVaiIncrementDemPos,
                       kPredefVaiIncrementTargetPos,
                       kPredefVaiStop,
                       kPredefVaiGoToPosAfterActualCommand,
                       kPredefVaiInfinitePositive,
                       kPredefVaiInfiniteNegative,
                       kPStream,
                       kPvStream,
                       kPvaStream,
                       kStopStreaming,
                       kTimeCurveWithDefaultParameters,
                       kTimeCurveToPosWithDefaultSpeed,
                       kVai16BitGoToPos,
                       kVai16BitIncrementDemPos,
                       kVai16BitIncrementTargetPos,
                       kVai16BitStop,
                       kPredefVai16BitGoToPos,
                       kPredefVai16BitStop,
                       kVaiDecAccGoToPos,
                       kVaiDecAccInfinitePositive,
                       kVaiDecAccInfiniteNegative,
                       kSinVaGoToPos,
                       kSinVaGoToPosAfterActualCommand,
                       kBestehornVajGoToPos,
                       kBestehornVajGoToPosAfterActualCommand,
                       kVajiGoToPos,
                       kPredefVajiGoToPos,
                       kStartCommandTableCommand}) {
    EXPECT_NE(FindCommand(id.master, id.sub), nullptr) << int(id.master) << "/" << int(id.sub);
  }
  EXPECT_EQ(kVaiGoToPos.WithCount(3).raw(), 0x0103);
}

TEST(AsVa, NonVaLayout_InvalidArgument) {
  EXPECT_EQ(AsVa(PredefVaiGoToPos(1)).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(AsVa(McCommand{0x00, 0x4, {}}).status().code(), absl::StatusCode::kNotFound);
  EXPECT_TRUE(AsVa(McCommand{0x3C, 0x2, {1, 2, 3, 4}}).ok());
  EXPECT_TRUE(AsVa(McCommand{0x0D, 0x0, {1, 2, 3, 4}}).ok());  // captured increment, VA layout
  EXPECT_EQ(AsVa(McCommand{0x01, 0x0, {1, -2, 3, 4}}).status().code(),
            absl::StatusCode::kOutOfRange);
}

TEST(FieldName, CommandAndParam) {
  const CommandSpec* c = FindCommand(0x01, 0x0);
  EXPECT_EQ(FieldName(*c, 1), "vai_go_to_pos.maximal_velocity");
  EXPECT_EQ(FieldName(*c, 9), "vai_go_to_pos");
}

}  // namespace
}  // namespace drivegw::linmot::mc
