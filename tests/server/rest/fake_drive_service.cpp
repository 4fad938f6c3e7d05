// The fake DriveService used by the REST tests (see fake_drive_service.h for its behaviour).
#include "tests/server/rest/fake_drive_service.h"

#include <algorithm>
#include <atomic>

#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"

namespace drivegw::rest::test_support {
namespace v1 = drivegw::v1;

namespace {

std::string Metadata(grpc::CallbackServerContext* ctx, const std::string& key) {
  const auto& md = ctx->client_metadata();
  auto it = md.find(key);
  return it == md.end() ? std::string() : std::string(it->second.data(), it->second.size());
}

grpc::ServerUnaryReactor* FinishWith(grpc::CallbackServerContext* ctx, grpc::Status status) {
  auto* reactor = ctx->DefaultReactor();
  reactor->Finish(std::move(status));
  return reactor;
}

v1::DriveStatus MakeStatus(const std::string& name, uint64_t sequence) {
  v1::DriveStatus s;
  s.set_name(name);
  s.set_state(v1::ENABLED);
  s.set_position_mm(10.5 + static_cast<double>(sequence));
  s.set_sequence(sequence);
  return s;
}

// Hangs until the call is cancelled (a deadline, TryCancel, or server shutdown).
class HangReactor final : public grpc::ServerUnaryReactor {
 public:
  explicit HangReactor(FakeDriveService* service) : service_(service) {}
  void OnCancel() override {
    service_->Update([](FakeDriveService::Seen& s) { ++s.home_cancelled; });
    Finish(grpc::Status::CANCELLED);
  }
  void OnDone() override { delete this; }

 private:
  FakeDriveService* service_;
};

class WatchReactor final : public grpc::ServerWriteReactor<v1::DriveStatus> {
 public:
  WatchReactor(FakeDriveService* service, const v1::WatchDrivesRequest& request)
      : service_(service) {
    for (const auto& n : request.names()) names_.push_back(n);
    if (names_.empty()) names_.push_back("x1");
    forever_ = std::find(names_.begin(), names_.end(), "forever") != names_.end();
    service_->Update([](FakeDriveService::Seen& s) { ++s.watch_active; });
    if (std::find(names_.begin(), names_.end(), "missing") != names_.end()) {
      FinishOnce(grpc::Status(grpc::StatusCode::NOT_FOUND, "drive 'missing' not found"));
      return;
    }
    SendNext();
  }

  void OnWriteDone(bool ok) override {
    if (!ok) return FinishOnce(grpc::Status::CANCELLED);
    // "forever" is paced by flow control alone: the REST side reads one message at a time.
    if (!forever_ && sent_ >= 3 * names_.size()) return FinishOnce(grpc::Status::OK);
    SendNext();
  }

  void OnCancel() override {
    service_->Update([](FakeDriveService::Seen& s) { ++s.watch_cancelled; });
    FinishOnce(grpc::Status::CANCELLED);
  }

  void OnDone() override {
    service_->Update([](FakeDriveService::Seen& s) { --s.watch_active; });
    delete this;
  }

 private:
  void SendNext() {
    std::lock_guard lock(mu_);
    if (finished_) return;
    status_ = MakeStatus("drives/" + names_[sent_ % names_.size()], sent_);
    ++sent_;
    StartWrite(&status_);
  }
  void FinishOnce(grpc::Status s) {
    std::lock_guard lock(mu_);
    if (finished_) return;
    finished_ = true;
    Finish(std::move(s));
  }

