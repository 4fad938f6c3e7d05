// One StreamCyclicSetpoints call on the core side: the drive's running cyclic command
// (Drive::CyclicStream), the checks of every later message, the close and the summary, and the
// stream's one audit entry (docs/decisions/008-cyclic-setpoint-stream.md). The gRPC reactor
// drives it; DriveServiceCore::StartCyclicSetpoints creates it.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/drive.h"
#include "drivegw/v1/drive.pb.h"
#include "server/core/call_context.h"

namespace drivegw::storage {
class AuditLog;
}

namespace drivegw::server {

// Payload type URL of the summary an ended-with-error stream carries (google.rpc.Status details).
inline constexpr std::string_view kCyclicSummaryUrl =
    "type.googleapis.com/drivegw.v1.CyclicStreamSummary";

// Audit action of the stream.
inline constexpr char kCyclicAuditAction[] = "StreamCyclicSetpoints";

// Not thread-safe: one caller at a time (the reactor has at most one read in flight and calls
// End after the last Next returned).
class CyclicSetpointStream {
 public:
  CyclicSetpointStream(Drive& drive, CyclicMode mode, std::unique_ptr<Drive::CyclicStream> stream,
                       v1::CyclicSetpointRequest first, CallContext context,
                       storage::AuditLog* audit, const std::atomic<bool>& shutting_down);
  // Ends a stream nobody ended (as CANCELLED), so the command is closed and audited once.
  ~CyclicSetpointStream();
  CyclicSetpointStream(const CyclicSetpointStream&) = delete;
  CyclicSetpointStream& operator=(const CyclicSetpointStream&) = delete;

  // Checks one message after the first (same drive and mode if given, a set point present and
  // valid for the axis) and queues its set point. Never blocks (Drive::CyclicStream::Push only
  // queues), so it may run on a gRPC callback thread. An error does not close the command: the
  // caller passes it to End.
  absl::Status Next(const v1::CyclicSetpointRequest& m);
  // Queues a checked set point (the first message's one); see Next.
  absl::Status PushSetpoint(const v1::CyclicSetpoint& p);

  // Closes the cyclic command (BLOCKS until the drive confirmed; the axis stops with its limits),
  // writes the audit entry and returns the summary; with a non-OK `reason`, returns `reason` with
  // the summary attached as a kCyclicSummaryUrl payload. A failing close turns an OK reason into
  // the close's error. Call once; later calls return FailedPrecondition.
  absl::StatusOr<v1::CyclicStreamSummary> End(absl::Status reason);

  // Set points accepted so far (the index the next one gets in "setpoints[i]").
  uint64_t accepted() const { return accepted_; }

 private:
  Drive& drive_;
  const CyclicMode mode_;
  std::unique_ptr<Drive::CyclicStream> stream_;
  const v1::CyclicSetpointRequest first_;
  const CallContext context_;
  storage::AuditLog* const audit_;
  const std::atomic<bool>& shutting_down_;
  uint64_t accepted_ = 0;
  bool ended_ = false;
};

// {"start": <first message>} or {"start": ..., "summary": ...}: the stream's audit request.
std::string CyclicAuditJson(const v1::CyclicSetpointRequest& first,
                            const v1::CyclicStreamSummary* summary);

}  // namespace drivegw::server
