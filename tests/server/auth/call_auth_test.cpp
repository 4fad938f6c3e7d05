// CallAuth::Check, the one enforcement point, without a network: the authorised context carries
// principal and role; refusals are audited as auth.denied with the method; beyond 20 refusals a
// second the rest are counted and the next written refusal carries the count (ManualClock).
#include "server/grpc/call_auth.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "storage/audit_log.h"
#include "storage/migrations.h"
#include "storage/token_repo.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::server {
namespace {

using ::testing::HasSubstr;

constexpr char kMove[] = "/drivegw.v1.DriveService/MoveAbsolute";

class CallAuthTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto db = storage::Db::Open(dir_.File("auth.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(std::move(*db));
    ASSERT_TRUE(storage::Migrate(*db_).ok());
    tokens_ = std::make_unique<storage::TokenRepo>(*db_);
    audit_ = std::make_unique<storage::AuditLog>(*db_);
    auto viewer = tokens_->Create("dash", "viewer");
    auto op = tokens_->Create("mes-line-3", "operator");
    ASSERT_TRUE(viewer.ok() && op.ok());
    viewer_ = viewer->token;
    operator_ = op->token;
    auth::AuthOptions o;
    o.enabled = true;
    authenticator_ = std::make_unique<auth::Authenticator>(o, tokens_.get());
    call_auth_ = std::make_unique<CallAuth>(*authenticator_, audit_.get(), clock_);
  }
  static CallCredentials Creds(const std::string& method, const std::string& token) {
    CallCredentials c;
    c.method = method;
    c.base.transport = "rest";
    c.base.source_address = "ipv4:10.0.0.7:5000";
    if (!token.empty()) c.authorization = "Bearer " + token;
    return c;
  }
  std::vector<storage::AuditRecord> Denials() {
    storage::AuditQuery q;
    q.action = "auth.denied";
    q.ascending = true;
    q.limit = 1000;
    auto r = audit_->Query(q);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : std::vector<storage::AuditRecord>{};
  }

  storage::testing::TempDir dir_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::TokenRepo> tokens_;
  std::unique_ptr<storage::AuditLog> audit_;
  std::unique_ptr<auth::Authenticator> authenticator_;
  ManualClock clock_;
  std::unique_ptr<CallAuth> call_auth_;
  std::string viewer_;
  std::string operator_;
};

TEST_F(CallAuthTest, Admitted_ContextCarriesPrincipalAndRole_NothingAudited) {
  auto cc = call_auth_->Check(Creds(kMove, operator_));
  ASSERT_TRUE(cc.ok()) << cc.status();
  EXPECT_EQ(cc->principal, "mes-line-3");
  EXPECT_EQ(cc->role, "operator");
  EXPECT_EQ(cc->source_address, "ipv4:10.0.0.7:5000");
  EXPECT_EQ(cc->transport, "rest");
  EXPECT_TRUE(Denials().empty());
}

TEST_F(CallAuthTest, Refusals_AuditedWithMethodPrincipalAndCode) {
  auto none = call_auth_->Check(Creds(kMove, ""));
  EXPECT_EQ(none.status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_THAT(none.status().message(), HasSubstr(kMove));
  auto low = call_auth_->Check(Creds(kMove, viewer_));
  EXPECT_EQ(low.status().code(), absl::StatusCode::kPermissionDenied);
  const auto rows = Denials();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].principal, "(unauthenticated)");
  EXPECT_EQ(rows[0].result_code, static_cast<int>(absl::StatusCode::kUnauthenticated));
  EXPECT_EQ(rows[0].request_json, std::string("{\"method\":\"") + kMove + "\"}");
  EXPECT_EQ(rows[0].source_address, "ipv4:10.0.0.7:5000");
  EXPECT_EQ(rows[1].principal, "dash");
  EXPECT_EQ(rows[1].role, "viewer");
  EXPECT_EQ(rows[1].result_code, static_cast<int>(absl::StatusCode::kPermissionDenied));
  EXPECT_THAT(rows[1].result_message, HasSubstr("needs role operator"));
}

TEST_F(CallAuthTest, RefusalFlood_TwentyASecondWritten_RestCountedIntoTheNext) {
  for (int i = 0; i < 50; ++i) {
    EXPECT_EQ(call_auth_->Check(Creds(kMove, "")).status().code(),
              absl::StatusCode::kUnauthenticated);  // every call is still refused
  }
  EXPECT_EQ(Denials().size(), static_cast<size_t>(CallAuth::kMaxDeniedAuditsPerSecond));
  clock_.Advance(std::chrono::seconds(1));
  EXPECT_FALSE(call_auth_->Check(Creds(kMove, viewer_)).ok());
  const auto rows = Denials();
  ASSERT_EQ(rows.size(), static_cast<size_t>(CallAuth::kMaxDeniedAuditsPerSecond) + 1);
  EXPECT_THAT(rows.back().request_json, HasSubstr("\"suppressed_before\":30"));
  EXPECT_EQ(rows.back().principal, "dash");
}

TEST_F(CallAuthTest, Open_AnonymousAdmin_UnknownMethodStillRefused) {
  auto cc = CallAuth::Open().Check(Creds(kMove, ""));
  ASSERT_TRUE(cc.ok()) << cc.status();
  EXPECT_EQ(cc->principal, "anonymous");
  EXPECT_EQ(cc->role, "admin");
  auto unknown = CallAuth::Open().Check(Creds("/drivegw.v1.DriveService/Nope", ""));
  EXPECT_EQ(unknown.status().code(), absl::StatusCode::kPermissionDenied);
}

}  // namespace
}  // namespace drivegw::server
