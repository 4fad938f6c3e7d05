// Curve info block codec and curve service sequences without a network: the layout of decision
// 706 byte by byte, and CurveService against a scripted RTC transaction (decision 707).
#include "adapters/linmot/linudp/curve_service.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <vector>

#include "adapters/linmot/linudp/curve_info_block.h"

namespace drivegw::linmot::linudp {
namespace {

using ::testing::HasSubstr;

LinMotParametricCurve Ramp() {
  LinMotParametricCurve c;
  c.curve_id = 12;
  c.x_length_s = 0.5;
  c.points = {0, 100'000, -300'000};
  c.offset_mm = 12.5;
  c.amplitude_scale_pct = -50;
  c.time_scale_pct = 150;
  return c;
}

TEST(CurveInfoBlock, Layout_XLengthAtOffset32_FieldsLittleEndian) {
  auto w = ToWireCurve(Ramp(), "ramp");
  ASSERT_TRUE(w.ok()) << w.status();
  const std::vector<uint8_t> b = EncodeCurveInfoBlock(w->info);
  ASSERT_EQ(b.size(), 70u);
  // linmot-mc.md §7 L1000: x-Length UInt32 at 32 (low word) / 34 (high word): 50000 x 10 µs.
  EXPECT_EQ(b[32] | b[33] << 8 | b[34] << 16 | b[35] << 24, 50'000);
  EXPECT_EQ(b[0], 70);   // data offset
  EXPECT_EQ(b[2], 3);    // position vs time
  EXPECT_EQ(b[4], 3);    // points
  EXPECT_EQ(b[6], 4);    // SInt32
  EXPECT_EQ(b[8], 'r');  // name
  EXPECT_EQ(b[30], 12);  // curve ID
  EXPECT_EQ(b[38], 5);   // y = position
  auto back = DecodeCurveInfoBlock(b);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, w->info);
  EXPECT_EQ(back->default_offset, 125'000);
  EXPECT_EQ(back->default_amplitude_scale, -500);
  EXPECT_EQ(back->default_time_scale, 15'000u);
  auto model = FromWireCurve(WireCurve{*back, w->points});
  ASSERT_TRUE(model.ok()) << model.status();
  EXPECT_EQ(*model, Ramp());
}

TEST(CurveInfoBlock, BadInputs_NameTheField) {
  EXPECT_THAT(DecodeCurveInfoBlock(std::vector<uint8_t>(4)).status().message(),
              HasSubstr("4 bytes, the layout needs 70"));
  LinMotParametricCurve c = Ramp();
  c.x_length_s = 0.123456;  // not whole 10 µs
  EXPECT_THAT(ToWireCurve(c).status().message(), HasSubstr("x_length_s"));
  auto w = ToWireCurve(Ramp());
  ASSERT_TRUE(w.ok());
  w->points.pop_back();
  EXPECT_THAT(FromWireCurve(*w).status().message(), HasSubstr("point_count: 3, expected 2"));
  auto a = *ToWireCurve(Ramp());
  auto b = a;
  b.info.x_length = 50'001;
  EXPECT_EQ(FirstDifference(a, b), "x_length: sent 50000, read 50001");
  b = a;
  b.points[1] = 7;
  EXPECT_EQ(FirstDifference(a, b), "points[1]: sent 100000, read 7");
  EXPECT_EQ(FirstDifference(a, a), "");
}

// A drive that stores curves like decision 603 §9, with scripted deviations.
class ScriptedDrive {
 public:
  absl::StatusOr<RtcReply> operator()(uint8_t id, uint16_t w2, uint16_t w3, uint16_t w4,
                                      const std::string&) {
    log.push_back(id);
    if (auto it = override_status.find(log.size() - 1); it != override_status.end()) {
      return RtcReply{0, it->second, w2, 0, 0};
    }
    switch (static_cast<RtcCommand>(id)) {
      case RtcCommand::kStartAddingCurve:
      case RtcCommand::kStartModifyingCurve: {
        const bool modify = id == static_cast<uint8_t>(RtcCommand::kStartModifyingCurve);
        if (modify != (stored.count(w2) == 1)) return RtcReply{0, 0xD4, w2, 0, 0};
        info_size = w3;
        data_size = w4;
        staged = {};
        return RtcReply{0, 0x00, w2, w3, w4};
      }
      case RtcCommand::kAddCurveInfoBlock:
      case RtcCommand::kModifyCurveInfoBlock:
      case RtcCommand::kAddCurveData:
      case RtcCommand::kModifyCurveData: {
        const bool info = id == 0x51 || id == 0x54;
        auto& buf = info ? staged.first : staged.second;
        const size_t limit = info ? info_size : data_size;
        for (uint8_t byte : {static_cast<uint8_t>(w3), static_cast<uint8_t>(w3 >> 8),
                             static_cast<uint8_t>(w4), static_cast<uint8_t>(w4 >> 8)}) {
          if (buf.size() < limit) buf.push_back(byte);
        }
        if (staged.first.size() < info_size || staged.second.size() < data_size) {
          return RtcReply{0, 0x04, w2, w3, w4};
        }
        stored[w2] = staged;
        return RtcReply{0, 0x00, w2, w3, w4};
      }
      case RtcCommand::kStartGettingCurve:
        if (!stored.count(w2)) return RtcReply{0, 0xD4, w2, 0, 0};
        read_info = read_data = 0;
        return RtcReply{0, 0x00, w2, 0, 0};  // sizes not reported (note 2)
      case RtcCommand::kGetCurveInfoBlock:
      case RtcCommand::kGetCurveData: {
        const auto& buf = id == 0x61 ? stored[w2].first : stored[w2].second;
        size_t& at = id == 0x61 ? read_info : read_data;
        uint8_t x[4] = {0, 0, 0, 0};
        for (size_t i = 0; i < 4 && at + i < buf.size(); ++i) x[i] = buf[at + i];
        at += 4;
        return RtcReply{0, 0x00, w2, static_cast<uint16_t>(x[0] | x[1] << 8),
                        static_cast<uint16_t>(x[2] | x[3] << 8)};
      }
      default:
        return RtcReply{0, 0xC0, w2, 0, 0};
    }
  }

  std::vector<uint8_t> log;
  std::map<size_t, uint8_t> override_status;  // telegram index -> status to answer instead
  std::map<uint16_t, std::pair<std::vector<uint8_t>, std::vector<uint8_t>>> stored;
  std::pair<std::vector<uint8_t>, std::vector<uint8_t>> staged;
  size_t info_size = 0, data_size = 0, read_info = 0, read_data = 0;
};

class CurveServiceTest : public ::testing::Test {
 protected:
  CurveService Service() {
    return CurveService(
        "x1", [this](uint8_t id, uint16_t w2, uint16_t w3, uint16_t w4, const std::string& what) {
          return drive_(id, w2, w3, w4, what);
        });
  }
  WireCurve Wire() { return *ToWireCurve(Ramp()); }
  ScriptedDrive drive_;
};

TEST_F(CurveServiceTest, Download_SequenceThenReadBack_UploadEqual) {
  ASSERT_TRUE(Service().Download(Wire()).ok());
  // 0x50, 18 x 0x51, 3 x 0x52, then 0x60, 18 x 0x61, 3 x 0x62 (linudp L350-L351).
  ASSERT_EQ(drive_.log.size(), 1u + 18 + 3 + 1 + 18 + 3);
  EXPECT_EQ(drive_.log[0], 0x50);
  EXPECT_EQ(drive_.log[18], 0x51);
  EXPECT_EQ(drive_.log[19], 0x52);
  EXPECT_EQ(drive_.log[22], 0x60);
  auto up = Service().Upload(12);
  ASSERT_TRUE(up.ok()) << up.status();
  EXPECT_EQ(*up, Wire());
}

TEST_F(CurveServiceTest, AlreadyDefined_ModifiesInPlace) {
  ASSERT_TRUE(Service().Download(Wire()).ok());
  drive_.log.clear();
  ASSERT_TRUE(Service().Download(Wire()).ok());
  EXPECT_EQ(drive_.log[0], 0x50);
  EXPECT_EQ(drive_.log[1], 0x53);
  EXPECT_EQ(drive_.log[2], 0x54);
  EXPECT_EQ(drive_.log[20], 0x55);
}

TEST_F(CurveServiceTest, TransferEndedEarly_IsDataLossNamingTheBlock) {
  drive_.override_status[5] = 0x00;  // the fifth info block answers "done"
  absl::Status s = Service().Download(Wire());
  EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss) << s;
  EXPECT_THAT(s.message(), HasSubstr("curve 12: Add Curve Info Block"));
  EXPECT_THAT(s.message(), HasSubstr("info block 4 of 18"));
  EXPECT_THAT(s.message(), HasSubstr("ended the transfer early"));
}

TEST_F(CurveServiceTest, SizeError_NamesTheStepAndCurve) {
  drive_.override_status[20] = 0xD1;  // the second point
  absl::Status s = Service().Download(Wire());
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  EXPECT_THAT(s.message(), HasSubstr("drive 'x1': curve 12"));
  EXPECT_THAT(s.message(), HasSubstr("point 1 of 3"));
  EXPECT_THAT(s.message(), HasSubstr("RTC status 0xD1"));
}

TEST_F(CurveServiceTest, Upload_InfoBlockOfAnotherCurve_DataLossNamingBoth) {
  ASSERT_TRUE(Service().Download(Wire()).ok());
  drive_.stored[7] = drive_.stored[12];  // slot 7 answers with curve 12's info block
  auto up = Service().Upload(7);
  EXPECT_EQ(up.status().code(), absl::StatusCode::kDataLoss) << up.status();
  EXPECT_THAT(up.status().message(),
              HasSubstr("curve 7: the drive returned the info block of curve 12"));
  EXPECT_TRUE(Service().Upload(12).ok());
}

TEST_F(CurveServiceTest, Upload_Absent_NotFound) {
  auto up = Service().Upload(3);
  EXPECT_EQ(up.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(up.status().message(), HasSubstr("no curve 3 on the drive"));
}

}  // namespace
}  // namespace drivegw::linmot::linudp
