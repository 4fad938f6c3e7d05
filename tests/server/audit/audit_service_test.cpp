// AuditServiceCore over a real SQLite file: list filters and paging, watch, export lines that
// verify on their own, verify with a tampered row, and the WriteAudit forms (decision 017).
#include "server/core/audit_service.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <condition_variable>
#include <mutex>
#include <set>
#include <thread>

#include "absl/strings/str_cat.h"
#include "google/protobuf/util/json_util.h"
#include "nlohmann/json.hpp"
#include "server/core/audit.h"
#include "storage/audit_log_hash.h"
#include "tests/storage/audit_fixture.h"

namespace drivegw::server {
namespace {

using std::chrono::milliseconds;
using storage::testing::kAuditT0;
using storage::testing::MakeEntry;
using ::testing::HasSubstr;

constexpr auto kWait = std::chrono::seconds(30);  // generous: ctest -j3 on two cores

class AuditServiceTest : public storage::testing::AuditDbTest {
 protected:
  void SetUp() override {
    AuditDbTest::SetUp();
    core_ = std::make_unique<AuditServiceCore>(*log_);
  }

  // 12 entries: drives x1/x2 alternating, principals alice/bob by thirds, one ms apart.
  void AppendMix() {
    for (int i = 0; i < 12; ++i) {
      storage::AuditEntry e = MakeEntry(i % 2 ? "x2" : "x1", i % 3 ? "MoveAbsolute" : "Enable",
                                        kAuditT0 + milliseconds(i));
      e.principal = i < 4 ? "alice" : (i < 8 ? "bob" : "carol");
      AppendOrDie(e);
    }
  }

