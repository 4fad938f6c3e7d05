// What the parameter-set and curve-set services share (server/core/set_service_common.h): the
// texts of set names and paging, the ETAG detail a stale etag gets (REST answers it 412), the
// audit before/after JSON, and the version and conditional-delete calls against a repo double.
#include "server/core/set_service_common.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include "adapters/core/status.h"
#include "drivegw/v1/curve_sets.pb.h"
#include "google/rpc/error_details.pb.h"

namespace drivegw::server {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

TEST(SetServiceCommonTest, SetIdFromName_PrefixOptionalOtherwiseNamedField) {
  EXPECT_EQ(*SetIdFromName("name", "curveSets/demo", "curveSets/", "curve set"), "demo");
  EXPECT_EQ(*SetIdFromName("name", "demo", "curveSets/", "curve set"), "demo");
  const auto empty = SetIdFromName("parameter_set.name", "", "parameterSets/", "parameter set");
  EXPECT_EQ(empty.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(empty.status().message(),
              HasSubstr("parameter_set.name: is required (\"parameterSets/{set}\")"));
  const auto nested = SetIdFromName("name", "curveSets/a/b", "curveSets/", "curve set");
  EXPECT_THAT(nested.status().message(),
              HasSubstr("name: 'curveSets/a/b' is not a curve set name (\"curveSets/{set}\")"));
  EXPECT_FALSE(SetIdFromName("name", "curveSets/", "curveSets/", "curve set").ok());
}

TEST(SetServiceCommonTest, SetPageOf_DefaultLimitOneMoreAskedAndRangeChecked) {
  auto first = SetPageOf(0, "", 1000);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_EQ(first->limit, 100);
  EXPECT_EQ(first->query_limit, 101);
  EXPECT_FALSE(first->after_name.has_value());
  auto last = SetPageOf(1000, "set-7", 1000);
  ASSERT_TRUE(last.ok()) << last.status();
  EXPECT_EQ(last->query_limit, 1000);  // capped: the repo never gets more than its maximum
  EXPECT_EQ(last->after_name, "set-7");
  EXPECT_THAT(SetPageOf(1001, "", 1000).status().message(),
              HasSubstr("page_size: 1001 is outside 0..1000"));
  EXPECT_THAT(SetPageOf(-1, "", 1000).status().message(), HasSubstr("page_size: -1"));
  EXPECT_THAT(SetPageOf(10, "bad token!", 1000).status().message(), HasSubstr("page_token"));
}

TEST(SetServiceCommonTest, EmitPage_FirstLimitRowsAndTokenOnlyWhenMoreCame) {
  const SetPage page{2, 3, std::nullopt};
  std::vector<std::string> out;
  auto name = [](const std::string& s) { return s; };
  auto emit = [&](const std::string& s) { out.push_back(s); };
  EXPECT_EQ(EmitPage(std::vector<std::string>{"a", "b", "c"}, page, emit, name), "b");
  EXPECT_THAT(out, ElementsAre("a", "b"));
  out.clear();
  EXPECT_EQ(EmitPage(std::vector<std::string>{"a", "b"}, page, emit, name), "");
  EXPECT_THAT(out, ElementsAre("a", "b"));
}

// "type/subject/description" of the single ETAG violation `s` carries, "" without a detail.
std::string EtagViolation(const absl::Status& s) {
  auto payload = s.GetPayload("type.googleapis.com/google.rpc.PreconditionFailure");
  google::rpc::PreconditionFailure pf;
  if (!payload || !pf.ParseFromString(std::string(*payload)) || pf.violations_size() != 1)
    return "";
  const auto& v = pf.violations(0);
  return absl::StrCat(v.type(), "/", v.subject(), "/", v.description());
}

TEST(SetServiceCommonTest, EtagDetail_OnlyForStaleEtags) {
  const absl::Status stale =
      EtagDetail(absl::FailedPreconditionError("etag mismatch"), "curveSets/demo");
  EXPECT_EQ(stale.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(EtagViolation(stale), "ETAG/curveSets/demo/etag mismatch");
  EXPECT_EQ(EtagViolation(EtagDetail(absl::FailedPreconditionError("in use"), "curveSets/d")), "");
  EXPECT_EQ(EtagDetail(absl::NotFoundError("etag"), "x").code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(EtagViolation(EtagDetail(absl::NotFoundError("etag"), "x")), "");
}

TEST(SetServiceCommonTest, BeforeAfterJson_EitherSideMayBeAbsent) {
  v1::CurveSetVersion before;
  before.set_version(1);
  v1::CurveSetVersion after;
  after.set_version(2);
  EXPECT_EQ(BeforeAfterJson(nullptr, nullptr), "{}");
  EXPECT_EQ(BeforeAfterJson(&before, nullptr), "{\"before\":{\"version\":1}}");
  EXPECT_EQ(BeforeAfterJson(nullptr, &after), "{\"after\":{\"version\":2}}");
  EXPECT_EQ(BeforeAfterJson(&before, &after),
            "{\"before\":{\"version\":1},\"after\":{\"version\":2}}");
}

// A repo with the calls the shared helpers make (the storage repos have the same shapes).
struct FakeRepo {
  struct Set {
    std::string name;
    int version = 0;
  };
  std::map<std::string, Set> sets;
  std::string etag = "e1";
  std::vector<std::string> deleted;

  absl::StatusOr<Set> Get(const std::string& name) const {
    auto it = sets.find(name);
    if (it == sets.end()) return absl::NotFoundError(name);
    return it->second;
  }
  absl::Status Delete(const std::string& name, const std::string& e) {
    if (e != etag) return absl::FailedPreconditionError("etag is stale");
    deleted.push_back(name);
    return absl::OkStatus();
  }
  absl::StatusOr<std::vector<int>> ListVersions(const std::string& name) const {
    DGW_ASSIGN_OR_RETURN(const Set s, Get(name));
    std::vector<int> out;
    for (int v = 1; v <= s.version; ++v) out.push_back(v);
    return out;
  }
  absl::StatusOr<int> GetVersion(const std::string& name, int version) const {
    DGW_ASSIGN_OR_RETURN(const Set s, Get(name));
    if (version > s.version) return absl::NotFoundError("no such version");
    return version;
  }
};

v1::CurveSetVersion VersionProto(const std::string& name, int v) {
  v1::CurveSetVersion p;
  p.set_name(name);
  p.set_version(v);
  return p;
}

TEST(SetServiceCommonTest, Versions_ListAndGetWithTheNameCheckedFirst) {
  FakeRepo repo;
  repo.sets["demo"] = {"demo", 2};
  auto list =
      ListSetVersions<v1::ListCurveSetVersionsResponse>(repo, std::string("demo"), VersionProto);
  ASSERT_TRUE(list.ok()) << list.status();
  ASSERT_EQ(list->versions_size(), 2);
  EXPECT_EQ(list->versions(1).version(), 2);
  const absl::StatusOr<std::string> bad = absl::InvalidArgumentError("name: bad");
  EXPECT_EQ(ListSetVersions<v1::ListCurveSetVersionsResponse>(repo, bad, VersionProto).status(),
            bad.status());
  auto one = GetSetVersion(repo, std::string("demo"), 2, VersionProto);
  ASSERT_TRUE(one.ok()) << one.status();
  EXPECT_EQ(one->version(), 2);
  EXPECT_THAT(GetSetVersion(repo, std::string("demo"), 0, VersionProto).status().message(),
              HasSubstr("version: 0 is below 1"));
  EXPECT_EQ(GetSetVersion(repo, bad, 0, VersionProto).status(), bad.status());
}

TEST(SetServiceCommonTest, DeleteSet_EtagRequiredStaleDetailedAuditHasTheOldSet) {
  FakeRepo repo;
  repo.sets["demo"] = {"demo", 3};
  auto to_proto = [](const FakeRepo::Set& s) { return VersionProto(s.name, s.version); };
  std::string json = "request";
  EXPECT_THAT(DeleteSet(repo, std::string("demo"), "", "curveSets/", to_proto, json).message(),
              HasSubstr("etag: is required (deletes are conditional)"));
  EXPECT_EQ(json, "request");  // nothing read: the request stays the audit's content
  const absl::Status stale =
      DeleteSet(repo, std::string("demo"), "e0", "curveSets/", to_proto, json);
  EXPECT_EQ(stale.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(EtagViolation(stale), "ETAG/curveSets/demo/etag is stale");
  EXPECT_EQ(json, "{\"before\":{\"name\":\"demo\",\"version\":3}}");
  EXPECT_TRUE(DeleteSet(repo, std::string("demo"), "e1", "curveSets/", to_proto, json).ok());
  EXPECT_THAT(repo.deleted, ElementsAre("demo"));
}

}  // namespace
}  // namespace drivegw::server
