// TokenRepo on a real WAL file (migration 004): the secret is shown once and never stored,
// verification needs the exact secret, revocation holds from the next Verify (no cache), even
// when another connection (the CLI's process) revokes; names, roles and malformed tokens refused.
#include "storage/token_repo.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <set>

#include "storage/migrations.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::storage {
namespace {

using ::testing::HasSubstr;
using ::testing::MatchesRegex;
using testing::TempDir;

class TokenRepoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    db_ = Open();
    ASSERT_NE(db_, nullptr);
    ASSERT_TRUE(Migrate(*db_).ok());
    repo_ = std::make_unique<TokenRepo>(*db_);
  }
  std::unique_ptr<Db> Open() {
    auto db = Db::Open(dir_.File("tokens.db"));
    EXPECT_TRUE(db.ok()) << db.status();
    return db.ok() ? std::make_unique<Db>(std::move(*db)) : nullptr;
  }
  // Every text column of every token row, concatenated.
  std::string AllStoredText() {
    auto stmt = db_->Prepare("SELECT id || name || role || salt || secret_hash FROM api_tokens");
    std::string all;
    while (stmt.ok() && stmt->Step().value_or(false)) all += stmt->ColumnText(0);
    return all;
  }

  TempDir dir_;
  std::unique_ptr<Db> db_;
  std::unique_ptr<TokenRepo> repo_;
};

TEST_F(TokenRepoTest, Create_ReturnsTokenOnce_StoresOnlySaltedHash) {
  auto created = repo_->Create("mes-line-3", "operator");
  ASSERT_TRUE(created.ok()) << created.status();
  EXPECT_THAT(created->token, MatchesRegex("dgw_[0-9a-f]{16}_[A-Za-z0-9_-]{43}"));
  EXPECT_EQ(created->token.substr(4, 16), created->record.id);
  EXPECT_EQ(created->record.name, "mes-line-3");
  EXPECT_EQ(created->record.role, "operator");
  EXPECT_FALSE(created->record.revoked_at);
  const std::string secret = created->token.substr(4 + 16 + 1);
  const std::string stored = AllStoredText();
  EXPECT_EQ(stored.find(secret), std::string::npos) << "the secret must never be stored";
  EXPECT_EQ(stored.find(created->token), std::string::npos);
}

TEST_F(TokenRepoTest, Create_TwoTokens_DifferInIdSecretAndSalt) {
  auto a = repo_->Create("a", "viewer");
  auto b = repo_->Create("b", "viewer");
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_NE(a->record.id, b->record.id);
  EXPECT_NE(a->token.substr(21), b->token.substr(21));
  auto stmt =
      db_->Prepare("SELECT COUNT(DISTINCT salt), COUNT(DISTINCT secret_hash) FROM api_tokens");
  ASSERT_TRUE(stmt.ok());
  ASSERT_TRUE(stmt->Step().value_or(false));
  EXPECT_EQ(stmt->ColumnInt(0), 2);
  EXPECT_EQ(stmt->ColumnInt(1), 2);
}

TEST_F(TokenRepoTest, Verify_ExactToken_ReturnsRecordAndNotesLastUse) {
  auto created = repo_->Create("eng", "engineer");
  ASSERT_TRUE(created.ok());
  auto v = repo_->Verify(created->token);
  ASSERT_TRUE(v.ok()) << v.status();
  EXPECT_EQ(v->name, "eng");
  EXPECT_EQ(v->role, "engineer");
  EXPECT_TRUE(v->last_used);
  auto list = repo_->List();
  ASSERT_TRUE(list.ok());
  ASSERT_EQ(list->size(), 1u);
  EXPECT_TRUE((*list)[0].last_used);
}

