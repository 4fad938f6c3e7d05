// MoveAbsolute through the asynchronous drive seam (decision 1301): DriveServiceCore::
// MoveAbsoluteAsync completes on the pool after the durable audit entry, refusals are audited
// without reaching the drive, and the gRPC reactor is finished from the drive's completion —
// also after the client cancelled, and through the idempotency hook when a key is sent.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "drivegw/v1/drive.grpc.pb.h"
#include "server/auth/authenticator.h"
#include "server/core/drive_service.h"
#include "server/core/idempotency.h"
#include "server/grpc/call_auth.h"
#include "server/grpc/drive_service_grpc.h"
#include "server/grpc/inline_completion.h"
#include "server/grpc/worker_pool.h"
#include "storage/audit_log.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "storage/token_repo.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::server {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

constexpr auto kWait = 10s;

// A drive whose MoveAsync holds the completion until the test releases it (as a LinUDP drive
// does until the count echo), and whose blocking Move answers at once (the idempotent path).
class HeldDrive final : public Drive {
 public:
  HeldDrive() {
    config_.name = "x1";
    config_.family = "linmot";
    config_.axis.min_mm = 0;
    config_.axis.max_mm = 100;
    config_.axis.max_velocity_mm_s = 500;
    config_.axis.max_acceleration_mm_s2 = 5000;
  }
  const DriveConfig& config() const override { return config_; }
  std::string endpoint() const override { return "held://x1"; }
  absl::Status Activate() override { return absl::OkStatus(); }
  void Deactivate() override {}
  Lifecycle lifecycle() const override { return Lifecycle::kActive; }
  absl::StatusOr<CommandInfo> Enable() override { return absl::UnimplementedError("test"); }
  absl::StatusOr<CommandInfo> Disable() override { return absl::UnimplementedError("test"); }
  absl::StatusOr<CommandInfo> Home() override { return absl::UnimplementedError("test"); }
  absl::StatusOr<CommandInfo> AcknowledgeFault() override {
    return absl::UnimplementedError("test");
  }
  absl::StatusOr<CommandInfo> Move(const MotionCommand& cmd) override {
    std::lock_guard lock(mu_);
    ++blocking_moves_;
    return Active(KindName(cmd), 100 + blocking_moves_);
  }
  void MoveAsync(const MotionCommand& cmd, Executor& blocking, CommandCompletion done) override {
    std::lock_guard lock(mu_);
    held_.push_back({cmd, &blocking, std::move(done)});
    cv_.notify_all();
  }
  absl::StatusOr<int64_t> ReadParameter(const ParameterRef&) override {
    return absl::UnimplementedError("test");
  }
  absl::Status WriteParameter(const ParameterRef&, int64_t) override {
    return absl::UnimplementedError("test");
  }
  absl::StatusOr<NativeReply> SendNative(const NativeRequest&) override {
    return absl::UnimplementedError("test");
  }
  DriveStatus GetStatus() const override { return {}; }
  std::optional<CommandInfo> GetCommand(uint64_t) const override { return std::nullopt; }
  DriveStatus WaitForStatus(uint64_t, std::chrono::steady_clock::time_point) const override {
    return {};
  }

  // Waits until MoveAsync was called `n` times in all; false after kWait.
  bool WaitHeld(size_t n) {
    std::unique_lock lock(mu_);
    return cv_.wait_for(lock, kWait, [&] { return held_.size() >= n; });
  }
  // Completes held move `i` as the drive would: on its executor, never inline.
  void Release(size_t i, absl::StatusOr<CommandInfo> result) {
    std::lock_guard lock(mu_);
    Held& h = held_.at(i);
    h.executor->Post([done = std::move(h.done), result] { done(result); });
  }
  MotionCommand held_command(size_t i) {
    std::lock_guard lock(mu_);
    return held_.at(i).cmd;
  }
  size_t held_count() {
    std::lock_guard lock(mu_);
    return held_.size();
  }
  int blocking_moves() {
    std::lock_guard lock(mu_);
    return blocking_moves_;
  }
  static CommandInfo Active(std::string kind, uint64_t id) {
    CommandInfo info;
    info.id = id;
    info.kind = std::move(kind);
    info.state = CommandState::kActive;
    return info;
  }

 private:
  struct Held {
    MotionCommand cmd;
    Executor* executor;
    CommandCompletion done;
  };
  DriveConfig config_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<Held> held_;
  int blocking_moves_ = 0;
};

