// Crash safety of the drivegw process (issue 11 "Crash safety", decision 1441): SIGKILL of the
// real binary in the middle of a parameter-set apply and in the middle of heavy audited writing,
// then the same data directory is checked and the gateway restarted on it:
//  - the SQLite file passes PRAGMA integrity_check and the audit hash chain verifies;
//  - the interrupted apply is reported INTERRUPTED with the pre-image the drive had, and
//    RestoreOperation writes that pre-image back onto the (simulated) drive;
//  - every command whose reply the client received is in the audit log (acknowledged means
//    committed: AuditLog::Append returns after the commit, decision 017).
// The simulated LinMot drive lives in this test process, so it keeps its values across the
// gateway's death, as a real drive would.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "adapters/core/clock.h"
#include "drivegw/v1/parameter_sets.pb.h"
#include "google/protobuf/util/json_util.h"
#include "sim/linmot/device.h"
#include "sim/linmot/parameters.h"
#include "sim/linmot/server.h"
#include "storage/audit_log.h"
#include "storage/db.h"
#include "tests/e2e/http_client.h"
#include "tests/reliability/gateway_process.h"

namespace drivegw {
namespace {

using namespace std::chrono_literals;
using testing::Eventually;
using testing::GatewayProcess;
using testing::HttpRequest;

// The set the apply test writes: RAM parameters of the simulator that move nothing (predefined
// VAI dynamics, curve scaling, monitoring channels), each given a value unlike its default.
const std::vector<std::pair<uint16_t, int64_t>> kSet = {
    {sim::linmot::upid::kPredefVelocity, 123'000},
    {sim::linmot::upid::kPredefAcceleration, 234'000},
    {sim::linmot::upid::kPredefDeceleration, 345'000},
    {sim::linmot::upid::kPredefJerk, 456'000},
    {sim::linmot::upid::kCurveOffset, 1'234},
    {sim::linmot::upid::kCurveAmplitudeScale, 1'500},
    {sim::linmot::upid::kCurveTimeScale, 12'000},
    {sim::linmot::upid::kMonitoringChannel1, 0x1B8D},
    {sim::linmot::upid::kMonitoringChannel1 + 1, 0x1B8E},
    {sim::linmot::upid::kMonitoringChannel1 + 2, 0x1B8F},
    {sim::linmot::upid::kMonitoringChannel1 + 3, 0x1B90},
};

class CrashSafetyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/drivegw-crash-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
    sim::linmot::SimOptions so;
    so.name = "x1";
    so.bind = transport::Endpoint{transport::Endpoint::kLoopback, 0};
    so.master_port = 0;  // reply to the gateway's (ephemeral) source port
    so.stroke_min_mm = 0;
    so.stroke_max_mm = 150;
    auto sim = sim::linmot::LinMotServer::Start(so, SteadyClock::Instance());
    ASSERT_TRUE(sim.ok()) << sim.status();
    sim_ = *std::move(sim);
    config_ = dir_ + "/drivegw.yaml";
    std::ofstream out(config_);
    // A generous reply time-out: the apply test slows the simulator's replies down so that the
    // apply is still running when the process is killed; the link must not count that as loss.
    out << "listen: {grpc: \"127.0.0.1:0\", http: \"127.0.0.1:0\"}\n"
        << "data_dir: " << dir_ << "/data\n"
        << "drives:\n"
        << "  - name: x1\n"
        << "    family: linmot\n"
        << "    linudp: {host: 127.0.0.1, port: " << sim_->port()
        << ", master_port: 0, bind_host: 127.0.0.1, reply_timeout_ms: 2000}\n"
        << "    axis: {min_mm: 0, max_mm: 150, max_velocity_mm_s: 1000, "
           "max_acceleration_mm_s2: 10000}\n";
  }
  void TearDown() override {
    sim_.reset();
    if (!HasFailure()) std::filesystem::remove_all(dir_);
  }

  std::unique_ptr<GatewayProcess> Start(int& http_port) {
    auto gw = std::make_unique<GatewayProcess>(DGW_GATEWAY_BIN, config_,
                                               absl::StrCat(dir_, "/drivegw-", ++starts_, ".log"));
    http_port = gw->started() ? gw->WaitForHttpPort(60s) : 0;
    return gw;
  }

  int64_t SimValue(uint16_t upid) {
    int64_t v = 0;
    sim_->WithDevice([&](sim::linmot::LinMotDevice& d) { v = d.parameters().Get(upid); });
    return v;
  }

  std::string DbPath() const { return dir_ + "/data/drivegw.db"; }

  // Integrity and the audit chain, on the file the killed process left (opened afresh: the WAL
  // is recovered as any new connection does).
  void ExpectDatabaseSound(const std::string& when) {
    auto db = storage::Db::Open(DbPath());
    ASSERT_TRUE(db.ok()) << when << ": " << db.status();
    auto lock = db->Lock();
    auto check = db->Prepare("PRAGMA integrity_check");
    ASSERT_TRUE(check.ok()) << check.status();
    std::string result;
    while (true) {
      auto row = check->Step();
      ASSERT_TRUE(row.ok()) << row.status();
      if (!*row) break;
      absl::StrAppend(&result, result.empty() ? "" : "; ", check->ColumnText(0));
    }
    EXPECT_EQ(result, "ok") << when;
    lock = {};
    storage::AuditLog audit(*db);
    auto report = audit.Verify();
    ASSERT_TRUE(report.ok()) << when << ": " << report.status();
    EXPECT_TRUE(report->ok) << when << ": " << (report->broken ? report->broken->message : "");
    EXPECT_GT(report->verified_entries, 0) << when;
  }

  // Rows of the audit log matching `action` whose request JSON contains `needle`.
  int64_t AuditRows(const std::string& action, const std::string& needle, bool ok_only) {
    auto db = storage::Db::Open(DbPath());
    EXPECT_TRUE(db.ok()) << db.status();
    if (!db.ok()) return -1;
    auto lock = db->Lock();
    auto q = db->Prepare(absl::StrCat(
        "SELECT COUNT(*) FROM audit_log WHERE action = ?1 AND instr(request_json, ?2) > 0",
        ok_only ? " AND result_code = 0" : ""));
    if (!q.ok()) return -1;
    (void)q->Bind(1, std::string_view(action));
    (void)q->Bind(2, std::string_view(needle));
    auto row = q->Step();
    return row.ok() && *row ? q->ColumnInt64(0) : -1;
  }

  static absl::StatusOr<v1::Operation> ParseOperation(const std::string& json) {
    v1::Operation op;
    google::protobuf::util::JsonParseOptions o;
    o.ignore_unknown_fields = true;
    auto s = google::protobuf::util::JsonStringToMessage(json, &op, o);
    if (!s.ok()) return absl::InvalidArgumentError(std::string(s.message()));
    return op;
  }

  std::string dir_;
  std::string config_;
  std::unique_ptr<sim::linmot::LinMotServer> sim_;
  int starts_ = 0;
};

TEST_F(CrashSafetyTest, SigkillMidApply_InterruptedWithPreImage_RestoreWrites) {
  int http = 0;
  auto gw = Start(http);
  ASSERT_GT(http, 0) << gw->Log();

  std::string params;
  for (const auto& [upid, value] : kSet) {
    absl::StrAppend(&params, params.empty() ? "" : ",", "{\"parameter\":\"", upid,
                    "\",\"value\":", value, "}");
  }
  auto created = HttpRequest(
      http, "POST", "/v1/parameterSets",
      absl::StrCat(R"({"name":"crash","family":"linmot","parameters":[)", params, "]}"));
  ASSERT_EQ(created.status, 200) << created.body;
  std::map<uint16_t, int64_t> before;
  for (const auto& [upid, value] : kSet) {
    before[upid] = SimValue(upid);
    ASSERT_NE(before[upid], value) << "UPID " << upid << " already holds the set's value";
  }

  // Slow replies (each parameter needs a read, a write and a read back): the apply takes
  // seconds, the kill lands after its first write.
  sim_->SetReplyDelay(std::chrono::milliseconds(40));
  auto applied = HttpRequest(http, "POST", "/v1/parameterSets/crash:apply", R"({"drives":["x1"]})");
  ASSERT_EQ(applied.status, 200) << applied.body;
  auto op = ParseOperation(applied.body);
  ASSERT_TRUE(op.ok()) << op.status() << applied.body;
  const std::string op_name = op->name();
  auto changed = [&] {
    int n = 0;
    for (const auto& [upid, value] : kSet) n += SimValue(upid) == value ? 1 : 0;
    return n;
  };
  ASSERT_TRUE(Eventually([&] { return changed() >= 1; }, 60s)) << gw->Log();
  gw->Kill();
  const int written_at_kill = changed();
  ASSERT_LT(written_at_kill, static_cast<int>(kSet.size()))
      << "the apply finished before the kill; the test did not interrupt it";
  sim_->SetReplyDelay(std::chrono::milliseconds(0));
  std::cout << "killed with " << written_at_kill << " of " << kSet.size()
            << " parameters written\n";

  ExpectDatabaseSound("after SIGKILL mid-apply");

  gw = Start(http);
  ASSERT_GT(http, 0) << gw->Log();
  EXPECT_NE(gw->Log().find("apply_interrupted"), std::string::npos) << gw->Log();
  auto got = HttpRequest(http, "GET", "/v1/" + op_name);
  ASSERT_EQ(got.status, 200) << got.body;
  auto interrupted = ParseOperation(got.body);
  ASSERT_TRUE(interrupted.ok()) << got.body;
  EXPECT_EQ(interrupted->state(), "INTERRUPTED") << got.body;
  EXPECT_TRUE(interrupted->done());
  ASSERT_EQ(interrupted->drives_size(), 1);
  EXPECT_EQ(interrupted->drives(0).state(), "INTERRUPTED") << got.body;
  EXPECT_FALSE(interrupted->drives(0).error().empty());
  // The pre-image is what the drive held before the apply, every parameter of the set.
  std::map<uint16_t, int64_t> pre;
  for (const auto& v : interrupted->drives(0).pre_image())
    pre[static_cast<uint16_t>(v.id())] = v.value();
  EXPECT_EQ(pre, before) << got.body;
  // The interruption is in the audit trail, by the gateway itself.
  EXPECT_EQ(AuditRows("ApplyParameterSet.interrupted", op_name, false), 1);

  auto restore = HttpRequest(http, "POST", "/v1/" + op_name + ":restore", "{}");
  ASSERT_EQ(restore.status, 200) << restore.body;
  auto restoring = ParseOperation(restore.body);
  ASSERT_TRUE(restoring.ok()) << restore.body;
  EXPECT_EQ(restoring->restores(), op_name);
  v1::Operation final_op;
  ASSERT_TRUE(Eventually(
      [&] {
        auto r = HttpRequest(http, "GET", "/v1/" + restoring->name());
        auto p = ParseOperation(r.body);
        if (r.status != 200 || !p.ok()) return false;
        final_op = *p;
        return p->done();
      },
      60s));
  EXPECT_EQ(final_op.state(), "SUCCEEDED") << final_op.DebugString();
  for (const auto& [upid, value] : before) EXPECT_EQ(SimValue(upid), value) << "UPID " << upid;
  // A finished apply that was restored cannot be restored while the restore runs; a second
  // restore of the same operation is allowed (idempotent values) but a dry run is refused.
  auto dry = HttpRequest(http, "POST", "/v1/parameterSets/crash:apply",
                         R"({"drives":["x1"],"dry_run":true})");
  ASSERT_EQ(dry.status, 200) << dry.body;
  auto dry_op = ParseOperation(dry.body);
  ASSERT_TRUE(dry_op.ok());
  ASSERT_TRUE(Eventually(
      [&] {
        auto p = ParseOperation(HttpRequest(http, "GET", "/v1/" + dry_op->name()).body);
        return p.ok() && p->done();
      },
      60s));
  auto refused = HttpRequest(http, "POST", "/v1/" + dry_op->name() + ":restore", "{}");
  EXPECT_EQ(refused.status, 400) << refused.body;
  EXPECT_NE(refused.body.find("dry run"), std::string::npos) << refused.body;

  gw->Kill();
  ExpectDatabaseSound("after the restore");
}

TEST_F(CrashSafetyTest, SigkillDuringAuditedWrites_EveryAcknowledgedCommandIsLogged) {
  int http = 0;
  auto gw = Start(http);
  ASSERT_GT(http, 0) << gw->Log();

  // Eight clients create parameter sets as fast as they can (each create is a data commit and an
  // audit append); the gateway is killed while they run.
  constexpr int kClients = 8;
  std::mutex mu;
  std::vector<std::string> acknowledged;
  std::atomic<bool> stop{false};
  std::vector<std::thread> clients;
  for (int c = 0; c < kClients; ++c) {
    clients.emplace_back([&, c] {
      for (int i = 0; !stop.load(); ++i) {
        const std::string name = absl::StrCat("c", c, "-", i);
        auto r = HttpRequest(
            http, "POST", "/v1/parameterSets",
            absl::StrCat(R"({"name":")", name,
                         R"(","family":"linmot","parameters":[{"parameter":"5310","value":)", i,
                         "}]}"));
        if (r.status == 200) {
          std::lock_guard lock(mu);
          acknowledged.push_back(name);
        } else if (r.status == 0) {
          return;  // the gateway is gone
        }
      }
    });
  }
  const size_t kBeforeKill = 200;
  const bool busy = Eventually(
      [&] {
        std::lock_guard lock(mu);
        return acknowledged.size() >= kBeforeKill;
      },
      120s);
  gw->Kill();
  stop = true;
  for (auto& t : clients) t.join();
  ASSERT_TRUE(busy) << "only " << acknowledged.size() << " commands before the kill";
  std::cout << acknowledged.size() << " commands acknowledged before the kill\n";

  ExpectDatabaseSound("after SIGKILL during audited writes");
  for (const std::string& name : acknowledged) {
    EXPECT_EQ(AuditRows("CreateParameterSet", absl::StrCat("\"parameterSets/", name, "\""), true),
              1)
        << name << " was acknowledged but is not in the audit log exactly once";
  }

  // The gateway starts on the file and its chain continues.
  gw = Start(http);
  ASSERT_GT(http, 0) << gw->Log();
  auto again = HttpRequest(
      http, "POST", "/v1/parameterSets",
      R"({"name":"after","family":"linmot","parameters":[{"parameter":"5310","value":1}]})");
  EXPECT_EQ(again.status, 200) << again.body;
  gw->Kill();
  ExpectDatabaseSound("after the restart");
  EXPECT_EQ(AuditRows("CreateParameterSet", "\"parameterSets/after\"", true), 1);
}

}  // namespace
}  // namespace drivegw
