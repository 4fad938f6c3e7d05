// CanopenMaster SDO client: one transfer per node at a time, the others queued in call order
// (CiA 301 v4.2.0 §7.2.4.1: one SDO channel per client/server pair; decision 1112), per-exchange
// time-outs with abort 0504 0000h (decision 1103), bounded retry of idempotent transfers
// (decision 1481), typed helpers and PDO configuration.
#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "adapters/canopen/cob_id.h"
#include "adapters/canopen/master.h"
#include "adapters/canopen/status_util.h"
#include "adapters/core/log.h"
#include "adapters/core/wire_observer.h"

namespace drivegw::canopen {
namespace {

int64_t Ms(Duration d) { return std::chrono::duration_cast<std::chrono::milliseconds>(d).count(); }

std::string Describe(const SdoClientTransfer& t, uint8_t node) {
  return absl::StrFormat("sdo %s 0x%04X:%02X node %d",
                         t.kind() == SdoTransferKind::kUpload ? "upload" : "download", t.index(),
                         t.sub(), node);
}

std::pair<uint16_t, uint8_t> ObjectOf(const SdoClientTransfer& t) { return {t.index(), t.sub()}; }

std::vector<uint8_t> LittleEndian(uint64_t value, size_t bytes) {
  std::vector<uint8_t> out(bytes);
  for (size_t i = 0; i < bytes; ++i) out[i] = static_cast<uint8_t>(value >> (8 * i));
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Queue.

std::string CanopenMaster::SdoRequest::context() const { return Describe(transfer, node); }

absl::StatusOr<std::vector<uint8_t>> CanopenMaster::Transfer(uint8_t node,
                                                             SdoClientTransfer transfer,
                                                             TimePoint deadline, bool retriable) {
  // The "sdo upload 0x6041:00 node 5" context is formatted only for an error: formatting costs
  // about a microsecond, on the path from one answer to the next request (decision 1321).
  if (OnReceiveThread()) {
    return absl::FailedPreconditionError(
        absl::StrCat(Describe(transfer, node), ": called on the receive thread of ", bus_name_,
                     " (from a NodeObserver callback), which delivers the answer"));
  }
  auto request = std::make_shared<SdoRequest>(std::move(transfer));
  request->node = node;
  request->deadline = deadline;
  request->retries_left = retriable ? std::max(options_.sdo_retries, 0) : 0;
  std::unique_lock lock(mu_);
  if (stopping_) {
    return absl::FailedPreconditionError(
        absl::StrCat(request->context(), ": canopen master ", bus_name_, " stopped"));
  }
  if (fault_ != BusFault::kNone) {
    return absl::UnavailableError(absl::StrCat(request->context(), ": canopen bus ", bus_name_,
                                               " is ",
                                               fault_ == BusFault::kBusOff ? "bus-off" : "down"));
  }
  Node& n = nodes_[node];
  n.sdo.push_back(request);
  counters_.sdo_queued_max =
      std::max<uint64_t>(counters_.sdo_queued_max, static_cast<uint64_t>(n.sdo.size() - 1));
  PumpSdoLocked(n, clock_.Now());
  if (request->done.load(std::memory_order_relaxed) == 0) {
    TimePoint next = request->started ? std::min(request->frame_deadline, deadline) : deadline;
    if (!request->started && WaitsForLateAnswersLocked(n, clock_.Now())) {
      next = std::min(next, n.late_until);
    }
    if (next < planned_wake_) {
      planned_wake_ = next;
      WakeReceiver();  // lock order mu_ → channel_mu_
    }
  }
  lock.unlock();
  // Completion (CompleteSdoLocked, ServiceSdoLocked, Stop) removes the request from the queue and
  // then stores `done` after the result: nothing touches it afterwards (decision 1321).
  request->done.wait(0, std::memory_order_acquire);
  return std::move(request->result);
}

void CanopenMaster::PumpSdoLocked(Node& n, TimePoint now) {
  while (!n.sdo.empty()) {
    SdoRequest& r = *n.sdo.front();
    if (r.started) return;
    if (now >= r.deadline) {
      ++counters_.sdo_timeouts;
      CompleteSdoLocked(n, AnnotateStatus(absl::DeadlineExceededError(
                                              "the caller's deadline passed before the transfer"),
                                          r.context()));
      continue;
    }
    if (WaitsForLateAnswersLocked(n, now)) return;  // ServiceSdoLocked starts it at late_until
    r.started = true;
    r.started_at = now;
    const transport::CanFrame first = r.transfer.Start();
    r.frame_deadline = now + options_.sdo_timeout;
    if (absl::Status s = SendFrame(first); !s.ok()) {
      CompleteSdoLocked(
          n, absl::UnavailableError(absl::StrCat(r.context(), ": send failed: ", s.message())));
      continue;
    }
    return;
  }
}

void CanopenMaster::CompleteSdoLocked(Node& n, absl::StatusOr<std::vector<uint8_t>> result) {
  std::shared_ptr<SdoRequest> r = n.sdo.front();
  n.sdo.pop_front();
  if (r->tries > 1) {
    // An earlier try's answer may still be on its way (decision 1481): for one more exchange
    // time it is recognised by the object it names.
    n.late_object = ObjectOf(r->transfer);
    n.late_until = clock_.Now() + options_.sdo_timeout;
  }
  if (result.ok()) {
    ++counters_.sdo_transfers;
    if (r->started && !n.drive.empty()) {
      wire::ObserveRoundTrip(n.family, n.drive, clock_.Now() - r->started_at);
    }
  } else {
    ++counters_.sdo_failures;
  }
  r->result = std::move(result);
  r->done.store(1, std::memory_order_release);
  r->done.notify_one();  // one caller per request
}

void CanopenMaster::ApplySdoStepLocked(Node& n, SdoStep step, TimePoint now) {
  switch (step.kind) {
    case SdoStep::Kind::kIgnored:
      ++counters_.sdo_unexpected;
      return;
    case SdoStep::Kind::kSend:
      if (absl::Status s = SendFrame(*step.frame); !s.ok()) {
        const std::string context = n.sdo.front()->context();
        CompleteSdoLocked(
            n, absl::UnavailableError(absl::StrCat(context, ": send failed: ", s.message())));
        break;
      }
      n.sdo.front()->frame_deadline = now + options_.sdo_timeout;
      return;
    case SdoStep::Kind::kDone:
      CompleteSdoLocked(n, std::move(step.data));
      break;
    case SdoStep::Kind::kFailed:
      if (step.frame) {
        ++counters_.sdo_aborts_sent;
        SendFrame(*step.frame).IgnoreError();  // the transfer is over either way
      } else {
        ++counters_.sdo_aborts_received;
      }
      CompleteSdoLocked(n, std::move(step.status));
      break;
  }
  PumpSdoLocked(n, now);
}

void CanopenMaster::HandleSdoResponseLocked(uint8_t node, const transport::CanFrame& frame,
                                            TimePoint now) {
  auto it = nodes_.find(node);
  if (it != nodes_.end() && IsStaleSdoAnswerLocked(it->second, frame)) {
    ++counters_.sdo_stale_responses;
    return;
  }
  if (it == nodes_.end() || it->second.sdo.empty() || !it->second.sdo.front()->started) {
    // Late (after its time-out), another client's, or a node answering nobody (decision 1112).
    ++counters_.sdo_unexpected;
    return;
  }
  Node& n = it->second;
  SdoStep step = n.sdo.front()->transfer.OnFrame(frame);
  if (step.kind == SdoStep::Kind::kFailed) {
    log::Debug("canopen_sdo_failed",
               log::Fields()
                   .Add("bus", bus_name_)
                   .Add("error", "\"" + std::string(step.status.message()) + "\""));
  }
  ApplySdoStepLocked(n, std::move(step), now);
}

TimePoint CanopenMaster::ServiceSdoLocked(Node& n, TimePoint now, TimePoint next) {
  // Waiting transfers whose caller gave up leave the queue without touching the bus.
  for (auto it = n.sdo.begin(); it != n.sdo.end();) {
    SdoRequest& r = **it;
    if (r.started || now < r.deadline) {
      if (!r.started) next = std::min(next, r.deadline);
      ++it;
      continue;
    }
    const size_t ahead = static_cast<size_t>(it - n.sdo.begin());
    ++counters_.sdo_timeouts;
    ++counters_.sdo_failures;
    r.result = absl::DeadlineExceededError(
        absl::StrCat(r.context(), ": the caller's deadline passed while waiting behind ", ahead,
                     " transfer(s) of the node (one SDO channel per node, decision 1112)"));
    std::shared_ptr<SdoRequest> keep = *it;  // the caller's wake-up below outlives the erase
    it = n.sdo.erase(it);
    keep->done.store(1, std::memory_order_release);
    keep->done.notify_one();
  }
  if (!n.sdo.empty() && !n.sdo.front()->started) {
    PumpSdoLocked(n, now);  // the front may have waited for late answers (decision 1481)
    if (WaitsForLateAnswersLocked(n, now)) next = std::min(next, n.late_until);
  }
  if (n.sdo.empty() || !n.sdo.front()->started) return next;
  SdoRequest& r = *n.sdo.front();
  const bool caller = now >= r.deadline;
  if (!caller && now < r.frame_deadline) return std::min({next, r.deadline, r.frame_deadline});
  // CiA 301 §7.2.4.3.17: end the transfer with abort 0504 0000h so the server stops waiting.
  SdoStep step = caller ? r.transfer.Cancel(SdoAbortCode::kTimeout) : r.transfer.Timeout();
  ++counters_.sdo_timeouts;
  ++counters_.sdo_aborts_sent;
  if (step.frame) SendFrame(*step.frame).IgnoreError();
  if (!caller && r.retries_left > 0) {
    RetrySdoLocked(n, now);
  } else {
    std::string detail = caller
                             ? "the caller's deadline passed during the transfer"
                             : absl::StrCat("no response within ", Ms(options_.sdo_timeout), " ms");
    if (r.tries > 1) absl::StrAppend(&detail, " (", r.tries, " tries)");
    // SdoAbortStatus maps 0504 0000h to DeadlineExceeded and keeps the code (decision 1104).
    CompleteSdoLocked(n,
                      SdoAbortStatus(SdoAbortCode::kTimeout,
                                     absl::StrCat(r.context(), ", ", detail, ": client aborted")));
  }
  PumpSdoLocked(n, now);
  if (!n.sdo.empty() && n.sdo.front()->started) {
    next = std::min({next, n.sdo.front()->deadline, n.sdo.front()->frame_deadline});
  } else if (WaitsForLateAnswersLocked(n, now)) {
    next = std::min(next, n.late_until);
  }
  return next;
}

void CanopenMaster::RetrySdoLocked(Node& n, TimePoint now) {
  // The timed-out try was just aborted (0504 0000h), so a server in the middle of a segmented
  // transfer is idle again; the retry is a new transfer of the same object from its initiate
  // with toggle 0 (CiA 301 §7.2.4.3.17; decision 1481).
  SdoRequest& r = *n.sdo.front();
  --r.retries_left;
  ++r.tries;
  ++counters_.sdo_retries;
  log::Debug("canopen_sdo_retry", log::Fields()
                                      .Add("bus", bus_name_)
                                      .Add("transfer", "\"" + r.context() + "\"")
                                      .Add("try", r.tries));
  r.frame_deadline = now + options_.sdo_timeout;
  if (absl::Status s = SendFrame(r.transfer.Start()); !s.ok()) {
    CompleteSdoLocked(
        n, absl::UnavailableError(absl::StrCat(r.context(), ": send failed: ", s.message())));
  }
}

bool CanopenMaster::WaitsForLateAnswersLocked(const Node& n, TimePoint now) const {
  return !n.sdo.empty() && !n.sdo.front()->started && n.late_object && now < n.late_until &&
         ObjectOf(n.sdo.front()->transfer) == *n.late_object;
}

bool CanopenMaster::IsStaleSdoAnswerLocked(const Node& n, const transport::CanFrame& frame) const {
  // Decision 1105 fails a transfer whose answer names another object (0604 0043h). On a bus
  // where frames get lost, retried or duplicated, such an answer is most likely one to an
  // earlier transfer that arrived late: the running transfer keeps waiting for its own (and is
  // retried if that never comes), so a stray frame costs neither transfer (decision 1481).
  if (options_.sdo_retries <= 0 || n.sdo.empty() || !n.sdo.front()->started) return false;
  const SdoClientTransfer& t = n.sdo.front()->transfer;
  if (!t.awaiting_initiate() || frame.dlc != kSdoFrameSize || frame.extended || frame.rtr ||
      frame.error) {
    return false;
  }
  absl::StatusOr<SdoFrame> f = DecodeSdo(frame.payload(), SdoDirection::kResponse);
  if (!f.ok() ||
      (f->command != SdoCommand::kInitiateUpload && f->command != SdoCommand::kInitiateDownload &&
       f->command != SdoCommand::kAbort)) {
    return false;
  }
  return std::make_pair(f->index, f->sub) != ObjectOf(t);
}

void CanopenMaster::FailAllSdoLocked(const absl::Status& status) {
  for (auto& [id, n] : nodes_) {
    while (!n.sdo.empty()) {
      CompleteSdoLocked(n, AnnotateStatus(status, n.sdo.front()->context()));
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Public SDO access.

absl::StatusOr<std::vector<uint8_t>> CanopenMaster::Upload(uint8_t node, uint16_t index,
                                                           uint8_t sub, TimePoint deadline) {
  absl::StatusOr<SdoChannel> channel = DefaultSdoChannel(node);
  if (!channel.ok()) return channel.status();
  // An upload changes nothing on the node: always retriable (decision 1481).
  return Transfer(node, SdoClientTransfer::Upload(*channel, index, sub, options_.sdo_max_size),
                  deadline, true);
}

absl::Status CanopenMaster::Download(uint8_t node, uint16_t index, uint8_t sub,
                                     std::span<const uint8_t> data, TimePoint deadline,
                                     SdoRetry retry) {
  absl::StatusOr<SdoChannel> channel = DefaultSdoChannel(node);
  if (!channel.ok()) return channel.status();
  return Transfer(node,
                  SdoClientTransfer::Download(*channel, index, sub,
                                              std::vector<uint8_t>(data.begin(), data.end())),
                  deadline, retry == SdoRetry::kIdempotent)
      .status();
}

absl::StatusOr<uint64_t> CanopenMaster::ReadUnsigned(uint8_t node, uint16_t index, uint8_t sub,
                                                     size_t bytes, const char* type,
                                                     TimePoint deadline) {
  absl::StatusOr<std::vector<uint8_t>> data = Upload(node, index, sub, deadline);
  if (!data.ok()) return data.status();
  const std::string what = absl::StrFormat("sdo upload 0x%04X:%02X node %d", index, sub, node);
  if (data->size() < bytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": ", data->size(), " byte(s), ", type, " needs ", bytes));
  }
  // An unsized expedited answer carries 4 bytes (decision 1102); zeros beyond the width are
  // padding, anything else means the object is wider than the caller thinks (decision 1112).
  for (size_t i = bytes; i < data->size(); ++i) {
    if ((*data)[i] != 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          what, ": ", data->size(), " bytes with non-zero data beyond the ", bytes, " of ", type));
    }
  }
  uint64_t value = 0;
  for (size_t i = 0; i < bytes; ++i) value |= static_cast<uint64_t>((*data)[i]) << (8 * i);
  return value;
}

absl::StatusOr<uint8_t> CanopenMaster::ReadU8(uint8_t node, uint16_t index, uint8_t sub,
                                              TimePoint deadline) {
  auto v = ReadUnsigned(node, index, sub, 1, "u8", deadline);
  if (!v.ok()) return v.status();
  return static_cast<uint8_t>(*v);
}

absl::StatusOr<uint16_t> CanopenMaster::ReadU16(uint8_t node, uint16_t index, uint8_t sub,
                                                TimePoint deadline) {
  auto v = ReadUnsigned(node, index, sub, 2, "u16", deadline);
  if (!v.ok()) return v.status();
  return static_cast<uint16_t>(*v);
}

absl::StatusOr<uint32_t> CanopenMaster::ReadU32(uint8_t node, uint16_t index, uint8_t sub,
                                                TimePoint deadline) {
  auto v = ReadUnsigned(node, index, sub, 4, "u32", deadline);
  if (!v.ok()) return v.status();
  return static_cast<uint32_t>(*v);
}

absl::StatusOr<int32_t> CanopenMaster::ReadI32(uint8_t node, uint16_t index, uint8_t sub,
                                               TimePoint deadline) {
  auto v = ReadUnsigned(node, index, sub, 4, "i32", deadline);
  if (!v.ok()) return v.status();
  return static_cast<int32_t>(static_cast<uint32_t>(*v));
}

absl::Status CanopenMaster::WriteU8(uint8_t node, uint16_t index, uint8_t sub, uint8_t value,
                                    TimePoint deadline, SdoRetry retry) {
  return Download(node, index, sub, LittleEndian(value, 1), deadline, retry);
}

absl::Status CanopenMaster::WriteU16(uint8_t node, uint16_t index, uint8_t sub, uint16_t value,
                                     TimePoint deadline, SdoRetry retry) {
  return Download(node, index, sub, LittleEndian(value, 2), deadline, retry);
}

absl::Status CanopenMaster::WriteU32(uint8_t node, uint16_t index, uint8_t sub, uint32_t value,
                                     TimePoint deadline, SdoRetry retry) {
  return Download(node, index, sub, LittleEndian(value, 4), deadline, retry);
}

absl::Status CanopenMaster::WriteI32(uint8_t node, uint16_t index, uint8_t sub, int32_t value,
                                     TimePoint deadline, SdoRetry retry) {
  return Download(node, index, sub, LittleEndian(static_cast<uint32_t>(value), 4), deadline, retry);
}

}  // namespace drivegw::canopen
