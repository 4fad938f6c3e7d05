// The audit hash chain (decision 017): canonical form, linking, verification of tampered,
// removed and legacy rows, the append-only triggers, retention with prune anchors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "nlohmann/json.hpp"
#include "storage/audit_log.h"
#include "storage/audit_log_hash.h"
#include "tests/storage/audit_fixture.h"

namespace drivegw::storage {
namespace {

using std::chrono::milliseconds;
using testing::AuditDbTest;
using ::testing::HasSubstr;
using testing::kAuditT0;
using testing::MakeEntry;

TEST(AuditHashTest, Sha256_KnownVector) {
  Sha256 sha;
  sha.Update("a");
  sha.Update("bc");
  EXPECT_EQ(sha.HexDigest(), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(AuditHashTest, CanonicalForm_LengthPrefixedFieldsInFixedOrder) {
  AuditEntry e = MakeEntry("x1", "MoveAbsolute", kAuditT0 + milliseconds(7));
  e.result_message = "line\nbreak";
  EXPECT_EQ(CanonicalAuditForm(3, e, "ab"),
            "drivegw.audit.v1\n"
            "seq 1:3\n"
            "ts 24:2024-05-01T12:00:00.007Z\n"
            "principal 5:alice\n"
            "role 8:operator\n"
            "source_address 19:ipv4:127.0.0.1:5000\n"
            "drive 2:x1\n"
            "action 12:MoveAbsolute\n"
            "request_json 20:{\"position_mm\":12.5}\n"
            "result_code 1:0\n"
            "result_message 10:line\nbreak\n"
            "before_json 0:\n"
            "after_json 0:\n"
            "prev_hash 2:ab\n");
  Sha256 sha;
  sha.Update(CanonicalAuditForm(3, e, "ab"));
  EXPECT_EQ(AuditEntryHash(3, e, "ab"), sha.HexDigest());
  // A boundary moved between two fields changes the hash.
  AuditEntry shifted = e;
  shifted.drive = "x";
  shifted.action = "1MoveAbsolute";
  EXPECT_NE(AuditEntryHash(3, shifted, "ab"), AuditEntryHash(3, e, "ab"));
}

using AuditChainTest = AuditDbTest;

TEST_F(AuditChainTest, Append_LinksEveryEntryFromTheGenesisAnchor) {
  for (int i = 0; i < 10; ++i) AppendOrDie(MakeEntry("x1", absl::StrCat("a", i)));
  const auto rows = All();
  ASSERT_EQ(rows.size(), 11u);
  EXPECT_EQ(rows[0].seq, 1);
  EXPECT_EQ(rows[0].action, AuditLog::kGenesisAction);
  EXPECT_EQ(rows[0].prev_hash, kGenesisPrevHash);
  for (size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].seq, static_cast<int64_t>(i) + 1);
    EXPECT_EQ(rows[i].hash, AuditEntryHash(rows[i].seq, rows[i], rows[i].prev_hash)) << i;
    if (i > 0) {
      EXPECT_EQ(rows[i].prev_hash, rows[i - 1].hash) << i;
    }
  }
  EXPECT_EQ(rows[1].role, "operator");
  const AuditVerifyReport v = VerifyOrDie();
  EXPECT_TRUE(v.ok);
  EXPECT_FALSE(v.broken.has_value());
  EXPECT_EQ(v.verified_entries, 11);
  EXPECT_EQ(v.first_seq, 1);
  EXPECT_EQ(v.last_seq, 11);
  EXPECT_EQ(v.head_hash, rows.back().hash);
  EXPECT_EQ(v.anchor, "genesis");
}

TEST_F(AuditChainTest, EmptyLog_VerifiesWithNothingToCheck) {
  const AuditVerifyReport v = VerifyOrDie();
  EXPECT_TRUE(v.ok);
  EXPECT_EQ(v.verified_entries, 0);
  EXPECT_EQ(v.first_seq, 0);
  EXPECT_TRUE(v.head_hash.empty());
}

TEST_F(AuditChainTest, BeforeAndAfter_StoredAndHashed) {
  AuditEntry e = MakeEntry("x1", "WriteParameter");
  e.before_json = R"({"value":1})";
  e.after_json = R"({"value":2})";
  AppendOrDie(e);
  const auto rows = All();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].before_json, e.before_json);
  EXPECT_EQ(rows[1].after_json, e.after_json);
  ExecOrDie("DROP TRIGGER audit_log_no_update");
  ExecOrDie("UPDATE audit_log SET after_json = '{\"value\":3}' WHERE seq = 2");
  const AuditVerifyReport v = VerifyOrDie();
  ASSERT_FALSE(v.ok);
  EXPECT_EQ(v.broken->seq, 2);
  EXPECT_EQ(v.broken->field, "hash");
}