v1::MoveAbsoluteRequest Request(std::string name = "drives/x1", double position = 40,
                                double velocity = 100) {
  v1::MoveAbsoluteRequest r;
  r.set_name(std::move(name));
  r.set_position_mm(position);
  r.set_velocity_mm_s(velocity);
  r.set_acceleration_mm_s2(1000);
  return r;
}

class MoveAsyncTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto db = storage::Db::Open(dir_.File("audit.db"));
    ASSERT_TRUE(db.ok()) << db.status();
    db_ = std::make_unique<storage::Db>(std::move(*db));
    ASSERT_TRUE(storage::Migrate(*db_).ok());
    audit_ = std::make_unique<storage::AuditLog>(*db_);
    drive_ = std::make_shared<HeldDrive>();
    core_ = std::make_unique<DriveServiceCore>(std::vector<std::shared_ptr<Drive>>{drive_},
                                               audit_.get());
  }
  void TearDown() override {
    if (server_) {
      server_->Shutdown(std::chrono::system_clock::now() + 2s);
      server_->Wait();
    }
    pool_.Shutdown();
  }

  // `auth` null: authentication off (CallAuth::Open()).
  void StartGrpc(const CallAuth* auth = nullptr) {
    service_ = std::make_unique<DriveServiceGrpc>(*core_, pool_, auth ? *auth : CallAuth::Open(),
                                                  &idempotency_);
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    stub_ = v1::DriveService::NewStub(grpc::CreateChannel("127.0.0.1:" + std::to_string(port_),
                                                          grpc::InsecureChannelCredentials()));
  }

  // The MoveAbsolute entries, oldest first.
  std::vector<storage::AuditRecord> MoveEntries() {
    storage::AuditQuery q;
    q.action = "MoveAbsolute";
    q.ascending = true;
    auto records = audit_->Query(q);
    EXPECT_TRUE(records.ok()) << records.status();
    return records.ok() ? *records : std::vector<storage::AuditRecord>{};
  }

  storage::testing::TempDir dir_;
  std::unique_ptr<storage::Db> db_;
  std::unique_ptr<storage::AuditLog> audit_;
  std::shared_ptr<HeldDrive> drive_;
  std::unique_ptr<DriveServiceCore> core_;
  WorkerPool pool_{2};
  IdempotencyCache idempotency_;
  std::unique_ptr<DriveServiceGrpc> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  std::unique_ptr<v1::DriveService::Stub> stub_;
};

// Collects one core completion: result, thread, and the audit entries visible at that moment.
struct CoreResult {
  std::mutex mu;
  std::condition_variable cv;
  std::optional<absl::StatusOr<v1::CommandHandle>> handle;
  std::thread::id thread;
  size_t audited_before_done = 0;
  int calls = 0;

  bool Wait() {
    std::unique_lock lock(mu);
    return cv.wait_for(lock, kWait, [&] { return handle.has_value(); });
  }
};

DriveServiceCore::HandleCompletion Collect(CoreResult& r, storage::AuditLog& audit) {
  return [&r, &audit](absl::StatusOr<v1::CommandHandle> h) {
    storage::AuditQuery q;
    q.action = "MoveAbsolute";
    auto seen = audit.Query(q);
    std::lock_guard lock(r.mu);
    r.audited_before_done = seen.ok() ? seen->size() : 0;
    r.handle = std::move(h);
    r.thread = std::this_thread::get_id();
    ++r.calls;
    r.cv.notify_all();
  };
}

TEST_F(MoveAsyncTest, Core_Accepted_HandleAfterTheDurableAuditEntryOnAPoolThread) {
  CoreResult r;
  core_->MoveAbsoluteAsync(Request(), CallContext{"alice", "operator", "ipv4:10.0.0.7:1", "grpc"},
                           pool_, Collect(r, *audit_));
  ASSERT_TRUE(drive_->WaitHeld(1));
  const MotionCommand held = drive_->held_command(0);
  const auto* cmd = std::get_if<MoveAbsolute>(&held);
  ASSERT_NE(cmd, nullptr);
  EXPECT_DOUBLE_EQ(cmd->position_mm, 40);
  EXPECT_DOUBLE_EQ(cmd->velocity_mm_s, 100);
  drive_->Release(0, HeldDrive::Active("MoveAbsolute", 7));
  ASSERT_TRUE(r.Wait());
  ASSERT_TRUE(r.handle->ok()) << r.handle->status();
  EXPECT_EQ((*r.handle)->name(), "drives/x1/commands/7");
  EXPECT_EQ((*r.handle)->state(), v1::ACTIVE);
  EXPECT_EQ(r.audited_before_done, 1u);  // durable before the reply may leave (decision 017)
  EXPECT_NE(r.thread, std::this_thread::get_id());
  const auto entries = MoveEntries();
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].principal, "alice");
  EXPECT_EQ(entries[0].drive, "x1");
  EXPECT_EQ(entries[0].result_code, 0);
  EXPECT_THAT(entries[0].request_json, HasSubstr("\"position_mm\":40"));
}