  std::unique_ptr<AuditServiceCore> core_;
  CallContext ctx_{"admin-token", "admin", "ipv4:127.0.0.1:1", "grpc", ""};
};

TEST_F(AuditServiceTest, List_FiltersCombine) {
  AppendMix();
  v1::ListAuditEventsRequest r;
  r.set_drive("x2");
  r.set_principal("bob");
  auto resp = core_->ListAuditEvents(r, ctx_);
  ASSERT_TRUE(resp.ok()) << resp.status();
  ASSERT_EQ(resp->events_size(), 2);  // i = 5, 7
  for (const auto& e : resp->events()) {
    EXPECT_EQ(e.drive(), "x2");
    EXPECT_EQ(e.principal(), "bob");
  }
  EXPECT_EQ(resp->events(0).time(), "2024-05-01T12:00:00.007Z");  // newest first
  EXPECT_TRUE(resp->next_page_token().empty());

  v1::ListAuditEventsRequest window;
  window.set_start_time("2024-05-01T12:00:00.003Z");
  window.set_end_time("2024-05-01T12:00:00.006Z");  // exclusive
  window.set_action("MoveAbsolute");
  resp = core_->ListAuditEvents(window, ctx_);
  ASSERT_TRUE(resp.ok()) << resp.status();
  ASSERT_EQ(resp->events_size(), 2);  // i = 4, 5 (3 is Enable)
  EXPECT_EQ(resp->events(0).time(), "2024-05-01T12:00:00.005Z");
  EXPECT_EQ(resp->events(1).time(), "2024-05-01T12:00:00.004Z");
  EXPECT_EQ(resp->events(0).role(), "operator");
  EXPECT_EQ(resp->events(0).hash().size(), 64u);
  EXPECT_GT(resp->events(0).sequence(), resp->events(1).sequence());
}

TEST_F(AuditServiceTest, List_PagesWithTokensUntilTheLastPage) {
  AppendMix();
  v1::ListAuditEventsRequest r;
  r.set_page_size(5);
  std::vector<int64_t> ids;
  int pages = 0;
  while (true) {
    auto resp = core_->ListAuditEvents(r, ctx_);
    ASSERT_TRUE(resp.ok()) << resp.status();
    ++pages;
    for (const auto& e : resp->events()) ids.push_back(e.id());
    if (resp->next_page_token().empty()) break;
    r.set_page_token(resp->next_page_token());
    ASSERT_LT(pages, 10);
  }
  EXPECT_EQ(pages, 3);  // 13 entries with the genesis anchor: 5 + 5 + 3
  EXPECT_EQ(ids.size(), 13u);
  EXPECT_TRUE(std::is_sorted(ids.rbegin(), ids.rend()));
  EXPECT_EQ(std::set<int64_t>(ids.begin(), ids.end()).size(), 13u);
}

TEST_F(AuditServiceTest, List_BadArgumentsNameTheField) {
  v1::ListAuditEventsRequest r;
  r.set_start_time("yesterday");
  auto resp = core_->ListAuditEvents(r, ctx_);
  EXPECT_EQ(resp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(resp.status().message(), HasSubstr("start_time: timestamp: 'yesterday'"));
  r.Clear();
  r.set_start_time("2024-05-01T12:00:00Z");
  r.set_end_time("2024-05-01T11:00:00Z");
  EXPECT_THAT(core_->ListAuditEvents(r, ctx_).status().message(),
              HasSubstr("end_time: '2024-05-01T11:00:00Z' is not after start_time"));
  r.Clear();
  r.set_page_token("abc");
  EXPECT_THAT(core_->ListAuditEvents(r, ctx_).status().message(), HasSubstr("page_token: 'abc'"));
  r.Clear();
  r.set_page_size(1001);
  EXPECT_THAT(core_->ListAuditEvents(r, ctx_).status().message(),
              HasSubstr("page_size: 1001 is outside 0..1000"));
}

TEST_F(AuditServiceTest, Watch_StreamsNewMatchingEntriesOnly) {
  AppendOrDie(MakeEntry("x2", "Enable"));  // before the watch: not streamed
  std::mutex mu;
  std::condition_variable cv;
  std::vector<v1::AuditEvent> got;
  bool running = false;
  std::atomic<bool> cancel{false};
  v1::WatchAuditEventsRequest r;
  r.set_drive("x2");
  absl::Status result;
  std::thread watcher([&] {
    result = core_->WatchAuditEvents(
        r, ctx_,
        [&](const v1::AuditEvent& e) {
          std::lock_guard lock(mu);
          got.push_back(e);
          cv.notify_all();
          return true;
        },
        [&] {
          std::lock_guard lock(mu);
          running = true;  // the stream's start point is taken before the first check
          cv.notify_all();
          return cancel.load();
        });
  });
  {
    std::unique_lock lock(mu);
    ASSERT_TRUE(cv.wait_for(lock, kWait, [&] { return running; }));
  }
  AppendOrDie(MakeEntry("x1", "Disable"));
  storage::AuditEntry wanted = MakeEntry("x2", "Disable");
  wanted.request_json = R"({"name":"x2"})";
  AppendOrDie(wanted);
  {
    std::unique_lock lock(mu);
    EXPECT_TRUE(cv.wait_for(lock, kWait, [&] { return !got.empty(); }));
  }
  cancel.store(true);
  watcher.join();
  EXPECT_TRUE(result.ok()) << result;
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].action(), "Disable");
  EXPECT_EQ(got[0].request_json(), R"({"name":"x2"})");
}

TEST_F(AuditServiceTest, Export_JsonLinesParseAndVerifyOnTheirOwn) {
  AppendMix();
  std::vector<std::string> lines;
  google::protobuf::util::JsonPrintOptions o;  // as the REST router prints NDJSON lines
  o.always_print_primitive_fields = true;
  o.preserve_proto_field_names = true;
  v1::ExportAuditEventsRequest r;
  absl::Status s = core_->ExportAuditEvents(
      r, ctx_,
      [&](const v1::AuditEvent& e) {
        std::string line;
        EXPECT_TRUE(google::protobuf::util::MessageToJsonString(e, &line, o).ok());
        lines.push_back(line);
        return true;
      },
      [] { return false; });
  ASSERT_TRUE(s.ok()) << s;
  ASSERT_EQ(lines.size(), 13u);
  std::string prev(storage::kGenesisPrevHash);
  for (size_t i = 0; i < lines.size(); ++i) {
    const auto j = nlohmann::json::parse(lines[i]);
    // Everything a verifier outside drivegw needs is on the line (decision 017).
    storage::AuditEntry e;
    e.time = *storage::ParseTimestamp(j["time"].get<std::string>());
    e.principal = j["principal"];
    e.role = j["role"];
    e.source_address = j["source_address"];
    e.drive = j["drive"];
    e.action = j["action"];
    e.request_json = j["request_json"];
    e.result_code = j["result_code"];
    e.result_message = j["result_message"];
    e.before_json = j["before_json"];
    e.after_json = j["after_json"];
    const int64_t seq = std::stoll(j["sequence"].get<std::string>());  // int64 is a JSON string
    EXPECT_EQ(seq, static_cast<int64_t>(i) + 1);
    EXPECT_EQ(j["prev_hash"], prev) << i;
    EXPECT_EQ(storage::AuditEntryHash(seq, e, prev), j["hash"]) << i;
    prev = j["hash"];
  }
  // The export itself is on the record, after what it exported.
  v1::ListAuditEventsRequest last;
  last.set_action("audit.export");
  auto resp = core_->ListAuditEvents(last, ctx_);
  ASSERT_TRUE(resp.ok());
  ASSERT_EQ(resp->events_size(), 1);
  EXPECT_EQ(resp->events(0).principal(), "admin-token");
  EXPECT_EQ(resp->events(0).result_message(), "exported 13 entries");
}

TEST_F(AuditServiceTest, Export_FiltersAndStopsWhenTheSinkRefuses) {
  AppendMix();
  v1::ExportAuditEventsRequest r;
  r.set_drive("x1");
  int n = 0;
  absl::Status s = core_->ExportAuditEvents(
      r, ctx_,
      [&](const v1::AuditEvent& e) {
        EXPECT_EQ(e.drive(), "x1");
        return ++n < 3;
      },
      [] { return false; });
  EXPECT_EQ(s.code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(n, 3);
}

// Gap 14: Export checks its time filters like List does, before anything is streamed.
TEST_F(AuditServiceTest, Export_BadTimes_InvalidArgumentNamingTheFieldNothingStreamed) {
  AppendOrDie(MakeEntry("x1", "Enable"));
  int streamed = 0;
  auto sink = [&](const v1::AuditEvent&) {
    ++streamed;
    return true;
  };
  auto never = [] { return false; };
  v1::ExportAuditEventsRequest r;
  r.set_start_time("2024-13-01T00:00:00Z");
  absl::Status s = core_->ExportAuditEvents(r, ctx_, sink, never);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("start_time: timestamp: '2024-13-01T00:00:00Z' is not UTC "
                                     "ISO-8601 (YYYY-MM-DDTHH:MM:SS.mmmZ)"));
  r.Clear();
  r.set_end_time("tomorrow");
  s = core_->ExportAuditEvents(r, ctx_, sink, never);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("end_time: timestamp: 'tomorrow'"));
  r.Clear();
  r.set_start_time("2024-05-01T12:00:00Z");
  r.set_end_time("2024-05-01T12:00:00Z");
  s = core_->ExportAuditEvents(r, ctx_, sink, never);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("end_time: '2024-05-01T12:00:00Z' is not after start_time "
                                     "'2024-05-01T12:00:00Z'"));
  EXPECT_EQ(streamed, 0);
}