TEST_F(AuditChainTest, TamperedRow_FirstBrokenLinkIsThatRow) {
  for (int i = 0; i < 10; ++i) AppendOrDie(MakeEntry("x1", absl::StrCat("a", i)));
  // Raw SQL as an attacker with file access would do it: the guard goes first.
  ExecOrDie("DROP TRIGGER audit_log_no_update");
  ExecOrDie("UPDATE audit_log SET request_json = '{\"position_mm\":99}' WHERE seq = 5");
  ExecOrDie("UPDATE audit_log SET result_code = 0 WHERE seq = 8");  // unchanged value: no harm
  const AuditVerifyReport v = VerifyOrDie();
  EXPECT_FALSE(v.ok);
  ASSERT_TRUE(v.broken.has_value());
  EXPECT_EQ(v.broken->seq, 5);
  EXPECT_EQ(v.broken->field, "hash");
  EXPECT_EQ(v.broken->actual, All()[4].hash);
  EXPECT_NE(v.broken->expected, v.broken->actual);
  EXPECT_THAT(v.broken->message, HasSubstr("seq 5"));
  EXPECT_EQ(v.verified_entries, 4);
}

TEST_F(AuditChainTest, TamperedRowWithRecomputedHash_BreaksTheNextLink) {
  for (int i = 0; i < 10; ++i) AppendOrDie(MakeEntry("x1", absl::StrCat("a", i)));
  AuditRecord r = All()[4];
  r.principal = "mallory";
  const std::string forged = AuditEntryHash(r.seq, r, r.prev_hash);
  ExecOrDie("DROP TRIGGER audit_log_no_update");
  ExecOrDie(absl::StrCat("UPDATE audit_log SET principal = 'mallory', hash = '", forged,
                         "' WHERE seq = 5"));
  const AuditVerifyReport v = VerifyOrDie();
  ASSERT_FALSE(v.ok);
  EXPECT_EQ(v.broken->seq, 6);
  EXPECT_EQ(v.broken->field, "prev_hash");
  EXPECT_EQ(v.broken->expected, forged);
}

TEST_F(AuditChainTest, RemovedRows_ReportedAsMissingSequence) {
  for (int i = 0; i < 10; ++i) AppendOrDie(MakeEntry("x1", absl::StrCat("a", i)));
  ExecOrDie("DROP TRIGGER audit_log_no_delete");
  ExecOrDie("DELETE FROM audit_log WHERE seq IN (4, 5)");
  AuditVerifyReport v = VerifyOrDie();
  ASSERT_FALSE(v.ok);
  EXPECT_EQ(v.broken->seq, 4);
  EXPECT_EQ(v.broken->field, "seq");
  EXPECT_THAT(v.broken->message, HasSubstr("rows seq 4..5 are missing"));

  // The oldest rows removed without an anchor.
  ExecOrDie("DELETE FROM audit_log WHERE seq < 4");
  v = VerifyOrDie();
  ASSERT_FALSE(v.ok);
  EXPECT_EQ(v.broken->seq, 6);
  EXPECT_EQ(v.broken->field, "anchor");
}

