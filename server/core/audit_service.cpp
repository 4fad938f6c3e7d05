// AuditServiceCore: filters and paging on storage::AuditLog, the watch loop, export, verify.
#include "server/core/audit_service.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <string>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/status.h"
#include "server/core/audit.h"
#include "server/core/errors.h"

namespace drivegw::server {
namespace {

using std::chrono::system_clock;

constexpr int kExportBatch = 500;
// The watch loop also wakes this often for appends by other processes and for cancellation.
constexpr auto kWatchPoll = std::chrono::milliseconds(250);

absl::Status ParseTime(const char* field, const std::string& text,
                       std::optional<system_clock::time_point>& out) {
  if (text.empty()) return absl::OkStatus();
  auto t = storage::ParseTimestamp(text);
  if (!t.ok()) return FieldError(field, std::string(t.status().message()));
  out = *t;
  return absl::OkStatus();
}

void SetText(const std::string& value, std::optional<std::string>& out) {
  if (!value.empty()) out = value;
}

// The filters every read shares; InvalidArgument naming the field.
template <typename Req>
absl::StatusOr<storage::AuditQuery> TimeFilters(const Req& r) {
  storage::AuditQuery q;
  DGW_RETURN_IF_ERROR(ParseTime("start_time", r.start_time(), q.since));
  DGW_RETURN_IF_ERROR(ParseTime("end_time", r.end_time(), q.until));
  if (q.since && q.until && *q.until <= *q.since) {
    return FieldError("end_time", absl::StrCat("'", r.end_time(), "' is not after start_time '",
                                               r.start_time(), "'"));
  }
  SetText(r.drive(), q.drive);
  SetText(r.principal(), q.principal);
  SetText(r.action(), q.action);
  return q;
}

}  // namespace

v1::AuditEvent ToProto(const storage::AuditRecord& r) {
  v1::AuditEvent e;
  e.set_id(r.id);
  e.set_sequence(r.seq);
  e.set_time(storage::FormatTimestamp(r.time));
  e.set_principal(r.principal);
  e.set_role(r.role);
  e.set_source_address(r.source_address);
  e.set_drive(r.drive);
  e.set_action(r.action);
  e.set_request_json(r.request_json);
  e.set_result_code(r.result_code);
  e.set_result_message(r.result_message);
  e.set_before_json(r.before_json);
  e.set_after_json(r.after_json);
  e.set_prev_hash(r.prev_hash);
  e.set_hash(r.hash);
  return e;
}

absl::StatusOr<v1::ListAuditEventsResponse> AuditServiceCore::ListAuditEvents(
    const v1::ListAuditEventsRequest& r, const CallContext&) {
  DGW_ASSIGN_OR_RETURN(storage::AuditQuery q, TimeFilters(r));
  if (r.page_size() < 0 || r.page_size() > storage::AuditQuery::kMaxLimit) {
    return FieldError("page_size", absl::StrCat(r.page_size(), " is outside 0..",
                                                storage::AuditQuery::kMaxLimit));
  }
  q.limit = r.page_size();
  if (!r.page_token().empty()) {
    int64_t before = 0;
    if (!absl::SimpleAtoi(r.page_token(), &before) || before < 1) {
      return FieldError("page_token", absl::StrCat("'", r.page_token(),
                                                   "' is not a token this service handed out"));
    }
    q.before_id = before;
  }
  DGW_ASSIGN_OR_RETURN(std::vector<storage::AuditRecord> rows, log_.Query(q));
  v1::ListAuditEventsResponse resp;
  for (const auto& row : rows) *resp.add_events() = ToProto(row);
  if (!rows.empty() && static_cast<int>(rows.size()) == (q.limit == 0 ? 100 : q.limit)) {
    // A token only when an older match exists, so the last page says so itself.
    storage::AuditQuery more = q;
    more.before_id = rows.back().id;
    more.limit = 1;
    DGW_ASSIGN_OR_RETURN(std::vector<storage::AuditRecord> next, log_.Query(more));
    if (!next.empty()) resp.set_next_page_token(absl::StrCat(rows.back().id));
  }
  return resp;
}

absl::Status AuditServiceCore::WatchAuditEvents(
    const v1::WatchAuditEventsRequest& r, const CallContext&,
    const std::function<bool(const v1::AuditEvent&)>& sink,
    const std::function<bool()>& cancelled) {
  storage::AuditQuery filter;
  SetText(r.drive(), filter.drive);
  SetText(r.principal(), filter.principal);
  SetText(r.action(), filter.action);
  filter.ascending = true;
  filter.limit = storage::AuditQuery::kMaxLimit;
  DGW_ASSIGN_OR_RETURN(int64_t seen, log_.LastId());
  while (!shutting_down_.load() && !cancelled()) {
    log_.WaitForAppend(seen, std::chrono::steady_clock::now() + kWatchPoll);
    if (shutting_down_.load() || cancelled()) break;
    // Everything up to `upto` is handled in this round, matching or not, so the next wait
    // sleeps until something newer exists (no spinning on filtered-out rows).
    DGW_ASSIGN_OR_RETURN(const int64_t upto, log_.LastId());
    while (seen < upto) {
      storage::AuditQuery q = filter;
      q.after_id = seen;
      q.before_id = upto + 1;
      DGW_ASSIGN_OR_RETURN(std::vector<storage::AuditRecord> rows, log_.Query(q));
      for (const auto& row : rows) {
        if (!sink(ToProto(row))) return absl::OkStatus();
      }
      if (static_cast<int>(rows.size()) < q.limit) break;
      seen = rows.back().id;
    }
    seen = std::max(seen, upto);
  }
  return absl::OkStatus();
}

absl::Status AuditServiceCore::ExportAuditEvents(
    const v1::ExportAuditEventsRequest& r, const CallContext& c,
    const std::function<bool(const v1::AuditEvent&)>& sink,
    const std::function<bool()>& cancelled) {
  DGW_ASSIGN_OR_RETURN(storage::AuditQuery q, TimeFilters(r));
  q.ascending = true;
  q.limit = kExportBatch;
  DGW_ASSIGN_OR_RETURN(const int64_t upto, log_.LastId());
  q.before_id = upto + 1;
  int64_t exported = 0;
  absl::Status result = absl::OkStatus();
  int64_t cursor = 0;
  while (cursor < upto) {
    if (cancelled() || shutting_down_.load()) {
      result = absl::CancelledError(absl::StrCat("export cancelled after ", exported, " entries"));
      break;
    }
    q.after_id = cursor;
    auto rows = log_.Query(q);
    if (!rows.ok()) {
      result = rows.status();
      break;
    }
    bool stop = false;
    for (const auto& row : *rows) {
      if (!sink(ToProto(row))) {
        stop = true;
        break;
      }
      ++exported;
    }
    if (stop) {
      result = absl::CancelledError(absl::StrCat("export cancelled after ", exported, " entries"));
      break;
    }
    if (static_cast<int>(rows->size()) < q.limit) break;
    cursor = rows->back().id;
  }
  WriteAudit(&log_, c,
             AuditWrite{"", "audit.export", ToAuditJson(r), result, "", "",
                        result.ok() ? absl::StrCat("exported ", exported, " entries") : ""});
  return result;
}

absl::StatusOr<v1::VerifyAuditLogResponse> AuditServiceCore::VerifyAuditLog(
    const v1::VerifyAuditLogRequest& r, const CallContext& c) {
  auto report = log_.Verify();
  if (!report.ok()) {
    WriteAudit(&log_, c, "", "audit.verify", ToAuditJson(r), report.status());
    return report.status();
  }
  v1::VerifyAuditLogResponse resp;
  resp.set_ok(report->ok);
  resp.set_verified_entries(report->verified_entries);
  resp.set_first_sequence(report->first_seq);
  resp.set_last_sequence(report->last_seq);
  resp.set_head_hash(report->head_hash);
  resp.set_legacy_entries(report->legacy_entries);
  resp.set_anchor(report->anchor);
  absl::Status outcome = absl::OkStatus();
  if (report->broken) {
    const storage::AuditBrokenLink& b = *report->broken;
    v1::AuditBrokenLink* link = resp.mutable_first_broken_link();
    link->set_sequence(b.seq);
    link->set_field(b.field);
    link->set_expected(b.expected);
    link->set_actual(b.actual);
    link->set_message(b.message);
    // The call worked; the entry's result says what it found (DATA_LOSS: evidence changed).
    outcome = absl::DataLossError(
        absl::StrCat("audit chain broken at seq ", b.seq, " (", b.field, "): ", b.message));
  }
  WriteAudit(&log_, c, "", "audit.verify", ToAuditJson(r), outcome);
  return resp;
}

}  // namespace drivegw::server
