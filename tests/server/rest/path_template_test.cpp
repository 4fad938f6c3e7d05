// Unit tests of google.api.http path templates: parsing, matching, verbs, percent-decoding.
#include "server/rest/path_template.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace drivegw::rest {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using Kind = PathTemplate::SegmentKind;

PathTemplate MustParse(std::string_view text) {
  auto t = PathTemplate::Parse(text);
  EXPECT_TRUE(t.ok()) << t.status();
  return t.ok() ? *std::move(t) : PathTemplate();
}

TEST(PathTemplateParse, LiteralsOnly_NoVariables) {
  const auto t = MustParse("/v1/drives");
  ASSERT_EQ(t.segments().size(), 2u);
  EXPECT_EQ(t.segments()[0].literal, "v1");
  EXPECT_EQ(t.segments()[1].literal, "drives");
  EXPECT_TRUE(t.variables().empty());
  EXPECT_EQ(t.verb(), "");
}

TEST(PathTemplateParse, VariableWithPatternAndVerb_SegmentsAndVerb) {
  const auto t = MustParse("/v1/{name=drives/*}:moveAbsolute");
  ASSERT_EQ(t.segments().size(), 3u);
  EXPECT_EQ(t.segments()[1].literal, "drives");
  EXPECT_EQ(t.segments()[2].kind, Kind::kSingle);
  ASSERT_EQ(t.variables().size(), 1u);
  EXPECT_EQ(t.variables()[0].field_path, "name");
  EXPECT_EQ(t.variables()[0].first_segment, 1u);
  EXPECT_EQ(t.variables()[0].end_segment, 3u);
  EXPECT_EQ(t.verb(), "moveAbsolute");
}

TEST(PathTemplateParse, TwoVariables_BothRecorded) {
  const auto t = MustParse("/v1/{name=drives/*}/parameters/{parameter_id}:write");
  ASSERT_EQ(t.variables().size(), 2u);
  EXPECT_EQ(t.variables()[1].field_path, "parameter_id");
  EXPECT_EQ(t.segments()[t.variables()[1].first_segment].kind, Kind::kSingle);
  EXPECT_EQ(t.verb(), "write");
}

TEST(PathTemplateParse, DottedFieldPathAndDoubleWildcard_Accepted) {
  const auto t = MustParse("/v1/{axis.kind}/{rest=**}");
  EXPECT_EQ(t.variables()[0].field_path, "axis.kind");
  EXPECT_EQ(t.segments().back().kind, Kind::kMulti);
}