TEST_F(AuditChainTest, Triggers_RefuseUpdateDeleteAndOffChainInserts) {
  AppendOrDie(MakeEntry("x1", "Enable"));
  absl::Status s = db_->Exec("UPDATE audit_log SET principal = 'mallory'");
  EXPECT_THAT(s.message(), HasSubstr("audit_log is append-only"));
  s = db_->Exec("DELETE FROM audit_log");
  EXPECT_THAT(s.message(), HasSubstr("audit_log is append-only"));
  const std::string h(64, 'a');
  for (const std::string seq : {"NULL", "2", "9"}) {
    s = db_->Exec(absl::StrCat(
        "INSERT INTO audit_log (ts, principal, source_address, drive, action, request_json, "
        "result_code, result_message, seq, prev_hash, hash) VALUES "
        "('2024-05-01T12:00:00.000Z', 'm', '', '', 'x', '{}', 0, '', ",
        seq, ", '", h, "', '", h, "')"));
    // Off the chain, a taken sequence number, a gap: the next one would be 3.
    EXPECT_THAT(s.message(), HasSubstr("only appended to the end of the hash chain")) << seq;
  }
  // With the right next seq but not at the end by id (migration 006 ties seq order to id order):
  // an explicit id below the newest, and INSERT OR REPLACE of an existing row (REPLACE deletes
  // without firing audit_log_no_delete), the head's id with the head's seq included.
  for (const auto& [verb, id, seq] :
       std::vector<std::array<std::string, 3>>{{"INSERT", "-1", "3"},
                                               {"INSERT OR REPLACE", "1", "3"},
                                               {"INSERT OR REPLACE", "2", "3"},
                                               {"INSERT OR REPLACE", "2", "2"}}) {
    s = db_->Exec(absl::StrCat(
        verb,
        " INTO audit_log (id, ts, principal, source_address, drive, action, request_json, "
        "result_code, result_message, seq, prev_hash, hash) VALUES (",
        id, ", '2024-05-01T12:00:00.000Z', 'm', '', '', 'x', '{}', 0, '', ", seq, ", '", h, "', '",
        h, "')"));
    EXPECT_THAT(s.message(), HasSubstr("only appended to the end of the hash chain"))
        << verb << " id " << id << " seq " << seq;
  }
  EXPECT_EQ(*log_->Count(), 2);
  EXPECT_TRUE(VerifyOrDie().ok);
}

TEST_F(AuditChainTest, LegacyRows_CoveredByTheGenesisDigest) {
  // Rows as migration 001 wrote them (seq NULL): the chain triggers (005, 006) are lifted for
  // the setup only.
  auto trig = db_->Prepare(
      "SELECT name, sql FROM sqlite_master WHERE type = 'trigger' AND name LIKE "
      "'audit_log_chain_%'");
  ASSERT_TRUE(trig.ok());
  std::vector<std::string> names, creates;
  while (*trig->Step()) {
    names.push_back(trig->ColumnText(0));
    creates.push_back(trig->ColumnText(1));
  }
  trig->Reset().IgnoreError();
  ASSERT_EQ(creates.size(), 2u);
  for (const std::string& name : names) ExecOrDie(absl::StrCat("DROP TRIGGER ", name));
  for (int i = 0; i < 3; ++i) {
    ExecOrDie(absl::StrCat(
        "INSERT INTO audit_log (ts, principal, source_address, drive, action, request_json, "
        "result_code, result_message) VALUES ('2024-05-01T11:00:00.00",
        i, "Z', 'bob', '', 'x1', 'Enable', '{}', 0, '')"));
  }
  for (const std::string& create : creates) ExecOrDie(create);
  AppendOrDie(MakeEntry("x1", "Disable"));
  const auto rows = All();
  ASSERT_EQ(rows.size(), 5u);
  EXPECT_EQ(rows[0].seq, 0);
  EXPECT_EQ(rows[3].action, AuditLog::kGenesisAction);
  const auto genesis = nlohmann::json::parse(rows[3].request_json);
  EXPECT_EQ(genesis["legacy_rows"], 3);
  EXPECT_EQ(genesis["legacy_last_id"], rows[2].id);
  AuditVerifyReport v = VerifyOrDie();
  EXPECT_TRUE(v.ok);
  EXPECT_EQ(v.legacy_entries, 3);
  EXPECT_EQ(v.verified_entries, 2);

  ExecOrDie("DROP TRIGGER audit_log_no_update");
  ExecOrDie("UPDATE audit_log SET principal = 'mallory' WHERE seq IS NULL AND id = 2");
  v = VerifyOrDie();
  ASSERT_FALSE(v.ok);
  EXPECT_EQ(v.broken->seq, 1);
  EXPECT_EQ(v.broken->field, "legacy_digest");
}