TEST_F(TokenRepoTest, Verify_WrongSecretOrUnknownId_Unauthenticated) {
  auto created = repo_->Create("op", "operator");
  ASSERT_TRUE(created.ok());
  std::string wrong = created->token;
  wrong.back() = wrong.back() == 'A' ? 'B' : 'A';
  auto v = repo_->Verify(wrong);
  EXPECT_EQ(v.status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_THAT(v.status().message(), HasSubstr("unknown or wrong token"));
  EXPECT_THAT(std::string(v.status().message()), ::testing::Not(HasSubstr(wrong.substr(21))));

  std::string other_id = created->token;
  other_id[4] = other_id[4] == '0' ? '1' : '0';
  EXPECT_EQ(repo_->Verify(other_id).status().code(), absl::StatusCode::kUnauthenticated);
}

TEST_F(TokenRepoTest, Verify_Malformed_UnauthenticatedBeforeTheDatabase) {
  for (const char* bad : {"", "dgw_", "Bearer x", "dgw_0123456789abcdef_short",
                          "xyz_0123456789abcdef_AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA",
                          "dgw_0123456789ABCDEF_AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA",
                          "dgw_0123456789abcdef_AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA="}) {
    auto v = repo_->Verify(bad);
    EXPECT_EQ(v.status().code(), absl::StatusCode::kUnauthenticated) << bad;
    EXPECT_THAT(v.status().message(), HasSubstr("malformed")) << bad;
  }
}

TEST_F(TokenRepoTest, Revoke_NextVerifyRefused) {
  auto created = repo_->Create("mes", "operator");
  ASSERT_TRUE(created.ok());
  ASSERT_TRUE(repo_->Verify(created->token).ok());
  auto revoked = repo_->Revoke("mes");
  ASSERT_TRUE(revoked.ok()) << revoked.status();
  EXPECT_TRUE(revoked->revoked_at);
  auto v = repo_->Verify(created->token);
  EXPECT_EQ(v.status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_THAT(v.status().message(), HasSubstr("'mes' was revoked at"));
}

TEST_F(TokenRepoTest, Revoke_ByAnotherConnection_NextVerifyRefused) {
  auto created = repo_->Create("mes", "operator");
  ASSERT_TRUE(created.ok());
  ASSERT_TRUE(repo_->Verify(created->token).ok());
  {
    // The CLI in another process: its own connection to the same file.
    std::unique_ptr<Db> other = Open();
    ASSERT_NE(other, nullptr);
    TokenRepo cli(*other);
    ASSERT_TRUE(cli.Revoke("mes").ok());
  }
  EXPECT_EQ(repo_->Verify(created->token).status().code(), absl::StatusCode::kUnauthenticated);
}

TEST_F(TokenRepoTest, Revoke_UnknownOrAlreadyRevoked_NotFound) {
  EXPECT_EQ(repo_->Revoke("nobody").status().code(), absl::StatusCode::kNotFound);
  ASSERT_TRUE(repo_->Create("t", "viewer").ok());
  ASSERT_TRUE(repo_->Revoke("t").ok());
  auto again = repo_->Revoke("t");
  EXPECT_EQ(again.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(again.status().message(), HasSubstr("no live token 't'"));
}

TEST_F(TokenRepoTest, Create_LiveNameTaken_AlreadyExists_RevokedNameReusable) {
  auto first = repo_->Create("line", "viewer");
  ASSERT_TRUE(first.ok());
  auto dup = repo_->Create("line", "admin");
  EXPECT_EQ(dup.status().code(), absl::StatusCode::kAlreadyExists);
  EXPECT_THAT(dup.status().message(), HasSubstr("name: a live token 'line' exists"));
  ASSERT_TRUE(repo_->Revoke("line").ok());
  auto second = repo_->Create("line", "admin");
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_EQ(repo_->Verify(first->token).status().code(), absl::StatusCode::kUnauthenticated);
  auto v = repo_->Verify(second->token);
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(v->role, "admin");
  auto live = repo_->List(/*include_revoked=*/false);
  auto all = repo_->List(/*include_revoked=*/true);
  ASSERT_TRUE(live.ok() && all.ok());
  EXPECT_EQ(live->size(), 1u);
  EXPECT_EQ(all->size(), 2u);
}

TEST_F(TokenRepoTest, Create_BadNameOrRole_InvalidArgumentNamingTheField) {
  auto bad_name = repo_->Create("mes line", "viewer");
  EXPECT_EQ(bad_name.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad_name.status().message(), HasSubstr("name: 'mes line' has a character outside"));
  EXPECT_THAT(repo_->Create("", "viewer").status().message(), HasSubstr("name: length 0"));
  auto bad_role = repo_->Create("x", "root");
  EXPECT_EQ(bad_role.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad_role.status().message(), HasSubstr("role: 'root' is not one of"));
}

TEST_F(TokenRepoTest, Table_RowsCannotBeDeletedOrRewritten) {
  auto created = repo_->Create("t", "viewer");
  ASSERT_TRUE(created.ok());
  EXPECT_FALSE(db_->Exec("DELETE FROM api_tokens").ok());
  EXPECT_FALSE(db_->Exec("UPDATE api_tokens SET role = 'admin'").ok());
  ASSERT_TRUE(repo_->Revoke("t").ok());
  EXPECT_FALSE(db_->Exec("UPDATE api_tokens SET revoked_at = NULL").ok());
  EXPECT_EQ(repo_->Verify(created->token).status().code(), absl::StatusCode::kUnauthenticated);
}

}  // namespace
}  // namespace drivegw::storage
