// WatchDrives on gRPC (issue 10, P5; decision 1341): every stream of a service is ticked by one
// shared WatchTicker and writes pre-serialised bytes (a raw ByteBuffer method), serialised once
// per snapshot for all streams instead of once per stream and message.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "absl/status/statusor.h"
#include "grpcpp/grpcpp.h"
#include "server/core/drive_service.h"
#include "server/core/watch_stream.h"
#include "server/core/watch_ticker.h"

namespace drivegw::server {

class WatchServing {
 public:
  explicit WatchServing(size_t ticker_threads = WatchTicker::DefaultThreads())
      : ticker_(ticker_threads) {}

  // The reactor of a stream `opened` (or, when it is an error, one that finishes with it at once).
  // It writes the first snapshot now and joins the ticker; it deletes itself in OnDone.
  grpc::ServerWriteReactor<grpc::ByteBuffer>* Start(
      absl::StatusOr<DriveServiceCore::OpenedWatch> opened);

  // The wire bytes of `s`, serialised once per snapshot (per drive name, newest sequence kept).
  // Never a default ByteBuffer: that would mean "no message", and an empty DriveStatus is a
  // message of 0 bytes.
  grpc::ByteBuffer Bytes(const SharedDriveStatus& s);

  WatchTicker& ticker() { return ticker_; }

 private:
  struct Wire {
    SharedDriveStatus proto;  // keeps the key's address from being reused
    grpc::ByteBuffer bytes;
  };
  std::mutex mu_;
  std::unordered_map<std::string, Wire> wire_;  // by drive name
  WatchTicker ticker_;  // last: its threads stop before the cache they use goes away
};

// The request of a raw WatchDrives call; InvalidArgument when the bytes do not parse.
absl::StatusOr<v1::WatchDrivesRequest> ParseWatchRequest(const grpc::ByteBuffer& raw);

}  // namespace drivegw::server
