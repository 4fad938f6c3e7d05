// A fake drivegw.v1.DriveService on a real grpc::Server (127.0.0.1:0) for the REST tests: a
// few methods with fixed answers, one that fails with google.rpc.BadRequest details, a
// streaming WatchDrives, and a unary call that hangs until cancelled.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "drivegw/v1/drive.grpc.pb.h"

namespace drivegw::rest::test_support {

// Behaviour keyed by request fields:
//  GetDrive        "drives/x1", "drives/x2" exist; other names: NOT_FOUND.
//  MoveAbsolute    velocity_mm_s > 1000: INVALID_ARGUMENT with a google.rpc.BadRequest
//                  naming move_absolute.velocity_mm_s; else a BUSY CommandHandle.
//  Read/WriteParameter  echo the request as a Parameter.
//  WatchDrives     names contains "missing": NOT_FOUND before any message; "forever": statuses
//                  until cancelled (paced by flow control); else three statuses per name, then OK.
//  Home            hangs until the call is cancelled (deadline or client).
//  Disable, ...    not implemented (UNIMPLEMENTED).
class FakeDriveService final : public drivegw::v1::DriveService::CallbackService {
 public:
  grpc::ServerUnaryReactor* ListDrives(grpc::CallbackServerContext* ctx,
                                       const drivegw::v1::ListDrivesRequest* request,
                                       drivegw::v1::ListDrivesResponse* response) override;
  grpc::ServerUnaryReactor* GetDrive(grpc::CallbackServerContext* ctx,
                                     const drivegw::v1::GetDriveRequest* request,
                                     drivegw::v1::Drive* response) override;
  grpc::ServerUnaryReactor* MoveAbsolute(grpc::CallbackServerContext* ctx,
                                         const drivegw::v1::MoveAbsoluteRequest* request,
                                         drivegw::v1::CommandHandle* response) override;
  grpc::ServerUnaryReactor* ReadParameter(grpc::CallbackServerContext* ctx,
                                          const drivegw::v1::ReadParameterRequest* request,
                                          drivegw::v1::Parameter* response) override;
  grpc::ServerUnaryReactor* WriteParameter(grpc::CallbackServerContext* ctx,
                                           const drivegw::v1::WriteParameterRequest* request,
                                           drivegw::v1::Parameter* response) override;
  grpc::ServerUnaryReactor* Home(grpc::CallbackServerContext* ctx,
                                 const drivegw::v1::HomeRequest* request,
                                 drivegw::v1::CommandHandle* response) override;
  grpc::ServerWriteReactor<drivegw::v1::DriveStatus>* WatchDrives(
      grpc::CallbackServerContext* ctx, const drivegw::v1::WatchDrivesRequest* request) override;

  // What the last call saw (metadata x-drivegw-source / x-drivegw-transport, requests).
  struct Seen {
    std::string source, transport, method;
    drivegw::v1::MoveAbsoluteRequest move;
    drivegw::v1::WatchDrivesRequest watch;
    drivegw::v1::WriteParameterRequest write;
    int watch_cancelled = 0;  // WatchDrives calls that ended by cancellation
    int watch_active = 0;
    int home_cancelled = 0;
  };
  Seen seen();
  // Waits until `pred(seen)` holds; false after `timeout`.
  template <typename Pred>
  bool WaitFor(Pred pred, std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    std::unique_lock lock(mu_);
    return cv_.wait_for(lock, timeout, [&] { return pred(seen_); });
  }

  // Internal: updates `seen` under the lock and wakes waiters.
  template <typename F>
  void Update(F f) {
    {
      std::lock_guard lock(mu_);
      f(seen_);
    }
    cv_.notify_all();
  }

 private:
  void Record(grpc::CallbackServerContext* ctx, std::string method);

  std::mutex mu_;
  std::condition_variable cv_;
  Seen seen_;
};

// The fake on a real server bound to 127.0.0.1:0, with the default health service.
class FakeGrpcServer {
 public:
  FakeGrpcServer();
  ~FakeGrpcServer();
  std::shared_ptr<grpc::Channel> InProcessChannel();
  FakeDriveService& service() { return service_; }
  void Shutdown();

 private:
  FakeDriveService service_;
  std::unique_ptr<grpc::Server> server_;
  bool shut_down_ = false;
};

}  // namespace drivegw::rest::test_support
