// JSON columns of parameter sets: exact round trips (escapes, int64 limits), malformed stored text
// is DataLoss naming the row, and random mutations of valid text never crash or throw.
#include "storage/parameter_set_json.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>
#include <random>

namespace drivegw::storage {
namespace {

using ::testing::HasSubstr;

const std::vector<ParameterValue> kEdge = {
    {"$4.vmax", 4, std::numeric_limits<int64_t>::min()},
    {"0x14BE", std::numeric_limits<uint32_t>::max(), std::numeric_limits<int64_t>::max()},
    {"quote\" back\\ nl\n ctl\x01 \xC3\xA9", 0, 0},
};

TEST(ParameterSetJsonTest, Values_RoundTripExactly) {
  auto json = ValuesToJson(kEdge);
  ASSERT_TRUE(json.ok()) << json.status();
  auto back = ValuesFromJson(*json, "set 'a' version 1");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, kEdge);
  EXPECT_EQ(*ValuesToJson({}), "[]");
}

TEST(ParameterSetJsonTest, Drives_RoundTripExactly) {
  ApplyDriveResult d;
  d.drive = "x1";
  d.state = "ROLLBACK_FAILED";
  d.pre_image = kEdge;
  d.written = {kEdge[1]};
  d.failed_parameter = "0x14BE";
  d.error = "read back 120, wrote 300";
  auto json = DrivesToJson({d, ApplyDriveResult{}});
  ASSERT_TRUE(json.ok()) << json.status();
  auto back = DrivesFromJson(*json, "operation op-1");
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->size(), 2u);
  EXPECT_EQ((*back)[0].drive, "x1");
  EXPECT_EQ((*back)[0].state, "ROLLBACK_FAILED");
  EXPECT_EQ((*back)[0].pre_image, kEdge);
  EXPECT_EQ((*back)[0].written, std::vector<ParameterValue>{kEdge[1]});
  EXPECT_EQ((*back)[0].failed_parameter, "0x14BE");
  EXPECT_EQ((*back)[0].error, d.error);
  EXPECT_TRUE((*back)[1].pre_image.empty());
}

TEST(ParameterSetJsonTest, InvalidUtf8_InvalidArgument) {
  auto r = ValuesToJson({{"bad\xff", 1, 1}});
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(r.status().message(), HasSubstr("values"));
}

TEST(ParameterSetJsonTest, MalformedStoredText_DataLossNamingRowAndField) {
  struct Case {
    const char* text;
    const char* want;
  };
  for (const Case& c : {
           Case{"", "not JSON"},
           Case{"{}", "not an array"},
           Case{"[1]", "values[0] is not an object"},
           Case{R"([{"id":1,"value":2}])", "values[0].parameter"},
           Case{R"([{"parameter":"p","id":-1,"value":2}])", "values[0].id"},
           Case{R"([{"parameter":"p","id":4294967296,"value":2}])", "values[0].id"},
           Case{R"([{"parameter":"p","id":1,"value":9223372036854775808}])", "values[0].value"},
           Case{R"([{"parameter":"p","id":1,"value":1.5}])", "values[0].value"},
           Case{R"([{"parameter":"p","id":1}])", "values[0].value"},
       }) {
    auto r = ValuesFromJson(c.text, "set 'a' version 2");
    EXPECT_EQ(r.status().code(), absl::StatusCode::kDataLoss) << c.text;
    EXPECT_THAT(r.status().message(), HasSubstr("set 'a' version 2")) << c.text;
    EXPECT_THAT(r.status().message(), HasSubstr(c.want)) << c.text;
  }
  auto d = DrivesFromJson(R"([{"drive":"x1","state":"APPLIED","failed_parameter":"","error":"",)"
                          R"("pre_image":[],"written":{}}])",
                          "operation op-7");
  EXPECT_EQ(d.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_THAT(d.status().message(), HasSubstr("operation op-7"));
  EXPECT_THAT(d.status().message(), HasSubstr("written"));
}

// Fixed seed: reproducible. Every mutation either parses to some value or is DataLoss; nothing
// escapes as an exception (which would abort the gateway).
TEST(ParameterSetJsonTest, Fuzz_MutatedText_NeverThrows) {
  ApplyDriveResult d;
  d.drive = "x1";
  d.state = "APPLIED";
  d.pre_image = kEdge;
  d.written = kEdge;
  const std::string values = *ValuesToJson(kEdge);
  const std::string drives = *DrivesToJson({d});
  std::mt19937 rng(12345);
  const std::string alphabet =
      "[]{}\",:0123456789-.eE\\u \x01\xff"
      "abcnulltrue";
  int ok = 0, bad = 0;
  for (int i = 0; i < 4000; ++i) {
    std::string text = (i % 2) ? values : drives;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits && !text.empty(); ++e) {
      const size_t pos = rng() % text.size();
      switch (rng() % 3) {
        case 0:
          text[pos] = alphabet[rng() % alphabet.size()];
          break;
        case 1:
          text.erase(pos, 1 + rng() % 3);
          break;
        default:
          text.insert(pos, 1, alphabet[rng() % alphabet.size()]);
          break;
      }
    }
    absl::Status s;
    EXPECT_NO_THROW({
      s = (i % 2) ? ValuesFromJson(text, "fuzz").status() : DrivesFromJson(text, "fuzz").status();
    }) << text;
    if (s.ok()) {
      ++ok;
    } else {
      EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss) << text;
      ++bad;
    }
  }
  EXPECT_GT(bad, 0);
  EXPECT_GT(ok, 0);  // some mutations (inside strings) keep the shape
}

}  // namespace
}  // namespace drivegw::storage