TEST_F(AuditChainTest, Retention_WarnsOnceThenPrunesWithAnAnchorAndStillVerifies) {
  AuditRetention r;
  r.max_entries = 20;
  r.warn_at_percent = 90;   // 18 rows
  r.prune_to_percent = 50;  // 10 rows after a prune
  ASSERT_TRUE(log_->SetRetention(r).ok());
  auto count_of = [&](std::string_view action) {
    AuditQuery q;
    q.action = std::string(action);
    q.limit = AuditQuery::kMaxLimit;
    return log_->Query(q)->size();
  };
  // genesis + 16 = 17 rows: below the warning.
  for (int i = 0; i < 16; ++i) AppendOrDie(MakeEntry("x1", "Poll"));
  EXPECT_EQ(count_of(AuditLog::kWarningAction), 0u);
  AppendOrDie(MakeEntry("x1", "Poll"));  // 18: the warning (19 rows)
  EXPECT_EQ(count_of(AuditLog::kWarningAction), 1u);
  EXPECT_EQ(*log_->Count(), 19);
  AuditQuery warn;
  warn.action = std::string(AuditLog::kWarningAction);
  const AuditRecord w = log_->Query(warn)->front();
  EXPECT_EQ(w.principal, AuditLog::kSystemPrincipal);
  EXPECT_THAT(w.result_message, HasSubstr("18 of max_entries 20"));
  EXPECT_EQ(count_of(AuditLog::kPrunedAction), 0u);
  AppendOrDie(MakeEntry("x1", "Poll"));  // 20: the limit -> prune to 10 including the anchor
  EXPECT_EQ(*log_->Count(), 10);
  EXPECT_EQ(count_of(AuditLog::kWarningAction), 1u);  // newer than the pruned rows
  AuditQuery pruned;
  pruned.action = std::string(AuditLog::kPrunedAction);
  const AuditRecord anchor = log_->Query(pruned)->front();
  const auto j = nlohmann::json::parse(anchor.request_json);
  EXPECT_EQ(j["pruned_rows"], 11);
  EXPECT_EQ(j["pruned_through_seq"], 11);
  EXPECT_EQ(All().front().seq, 12);
  EXPECT_EQ(All().front().prev_hash, j["last_pruned_hash"]);
  AuditVerifyReport v = VerifyOrDie();
  EXPECT_TRUE(v.ok) << v.broken->message;
  EXPECT_EQ(v.anchor, "pruned through seq 11");
  EXPECT_EQ(v.first_seq, 12);
  EXPECT_EQ(v.verified_entries, 10);

  // Further cycles: one warning per fill-up, every prune anchored, verification holds.
  for (int i = 0; i < 45; ++i) AppendOrDie(MakeEntry("x1", "Poll"));
  EXPECT_LE(*log_->Count(), 20);
  EXPECT_GE(count_of(AuditLog::kWarningAction), 1u);
  EXPECT_LE(count_of(AuditLog::kWarningAction), 2u);  // this fill-up's and maybe the last one's
  EXPECT_EQ(count_of(AuditLog::kPrunedAction), 1u);   // older anchors were pruned with their rows
  v = VerifyOrDie();
  EXPECT_TRUE(v.ok) << v.broken->message;
  // Only the pruning path may delete: the guard row is gone again.
  absl::Status s = db_->Exec("DELETE FROM audit_log WHERE id = (SELECT MIN(id) FROM audit_log)");
  EXPECT_THAT(s.message(), HasSubstr("audit_log is append-only"));
}

