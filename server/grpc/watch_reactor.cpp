// WatchServing: the WatchDrives reactor between gRPC and the core's WatchStream, and the shared
// wire bytes of each snapshot.
#include "server/grpc/watch_reactor.h"

#include <utility>

#include "server/grpc/call_auth.h"
#include "server/grpc/status_mapping.h"

namespace drivegw::server {
namespace {

class WatchReactor final : public grpc::ServerWriteReactor<grpc::ByteBuffer>,
                           private WatchStream::Output {
 public:
  WatchReactor(WatchServing& serving, DriveServiceCore::OpenedWatch opened)
      : serving_(serving),
        stream_(std::make_shared<WatchStream>(std::move(opened.source),
                                              static_cast<WatchStream::Output*>(this))) {
    // The first snapshot goes out at once, as it did with a producer thread per stream; from then
    // on the shared tick of the stream's period drives it.
    if (stream_->Tick()) serving_.ticker().Add(opened.period, stream_);
  }

  void OnWriteDone(bool ok) override { stream_->WriteDone(ok); }
  void OnCancel() override { stream_->Cancel(); }
  void OnDone() override {
    stream_->Detach();  // the ticker may still hold the stream; it drops it at the next tick
    delete this;
  }

 private:
  void StartWrite(const SharedDriveStatus& s) noexcept override {
    out_ = serving_.Bytes(s);
    grpc::ServerWriteReactor<grpc::ByteBuffer>::StartWrite(&out_);
  }
  void Finish(const absl::Status& s) noexcept override {
    grpc::ServerWriteReactor<grpc::ByteBuffer>::Finish(ToGrpcStatus(s));
  }

  WatchServing& serving_;
  grpc::ByteBuffer out_;  // one write in flight at a time (WatchStream)
  std::shared_ptr<WatchStream> stream_;
};

}  // namespace

grpc::ServerWriteReactor<grpc::ByteBuffer>* WatchServing::Start(
    absl::StatusOr<DriveServiceCore::OpenedWatch> opened) {
  if (!opened.ok()) return new RefusedWriter<grpc::ByteBuffer>(opened.status());
  return new WatchReactor(*this, *std::move(opened));  // deletes itself in OnDone
}

grpc::ByteBuffer WatchServing::Bytes(const SharedDriveStatus& s) {
  {
    std::lock_guard lock(mu_);
    auto it = wire_.find(s->name());
    if (it != wire_.end() && it->second.proto == s) return it->second.bytes;
  }
  // Serialised outside the lock; a stream of another drive does not wait for it.
  const std::string bytes = s->SerializeAsString();
  grpc::Slice slice(bytes);  // one slice, even for 0 bytes: a valid, empty message
  grpc::ByteBuffer buffer(&slice, 1);
  std::lock_guard lock(mu_);
  Wire& w = wire_[s->name()];
  if (w.proto == nullptr || s->sequence() >= w.proto->sequence()) w = Wire{s, buffer};
  return buffer;
}

absl::StatusOr<v1::WatchDrivesRequest> ParseWatchRequest(const grpc::ByteBuffer& raw) {
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (raw.Dump(&slices).ok()) {
    for (const auto& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  }
  v1::WatchDrivesRequest r;
  if (!r.ParseFromString(bytes))
    return absl::InvalidArgumentError("watch_drives: the request is not a WatchDrivesRequest");
  return r;
}

}  // namespace drivegw::server
