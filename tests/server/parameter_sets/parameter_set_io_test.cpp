// Parameter set files (server/core/parameter_set_io): JSON and CSV round trips, and every
// malformed-file error naming the line and the field (decision 011).
#include "server/core/parameter_set_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace drivegw::server {
namespace {

using ::testing::HasSubstr;

storage::ParameterSet Sample() {
  storage::ParameterSet s;
  s.name = "feeder-tuning";
  s.family = "trinamic";
  s.model = "SIXpack 2";
  s.description = "feeder \"fast\"\nsecond line";
  s.target_stored = true;
  s.version = 3;
  s.values = {{"$14.vmax", 4, 300}, {"$14.amax", 5, -12}, {"$15.vmax", 6, 0}};
  return s;
}

TEST(ParameterSetIo, JsonRoundTrip) {
  const storage::ParameterSet s = Sample();
  auto back = ParseParameterSetJson(ParameterSetToJson(s));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->name, s.name);
  EXPECT_EQ(back->family, s.family);
  EXPECT_EQ(back->model, s.model);
  EXPECT_EQ(back->description, s.description);
  EXPECT_TRUE(back->target_stored);
  ASSERT_EQ(back->values.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(back->values[i].parameter, s.values[i].parameter);
    EXPECT_EQ(back->values[i].value, s.values[i].value);
  }
}

TEST(ParameterSetIo, CsvRoundTrip) {
  const storage::ParameterSet s = Sample();
  const std::string csv = ParameterSetToCsv(s);
  EXPECT_THAT(csv, HasSubstr("parameter,value\n$14.vmax,300\n"));
  auto back = ParseParameterSetCsv(csv);
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->values.size(), 3u);
  EXPECT_EQ(back->values[1].parameter, "$14.amax");
  EXPECT_EQ(back->values[1].value, -12);
}

TEST(ParameterSetIo, CsvCommentsBlankLinesCrlfAndHex) {
  auto s = ParseParameterSetCsv(
      "# exported\r\n\r\nParameter , Value\r\n0x14BE, 0x10\r\n# x\r\n5,-3\r\n");
  ASSERT_TRUE(s.ok()) << s.status();
  ASSERT_EQ(s->values.size(), 2u);
  EXPECT_EQ(s->values[0].parameter, "0x14BE");
  EXPECT_EQ(s->values[0].value, 16);
  EXPECT_EQ(s->values[1].value, -3);
}

TEST(ParameterSetIo, JsonValueAsStringAndExtraInformativeFields) {
  auto s = ParseParameterSetJson(
      R"({"name":"a","family":"linmot","parameters":[{"parameter":"0x14BE","value":"0x20","unit":"mm/s"}]})");
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_EQ(s->values[0].value, 32);
}

struct Bad {
  const char* content;
  const char* message;
};

class CsvErrors : public ::testing::TestWithParam<Bad> {};
TEST_P(CsvErrors, NameLineAndField) {
  auto s = ParseParameterSetCsv(GetParam().content);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(s.status().message()), HasSubstr(GetParam().message));
}
INSTANTIATE_TEST_SUITE_P(
    All, CsvErrors,
    ::testing::Values(
        Bad{"parameter,value\n$14.vmax,300\n#\n\n\n\n$14.amax,abc\n",
            "line 7, field value: 'abc' is not an integer"},
        Bad{"name,value\n", "line 1, field header: expected 'parameter,value'"},
        Bad{"# only a comment\n", "field header: missing"}, Bad{"", "field header: missing"},
        Bad{"parameter,value\n$14.vmax\n", "line 2, field value: expected 2 fields"},
        Bad{"parameter,value\n$14.vmax,1,2\n", "line 2, field (row): expected 2 fields"},
        Bad{"parameter,value\n,5\n", "line 2, field parameter: is empty"},
        Bad{"parameter,value\n$14.vmax,\n", "line 2, field value: '' is not an integer"},
        Bad{"parameter,value\n$14.vmax,1.5\n", "line 2, field value: '1.5' is not an integer"},
        Bad{"parameter,value\nx,99999999999999999999\n",
            "line 2, field value: '99999999999999999999'"},
        // Decision 1404: a sign or a second prefix after "0x" is not hex; "-0x-8000000000000000"
        // used to negate INT64_MIN (UBSan: signed overflow).
        Bad{"parameter,value\nx,-0x-8000000000000000\n",
            "line 2, field value: '-0x-8000000000000000' is not an integer"},
        Bad{"parameter,value\nx,0x-5\n", "line 2, field value: '0x-5' is not an integer"},
        Bad{"parameter,value\nx,0x0x5\n", "line 2, field value: '0x0x5' is not an integer"},
        Bad{"parameter,value\nx,-0x\n", "line 2, field value: '-0x' is not an integer"}));

class JsonErrors : public ::testing::TestWithParam<Bad> {};
TEST_P(JsonErrors, NameLineAndField) {
  auto s = ParseParameterSetJson(GetParam().content);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(s.status().message()), HasSubstr(GetParam().message));
}
INSTANTIATE_TEST_SUITE_P(
    All, JsonErrors,
    ::testing::Values(
        Bad{"{\n \"name\": \"a\",\n \"parameters\": [\n  {\"parameter\": \"$14.vmax\",\n   "
            "\"value\": \"abc\"}\n ]\n}",
            "line 5, field value: 'abc' is not an integer"},
        Bad{"{\n \"parameters\": [\n  {\"parameter\": \"p\", \"value\": 1.5}]}",
            "line 3, field value: '1.5' is not an integer"},
        Bad{"{\"parameters\": [{\"parameter\": \"p\", \"value\": true}]}",
            "line 1, field value: expected an integer, got a boolean"},
        Bad{"{\"parameters\": [{\"parameter\": \"p\"}]}", "line 1, field value: is required"},
        Bad{"{\"parameters\": [{\"value\": 1}]}", "line 1, field parameter: is required"},
        Bad{"{\"parameters\": [{\"parameter\": \"p\", \"valu\": 1}]}",
            "line 1, field valu: unknown field"},
        Bad{"{\"name\": \"a\",\n\"famly\": \"x\", \"parameters\": []}",
            "line 2, field famly: unknown field"},
        Bad{"{\"name\": 5, \"parameters\": []}",
            "line 1, field name: expected a string, got a number"},
        Bad{"{\"target_stored\": \"yes\", \"parameters\": []}",
            "field target_stored: expected true or false"},
        Bad{"{\"parameters\": {}}", "field parameters: expected an array, got an object"},
        Bad{"{\"parameters\": [5]}", "field parameters[0]: expected an object"},
        Bad{"{\"name\": \"a\"}", "line 1, field parameters: is required"},
        Bad{"[1]", "field (document): expected an object"},
        Bad{"{\n\"name\": \"a\",\n\"parameters\": [\n", "line 4: JSON syntax"},
        Bad{"{\"name\": \"a\" \"family\": \"b\"}", "line 1: JSON syntax: expected ',' or '}'"},
        Bad{"{\"name\": \"a\"} x", "JSON syntax: trailing characters"},
        Bad{"{\"name\": \"a\n\"}", "JSON syntax: newline in a string"}));

}  // namespace
}  // namespace drivegw::server