TEST_F(AuditChainTest, Retention_PrunedRowsRemovedByHand_AreNotCoveredByTheAnchor) {
  AuditRetention r;
  r.max_entries = 10;
  r.warn_at_percent = 90;
  r.prune_to_percent = 50;
  ASSERT_TRUE(log_->SetRetention(r).ok());
  for (int i = 0; i < 12; ++i) AppendOrDie(MakeEntry("x1", "Poll"));
  ASSERT_TRUE(VerifyOrDie().ok);
  ExecOrDie("DROP TRIGGER audit_log_no_delete");
  ExecOrDie("DELETE FROM audit_log WHERE id = (SELECT MIN(id) FROM audit_log)");
  const AuditVerifyReport v = VerifyOrDie();
  ASSERT_FALSE(v.ok);
  EXPECT_EQ(v.broken->field, "anchor");
}

TEST_F(AuditChainTest, SetRetention_RefusesLimitsOutOfOrder) {
  AuditRetention r;
  r.max_entries = 5;
  EXPECT_THAT(log_->SetRetention(r).message(), HasSubstr("audit.max_entries: 5 is below 10"));
  r.max_entries = 100;
  r.warn_at_percent = 101;
  EXPECT_THAT(log_->SetRetention(r).message(), HasSubstr("audit.warn_at_percent: 101"));
  r.warn_at_percent = 80;
  r.prune_to_percent = 80;
  EXPECT_THAT(log_->SetRetention(r).message(), HasSubstr("audit.prune_to_percent: 80 must be"));
  r.prune_to_percent = 50;
  EXPECT_TRUE(log_->SetRetention(r).ok());
}

TEST_F(AuditChainTest, Query_PrincipalUntilAscendingAfterId) {
  AuditEntry a = MakeEntry("x1", "Enable", kAuditT0);
  AuditEntry b = MakeEntry("x1", "Enable", kAuditT0 + milliseconds(10));
  b.principal = "bob";
  AuditEntry c = MakeEntry("x2", "Enable", kAuditT0 + milliseconds(20));
  AppendOrDie(a);
  AppendOrDie(b);
  AppendOrDie(c);
  AuditQuery q;
  q.principal = "bob";
  auto r = log_->Query(q);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->size(), 1u);
  EXPECT_EQ(r->front().principal, "bob");

  AuditQuery until;
  until.until = kAuditT0 + milliseconds(20);  // exclusive
  until.action = "Enable";
  until.ascending = true;
  r = log_->Query(until);
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[0].time, kAuditT0);
  EXPECT_EQ((*r)[1].principal, "bob");

  AuditQuery after;
  after.after_id = (*r)[0].id;
  after.ascending = true;
  after.action = "Enable";
  r = log_->Query(after);
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[1].drive, "x2");
}

TEST_F(AuditChainTest, WaitForAppend_WakesOnAnAppendFromAnotherThread) {
  AppendOrDie(MakeEntry("x1", "Enable"));
  const int64_t last = *log_->LastId();
  std::thread writer([&] { AppendOrDie(MakeEntry("x1", "Disable")); });
  log_->WaitForAppend(last, std::chrono::steady_clock::now() + std::chrono::seconds(30));
  writer.join();
  EXPECT_GT(*log_->LastId(), last);
}

TEST_F(AuditChainTest, ConcurrentAppends_StayOneLinearChain) {
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < 50; ++i) {
        EXPECT_TRUE(log_->Append(MakeEntry(absl::StrCat("t", t), "Poll")).ok());
      }
    });
  }
  for (auto& th : threads) th.join();
  const AuditVerifyReport v = VerifyOrDie();
  EXPECT_TRUE(v.ok);
  EXPECT_EQ(v.verified_entries, 201);
}

TEST_F(AuditChainTest, SecondAuditLogOnTheSameFile_ContinuesTheChain) {
  AppendOrDie(MakeEntry("x1", "Enable"));
  auto other_db = Db::Open(dir_.File("audit.db"));
  ASSERT_TRUE(other_db.ok());
  AuditLog other(*other_db);
  ASSERT_TRUE(other.Append(MakeEntry("x1", "Disable")).ok());
  AppendOrDie(MakeEntry("x1", "Enable"));
  const AuditVerifyReport v = VerifyOrDie();
  EXPECT_TRUE(v.ok);
  EXPECT_EQ(v.last_seq, 4);
}

}  // namespace
}  // namespace drivegw::storage
