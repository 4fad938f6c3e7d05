// CyclicSetpointReactor: one read at a time. The first message starts the drive's cyclic command
// and every End closes it — both block on the drive, so they run on the worker pool; the set
// points of later messages are checked and queued on the callback thread (Push never blocks,
// adapters/core/drive.h), so a busy pool cannot make them late.
#include "server/grpc/cyclic_reactor.h"

#include <memory>
#include <utility>

#include "server/core/errors.h"
#include "server/grpc/status_mapping.h"

namespace drivegw::server {
namespace {

class CyclicSetpointReactor final : public grpc::ServerReadReactor<v1::CyclicSetpointRequest> {
 public:
  CyclicSetpointReactor(DriveServiceCore& core, WorkerPool& pool, grpc::CallbackServerContext* ctx,
                        v1::CyclicStreamSummary* response, CallContext cc)
      : core_(core), pool_(pool), ctx_(ctx), response_(response), cc_(std::move(cc)) {
    StartRead(&message_);
  }

  void OnReadDone(bool ok) override {
    if (!ok) {
      // The client half-closed, or the call was cancelled (client gone, deadline, shutdown).
      if (stream_ == nullptr) {
        Finish(ToGrpcStatus(FieldError(
            "name", "is required: the stream ended before its first message (name, mode)")));
        return;
      }
      End(ctx_->IsCancelled() ? absl::CancelledError("the call was cancelled") : absl::OkStatus());
      return;
    }
    if (stream_ == nullptr) {
      pool_.Post([this, first = message_] {
        auto started = core_.StartCyclicSetpoints(first, cc_);
        if (!started.ok()) {
          Finish(ToGrpcStatus(started.status()));  // nothing of `this` is touched after Finish
          return;
        }
        stream_ = *std::move(started);
        StartRead(&message_);
      });
      return;
    }
    if (absl::Status s = stream_->Next(message_); !s.ok()) {
      End(std::move(s));
      return;
    }
    StartRead(&message_);
  }

  void OnDone() override { delete this; }

 private:
  // Closes the cyclic command on the pool and finishes with the summary (or `reason` carrying it).
  void End(absl::Status reason) {
    pool_.Post([this, reason = std::move(reason)] {
      auto summary = stream_->End(reason);
      stream_.reset();
      if (summary.ok()) *response_ = *std::move(summary);
      Finish(ToGrpcStatus(summary.status()));
    });
  }

  DriveServiceCore& core_;
  WorkerPool& pool_;
  grpc::CallbackServerContext* const ctx_;
  v1::CyclicStreamSummary* const response_;
  const CallContext cc_;
  v1::CyclicSetpointRequest message_;
  std::unique_ptr<CyclicSetpointStream> stream_;
};

}  // namespace

grpc::ServerReadReactor<v1::CyclicSetpointRequest>* NewCyclicSetpointReactor(
    DriveServiceCore& core, WorkerPool& pool, grpc::CallbackServerContext* ctx,
    v1::CyclicStreamSummary* response, CallContext cc) {
  // Raw new: the callback API hands ownership to gRPC until OnDone deletes the reactor.
  return new CyclicSetpointReactor(core, pool, ctx, response, std::move(cc));
}

}  // namespace drivegw::server
