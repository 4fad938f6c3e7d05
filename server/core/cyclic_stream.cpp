// CyclicSetpointStream: later messages, close, summary and audit of a cyclic set-point stream.
#include "server/core/cyclic_stream.h"

#include <utility>

#include "absl/strings/cord.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/core/audit.h"
#include "server/core/convert.h"
#include "server/core/cyclic_validation.h"
#include "server/core/errors.h"
#include "server/ops/metrics.h"

namespace drivegw::server {
namespace {

v1::CyclicStats ToProto(const CyclicStats& s) {
  v1::CyclicStats p;
  p.set_received(s.received);
  p.set_sent(s.sent);
  p.set_late(s.late);
  p.set_missing(s.missing);
  p.set_cycle_us(static_cast<uint32_t>(s.cycle.count()));
  return p;
}

// "drives/x1" and "x1" name the same drive.
absl::string_view DriveId(absl::string_view name) {
  if (absl::StartsWith(name, "drives/")) name.remove_prefix(7);
  return name;
}

}  // namespace

std::string CyclicAuditJson(const v1::CyclicSetpointRequest& first,
                            const v1::CyclicStreamSummary* summary) {
  std::string out = absl::StrCat("{\"start\":", ToAuditJson(first));
  if (summary != nullptr) absl::StrAppend(&out, ",\"summary\":", ToAuditJson(*summary));
  out += "}";
  return out;
}

CyclicSetpointStream::CyclicSetpointStream(Drive& drive, CyclicMode mode,
                                           std::unique_ptr<Drive::CyclicStream> stream,
                                           v1::CyclicSetpointRequest first, CallContext context,
                                           storage::AuditLog* audit,
                                           const std::atomic<bool>& shutting_down)
    : drive_(drive),
      mode_(mode),
      stream_(std::move(stream)),
      first_(std::move(first)),
      context_(std::move(context)),
      audit_(audit),
      shutting_down_(shutting_down) {}

CyclicSetpointStream::~CyclicSetpointStream() {
  if (!ended_) (void)End(absl::CancelledError("the stream ended without a close"));
}

absl::Status CyclicSetpointStream::Next(const v1::CyclicSetpointRequest& m) {
  if (shutting_down_.load()) {
    return absl::UnavailableError("the gateway is shutting down; the cyclic command was closed");
  }
  // Later messages may repeat the first one's drive and mode, never change them.
  if (!m.name().empty() && DriveId(m.name()) != drive_.config().name) {
    return FieldError("name", absl::StrCat("'", m.name(), "' differs from the stream's drive ",
                                           DriveResourceName(drive_.config().name),
                                           "; only the first message chooses the drive"));
  }
  if (m.mode() != v1::CYCLIC_MODE_UNSPECIFIED && m.mode() != first_.mode()) {
    return FieldError(
        "mode", absl::StrCat(v1::CyclicMode_Name(m.mode()), " differs from the stream's mode ",
                             v1::CyclicMode_Name(first_.mode()),
                             "; only the first message chooses the mode"));
  }
  if (!m.has_setpoint()) {
    return FieldError(absl::StrCat("setpoints[", accepted_, "]"),
                      "is missing; every message after the first carries a set point");
  }
  return PushSetpoint(m.setpoint());
}

absl::Status CyclicSetpointStream::PushSetpoint(const v1::CyclicSetpoint& p) {
  auto sp = ValidateCyclicSetpoint(p, mode_, drive_.config().axis, accepted_);
  if (!sp.ok()) return sp.status();
  if (auto s = stream_->Push(*sp); !s.ok()) return s;
  ++accepted_;
  return absl::OkStatus();
}

absl::StatusOr<v1::CyclicStreamSummary> CyclicSetpointStream::End(absl::Status reason) {
  if (ended_) return absl::FailedPreconditionError("the cyclic stream has already ended");
  ended_ = true;
  const std::string& name = drive_.config().name;
  absl::StatusOr<CommandInfo> closed = stream_->Close();
  if (!closed.ok() && reason.ok()) reason = closed.status();
  v1::CyclicStreamSummary summary;
  summary.set_name(DriveResourceName(name));
  *summary.mutable_command() = ToProto(name, closed.ok() ? *closed : stream_->command());
  *summary.mutable_stats() = ToProto(stream_->stats());
  const CyclicStats st = stream_->stats();  // /metrics: cycle lateness (decision 021)
  ops::ObserveCyclicStream(name, drive_.config().family, st.late, st.missing, st.sent);
  summary.set_state(ToProto(drive_.GetStatus().state));
  WriteAudit(audit_, context_, name, kCyclicAuditAction, CyclicAuditJson(first_, &summary), reason);
  if (reason.ok()) return summary;
  reason.SetPayload(absl::string_view(kCyclicSummaryUrl.data(), kCyclicSummaryUrl.size()),
                    absl::Cord(summary.SerializeAsString()));
  return reason;
}

}  // namespace drivegw::server
