// Authenticator and the role table: bearer header forms (RFC 6750 §2.1), certificate mapping,
// auth disabled = anonymous admin, and PERMISSION_DENIED naming method, needed role and the
// principal's role; the role order and the table's shape.
#include "server/auth/authenticator.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "server/auth/method_roles.h"
#include "storage/migrations.h"
#include "storage/token_repo.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::auth {
namespace {

using ::testing::HasSubstr;

class AuthenticatorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto db = storage::Db::Open(dir_.File("auth.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(std::move(*db));
    ASSERT_TRUE(storage::Migrate(*db_).ok());
    tokens_ = std::make_unique<storage::TokenRepo>(*db_);
    auto t = tokens_->Create("mes-line-3", "operator");
    ASSERT_TRUE(t.ok());
    token_ = t->token;
  }
  Authenticator Enabled() {
    AuthOptions o;
    o.enabled = true;
    o.certificates.push_back({"eng-laptop-07", "a.weber", Role::kEngineer});
    return Authenticator(o, tokens_.get());
  }

  storage::testing::TempDir dir_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::TokenRepo> tokens_;
  std::string token_;
};

TEST_F(AuthenticatorTest, FromBearer_SchemeCaseInsensitive_ExtraSpaces) {
  const Authenticator a = Enabled();
  for (const std::string& header :
       {"Bearer " + token_, "bearer " + token_, "BEARER  " + token_, " Bearer " + token_ + " "}) {
    auto p = a.FromBearer(header);
    ASSERT_TRUE(p.ok()) << header << ": " << p.status();
    EXPECT_EQ(p->name, "mes-line-3");
    EXPECT_EQ(p->role, Role::kOperator);
    EXPECT_EQ(p->via, "token");
  }
}

TEST_F(AuthenticatorTest, FromBearer_OtherSchemeOrBareToken_Unauthenticated) {
  const Authenticator a = Enabled();
  for (const std::string& header :
       std::vector<std::string>{token_, "Basic dXNlcjpwYXNz", "Bearer", "Bearer "}) {
    auto p = a.FromBearer(header);
    EXPECT_EQ(p.status().code(), absl::StatusCode::kUnauthenticated) << header;
    EXPECT_THAT(p.status().message(), HasSubstr("not a bearer token")) << header;
  }
}

TEST_F(AuthenticatorTest, Authenticate_Disabled_AnonymousAdmin) {
  const Authenticator a(AuthOptions{}, nullptr);
  auto p = a.Authenticate("", std::nullopt);
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p->name, "anonymous");
  EXPECT_EQ(p->role, Role::kAdmin);
}

TEST_F(AuthenticatorTest, Authenticate_NoCredentials_UnauthenticatedSayingWhatToSend) {
  auto p = Enabled().Authenticate("", std::nullopt);
  EXPECT_EQ(p.status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_THAT(p.status().message(), HasSubstr("authorization: Bearer <token>"));
}

TEST_F(AuthenticatorTest, Authenticate_MappedCertificate_ItsPrincipal_UnmappedRefused) {
  const Authenticator a = Enabled();
  auto p = a.Authenticate("", std::string_view("eng-laptop-07"));
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->name, "a.weber");
  EXPECT_EQ(p->role, Role::kEngineer);
  EXPECT_EQ(p->via, "certificate");
  auto unmapped = a.Authenticate("", std::string_view("stranger"));
  EXPECT_EQ(unmapped.status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_THAT(unmapped.status().message(),
              HasSubstr("CN 'stranger' is not in tls.client_principals"));
  EXPECT_FALSE(a.FromCertificate("ENG-LAPTOP-07")) << "CNs compare exactly";
}

TEST_F(AuthenticatorTest, Authenticate_BadTokenWithMappedCertificate_TokenDecides) {
  auto p = Enabled().Authenticate("Bearer dgw_nonsense", std::string_view("eng-laptop-07"));
  EXPECT_EQ(p.status().code(), absl::StatusCode::kUnauthenticated);
}

TEST_F(AuthenticatorTest, Authenticate_RevokedToken_RefusedAtOnce) {
  const Authenticator a = Enabled();
  ASSERT_TRUE(a.Authenticate("Bearer " + token_, std::nullopt).ok());
  ASSERT_TRUE(tokens_->Revoke("mes-line-3").ok());
  auto p = a.Authenticate("Bearer " + token_, std::nullopt);
  EXPECT_EQ(p.status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_THAT(p.status().message(), HasSubstr("revoked"));
}

TEST(AuthorizeTest, BelowRequiredRole_PermissionDeniedNamingBothRoles) {
  const Principal viewer{"dash", Role::kViewer, "token"};
  absl::Status s = Authenticator::Authorize("/drivegw.v1.DriveService/MoveAbsolute", viewer);
  EXPECT_EQ(s.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_EQ(s.message(),
            "/drivegw.v1.DriveService/MoveAbsolute needs role operator; principal 'dash' has "
            "role viewer");
  EXPECT_TRUE(Authenticator::Authorize("/drivegw.v1.DriveService/ListDrives", viewer).ok());
}

TEST(AuthorizeTest, UnknownMethod_DeniedEvenForAdmin) {
  const Principal admin{"root", Role::kAdmin, "anonymous"};
  absl::Status s = Authenticator::Authorize("/drivegw.v1.DriveService/SelfDestruct", admin);
  EXPECT_EQ(s.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_THAT(s.message(), HasSubstr("no role is assigned"));
}

TEST(RoleTest, OrderAndNames) {
  EXPECT_TRUE(Satisfies(Role::kAdmin, Role::kViewer));
  EXPECT_TRUE(Satisfies(Role::kOperator, Role::kOperator));
  EXPECT_FALSE(Satisfies(Role::kOperator, Role::kEngineer));
  for (Role r : kAllRoles) EXPECT_EQ(ParseRole(RoleName(r)), r);
  EXPECT_FALSE(ParseRole("Admin"));
  EXPECT_FALSE(ParseRole("root"));
}

TEST(MethodRolesTest, IssueSevenExamples) {
  EXPECT_EQ(RequiredRole("/drivegw.v1.DriveService/WatchDrives"), Role::kViewer);
  EXPECT_EQ(RequiredRole("/drivegw.v1.DriveService/Enable"), Role::kOperator);
  EXPECT_EQ(RequiredRole("/drivegw.v1.DriveService/AcknowledgeFault"), Role::kOperator);
  EXPECT_EQ(RequiredRole("/drivegw.v1.DriveService/WriteParameter"), Role::kEngineer);
  EXPECT_EQ(RequiredRole("/drivegw.v1.DriveService/SendNativeCommand"), Role::kEngineer);
  EXPECT_EQ(RequiredRole("/drivegw.v1.CurveSetService/CreateCurveSet"), Role::kEngineer);
  EXPECT_EQ(RequiredRole("/drivegw.v1.ParameterSetService/ApplyParameterSet"), Role::kEngineer);
  EXPECT_EQ(RequiredRole("/drivegw.v1.TokenService/CreateToken"), Role::kAdmin);
  EXPECT_FALSE(RequiredRole("drivegw.v1.DriveService/Enable")) << "full names start with '/'";
}

}  // namespace
}  // namespace drivegw::auth