TEST(PathTemplateParse, Malformed_ErrorNamesTemplateAndOffset) {
  struct Case {
    const char* text;
    const char* message;
  } cases[] = {
      {"v1/drives", "must start with '/'"},
      {"/v1/{name", "expected '}'"},
      {"/v1/{name=drives/*", "expected '}'"},
      {"/v1//drives", "empty segment"},
      {"/v1/drives/", "empty segment"},
      {"/v1/drives:", "empty verb"},
      {"/v1/{1name}", "expected field name"},
      {"/v1/{a={b}}", "nested variable"},
      {"/v1/**/x", "'**' must be the last segment"},
      {"/v1/{a}/{a}", "field a bound twice"},
      {"/v1/x}", "unexpected '}'"},
      {"/v1/%zz", "malformed percent-encoding"},
  };
  for (const auto& c : cases) {
    auto t = PathTemplate::Parse(c.text);
    ASSERT_FALSE(t.ok()) << c.text;
    EXPECT_EQ(t.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(std::string(t.status().message()), HasSubstr(c.message)) << c.text;
    EXPECT_THAT(std::string(t.status().message()), HasSubstr(c.text));
  }
}

TEST(PathTemplateMatch, LiteralTemplate_ExactPathOnly) {
  const auto t = MustParse("/v1/drives");
  EXPECT_TRUE(t.Match("/v1/drives"));
  EXPECT_FALSE(t.Match("/v1/drives/"));
  EXPECT_FALSE(t.Match("/v1/drive"));
  EXPECT_FALSE(t.Match("/v1/drives/x1"));
  EXPECT_FALSE(t.Match("v1/drives"));
  EXPECT_FALSE(t.Match("/v1/drives:watch"));
}

TEST(PathTemplateMatch, VariableOverTwoSegments_BindsJoinedValue) {
  const auto t = MustParse("/v1/{name=drives/*}");
  EXPECT_THAT(*t.Match("/v1/drives/x1"), ElementsAre(PathBinding{"name", "drives/x1"}));
  EXPECT_FALSE(t.Match("/v1/motors/x1"));
  EXPECT_FALSE(t.Match("/v1/drives"));
  EXPECT_FALSE(t.Match("/v1/drives/"));
  EXPECT_FALSE(t.Match("/v1/drives/x1/commands/2"));
}

TEST(PathTemplateMatch, Verb_RequiredAndStripped) {
  const auto t = MustParse("/v1/{name=drives/*}:moveAbsolute");
  EXPECT_THAT(*t.Match("/v1/drives/x1:moveAbsolute"),
              ElementsAre(PathBinding{"name", "drives/x1"}));
  EXPECT_FALSE(t.Match("/v1/drives/x1"));
  EXPECT_FALSE(t.Match("/v1/drives/x1:moveRelative"));
  EXPECT_FALSE(t.Match("/v1/drives/x1%3AmoveAbsolute"));  // an encoded colon is data
  const auto watch = MustParse("/v1/drives:watch");
  EXPECT_TRUE(watch.Match("/v1/drives:watch"));
  EXPECT_FALSE(watch.Match("/v1/drives"));
}

TEST(PathTemplateMatch, NoVerbInTemplate_ColonStaysInValue) {
  const auto t = MustParse("/v1/{name=drives/*}");
  EXPECT_THAT(*t.Match("/v1/drives/a:b"), ElementsAre(PathBinding{"name", "drives/a:b"}));
}

TEST(PathTemplateMatch, TwoVariables_BothBound) {
  const auto t = MustParse("/v1/{name=drives/*}/parameters/{parameter_id}:write");
  EXPECT_THAT(*t.Match("/v1/drives/x1/parameters/1234:write"),
              ElementsAre(PathBinding{"name", "drives/x1"}, PathBinding{"parameter_id", "1234"}));
}

TEST(PathTemplateMatch, PercentEncoding_SingleDecodedMultiKeepsSlash) {
  const auto single = MustParse("/v1/drives/{id}");
  EXPECT_THAT(*single.Match("/v1/drives/a%2Fb%20c"), ElementsAre(PathBinding{"id", "a/b c"}));
  const auto multi = MustParse("/v1/{name=drives/*}");
  EXPECT_THAT(*multi.Match("/v1/drives/a%2Fb%20c"),
              ElementsAre(PathBinding{"name", "drives/a%2Fb c"}));
  EXPECT_THAT(*multi.Match("/v1/dri%76es/x%31"), ElementsAre(PathBinding{"name", "drives/x1"}));
}

TEST(PathTemplateMatch, DoubleWildcard_ZeroOrMoreSegments) {
  const auto t = MustParse("/static/{path=**}");
  EXPECT_THAT(*t.Match("/static/a/b/c.js"), ElementsAre(PathBinding{"path", "a/b/c.js"}));
  EXPECT_THAT(*t.Match("/static/x"), ElementsAre(PathBinding{"path", "x"}));
  EXPECT_THAT(*t.Match("/static"), ElementsAre(PathBinding{"path", ""}));
  EXPECT_FALSE(t.Match("/other/x"));
}

TEST(PathTemplateMatch, Specificity_LiteralsAndVerbRankHigher) {
  EXPECT_GT(MustParse("/v1/{name=drives/*}:enable").Specificity(),
            MustParse("/v1/{name=drives/*}").Specificity());
  EXPECT_GT(MustParse("/v1/drives/{id}").Specificity(), MustParse("/v1/{a}/{b}").Specificity());
}

// Templates and request paths the Fits tests try in every combination.
constexpr const char* kFitTemplates[] = {"/v1/drives",
                                         "/v1/{name=drives/*}",
                                         "/v1/{name=drives/*}:enable",
                                         "/v1/{name=drives/*/commands/*}",
                                         "/v1/{name=drives/*}/parameters/{parameter_id}",
                                         "/v1/drives:watch",
                                         "/files/**",
                                         "/v1/{path=files/**}",
                                         "/v1/*/x/{id}",
                                         "/v1/a%2Fb"};
constexpr const char* kFitPaths[] = {"/v1/drives",
                                     "/v1/drives/",
                                     "/v1/drives/x1",
                                     "/v1/drives/x%31",
                                     "/v1/drives/x%zz",
                                     "/v1/drives/x%2",
                                     "/v1/drives/x1:enable",
                                     "/v1/drives/x1:enabl",
                                     "/v1/drives/x1%3Aenable",
                                     "/v1/drives:watch",
                                     "/v1/drives/x1/commands/7",
                                     "/v1/drives//commands/7",
                                     "/v1/drives/x1/parameters/1234",
                                     "/v1/drives/x1/parameters/%zz",
                                     "/files",
                                     "/files/",
                                     "/files/a/b/c",
                                     "/files/a/%zz",
                                     "/v1/files",
                                     "/v1/files/a/b%2Fc",
                                     "/v1/files/a/%g0",
                                     "/v1/q/x/7",
                                     "/v1/%zz/x/7",
                                     "/v1/q/x/%zz",
                                     "/v1/a%2Fb",
                                     "/v1/a%2fb",
                                     "/v1/a/b",
                                     "",
                                     "v1/drives",
                                     "/",
                                     "/v1/dr%69ves",
                                     "/v1/drives/x1:",
                                     "/v1/drives/x1:a:enable",
                                     "/v1/a:b/drives:watch",
                                     "/v1/drives/x1:enable/x"};
// Routing ranks with Fits and binds with Match (router.cpp): they must accept the same paths.
TEST(PathTemplateFits, EveryTemplateAndPath_SameAnswerAsMatch) {
  for (const char* text : kFitTemplates) {
    const PathTemplate t = MustParse(text);
    for (const char* path : kFitPaths) {
      EXPECT_EQ(t.Fits(path), t.Match(path).has_value()) << text << " vs " << path;
    }
  }
}

// The router skips a template with a verb unless the path's PathVerb equals it (decision 1364):
// that must never skip a template that fits.
TEST(PathTemplateFits, TemplateWithVerb_FitsOnlyPathsOfThatVerb) {
  for (const char* text : kFitTemplates) {
    const PathTemplate t = MustParse(text);
    if (t.verb().empty()) continue;
    for (const char* path : kFitPaths) {
      if (t.Fits(path)) {
        EXPECT_EQ(PathVerb(path), t.verb()) << text << " vs " << path;
      }
    }
  }
  EXPECT_EQ(PathVerb("/v1/drives/x1:enable"), "enable");
  EXPECT_EQ(PathVerb("/v1/drives/x1:a:enable"), "enable");
  EXPECT_EQ(PathVerb("/v1/drives:watch"), "watch");
  EXPECT_EQ(PathVerb("/v1/a:b/drives"), "");
  EXPECT_EQ(PathVerb("/v1/drives/x1%3Aenable"), "");
  EXPECT_EQ(PathVerb("/v1/drives/x1:"), "");
  EXPECT_EQ(PathVerb("/v1/drives/x1"), "");
  EXPECT_EQ(PathVerb(""), "");
}

TEST(PercentDecode, Escapes_DecodedOrRejected) {
  EXPECT_EQ(*PercentDecode("a%41%62"), "aAb");
  EXPECT_EQ(*PercentDecode("a+b", false, true), "a b");
  EXPECT_EQ(*PercentDecode("a+b"), "a+b");
  EXPECT_EQ(*PercentDecode("x%2fy", true), "x%2fy");
  EXPECT_FALSE(PercentDecode("%"));
  EXPECT_FALSE(PercentDecode("%4"));
  EXPECT_FALSE(PercentDecode("%g1"));
}

}  // namespace
}  // namespace drivegw::rest