  FakeDriveService* service_;
  std::vector<std::string> names_;
  bool forever_ = false;
  size_t sent_ = 0;
  v1::DriveStatus status_;
  std::recursive_mutex mu_;  // StartWrite/Finish may complete inline
  bool finished_ = false;
};

}  // namespace

FakeDriveService::Seen FakeDriveService::seen() {
  std::lock_guard lock(mu_);
  return seen_;
}

void FakeDriveService::Record(grpc::CallbackServerContext* ctx, std::string method) {
  Update([&](Seen& s) {
    s.source = Metadata(ctx, "x-drivegw-source");
    s.transport = Metadata(ctx, "x-drivegw-transport");
    s.method = std::move(method);
  });
}

grpc::ServerUnaryReactor* FakeDriveService::ListDrives(grpc::CallbackServerContext* ctx,
                                                       const v1::ListDrivesRequest*,
                                                       v1::ListDrivesResponse* response) {
  Record(ctx, "ListDrives");
  for (const char* name : {"drives/x1", "drives/x2"}) {
    auto* d = response->add_drives();
    d->set_name(name);
    d->set_family("linmot");
    d->mutable_axis()->set_kind(v1::LINEAR);
    d->mutable_axis()->set_max_mm(100);
  }
  return FinishWith(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor* FakeDriveService::GetDrive(grpc::CallbackServerContext* ctx,
                                                     const v1::GetDriveRequest* request,
                                                     v1::Drive* response) {
  Record(ctx, "GetDrive");
  if (request->name() != "drives/x1" && request->name() != "drives/x2") {
    return FinishWith(ctx, grpc::Status(grpc::StatusCode::NOT_FOUND,
                                        "drive '" + request->name() + "' not found"));
  }
  response->set_name(request->name());
  response->set_family("linmot");
  *response->mutable_status() = MakeStatus(request->name(), 7);
  return FinishWith(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor* FakeDriveService::MoveAbsolute(grpc::CallbackServerContext* ctx,
                                                         const v1::MoveAbsoluteRequest* request,
                                                         v1::CommandHandle* response) {
  Record(ctx, "MoveAbsolute");
  Update([&](Seen& s) { s.move = *request; });
  if (request->velocity_mm_s() > 1000) {
    // As the service core does (STYLE.md §4): details ride in a google.rpc.Status.
    google::rpc::BadRequest bad;
    auto* v = bad.add_field_violations();
    v->set_field("move_absolute.velocity_mm_s");
    v->set_description("exceeds axis limit 1000");
    google::rpc::Status rich;
    rich.set_code(grpc::StatusCode::INVALID_ARGUMENT);
    rich.set_message("move_absolute.velocity_mm_s: " + std::to_string(request->velocity_mm_s()) +
                     " exceeds axis limit 1000");
    rich.add_details()->PackFrom(bad);
    return FinishWith(ctx, grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, rich.message(),
                                        rich.SerializeAsString()));
  }
  response->set_name(request->name() + "/commands/1");
  response->set_kind("MoveAbsolute");
  response->set_state(v1::BUSY);
  return FinishWith(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor* FakeDriveService::ReadParameter(grpc::CallbackServerContext* ctx,
                                                          const v1::ReadParameterRequest* request,
                                                          v1::Parameter* response) {
  Record(ctx, "ReadParameter");
  response->set_name(request->name());
  response->set_parameter_id(request->parameter_id());
  response->set_rom(request->rom());
  response->set_value(-42);
  return FinishWith(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor* FakeDriveService::WriteParameter(grpc::CallbackServerContext* ctx,
                                                           const v1::WriteParameterRequest* request,
                                                           v1::Parameter* response) {
  Record(ctx, "WriteParameter");
  Update([&](Seen& s) { s.write = *request; });
  response->set_name(request->name());
  response->set_parameter_id(request->parameter_id());
  response->set_value(request->value());
  response->set_rom(request->rom());
  return FinishWith(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor* FakeDriveService::Home(grpc::CallbackServerContext* ctx,
                                                 const v1::HomeRequest*, v1::CommandHandle*) {
  Record(ctx, "Home");
  return new HangReactor(this);
}

grpc::ServerWriteReactor<v1::DriveStatus>* FakeDriveService::WatchDrives(
    grpc::CallbackServerContext* ctx, const v1::WatchDrivesRequest* request) {
  Record(ctx, "WatchDrives");
  Update([&](Seen& s) { s.watch = *request; });
  return new WatchReactor(this, *request);
}

FakeGrpcServer::FakeGrpcServer() {
  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service_);
  server_ = builder.BuildAndStart();
}

FakeGrpcServer::~FakeGrpcServer() { Shutdown(); }

std::shared_ptr<grpc::Channel> FakeGrpcServer::InProcessChannel() {
  return server_->InProcessChannel(grpc::ChannelArguments());
}

void FakeGrpcServer::Shutdown() {
  if (server_ && !shut_down_) {
    shut_down_ = true;
    server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
    server_->Wait();
  }
}

}  // namespace drivegw::rest::test_support