TEST_F(MoveAsyncTest, Core_DriveError_SameStatusAuditedWithItsCode) {
  CoreResult r;
  core_->MoveAbsoluteAsync(Request(), CallContext{}, pool_, Collect(r, *audit_));
  ASSERT_TRUE(drive_->WaitHeld(1));
  drive_->Release(0, absl::DeadlineExceededError("drive 'x1': MoveAbsolute: not accepted"));
  ASSERT_TRUE(r.Wait());
  EXPECT_EQ(r.handle->status().code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_EQ(r.audited_before_done, 1u);
  const auto entries = MoveEntries();
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].result_code, static_cast<int>(absl::StatusCode::kDeadlineExceeded));
}

TEST_F(MoveAsyncTest, Core_Refusals_AuditedOnThePoolAndNeverReachTheDrive) {
  struct Case {
    v1::MoveAbsoluteRequest request;
    absl::StatusCode code;
    const char* text;
  };
  const std::vector<Case> cases = {
      {Request("drives/nope"), absl::StatusCode::kNotFound, "is not configured"},
      {Request("drives/x1", 40, 900), absl::StatusCode::kOutOfRange, "velocity_mm_s"},
      {Request("drives/x1", 400), absl::StatusCode::kOutOfRange, "position_mm"},
  };
  for (const Case& c : cases) {
    CoreResult r;
    core_->MoveAbsoluteAsync(c.request, CallContext{}, pool_, Collect(r, *audit_));
    ASSERT_TRUE(r.Wait());
    EXPECT_EQ(r.handle->status().code(), c.code) << r.handle->status();
    EXPECT_THAT(r.handle->status().message(), HasSubstr(c.text));
    EXPECT_NE(r.thread, std::this_thread::get_id());
  }
  EXPECT_EQ(drive_->held_count(), 0u);
  EXPECT_EQ(MoveEntries().size(), cases.size());
}

TEST_F(MoveAsyncTest, Grpc_FinishedFromTheCompletion_HandleAndErrorsMapped) {
  StartGrpc();
  std::thread releaser([&] {
    ASSERT_TRUE(drive_->WaitHeld(1));
    drive_->Release(0, HeldDrive::Active("MoveAbsolute", 3));
    ASSERT_TRUE(drive_->WaitHeld(2));
    drive_->Release(1, absl::UnavailableError("drive 'x1': MoveAbsolute: link lost"));
  });
  {
    grpc::ClientContext ctx;
    v1::CommandHandle h;
    grpc::Status s = stub_->MoveAbsolute(&ctx, Request(), &h);
    ASSERT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(h.name(), "drives/x1/commands/3");
    EXPECT_EQ(h.state(), v1::ACTIVE);
  }
  {
    grpc::ClientContext ctx;
    v1::CommandHandle h;
    grpc::Status s = stub_->MoveAbsolute(&ctx, Request(), &h);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAVAILABLE);
    EXPECT_THAT(s.error_message(), HasSubstr("link lost"));
  }
  releaser.join();
  EXPECT_EQ(MoveEntries().size(), 2u);
}

TEST_F(MoveAsyncTest, Grpc_ClientCancelsWhileTheDriveHoldsTheMove_ServerFinishesAndAudits) {
  StartGrpc();
  grpc::ClientContext ctx;
  v1::CommandHandle h;
  std::mutex mu;
  std::condition_variable cv;
  std::optional<grpc::Status> client;
  const v1::MoveAbsoluteRequest request = Request();
  stub_->async()->MoveAbsolute(&ctx, &request, &h, [&](grpc::Status s) {
    std::lock_guard lock(mu);
    client = std::move(s);
    cv.notify_all();
  });
  ASSERT_TRUE(drive_->WaitHeld(1));
  ctx.TryCancel();
  {
    std::unique_lock lock(mu);
    ASSERT_TRUE(cv.wait_for(lock, kWait, [&] { return client.has_value(); }));
    EXPECT_EQ(client->error_code(), grpc::StatusCode::CANCELLED);
  }
  // The drive accepted the move anyway (the command left): the completion still finishes the
  // reactor (gRPC drops the reply) and the audit entry records what happened.
  drive_->Release(0, HeldDrive::Active("MoveAbsolute", 5));
  for (auto until = std::chrono::steady_clock::now() + kWait;
       MoveEntries().empty() && std::chrono::steady_clock::now() < until;) {
    audit_->WaitForAppend(0, std::chrono::steady_clock::now() + 100ms);
  }
  const auto entries = MoveEntries();
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].result_code, 0);
  // The server goes on serving.
  std::thread releaser([&] {
    ASSERT_TRUE(drive_->WaitHeld(2));
    drive_->Release(1, HeldDrive::Active("MoveAbsolute", 6));
  });
  grpc::ClientContext ctx2;
  grpc::Status s = stub_->MoveAbsolute(&ctx2, Request(), &h);
  releaser.join();
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(h.name(), "drives/x1/commands/6");
}