TEST_F(AuditServiceTest, Verify_ReportsTheFirstBrokenLinkAndIsAudited) {
  AppendMix();
  auto ok = core_->VerifyAuditLog({}, ctx_);
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_TRUE(ok->ok());
  EXPECT_EQ(ok->verified_entries(), 13);
  EXPECT_EQ(ok->anchor(), "genesis");
  EXPECT_FALSE(ok->has_first_broken_link());

  ExecOrDie("DROP TRIGGER audit_log_no_update");
  ExecOrDie("UPDATE audit_log SET result_code = 7 WHERE seq = 6");
  auto broken = core_->VerifyAuditLog({}, ctx_);
  ASSERT_TRUE(broken.ok()) << broken.status();
  EXPECT_FALSE(broken->ok());
  EXPECT_EQ(broken->first_broken_link().sequence(), 6);
  EXPECT_EQ(broken->first_broken_link().field(), "hash");
  EXPECT_EQ(broken->verified_entries(), 5);

  v1::ListAuditEventsRequest r;
  r.set_action("audit.verify");
  auto entries = core_->ListAuditEvents(r, ctx_);
  ASSERT_TRUE(entries.ok());
  ASSERT_EQ(entries->events_size(), 2);
  EXPECT_EQ(entries->events(0).result_code(), static_cast<int>(absl::StatusCode::kDataLoss));
  EXPECT_THAT(entries->events(0).result_message(), HasSubstr("broken at seq 6 (hash)"));
  EXPECT_EQ(entries->events(1).result_code(), 0);
}

TEST_F(AuditServiceTest, WriteAudit_BothFormsRecordRoleAndTheNewOneBeforeAfter) {
  CallContext c{"mes-line-3", "engineer", "ipv4:10.0.0.7:4000", "rest", ""};
  WriteAudit(log_.get(), c, "x1", "Enable", "{}", absl::OkStatus());
  WriteAudit(log_.get(), c,
             AuditWrite{"x1", "WriteParameter", R"({"parameter":"$14.vmax"})",
                        absl::FailedPreconditionError("drive is moving"), R"({"value":100})",
                        R"({"value":300})", ""});
  const auto rows = All();
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[1].principal, "mes-line-3");
  EXPECT_EQ(rows[1].role, "engineer");
  EXPECT_EQ(rows[1].source_address, "ipv4:10.0.0.7:4000");
  EXPECT_TRUE(rows[1].before_json.empty());
  EXPECT_EQ(rows[2].action, "WriteParameter");
  EXPECT_EQ(rows[2].result_code, static_cast<int>(absl::StatusCode::kFailedPrecondition));
  EXPECT_EQ(rows[2].result_message, "drive is moving");
  EXPECT_EQ(rows[2].before_json, R"({"value":100})");
  EXPECT_EQ(rows[2].after_json, R"({"value":300})");
  EXPECT_TRUE(VerifyOrDie().ok);
}

}  // namespace
}  // namespace drivegw::server