TEST_F(MoveAsyncTest, Grpc_BearerToken_CheckedOnThePoolThenCompletedThere) {
  storage::TokenRepo tokens(*db_);
  auto op = tokens.Create("mes-line-3", "operator");
  ASSERT_TRUE(op.ok()) << op.status();
  auth::AuthOptions o;
  o.enabled = true;
  auth::Authenticator authenticator(o, &tokens);
  CallAuth call_auth(authenticator, audit_.get());
  StartGrpc(&call_auth);
  std::thread releaser([&] {
    ASSERT_TRUE(drive_->WaitHeld(1));
    drive_->Release(0, HeldDrive::Active("MoveAbsolute", 9));
  });
  grpc::ClientContext ctx;
  ctx.AddMetadata("authorization", "Bearer " + op->token);
  ctx.set_deadline(std::chrono::system_clock::now() + kWait);
  v1::CommandHandle h;
  grpc::Status s = stub_->MoveAbsolute(&ctx, Request(), &h);
  releaser.join();
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(h.name(), "drives/x1/commands/9");
  const auto entries = MoveEntries();
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].principal, "mes-line-3");
  // The server must stop before the token store and CallAuth above go away.
  server_->Shutdown(std::chrono::system_clock::now() + 2s);
  server_->Wait();
  server_.reset();
}

TEST_F(MoveAsyncTest, Grpc_IdempotencyKey_KeepsTheBlockingPathAndRunsOnce) {
  StartGrpc();
  for (int i = 0; i < 2; ++i) {
    grpc::ClientContext ctx;
    ctx.AddMetadata("idempotency-key", "k-1");
    v1::CommandHandle h;
    grpc::Status s = stub_->MoveAbsolute(&ctx, Request(), &h);
    ASSERT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(h.name(), "drives/x1/commands/101");  // the first call's handle both times
  }
  EXPECT_EQ(drive_->blocking_moves(), 1);
  EXPECT_EQ(drive_->held_count(), 0u);
  EXPECT_EQ(MoveEntries().size(), 1u);
}

// Records the thread every task it is given runs on (runs them at once, on the poster's thread).
class RecordingExecutor final : public Executor {
 public:
  void Post(std::function<void()> task) override {
    ++posted;
    task();
  }
  int posted = 0;
};

TEST(InlineCompletion, PostedByAnotherThreadBeforeOrDuringTheWait_RunsOnTheOwner) {
  RecordingExecutor fallback;
  for (bool before_wait : {true, false}) {
    InlineCompletion inline_completion(fallback);
    std::thread::id ran_on;
    std::thread poster(
        [&] { inline_completion.Post([&] { ran_on = std::this_thread::get_id(); }); });
    if (before_wait) poster.join();
    inline_completion.WaitAndRun(std::chrono::duration_cast<std::chrono::microseconds>(kWait));
    if (!before_wait) poster.join();
    EXPECT_EQ(ran_on, std::this_thread::get_id()) << "before_wait=" << before_wait;
  }
  EXPECT_EQ(fallback.posted, 0);
}

TEST(InlineCompletion, PostedByTheOwnerOrAfterTheWait_GoesToTheFallback) {
  RecordingExecutor fallback;
  InlineCompletion inline_completion(fallback);
  int ran = 0;
  inline_completion.Post([&] { ++ran; });  // a family's blocking fallback, from inside MoveAsync
  EXPECT_EQ(fallback.posted, 1);
  inline_completion.WaitAndRun(std::chrono::microseconds(200));       // nothing comes: times out
  std::thread late([&] { inline_completion.Post([&] { ++ran; }); });  // the late completion
  late.join();
  EXPECT_EQ(fallback.posted, 2);
  EXPECT_EQ(ran, 2);
}

}  // namespace
}  // namespace drivegw::server
